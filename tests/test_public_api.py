"""The top-level API: ``noisybolt.__all__`` is the small public surface, lazily imported."""

from __future__ import annotations

import doctest
import importlib
import subprocess
import sys

import pytest

import noisybolt

PUBLIC = {
    "BoltVecEnv",
    "FluentDetector",
    "FluentLabels",
    "GridLayout",
    "RestrainingBoltWrapper",
    "Spec",
    "__version__",
    "compile_ltlf",
    "make_bolted_vec_env",
}


def test_all_is_the_documented_api_and_every_name_resolves() -> None:
    assert set(noisybolt.__all__) == PUBLIC
    from noisybolt.envs.labels import FluentLabels
    from noisybolt.logic import compile_ltlf
    from noisybolt.wrappers import RestrainingBoltWrapper, make_bolted_vec_env

    assert noisybolt.FluentLabels is FluentLabels
    assert noisybolt.RestrainingBoltWrapper is RestrainingBoltWrapper
    assert noisybolt.make_bolted_vec_env is make_bolted_vec_env
    assert noisybolt.compile_ltlf is compile_ltlf
    for name in PUBLIC:
        assert getattr(noisybolt, name) is not None
        assert name in dir(noisybolt)


def test_an_unknown_name_is_an_attribute_error() -> None:
    try:
        noisybolt.Nope  # type: ignore[attr-defined]  # noqa: B018
    except AttributeError as exc:
        assert "Nope" in str(exc)
    else:  # pragma: no cover
        raise AssertionError("noisybolt.Nope should not exist")


def test_importing_the_logic_layer_loads_neither_gymnasium_nor_torch() -> None:
    code = (
        "import sys, noisybolt.logic, noisybolt.bolt; "
        "print('gymnasium' in sys.modules, 'torch' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["False", "False"]


@pytest.mark.parametrize(
    "name",
    [
        "noisybolt",
        "noisybolt.envs.labels",
        "noisybolt.envs.labelled_vec",
        "noisybolt.envs.registry",
        "noisybolt.wrappers._inputs",
        "noisybolt.wrappers.bolt_wrapper",
        "noisybolt.wrappers.make_vec",
        "noisybolt.agents.extractor",
        "noisybolt.agents.hyperparams",
        "noisybolt.runs.config",
        "noisybolt.runs.sections",
        "noisybolt.runs.resolution",
        "noisybolt.runs.play",
        "noisybolt.runs.legacy",
        "noisybolt.runs.presentation",
        "noisybolt.experiments.table1_rows",
        "noisybolt.runs.detectors",
        "noisybolt.cli.train",
        "noisybolt.wrappers._common",
        "noisybolt.perception.dataset",
    ],
)
def test_docstring_examples_run(name: str) -> None:
    result = doctest.testmod(importlib.import_module(name), optionflags=doctest.ELLIPSIS)
    assert result.attempted > 0 and result.failed == 0
