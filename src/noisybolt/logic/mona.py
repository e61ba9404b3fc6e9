"""MONA backend: ltlf2dfa's MONA encoding, run and read by us.

We use two pieces of ltlf2dfa: its parser and its translation of LTLf into a MONA (WS1S)
program (:class:`ltlf2dfa.base.MonaProgram`). We do **not** use its I/O
(``ltlf2dfa.ltlf2dfa.to_dfa``), because, as measured (see FACTS.md):

* it writes every program to one fixed file, ``automa.mona`` inside site-packages, so
  processes compiling at the same time read each other's programs and silently get the
  wrong automaton;
* it runs ``mona`` through a shell with the unquoted install path;
* when MONA is missing it prints "Could not find the value" and returns a bogus automaton
  instead of raising, and its 30 s timeout surfaces as a ``TypeError``;
* it rebuilds guards with sympy, whose simplification is exponential in the number of
  fluents (> 120 s at 8 fluents).

Instead we write the program to a private temporary file, run ``mona -xw`` with an
argument list (no shell), a timeout and a checked return code (MONA dies of SIGABRT,
without a message, on very large products), and read its ``-xw`` output, which already is
a shared multi-terminal BDD (``behaviour:`` gives each state's root node; ``bdd:`` lines are
``var lo hi`` with ``var = -1`` at leaves, whose ``lo`` is the target state), straight into
a :class:`~noisybolt.logic.dfa.GuardDiagram` with numpy.

MONA's automaton has one extra first state, before the trace: every letter leads from it
to the state of the empty trace, which is our initial state. The MONA encoding decides
whether the empty trace is accepted (``G(e)``: yes; ``F(t)``: no).
"""

from __future__ import annotations

import functools
import re
import shutil
import signal
import subprocess
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from noisybolt.errors import BackendUnavailableError, CompilationError
from noisybolt.logic._diagram import GuardDiagram, RawAutomaton, order_rank
from noisybolt.logic.syntax import atoms_in_order

if TYPE_CHECKING:
    from ltlf2dfa.base import Formula

__all__ = [
    "MONA_INSTALL",
    "compile_mona",
    "find_mona",
    "mona_program",
    "mona_version",
    "parse_mona_output",
    "require_mona",
]

#: How to get MONA on Debian/Ubuntu.
MONA_INSTALL = "sudo apt-get install mona"


def find_mona() -> str | None:
    """Path of the ``mona`` executable on ``PATH``, or None."""
    return shutil.which("mona")


def require_mona() -> str:
    """Path of the ``mona`` executable.

    Raises:
        BackendUnavailableError: MONA is not installed; the message says how to get it.
    """
    path = find_mona()
    if path is None:
        raise BackendUnavailableError(
            f"MONA is not installed (no 'mona' on PATH); install it with `{MONA_INSTALL}`, "
            "or compile with backend='bdd' (pure Python) or backend='auto'"
        )
    return path


@functools.lru_cache(maxsize=8)
def mona_version(path: str) -> str:
    """MONA's version string (e.g. ``"1.4-18"``), read from its banner."""
    try:
        banner = subprocess.run(
            [path], capture_output=True, text=True, timeout=10, check=False
        ).stdout
    except (OSError, subprocess.TimeoutExpired):
        return "unknown"
    found = re.search(r"MONA v(\S+)", banner)
    return found.group(1) if found else "unknown"


def mona_program(parsed: Formula, vocabulary: Sequence[str]) -> str:
    """ltlf2dfa's MONA program for ``parsed``.

    MONA orders its BDD variables as declared: ltlf2dfa declares them in order of first
    occurrence, which is also the order the BDD backend uses (see
    :func:`~noisybolt.logic.syntax.atoms_in_order`). We set it explicitly so that the two
    stay in step whatever ltlf2dfa does.
    """
    from ltlf2dfa.base import MonaProgram

    program = MonaProgram(parsed)
    program.vars = [name.upper() for name in atoms_in_order(parsed)]
    return str(program.mona_program())


def compile_mona(
    parsed: Formula,
    vocabulary: Sequence[str],
    *,
    formula: str,
    timeout: float,
    mona: str | None = None,
) -> RawAutomaton:
    """Compiles a parsed formula with MONA.

    Args:
        parsed: ltlf2dfa's syntax tree.
        vocabulary: the DFA's fluents (a superset of the formula's atoms).
        formula: the source text, for messages.
        timeout: seconds MONA may run.
        mona: path of the executable (default: ``mona`` on ``PATH``).

    Returns:
        The automaton as MONA built it (minimal, plus its pre-trace state).

    Raises:
        BackendUnavailableError: MONA is not installed.
        CompilationError: MONA timed out, crashed or printed something unreadable.
    """
    path = mona or require_mona()
    program = mona_program(parsed, vocabulary)
    with tempfile.TemporaryDirectory(prefix="noisybolt-mona-") as directory:
        source = Path(directory) / "formula.mona"
        source.write_text(program, encoding="utf-8")
        try:
            run = subprocess.run(
                [path, "-xw", str(source)],
                capture_output=True,
                text=True,
                timeout=timeout,
                check=False,
            )
        except subprocess.TimeoutExpired:
            raise CompilationError(
                f"MONA did not finish compiling {formula!r} within {timeout:g} s; raise "
                "timeout=, use backend='bdd' (the BDD progression, often much faster on "
                "long chains of X), or split the formula into several specs",
                formula=formula,
            ) from None
        except OSError as error:
            raise CompilationError(
                f"could not run MONA ({path}) on {formula!r}: {error}", formula=formula
            ) from None
    if run.returncode != 0:
        if run.returncode < 0:
            try:
                name = signal.Signals(-run.returncode).name
            except ValueError:
                name = f"signal {-run.returncode}"
            how = f"was killed by {name}"
            if name == "SIGABRT":
                how += " (MONA aborts this way when an automaton grows too large)"
        else:
            how = f"exited with status {run.returncode}"
        tail = (run.stderr.strip() or run.stdout.strip())[-800:]
        raise CompilationError(
            f"MONA {how} while compiling {formula!r}" + (f":\n{tail}" if tail else ""),
            formula=formula,
        )
    return parse_mona_output(run.stdout, vocabulary, formula=formula)


def parse_mona_output(text: str, vocabulary: Sequence[str], *, formula: str) -> RawAutomaton:
    """Reads ``mona -xw`` output into an automaton over ``vocabulary``.

    Raises:
        CompilationError: the output is not a well-formed MONA DFA of this shape.
    """

    def fail(why: str) -> CompilationError:
        return CompilationError(
            f"unreadable MONA output for {formula!r} ({why}):\n{text[:400]}", formula=formula
        )

    fields: dict[str, str] = {}
    node_lines: list[str] = []
    lines = iter(text.splitlines())
    for line in lines:
        if line.strip() == "MONA DFA":
            break
    else:
        raise fail("no 'MONA DFA' header")
    for line in lines:
        if line.strip() == "bdd:":
            break
        key, sep, value = line.partition(":")
        if sep:
            fields[key.strip()] = value.strip()
    else:
        raise fail("no 'bdd:' section")
    for line in lines:
        if line.strip() == "end":
            break
        node_lines.append(line)
    else:
        raise fail("no 'end' after the BDD")
    try:
        names = fields["variables"].split()
        n_states = int(fields["states"])
        initial = int(fields["initial"])
        final = np.array(fields["final"].split(), dtype=np.int64)
        behaviour = np.array(fields["behaviour"].split(), dtype=np.int64)
        nodes = np.array(" ".join(node_lines).split(), dtype=np.int64).reshape(-1, 3)
        n_nodes = int(fields["bdd nodes"])
    except (KeyError, ValueError) as error:
        raise fail(str(error)) from None
    if final.shape != (n_states,) or behaviour.shape != (n_states,) or len(nodes) != n_nodes:
        raise fail("sizes do not match the header")
    index = {name: i for i, name in enumerate(vocabulary)}
    try:
        fluent_of = np.array([index[name.lower()] for name in names] + [-1], dtype=np.int64)
    except KeyError as error:
        raise fail(f"variable {error} is not a fluent") from None

    mona_var, mona_lo, mona_hi = nodes[:, 0], nodes[:, 1], nodes[:, 2]
    leaf = mona_var == -1
    if np.any(mona_var < -1) or np.any(mona_var >= len(names)):
        raise fail("a node tests an undeclared variable")
    if np.any(mona_lo[leaf] < 0) or np.any(mona_lo[leaf] >= n_states):
        raise fail("a leaf names a state that does not exist")
    inner_lo, inner_hi = mona_lo[~leaf], mona_hi[~leaf]
    if inner_lo.size and (
        min(inner_lo.min(), inner_hi.min()) < 0 or max(inner_lo.max(), inner_hi.max()) >= n_nodes
    ):
        raise fail("a node's child does not exist")
    if np.any(behaviour < 0) or np.any(behaviour >= n_nodes):
        raise fail("a state's root does not exist")
    # Our node ids: MONA leaf -> its state; MONA inner node -> n_states + its rank.
    node_id = np.where(leaf, mona_lo, n_states + np.cumsum(~leaf) - 1)
    var = np.concatenate([np.full(n_states, -1, dtype=np.int64), fluent_of[mona_var[~leaf]]])
    states = np.arange(n_states, dtype=np.int64)
    lo = np.concatenate([states, node_id[inner_lo]])
    hi = np.concatenate([states, node_id[inner_hi]])
    rank = order_rank(fluent_of[:-1].tolist(), len(vocabulary))
    diagram = GuardDiagram(var=var, lo=lo, hi=hi, root=node_id[behaviour], rank=rank)
    node_rank = diagram.node_rank()
    inner = node_rank[n_states:]
    if np.any(node_rank[lo[n_states:]] >= inner) or np.any(node_rank[hi[n_states:]] >= inner):
        raise fail("the BDD does not follow the declared variable order")
    start = behaviour[initial] if 0 <= initial < n_states else -1
    if start < 0 or not leaf[start]:
        raise fail("the pre-trace state does not lead to a single state")
    empty_trace = int(mona_lo[start])
    others = np.arange(n_states) != initial
    if np.any(final[others] == 0) or np.any(np.abs(final) > 1):
        raise fail("unexpected acceptance values")
    return RawAutomaton(
        diagram=diagram,
        accepting=final == 1,
        initial_state=empty_trace,
    )
