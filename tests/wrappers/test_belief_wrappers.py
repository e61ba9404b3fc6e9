"""Both bolt wrappers under ``tracking="belief"``, and threshold tracking left unchanged."""

from __future__ import annotations

from typing import Any, cast

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from stable_baselines3 import PPO

from noisybolt.agents.extractor import BoltFeaturesExtractor
from noisybolt.bolt import BeliefSettings, RestrainingBolt
from noisybolt.envs import SB3VecEnv
from noisybolt.envs.gridworld import GridworldEnv
from noisybolt.envs.gridworld_vec import VectorGridworld
from noisybolt.errors import ConfidenceLevelError, UnknownNameError
from noisybolt.perception.detectors import OracleDetector, SyntheticDetector
from noisybolt.runs.specs import resolve_spec
from noisybolt.wrappers import BoltVecEnv, RestrainingBoltWrapper

SPECS = [resolve_spec("edge"), resolve_spec("one_corner_once")]


def _vec(tracking: str | None, *, seed: int = 0, **kwargs: object) -> BoltVecEnv:
    world = VectorGridworld(num_envs=4, max_steps=15, seed=seed)
    detector = SyntheticDetector(world.fluent_names, seed=7)
    extra = {} if tracking is None else {"tracking": tracking}
    return BoltVecEnv(SB3VecEnv(world), SPECS, detector, world=world, **extra, **kwargs)  # type: ignore[arg-type]


def test_explicit_threshold_tracking_is_bit_identical_to_the_default() -> None:
    default, threshold = _vec(None), _vec("threshold")
    obs_a: Any = default.reset()
    obs_b: Any = threshold.reset()
    rng = np.random.default_rng(0)
    for _ in range(80):
        for key in ("image", "dfa"):
            np.testing.assert_array_equal(obs_a[key], obs_b[key])
        actions = rng.integers(4, size=4)
        obs_a, rew_a, done_a, info_a = default.step(actions)
        obs_b, rew_b, done_b, info_b = threshold.step(actions)
        assert rew_a.tobytes() == rew_b.tobytes()
        np.testing.assert_array_equal(done_a, done_b)
        for a, b in zip(info_a, info_b, strict=True):
            for key in ("bolt_reward", "dfa_states", "dfa_accepting", "bolt_low_confidence"):
                np.testing.assert_array_equal(a[key], b[key])
    assert default.observation_space == threshold.observation_space


def test_belief_observation_is_a_box_of_distributions_sb3_can_read() -> None:
    env = _vec("belief")
    space = cast(gym.spaces.Dict, env.observation_space)["dfa"]
    assert isinstance(space, gym.spaces.Box)
    assert space.shape == (sum(env.bolt.n_states),)
    obs: Any = env.reset()
    rng = np.random.default_rng(1)
    offsets = np.cumsum((0, *env.bolt.n_states))[:-1]
    for _ in range(30):
        assert env.observation_space.contains({"image": obs["image"][0], "dfa": obs["dfa"][0]})
        np.testing.assert_allclose(np.add.reduceat(obs["dfa"], offsets, axis=1), 1.0, atol=1e-5)
        obs, *_ = env.step(rng.integers(4, size=4))
    # SB3 end to end: PPO with the project's extractor reads the Box beside the image.
    model = PPO(
        "MultiInputPolicy",
        env,
        n_steps=8,
        batch_size=16,
        n_epochs=1,
        seed=0,
        policy_kwargs={"features_extractor_class": BoltFeaturesExtractor},
    )
    model.learn(32)
    action, _ = model.predict(obs, deterministic=True)
    assert action.shape == (4,)


def test_argmax_observation_is_multidiscrete_of_the_most_likely_states() -> None:
    env = _vec("belief", belief=BeliefSettings(observation="argmax"))
    assert isinstance(cast(gym.spaces.Dict, env.observation_space)["dfa"], gym.spaces.MultiDiscrete)
    obs: Any = env.reset()
    for _ in range(10):
        np.testing.assert_array_equal(obs["dfa"], env.bolt.states)
        obs, *_ = env.step(np.zeros(4, dtype=int))


def test_bad_tracking_input_is_refused_by_the_wrappers() -> None:
    with pytest.raises(UnknownNameError):
        _vec("bayes")
    with pytest.raises(ConfidenceLevelError):
        _vec("belief", belief=BeliefSettings(confidence=0.4))


def test_single_wrapper_passes_gymnasium_checks_under_belief_tracking() -> None:
    env = GridworldEnv()
    wrapped = RestrainingBoltWrapper(
        env, SPECS, OracleDetector(env.fluent_names), tracking="belief"
    )
    check_env(wrapped, skip_render_check=True)


def test_belief_wrapped_reward_is_env_reward_plus_an_independent_belief_bolt() -> None:
    # Same seed, same detector draws: the wrapper's bolt terms are what a belief bolt fed
    # the step's fluent probabilities pays.
    plain, bolted = GridworldEnv(max_steps=30), GridworldEnv(max_steps=30)
    wrapped = RestrainingBoltWrapper(
        bolted, SPECS, SyntheticDetector(bolted.fluent_names, seed=3), tracking="belief"
    )
    reference = RestrainingBolt(SPECS, bolted.fluent_names, tracking="belief")
    rng = np.random.default_rng(0)
    plain.reset(seed=1)
    _, info = wrapped.reset(seed=1)
    reference.reset(info["fluent_probs"][None].astype(np.float64))
    for _ in range(150):
        action = int(rng.integers(4))
        obs, reward, term, trunc, _ = plain.step(action)
        wobs, wreward, _wterm, _wtrunc, info = wrapped.step(action)
        np.testing.assert_array_equal(obs, wobs["image"])
        out = reference.step(info["fluent_probs"][None].astype(np.float64), done=term or trunc)
        assert info["env_reward"] == reward
        assert info["bolt_reward"] == pytest.approx(float(out.total[0]))
        assert wreward == pytest.approx(float(reward) + float(out.total[0]))
        np.testing.assert_array_equal(info["dfa_accepting"], out.accepting[0])
        np.testing.assert_allclose(wobs["dfa"], reference.beliefs[0], atol=1e-6)
        if term or trunc:
            plain.reset()
            _, info = wrapped.reset()
            reference.reset(info["fluent_probs"][None].astype(np.float64))


def test_batched_belief_bolt_equals_single_wrappers() -> None:
    n, steps = 4, 100
    world = VectorGridworld(num_envs=n, max_steps=15, seed=0)
    batched = BoltVecEnv(
        SB3VecEnv(world), SPECS, OracleDetector(world.fluent_names), world=world, tracking="belief"
    )
    singles = []
    for _ in range(n):
        env = GridworldEnv(max_steps=15)
        singles.append(
            RestrainingBoltWrapper(env, SPECS, OracleDetector(env.fluent_names), tracking="belief")
        )
    obs: Any = batched.reset()
    single_obs = [s.reset(seed=0)[0] for s in singles]
    rng = np.random.default_rng(0)
    n_done = 0
    for _ in range(steps):
        for i in range(n):
            np.testing.assert_allclose(obs["dfa"][i], single_obs[i]["dfa"], atol=1e-6)
        actions = rng.integers(4, size=n)
        obs, rewards, dones, infos = batched.step(actions)
        for i, single in enumerate(singles):
            sobs, sreward, _sterm, _strunc, sinfo = single.step(int(actions[i]))
            assert rewards[i] == pytest.approx(sreward, abs=1e-4)
            np.testing.assert_array_equal(infos[i]["dfa_accepting"], sinfo["dfa_accepting"])
            # The oracle is sure: the bolt's decisions are the truth's.
            np.testing.assert_array_equal(infos[i]["dfa_accepting"], infos[i]["true_accepting"])
            if dones[i]:
                n_done += 1
                terminal = infos[i]["terminal_observation"]
                np.testing.assert_allclose(terminal["dfa"], sobs["dfa"], atol=1e-6)
                sobs, _ = single.reset()
            single_obs[i] = sobs
    assert n_done >= n


def test_single_wrapper_with_explicit_threshold_is_bit_identical_to_the_default() -> None:
    envs = [GridworldEnv(max_steps=30), GridworldEnv(max_steps=30)]
    default = RestrainingBoltWrapper(
        envs[0], SPECS, SyntheticDetector(envs[0].fluent_names, seed=3)
    )
    threshold = RestrainingBoltWrapper(
        envs[1], SPECS, SyntheticDetector(envs[1].fluent_names, seed=3), tracking="threshold"
    )
    obs_a, _ = default.reset(seed=2)
    obs_b, _ = threshold.reset(seed=2)
    rng = np.random.default_rng(0)
    for _ in range(120):
        np.testing.assert_array_equal(obs_a["dfa"], obs_b["dfa"])
        assert obs_a["dfa"].dtype == obs_b["dfa"].dtype == np.int64
        action = int(rng.integers(4))
        obs_a, rew_a, term_a, trunc_a, info_a = default.step(action)
        obs_b, rew_b, term_b, trunc_b, info_b = threshold.step(action)
        assert rew_a == rew_b and (term_a, trunc_a) == (term_b, trunc_b)
        np.testing.assert_array_equal(info_a["bolt_terminal"], info_b["bolt_terminal"])
        if term_a or trunc_a:
            obs_a, _ = default.reset()
            obs_b, _ = threshold.reset()


def test_a_condition_met_in_one_step_is_credited_only_below_the_two_step_dwell() -> None:
    # FrozenLake, right along the top row: the agent is on cell 1 for exactly one step,
    # then on cell 2. Belief tracking's default model has a fluent stay true two steps
    # once true (min_dwell=2, against one-frame glitches): even the oracle's certainty
    # that at1 held for one step is not believed, and the spec is not credited; with
    # min_dwell=1 it is, as threshold tracking credits it.
    from noisybolt.envs.labels import FluentLabels

    fluents = {"at1": lambda e: e.s == 1, "at2": lambda e: e.s == 2}
    spec = "F(at1 & X(at2))"
    accepted = {}
    for name, kwargs in {
        "threshold": {},
        "belief, min_dwell 2": {"tracking": "belief"},
        "belief, min_dwell 1": {"tracking": "belief", "belief": BeliefSettings(min_dwell=1)},
    }.items():
        lake = FluentLabels(
            gym.make("FrozenLake-v1", is_slippery=False, render_mode="rgb_array"), fluents=fluents
        )
        bolted = RestrainingBoltWrapper(lake, [spec], OracleDetector(lake.fluent_names), **kwargs)
        bolted.reset(seed=0)
        for _ in range(3):  # right: cells 1, 2, 3
            *_, info = bolted.step(2)
        assert info["true_accepting"].tolist() == [True]
        accepted[name] = bool(info["dfa_accepting"][0])
    assert accepted == {
        "threshold": True,
        "belief, min_dwell 2": False,
        "belief, min_dwell 1": True,
    }


def test_belief_tracking_without_base_rates_is_warned_of_in_the_api() -> None:
    import warnings

    from noisybolt.errors import UnknownBaseRatesWarning

    def warned(belief: BeliefSettings | None) -> list[str]:
        env = GridworldEnv()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            RestrainingBoltWrapper(
                env, SPECS, OracleDetector(env.fluent_names), tracking="belief", belief=belief
            )
        return [str(w.message) for w in caught if w.category is UnknownBaseRatesWarning]

    [message] = warned(None)
    assert "belief_settings_from_play" in message
    assert len(warned(BeliefSettings())) == 1
    assert warned(BeliefSettings(base_rates=0.1)) == []
