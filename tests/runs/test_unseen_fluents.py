"""A classifier that never saw a fluent some spec uses is refused, at training and when
its cached file is used again; one that saw it only a few times is warned of.

The world is a non-slippery FrozenLake whose camera paints the agent's cell as a grey
level. ``off_lake`` (the agent off the 4x4 lake) is true in no state the world can reach,
so it is never true in the collected images, whatever the seed; ``top`` (the first row) is
true in most of them. (A fluent true only as an episode ends, such as falling in a hole,
is collected since ``detector.final_views``: tests/perception/test_final_views.py.)
"""

from __future__ import annotations

import re
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from noisybolt.envs import make_world
from noisybolt.errors import ConfigError, RareFluentWarning, UnseenFluentError
from noisybolt.perception.classifier import load_classifier
from noisybolt.perception.dataset import LabelCounts, collect_samples
from noisybolt.runs import DetectorConfig, TrainConfig, train
from noisybolt.runs.detectors import RARE_FLUENT_IMAGES, check_fluents_shown, make_detector
from noisybolt.runs.resolution import resolve

WORLD = """
import gymnasium as gym
import numpy as np
import noisybolt


def lamp(env):
    return np.full((8, 8, 3), 12 * env.unwrapped.s, dtype=np.uint8)


def make():
    lake = gym.make("FrozenLake-v1", is_slippery=False)
    fluents = {
        "off_lake": lambda e: not 0 <= int(e.unwrapped.s) < 16,
        "top": lambda e: e.unwrapped.s < 4,
    }
    return noisybolt.FluentLabels(lake, fluents=fluents, camera=lamp, return_bounds=(0, 1))
"""
NAME = "unseenlake:make"
SMALL = DetectorConfig(kind="classifier", samples=64, epochs=1, restarts=1)


@pytest.fixture
def lake(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, world_module: Callable[[str, str], str]
) -> Any:
    """The world's module in the current directory, and a cache of this test's own."""
    monkeypatch.setenv("NOISYBOLT_CACHE_DIR", str(tmp_path / "cache"))
    world_module("unseenlake", WORLD)
    return make_world(NAME, num_envs=1, seed=0)


def _detector(lake: Any, spec_fluents: tuple[str, ...], config: DetectorConfig = SMALL) -> Any:
    return make_detector(
        config,
        world=NAME,
        world_kwargs={},
        fluent_names=lake.fluent_names,
        camera_spec=lake.camera_spec,
        progress=False,
        log=lambda line: None,
        spec_fluents=spec_fluents,
    )


def _cached_files(root: Path) -> list[Path]:
    return sorted((root / "cache").glob("classifiers/*.safetensors"))


def test_a_spec_over_a_fluent_never_collected_true_is_refused_and_nothing_is_written(
    lake: Any, tmp_path: Path
) -> None:
    config = resolve(
        TrainConfig.create(
            world=NAME, specs=["F(off_lake)"], detector=SMALL, frames=1024, eval_freq=0
        )
    )
    with pytest.raises(UnseenFluentError) as caught:
        train(config, tmp_path / "run", log=lambda line: None)
    message = str(caught.value)
    assert caught.value.fluents == ("off_lake",) and caught.value.images == 64
    assert "the 64 images collected from the world's random play (seed 0)" in message
    assert "never show 'off_lake' true" in message
    assert "--detector synthetic or oracle" in message and "detector.samples=N" in message
    assert isinstance(caught.value, ConfigError)
    # refused before a classifier was trained: no cached file, no run directory
    assert _cached_files(tmp_path) == []
    assert not (tmp_path / "run").exists()


def test_specs_over_the_other_fluents_train_and_the_counts_are_saved(
    lake: Any, tmp_path: Path
) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error", RareFluentWarning)
        detector = _detector(lake, ("top",))
    assert detector.fluent_names == ("off_lake", "top")
    (path,) = _cached_files(tmp_path)
    counts = load_classifier(path).training["label_counts"]
    # the images it was trained on, collected again as make_detector collects them
    collector = make_world(NAME, num_envs=16, seed=0)
    images = collect_samples(collector, num_samples=64, seed=0)
    assert counts == {"images": 64, "positives": images.positives}
    assert counts["positives"]["off_lake"] == 0 and 0 < counts["positives"]["top"] < 64


def test_a_cached_classifier_is_refused_for_a_spec_over_a_fluent_it_never_saw(
    lake: Any, tmp_path: Path
) -> None:
    _detector(lake, ("top",))
    (path,) = _cached_files(tmp_path)
    with pytest.raises(UnseenFluentError, match="never show 'off_lake' true") as caught:
        _detector(lake, ("top", "off_lake"))
    assert f"the 64 images the cached classifier {path} was trained on" in str(caught.value)
    assert caught.value.fluents == ("off_lake",)
    assert _cached_files(tmp_path) == [path]  # the file is kept: other specs may use it
    _detector(lake, ("top",))  # and still serves them


def test_a_cached_classifier_saved_without_counts_is_used_unchecked(
    lake: Any, tmp_path: Path
) -> None:
    _detector(lake, ("top",))
    (path,) = _cached_files(tmp_path)
    legacy = load_classifier(path)
    del legacy.training["label_counts"]
    legacy.save(path)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RareFluentWarning)
        detector = _detector(lake, ("off_lake",))
    assert detector.fluent_names == ("off_lake", "top")


def test_a_fluent_seen_in_few_images_is_warned_of(lake: Any) -> None:
    # 16 images: top is true, or false, in 8 of them at most, under 20
    few = DetectorConfig(kind="classifier", samples=16, epochs=1, restarts=1)
    with pytest.warns(RareFluentWarning, match=r"'top' true in \d+ and false in \d+") as caught:
        _detector(lake, ("top",), few)
    (warning,) = caught
    true, false = re.findall(r"true in (\d+) and false in (\d+)", str(warning.message))[0]
    assert int(true) + int(false) == 16 and "the 16 images" in str(warning.message)


def test_the_warning_threshold_counts_either_value() -> None:
    assert RARE_FLUENT_IMAGES == 20
    at = LabelCounts(images=100, positives={"a": 20, "b": 80, "c": 50})
    with warnings.catch_warnings():
        warnings.simplefilter("error", RareFluentWarning)
        check_fluents_shown(at, ["a", "b", "c"], source="the images")  # 20 of each at least
    below = LabelCounts(images=100, positives={"a": 19, "b": 81, "c": 50})
    for fluent in ("a", "b"):  # 19 true; 19 false
        with pytest.warns(RareFluentWarning, match=f"'{fluent}' true in"):
            check_fluents_shown(below, [fluent], source="the images")
    always = LabelCounts(images=100, positives={"a": 100, "b": 0, "c": 50})
    with pytest.raises(UnseenFluentError, match="never show 'a' false or 'b' true") as caught:
        check_fluents_shown(always, ["c", "a", "b"], source="the images")
    assert caught.value.fluents == ("a", "b")
    check_fluents_shown(always, ["c"], source="the images")  # a and b: no spec uses them


@pytest.mark.parametrize("reward", ["compliance"])
def test_a_detector_reading_the_truth_warns_of_a_spec_fluent_random_play_never_shows(
    lake: Any, reward: str
) -> None:
    # The oracle would silently never credit F(off_lake): the run trains to 0 % compliance.
    from noisybolt.errors import UnseenFluentWarning
    from noisybolt.runs.environments import prepare_bolt

    def warned(spec: str) -> list[str]:
        config = resolve(
            TrainConfig.create(
                world=NAME, specs=[spec], detector=DetectorConfig(kind="oracle"), reward=reward
            )
        )
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            prepare_bolt(config, seed=0, log=lambda _: None)
        return [str(w.message) for w in caught if w.category is UnseenFluentWarning]

    [message] = warned("F(off_lake) | G(top)")
    assert message.startswith(
        "the specs' fluent off_lake was never true in 16 games of random play, in the first "
        "128 steps of each (2,048 steps)"
    )
    assert "always false" in message
    assert warned("F(!top)") == []  # seen both ways
