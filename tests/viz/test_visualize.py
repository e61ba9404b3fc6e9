from __future__ import annotations

import doctest
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import imageio.v3 as iio
import numpy as np
import pytest

import noisybolt.viz as viz
from noisybolt.bolt import confidence_bands
from noisybolt.envs.gridworld import GridAction, GridworldEnv
from noisybolt.errors import ConfigError
from noisybolt.perception.detectors import BetaNoise, SyntheticDetector
from noisybolt.runs.specs import resolve_spec
from noisybolt.viz import (
    EpisodeRecording,
    default_frame,
    policy_from_model,
    record_episode,
    render_episode_frames,
    save_episode_gif,
    trajectory_heatmap,
    visit_counts,
)
from noisybolt.wrappers.bolt_wrapper import RestrainingBoltWrapper

R, L, F = GridAction.RIGHT, GridAction.LEFT, GridAction.FORWARD
# Down the west wall to the bottom-left corner, then east along the south wall to the goal.
SCRIPT = (R, F, F, F, L, F, F, F)
SCRIPT_CELLS = [(1, 1), (1, 1), (1, 2), (1, 3), (1, 4), (1, 4), (2, 4), (3, 4), (4, 4)]
ACTION_NAMES = [a.name for a in GridAction]


class SpyDetector:
    """A synthetic detector that keeps every batch of images it is shown."""

    def __init__(self, fluent_names: tuple[str, ...]) -> None:
        low = {"bottom_left_corner": BetaNoise.low_confidence()}
        self._inner = SyntheticDetector(fluent_names, seed=3, fluents=low)
        self.images: list[np.ndarray] = []

    @property
    def fluent_names(self) -> tuple[str, ...]:
        return self._inner.fluent_names

    @property
    def needs_truth(self) -> bool:
        return True

    def predict(self, images: np.ndarray, *, truth: np.ndarray | None = None) -> np.ndarray:
        self.images.append(np.array(images[0]))
        return self._inner.predict(images, truth=truth)


def _bolted() -> tuple[RestrainingBoltWrapper, SpyDetector]:
    env = GridworldEnv(noise="gaussian:sigma=12")
    spy = SpyDetector(env.fluent_names)
    specs = [resolve_spec("edge"), resolve_spec("avoid_top_right")]
    return RestrainingBoltWrapper(env, specs, spy), spy


def _scripted() -> Any:
    actions: Iterator[GridAction] = iter(SCRIPT)
    return lambda obs: next(actions)


@pytest.fixture(scope="module")
def recorded() -> tuple[EpisodeRecording, RestrainingBoltWrapper, SpyDetector]:
    env, spy = _bolted()
    return record_episode(env, _scripted(), seed=7), env, spy


@pytest.fixture(scope="module")
def reference() -> tuple[list[dict[str, Any]], list[np.ndarray]]:
    """The same episode run without recording: the infos and the images the bolt read."""
    env, spy = _bolted()
    _, info = env.reset(seed=7)
    infos = [info]
    for action in SCRIPT:
        infos.append(env.step(action)[4])
    return infos, spy.images


# ---------------------------------------------------------------------------- visit counts


def test_visit_counts_per_step_and_per_episode_by_hand() -> None:
    paths = [
        [(1, 1), (2, 1), (2, 1), (2, 2)],  # turns in place at (2, 1)
        [(1, 1), (1, 2), (2, 2)],
        [],
    ]
    steps = visit_counts(paths, size=4)
    expected = np.zeros((4, 4), dtype=np.int64)  # [y, x]
    expected[1, 1] = 2
    expected[1, 2] = 2
    expected[2, 1] = 1
    expected[2, 2] = 2
    np.testing.assert_array_equal(steps, expected)
    episodes = visit_counts(paths, size=4, per_episode=True)
    expected[1, 2] = 1
    np.testing.assert_array_equal(episodes, expected)


def test_visit_counts_index_rows_by_y() -> None:
    counts = visit_counts([[(3, 1)]], size=5)
    assert counts[1, 3] == 1
    assert counts.sum() == 1


@pytest.mark.parametrize("paths", [[[(1, 1), (4, 1)]], [[(-1, 1)]], [[(1, 1, 0)]], [[(1.5, 1)]]])
def test_visit_counts_reject_cells_outside_the_room(paths: Any) -> None:
    with pytest.raises(ConfigError):
        visit_counts(paths, size=4)


# ---------------------------------------------------------------------------- recording


def test_recording_follows_the_script(recorded: Any) -> None:
    rec, _, _ = recorded
    t = len(SCRIPT)
    assert rec.n_steps == t
    assert rec.frames.shape == (t + 1, 192, 192, 3)
    assert rec.frames.dtype == np.uint8
    assert rec.bolt_images.shape == (t + 1, 48, 48, 3)
    assert rec.positions is not None
    assert [tuple(p) for p in rec.positions.tolist()] == SCRIPT_CELLS
    assert rec.actions.tolist() == [int(a) for a in SCRIPT]
    np.testing.assert_allclose(rec.env_rewards, [-1.5] * 7 + [98.5])
    assert rec.env_return == pytest.approx(100 - 8 * 1.5)
    assert rec.terminated and not rec.truncated
    assert rec.spec_names == ("edge", "avoid_top_right")
    assert rec.fluent_names == GridworldEnv().fluent_names


def test_recording_matches_the_wrappers_info(recorded: Any, reference: Any) -> None:
    rec, env, _ = recorded
    infos, _ = reference
    np.testing.assert_array_equal(rec.probs, np.stack([i["fluent_probs"] for i in infos]))
    np.testing.assert_array_equal(rec.dfa_states, np.stack([i["dfa_states"] for i in infos]))
    np.testing.assert_array_equal(
        rec.true_dfa_states, np.stack([i["true_dfa_states"] for i in infos])
    )
    np.testing.assert_array_equal(rec.bolt_rewards, [i["bolt_reward"] for i in infos[1:]])
    np.testing.assert_array_equal(
        rec.bands[1:], np.stack([i["confidence_bands"] for i in infos[1:]])
    )
    np.testing.assert_array_equal(rec.bands, confidence_bands(rec.probs))
    assert rec.bands[4, rec.fluent_names.index("bottom_left_corner")] == 1  # low, as set
    np.testing.assert_array_equal(
        rec.true_accepting, np.stack([i["true_accepting"] for i in infos])
    )
    for mask, dfa in zip(rec.accepting, env.bolt.dfas, strict=True):
        np.testing.assert_array_equal(mask, dfa.accepting)


def test_bolt_images_are_those_the_detector_read_and_the_episode_is_unchanged(
    recorded: Any, reference: Any
) -> None:
    rec, env, spy = recorded
    _, reference_images = reference
    np.testing.assert_array_equal(rec.bolt_images, np.stack(spy.images))
    # Same seed, recorded or not: the camera's noise stream was not disturbed.
    np.testing.assert_array_equal(rec.bolt_images, np.stack(reference_images))
    assert "bolt_image" not in vars(env.unwrapped)  # the tap is removed


def test_max_steps_cuts_the_recording_short() -> None:
    env, _ = _bolted()
    rec = record_episode(env, _scripted(), seed=0, max_steps=3)
    assert rec.n_steps == 3
    assert rec.frames.shape[0] == 4
    assert not rec.terminated and not rec.truncated
    with pytest.raises(ConfigError):
        record_episode(env, _scripted(), seed=0, max_steps=-1)


def test_recording_checks_its_shapes(recorded: Any) -> None:
    rec, _, _ = recorded
    fields = {name: getattr(rec, name) for name in rec.__dataclass_fields__}
    fields["probs"] = rec.probs[:, :2]
    with pytest.raises(ValueError, match="probs"):
        EpisodeRecording(**fields)


def test_default_frame_needs_a_picture() -> None:
    with pytest.raises(ConfigError, match="frame_fn"):
        default_frame(object())


def test_policy_from_model_unwraps_sb3_predict() -> None:
    class Model:
        def predict(self, obs: Any, deterministic: bool = True) -> tuple[np.ndarray, None]:
            return np.array(1 if deterministic else 0), None

    assert policy_from_model(Model())({}) == 1
    assert policy_from_model(Model(), deterministic=False)({}) == 0


# ---------------------------------------------------------------------------- pictures


def test_gif_has_one_frame_per_state(recorded: Any, tmp_path: Path) -> None:
    rec, _, _ = recorded
    path = save_episode_gif(rec, tmp_path / "sub" / "episode.gif", fps=5, action_names=ACTION_NAMES)
    assert path.exists()
    frames = iio.imread(path, index=None)
    assert frames.shape[0] == rec.n_steps + 1
    assert frames.ndim == 4 and frames.shape[-1] in (3, 4)
    assert not any(p.name.endswith(".tmp") for p in path.parent.iterdir())
    with pytest.raises(ConfigError):
        save_episode_gif(rec, tmp_path / "bad.gif", fps=0)


def test_rendered_frames_change_with_the_step() -> None:
    env, _ = _bolted()
    rec = record_episode(env, _scripted(), seed=0, max_steps=2)
    frames = render_episode_frames(rec, action_names=ACTION_NAMES)
    assert frames.shape[0] == 3 and frames.dtype == np.uint8
    assert not np.array_equal(frames[0], frames[1])


@pytest.mark.parametrize("draw_paths", [False, True])
def test_heatmap_png_has_the_asked_size(tmp_path: Path, draw_paths: bool) -> None:
    paths = [SCRIPT_CELLS, [(1, 1), (2, 1), (3, 1), (4, 1), (4, 2), (4, 3), (4, 4)]]
    path = trajectory_heatmap(
        paths, size=6, path=tmp_path / "heat.png", draw_paths=draw_paths, figsize=(5.0, 4.4)
    )
    image = iio.imread(path)
    assert image.shape[:2] == (440, 500)
    with pytest.raises(ConfigError):
        trajectory_heatmap([], size=6, path=tmp_path / "empty.png")


def test_any_labelled_env_records_what_its_info_showed_the_bolt() -> None:
    import gymnasium as gym

    from noisybolt import FluentLabels

    lake = gym.make("FrozenLake-v1", render_mode="rgb_array", is_slippery=False)
    labelled = FluentLabels(
        lake, fluents={"top_row": lambda e: e.s < 4, "at_goal": lambda e: e.s == 15}
    )
    env = RestrainingBoltWrapper(labelled, ["X(G(!top_row))"], "oracle")
    rec = record_episode(env, lambda obs: 1, seed=0, max_steps=3)  # down, down, down
    assert rec.n_steps == 3 and rec.positions is None
    assert rec.frames.shape == rec.bolt_images.shape == (4, 256, 256, 3)
    # No noise: the bolt saw the env's own render, step by step.
    np.testing.assert_array_equal(rec.bolt_images, rec.frames)
    assert rec.true_accepting[:, 0].tolist() == [False, True, True, True]
    assert render_episode_frames(rec).shape[0] == 4


def test_a_world_without_a_picture_of_its_own_is_drawn_as_the_bolt_sees_it() -> None:
    import gymnasium as gym

    from noisybolt import FluentLabels

    # no render_mode: only the user's camera (the cell as a grey level, 8x8) draws it
    lake = gym.make("FrozenLake-v1", is_slippery=False)

    def camera(env: Any) -> np.ndarray:
        return np.full((8, 8, 3), 16 * env.unwrapped.s, dtype=np.uint8)

    labelled = FluentLabels(lake, fluents={"top_row": lambda e: e.s < 4}, camera=camera)
    env = RestrainingBoltWrapper(labelled, ["X(G(!top_row))"], "oracle")
    rec = record_episode(env, lambda obs: 1, seed=0, max_steps=2)  # down, down: cells 4, 8
    assert rec.world_view == "bolt's camera"
    np.testing.assert_array_equal(rec.frames, rec.bolt_images)
    assert rec.frames[:, 0, 0, 0].tolist() == [0, 64, 128]
    assert render_episode_frames(rec).shape[0] == 3
    rendered = record_episode(
        RestrainingBoltWrapper(
            FluentLabels(
                gym.make("FrozenLake-v1", render_mode="rgb_array", is_slippery=False),
                fluents={"top_row": lambda e: e.s < 4},
            ),
            ["X(G(!top_row))"],
            "oracle",
        ),
        lambda obs: 1,
        seed=0,
        max_steps=1,
    )
    assert rendered.world_view == "world"


def test_compared_heatmaps_share_one_picture_and_one_scale(tmp_path: Path) -> None:
    top = [(1, 1), (2, 1), (3, 1), (4, 1), (4, 2), (4, 3), (4, 4)]
    one = viz.compare_heatmaps(
        {"down the west wall": [SCRIPT_CELLS]}, size=6, path=tmp_path / "one.png", title="t"
    )
    two = viz.compare_heatmaps(
        {"without\nthe bolt": [top, top], "with\nthe bolt": [SCRIPT_CELLS]},
        size=6,
        path=tmp_path / "two.png",
        title="two agents\nspec",
        per_episode=False,
    )
    height, width = iio.imread(two).shape[:2]
    one_width = iio.imread(one).shape[1]
    assert width - one_width == pytest.approx(3.6 * 100 + 35, abs=2)  # one more room
    assert height > 3.6 * 100
    with pytest.raises(ConfigError, match="at least one panel"):
        viz.compare_heatmaps({}, size=6, path=tmp_path / "none.png", title="t")
    with pytest.raises(ConfigError, match="'empty'"):
        viz.compare_heatmaps({"empty": []}, size=6, path=tmp_path / "empty.png", title="t")
    with pytest.raises(ConfigError, match="outside"):
        viz.compare_heatmaps({"x": [[(9, 9)]]}, size=6, path=tmp_path / "out.png", title="t")


def test_public_api_and_docstring_examples() -> None:
    import noisybolt.viz.heatmaps as heatmaps

    for name in viz.__all__:
        assert getattr(viz, name).__doc__ or name in {"BAND_COLOURS", "DPI"}
    result = doctest.testmod(heatmaps, optionflags=doctest.NORMALIZE_WHITESPACE)
    assert result.failed == 0 and result.attempted > 0


def test_a_breakout_game_records_and_draws() -> None:
    from noisybolt.envs.breakout import BreakoutEnv
    from noisybolt.perception.detectors import OracleDetector

    game = BreakoutEnv(seed=0, fluents=["left_gone_row5", "brick_clear_left"])
    specs = [resolve_spec("left_row5"), resolve_spec("clear_left_column")]
    env = RestrainingBoltWrapper(game, specs, OracleDetector(game.fluent_names))
    rng = np.random.default_rng(0)
    rec = record_episode(env, lambda obs: int(rng.integers(0, 4)), seed=1, max_steps=12)
    assert rec.n_steps == 12
    assert rec.frames[0].shape == (210, 160, 3) and rec.bolt_images[0].shape == (84, 84, 3)
    assert rec.positions is None  # no cells to draw a heat-map of
    frames = render_episode_frames(rec, action_names=["no-op", "fire", "right", "left"])
    assert len(frames) == 13
