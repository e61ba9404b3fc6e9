"""The public surface of noisybolt.logic, and the examples in its docstrings."""

from __future__ import annotations

import doctest
import importlib
import inspect

import pytest

import noisybolt.logic

MODULES = [
    "noisybolt.logic",
    "noisybolt.logic.analysis",
    "noisybolt.logic.cache",
    "noisybolt.logic.compiler",
    "noisybolt.logic.dfa",
    "noisybolt.logic.evaluator",
    "noisybolt.logic.mona",
    "noisybolt.logic.progression",
    "noisybolt.logic.syntax",
]


def test_public_api() -> None:
    assert sorted(noisybolt.logic.__all__) == [
        "BACKENDS",
        "DENSE_TABLE_LIMIT",
        "DFA",
        "Edge",
        "GuardDiagram",
        "assignment_to_mask",
        "compile_ltlf",
        "distance_to_acceptance",
        "holds",
        "is_satisfiable",
        "is_valid",
        "masks_from_bool_matrix",
    ]


@pytest.mark.parametrize("name", MODULES)
def test_all_names_exist_and_are_documented(name: str) -> None:
    module = importlib.import_module(name)
    assert module.__doc__
    for attribute in module.__all__:
        value = getattr(module, attribute)
        if inspect.isfunction(value) or inspect.isclass(value):
            assert value.__doc__, f"{name}.{attribute} has no docstring"


# Modules with no example of their own, and why; every other module must have at least
# one, so a docstring whose examples stop being collected fails here instead of passing.
WITHOUT_EXAMPLES = {
    "noisybolt.logic": "re-exports names whose own modules hold the examples",
    "noisybolt.logic.cache": "the on-disk DFA cache that compile_ltlf reads and writes",
    "noisybolt.logic.mona": "a backend of compile_ltlf, whose examples go through it",
    "noisybolt.logic.progression": "a backend of compile_ltlf (used when MONA is missing)",
}


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name: str) -> None:
    result = doctest.testmod(importlib.import_module(name), optionflags=doctest.ELLIPSIS)
    assert result.failed == 0
    assert result.attempted > 0 or name in WITHOUT_EXAMPLES, f"{name} has no examples"


def test_modules_without_examples_are_listed_modules() -> None:
    assert set(WITHOUT_EXAMPLES) < set(MODULES)
