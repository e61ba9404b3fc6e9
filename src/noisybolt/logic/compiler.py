"""``compile_ltlf``: LTLf text to a minimal DFA, through MONA or the BDD backend."""

from __future__ import annotations

import math
import os
import warnings
from collections.abc import Sequence
from typing import Literal

from noisybolt.errors import BackendFallbackWarning, CompilationError
from noisybolt.logic import cache as dfa_cache
from noisybolt.logic.dfa import DFA
from noisybolt.logic.mona import (
    MONA_INSTALL,
    compile_mona,
    find_mona,
    mona_version,
    require_mona,
)
from noisybolt.logic.progression import bdd_backend_version, compile_progression
from noisybolt.logic.syntax import normalise, parse_ltlf, resolve_vocabulary

__all__ = ["BACKENDS", "Backend", "compile_ltlf", "resolve_backend"]

Backend = Literal["auto", "mona", "bdd"]
#: The backends ``compile_ltlf`` accepts.
BACKENDS: tuple[str, ...] = ("auto", "mona", "bdd")

# Whether this process has said that "auto" compiles without MONA (said once, not per spec).
_fallback_announced = False


def resolve_backend(backend: str) -> str:
    """The backend that ``backend`` stands for here: ``"auto"`` is MONA if installed.

    Raises:
        ValueError: ``backend`` is not one of :data:`BACKENDS`.
    """
    if backend not in BACKENDS:
        raise ValueError(f"backend must be one of {list(BACKENDS)}, got {backend!r}")
    if backend == "auto":
        return "mona" if find_mona() is not None else "bdd"
    return backend


def _announce_fallback() -> None:
    """Warns, once per process, that ``"auto"`` compiles with the BDD progression."""
    global _fallback_announced
    if _fallback_announced:
        return
    _fallback_announced = True
    warnings.warn(
        "MONA is not installed (no 'mona' on PATH), so specs are compiled by the pure-Python "
        "BDD backend: the same DFAs, slower on large specs. Install MONA with "
        f"`{MONA_INSTALL}` (`make mona` in a checkout) to compile with it.",
        BackendFallbackWarning,
        stacklevel=3,
    )


def compile_ltlf(
    formula: str,
    fluents: Sequence[str] | None = None,
    *,
    backend: Backend = "auto",
    timeout: float = 30.0,
    cache: bool | str | os.PathLike[str] = True,
) -> DFA:
    """Compiles an LTLf formula into its minimal DFA over a fluent vocabulary.

    Syntax and semantics are ltlf2dfa's (see :mod:`noisybolt.logic.syntax`): ``X`` strong
    next, ``WX`` weak next, ``last``, ``U``, ``R``, ``F``, ``G``, ``!``, ``&``, ``|``,
    ``->``, ``<->``, ``true``, ``false``, over non-empty finite traces. The initial state
    stands for the empty trace, as in MONA's automaton (so it accepts for ``G(e)``);
    states are numbered breadth-first from it, and both backends give identical arrays.

    Args:
        formula: the formula text.
        fluents: the vocabulary, in mask-bit order. None: the formula's atoms, sorted.
            Fluents the formula does not mention are don't-cares.
        backend: ``"mona"`` (ltlf2dfa's encoding run by MONA), ``"bdd"`` (progression over
            BDDs in Python; no binary needed) or ``"auto"`` (MONA when installed, the
            BDD progression where MONA is not, or where it times out or fails). Where
            MONA is not installed, ``"auto"`` says so once per process
            (:class:`~noisybolt.errors.BackendFallbackWarning`).
        timeout: seconds each backend may take (under ``"auto"``, MONA and then the
            progression may each take this long).
        cache: True for the default cache directory (``$NOISYBOLT_CACHE_DIR`` or
            ``~/.cache/noisybolt/dfa``), a directory, or False for no cache.

    Returns:
        The DFA (compact when its dense table would exceed ``DENSE_TABLE_LIMIT``).

    Raises:
        SpecSyntaxError: the formula cannot be parsed (the message points at the column).
        UnknownFluentError: the formula uses a fluent outside ``fluents``.
        ValueError: a fluent name is malformed, or an argument is out of range.
        BackendUnavailableError: ``backend="mona"`` and MONA is not installed.
        CompilationError: the backend timed out or failed.

    Example:
        >>> dfa = compile_ltlf("F(a & b)", ["a", "b", "c"], cache=False)
        >>> dfa.n_states, dfa.accepts([{"a": True}, {"a": True, "b": True}])
        (2, True)
        >>> [(e.src, e.dst, e.guard) for e in dfa.edges() if e.src != e.dst]
        [(0, 1, 'a & b')]
    """
    if not isinstance(timeout, int | float) or not math.isfinite(timeout) or timeout <= 0:
        raise ValueError(f"timeout must be a positive number of seconds, got {timeout!r}")
    parsed = parse_ltlf(formula)
    vocabulary = resolve_vocabulary(formula, parsed, fluents)
    chosen = resolve_backend(backend)
    if backend == "auto" and chosen == "bdd":
        _announce_fallback()
    # Under "auto" MONA goes first and the BDD progression takes over if MONA times out
    # or fails: MONA's time grows steeply on long chains of X (20 nested conjuncts of
    # G(a -> X^k b): past 60 s) that the progression compiles in about a second.
    order = ["mona", "bdd"] if backend == "auto" and chosen == "mona" else [chosen]
    key = normalise(parsed)
    directory = dfa_cache.cache_directory(cache)
    versions = {
        name: mona_version(require_mona()) if name == "mona" else bdd_backend_version()
        for name in order
    }
    if directory is not None:
        for name in order:
            found = dfa_cache.load(
                directory,
                formula=key,
                fluents=vocabulary,
                backend=name,
                backend_version=versions[name],
                source=formula,
            )
            if found is not None:
                return found
    failures: list[CompilationError] = []
    for name in order:
        try:
            if name == "mona":
                raw = compile_mona(
                    parsed, vocabulary, formula=formula, timeout=timeout, mona=require_mona()
                )
            else:
                raw = compile_progression(parsed, vocabulary, formula=formula, timeout=timeout)
        except CompilationError as error:
            failures.append(error)
            continue
        dfa = DFA.from_diagram(
            vocabulary,
            initial_state=raw.initial_state,
            accepting=raw.accepting,
            diagram=raw.diagram,
            formula=formula,
            minimise=True,
        )
        if directory is not None:
            dfa_cache.store(
                directory, dfa, formula=key, backend=name, backend_version=versions[name]
            )
        return dfa
    if len(failures) == 1:
        raise failures[0]
    raise CompilationError(
        f"neither backend compiled {formula!r}: MONA: {failures[0]}; the BDD progression: "
        f"{failures[1]}",
        formula=formula,
    ) from failures[-1]
