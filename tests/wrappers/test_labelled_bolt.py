"""The bolt over a user's env labelled with FluentLabels (FrozenLake; see tests/envs/test_labels.py
for its map): the single wrapper reads ``info`` only, and the batched one equals it."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from noisybolt.bolt import Spec
from noisybolt.envs.labels import FluentLabels
from noisybolt.errors import (
    ConfigError,
    UnknownFluentError,
    UnknownNameError,
    UnlabelledEnvError,
    UnseenFluentError,
)
from noisybolt.perception.detectors import OracleDetector, SyntheticDetector
from noisybolt.wrappers import BoltVecEnv, RestrainingBoltWrapper, make_bolted_vec_env
from noisybolt.wrappers._inputs import coerce_specs

HOLES = (5, 7, 11, 12)
FLUENTS = {
    "at_goal": lambda lake: lake.s == 15,
    "in_hole": lambda lake: int(lake.s) in HOLES,
    "top_row": lambda lake: lake.s < 4,
}
SPECS = [
    "G(!in_hole)",
    Spec(
        "F(top_row & X(!top_row))", terminal_reward=2.0, low_confidence_cost=0.5, name="leave_top"
    ),
]


def lake(slippery: bool = False, **kwargs: Any) -> FluentLabels:
    env = gym.make("FrozenLake-v1", render_mode="rgb_array", is_slippery=slippery)
    return FluentLabels(env, fluents=FLUENTS, success="at_goal", **kwargs)


def test_labelled_env_passes_gymnasium_checks() -> None:
    check_env(RestrainingBoltWrapper(lake(), SPECS, "oracle"), skip_render_check=True)


def test_hand_computed_rewards_of_a_text_spec() -> None:
    # "G(top_row)" as text: +1 per accepting step, oracle (no low-confidence cost).
    env = RestrainingBoltWrapper(lake(), "G(top_row)", "oracle")
    obs, info = env.reset(seed=0)
    assert env.bolt.specs[0].terminal_reward == 1.0
    assert env.bolt.specs[0].low_confidence_cost == 0.5
    assert obs["image"] == 0 and info["true_accepting"].tolist() == [True]
    _, r1, *_ = env.step(2)  # 0 -> 1: still on the top row, +1 and +1 carried from reset
    _, r2, terminated, _, info = env.step(1)  # 1 -> 5: a hole, off the top row for good
    assert (r1, r2) == (2.0, 0.0)
    assert terminated and info["dfa_violated"].tolist() == [True]


def test_wrapped_reward_is_env_reward_plus_bolt_terms_from_the_same_seed() -> None:
    plain = gym.make("FrozenLake-v1", is_slippery=True)
    wrapped = RestrainingBoltWrapper(lake(slippery=True), SPECS, "synthetic", seed=3)
    assert isinstance(wrapped._detector, SyntheticDetector)
    plain.reset(seed=1)
    wrapped.reset(seed=1)
    rng = np.random.default_rng(0)
    for _ in range(150):
        action = int(rng.integers(4))
        obs, reward, term, trunc, _ = plain.step(action)
        wobs, wreward, wterm, wtrunc, info = wrapped.step(action)
        assert obs == wobs["image"] and (term, trunc) == (wterm, wtrunc)
        assert info["env_reward"] == reward
        assert wreward == pytest.approx(reward + info["bolt_reward"])
        assert info["true_fluents"].tolist() == [obs == 15, obs in HOLES, obs < 4]
        if term or trunc:
            plain.reset()
            wrapped.reset()


def test_the_bolt_reads_info_not_the_env() -> None:
    # An env that declares fluents but labels nothing is refused at reset, naming the key.
    class Declares(gym.Wrapper):
        fluent_names = ("top_row",)

    env = RestrainingBoltWrapper(Declares(gym.make("FrozenLake-v1")), ["G(top_row)"], "oracle")
    with pytest.raises(UnlabelledEnvError, match="'bolt_image'"):
        env.reset(seed=0)


def test_unlabelled_env_is_refused_at_construction() -> None:
    with pytest.raises(UnlabelledEnvError, match="FluentLabels"):
        RestrainingBoltWrapper(gym.make("FrozenLake-v1"), ["G(a)"], "oracle")


def test_labels_under_another_wrapper_are_found() -> None:
    env = gym.wrappers.TimeLimit(lake(), max_episode_steps=3)
    bolted = RestrainingBoltWrapper(env, ["G(top_row)"], "oracle")
    bolted.reset(seed=0)
    *_, truncated, _ = bolted.step(0)
    *_, truncated, _ = bolted.step(0)
    *_, truncated, info = bolted.step(0)
    assert truncated and info["true_accepting"].tolist() == [True]


def test_bad_specs_and_detectors_are_named() -> None:
    with pytest.raises(UnknownFluentError, match="top_row"):
        RestrainingBoltWrapper(lake(), ["G(lava)"], "oracle")
    with pytest.raises(UnknownNameError, match="classifier, oracle, synthetic"):
        RestrainingBoltWrapper(lake(), ["G(top_row)"], "psychic")  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match="FluentDetector"):
        RestrainingBoltWrapper(lake(), ["G(top_row)"], object())  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match="at least one spec"):
        RestrainingBoltWrapper(lake(), [], "oracle")


def test_classifier_by_name_is_trained_on_the_envs_own_camera() -> None:
    def lamp(env: gym.Env) -> np.ndarray:  # bright on the top row, dark elsewhere
        return np.full((8, 8, 3), 230 if env.unwrapped.s < 4 else 20, dtype=np.uint8)

    env = FluentLabels(
        gym.make("FrozenLake-v1", is_slippery=True),
        fluents={"top_row": FLUENTS["top_row"]},
        camera=lamp,
    )
    bolted = RestrainingBoltWrapper(env, ["G(top_row)"], "classifier", classifier_samples=300)
    assert not bolted._detector.needs_truth
    _, info = bolted.reset(seed=0)
    assert info["fluent_probs"][0] > 0.9  # the start is on the top row
    _, _, _, _, info = bolted.step(1)  # 0 -> 4 (or slips along the row)
    state_top = info["true_fluents"][0]
    assert (info["fluent_probs"][0] > 0.5) == state_top


def test_classifier_by_name_refuses_samples_that_never_show_a_spec_fluent() -> None:
    # 'off_lake' (the agent off the 4x4 lake) holds in no state the lake reaches, so the
    # samples never show it true and a classifier could not learn it: refused before any
    # training, by both wrappers, in their own keyword arguments' terms.
    def lamp(env: gym.Env) -> np.ndarray:
        return np.full((8, 8, 3), 12 * env.unwrapped.s, dtype=np.uint8)

    def labelled() -> FluentLabels:
        fluents = {"off_lake": lambda e: not 0 <= int(e.s) < 16, "top_row": FLUENTS["top_row"]}
        return FluentLabels(gym.make("FrozenLake-v1"), fluents=fluents, camera=lamp)

    with pytest.raises(UnseenFluentError, match="never show 'off_lake' true") as caught:
        RestrainingBoltWrapper(labelled(), ["G(!off_lake)"], "classifier", classifier_samples=64)
    assert "classifier_samples=N" in str(caught.value) and "--" not in str(caught.value)
    assert caught.value.fluents == ("off_lake",)
    with pytest.raises(UnseenFluentError, match="never show 'off_lake' true"):
        make_bolted_vec_env(labelled, 2, ["F(top_row) | G(!off_lake)"], "classifier")


# ------------------------------------------------------------------ batched


def test_batched_bolt_equals_single_wrappers_across_episodes() -> None:
    n, seed = 4, 7
    batched = make_bolted_vec_env(lambda: lake(slippery=True), n, SPECS, "oracle", seed=seed)
    assert isinstance(batched, BoltVecEnv)
    singles = [RestrainingBoltWrapper(lake(slippery=True), SPECS, "oracle") for _ in range(n)]
    obs = batched.reset()
    single_resets = [s.reset(seed=seed + i) for i, s in enumerate(singles)]
    single_obs = [o for o, _ in single_resets]
    for i, (_, info) in enumerate(single_resets):  # the first letter, as each single says it
        keys = ("true_fluents", "fluent_probs", "dfa_states", "true_dfa_states")
        keys += ("dfa_accepting", "dfa_violated", "confidence_bands")  # as a step's info
        for key in keys:
            np.testing.assert_array_equal(batched.reset_infos[i][key], info[key])
        assert batched.reset_infos[i]["true_accepting"].tolist() == info["true_accepting"].tolist()
    rng = np.random.default_rng(0)
    n_done = n_success = 0
    for _ in range(120):
        for i in range(n):
            assert obs["image"][i] == single_obs[i]["image"]
            np.testing.assert_array_equal(obs["dfa"][i], single_obs[i]["dfa"])
        actions = rng.integers(4, size=n)
        obs, rewards, dones, infos = batched.step(actions)
        for i, single in enumerate(singles):
            sobs, sreward, sterm, strunc, sinfo = single.step(int(actions[i]))
            assert rewards[i] == pytest.approx(sreward, abs=1e-6)
            assert dones[i] == (sterm or strunc)
            for key in ("true_dfa_states", "true_fluents", "dfa_accepting", "fluent_probs"):
                np.testing.assert_array_equal(infos[i][key], sinfo[key])
            if dones[i]:
                n_done += 1
                assert infos[i]["is_success"] == sinfo["is_success"]
                n_success += bool(sinfo["is_success"])
                terminal = infos[i]["terminal_observation"]
                assert terminal["image"] == sobs["image"]
                np.testing.assert_array_equal(terminal["dfa"], sobs["dfa"])
                sobs, _ = single.reset()
            single_obs[i] = sobs
    assert n_done >= n  # the comparison crossed episode boundaries


class _Unsure:
    """Reads every fluent right, never surely: 0.8 where it holds, 0.3 where it does not
    (the same for every env, so batched and single bolts see the same probabilities)."""

    needs_truth = True
    fluent_names = tuple(FLUENTS)

    def predict(self, images: np.ndarray, *, truth: np.ndarray | None = None) -> np.ndarray:
        assert truth is not None
        return np.where(truth, 0.8, 0.3).astype(np.float32)


def test_batched_belief_bolt_equals_single_wrappers_on_a_users_env() -> None:
    n, seed = 3, 5
    batched = make_bolted_vec_env(
        lambda: lake(slippery=True), n, SPECS, _Unsure(), seed=seed, tracking="belief"
    )
    singles = [
        RestrainingBoltWrapper(lake(slippery=True), SPECS, _Unsure(), tracking="belief")
        for _ in range(n)
    ]
    obs = batched.reset()
    single_obs = [s.reset(seed=seed + i)[0] for i, s in enumerate(singles)]
    assert obs["dfa"].dtype == np.float32 and not np.isin(obs["dfa"], (0.0, 1.0)).all()
    rng = np.random.default_rng(1)
    n_done = 0
    for _ in range(80):
        for i in range(n):
            np.testing.assert_allclose(obs["dfa"][i], single_obs[i]["dfa"], atol=1e-6)
        actions = rng.integers(4, size=n)
        obs, rewards, dones, infos = batched.step(actions)
        for i, single in enumerate(singles):
            sobs, sreward, sterm, strunc, sinfo = single.step(int(actions[i]))
            assert rewards[i] == pytest.approx(sreward, abs=1e-5)
            assert dones[i] == (sterm or strunc)
            np.testing.assert_array_equal(infos[i]["dfa_accepting"], sinfo["dfa_accepting"])
            if dones[i]:
                n_done += 1
                sobs, _ = single.reset()
            single_obs[i] = sobs
    assert n_done >= n


def test_batched_bolt_reports_goals_to_the_monitor() -> None:
    venv = make_bolted_vec_env(lake, 1, ["G(!in_hole)"], seed=0)
    venv.reset()
    for action in (2, 2, 1, 1, 1):
        venv.step(np.array([action]))
    _, _, dones, infos = venv.step(np.array([2]))
    assert dones[0] and infos[0]["is_success"] is True
    assert infos[0]["episode"]["r"] == 1.0  # the env's return, logged below the bolt


def test_make_bolted_vec_env_refuses_bad_input() -> None:
    with pytest.raises(ConfigError, match="n_envs"):
        make_bolted_vec_env(lake, 0, ["G(top_row)"])
    with pytest.raises(UnlabelledEnvError):
        make_bolted_vec_env(lambda: gym.make("FrozenLake-v1"), 2, ["G(top_row)"])
    with pytest.raises(UnknownFluentError):
        make_bolted_vec_env(lake, 2, ["G(lava)"], OracleDetector(list(FLUENTS)))


def test_batched_bolt_reads_the_worlds_batched_info_through_sb3_vec_env() -> None:
    from stable_baselines3.common.vec_env import DummyVecEnv

    from noisybolt.envs import SB3VecEnv
    from noisybolt.envs.labelled_vec import LabelledVectorEnv

    specs, oracle = coerce_specs("G(top_row)"), OracleDetector(list(FLUENTS))
    with pytest.raises(ConfigError, match="SB3VecEnv"):
        BoltVecEnv(DummyVecEnv([lake]), specs, oracle)  # type: ignore[arg-type]
    world = LabelledVectorEnv([lake, lake])
    with pytest.raises(ConfigError, match="not the vector env under"):
        BoltVecEnv(SB3VecEnv(world), specs, oracle, world=LabelledVectorEnv([lake]))

    class ForgetsEndedEpisodes(gym.vector.VectorWrapper):
        """Drops the ended episodes' labels from final_info (what the bolt must read)."""

        def step(self, actions: Any) -> Any:
            obs, rewards, terminated, truncated, info = self.env.step(actions)
            info.get("final_info", {}).pop("bolt_image", None)
            return obs, rewards, terminated, truncated, info

    forgetful = ForgetsEndedEpisodes(LabelledVectorEnv([lake]))
    forgetful.fluent_names = world.fluent_names  # type: ignore[attr-defined]
    bolted = BoltVecEnv(SB3VecEnv(forgetful), specs, oracle)  # type: ignore[arg-type]
    bolted.reset()
    for action in (1, 1, 1, 1, 1, 1, 1, 1):  # down until the lake ends the episode
        bolted.step_async(np.array([action]))
        try:
            bolted.step_wait()
        except UnlabelledEnvError as error:
            assert "final_info" in str(error) and "bolt_image" in str(error)
            break
    else:
        pytest.fail("the episode never ended, or the bolt read a final_info without labels")


def test_an_episode_the_bolt_ends_on_a_violation_is_not_a_success() -> None:
    # FluentLabels reports is_success only when the env itself ends an episode; one the
    # bolt ends (end_on_violation) did not reach the goal, and says so.
    env = RestrainingBoltWrapper(lake(), ["G(top_row)"], "oracle", end_on_violation=True)
    env.reset(seed=0)
    _, _, terminated, truncated, info = env.step(1)  # down: off the top row
    assert terminated and not truncated and info["dfa_violated"].tolist() == [True]
    assert info["is_success"] is False


def test_a_world_without_a_camera_renders_nothing_and_refuses_a_classifier(
    world_module: Any, tmp_path: Any
) -> None:
    # camera=False: a bolt that reads the truth needs no image, and a toy-text env's
    # render is most of its step. The env here cannot even render (render_mode None).
    from noisybolt.envs import make_world
    from noisybolt.errors import ConfigError
    from noisybolt.runs import DetectorConfig
    from noisybolt.runs.detectors import make_detector

    plain = gym.make("FrozenLake-v1", is_slippery=False)
    blind = FluentLabels(plain, fluents=FLUENTS, camera=False, success="at_goal")
    bolted = RestrainingBoltWrapper(blind, SPECS, "oracle")
    _, info = bolted.reset(seed=0)
    assert info["bolt_image"].shape == (1, 1, 3) and not info["bolt_image"].any()
    _, _, _, _, info = bolted.step(1)
    assert info["true_fluents"].tolist() == [False, False, False]  # (1, 0): off the top row
    world_module(
        "blindlake",
        "import gymnasium as gym\nimport noisybolt\n"
        "def make():\n"
        "    env = gym.make('FrozenLake-v1', is_slippery=False)\n"
        "    return noisybolt.FluentLabels(env, fluents={'top': lambda e: e.s < 4}, "
        "camera=False)\n",
    )
    world = make_world("blindlake:make", num_envs=1, seed=0)
    with pytest.raises(ConfigError, match="shows the bolt no image"):
        make_detector(
            DetectorConfig(kind="classifier"),
            world="blindlake:make",
            world_kwargs={},
            fluent_names=world.fluent_names,
            camera_spec=world.camera_spec,
        )


class _Lamp:
    """A camera of the lake's cell (10 x the cell index), counting its renders."""

    def __init__(self) -> None:
        self.renders = 0

    def __call__(self, env: gym.Env) -> np.ndarray:
        self.renders += 1
        return np.full((2, 2, 3), 10 * int(env.unwrapped.s), dtype=np.uint8)


class _CellReader:
    """A detector that reads the images' pixels (``reads_images`` unset): the cell."""

    fluent_names = ("at_goal", "in_hole", "top_row")
    needs_truth = False

    def __init__(self) -> None:
        self.cells: list[list[int]] = []

    def predict(self, images: np.ndarray, *, truth: np.ndarray | None = None) -> np.ndarray:
        cells = np.asarray(images)[:, 0, 0, 0].astype(int) // 10
        self.cells.append(cells.tolist())
        probs = np.stack([cells == 15, np.isin(cells, HOLES), cells < 4], axis=1)
        return probs.astype(np.float32)


@pytest.mark.parametrize("detector", ["oracle", "synthetic"])
def test_a_detector_of_the_truth_leaves_the_camera_off_but_for_episode_ends(
    detector: str,
) -> None:
    lamp = _Lamp()
    venv = make_bolted_vec_env(lambda: lake(slippery=True, camera=lamp), 3, SPECS, detector, seed=0)
    venv.reset()
    first = lamp.renders  # each env's first image fixes its camera's size
    assert first == 3
    rng = np.random.default_rng(0)
    ends = 0
    for _ in range(60):
        venv.step_async(rng.integers(0, 4, 3))
        ends += int(venv.step_wait()[2].sum())
    assert ends > 0
    assert lamp.renders - first == ends  # only each ended episode's last view


def test_a_detector_that_reads_the_images_sees_every_state_as_it_was() -> None:
    lamp, reader = _Lamp(), _CellReader()
    venv = make_bolted_vec_env(lambda: lake(slippery=True, camera=lamp), 3, SPECS, reader, seed=0)
    world = venv.world
    venv.reset()
    assert reader.cells[-1] == [int(env.unwrapped.s) for env in world.envs]
    rng = np.random.default_rng(0)
    for _ in range(60):
        venv.step_async(rng.integers(0, 4, 3))
        _, _, dones, infos = venv.step_wait()
        seen = reader.cells[-1]
        # rows [0, 3): the state each step reached (an ended episode's last one), then
        # the new episodes' first cells: the states the envs are in now
        now = [int(env.unwrapped.s) for env in world.envs]
        ended = np.flatnonzero(dones).tolist()
        assert seen[3:] == [now[i] for i in ended]
        for i in range(3):
            if i not in ended:
                assert seen[i] == now[i]
            else:
                assert seen[i] == int(infos[i]["terminal_observation"]["image"])  # its last cell
