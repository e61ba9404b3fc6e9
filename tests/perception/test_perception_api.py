"""Public API of the classifier side of perception: names exported, examples run."""

from __future__ import annotations

import doctest
import importlib
import types

import pytest

MODULES = [
    "noisybolt.perception.metrics",
    "noisybolt.perception.compat",
    "noisybolt.perception.dataset",
    "noisybolt.perception.detectors",
    "noisybolt.perception.classifier",
    "noisybolt.perception.training",
    "noisybolt.envs.breakout",
]


@pytest.mark.parametrize("name", MODULES)
def test_all_names_exist_and_are_documented(name):
    module = importlib.import_module(name)
    assert module.__doc__
    for public in module.__all__:
        obj = getattr(module, public)
        if isinstance(obj, (type, types.FunctionType)):
            assert obj.__doc__, f"{name}.{public} has no docstring"


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples_run(name):
    result = doctest.testmod(importlib.import_module(name), optionflags=doctest.ELLIPSIS)
    assert result.failed == 0
