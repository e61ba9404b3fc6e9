"""The old homes of moved names (issue 44's split of ``agents`` into the learner, ``runs``
and ``viz``) still work for one release, each with a DeprecationWarning naming the new
home, and hand back the very same objects."""

from __future__ import annotations

import importlib
import sys
import warnings

import pytest

from noisybolt._moved import MOVED_ATTRIBUTES, MOVED_MODULES, REEXPORTED


@pytest.mark.parametrize("old", sorted(MOVED_MODULES))
def test_an_old_module_path_is_the_new_module_with_a_warning(old: str) -> None:
    sys.modules.pop(old, None)
    with pytest.warns(DeprecationWarning, match=MOVED_MODULES[old].replace(".", r"\.")):
        module = importlib.import_module(old)
    new = importlib.import_module(MOVED_MODULES[old])
    if old in REEXPORTED:  # a view: every name of the new module, and those it re-exported
        assert all(getattr(module, name) is getattr(new, name) for name in new.__all__)
    else:
        assert module is new


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


def test_an_old_module_that_reexported_names_still_offers_them() -> None:
    from noisybolt.runs.config import TrainConfig
    from noisybolt.runs.environments import make_env
    from noisybolt.runs.training import train

    sys.modules.pop("noisybolt.agents.training", None)
    with pytest.warns(DeprecationWarning, match=r"noisybolt\.runs\.training"):
        from noisybolt.agents.training import TrainConfig as Old
        from noisybolt.agents.training import make_env as old_make_env
        from noisybolt.agents.training import train as old_train
    assert (Old, old_make_env, old_train) == (TrainConfig, make_env, train)
    sys.modules.pop("noisybolt.agents.config", None)
    with pytest.warns(DeprecationWarning):
        from noisybolt.agents.config import nested_config, resolve
    from noisybolt.runs.legacy import nested_config as new_nested
    from noisybolt.runs.resolution import resolve as new_resolve

    assert (nested_config, resolve) == (new_nested, new_resolve)
    with pytest.raises(ImportError):
        from noisybolt.agents.training import nothing_here  # noqa: F401
