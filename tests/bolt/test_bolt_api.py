"""The public API of noisybolt.bolt: exported names, docstrings, runnable examples."""

from __future__ import annotations

import doctest
import importlib
import inspect

import pytest

import noisybolt.bolt as bolt

MODULES = [
    "noisybolt.bolt",
    "noisybolt.bolt.augmented",
    "noisybolt.bolt.bands",
    "noisybolt.bolt.belief",
    "noisybolt.bolt.engine",
    "noisybolt.bolt.restraining_bolt",
    "noisybolt.bolt.schemes",
    "noisybolt.bolt.settings",
    "noisybolt.bolt.shaping",
    "noisybolt.bolt.spec",
]


def test_public_names() -> None:
    assert set(bolt.__all__) == {
        "BELIEF_OBSERVATIONS",
        "CONSTRAINT_KEYS",
        "COST_MODES",
        "DEFAULT_THRESHOLDS",
        "REWARD_SCHEMES",
        "REWARD_TIMINGS",
        "TRACKING_MODES",
        "AugmentedDFA",
        "AugmentedEdge",
        "AugmentedStep",
        "Band",
        "BeliefEngine",
        "BeliefObservation",
        "BeliefSettings",
        "BoltEngine",
        "BoltSettings",
        "BoltStep",
        "CostLimit",
        "CostMode",
        "LagrangeMultiplier",
        "ProgressShaping",
        "RestrainingBolt",
        "ReturnBounds",
        "RewardScheme",
        "RewardSchemeName",
        "RewardTiming",
        "Spec",
        "Thresholds",
        "Tracking",
        "check_probs",
        "compliance_scale",
        "confidence_bands",
        "episode_costs",
        "high_confidence_mask",
        "low_confidence_mask",
        "progress_potential",
        "proportional_weights",
        "truth_mask",
    }


@pytest.mark.parametrize("module_name", MODULES)
def test_every_public_name_exists_and_is_documented(module_name: str) -> None:
    module = importlib.import_module(module_name)
    assert module.__doc__
    for name in module.__all__:
        obj = getattr(module, name)
        if inspect.isclass(obj) or inspect.isfunction(obj):
            assert obj.__doc__, f"{module_name}.{name} has no docstring"


@pytest.mark.parametrize("module_name", MODULES)
def test_docstring_examples_run(module_name: str) -> None:
    module = importlib.import_module(module_name)
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS)
    assert result.failed == 0


def test_the_bolt_layer_imports_no_gymnasium_or_torch() -> None:
    import subprocess
    import sys

    code = (
        "import sys, noisybolt.bolt; "
        "bad = [m for m in ('gymnasium', 'torch') if m in sys.modules]; "
        "sys.exit(1 if bad else 0)"
    )
    assert subprocess.run([sys.executable, "-c", code], check=False).returncode == 0
