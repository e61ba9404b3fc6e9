"""The old homes of moved names (issue 44's split of ``agents`` into the learner, ``runs``
and ``viz``) still work for one release, each with a DeprecationWarning naming the new
home, and hand back the very same objects."""

from __future__ import annotations

import importlib
import sys
import warnings

import pytest

from noisybolt._moved import MOVED_ATTRIBUTES, MOVED_MODULES


@pytest.mark.parametrize("old", sorted(MOVED_MODULES))
def test_an_old_module_path_is_the_new_module_with_a_warning(old: str) -> None:
    sys.modules.pop(old, None)
    with pytest.warns(DeprecationWarning, match=MOVED_MODULES[old].replace(".", r"\.")):
        module = importlib.import_module(old)
    assert module is importlib.import_module(MOVED_MODULES[old])


def test_from_an_old_module_import_a_name_gets_the_same_class() -> None:
    from noisybolt.runs.config import TrainConfig

    sys.modules.pop("noisybolt.agents.config", None)
    with pytest.warns(DeprecationWarning, match=r"noisybolt\.runs\.config"):
        from noisybolt.agents.config import TrainConfig as Old
    assert Old is TrainConfig


@pytest.mark.parametrize(("package", "name"), sorted(MOVED_ATTRIBUTES))
def test_an_old_package_attribute_warns_and_is_the_new_object(package: str, name: str) -> None:
    with pytest.warns(DeprecationWarning, match=f"{MOVED_ATTRIBUTES[package, name]}.{name}"):
        old = getattr(importlib.import_module(package), name)
    assert old is getattr(importlib.import_module(MOVED_ATTRIBUTES[package, name]), name)


def test_names_that_never_lived_there_are_still_missing() -> None:
    import noisybolt.agents

    with pytest.raises(AttributeError, match="no attribute 'nothing_here'"):
        noisybolt.agents.nothing_here  # noqa: B018
    with pytest.raises(ModuleNotFoundError):
        importlib.import_module("noisybolt.agents.nothing_here")


def test_the_learner_package_imports_without_a_warning_or_the_runs_layer() -> None:
    code = (
        "import sys, warnings; warnings.simplefilter('error');"
        "import noisybolt.agents;"
        "assert 'noisybolt.runs' not in sys.modules, sorted(sys.modules)"
    )
    import subprocess

    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr


def test_no_warning_for_the_new_homes() -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)
        from noisybolt.runs import TrainConfig, train  # noqa: F401
        from noisybolt.viz import save_episode_gif  # noqa: F401
