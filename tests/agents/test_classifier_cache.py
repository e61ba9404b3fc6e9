"""The on-the-fly classifier of a factory-path world is cached by what its fluents mean:
a fluent redefined under the same name gets a new classifier, not the stale one."""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

import pytest

from noisybolt.agents.training import DetectorConfig, TrainConfig, make_detector, train
from noisybolt.envs import make_world
from noisybolt.envs.registry import world_fingerprint
from noisybolt.errors import ConfigError

WORLD = """
import gymnasium as gym
import numpy as np
import noisybolt


def lamp(env):
    return np.full((8, 8, 3), 12 * env.unwrapped.s, dtype=np.uint8)


def make():
    lake = gym.make("FrozenLake-v1", is_slippery=True)
    return noisybolt.FluentLabels(lake, fluents={{"marked": lambda e: {definition}}}, camera=lamp)
"""


def _write_world(folder: Path, definition: str) -> None:
    (folder / "cachedlake.py").write_text(WORLD.format(definition=definition))
    shutil.rmtree(folder / "__pycache__", ignore_errors=True)
    sys.modules.pop("cachedlake", None)  # as a new process would import it


def _detector_path(log: list[str]) -> str:
    world = make_world("cachedlake:make", num_envs=1, seed=0)
    config = DetectorConfig(kind="classifier", samples=64, epochs=1)
    make_detector(
        config,
        world="cachedlake:make",
        world_kwargs={},
        fluent_names=world.fluent_names,
        camera_spec=world.camera_spec,
        progress=False,
        log=log.append,
    )
    trained = [line for line in log if "training one" in line]
    return trained[-1] if trained else ""


def test_a_redefined_fluent_gets_a_new_classifier(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(sys, "path", list(sys.path))  # the import adds the folder to it
    _write_world(tmp_path, "e.s < 8")  # the top half of the lake
    first: list[str] = []
    assert "training one" in _detector_path(first)
    again: list[str] = []
    assert _detector_path(again) == ""  # same meaning: the cached classifier is reused
    _write_world(tmp_path, "e.s % 4 < 2")  # same name, now the left half
    changed: list[str] = []
    assert "training one" in _detector_path(changed)
    assert changed[0] != first[0]  # another file
    sys.modules.pop("cachedlake", None)


def test_the_fingerprint_follows_labels_and_images_not_the_module(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(sys, "path", list(sys.path))  # the import adds the folder to it
    _write_world(tmp_path, "e.s < 8")
    top = world_fingerprint("cachedlake:make")
    _write_world(tmp_path, "bool(e.s <= 7)")  # other code, the same fluent
    assert world_fingerprint("cachedlake:make") == top
    _write_world(tmp_path, "e.s < 4")
    assert world_fingerprint("cachedlake:make") != top
    sys.modules.pop("cachedlake", None)


def test_retrain_trains_the_cached_classifier_again(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(sys, "path", list(sys.path))
    _write_world(tmp_path, "e.s == 14")
    world = make_world("cachedlake:make", num_envs=1, seed=0)
    config = DetectorConfig(kind="classifier", samples=64, epochs=1)
    kwargs = {
        "world": "cachedlake:make",
        "world_kwargs": {},
        "fluent_names": world.fluent_names,
        "camera_spec": world.camera_spec,
        "progress": False,
    }
    log: list[str] = []
    make_detector(config, log=log.append, **kwargs)  # type: ignore[arg-type]
    make_detector(config, log=log.append, **kwargs)  # type: ignore[arg-type]
    assert len(log) == 2 and log[0].startswith("no cached classifier")  # + its report
    make_detector(config, log=log.append, retrain=True, **kwargs)  # type: ignore[arg-type]
    assert log[2].startswith("retraining it")
    with pytest.raises(ConfigError, match="used as given"):
        make_detector(
            DetectorConfig(kind="classifier", path=str(tmp_path / "mine.safetensors")),
            retrain=True,
            **kwargs,  # type: ignore[arg-type]
        )
    sys.modules.pop("cachedlake", None)


def test_retrain_is_refused_on_resume(tmp_path: Path) -> None:
    config = TrainConfig.create(specs=["edge"], detector=DetectorConfig(kind="oracle"))
    with pytest.raises(ConfigError, match="halfway"):
        train(config, tmp_path / "run", resume=True, retrain_classifier=True)
    assert not (tmp_path / "run").exists()
