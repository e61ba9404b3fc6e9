"""FluentLabels: any Gymnasium env labelled for the bolt through ``info``.

FrozenLake 4x4 (not slippery), states numbered row by row::

    S F F F      0  1  2  3
    F H F H      4  5  6  7
    F F F H      8  9 10 11
    H F F G     12 13 14 15

Actions: 0 left, 1 down, 2 right, 3 up.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
import pytest

from noisybolt.envs.labelled_vec import LabelledVectorEnv
from noisybolt.envs.labels import FluentLabels, collect_labelled_samples
from noisybolt.errors import (
    CameraError,
    ConfigError,
    FluentFunctionError,
    StaleInfoError,
    UnlabelledEnvError,
)
from noisybolt.perception.protocols import BOLT_IMAGE_KEY, TRUE_FLUENTS_KEY, BoltObservable

HOLES = (5, 7, 11, 12)
TO_GOAL = (2, 2, 1, 1, 1, 2)  # 0 -> 1 -> 2 -> 6 -> 10 -> 14 -> 15
FLUENTS = {
    "at_goal": lambda lake: lake.s == 15,
    "in_hole": lambda lake: int(lake.s) in HOLES,
    "top_row": lambda lake: lake.s < 4,
}


def _lake(render_mode: str | None = "rgb_array", slippery: bool = False) -> gym.Env:
    return gym.make("FrozenLake-v1", render_mode=render_mode, is_slippery=slippery)


def _labelled(**kwargs: Any) -> FluentLabels:
    return FluentLabels(_lake(), fluents=kwargs.pop("fluents", FLUENTS), **kwargs)


def test_contract_keys_are_the_documented_ones() -> None:
    assert (BOLT_IMAGE_KEY, TRUE_FLUENTS_KEY) == ("bolt_image", "true_fluents")


def test_labelled_run_equals_the_plain_run_and_labels_the_state_reached() -> None:
    plain, labelled = _lake(slippery=True), FluentLabels(_lake(slippery=True), fluents=FLUENTS)
    obs, _ = plain.reset(seed=4)
    lobs, info = labelled.reset(seed=4)
    assert obs == lobs == 0
    assert info["true_fluents"].tolist() == [False, False, True]
    np.testing.assert_array_equal(info["bolt_image"], plain.render())
    rng = np.random.default_rng(0)
    for _ in range(60):
        action = int(rng.integers(4))
        step = plain.step(action)
        lstep = labelled.step(action)
        assert step[:4] == lstep[:4]
        state, info = int(lstep[0]), lstep[4]
        want = [state == 15, state in HOLES, state < 4]
        assert info["true_fluents"].tolist() == want
        assert info["true_fluents"].dtype == np.bool_
        np.testing.assert_array_equal(info["bolt_image"], plain.render())
        if step[2] or step[3]:
            plain.reset()
            labelled.reset()


def test_success_fluent_reports_is_success_at_the_end_only() -> None:
    env = _labelled(success="at_goal")
    env.reset(seed=0)
    infos = [env.step(a)[4] for a in TO_GOAL]
    assert ["is_success" in info for info in infos] == [False] * 5 + [True]
    assert infos[-1]["is_success"] is True
    env.reset(seed=0)
    *_, terminated, _, info = env.step(1)  # 0 -> 4
    *_, terminated, _, info = env.step(2)  # 4 -> 5: a hole
    assert terminated and info["is_success"] is False


def test_camera_noise_is_reproducible_from_the_reset_seed() -> None:
    def images(seed: int) -> list[np.ndarray]:
        env = _labelled(noise="gaussian:sigma=20")
        out = [np.asarray(env.reset(seed=seed)[1]["bolt_image"])]
        out += [np.asarray(env.step(a)[4]["bolt_image"]) for a in TO_GOAL[:3]]  # read at once
        return out

    a, b, c = images(1), images(1), images(2)
    assert all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))
    assert not any(np.array_equal(x, y) for x, y in zip(a, c, strict=True))
    clean = _labelled()
    assert not np.array_equal(a[0], clean.reset(seed=1)[1]["bolt_image"])
    assert clean.camera_spec.shape == (256, 256, 3)
    assert clean.camera_spec.world == "FrozenLake-v1"


def test_the_camera_renders_only_the_images_read_and_the_last_one_before_a_reset() -> None:
    shots: list[int] = []

    def lamp(env: gym.Env) -> np.ndarray:
        shots.append(int(env.unwrapped.s))
        return np.full((4, 6, 3), 10 * env.unwrapped.s, dtype=np.uint8)

    env = FluentLabels(_lake(render_mode=None), fluents=FLUENTS, camera=lamp)
    env.defer_camera = True  # as a vectorised world of them sets it
    env.reset(seed=0)
    assert shots == [0]  # the first image, at once: it fixes the camera's size
    infos = [env.step(a)[4] for a in TO_GOAL[:3]]  # right, right, down: cells 1, 2, 6
    assert shots == [0]  # nobody looked
    with pytest.raises(StaleInfoError):  # a view the world has moved on from
        np.asarray(infos[0]["bolt_image"])
    assert np.asarray(infos[2]["bolt_image"]).max() == 60 and shots == [0, 6]
    env.step(TO_GOAL[3])  # down: cell 10, not read...
    env.reset()  # ...but an episode's last view is rendered before its state is gone
    assert shots == [0, 6, 10]


def test_a_custom_camera_replaces_the_render() -> None:
    def lamp(env: gym.Env) -> np.ndarray:
        return np.full((4, 6, 3), 10 * env.unwrapped.s, dtype=np.uint8)

    env = FluentLabels(_lake(render_mode=None), fluents=FLUENTS, camera=lamp)
    _, info = env.reset(seed=0)
    assert info["bolt_image"].shape == (4, 6, 3) and info["bolt_image"].max() == 0
    info = env.step(2)[4]  # -> state 1
    assert np.all(info["bolt_image"] == 10)
    assert env.camera_spec.shape == (4, 6, 3)


def test_fluent_that_raises_is_named_at_the_first_reset() -> None:
    env = _labelled(fluents={"top_row": FLUENTS["top_row"], "broken": lambda lake: lake.nope})
    with pytest.raises(FluentFunctionError, match=r"'broken'.*AttributeError") as err:
        env.reset(seed=0)
    assert err.value.fluent == "broken"


@pytest.mark.parametrize("value", [1, 0.0, None, np.array([True])])
def test_fluent_returning_a_non_bool_is_named(value: Any) -> None:
    env = _labelled(fluents={"odd": lambda lake: value})
    with pytest.raises(FluentFunctionError, match="fluent 'odd' must return a bool"):
        env.reset(seed=0)


def test_numpy_bools_are_bools() -> None:
    env = _labelled(fluents={"top_row": lambda lake: np.bool_(lake.s < 4)})
    assert env.reset(seed=0)[1]["true_fluents"].tolist() == [True]


@pytest.mark.parametrize(
    ("image", "message"),
    [
        (np.zeros((4, 4, 3), np.float32), "uint8"),
        (np.zeros((4, 4), np.uint8), "uint8 \\[H, W, 3\\]"),
        (np.zeros((4, 4, 4), np.uint8), "RGB"),
        ([[0]], "uint8"),
    ],
)
def test_camera_returning_a_wrong_image_is_refused(image: Any, message: str) -> None:
    env = _labelled(camera=lambda env: image)
    with pytest.raises(CameraError, match=message):
        env.reset(seed=0)


def test_camera_changing_its_image_size_is_refused() -> None:
    def growing(env: gym.Env) -> np.ndarray:
        side = 4 + int(env.unwrapped.s)
        return np.zeros((side, side, 3), np.uint8)

    env = _labelled(camera=growing)
    env.reset(seed=0)
    with pytest.raises(CameraError, match="one size"):
        env.step(2)
    env = _labelled(camera=growing)
    env.defer_camera = True
    env.reset(seed=0)
    info = env.step(2)[4]
    with pytest.raises(CameraError, match="one size"):  # deferred: when the image is read
        np.asarray(info["bolt_image"])


def test_bad_construction_is_refused_before_any_step() -> None:
    with pytest.raises(CameraError, match="render_mode='rgb_array'"):
        FluentLabels(_lake(render_mode=None), fluents=FLUENTS)
    with pytest.raises(ConfigError, match="at least one fluent"):
        FluentLabels(_lake(), fluents={})
    with pytest.raises(ConfigError, match="fluent name"):
        FluentLabels(_lake(), fluents={"TopRow": FLUENTS["top_row"]})
    with pytest.raises(FluentFunctionError, match="'top_row' must be a function"):
        FluentLabels(_lake(), fluents={"top_row": True})  # type: ignore[dict-item]
    with pytest.raises(ConfigError, match="success='goal' is not one of the fluents"):
        FluentLabels(_lake(), fluents=FLUENTS, success="goal")
    with pytest.raises(CameraError, match="reset"):
        _ = _labelled().camera_spec


def test_collected_samples_are_the_labels_of_a_random_play() -> None:
    env = _labelled()
    data = collect_labelled_samples(env, num_samples=30, seed=0)
    assert data.images.shape == (30, 256, 256, 3) and data.labels.shape == (30, 3)
    assert data.fluent_names == ("at_goal", "in_hole", "top_row")
    assert data.labels[0].tolist() == [False, False, True]  # the start
    with pytest.raises(UnlabelledEnvError):
        collect_labelled_samples(_lake(), num_samples=3)


# ------------------------------------------------------------------ vector form


def test_vector_world_keeps_each_ended_episodes_last_view() -> None:
    n = 3
    world = LabelledVectorEnv([lambda: _labelled(success="at_goal")] * n)
    singles = [_labelled(success="at_goal") for _ in range(n)]
    assert isinstance(world, BoltObservable)
    world.reset(seed=10)
    for i, single in enumerate(singles):
        _, info = single.reset(seed=10 + i)
        np.testing.assert_array_equal(world.true_fluents()[i], info["true_fluents"])
    rng = np.random.default_rng(1)
    ended = 0
    for _ in range(40):
        actions = rng.integers(4, size=n)
        _, rewards, term, trunc, vinfo = world.step(actions)
        for i, single in enumerate(singles):
            _, reward, sterm, strunc, info = single.step(int(actions[i]))
            assert (rewards[i], term[i], trunc[i]) == (reward, sterm, strunc)
            if sterm or strunc:  # the ended episode's last view, in final_info
                final = vinfo["final_info"]
                assert final["_true_fluents"][i] and final["_bolt_image"][i]
                np.testing.assert_array_equal(final["true_fluents"][i], info["true_fluents"])
                np.testing.assert_array_equal(final["bolt_image"][i], info["bolt_image"])
                ended += 1
                _, info = single.reset()
            np.testing.assert_array_equal(world.true_fluents()[i], info["true_fluents"])
            np.testing.assert_array_equal(world.bolt_images()[i], info["bolt_image"])
    assert ended >= n


def test_vector_world_refuses_unlabelled_envs() -> None:
    with pytest.raises(UnlabelledEnvError, match="FluentLabels"):
        LabelledVectorEnv([_lake])
