"""A user's world whose uint8 images are small integers (MiniGrid's symbolic grid) reaches
the network undivided; pixels, other observations and explicit choices are left alone."""

from __future__ import annotations

import warnings
from pathlib import Path

import pytest

from noisybolt.errors import SmallIntegerImagesWarning
from noisybolt.runs import DetectorConfig, TrainConfig
from noisybolt.runs.resolution import resolve

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
ROOM = "minigrid_empty:make_room"
ORACLE = DetectorConfig(kind="oracle")


@pytest.fixture(autouse=True)
def _examples_importable(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.syspath_prepend(str(EXAMPLES))


def _normalize(config: TrainConfig) -> object:
    return dict(config.algorithm.hyperparams.get("policy_kwargs") or {}).get(
        "normalize_images", True
    )


def test_a_symbolic_grid_is_kept_as_integers_with_a_warning() -> None:
    with pytest.warns(SmallIntegerImagesWarning, match=r"at most 10 in random play"):
        config = resolve(TrainConfig.create(world=ROOM, specs=["F(at_goal)"], detector=ORACLE))
    assert _normalize(config) is False
    # what the run saves, and so evaluate and --resume read
    hyperparams = config.to_dict()["algorithm"]["hyperparams"]
    assert hyperparams["policy_kwargs"]["normalize_images"] is False


def test_an_explicit_choice_is_kept_and_not_warned_about() -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error", SmallIntegerImagesWarning)
        config = resolve(
            TrainConfig.create(
                world=ROOM,
                specs=["F(at_goal)"],
                detector=ORACLE,
                overrides={"policy_kwargs.normalize_images": True},
            )
        )
    assert _normalize(config) is True


PIXEL_ROOM = """
import gymnasium as gym
import minigrid  # noqa: F401
from minigrid.wrappers import ImgObsWrapper, RGBImgPartialObsWrapper
import noisybolt

def make():
    room = ImgObsWrapper(RGBImgPartialObsWrapper(gym.make("MiniGrid-Empty-5x5-v0")))
    camera = lambda env: env.unwrapped.get_frame(highlight=False, tile_size=4)
    fluents = {"at_goal": lambda e: tuple(e.agent_pos) == (3, 3)}
    return noisybolt.FluentLabels(room, fluents=fluents, camera=camera)
"""


def test_pixels_and_non_image_observations_are_left_alone(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    (tmp_path / "pixel_room.py").write_text(PIXEL_ROOM)
    monkeypatch.syspath_prepend(str(tmp_path))
    with warnings.catch_warnings():
        warnings.simplefilter("error", SmallIntegerImagesWarning)
        # the same room seen as RGB pixels (up to 255); FrozenLake's Discrete cell
        pixels = resolve(
            TrainConfig.create(
                world="pixel_room:make", specs=["F(at_goal)"], detector=ORACLE, reward_scale=1.0
            )
        )
        lake = resolve(
            TrainConfig.create(world="frozenlake:make_lake", specs=["F(at_goal)"], detector=ORACLE)
        )
    assert _normalize(pixels) is True
    assert _normalize(lake) is True
