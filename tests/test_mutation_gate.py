"""The bolt's mutation gate (``scripts/mutate_bolt.py``) cannot rot (issue 46): each
mutation still finds the code it breaks, and finds it by what the code is, not by its
line. Cheap: the mutations are applied in memory and no test suite is run (``make
test-slow`` runs the whole gate)."""

from __future__ import annotations

import ast
from collections.abc import Callable
from pathlib import Path
from types import ModuleType

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def gate(load_script: Callable[..., ModuleType]) -> ModuleType:
    return load_script("scripts/mutate_bolt.py")


def test_every_mutation_still_applies(gate: ModuleType) -> None:
    problems = gate.check_mutations()
    assert len(problems) == len(gate.MUTATIONS)  # names are unique
    assert {name: p for name, p in problems.items() if p is not None} == {}


def test_each_mutation_changes_only_its_function(gate: ModuleType) -> None:
    parsed: dict[str, dict[str, str]] = {}
    for m in gate.MUTATIONS:
        source = (ROOT / m.path).read_text()
        if m.path not in parsed:
            parsed[m.path] = _functions(ast.parse(source))
        before, after = parsed[m.path], _functions(ast.parse(m.apply(source)))
        changed = {name for name in before | after if before.get(name) != after.get(name)}
        assert changed == {m.function}, m.name
        for test in m.tests:
            assert (ROOT / test).is_file(), (m.name, test)


def _functions(tree: ast.AST, prefix: str = "") -> dict[str, str]:
    """Each function's qualified name -> its syntax tree, dumped (its own body only)."""
    out = {}
    for node in ast.iter_child_nodes(tree):
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
            name = prefix + node.name
            if not isinstance(node, ast.ClassDef):
                out[name] = ast.dump(node)
            out.update(_functions(node, name + "."))
    return out


SOURCE = """
class Engine:
    def step(self, probs):
        truth = probs >= self.truth  # a comment
        return truth

    def other(self, probs):
        return probs >= self.truth
"""


def test_a_mutation_finds_its_code_whatever_the_layout(gate: ModuleType) -> None:
    m = gate.Mutation("t", "x.py", "Engine.step", "probs >= self.truth", "probs > self.truth", ())
    mutated = m.apply(SOURCE)
    assert "truth = (probs > self.truth)  # a comment" in mutated
    assert "return probs >= self.truth" in mutated  # the other function is left alone
    moved = "\n\n# a new first line\n" + SOURCE.replace(
        "probs >= self.truth  #", "(\n probs\n >= self.truth)  #"
    )
    assert "(probs > self.truth)" in m.apply(moved)


@pytest.mark.parametrize(
    ("function", "old", "message"),
    [
        ("Engine.gone", "probs >= self.truth", "no function Engine.gone"),
        ("Engine.step", "probs > self.truth", "found 0 times"),  # the code was rewritten
    ],
)
def test_a_mutation_whose_code_is_gone_says_so(
    gate: ModuleType, function: str, old: str, message: str
) -> None:
    m = gate.Mutation("t", "x.py", function, old, "probs", ())
    with pytest.raises(gate.MutationNotAppliedError, match=message):
        m.apply(SOURCE)


def test_a_mutation_found_twice_is_refused_unless_every(gate: ModuleType) -> None:
    twice = SOURCE.replace("return truth", "return probs >= self.truth")
    m = gate.Mutation("t", "x.py", "Engine.step", "probs >= self.truth", "probs", ())
    with pytest.raises(gate.MutationNotAppliedError, match="found 2 times"):
        m.apply(twice)
    every = gate.Mutation("t", "x.py", "Engine.step", "probs >= self.truth", "probs", (), True)
    assert every.apply(twice).count("(probs)") == 2


def test_the_gate_runs_in_make_test_slow() -> None:
    makefile = (ROOT / "Makefile").read_text()
    target = makefile.split("\ntest-slow:", 1)[1].split("\n\n", 1)[0]
    assert "scripts/mutate_bolt.py" in target
