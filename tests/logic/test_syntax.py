"""Bad formulas and vocabularies fail early, by type, with messages that say what to do."""

from __future__ import annotations

import warnings

import pytest

from noisybolt.errors import SpecSyntaxError, UnknownFluentError
from noisybolt.logic import compile_ltlf
from noisybolt.logic.syntax import atoms, atoms_in_order, check_fluent_names, parse_ltlf


@pytest.mark.parametrize(
    ("formula", "position", "says"),
    [
        ("F(a &)", 5, "unexpected ')'"),
        ("F(a", 3, "ends too early"),
        ("", 0, "ends too early"),
        ("a b", 2, "unexpected 'b'"),
        ("G(a) % b", 5, "unexpected '%'"),
        ("(a))", 3, "unexpected ')'"),
    ],
)
def test_syntax_errors_point_at_the_column(formula: str, position: int, says: str) -> None:
    with pytest.raises(SpecSyntaxError) as caught:
        compile_ltlf(formula, cache=False)
    error = caught.value
    assert error.position == position and error.formula == formula
    message = str(error)
    assert says in message and f"column {position + 1}" in message
    # The formula is shown with a caret under the offending column.
    shown, caret = message.splitlines()[1:3]
    assert shown == f"  {formula}" and caret == "  " + " " * position + "^"


def test_glued_operator_gets_a_hint() -> None:
    with pytest.raises(SpecSyntaxError, match=r"write 'X x' or 'X\(x\)'") as caught:
        parse_ltlf("G(Xa)")
    assert caught.value.position == 2


@pytest.mark.parametrize(
    ("formula", "hint"),
    [
        ("F(Door)", "hint: fluent names are lowercase: write 'door'"),
        ("F(Right_Edge)", "hint: fluent names are lowercase: write 'right_edge'"),
        ("G(topRow)", "hint: fluent names are lowercase: write 'toprow'"),
        ("G(a) & Q", "hint: atoms are lowercase ([a-z][a-z0-9_]*); uppercase letters are"),
        ("F(Right)", "write 'R x' or 'R(x)', or, for a fluent, write it lowercase: 'right'"),
        ("top W edge", "hint: W (weak until) is not in this syntax: write 'a W b' as '(a U b)"),
        ("a M b", "hint: M (strong release) is not in this syntax"),
        ("N a", "hint: N (weak next) is written WX here"),
    ],
)
def test_uppercase_names_and_other_dialects_get_a_hint(formula: str, hint: str) -> None:
    with pytest.raises(SpecSyntaxError) as caught:
        parse_ltlf(formula)
    assert hint in str(caught.value)


def test_multiline_formula_names_the_line() -> None:
    with pytest.raises(SpecSyntaxError, match="column 3 of line 2") as caught:
        parse_ltlf("F(a) &\nG(& b)")
    assert caught.value.position == len("F(a) &\n") + 2


def test_non_string_formula() -> None:
    with pytest.raises(TypeError, match="string"):
        compile_ltlf(42, cache=False)  # type: ignore[arg-type]


def test_unknown_fluent_lists_the_vocabulary() -> None:
    with pytest.raises(UnknownFluentError, match=r"\['a', 'c'\]") as caught:
        compile_ltlf("F(a & b) | G(d)", ["a", "c"], cache=False)
    assert caught.value.unknown == ("b", "d")
    assert caught.value.known == ("a", "c")


@pytest.mark.parametrize("name", ["A", "1a", "a-b", "_a", "a b", "", "é"])
def test_malformed_fluent_names(name: str) -> None:
    with pytest.raises(ValueError, match=r"\[a-z\]\[a-z0-9_\]\*"):
        compile_ltlf("true", [name], cache=False)


@pytest.mark.parametrize("name", ["true", "false", "last", "lastly", "true_x", "falsey"])
def test_keyword_fluent_names(name: str) -> None:
    with pytest.raises(ValueError, match="keyword"):
        check_fluent_names([name])


def test_vocabulary_shape_errors() -> None:
    with pytest.raises(TypeError, match="not the string"):
        compile_ltlf("F(a)", "ab", cache=False)
    with pytest.raises(ValueError, match="duplicate"):
        compile_ltlf("F(a)", ["a", "b", "a"], cache=False)
    with pytest.raises(TypeError, match="strings"):
        check_fluent_names(["a", 3])  # type: ignore[list-item]


def test_end_is_an_atom_and_inferring_it_warns() -> None:
    # ltlf2dfa has no end-of-trace operator: `end` is a fluent like any other.
    with pytest.warns(UserWarning, match="'end' is read as a fluent"):
        dfa = compile_ltlf("F(end)", backend="bdd", cache=False)
    assert dfa.fluents == ("end",)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        compile_ltlf("F(end)", ["end", "x"], backend="bdd", cache=False)


def test_atoms() -> None:
    parsed = parse_ltlf("G(b -> F(a)) & X(c) & b")
    assert atoms(parsed) == ("a", "b", "c")
    assert atoms_in_order(parsed) == ("b", "a", "c")


def test_default_vocabulary_is_sorted_atoms() -> None:
    assert compile_ltlf("G(zeta -> F(alpha))", backend="bdd", cache=False).fluents == (
        "alpha",
        "zeta",
    )
