"""``BoltVecEnv(info_records=False)``: the learner's envs without the per-step records.

Same seed, same world, same detector: the observations, rewards, dones and terminal
observations are those of the bolt with records, and a PPO trained on either ends with the
same weights; ``noisybolt train`` builds its learner's envs without records (but with the
reward's two shares) and its evaluation envs with them.
"""

from __future__ import annotations

import numpy as np
import pytest
import torch
from stable_baselines3 import PPO
from stable_baselines3.common.vec_env import VecMonitor

from noisybolt.agents.extractor import BoltFeaturesExtractor
from noisybolt.agents.policies import BoltActorCriticPolicy
from noisybolt.bolt import Spec
from noisybolt.envs import SB3VecEnv
from noisybolt.envs.gridworld_vec import VectorGridworld
from noisybolt.perception.detectors import OracleDetector, SyntheticDetector
from noisybolt.runs import DetectorConfig, TrainConfig
from noisybolt.runs.environments import make_env
from noisybolt.runs.resolution import resolve
from noisybolt.runs.specs import resolve_spec
from noisybolt.wrappers import BoltVecEnv

SPECS = [
    resolve_spec("edge"),
    Spec(
        "F(top_right_corner)",
        terminal_reward=5.0,
        low_confidence_cost=0.5,
        reward_timing="on_entry",
    ),
]
RECORD_KEYS = ("bolt_terminal", "fluent_probs", "true_dfa_states", "confidence_bands")
#: What both write: the reward's shares (``normalize_reward: split`` reads them in training).
SHARE_KEYS = ("env_reward", "bolt_reward")


def _bolted(records: bool, *, n: int = 6, seed: int = 0) -> BoltVecEnv:
    world = VectorGridworld(num_envs=n, max_steps=20, seed=seed)
    # A noisy detector (its own seeded noise), so bands and low-confidence costs vary.
    detector = SyntheticDetector(world.fluent_names, seed=seed)
    return BoltVecEnv(
        VecMonitor(SB3VecEnv(world)), SPECS, detector, world=world, info_records=records
    )


def test_same_seed_same_steps_with_and_without_records() -> None:
    full, lean = _bolted(True), _bolted(False)
    obs_full, obs_lean = full.reset(), lean.reset()
    rng = np.random.default_rng(0)
    ended = 0
    for _ in range(150):
        for key in ("image", "dfa"):
            np.testing.assert_array_equal(obs_full[key], obs_lean[key])
        actions = rng.integers(3, size=full.num_envs)
        obs_full, r_full, d_full, i_full = full.step(actions)
        obs_lean, r_lean, d_lean, i_lean = lean.step(actions)
        np.testing.assert_array_equal(r_full, r_lean)
        np.testing.assert_array_equal(d_full, d_lean)
        for a, b in zip(i_full, i_lean, strict=True):
            assert all(key in a for key in RECORD_KEYS)
            assert not any(key in b for key in RECORD_KEYS)
            assert all(key in b for key in SHARE_KEYS)  # compared with a's below
            assert b.keys() <= a.keys()
            for key in b.keys() - {"terminal_observation", "episode"}:
                np.testing.assert_array_equal(a[key], b[key])
            if "episode" in b:  # the monitor's return and length (its clock differs)
                assert (a["episode"]["r"], a["episode"]["l"]) == (
                    b["episode"]["r"],
                    b["episode"]["l"],
                )
            if "terminal_observation" in b:
                ended += 1
                for key in ("image", "dfa"):
                    np.testing.assert_array_equal(
                        a["terminal_observation"][key], b["terminal_observation"][key]
                    )
    assert ended >= 6  # episodes ended and restarted on the way


def test_ppo_learns_the_same_as_before_records_were_left_out() -> None:
    # Before: SB3's own policy on envs with records; now: the bolt's policy without them.
    weights, rewards = [], []
    for policy, records in (("MultiInputPolicy", True), (BoltActorCriticPolicy, False)):
        model = PPO(
            policy,
            _bolted(records, n=4),
            n_steps=32,
            batch_size=64,
            n_epochs=2,
            seed=1,
            device="cpu",
            policy_kwargs={
                "features_extractor_class": BoltFeaturesExtractor,
                "normalize_images": False,
            },
        )
        model.learn(256)
        weights.append(model.policy.state_dict())
        assert model.rollout_buffer is not None
        rewards.append(model.rollout_buffer.rewards.copy())
    np.testing.assert_array_equal(rewards[0], rewards[1])
    for key, value in weights[0].items():
        assert torch.equal(value, weights[1][key]), key


@pytest.mark.parametrize("training", [True, False])
def test_train_builds_lean_learner_envs_and_recording_evaluation_envs(training: bool) -> None:
    config = resolve(
        TrainConfig.create(specs=["edge"], detector=DetectorConfig(kind="oracle"), frames=64)
    )
    world = VectorGridworld(num_envs=1, seed=0)
    env = make_env(config, OracleDetector(world.fluent_names), training=training, n_envs=2)
    env.reset()
    _, _, _, infos = env.step(np.zeros(2, dtype=np.int64))
    assert all(("true_accepting" in info) is not training for info in infos)
