"""The bolt wrappers: wrapped vs unwrapped runs, hand-computed rewards, batched == single."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from noisybolt.bolt import Spec
from noisybolt.envs.gridworld import GridAction, GridworldEnv
from noisybolt.envs.gridworld_vec import VectorGridworld
from noisybolt.errors import IncompatibleError, UnknownFluentError
from noisybolt.perception.detectors import OracleDetector, SyntheticDetector
from noisybolt.runs.specs import resolve_spec
from noisybolt.wrappers import BoltVecEnv, RestrainingBoltWrapper

SPECS = [resolve_spec("edge"), resolve_spec("one_corner_once")]


def _oracle(env: GridworldEnv | VectorGridworld) -> OracleDetector:
    return OracleDetector(env.fluent_names)


def test_wrapped_env_passes_gymnasium_checks() -> None:
    env = GridworldEnv()
    check_env(RestrainingBoltWrapper(env, SPECS, _oracle(env)), skip_render_check=True)


def test_observation_is_a_dict_of_image_and_dfa_states() -> None:
    env = GridworldEnv()
    wrapped = RestrainingBoltWrapper(env, SPECS, _oracle(env))
    assert isinstance(wrapped.observation_space, gym.spaces.Dict)
    assert isinstance(wrapped.observation_space["dfa"], gym.spaces.MultiDiscrete)
    assert wrapped.observation_space["dfa"].nvec.tolist() == list(wrapped.bolt.n_states)
    obs, _ = wrapped.reset(seed=0)
    assert obs["dfa"].shape == (2,)
    assert wrapped.observation_space.contains(obs)


def test_wrapped_reward_is_env_reward_plus_bolt_terms_from_the_same_seed() -> None:
    plain, bolted_env = GridworldEnv(max_steps=30), GridworldEnv(max_steps=30)
    detector = SyntheticDetector(bolted_env.fluent_names, seed=3)
    wrapped = RestrainingBoltWrapper(bolted_env, SPECS, detector)
    rng = np.random.default_rng(0)
    plain.reset(seed=1)
    wrapped.reset(seed=1)
    for _ in range(200):
        action = int(rng.integers(4))
        obs, reward, term, trunc, _ = plain.step(action)
        wobs, wreward, wterm, wtrunc, info = wrapped.step(action)
        np.testing.assert_array_equal(obs, wobs["image"])
        assert (term, trunc) == (wterm, wtrunc)
        assert info["env_reward"] == reward
        terms = (
            info["bolt_terminal"].sum() + info["bolt_low_confidence"].sum() + info["bolt_carried"]
        )
        assert info["bolt_reward"] == pytest.approx(terms)
        assert wreward == pytest.approx(reward + info["bolt_reward"])
        if term or trunc:
            plain.reset()
            wrapped.reset()


def test_hand_computed_rewards_along_the_edge_to_the_goal() -> None:
    # G(on_edge), +1 per accepting step, oracle detector (no low-confidence costs).
    env = GridworldEnv()
    spec = Spec("G(on_edge)", terminal_reward=1.0, low_confidence_cost=0.5, name="edge")
    wrapped = RestrainingBoltWrapper(env, [spec], _oracle(env))
    wrapped.reset(seed=0)
    script = [GridAction.FORWARD] * 3 + [GridAction.RIGHT] + [GridAction.FORWARD] * 3
    rewards = [wrapped.step(int(a))[1] for a in script]
    # First step: -1.5 env, +1 accepting, +1 carried from the reset transition.
    assert rewards[0] == pytest.approx(-1.5 + 1 + 1)
    assert rewards[1:-1] == pytest.approx([-0.5] * 5)
    assert rewards[-1] == pytest.approx(98.5 + 1)


def test_low_confidence_fluent_on_the_taken_edge_is_charged() -> None:
    env = GridworldEnv()
    spec = Spec("G(on_edge)", terminal_reward=1.0, low_confidence_cost=0.5, name="edge")

    class DimEdge(OracleDetector):
        def predict(self, images, *, truth=None):  # type: ignore[no-untyped-def]
            probs = super().predict(images, truth=truth)
            probs[:, 0] = np.where(probs[:, 0] > 0.5, 0.7, 0.1)  # on_edge seen dimly
            return probs

    wrapped = RestrainingBoltWrapper(env, [spec], DimEdge(env.fluent_names))
    wrapped.reset(seed=0)
    _, reward, _, _, info = wrapped.step(int(GridAction.FORWARD))
    assert info["bolt_low_confidence"].tolist() == [-0.5]
    assert reward == pytest.approx(-1.5 + 1 - 0.5 + (1 - 0.5))  # carried reset term too


def test_true_dfa_states_follow_ground_truth_not_the_detector() -> None:
    env = GridworldEnv()

    class Blind(OracleDetector):
        def predict(self, images, *, truth=None):  # type: ignore[no-untyped-def]
            return np.zeros((len(images), len(self.fluent_names)), np.float32)

    wrapped = RestrainingBoltWrapper(env, [resolve_spec("edge")], Blind(env.fluent_names))
    wrapped.reset(seed=0)
    _, _, _, _, info = wrapped.step(int(GridAction.FORWARD))
    assert info["true_accepting"].tolist() == [True]  # really on the edge
    assert info["bolt_terminal"].tolist() == [0.0]  # the blind bolt thinks it left it
    assert info["dfa_accepting"].tolist() == [False]
    on_edge = list(env.fluent_names).index("on_edge")
    assert info["true_fluents"][on_edge] and not info["fluent_probs"][on_edge]


def test_spec_over_an_unknown_fluent_lists_the_worlds_fluents() -> None:
    env = GridworldEnv()
    with pytest.raises(UnknownFluentError, match="on_edge"):
        RestrainingBoltWrapper(env, [resolve_spec("F(lava)")], _oracle(env))


def test_detector_for_other_fluents_is_refused() -> None:
    env = GridworldEnv()
    with pytest.raises(IncompatibleError, match="detector predicts"):
        RestrainingBoltWrapper(env, SPECS, OracleDetector(["on_edge"]))


@pytest.mark.parametrize("obs_mode", ["grid", "view"])
def test_batched_bolt_equals_single_wrappers(obs_mode: str) -> None:
    from noisybolt.envs import SB3VecEnv

    n, steps = 4, 120
    world = VectorGridworld(num_envs=n, obs_mode=obs_mode, max_steps=15, seed=0)
    batched = BoltVecEnv(SB3VecEnv(world), SPECS, _oracle(world), world=world)
    singles = []
    for _ in range(n):
        env = GridworldEnv(obs_mode=obs_mode, max_steps=15)
        singles.append(RestrainingBoltWrapper(env, SPECS, _oracle(env)))
    obs = batched.reset()
    single_obs = [s.reset(seed=0)[0] for s in singles]
    rng = np.random.default_rng(0)
    n_done = 0
    for _ in range(steps):
        for i in range(n):
            np.testing.assert_array_equal(obs["image"][i], single_obs[i]["image"])
            np.testing.assert_array_equal(obs["dfa"][i], single_obs[i]["dfa"])
        actions = rng.integers(4, size=n)
        obs, rewards, dones, infos = batched.step(actions)
        for i, single in enumerate(singles):
            sobs, sreward, sterm, strunc, sinfo = single.step(int(actions[i]))
            assert rewards[i] == pytest.approx(sreward, abs=1e-5)
            assert dones[i] == (sterm or strunc)
            for key in ("true_dfa_states", "true_fluents", "dfa_accepting"):
                np.testing.assert_array_equal(infos[i][key], sinfo[key])
            if dones[i]:
                n_done += 1
                terminal = infos[i]["terminal_observation"]
                np.testing.assert_array_equal(terminal["image"], sobs["image"])
                np.testing.assert_array_equal(terminal["dfa"], sobs["dfa"])
                sobs, _ = single.reset()
            single_obs[i] = sobs
    assert n_done >= n  # the comparison crossed episode boundaries


@pytest.mark.parametrize(
    "space",
    [
        gym.spaces.Dict({"pos": gym.spaces.Discrete(4)}),
        gym.spaces.Tuple((gym.spaces.Discrete(32), gym.spaces.Discrete(11))),
    ],
)
def test_a_structured_observation_is_refused_by_both_bolts_before_anything_is_built(
    space: gym.Space,
) -> None:
    # SB3 takes no space nested under the bolt's "image" entry; it used to fail inside
    # PPO's constructor with NotImplementedError. Refused before a classifier is trained.
    from gymnasium.vector import AutoresetMode, SyncVectorEnv

    from noisybolt.envs import SB3VecEnv
    from noisybolt.errors import ObservationSpaceError
    from noisybolt.wrappers import BoltVecEnv

    class Structured(gym.Env):
        observation_space = space
        action_space = gym.spaces.Discrete(2)
        fluent_names = ("x",)

    with pytest.raises(ObservationSpaceError, match="FlattenObservation"):
        RestrainingBoltWrapper(Structured(), ["F(x)"], "classifier")
    vector = SyncVectorEnv([Structured], autoreset_mode=AutoresetMode.SAME_STEP)
    with pytest.raises(ObservationSpaceError, match='nested under the bolt\'s "image"'):
        BoltVecEnv(SB3VecEnv(vector), ["F(x)"], OracleDetector(("x",)))


def test_a_seeded_reset_sees_the_same_synthetic_noise_again() -> None:
    # The env's camera and the detector's noise both restart from reset(seed=): two
    # seeded episodes with the same actions read the same probabilities, another seed not.
    env = GridworldEnv()
    wrapped = RestrainingBoltWrapper(env, SPECS, SyntheticDetector(env.fluent_names, seed=0))

    def episode(seed: int) -> np.ndarray:
        probs = [wrapped.reset(seed=seed)[1]["fluent_probs"]]
        for action in [0, 1, 2, 0, 0, 3, 1]:
            probs.append(wrapped.step(action)[4]["fluent_probs"])
        return np.array(probs)

    first = episode(3)
    np.testing.assert_array_equal(first, episode(3))
    assert not np.array_equal(first, episode(4))
