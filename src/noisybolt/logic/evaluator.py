"""An LTLf evaluator on finite traces, straight from the semantics.

De Giacomo & Vardi (IJCAI 2013) define, for a non-empty trace ``pi`` of length ``n`` and a
position ``0 <= i < n``::

    pi, i |= a          iff  a is true in pi[i]
    pi, i |= X f        iff  i + 1 < n  and  pi, i + 1 |= f        (strong next)
    pi, i |= WX f       iff  i + 1 >= n  or  pi, i + 1 |= f        (weak next)
    pi, i |= last       iff  i + 1 = n
    pi, i |= f U g      iff  some j in [i, n) has pi, j |= g and every k in [i, j) has f
    pi, i |= f R g      iff  some j in [i, n) has pi, j |= f and every k in [i, j] has g,
                             or every k in [i, n) has g
    F f = true U f,  G f = false R f, and the boolean connectives as usual.

This module evaluates ltlf2dfa's syntax tree by exactly these clauses, by recursion,
sharing no code with either compiler (only the parser). It reads n-ary chains as ltlf2dfa
does: ``a U b U c`` = ``a U (b U c)`` (and ``R``), ``a -> b -> c`` = ``(a -> b) -> c``,
``a <-> b <-> c`` = all the same value. The tests hold both compilers to it.
"""

from __future__ import annotations

from collections.abc import Collection, Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from noisybolt.logic.syntax import parse_ltlf

if TYPE_CHECKING:
    from ltlf2dfa.base import Formula

__all__ = ["holds", "holds_batch"]

Letter = Mapping[str, bool] | Collection[str]


def holds(formula: str | Formula, trace: Sequence[Letter], i: int = 0) -> bool:
    """Whether ``trace`` satisfies ``formula`` at position ``i``.

    Args:
        formula: LTLf text, or ltlf2dfa's syntax tree of it.
        trace: non-empty sequence of letters; a letter is a mapping fluent -> bool (missing
            fluents are false) or the collection of the fluents that are true.
        i: position, ``0 <= i < len(trace)``.

    Raises:
        ValueError: the trace is empty or ``i`` is not a position of it.

    Example:
        >>> holds("F(a & X(!F(a)))", [{"a": True}, {"a": False}])
        True
        >>> holds("X(true)", [{"a": True}])  # strong next: there is no next position
        False
    """
    parsed = parse_ltlf(formula) if isinstance(formula, str) else formula
    if len(trace) == 0:
        raise ValueError("LTLf is evaluated on non-empty traces; the trace is empty")
    if not 0 <= i < len(trace):
        raise ValueError(f"position {i} is not in 0..{len(trace) - 1}")
    return _holds(parsed, trace, i)


def _true_in(letter: Letter, name: str) -> bool:
    if isinstance(letter, Mapping):
        return bool(letter.get(name, False))
    return name in letter


def _holds(f: Any, trace: Sequence[Letter], i: int) -> bool:
    from ltlf2dfa import ltlf

    n = len(trace)
    if isinstance(f, ltlf.LTLfTrue):
        return True
    if isinstance(f, ltlf.LTLfFalse):
        return False
    if isinstance(f, ltlf.LTLfAtomic):
        return _true_in(trace[i], str(f.s))
    if isinstance(f, ltlf.LTLfNot):
        return not _holds(f.f, trace, i)
    if isinstance(f, ltlf.LTLfAnd):
        return all(_holds(g, trace, i) for g in f.formulas)
    if isinstance(f, ltlf.LTLfOr):
        return any(_holds(g, trace, i) for g in f.formulas)
    if isinstance(f, ltlf.LTLfImplies):
        value = _holds(f.formulas[0], trace, i)
        for g in f.formulas[1:]:
            value = (not value) or _holds(g, trace, i)
        return value
    if isinstance(f, ltlf.LTLfEquivalence):
        return len({_holds(g, trace, i) for g in f.formulas}) == 1
    if isinstance(f, ltlf.LTLfNext):
        return i + 1 < n and _holds(f.f, trace, i + 1)
    if isinstance(f, ltlf.LTLfWeakNext):
        return i + 1 >= n or _holds(f.f, trace, i + 1)
    if isinstance(f, ltlf.LTLfLast):
        return i + 1 == n
    if isinstance(f, ltlf.LTLfUntil):
        left, right = f.formulas[0], _rest(f, ltlf.LTLfUntil)
        return any(
            _holds(right, trace, j) and all(_holds(left, trace, k) for k in range(i, j))
            for j in range(i, n)
        )
    if isinstance(f, ltlf.LTLfRelease):
        left, right = f.formulas[0], _rest(f, ltlf.LTLfRelease)
        released = any(
            _holds(left, trace, j) and all(_holds(right, trace, k) for k in range(i, j + 1))
            for j in range(i, n)
        )
        return released or all(_holds(right, trace, k) for k in range(i, n))
    if isinstance(f, ltlf.LTLfEventually):
        return any(_holds(f.f, trace, j) for j in range(i, n))
    if isinstance(f, ltlf.LTLfAlways):
        return all(_holds(f.f, trace, j) for j in range(i, n))
    raise TypeError(f"cannot evaluate {f!r} ({type(f).__name__})")


def _rest(f: Any, operator: type) -> Any:
    """The right operand of an n-ary right-nested chain ``f0 op f1 op ... op fk``."""
    return f.formulas[1] if len(f.formulas) == 2 else operator(f.formulas[1:])


def holds_batch(formula: str | Formula, truth: np.ndarray, fluents: Sequence[str]) -> np.ndarray:
    """:func:`holds` at position 0 for many traces of one length at once.

    The same clauses as :func:`holds`, each evaluated on a boolean vector over the traces
    (one vector per subformula and position), so exhaustive sets of short traces are
    cheap to check.

    Args:
        formula: LTLf text, or ltlf2dfa's syntax tree of it.
        truth: bool ``[n_traces, length, n_fluents]``, ``length >= 1``.
        fluents: names of the columns of ``truth``; atoms outside them are false.

    Returns:
        bool ``[n_traces]``.

    Example:
        >>> truth = np.array([[[True], [False]], [[False], [False]]])
        >>> holds_batch("F(a)", truth, ["a"])
        array([ True, False])
    """
    parsed = parse_ltlf(formula) if isinstance(formula, str) else formula
    truth = np.asarray(truth, dtype=bool)
    if truth.ndim != 3 or truth.shape[1] == 0 or truth.shape[2] != len(fluents):
        raise ValueError(
            f"truth must be [n_traces, length >= 1, {len(fluents)}], got shape {truth.shape}"
        )
    column = {name: j for j, name in enumerate(fluents)}
    return _holds_batch(parsed, truth, column, 0, {})


def _holds_batch(
    f: Any,
    truth: np.ndarray,
    column: dict[str, int],
    i: int,
    memo: dict[tuple[int, int], tuple[Any, np.ndarray]],
) -> np.ndarray:
    from ltlf2dfa import ltlf

    # Keyed by identity: the memo keeps each formula alive, so no id is reused meanwhile.
    key = (id(f), i)
    if key in memo:
        return memo[key][1]
    n_traces, n = truth.shape[:2]

    def rest(operator: type) -> Any:
        found = memo.get((id(f), -1))
        if found is None:
            found = (f, _rest(f, operator))
            memo[id(f), -1] = found
        return found[1]

    def at(g: Any, j: int) -> np.ndarray:
        return _holds_batch(g, truth, column, j, memo)

    def const(value: bool) -> np.ndarray:
        return np.full(n_traces, value)

    def every(g: Any, positions: range) -> np.ndarray:
        return np.logical_and.reduce([at(g, k) for k in positions] or [const(True)])

    def some(parts: list[np.ndarray]) -> np.ndarray:
        return np.logical_or.reduce(parts or [const(False)])

    if isinstance(f, ltlf.LTLfTrue):
        result = const(True)
    elif isinstance(f, ltlf.LTLfFalse):
        result = const(False)
    elif isinstance(f, ltlf.LTLfAtomic):
        j = column.get(str(f.s))
        result = const(False) if j is None else truth[:, i, j]
    elif isinstance(f, ltlf.LTLfNot):
        result = ~at(f.f, i)
    elif isinstance(f, ltlf.LTLfAnd):
        result = np.logical_and.reduce([at(g, i) for g in f.formulas])
    elif isinstance(f, ltlf.LTLfOr):
        result = np.logical_or.reduce([at(g, i) for g in f.formulas])
    elif isinstance(f, ltlf.LTLfImplies):
        result = at(f.formulas[0], i)
        for g in f.formulas[1:]:
            result = ~result | at(g, i)
    elif isinstance(f, ltlf.LTLfEquivalence):
        values = [at(g, i) for g in f.formulas]
        result = np.logical_and.reduce(values) | ~np.logical_or.reduce(values)
    elif isinstance(f, ltlf.LTLfNext):
        result = at(f.f, i + 1) if i + 1 < n else const(False)
    elif isinstance(f, ltlf.LTLfWeakNext):
        result = at(f.f, i + 1) if i + 1 < n else const(True)
    elif isinstance(f, ltlf.LTLfLast):
        result = const(i + 1 == n)
    elif isinstance(f, ltlf.LTLfUntil):
        left, right = f.formulas[0], rest(ltlf.LTLfUntil)
        result = some([at(right, j) & every(left, range(i, j)) for j in range(i, n)])
    elif isinstance(f, ltlf.LTLfRelease):
        left, right = f.formulas[0], rest(ltlf.LTLfRelease)
        released = some([at(left, j) & every(right, range(i, j + 1)) for j in range(i, n)])
        result = released | every(right, range(i, n))
    elif isinstance(f, ltlf.LTLfEventually):
        result = some([at(f.f, j) for j in range(i, n)])
    elif isinstance(f, ltlf.LTLfAlways):
        result = every(f.f, range(i, n))
    else:
        raise TypeError(f"cannot evaluate {f!r} ({type(f).__name__})")
    memo[key] = (f, result)
    return result
