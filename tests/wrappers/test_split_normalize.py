"""``normalize_reward: split``: the world's and the bolt's rewards normalised apart, each
exactly as SB3's VecNormalize would normalise it alone."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from playback import PlaybackVecEnv
from stable_baselines3.common.vec_env import VecEnv, VecNormalize

from noisybolt.agents.hyperparams import check_hyperparameter_values
from noisybolt.envs import make_world
from noisybolt.errors import ConfigError, CorruptFileError
from noisybolt.perception.detectors import OracleDetector
from noisybolt.runs import DetectorConfig, TrainConfig, train
from noisybolt.runs.checkpoints import NORMALISER, load_normaliser, save_normaliser
from noisybolt.runs.environments import make_env
from noisybolt.runs.presentation import describe_scheme
from noisybolt.runs.resolution import resolve
from noisybolt.wrappers import SplitRewardNormalize

GAMMA = 0.9


class Scripted(PlaybackVecEnv):
    """Plays back the world's and the bolt's rewards per step, summed as the reward and
    each reported in ``info`` as the bolt reports them (no ``info`` and no bolt reward
    where ``bolt`` is None), and dones; one env per column."""

    def __init__(self, world: np.ndarray, bolt: np.ndarray | None, dones: np.ndarray):
        self.world = np.asarray(world, dtype=np.float64)
        self.bolt = bolt
        summed = self.world if bolt is None else self.world + bolt
        self.rewards = summed.astype(np.float32)  # as the bolt hands them on
        self.dones = np.asarray(dones, dtype=bool)
        super().__init__(self.rewards.shape[1])
        self.t = 0

    def reset(self) -> Any:
        self.t = 0
        return np.zeros((self.num_envs, 1), np.float32)

    def step_wait(self) -> Any:
        t, self.t = self.t, self.t + 1
        infos: list[dict[str, Any]] = [{} for _ in range(self.num_envs)]
        if self.bolt is not None:
            for i, info in enumerate(infos):
                info["bolt_reward"] = float(self.bolt[t, i])
                info["env_reward"] = float(self.world[t, i])
        return np.zeros((self.num_envs, 1), np.float32), self.rewards[t], self.dones[t], infos


def _play(env: VecEnv, steps: int) -> np.ndarray:
    env.reset()
    actions = np.zeros(env.num_envs, dtype=np.int64)
    return np.stack([env.step(actions)[1] for _ in range(steps)])


def _plain(rewards: np.ndarray, dones: np.ndarray) -> np.ndarray:
    env = VecNormalize(Scripted(rewards, None, dones), norm_obs=False, gamma=GAMMA)
    return _play(env, len(rewards))


# Rewards that float32 holds exactly (halves), so a sum less its bolt share is exact.
_halves = st.integers(-20, 20).map(lambda k: k / 2)
_streams = st.integers(1, 20).flatmap(
    lambda steps: st.tuples(
        *(
            st.lists(st.lists(kind, min_size=3, max_size=3), min_size=steps, max_size=steps)
            for kind in (_halves, _halves.map(lambda r: r * 40), st.booleans())
        )
    )
)


@settings(max_examples=40, deadline=None)
@given(_streams)
def test_each_share_is_normalised_as_vecnormalize_would_alone(streams: tuple) -> None:
    world, bolt, dones = (np.asarray(s, dtype=np.float64) for s in streams)
    dones = dones.astype(bool)
    split = SplitRewardNormalize(Scripted(world, bolt, dones), gamma=GAMMA)
    got = _play(split, len(world))
    expected = _plain(world, dones) + _plain(bolt, dones)
    np.testing.assert_allclose(got, expected, rtol=1e-5, atol=1e-5)


@settings(max_examples=30, deadline=None)
@given(_streams, st.floats(0.1, 1000.0))
def test_scaling_the_bolt_rewards_changes_nothing_the_learner_sees(
    streams: tuple, factor: float
) -> None:
    world, bolt, dones = (np.asarray(s, dtype=np.float64) for s in streams)
    dones = dones.astype(bool)
    seen = [
        _play(SplitRewardNormalize(Scripted(world, b, dones), gamma=GAMMA), len(world))
        for b in (bolt, bolt * factor)
    ]
    # up to SB3's prior (a variance of 1 weighing 1e-4 of a step), which does not scale
    np.testing.assert_allclose(seen[0], seen[1], rtol=2e-3, atol=1e-4)


def test_without_bolt_rewards_it_is_plain_vecnormalize() -> None:
    rng = np.random.default_rng(0)
    world = rng.integers(-2, 3, size=(50, 4)).astype(np.float64)
    dones = rng.random((50, 4)) < 0.1
    # an unbolted run's bolt pays 0
    got = _play(SplitRewardNormalize(Scripted(world, np.zeros_like(world), dones), gamma=GAMMA), 50)
    np.testing.assert_array_equal(got, _plain(world, dones))


def test_a_step_without_the_bolts_shares_is_refused() -> None:
    env = SplitRewardNormalize(Scripted(np.ones((1, 1)), None, np.zeros((1, 1), dtype=bool)))
    env.reset()
    with pytest.raises(RuntimeError, match="lacks 'bolt_reward'"):
        env.step(np.zeros(1, dtype=np.int64))


def test_rare_large_bolt_payments_no_longer_drown_the_worlds_rewards() -> None:
    # Breakout-like: a clipped point every 4th step, a 237.6 milestone every 200th.
    steps = 4000
    world = np.where(np.arange(steps) % 4 == 0, 1.0, 0.0)[:, None]
    bolt = np.where(np.arange(steps) % 200 == 199, 237.6, 0.0)[:, None]
    dones = np.zeros((steps, 1), dtype=bool)
    joint = VecNormalize(Scripted(world, bolt, dones), norm_obs=False, gamma=0.99)
    split = SplitRewardNormalize(Scripted(world, bolt, dones), gamma=0.99)
    point = world[-400:, 0] == 1
    assert _play(joint, steps)[-400:, 0][point].max() < 0.05  # a point is lost in the noise
    assert _play(split, steps)[-400:, 0][point].min() > 0.05  # ... and here it is heard
    # and the bolt's milestone is still worth more than a point
    assert _play(split, steps)[-1, 0] > 5 * _play(split, steps)[-4, 0]


def test_saved_statistics_continue_where_they_stopped(tmp_path: Path) -> None:
    rng = np.random.default_rng(1)
    world = rng.integers(-1, 2, size=(60, 2)).astype(np.float64)
    bolt = np.where(rng.random((60, 2)) < 0.1, 10.0, 0.0)
    dones = rng.random((60, 2)) < 0.05
    whole = _play(SplitRewardNormalize(Scripted(world, bolt, dones), gamma=GAMMA), 60)
    first = SplitRewardNormalize(Scripted(world, bolt, dones), gamma=GAMMA)
    _play(first, 30)
    save_normaliser(first, tmp_path / "normaliser.npz")
    later = SplitRewardNormalize(Scripted(world, bolt, dones), gamma=GAMMA)
    load_normaliser(later, tmp_path / "normaliser.npz")
    later.venv.t = 30  # type: ignore[attr-defined]
    actions = np.zeros(2, dtype=np.int64)
    rest = np.stack([later.step(actions)[1] for _ in range(30)])
    np.testing.assert_array_equal(rest, whole[30:])


def test_a_joint_normalisers_file_is_refused_by_a_split_one(tmp_path: Path) -> None:
    dones = np.zeros((1, 1), dtype=bool)
    joint = VecNormalize(Scripted(np.ones((1, 1)), None, dones), norm_obs=False)
    save_normaliser(joint, tmp_path / "normaliser.npz")
    split = SplitRewardNormalize(Scripted(np.ones((1, 1)), None, dones))
    with pytest.raises(CorruptFileError, match="bolt_ret_mean"):
        load_normaliser(split, tmp_path / "normaliser.npz")


def test_a_summed_reward_cannot_be_normalised_after_the_fact() -> None:
    env = SplitRewardNormalize(Scripted(np.ones((1, 1)), None, np.zeros((1, 1), dtype=bool)))
    with pytest.raises(TypeError, match="normalize_reward true"):
        env.normalize_reward(np.ones(1))


@pytest.mark.parametrize(
    ("algo", "value", "error"),
    [
        ("ppo", "split", None),
        ("a2c", "split", None),
        ("ppo", True, None),
        ("dqn", "split", "on-policy"),
        ("ppo", "yes", "true, false or 'split'"),
        ("ppo", 1, "true, false or 'split'"),
    ],
)
def test_normalize_reward_takes_true_false_or_split(algo: str, value: Any, error: str | None):
    if error is None:
        check_hyperparameter_values(algo, {"normalize_reward": value})
    else:
        with pytest.raises(ConfigError, match=error):
            check_hyperparameter_values(algo, {"normalize_reward": value})


def test_a_split_run_trains_and_resumes_with_its_bolt_statistics(tmp_path: Path) -> None:
    def config(frames: int) -> TrainConfig:
        return resolve(
            TrainConfig.create(
                specs=["edge"],
                detector=DetectorConfig(kind="oracle"),
                frames=frames,
                eval_freq=1024,
                eval_episodes=2,
                checkpoint_freq=1024,
                progress_bar=False,
                overrides={"n_steps": 64, "normalize_reward": "split"},
            )
        )

    run = tmp_path / "run"
    train(config(1024), run, log=lambda _: None)
    train(config(2048), run, resume=True, log=lambda _: None)
    latest = json.loads((run / "checkpoints" / "latest.json").read_text())
    stats = np.load(run / "checkpoints" / latest["folder"] / NORMALISER)
    # one count per game per step: the resumed half added to the restored half
    assert float(stats["bolt_ret_count"]) == pytest.approx(2048, abs=1)
    assert float(stats["ret_count"]) == pytest.approx(2048, abs=1)
    # the bolt's stream is the bolt's: G(on_edge) pays ~1 a step to an agent on the edge
    # and takes it back as it leaves; the world's pays -1.5 a step and 100 at the goal
    assert float(stats["bolt_ret_var"]) > 0.1
    assert float(stats["ret_mean"]) < -1  # the step costs, without the bolt's +1s


def test_shares_that_do_not_add_up_to_the_reward_are_refused() -> None:
    class Doubled(Scripted):  # a wrapper above the bolt that changed the rewards
        def step_wait(self) -> Any:
            obs, rewards, dones, infos = super().step_wait()
            return obs, rewards * 2, dones, infos

    inner = Doubled(np.full((1, 1), 2.0), np.ones((1, 1)), np.zeros((1, 1), dtype=bool))
    env = SplitRewardNormalize(inner)
    env.reset()
    with pytest.raises(RuntimeError, match="changed them"):
        env.step(np.zeros(1, dtype=np.int64))


@pytest.mark.parametrize(("value", "said"), [("split", True), (True, False)])
def test_the_run_says_when_the_scale_no_longer_matters(value: Any, said: bool) -> None:
    config = resolve(
        TrainConfig.create(
            specs=["edge"], reward="compliance", overrides={"normalize_reward": value}
        )
    )
    assert ("the scale does not change what it learns" in describe_scheme(config)) is said


@settings(max_examples=30, deadline=None)
@given(_streams, st.sampled_from([1.0, 5.0]) | st.floats(0.1, 20.0))
def test_bolt_weight_mixes_the_normalised_shares_with_weights_adding_up_to_two(
    streams: tuple, weight: float
) -> None:
    world, bolt, dones = (np.asarray(s, dtype=np.float64) for s in streams)
    dones = dones.astype(bool)
    weighed = SplitRewardNormalize(Scripted(world, bolt, dones), gamma=GAMMA, bolt_weight=weight)
    # w = 5: a third of the world's share and five thirds of the bolt's
    expected = (2 / (1 + weight)) * (_plain(world, dones) + weight * _plain(bolt, dones))
    np.testing.assert_allclose(_play(weighed, len(world)), expected, rtol=1e-5, atol=1e-4)


@pytest.mark.parametrize(
    ("overrides", "error"),
    [
        ({"normalize_reward": "split", "bolt_weight": 5.0}, None),
        ({"normalize_reward": True, "bolt_weight": 5.0}, "only normalize_reward=split keeps apart"),
        ({"bolt_weight": 5.0}, "normalize_reward=split"),
        ({"normalize_reward": "split", "bolt_weight": 0.0}, "out of range"),
        ({"normalize_reward": "split", "bolt_weight": "heavy"}, "must be a number"),
    ],
)
def test_bolt_weight_needs_split_and_a_positive_number(
    overrides: dict[str, Any], error: str | None
) -> None:
    if error is None:
        config = resolve(
            TrainConfig.create(specs=["edge"], reward="compliance", overrides=overrides)
        )
        assert "the bolt's weighed 5 times the world's" in describe_scheme(config)
    else:
        with pytest.raises(ConfigError, match=error):
            resolve(TrainConfig.create(specs=["edge"], overrides=overrides))


@pytest.mark.parametrize(("bolted", "weight"), [(True, 7.0), (False, 1.0)])
def test_a_weighted_run_builds_its_normaliser_with_the_weight(bolted: bool, weight: float):
    # the weight reaches the normaliser a run builds (not only the class's default); an
    # unbolted control's world rewards are normalised as plainly as any other control's
    config = resolve(
        TrainConfig.create(
            specs=["edge"],
            detector=DetectorConfig(kind="oracle"),
            bolted=bolted,
            overrides={"normalize_reward": "split", "bolt_weight": 7.0},
        )
    )
    fluents = make_world("gridworld", num_envs=1, seed=0).fluent_names
    env = make_env(config, OracleDetector(fluents), training=True)
    assert isinstance(env, SplitRewardNormalize)
    assert env.bolt_weight == weight
