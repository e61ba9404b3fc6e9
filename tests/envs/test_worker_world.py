"""A world split over worker processes (:class:`noisybolt.envs.worker_world.WorkerWorld`).

It must play the very games of the world in process with the same seed — observations,
rewards, ends, lives, the bolt's camera images and true fluents, and the ended games'
last ones — and leave no process behind, however it ends.
"""

from __future__ import annotations

import gc
import os
import signal
import time
from typing import Any

import numpy as np
import pytest
import torch

from noisybolt.envs.breakout import FLUENT_NAMES, BreakoutWorld, make_breakout_world
from noisybolt.envs.registry import make_world
from noisybolt.envs.worker_world import WorkerWorld
from noisybolt.errors import ConfigError, WorldWorkerError
from noisybolt.perception.classifier import ClassifierDetector
from noisybolt.perception.detectors import OracleDetector
from noisybolt.runs.config import TrainConfig
from noisybolt.runs.environments import make_env, make_run_world
from noisybolt.wrappers import BoltVecEnv

SETTINGS: dict[str, Any] = {
    "noise": "gaussian:sigma=30",
    "fire_on_reset": True,
    "max_episode_frames": 320,  # 80 agent steps: every game is cut a few times
}
LABELS = ("bolt_image", "true_fluents")


def _alive(pid: int | None) -> bool:
    assert pid is not None
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return True


def _gone(pids: tuple[int | None, ...], within_s: float = 5.0) -> bool:
    deadline = time.monotonic() + within_s
    while any(_alive(pid) for pid in pids):
        if time.monotonic() > deadline:
            return False
        time.sleep(0.05)
    return True


def _assert_same_info(ours: dict[str, Any], theirs: dict[str, Any], step: int) -> None:
    """The in-process world's info (``theirs``) and the worker world's agree on every key
    the bolt and SB3 read, the ended games' final ones included."""
    for key in (*LABELS, "lives"):
        assert np.array_equal(np.asarray(theirs[key]), ours[key]), (step, key)
    assert ("final_info" in ours) == ("final_info" in theirs), step
    if "final_info" not in theirs:
        return
    assert np.array_equal(theirs["_final_obs"], ours["_final_obs"]), step
    for mine, other in zip(ours["final_obs"], theirs["final_obs"], strict=True):
        assert (mine is None and other is None) or np.array_equal(mine, other), step
    for key in (*LABELS, *(f"_{k}" for k in LABELS)):
        assert np.array_equal(np.asarray(theirs["final_info"][key]), ours["final_info"][key]), (
            step,
            key,
        )


@pytest.mark.parametrize(("name", "steps"), [("breakout-ram", 400), ("breakout", 120)])
def test_workers_play_the_in_process_worlds_games(name: str, steps: int) -> None:
    # 3 games over 2 workers: uneven shards (2 + 1).
    inside: Any = make_world(name, num_envs=3, seed=5, **SETTINGS)
    outside = WorkerWorld(name, num_envs=3, workers=2, seed=5, **SETTINGS)
    try:
        assert outside.shards == ((0, 2), (2, 1))
        assert outside.fluent_names == FLUENT_NAMES and outside.camera_spec == inside.camera_spec
        assert outside.single_observation_space == inside.single_observation_space
        assert outside.return_bounds() == inside.return_bounds()
        obs, info = inside.reset(seed=5)
        ours, our_info = outside.reset(seed=5)
        assert np.array_equal(obs, ours)
        _assert_same_info(our_info, info, -1)
        rng = np.random.default_rng(0)
        ended = 0
        for step in range(steps):
            actions = rng.integers(0, 4, 3)
            theirs = inside.step(actions)
            mine = outside.step(actions)
            for a, b in zip(theirs[:4], mine[:4], strict=True):
                assert np.array_equal(a, b), step
            _assert_same_info(mine[4], theirs[4], step)
            assert np.array_equal(outside.lives(), inside.lives())
            ended += int(np.sum(theirs[2] | theirs[3]))
        assert ended >= 3  # the final_info path was exercised, across both shards
        # A partial reset resets the same games.
        mask = np.array([False, True, True])
        obs, info = inside.reset(options={"reset_mask": mask})
        ours, our_info = outside.reset(options={"reset_mask": mask})
        assert np.array_equal(obs, ours)
        _assert_same_info(our_info, info, steps)
    finally:
        outside.close()
        inside.close()


def test_a_shard_plays_its_games_of_the_whole_world() -> None:
    whole = make_breakout_world(num_envs=3, seed=9, obs_mode="ram", **SETTINGS)
    part = make_breakout_world(num_envs=2, seed=9, obs_mode="ram", shard=(1, 3), **SETTINGS)
    obs, info = whole.reset(seed=9)
    ours, our_info = part.reset(seed=9)
    assert np.array_equal(obs[1:], ours)
    rng = np.random.default_rng(1)
    for _ in range(100):
        actions = rng.integers(0, 4, 3)
        obs, rewards, _, _, info = whole.step(actions)
        ours, our_rewards, _, _, our_info = part.step(actions[1:])
        assert np.array_equal(obs[1:], ours) and np.array_equal(rewards[1:], our_rewards)
        for key in LABELS:
            assert np.array_equal(np.asarray(info[key])[1:], np.asarray(our_info[key]))


def test_bad_shards_and_worker_counts_are_refused() -> None:
    with pytest.raises(ConfigError, match="shard"):
        BreakoutWorld(num_envs=2, shard=(2, 3))
    with pytest.raises(ConfigError, match="workers"):
        WorkerWorld("breakout", num_envs=2, workers=3)
    with pytest.raises(ConfigError, match="workers"):
        WorkerWorld("breakout", num_envs=2, workers=0)
    with pytest.raises(ConfigError, match=r"world\.workers"):
        TrainConfig.build({"world.workers": -1})


def test_a_world_that_does_not_split_is_refused_by_name() -> None:
    with pytest.raises(ConfigError, match=r"'gridworld' cannot run in worker processes.*shard"):
        WorkerWorld("gridworld", num_envs=2, workers=1)


def test_close_and_garbage_collection_end_every_worker() -> None:
    world = WorkerWorld("breakout-ram", num_envs=2, workers=2, seed=0)
    pids = world.pids
    assert all(_alive(pid) for pid in pids)
    world.reset(seed=0)
    world.close()
    assert _gone(pids)
    world.close()  # twice is fine
    with pytest.raises(WorldWorkerError, match="closed"):
        world.step(np.zeros(2, dtype=np.int64))

    world = WorkerWorld("breakout-ram", num_envs=2, workers=2, seed=0)
    pids = world.pids
    del world
    gc.collect()
    assert _gone(pids)


@pytest.mark.parametrize("wait_s", [0.0, 0.5])
def test_a_dead_worker_is_named_and_the_others_are_closed(wait_s: float) -> None:
    # Sent to at once, or once its end of the pipe is surely closed (the send then breaks
    # the pipe before any receive): either way the message says it exited.
    world = WorkerWorld("breakout-ram", num_envs=4, workers=2, seed=0)
    pids = world.pids
    world.reset(seed=0)
    assert pids[1] is not None
    os.kill(pids[1], signal.SIGKILL)
    time.sleep(wait_s)
    with pytest.raises(WorldWorkerError, match=r"worker 1 .* games 2\.\.3, failed: it exited"):
        world.step(np.zeros(4, dtype=np.int64))
    assert _gone(pids)


def test_a_sigterm_to_the_process_group_leaves_the_workers_to_their_parent() -> None:
    # `timeout`, `kill -TERM -PGID` and batch schedulers signal every process of the
    # group: the workers must go on serving, so that the training can save its checkpoint
    # (its SIGTERM is a KeyboardInterrupt) and then close them.
    world = WorkerWorld("breakout-ram", num_envs=4, workers=2, seed=0)
    pids = world.pids
    world.reset(seed=0)
    for pid in pids:
        assert pid is not None
        os.kill(pid, signal.SIGTERM)
    time.sleep(0.2)
    assert all(_alive(pid) for pid in pids)
    observations, *_ = world.step(np.zeros(4, dtype=np.int64))
    assert observations.shape[0] == 4
    world.close()
    assert _gone(pids)


def test_an_error_in_a_worker_is_raised_with_its_traceback() -> None:
    world = WorkerWorld("breakout-ram", num_envs=2, workers=2, seed=0)
    pids = world.pids
    world.reset(seed=0)
    with pytest.raises(WorldWorkerError, match=r"(?s)worker 0 .*raised.*ValueError: actions"):
        world.step(np.array([7, 0]))  # no such action: the shard's world refuses it
    assert _gone(pids)


def _run_config(workers: int) -> TrainConfig:
    """A bolted Breakout RAM run with its world in ``workers`` processes (0: in process);
    the envs are built with whatever detector a test hands them."""
    return TrainConfig.build(
        {
            "world.name": "breakout-ram",
            "world.workers": workers,
            "world.kwargs": {"noise": "gaussian:sigma=30", "max_episode_frames": 320},
            "bolt.specs": ["left_column_milestones"],
            "bolt.reward": "paper",
            "detector.kind": "oracle",
            "seed": 3,
        }
    )


def _lockstep(inside: Any, outside: Any, *, steps: int) -> Any:
    """Seeds and resets two bolted envs of 3 games alike, then steps them with the same
    random actions, asserting the same observations (before each step), rewards and
    dones; yields ``(step, dones, infos inside, infos outside)`` after each step."""
    inside.seed(3)
    outside.seed(3)
    a: Any = inside.reset()
    b: Any = outside.reset()
    rng = np.random.default_rng(2)
    for step in range(steps):
        for key in a:
            assert np.array_equal(a[key], b[key]), (step, key)
        actions = rng.integers(0, 4, 3)
        a, ra, da, ia = inside.step(actions)
        b, rb, db, ib = outside.step(actions)
        assert np.array_equal(ra, rb) and np.array_equal(da, db), step
        yield step, da, ia, ib


def _bolt_of(env: Any) -> BoltVecEnv:
    """The bolt under a run's wrappers."""
    while not isinstance(env, BoltVecEnv):
        env = env.venv
    return env


def test_the_run_setting_puts_the_same_bolted_world_in_workers() -> None:
    """``world.workers`` through the run's whole stack (SB3VecEnv, the bolt, the Atari
    conventions): the same observations, rewards and ends as in process."""

    assert isinstance(make_run_world(_run_config(0), n_envs=2, seed=0), BreakoutWorld)
    detector = OracleDetector(FLUENT_NAMES)
    inside = make_env(_run_config(0), detector, training=True, n_envs=3)
    outside = make_env(_run_config(2), detector, training=True, n_envs=3)
    try:
        assert isinstance(_bolt_of(outside).world, WorkerWorld)
        for _ in _lockstep(inside, outside, steps=200):
            pass
    finally:
        outside.close()
        inside.close()


def test_a_worker_world_can_be_a_shard_and_step_in_two_halves() -> None:
    """``shard``: games 2..4 of a 5-game world, in 2 workers; ``step_async`` returns while
    the workers step, ``step_wait`` gives what ``step`` gives."""
    whole = make_breakout_world(num_envs=5, seed=9, obs_mode="ram", **SETTINGS)
    part = WorkerWorld("breakout-ram", num_envs=3, workers=2, seed=9, shard=(2, 5), **SETTINGS)
    try:
        obs, info = whole.reset(seed=9)
        ours, our_info = part.reset(seed=9)
        assert np.array_equal(obs[2:], ours)
        # read every step, as the worker does (a deferred camera draws its noise on reading)
        assert np.array_equal(np.asarray(info["bolt_image"])[2:], our_info["bolt_image"])
        rng = np.random.default_rng(3)
        for step in range(60):
            actions = rng.integers(0, 4, 5)
            theirs = whole.step(actions)
            part.step_async(actions[2:])
            with pytest.raises(RuntimeError, match="step_wait first"):
                part.reset()
            mine = part.step_wait()
            for a, b in zip(theirs[:4], mine[:4], strict=True):
                assert np.array_equal(a[2:], b), step
            assert np.array_equal(np.asarray(theirs[4]["bolt_image"])[2:], mine[4]["bolt_image"])
        with pytest.raises(RuntimeError, match="without a step_async"):
            part.step_wait()
    finally:
        part.close()
        whole.close()
    with pytest.raises(ConfigError, match="shard"):
        WorkerWorld("breakout-ram", num_envs=3, workers=1, shard=(3, 5))


def _loud_classifier() -> ClassifierDetector:
    """An untrained classifier of the Breakout camera whose probabilities move with the
    images, its columns in another order than the world's (the workers must reorder)."""
    camera = make_breakout_world(num_envs=1, seed=0, obs_mode="ram", **SETTINGS).camera_spec
    torch.manual_seed(0)
    detector = ClassifierDetector.untrained(
        fluent_names=tuple(reversed(FLUENT_NAMES)), camera_spec=camera
    )
    with torch.no_grad():
        for parameter in detector.model.parameters():
            parameter.mul_(3)
    return detector


def test_a_classifier_runs_in_the_workers_with_the_bolts_own_results() -> None:
    """A classifier detector goes to the workers with the world: each runs it on its own
    images, and the bolted run is the one in process — the same probabilities in every
    step's records (the ended games' last views and the new games' first ones included),
    the same DFA states in the observations, the same rewards."""

    detector = _loud_classifier()
    inside = make_env(_run_config(0), detector, training=False, n_envs=3)
    outside = make_env(_run_config(2), detector, training=False, n_envs=3)
    try:
        assert outside.world.detector is detector  # type: ignore[attr-defined]
        assert not inside._world_probs  # type: ignore[attr-defined]
        assert outside._world_probs  # type: ignore[attr-defined]
        ended = 0
        seen: list[np.ndarray] = []
        for step, da, ia, ib in _lockstep(inside, outside, steps=200):
            if step == 0:  # the reset's records (a step leaves them)
                for ours, theirs in zip(inside.reset_infos, outside.reset_infos, strict=True):
                    np.testing.assert_allclose(
                        ours["fluent_probs"], theirs["fluent_probs"], atol=1e-5
                    )
            # the same network on the same images; a batch of another size may round
            # the last bit of a float32 differently
            ours = np.stack([info["fluent_probs"] for info in ia])
            theirs = np.stack([info["fluent_probs"] for info in ib])
            np.testing.assert_allclose(ours, theirs, rtol=0, atol=1e-5, err_msg=str(step))
            seen.append(theirs)
            ended += int(da.sum())
        assert ended >= 3  # the ended games' last views were read from final_info
        # images differ, and so do their probabilities: not a constant a mix-up would give
        assert np.stack(seen).std(axis=0).min() > 1e-3
    finally:
        outside.close()
        inside.close()


def test_only_a_classifier_goes_to_the_workers() -> None:
    with pytest.raises(ConfigError, match="only a classifier"):
        oracle: Any = OracleDetector(FLUENT_NAMES)
        WorkerWorld("breakout-ram", num_envs=2, workers=2, detector=oracle)


def test_a_learners_images_stay_in_the_workers() -> None:
    """Training: the classifier's probabilities come back, the images do not (they keep
    their shape, and reading them is refused by name); the learner's run is the same as in
    process, ended games included."""
    detector = _loud_classifier()
    inside = make_env(_run_config(0), detector, training=True, n_envs=3)
    outside = make_env(_run_config(2), detector, training=True, n_envs=3)
    try:
        bolted = _bolt_of(outside)
        world = bolted.world
        assert isinstance(world, WorkerWorld) and world.detector is detector
        assert not world.images
        ended = 0  # games that ended (not lives lost, which end the learner's episodes)
        for _ in _lockstep(inside, outside, steps=200):
            info = bolted.venv.batched_info  # type: ignore[attr-defined]
            assert info["bolt_image"].shape == (3, 84, 84, 3)
            assert info["bolt_probs"].shape == (3, len(FLUENT_NAMES))
            if "final_info" in info:
                ended += 1
                final = info["final_info"]
                assert final["bolt_image"].shape == (3, 84, 84, 3)
                with pytest.raises(ConfigError, match="images=True"):
                    np.asarray(final["bolt_image"])
        assert ended >= 2
        with pytest.raises(ConfigError, match=r"stayed in the world's worker.*images=True"):
            np.asarray(info["bolt_image"])
    finally:
        outside.close()
        inside.close()
    with pytest.raises(ConfigError, match="give the detector"):
        WorkerWorld("breakout-ram", num_envs=2, workers=2, images=False)
    # an evaluation's world sends them (its records and recordings may read them)
    evaluated = make_run_world(_run_config(2), n_envs=2, seed=0, detector=detector)
    try:
        assert evaluated.images
        _, info = evaluated.reset(seed=0)
        assert np.asarray(info["bolt_image"]).shape == (2, 84, 84, 3)
    finally:
        evaluated.close()
