"""BDD backend: LTLf to DFA by formula progression, in Python over BDDs (``dd``).

No binary needed. The formula is put in negation normal form and *unfolded* one step: at
each position it is equivalent to a propositional formula over the current letter and
*obligations* on the next position, ``X psi`` (strong: there is a next position and
``psi`` holds there) or ``WX psi`` (weak: if there is a next position, ``psi`` holds
there)::

    l U r  =  r | (l & X(l U r))        l R r  =  r & (l | WX(l R r))
    F p = true U p     G p = false R p     last = WX false

A state is a BDD over the obligation variables (a boolean combination of what is owed to
the next position), so equal states are equal nodes. From state ``S``, substituting every
obligation by its unfolding gives one BDD ``N`` over fluents and obligations. With the
fluents above the obligations in the variable order, the top of ``N`` *is* the state's
guard diagram: walking down through fluent nodes splits the letters into sets, and the
first non-fluent node reached is the successor state. So successors are found per letter
*set*, never letter by letter. A state accepts (the trace may end there) when ``S`` holds
with every strong obligation false and every weak one true.

The initial state is the empty trace; whether it accepts follows the MONA encoding of
ltlf2dfa (see :func:`empty_trace_value`), so that both backends give the same automaton.
The result is minimised and numbered by :func:`noisybolt.logic._diagram.canonicalise`.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from noisybolt.errors import CompilationError
from noisybolt.logic._diagram import GuardDiagram, RawAutomaton, order_rank
from noisybolt.logic.syntax import atoms_in_order

if TYPE_CHECKING:
    from ltlf2dfa.base import Formula

__all__ = ["bdd_backend_version", "compile_progression", "empty_trace_value", "to_nnf"]

#: Bumped when the construction changes (part of the cache key).
ALGORITHM_VERSION = "1"

# Formulas in negation normal form, as hashable tuples:
#   ("true",) ("false",) ("lit", name, positive) ("and", children) ("or", children)
#   ("next", f) ("wnext", f) ("until", left, right) ("release", left, right)
Node = tuple[Any, ...]
TRUE: Node = ("true",)
FALSE: Node = ("false",)


def _bdd_module() -> Any:
    try:
        import dd.cudd as module
    except ImportError:  # pragma: no cover - dd without its CUDD extension
        import dd.autoref as module
    return module


def bdd_backend_version() -> str:
    """Version string of this backend (its algorithm and the BDD library under it)."""
    import dd

    module = _bdd_module()
    return f"progression-{ALGORITHM_VERSION} dd-{dd.__version__} {module.__name__}"


def _join(kind: str, children: Sequence[Node]) -> Node:
    """n-ary and/or with units, absorbing constants and duplicates removed."""
    unit, zero = (TRUE, FALSE) if kind == "and" else (FALSE, TRUE)
    flat: list[Node] = []
    for child in children:
        parts = child[1] if child[0] == kind else (child,)
        for part in parts:
            if part == zero:
                return zero
            if part != unit and part not in flat:
                flat.append(part)
    if not flat:
        return unit
    return flat[0] if len(flat) == 1 else (kind, tuple(flat))


def to_nnf(parsed: Formula, negate: bool = False) -> Node:
    """ltlf2dfa's syntax tree in negation normal form (``negate``: of its negation).

    n-ary operators read as ltlf2dfa reads them: ``U`` and ``R`` nest to the right,
    ``->`` folds to the left, ``<->`` means "all operands have the same value".
    """
    from ltlf2dfa import ltlf

    f = parsed
    if isinstance(f, ltlf.LTLfTrue):
        return FALSE if negate else TRUE
    if isinstance(f, ltlf.LTLfFalse):
        return TRUE if negate else FALSE
    if isinstance(f, ltlf.LTLfAtomic):
        return ("lit", str(f.s), not negate)
    if isinstance(f, ltlf.LTLfNot):
        return to_nnf(f.f, not negate)
    if isinstance(f, ltlf.LTLfAnd | ltlf.LTLfOr):
        is_and = isinstance(f, ltlf.LTLfAnd) != negate
        return _join("and" if is_and else "or", [to_nnf(g, negate) for g in f.formulas])
    if isinstance(f, ltlf.LTLfImplies):
        positive, negative = to_nnf(f.formulas[0]), to_nnf(f.formulas[0], True)
        for g in f.formulas[1:]:
            positive, negative = (
                _join("or", [negative, to_nnf(g)]),
                _join("and", [positive, to_nnf(g, True)]),
            )
        return negative if negate else positive
    if isinstance(f, ltlf.LTLfEquivalence):
        all_true = _join("and", [to_nnf(g) for g in f.formulas])
        all_false = _join("and", [to_nnf(g, True) for g in f.formulas])
        if negate:
            some_false = _join("or", [to_nnf(g, True) for g in f.formulas])
            some_true = _join("or", [to_nnf(g) for g in f.formulas])
            return _join("and", [some_false, some_true])
        return _join("or", [all_true, all_false])
    if isinstance(f, ltlf.LTLfNext | ltlf.LTLfWeakNext):
        strong = isinstance(f, ltlf.LTLfNext) != negate
        return ("next" if strong else "wnext", to_nnf(f.f, negate))
    if isinstance(f, ltlf.LTLfUntil | ltlf.LTLfRelease):
        until = isinstance(f, ltlf.LTLfUntil) != negate
        result = to_nnf(f.formulas[-1], negate)
        for g in reversed(f.formulas[:-1]):
            result = ("until" if until else "release", to_nnf(g, negate), result)
        return result
    if isinstance(f, ltlf.LTLfEventually):  # F p = true U p
        return ("release", FALSE, to_nnf(f.f, True)) if negate else ("until", TRUE, to_nnf(f.f))
    if isinstance(f, ltlf.LTLfAlways):  # G p = false R p
        return ("until", TRUE, to_nnf(f.f, True)) if negate else ("release", FALSE, to_nnf(f.f))
    if isinstance(f, ltlf.LTLfLast):  # last = WX false; !last = X true
        return ("next", TRUE) if negate else ("wnext", FALSE)
    raise CompilationError(
        f"the BDD backend does not know the operator of {f} ({type(f).__name__})",
        formula=str(parsed),
    )


def empty_trace_value(parsed: Formula) -> bool:
    """Whether ltlf2dfa's MONA encoding of ``parsed`` holds on the empty trace.

    LTLf has no empty trace; MONA's automaton still has a state for it, and whether it
    accepts comes out of how ltlf2dfa encodes each operator, evaluated with no positions:
    an atom ``0 in A`` is false, every ``ex1`` is false and every ``all1`` true, and
    ``0 = max($)`` holds (MONA takes the maximum of the empty set to be 0). So ``X``, ``U``
    and ``F`` are false, ``WX``, ``last``, ``R`` and ``G`` true, ``!`` negates, and ``->``
    and ``<->`` are first rewritten into negation normal form by ltlf2dfa (which is why
    ``!last`` is false but ``last -> a`` is true). Only the initial state's acceptance
    depends on this; it is checked against MONA in the tests.
    """
    from ltlf2dfa import ltlf

    f = parsed
    if isinstance(f, ltlf.LTLfImplies | ltlf.LTLfEquivalence):
        return empty_trace_value(f.to_nnf())
    if isinstance(f, ltlf.LTLfTrue):
        return True
    if isinstance(f, ltlf.LTLfFalse | ltlf.LTLfAtomic):
        return False
    if isinstance(f, ltlf.LTLfNot):
        return not empty_trace_value(f.f)
    if isinstance(f, ltlf.LTLfAnd):
        return all(empty_trace_value(g) for g in f.formulas)
    if isinstance(f, ltlf.LTLfOr):
        return any(empty_trace_value(g) for g in f.formulas)
    if isinstance(f, ltlf.LTLfNext | ltlf.LTLfUntil | ltlf.LTLfEventually):
        return False
    if isinstance(f, ltlf.LTLfWeakNext | ltlf.LTLfLast | ltlf.LTLfRelease | ltlf.LTLfAlways):
        return True
    raise CompilationError(
        f"no empty-trace value for {f} ({type(f).__name__})", formula=str(parsed)
    )


class _Unfolder:
    """Unfoldings of NNF formulas into BDDs over fluent and obligation variables."""

    def __init__(self, bdd: Any, fluent_var: dict[str, str]) -> None:
        self.bdd = bdd
        self.fluent_var = fluent_var
        self.obligations: dict[tuple[str, Node], str] = {}  # (kind, formula) -> variable
        self._memo: dict[Node, Any] = {}

    def obligation(self, kind: str, f: Node) -> Any:
        if kind == "next" and f == FALSE:
            return self.bdd.false
        if kind == "wnext" and f == TRUE:
            return self.bdd.true
        name = self.obligations.get((kind, f))
        if name is None:
            name = f"o{len(self.obligations)}"
            self.bdd.declare(name)  # below every fluent: declared later
            self.obligations[kind, f] = name
        return self.bdd.var(name)

    def unfold(self, f: Node) -> Any:
        found = self._memo.get(f)
        if found is not None:
            return found
        bdd, op = self.bdd, f[0]
        if op == "true":
            result = bdd.true
        elif op == "false":
            result = bdd.false
        elif op == "lit":
            result = bdd.var(self.fluent_var[f[1]])
            if not f[2]:
                result = ~result
        elif op in ("and", "or"):
            result = bdd.true if op == "and" else bdd.false
            for child in f[1]:
                result = result & self.unfold(child) if op == "and" else result | self.unfold(child)
        elif op in ("next", "wnext"):
            result = self.obligation(op, f[1])
        elif op == "until":
            result = self.unfold(f[2]) | (self.unfold(f[1]) & self.obligation("next", f))
        elif op == "release":
            result = self.unfold(f[2]) & (self.unfold(f[1]) | self.obligation("wnext", f))
        else:  # pragma: no cover - to_nnf produces nothing else
            raise ValueError(f"unknown node {f!r}")
        self._memo[f] = result
        return result


class _Explorer:
    """Breadth-first exploration of the progression automaton, one state at a time.

    A class rather than nested functions: a recursive closure would put the BDD manager
    in a reference cycle, and when the garbage collector breaks such a cycle it may free
    CUDD's manager before the nodes that still point into it.
    """

    def __init__(self, parsed: Formula, vocabulary: Sequence[str]) -> None:
        self.bdd = _bdd_module().BDD()
        self.bdd.configure(reordering=False)  # the walk relies on fluents staying on top
        index = {name: i for i, name in enumerate(vocabulary)}
        order = atoms_in_order(parsed)
        self.rank = order_rank([index[name] for name in order], len(vocabulary))
        fluent_var = {name: f"x{index[name]}" for name in order}
        self.var_fluent = {v: index[name] for name, v in fluent_var.items()}
        for name in order:  # declared first = nearest the roots
            self.bdd.declare(fluent_var[name])
        unfolder = _Unfolder(self.bdd, fluent_var)
        self.first = unfolder.unfold(to_nnf(parsed))
        # Close the obligations under unfolding (unfolding may owe new ones).
        self.substitution: dict[str, Any] = {}
        while len(self.substitution) < len(unfolder.obligations):
            for (_, f), name in list(unfolder.obligations.items()):
                if name not in self.substitution:
                    self.substitution[name] = unfolder.unfold(f)
        self.at_end = {name: kind == "wnext" for (kind, _), name in unfolder.obligations.items()}
        self.state_of: dict[Any, int] = {}  # obligation-level BDD -> state
        self.functions: list[Any] = [None]  # state 0 is the empty trace
        self.accepting = [empty_trace_value(parsed)]
        self.code_of: dict[Any, int] = {}  # BDD node -> inner node i, or leaf s as -(s + 1)
        self.inner: tuple[list[int], list[int], list[int]] = ([], [], [])  # var, lo, hi
        self.roots: list[int] = []

    def explore(self, deadline: float, formula: str, timeout: float) -> None:
        while len(self.roots) < len(self.functions):
            if time.monotonic() > deadline:
                raise CompilationError(
                    f"the BDD backend did not finish compiling {formula!r} within {timeout:g} s "
                    f"({len(self.roots)} states so far); raise timeout= or install MONA",
                    formula=formula,
                )
            state = len(self.roots)
            if state == 0:
                step = self.first
            elif self.substitution:
                step = self.bdd.let(self.substitution, self.functions[state])
            else:  # no obligations: the state is a constant
                step = self.functions[state]
            self.roots.append(self.visit(step))

    def visit(self, u: Any) -> int:
        """Code of the diagram node of BDD node ``u`` (created on first visit)."""
        code = self.code_of.get(u)
        if code is not None:
            return code
        fluent = self.var_fluent.get(u.var) if u.var is not None else None
        if fluent is None:  # an obligation-level node: a state
            state = self.state_of.get(u)
            if state is None:
                state = len(self.functions)
                self.state_of[u] = state
                self.functions.append(u)
                ends = self.bdd.let(self.at_end, u) if self.at_end else u
                self.accepting.append(ends == self.bdd.true)
            code = -(state + 1)
        else:
            low, high = u.low, u.high
            if u.negated:  # dd's low/high are those of the uncomplemented node
                low, high = ~low, ~high
            low_code, high_code = self.visit(low), self.visit(high)
            var, lo, hi = self.inner
            code = len(var)
            var.append(fluent)
            lo.append(low_code)
            hi.append(high_code)
        self.code_of[u] = code
        return code

    def automaton(self) -> RawAutomaton:
        n_states = len(self.functions)

        def node_id(codes: list[int]) -> np.ndarray:
            array = np.asarray(codes, dtype=np.int64)
            return np.where(array < 0, -array - 1, array + n_states)

        states = np.arange(n_states, dtype=np.int64)
        var, lo, hi = self.inner
        diagram = GuardDiagram(
            var=np.concatenate(
                [np.full(n_states, -1, dtype=np.int64), np.asarray(var, dtype=np.int64)]
            ),
            lo=np.concatenate([states, node_id(lo)]),
            hi=np.concatenate([states, node_id(hi)]),
            root=node_id(self.roots),
            rank=self.rank,
        )
        return RawAutomaton(diagram=diagram, accepting=np.asarray(self.accepting), initial_state=0)

    def release(self) -> None:
        """Drops every BDD node before the manager, in that order."""
        self.code_of.clear()
        self.state_of.clear()
        self.functions.clear()
        self.substitution.clear()
        self.first = None
        self.bdd = None


def compile_progression(
    parsed: Formula,
    vocabulary: Sequence[str],
    *,
    formula: str,
    timeout: float,
) -> RawAutomaton:
    """Compiles a parsed formula by progression (see the module docstring).

    Args:
        parsed: ltlf2dfa's syntax tree.
        vocabulary: the DFA's fluents (a superset of the formula's atoms).
        formula: the source text, for messages.
        timeout: seconds the construction may take.

    Returns:
        The automaton over ``vocabulary`` (not minimal).

    Raises:
        CompilationError: the construction took longer than ``timeout``.
    """
    deadline = time.monotonic() + timeout
    explorer = _Explorer(parsed, vocabulary)
    try:
        explorer.explore(deadline, formula, timeout)
        return explorer.automaton()
    finally:
        explorer.release()
