"""Overlapped rollouts (``world.overlap``, :mod:`noisybolt.agents.pipeline`).

The overlapped collector must fill PPO's rollout buffer with what SB3's synchronous
collector puts there for the same games: with a deterministic policy the very same
rollouts and the same trained weights; with sampled actions transitions that the world in
process reproduces from the recorded actions, and log-probabilities of the current policy.
"""

from __future__ import annotations

import functools
from typing import Any

import numpy as np
import pytest
import torch as th
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.utils import obs_as_tensor
from stable_baselines3.common.vec_env import VecNormalize

from noisybolt.agents.pipeline import GroupedVecEnv, group_bounds, grouped_below
from noisybolt.envs.breakout import FLUENT_NAMES
from noisybolt.errors import ConfigError
from noisybolt.perception.detectors import OracleDetector
from noisybolt.runs.config import RESUMABLE_KEYS, TrainConfig
from noisybolt.runs.environments import make_env
from noisybolt.runs.legacy import LEGACY_DEFAULTS
from noisybolt.runs.models import make_model
from noisybolt.runs.resolution import resolve

N_ENVS, N_STEPS = 5, 24  # uneven groups (2 + 3)


def _config(*, overlap: bool, frames_per_game: int = 60, **more: Any) -> TrainConfig:
    return resolve(
        TrainConfig.build(
            {
                "world.name": "breakout-ram",
                "world.workers": 2 if overlap else 0,
                "world.overlap": overlap,
                "world.n_envs": N_ENVS,
                # short games: truncations (bootstrapped) and lost lives inside a rollout
                "world.kwargs": {
                    "noise": "gaussian:sigma=30",
                    "max_episode_frames": frames_per_game,
                },
                "bolt.specs": ["left_column_milestones"],
                "bolt.reward": "paper",
                "detector.kind": "oracle",
                "algorithm.name": "ppo",
                "algorithm.hyperparams.n_steps": N_STEPS,
                "algorithm.hyperparams.batch_size": 40,
                "seed": 4,
                **more,
            }
        )
    )


def _model(config: TrainConfig, *, deterministic: bool) -> Any:
    env = make_env(config, OracleDetector(FLUENT_NAMES), training=True)
    model = make_model(config, env)
    if deterministic:  # both collectors call policy(obs); make it take the likeliest action
        policy = model.policy
        policy.forward = functools.partial(type(policy).forward, policy, deterministic=True)  # type: ignore[method-assign]
    return model


def _collect(model: Any) -> Any:
    """One rollout, as ``learn`` collects it, without the update."""
    _, callback = model._setup_learn(N_ENVS * N_STEPS, None)
    callback.init_callback(model)
    assert model.collect_rollouts(model.env, callback, model.rollout_buffer, N_STEPS)
    return model.rollout_buffer


def _assert_same_buffers(ours: Any, theirs: Any) -> None:
    for key in theirs.observations:
        assert np.array_equal(ours.observations[key], theirs.observations[key]), key
    for name in ("actions", "episode_starts"):
        assert np.array_equal(getattr(ours, name), getattr(theirs, name)), name
    for name in ("rewards", "values", "log_probs", "returns", "advantages"):
        np.testing.assert_allclose(getattr(ours, name), getattr(theirs, name), rtol=1e-5, atol=1e-6)


def test_a_deterministic_policy_gets_the_same_rollouts_and_weights() -> None:
    inside = _model(_config(overlap=False), deterministic=True)
    overlapped = _model(_config(overlap=True), deterministic=True)
    try:
        assert isinstance(overlapped.env, GroupedVecEnv)
        assert [s.stop - s.start for s in overlapped.env.slices] == [2, 3]
        theirs, ours = _collect(inside), _collect(overlapped)
        _assert_same_buffers(ours, theirs)
        # The games ended and lost lives inside the rollout, and truncations were
        # bootstrapped (rewards hold gamma * V of the cut state), in both alike.
        assert theirs.episode_starts[1:].sum() >= N_ENVS
        # Training on them, and a second rollout with the trained policy: still the same.
        for model in (inside, overlapped):
            np.random.seed(0)  # noqa: NPY002 - PPO shuffles minibatches with the global generator
            model.train()
        for a, b in zip(inside.policy.parameters(), overlapped.policy.parameters(), strict=True):
            np.testing.assert_allclose(a.detach().numpy(), b.detach().numpy(), atol=1e-5)
        assert inside.collect_rollouts(inside.env, _Noop(inside), inside.rollout_buffer, N_STEPS)
        assert overlapped.collect_rollouts(
            overlapped.env, _Noop(overlapped), overlapped.rollout_buffer, N_STEPS
        )
        _assert_same_buffers(overlapped.rollout_buffer, inside.rollout_buffer)
    finally:
        inside.env.close()
        overlapped.env.close()


@pytest.mark.parametrize("normalize", [True, "split"])
def test_a_reward_normaliser_sees_the_same_steps_as_over_the_world_in_process(
    normalize: bool | str,
) -> None:
    """``normalize_reward`` on top of the groups: the same normalised rewards in the buffer
    and the same running statistics as the normaliser over the world stepped whole."""
    more = {"algorithm.hyperparams.normalize_reward": normalize, "bolt.reward": "compliance"}
    if normalize == "split":
        more["algorithm.hyperparams.bolt_weight"] = 2.0
    inside = _model(_config(overlap=False, **more), deterministic=True)
    overlapped = _model(_config(overlap=True, **more), deterministic=True)
    try:
        assert isinstance(overlapped.env, VecNormalize)
        assert isinstance(overlapped.env.venv, GroupedVecEnv)
        assert type(overlapped.env) is type(inside.env)
        theirs, ours = _collect(inside), _collect(overlapped)
        _assert_same_buffers(ours, theirs)
        names = ["ret_rms", "bolt_ret_rms"] if normalize == "split" else ["ret_rms"]
        for name in names:
            a, b = getattr(inside.env, name), getattr(overlapped.env, name)
            # one update a step, with every game's running return (count starts at 1e-4)
            assert a.count == pytest.approx(1e-4 + N_ENVS * N_STEPS) == b.count
            assert a.var != 1.0  # moved from its start: the rewards were normalised
            np.testing.assert_allclose([a.mean, a.var], [b.mean, b.var], rtol=1e-9)
        np.testing.assert_allclose(inside.env.returns, overlapped.env.returns, rtol=1e-9)
    finally:
        inside.env.close()
        overlapped.env.close()


def test_a_normaliser_of_observations_over_the_groups_is_refused() -> None:
    model = _model(_config(overlap=True), deterministic=False)
    try:
        assert grouped_below(model.env) is model.env
        assert grouped_below(VecNormalize(model.env, norm_obs=False)) is model.env
        with pytest.raises(ConfigError, match="norm_obs"):
            grouped_below(VecNormalize(model.env, norm_obs=True, norm_obs_keys=["image"]))
        assert grouped_below(model.env.groups[0]) is None
    finally:
        model.env.close()


def test_sampled_rollouts_are_the_worlds_transitions_under_the_current_policy() -> None:
    """Sampled actions differ from the synchronous collector's (each group draws its
    own), but every transition is one the world makes for the recorded action, and every
    log-probability and value is the current policy's."""
    config = _config(overlap=True, frames_per_game=100_000)  # no truncation: raw rewards
    model = _model(config, deterministic=False)
    replay = make_env(
        _config(overlap=False, frames_per_game=100_000), OracleDetector(FLUENT_NAMES), training=True
    )
    try:
        buffer = _collect(model)
        replay.seed(config.seed)
        obs: Any = replay.reset()
        starts = np.ones(N_ENVS, dtype=bool)
        for t in range(N_STEPS):
            for key in obs:
                assert np.array_equal(buffer.observations[key][t], obs[key]), (t, key)
            assert np.array_equal(buffer.episode_starts[t], starts), t
            obs, rewards, starts, _ = replay.step(buffer.actions[t, :, 0].astype(int))
            np.testing.assert_allclose(buffer.rewards[t], rewards)
        flat = {
            key: value.reshape(N_ENVS * N_STEPS, -1) for key, value in buffer.observations.items()
        }
        with th.no_grad():
            values, log_probs, _ = model.policy.evaluate_actions(
                obs_as_tensor(flat, "cpu"), th.as_tensor(buffer.actions.reshape(-1))
            )
        np.testing.assert_allclose(buffer.log_probs.reshape(-1), log_probs.numpy(), atol=1e-5)
        np.testing.assert_allclose(buffer.values.reshape(-1), values.numpy().ravel(), atol=1e-5)
    finally:
        model.env.close()
        replay.close()


def test_a_callback_that_stops_leaves_no_step_under_way() -> None:
    model = _model(_config(overlap=True), deterministic=False)
    try:
        _, callback = model._setup_learn(1000, _StopAt(3))
        callback.init_callback(model)
        assert not model.collect_rollouts(model.env, callback, model.rollout_buffer, N_STEPS)
        assert model.num_timesteps == 3 * N_ENVS
        model.env.step(np.zeros(N_ENVS, dtype=int))  # would raise if a group still stepped
    finally:
        model.env.close()


def test_the_setting_is_checked_and_old_runs_load_without_it() -> None:
    with pytest.raises(ConfigError, match=r"world\.workers >= 2"):
        TrainConfig.build({"world.name": "breakout-ram", "world.overlap": True})
    with pytest.raises(ConfigError, match=r"world\.overlap must be true or false"):
        resolve(
            TrainConfig.build(
                {"world.name": "breakout-ram", "world.workers": 2, "world.overlap": 1}
            )
        )
    with pytest.raises(ConfigError, match="not on-policy"):
        config = _config(overlap=True, **{"algorithm.name": "dqn"})
        make_model(config, make_env(config, OracleDetector(FLUENT_NAMES), training=True))
    assert LEGACY_DEFAULTS["world.overlap"] is False and "world.overlap" in RESUMABLE_KEYS
    saved = _config(overlap=False).to_dict()
    del saved["world"]["overlap"]  # a run saved before the setting existed
    assert TrainConfig.from_dict(saved).world_config.overlap is False
    # Evaluation is unchanged: its envs are the bolted world, never grouped.
    evaluation = make_env(_config(overlap=True), OracleDetector(FLUENT_NAMES), training=False)
    evaluation.close()
    assert not isinstance(evaluation, GroupedVecEnv)


def test_group_bounds_split_evenly() -> None:
    assert group_bounds(8, 2) == ((0, 4), (4, 4))
    assert group_bounds(3, 2) == ((0, 2), (2, 1)) or group_bounds(3, 2) == ((0, 1), (1, 2))
    assert sum(count for _, count in group_bounds(7, 3)) == 7
    with pytest.raises(ConfigError):
        group_bounds(1, 2)


class _Noop(BaseCallback):
    def __init__(self, model: Any) -> None:
        super().__init__()
        self.init_callback(model)

    def _on_step(self) -> bool:
        return True


class _StopAt(BaseCallback):
    def __init__(self, steps: int) -> None:
        super().__init__()
        self.steps = steps

    def _on_step(self) -> bool:
        return self.n_calls < self.steps
