"""Reading LTLf text: ltlf2dfa's grammar, with errors that say where and what to do.

The language is ltlf2dfa's (2.0): atoms ``[a-z][a-z0-9_]*``; ``true``, ``false``, ``last``
(case-insensitive keywords); unary ``!``/``~``, ``X`` (strong next), ``WX`` (weak next),
``F``, ``G``; binary, tightest first, ``R``, ``U``, ``&``, ``|``, ``->``, ``<->``. Chains
are n-ary: ``a U b U c`` is ``a U (b U c)`` (so is ``R``), ``a -> b -> c`` is
``(a -> b) -> c`` and ``a <-> b <-> c`` means "all three have the same value".

Pitfalls of that grammar, and what we do:

* An operator letter glued to an atom (``Xa``, ``Fa``) is a lexer error: the message says
  to write ``X a`` or ``X(a)``.
* ``end`` is *not* an end-of-trace operator: ltlf2dfa reads it as an ordinary atom. We keep
  ltlf2dfa's language (rejecting it would make some of its formulas unreadable here), but
  :func:`resolve_vocabulary` warns when a vocabulary is inferred with a fluent ``end``.
* Names that begin with a keyword (``lastly``, ``true_x``) cannot be read as atoms, so such
  fluent names are refused up front by :func:`check_fluent_names`.
"""

from __future__ import annotations

import functools
import re
import threading
import warnings
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

from noisybolt.errors import SpecSyntaxError, UnknownFluentError

if TYPE_CHECKING:
    from ltlf2dfa.base import Formula

__all__ = [
    "FLUENT_NAME",
    "atoms",
    "atoms_in_order",
    "check_fluent_names",
    "normalise",
    "parse_ltlf",
    "resolve_vocabulary",
]

#: What a fluent name must look like (ltlf2dfa's atoms).
FLUENT_NAME = re.compile(r"[a-z][a-z0-9_]*")

_OPERATOR_GLUED = re.compile(r"(WX|[XFGUR])[a-z]")
_WORD = re.compile(r"[A-Za-z][A-Za-z0-9_]*")
#: Operators of other LTL dialects that ltlf2dfa's grammar lacks, and how to write them.
_OTHER_DIALECTS = {
    "W": "W (weak until) is not in this syntax: write 'a W b' as '(a U b) | G(a)'",
    "M": "M (strong release) is not in this syntax: write 'a M b' as '(a R b) & F(a)'",
    "N": "N (weak next) is written WX here: 'WX a'",
}
_lock = threading.Lock()


@functools.lru_cache(maxsize=1)
def _parser() -> Any:
    # Imported lazily: ltlf2dfa pulls in sympy (for its own I/O, which we do not use).
    from ltlf2dfa.parser.ltlf import LTLfParser

    return LTLfParser()


def parse_ltlf(formula: str) -> Formula:
    """Parses ``formula`` with ltlf2dfa's parser.

    Returns:
        ltlf2dfa's syntax tree.

    Raises:
        TypeError: ``formula`` is not a string.
        SpecSyntaxError: the text is not a formula (the message shows it with a caret under
            the offending column), or it is nested beyond Python's recursion limit.

    Example:
        >>> str(parse_ltlf("G(a -> F b)"))
        'G((a -> F(b)))'
    """
    if not isinstance(formula, str):
        raise TypeError(f"an LTLf formula must be a string, got {type(formula).__name__}")
    from lark.exceptions import LarkError, UnexpectedInput

    try:
        with _lock:  # lark parsers keep per-parse state; share one safely between threads
            return _parser()(formula)
    except UnexpectedInput as error:
        raise _syntax_error(formula, error) from None
    except (LarkError, ValueError) as error:  # ltlf2dfa's own "Parsing error."
        raise SpecSyntaxError(
            f"cannot read LTLf formula {formula!r}: {error}", formula=formula
        ) from None
    except RecursionError:  # the parser recurses once per nested operator
        raise SpecSyntaxError(
            f"LTLf formula {formula[:40]!r}... is nested too deeply to parse (Python's "
            "recursion limit); write it with fewer nested operators",
            formula=formula,
        ) from None


def _syntax_error(formula: str, error: Any) -> SpecSyntaxError:
    position = getattr(error, "pos_in_stream", None)
    token = getattr(error, "token", None)
    if position is None or getattr(token, "type", None) == "$END":
        position = len(formula)
    position = max(0, min(int(position), len(formula)))
    line_start = formula.rfind("\n", 0, position) + 1
    line_end = formula.find("\n", position)
    line = formula[line_start : line_end if line_end >= 0 else len(formula)]
    column = position - line_start
    line_number = formula.count("\n", 0, position) + 1
    where = f"column {column + 1}" + (f" of line {line_number}" if "\n" in formula else "")
    if position >= len(formula.rstrip()):
        what = "the formula ends too early (an operand or ')' is missing)"
    else:
        what = f"unexpected {formula[position]!r}"
    hint = ""
    start = position
    while start > 0 and (formula[start - 1].isalnum() or formula[start - 1] == "_"):
        start -= 1
    word = _WORD.match(formula, start)
    name = word.group(0) if word else ""
    glued = _OPERATOR_GLUED.match(formula, position)
    plain_word = not any(c.isupper() for c in name[1:]) and "_" not in name
    if name in _OTHER_DIALECTS:
        hint = f"\nhint: {_OTHER_DIALECTS[name]}"
    elif glued and start == position and plain_word:
        op = glued.group(1)
        hint = f"\nhint: separate the operator from its operand: write '{op} x' or '{op}(x)'"
        if len(name) > 2:
            hint += f", or, for a fluent, write it lowercase: {name.lower()!r}"
    elif len(name) > 1 and any(c.isupper() for c in name):
        hint = f"\nhint: fluent names are lowercase: write {name.lower()!r}"
    elif formula[position : position + 1].isupper():
        hint = "\nhint: atoms are lowercase ([a-z][a-z0-9_]*); uppercase letters are operators"
    return SpecSyntaxError(
        f"syntax error at {where}: {what}\n  {line}\n  {' ' * column}^{hint}",
        formula=formula,
        position=position,
    )


def atoms(parsed: Formula) -> tuple[str, ...]:
    """The atoms of a parsed formula, sorted."""
    return tuple(sorted({str(name) for name in parsed.find_labels()}))


def atoms_in_order(parsed: Formula) -> tuple[str, ...]:
    """The atoms of a parsed formula in order of first occurrence.

    This is the order in which ltlf2dfa declares MONA's variables, and the variable order
    of our diagrams: it keeps fluents that occur together close, which keeps BDDs small
    (``G(a1 -> F b1) & ... & G(a10 -> F b10)`` has ~30x more nodes with all ``a``s first).
    """
    return tuple(dict.fromkeys(str(name) for name in parsed.find_labels()))


def normalise(parsed: Formula) -> str:
    """ltlf2dfa's fully parenthesised printing: equal for texts differing in spacing."""
    return str(parsed)


@functools.lru_cache(maxsize=4096)
def _is_atom(name: str) -> bool:
    from ltlf2dfa.ltlf import LTLfAtomic, LTLfFalse, LTLfTrue

    try:
        with _lock:
            parsed = _parser()(name)
    except Exception:
        return False
    return (
        isinstance(parsed, LTLfAtomic)
        and not isinstance(parsed, LTLfTrue | LTLfFalse)
        and str(parsed) == name
    )


def check_fluent_names(fluents: Sequence[str]) -> tuple[str, ...]:
    """Checks a vocabulary: names of atoms ltlf2dfa can read, no duplicates.

    Raises:
        TypeError: ``fluents`` is a single string or holds non-strings.
        ValueError: a name is malformed, reserved or repeated.
    """
    if isinstance(fluents, str):
        raise TypeError(f"fluents must be a sequence of names, not the string {fluents!r}")
    names = tuple(fluents)
    for name in names:
        if not isinstance(name, str):
            raise TypeError(f"fluent names must be strings, got {name!r}")
        if not FLUENT_NAME.fullmatch(name):
            raise ValueError(
                f"fluent name {name!r} is not allowed: names must match [a-z][a-z0-9_]* "
                "(lowercase letter first; lowercase letters, digits and '_' after), "
                "as ltlf2dfa's atoms do"
            )
        if not _is_atom(name):
            raise ValueError(
                f"fluent name {name!r} is not allowed: ltlf2dfa reads it as (or starting with) "
                "a keyword (true, false, last); rename the fluent"
            )
    duplicates = sorted({name for name in names if names.count(name) > 1})
    if duplicates:
        raise ValueError(f"duplicate fluent names {duplicates} in {list(names)}")
    return names


def resolve_vocabulary(
    formula: str, parsed: Formula, fluents: Sequence[str] | None
) -> tuple[str, ...]:
    """The vocabulary of a compiled formula.

    Args:
        formula: the source text (for messages).
        parsed: its syntax tree.
        fluents: the vocabulary asked for, or None for the formula's atoms, sorted.

    Raises:
        UnknownFluentError: the formula uses an atom outside ``fluents``.
    """
    used = atoms(parsed)
    if fluents is None:
        if "end" in used:
            warnings.warn(
                f"in {formula!r}, 'end' is read as a fluent named 'end': ltlf2dfa has no "
                "end-of-trace operator (use 'last' for the last position)",
                UserWarning,
                stacklevel=3,
            )
        return used
    vocabulary = check_fluent_names(fluents)
    unknown = tuple(name for name in used if name not in vocabulary)
    if unknown:
        raise UnknownFluentError(
            f"formula {formula!r} uses fluent(s) {list(unknown)} outside the vocabulary "
            f"{list(vocabulary)}; add them to fluents or fix the formula",
            unknown=unknown,
            known=vocabulary,
        )
    return vocabulary
