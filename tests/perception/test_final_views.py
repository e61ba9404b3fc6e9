"""Collection keeps the last state of each episode random play ends (``final_views``).

The world is a non-slippery FrozenLake whose camera paints the agent's cell ``s`` as the
grey level ``12 * s``. ``in_hole`` and ``at_goal`` are true only on the step that ends an
episode; the vector world resets an ended episode in the same step, so the state it shows
after that step is the next episode's first one (the start, cell 0), and only the step's
``info["final_info"]`` shows where the episode ended.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

from noisybolt.envs import make_world
from noisybolt.envs.registry import world_fingerprint
from noisybolt.errors import ConfigError, RareFluentWarning, UnlabelledEnvError, UnseenFluentError
from noisybolt.perception import dataset
from noisybolt.perception.dataset import collect_samples
from noisybolt.perception.protocols import CameraSpec
from noisybolt.runs import DetectorConfig, train
from noisybolt.runs.config import TrainConfig
from noisybolt.runs.detectors import classifier_architecture, default_classifier_path, make_detector
from noisybolt.runs.legacy import LEGACY_DEFAULTS

WORLD = """
import gymnasium as gym
import numpy as np
import noisybolt

HOLES = (5, 7, 11, 12)


def lamp(env):
    return np.full((8, 8, 3), 12 * env.unwrapped.s, dtype=np.uint8)


def make():
    lake = gym.make("FrozenLake-v1", is_slippery=False)
    fluents = {
        "at_goal": lambda e: int(e.unwrapped.s) == 15,
        "in_hole": lambda e: int(e.unwrapped.s) in HOLES,
        "top": lambda e: e.unwrapped.s < 4,
    }
    return noisybolt.FluentLabels(lake, fluents=fluents, camera=lamp, return_bounds=(0, 1))
"""
NAME = "finallake:make"
HOLES = (5, 7, 11, 12)
SMALL = DetectorConfig(kind="classifier", samples=64, epochs=1, restarts=1)


@pytest.fixture
def lake(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, world_module: Callable[[str, str], str]
) -> Any:
    """The world's module in the current directory, and a cache of this test's own."""
    monkeypatch.setenv("NOISYBOLT_CACHE_DIR", str(tmp_path / "cache"))
    world_module("finallake", WORLD)
    return make_world(NAME, num_envs=1, seed=0)


def _replay(n_envs: int, rounds: int, seed: int) -> tuple[int, int, int]:
    """``(episodes ended, of them in a hole, at the goal)`` in the random play that
    collection runs: the same reset seed and the same action draws, read from the
    rewards and termination flags alone (a non-slippery lake ends an episode only in a
    hole, reward 0, or at the goal, reward 1; 100 steps truncate it)."""
    world: Any = make_world(NAME, num_envs=n_envs, seed=seed)
    world.reset(seed=seed)
    rng = np.random.default_rng(seed)
    ended = holes = goals = 0
    for _ in range(rounds):
        _, rewards, terminated, truncated, _ = world.step(rng.integers(0, 4, size=n_envs))
        assert not truncated.any()
        ended += int(terminated.sum())
        holes += int((terminated & (rewards == 0)).sum())
        goals += int((terminated & (rewards == 1)).sum())
    return ended, holes, goals


def test_the_pool_gains_each_ended_episodes_last_state_as_a_replay_counts(lake: Any) -> None:
    n_envs, samples = 8, 100
    rounds = 25  # a pool of 2 * 100 images, 8 a round
    ended, holes, goals = _replay(n_envs, rounds, seed=0)
    assert ended == holes + goals and holes > 0  # random play falls in holes
    views = collect_samples(make_world(NAME, num_envs=n_envs, seed=0), num_samples=samples, seed=0)
    meta = views.metadata
    assert meta["final_views"] is True and meta["rounds"] == rounds
    assert meta["final_view_images"] == ended
    assert meta["pool_size"] == rounds * n_envs + ended
    # after a step the world shows the start (never a hole or the goal): the positives
    # of the pool are exactly the ended episodes' last states
    assert meta["pool_positives"]["in_hole"] == holes
    assert meta["pool_positives"]["at_goal"] == goals
    # the few positives are all picked, and their images are the holes' cells
    assert views.positives["in_hole"] == holes
    cells = views.images[views.labels[:, views.fluent_names.index("in_hole")], 0, 0, 0] // 12
    assert set(cells.tolist()) <= set(HOLES)

    plain = collect_samples(
        make_world(NAME, num_envs=n_envs, seed=0), num_samples=samples, seed=0, final_views=False
    )
    assert plain.metadata["final_views"] is False and plain.metadata["final_view_images"] == 0
    assert plain.metadata["pool_size"] == rounds * n_envs
    assert plain.metadata["pool_positives"]["in_hole"] == 0 == plain.positives["in_hole"]
    # the states after each step are the same either way
    assert plain.metadata["pool_positives"]["top"] == meta["pool_positives"]["top"]


def test_the_same_seed_collects_the_same_images(lake: Any) -> None:
    a, b = (
        collect_samples(make_world(NAME, num_envs=4, seed=0), num_samples=32, seed=3)
        for _ in range(2)
    )
    assert np.array_equal(a.images, b.images) and np.array_equal(a.labels, b.labels)


class _NoFinalInfo(gym.vector.VectorEnv):
    """A one-fluent world whose every step ends its episodes but whose info lacks
    ``final_info``: it breaks the world–bolt contract."""

    fluent_names = ("lit",)
    camera_spec = CameraSpec("nofinal", 4, 4)

    def __init__(self) -> None:
        self.num_envs = 2
        self.single_action_space = gym.spaces.Discrete(2)
        self.action_space = gym.spaces.MultiDiscrete([2, 2])

    def reset(self, *, seed: int | None = None, options: Any = None) -> tuple[Any, dict]:
        return np.zeros(2), {}

    def step(self, actions: Any) -> tuple[Any, ...]:
        done = np.ones(2, dtype=bool)
        return np.zeros(2), np.zeros(2), done, np.zeros(2, dtype=bool), {}

    def bolt_images(self) -> np.ndarray:
        return np.zeros((2, 4, 4, 3), np.uint8)

    def true_fluents(self) -> np.ndarray:
        return np.zeros((2, 1), bool)


def test_a_world_without_final_info_on_an_ended_step_is_refused() -> None:
    with pytest.raises(UnlabelledEnvError, match=r"info\['final_info'\]\['bolt_image'\]"):
        collect_samples(_NoFinalInfo(), num_samples=4, seed=0)
    assert len(collect_samples(_NoFinalInfo(), num_samples=4, seed=0, final_views=False)) == 4


def test_a_spec_over_a_fluent_true_only_as_episodes_end_now_trains(
    lake: Any, tmp_path: Path
) -> None:
    def config(detector: DetectorConfig) -> TrainConfig:
        return TrainConfig.create(
            world=NAME,
            specs=["F(in_hole)"],
            detector=detector,
            frames=256,
            eval_freq=0,
            overrides={"n_steps": 32},  # one rollout of 8 x 32 within the budget
        )

    legacy = DetectorConfig(kind="classifier", samples=64, epochs=1, restarts=1, final_views=False)
    with pytest.raises(UnseenFluentError, match="never show 'in_hole' true"):
        train(config(legacy), tmp_path / "refused", log=lambda line: None)
    with pytest.warns(RareFluentWarning, match=r"'in_hole' true in 13 and false in 51"):
        train(config(SMALL), tmp_path / "run", log=lambda line: None)
    assert (tmp_path / "run" / "config.json").is_file()
    saved = TrainConfig.from_dict(json.loads((tmp_path / "run" / "config.json").read_text()))
    assert saved.detector.final_views is True


def test_the_setting_reaches_every_collection_of_a_run(
    lake: Any, monkeypatch: pytest.MonkeyPatch
) -> None:
    # collect_samples is imported where it is used, so the spy sees every collection
    seen: list[bool] = []
    collect = dataset.collect_samples

    def spy(*args: Any, **kwargs: Any) -> Any:
        seen.append(kwargs["final_views"])
        return collect(*args, **kwargs)

    monkeypatch.setattr(dataset, "collect_samples", spy)
    for final_views in (True, False):
        seen.clear()
        make_detector(
            DetectorConfig(
                kind="classifier", samples=64, epochs=1, restarts=2, final_views=final_views
            ),
            world=NAME,
            world_kwargs={},
            fluent_names=lake.fluent_names,
            camera_spec=lake.camera_spec,
            progress=False,
            log=lambda line: None,
            spec_fluents=("top",),
        )
        # the fingerprint, up to two classifiers' images and the held-out images
        assert len(seen) >= 3 and set(seen) == {final_views}


def test_a_config_saved_before_the_setting_keeps_its_classifier_name(lake: Any) -> None:
    assert DetectorConfig().final_views is True
    assert LEGACY_DEFAULTS["detector.final_views"] is False
    with pytest.raises(ConfigError, match=r"detector\.final_views"):
        DetectorConfig(final_views="yes")  # type: ignore[arg-type]
    new = TrainConfig.create(world=NAME, specs=["G(top)"], detector=SMALL)
    saved = new.to_dict()
    del saved["detector"]["final_views"]
    old = TrainConfig.from_dict(saved)
    assert old.detector.final_views is False and new.detector.final_views is True
    camera = lake.camera_spec
    arch = classifier_architecture(camera)

    def name(config: DetectorConfig, world: str = NAME) -> str:
        fingerprint = world_fingerprint(world, {}, final_views=config.final_views)
        return default_classifier_path(
            world, config, camera, arch, fingerprint=fingerprint, world_kwargs={}
        ).name

    # the names noisybolt gave before final_views existed (computed with that code)
    assert world_fingerprint(NAME, {}) == "9be2c87c7549663c"
    assert name(old.detector) == "finallake.make-36d7b1ae75bc6fa3.safetensors"
    restarts = DetectorConfig(kind="classifier", restarts=3, final_views=False)
    assert name(restarts) == "finallake.make-7d108cac5a68b574.safetensors"
    # a new run's images differ, and so does its classifier's name
    assert name(new.detector) != name(old.detector)
    assert world_fingerprint(NAME, {}, final_views=True) != world_fingerprint(NAME, {})
    for world, before in (
        ("gridworld", "gridworld-5a1da94a2515c7dc"),
        ("breakout-ram", "breakout-ram-82ea9225fd589938"),
    ):
        shown = make_world(world, num_envs=1, seed=0).camera_spec
        shape = classifier_architecture(shown)
        legacy = DetectorConfig(restarts=1, final_views=False)
        assert default_classifier_path(world, legacy, shown, shape).stem == before
        assert (
            default_classifier_path(world, DetectorConfig(restarts=1), shown, shape).stem != before
        )
