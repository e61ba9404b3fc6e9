"""The bolt's policies: SB3's MultiInputPolicy with the DFA states one-hot in one scatter.

Same tensors as SB3's ``preprocess_obs``, same outputs as SB3's policies with the same
weights, and runs saved with SB3's own policy (before these existed) load, evaluate and
resume.
"""

from __future__ import annotations

import json
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import torch
from stable_baselines3 import DQN, PPO
from stable_baselines3.common.preprocessing import preprocess_obs
from stable_baselines3.common.vec_env import DummyVecEnv

from noisybolt.agents.extractor import BoltFeaturesExtractor
from noisybolt.agents.hyperparams import algorithm_class
from noisybolt.agents.policies import BoltActorCriticPolicy, BoltDQNPolicy, policy_class
from noisybolt.cli import main
from noisybolt.errors import UnknownNameError
from noisybolt.runs import DetectorConfig, TrainConfig, models, train
from noisybolt.runs.evaluation import evaluate_bolted_policy
from noisybolt.runs.models import load_model, read_model_data
from noisybolt.runs.resolution import resolve

NVEC = [3, 2, 4]


def _space(image: gym.Space | None = None) -> gym.spaces.Dict:
    return gym.spaces.Dict(
        {
            "image": image or gym.spaces.Box(0, 255, (6, 6, 3), np.uint8),
            "dfa": gym.spaces.MultiDiscrete(NVEC),
        }
    )


def test_one_hot_states_by_hand() -> None:
    extractor = BoltFeaturesExtractor(_space())
    obs = {"image": torch.zeros(2, 6, 6, 3), "dfa": torch.tensor([[2, 0, 3], [0, 1, 0]])}
    dfa = extractor.preprocess(obs, normalize_images=True)["dfa"]
    expected = [[0, 0, 1, 1, 0, 0, 0, 0, 1], [1, 0, 0, 0, 1, 1, 0, 0, 0]]
    assert dfa.dtype == torch.float32
    np.testing.assert_array_equal(dfa.numpy(), expected)


@pytest.mark.parametrize("normalize_images", [True, False])
@pytest.mark.parametrize(
    "image",
    [
        gym.spaces.Box(0, 255, (6, 6, 3), np.uint8),
        gym.spaces.Box(0, 255, (3, 6, 6), np.uint8),
        gym.spaces.Discrete(16),
        gym.spaces.Box(-1.0, 1.0, (5,), np.float32),
    ],
)
def test_preprocess_gives_sb3s_tensors(image: gym.Space, normalize_images: bool) -> None:
    space = _space(image)
    extractor = BoltFeaturesExtractor(space)
    rng = np.random.default_rng(0)
    for batch in (1, 7, 64):
        sample = [space.sample() for _ in range(batch)]
        obs = {
            key: torch.as_tensor(np.stack([np.asarray(s[key]) for s in sample]))
            for key in space.spaces
        }
        obs["dfa"] = torch.as_tensor(rng.integers(0, NVEC, (batch, len(NVEC))))
        ours = extractor.preprocess(obs, normalize_images=normalize_images)
        theirs = preprocess_obs(obs, space, normalize_images=normalize_images)
        assert isinstance(theirs, dict) and ours.keys() == theirs.keys()
        for key in ours:
            assert ours[key].dtype == theirs[key].dtype
            assert torch.equal(ours[key], theirs[key]), key


def test_belief_observations_pass_through_as_sb3_does() -> None:
    space = gym.spaces.Dict(
        {
            "image": gym.spaces.Box(0, 255, (6, 6, 3), np.uint8),
            "dfa": gym.spaces.Box(0.0, 1.0, (5,), np.float32),
        }
    )
    extractor = BoltFeaturesExtractor(space)
    assert not extractor.one_hot_states
    beliefs = torch.rand(4, 5)
    obs = {"image": torch.zeros(4, 6, 6, 3, dtype=torch.uint8), "dfa": beliefs}
    assert torch.equal(extractor.preprocess(obs, normalize_images=False)["dfa"], beliefs)


class _DictEnv(gym.Env[dict[str, np.ndarray], int]):
    """Random Dict observations in the bolt's shape; only the spaces matter here."""

    observation_space = _space(gym.spaces.Box(0, 10, (6, 6, 3), np.uint8))
    action_space = gym.spaces.Discrete(3)

    def reset(self, *, seed: int | None = None, options: object = None) -> tuple[dict, dict]:
        super().reset(seed=seed)
        return self.observation_space.sample(), {}

    def step(self, action: int) -> tuple[dict, float, bool, bool, dict]:
        return self.observation_space.sample(), 0.0, False, False, {}


@pytest.mark.parametrize("algo", ["ppo", "a2c", "dqn"])
def test_the_policies_compute_what_sb3s_compute_with_the_same_weights(algo: str) -> None:
    cls = algorithm_class(algo)
    kwargs = {"policy_kwargs": {"features_extractor_class": BoltFeaturesExtractor}}
    if algo == "dqn":
        kwargs["buffer_size"] = 16
    ours = cls(policy_class(algo), DummyVecEnv([_DictEnv]), seed=3, device="cpu", **kwargs)
    theirs = cls("MultiInputPolicy", DummyVecEnv([_DictEnv]), seed=3, device="cpu", **kwargs)
    assert type(ours.policy) is (BoltDQNPolicy if algo == "dqn" else BoltActorCriticPolicy)
    # No parameter added: SB3's weights fit as they are (strict load).
    ours.policy.load_state_dict(theirs.policy.state_dict())
    rng = np.random.default_rng(1)
    obs = {
        "image": torch.as_tensor(rng.integers(0, 11, (32, 6, 6, 3), dtype=np.uint8)),
        "dfa": torch.as_tensor(rng.integers(0, NVEC, (32, len(NVEC)))),
    }
    with torch.no_grad():
        if isinstance(ours, DQN):
            torch.testing.assert_close(ours.q_net(obs), theirs.q_net(obs), rtol=0, atol=0)
        else:
            actions = torch.as_tensor(rng.integers(0, 3, 32))
            for a, b in zip(
                ours.policy.evaluate_actions(obs, actions),
                theirs.policy.evaluate_actions(obs, actions),
                strict=True,
            ):
                assert a is not None and b is not None
                torch.testing.assert_close(a, b, rtol=0, atol=0)


def test_an_unknown_algorithm_is_named() -> None:
    with pytest.raises(UnknownNameError, match="sac"):
        policy_class("sac")


def _quiet(_: str) -> None:
    pass


@pytest.mark.parametrize("algo", ["ppo", "dqn"])
def test_a_run_saved_with_sb3s_own_policy_loads_evaluates_and_resumes(
    algo: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    config = resolve(
        TrainConfig.create(
            specs=["edge"],
            algo=algo,
            detector=DetectorConfig(kind="oracle"),
            frames=512,
            eval_freq=0,
            eval_episodes=2,
            checkpoint_freq=256,
            progress_bar=False,
            overrides={"learning_starts": 64} if algo == "dqn" else {"n_steps": 32},
        )
    )
    run = tmp_path / "run"
    with monkeypatch.context() as old:  # what make_model built before these policies
        old.setattr(models, "policy_class", lambda _: "MultiInputPolicy")
        train(config, run, log=_quiet)
    saved = read_model_data(run / "model.zip")["policy_class"][":type:"]
    assert saved == "<class 'abc.ABCMeta'>"
    old_model = (DQN if algo == "dqn" else PPO).load(run / "model.zip", device="cpu")
    sb3_name = "MultiInputPolicy" if algo == "dqn" else "MultiInputActorCriticPolicy"
    assert type(old_model.policy).__name__ == sb3_name
    from noisybolt.envs import make_world
    from noisybolt.perception.detectors import OracleDetector
    from noisybolt.runs.environments import make_env

    fluents = make_world(config.world_config.name, num_envs=1, seed=0).fluent_names
    env = make_env(config, OracleDetector(fluents), training=False, n_envs=4)
    model = load_model(run / "model.zip", config, env)
    assert isinstance(model.policy, BoltDQNPolicy if algo == "dqn" else BoltActorCriticPolicy)
    obs = env.reset()
    np.testing.assert_array_equal(
        model.predict(obs, deterministic=True)[0], old_model.predict(obs, deterministic=True)[0]
    )
    # Evaluation of the same envs: the same episodes, record for record.
    results = []
    for loaded in (old_model, model):
        results.append(
            evaluate_bolted_policy(
                lambda obs, m=loaded: m.predict(obs, deterministic=True)[0],
                make_env(config, OracleDetector(fluents), training=False, n_envs=4),
                n_episodes=8,
                spec_names=["edge"],
            )
        )
    assert results[0] == results[1]
    assert main(["evaluate", str(run), "--episodes", "2"]) == 0
    more = TrainConfig.from_dict({**json.loads((run / "config.json").read_text()), "frames": 768})
    assert train(more, run, resume=True, log=_quiet).frames == 768
