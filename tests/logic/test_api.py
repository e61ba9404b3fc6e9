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


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name: str) -> None:
    result = doctest.testmod(importlib.import_module(name), optionflags=doctest.ELLIPSIS)
    assert result.failed == 0
