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
    "noisybolt.perception.fluent_dataset",
    "noisybolt.perception.label_counts",
    "noisybolt.perception.noise_base",
    "noisybolt.perception.noise_regional",
    "noisybolt.envs.breakout",
    "noisybolt.envs.breakout.camera",
    "noisybolt.envs.breakout.config",
    "noisybolt.envs.breakout.ram",
]


@pytest.mark.parametrize("name", MODULES)
def test_all_names_exist_and_are_documented(name):
    module = importlib.import_module(name)
    assert module.__doc__
    for public in module.__all__:
        obj = getattr(module, public)
        if isinstance(obj, (type, types.FunctionType)):
            assert obj.__doc__, f"{name}.{public} has no docstring"


# Modules with no example of their own, and why; every other module must have at least
# one, so a docstring whose examples stop being collected fails here instead of passing.
WITHOUT_EXAMPLES = {
    "noisybolt.perception.compat": "checks a file's camera against a world's; the loaders' "
    "examples (dataset, classifier) go through it",
}


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples_run(name):
    result = doctest.testmod(importlib.import_module(name), optionflags=doctest.ELLIPSIS)
    assert result.failed == 0
    assert result.attempted > 0 or name in WITHOUT_EXAMPLES, f"{name} has no examples"


def test_modules_without_examples_are_listed_modules():
    assert set(WITHOUT_EXAMPLES) < set(MODULES)
