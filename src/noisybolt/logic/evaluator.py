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

from noisybolt.logic.syntax import parse_ltlf

if TYPE_CHECKING:
    from ltlf2dfa.base import Formula

__all__ = ["holds"]

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
