"""The on-the-fly classifier of a factory-path world is cached by what its fluents mean:
a fluent redefined under the same name gets a new classifier, not the stale one."""

from __future__ import annotations

import shutil
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from noisybolt.envs import make_world
from noisybolt.envs.registry import world_fingerprint
from noisybolt.errors import ConfigError
from noisybolt.runs import DetectorConfig, TrainConfig, train
from noisybolt.runs.detectors import best_of_restarts, make_detector, restart_seed

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
    # "no cached classifier", its last epoch, its report, its held-out accuracy
    trained = len(log)
    assert log[0].startswith("no cached classifier") and trained == 4
    assert log[1].startswith("classifier: epoch 1/1")
    make_detector(config, log=log.append, **kwargs)  # type: ignore[arg-type]
    assert len(log) == trained  # the cached one is reused in silence
    make_detector(config, log=log.append, retrain=True, **kwargs)  # type: ignore[arg-type]
    assert log[trained].startswith("retraining it")
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


class _Reads:
    """A stand-in classifier that reads fluent ``k`` right on the first ``right[k]``
    held-out images and wrong on the rest."""

    fluent_names = ("a", "b")

    def __init__(self, right: tuple[int, int], labels: np.ndarray) -> None:
        self._right, self._labels = right, labels

    def predict(self, images: np.ndarray) -> np.ndarray:
        probs = self._labels.astype(float)
        for k, n in enumerate(self._right):
            probs[n:, k] = 1.0 - probs[n:, k]
        return probs


def _held_out() -> SimpleNamespace:
    labels = np.zeros((100, 2), dtype=bool)
    labels[::2] = True
    return SimpleNamespace(images=np.zeros((100, 1, 1, 3), np.uint8), labels=labels)


def test_restarts_keep_the_classifier_whose_worst_fluent_reads_best() -> None:
    data = _held_out()
    reads = [(99, 80), (90, 91), (97, 70), (100, 100)]  # worst fluent: 0.80, 0.90, 0.70, 1
    trained: list[int] = []
    built: list[int] = []

    def train_one(restart: int) -> _Reads:
        trained.append(restart)
        return _Reads(reads[restart], data.labels)

    def held_out() -> SimpleNamespace:
        built.append(1)
        return data

    log: list[str] = []
    best = best_of_restarts(train_one, held_out, restarts=3, log=log.append)
    assert trained == [0, 1, 2] and built == [1]  # the held-out set is made once
    assert (
        best.predict(data.images)[:, 1].tolist()
        == _Reads((90, 91), data.labels).predict(data.images)[:, 1].tolist()
    )
    assert "0.900 at worst (a)" in log[1]
    # stops at the first that reaches ACCEPT_ACCURACY (0.95): (100, 100) after (99, 80)
    reads[1] = (100, 100)
    trained.clear()
    best_of_restarts(train_one, held_out, restarts=3, log=log.append)
    assert trained == [0, 1]
    # one restart: the first classifier, no held-out set
    trained.clear()
    built.clear()
    best_of_restarts(train_one, held_out, restarts=1, log=log.append)
    assert trained == [0] and built == []


def test_restart_seeds_start_at_the_seed_and_differ() -> None:
    assert restart_seed(7, 0) == 7
    seeds = {restart_seed(s, r) for s in range(3) for r in range(4)}
    assert len(seeds) == 12


def test_restarts_key_the_cache_from_two_on_and_legacy_runs_had_one() -> None:
    from noisybolt.runs.detectors import classifier_architecture, default_classifier_path
    from noisybolt.runs.legacy import LEGACY_DEFAULTS

    names = {}
    for world in ("breakout-ram", "gridworld"):
        camera = make_world(world, num_envs=1, seed=0).camera_spec
        for restarts in (1, 3):
            # final_views False: as every run saved before that setting collected
            config = DetectorConfig(restarts=restarts, final_views=False)
            names[world, restarts] = default_classifier_path(
                world, config, camera, classifier_architecture(camera)
            ).name
    # one classifier keeps the name it had before restarts existed
    assert names["breakout-ram", 1] == "breakout-ram-82ea9225fd589938.safetensors"
    assert names["gridworld", 1] == "gridworld-5a1da94a2515c7dc.safetensors"
    assert names["breakout-ram", 3] != names["breakout-ram", 1]
    # from restarts on, how the collector is built keys it too (not before: legacy names)
    camera = make_world("breakout-ram", num_envs=1, seed=0).camera_spec
    arch = classifier_architecture(camera)
    for restarts, differ in ((3, True), (1, False)):
        config = DetectorConfig(restarts=restarts, final_views=False)
        plain = default_classifier_path("breakout-ram", config, camera, arch, world_kwargs={})
        fire = default_classifier_path(
            "breakout-ram", config, camera, arch, world_kwargs={"fire_on_reset": True}
        )
        assert (plain != fire) is differ
        assert plain.name == names["breakout-ram", restarts]
    assert DetectorConfig().restarts == 3 and LEGACY_DEFAULTS["detector.restarts"] == 1
    with pytest.raises(ConfigError, match=r"detector\.restarts"):
        DetectorConfig(restarts=0)


def test_a_classifier_trained_with_restarts_compares_them_on_held_out_images() -> None:
    world = make_world("gridworld", num_envs=1, seed=0, noise="regional")
    log: list[str] = []
    make_detector(
        DetectorConfig(kind="classifier", samples=64, epochs=1, restarts=2),
        world="gridworld",
        world_kwargs={"noise": "regional"},
        fluent_names=world.fluent_names,
        camera_spec=world.camera_spec,
        progress=False,
        log=log.append,
    )
    trained = [line for line in log if line.startswith("classifier trained")]
    compared = [line for line in log if "held-out accuracy" in line]
    # 64 images and one epoch read no smudged corner at 0.92: both are trained, the
    # second from its own seed on twice the images
    assert len(trained) == 2 and len(compared) == 2
    assert "on 64 bolt images (seed 0)" in trained[0]
    assert f"on 128 bolt images (seed {restart_seed(0, 1)})" in trained[1]


def test_a_large_camera_is_warned_of_before_a_classifier_is_trained_on_it() -> None:
    import warnings

    from noisybolt.errors import LargeCameraWarning
    from noisybolt.perception.protocols import CameraSpec
    from noisybolt.runs.detectors import warn_of_large_camera

    with pytest.warns(LargeCameraWarning, match=r"500x500 images.*about 35 times.*\[::6, ::6\]"):
        warn_of_large_camera(CameraSpec("pendulum", 500, 500), samples=4000, epochs=30)
    with warnings.catch_warnings():  # the shipped worlds' cameras say nothing
        warnings.simplefilter("error", LargeCameraWarning)
        warn_of_large_camera(CameraSpec("breakout", 84, 84), samples=4000, epochs=30)
        warn_of_large_camera(CameraSpec("wide", 64, 128), samples=4000, epochs=30)
