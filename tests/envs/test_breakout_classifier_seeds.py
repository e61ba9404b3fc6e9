"""benchmarks/breakout_classifier_seeds.py: its recorded episodes name their images."""

from __future__ import annotations

import importlib.util
from pathlib import Path
from types import ModuleType

import numpy as np

from noisybolt.envs import make_world

SCRIPT = Path(__file__).resolve().parents[2] / "benchmarks" / "breakout_classifier_seeds.py"


def _module() -> ModuleType:
    spec = importlib.util.spec_from_file_location("breakout_classifier_seeds", SCRIPT)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


class _Brightness:
    """A detector whose one "probability" is each image's mean pixel."""

    needs_truth = False

    def predict(self, images: np.ndarray, *, truth: np.ndarray | None = None) -> np.ndarray:
        return np.asarray(images, dtype=np.float64).mean(axis=(1, 2, 3))[:, None]


def test_the_image_log_rows_name_the_images_each_frame_showed() -> None:
    bench = _module()
    bt = bench._belief_tracking()

    def play(detector: object) -> list:
        world = make_world("gridworld", num_envs=3, seed=0, noise="gaussian:sigma=20")
        return bt.record(world, detector, 5, 0, 3)

    log = bench.ImageLog()
    logged = play(log)
    seen = play(_Brightness())  # the same seed: the same frames
    images = np.stack(log.images)
    assert len(images) >= sum(len(e.probs) for e in logged)  # and the unfinished episodes
    for by_log, by_brightness in zip(logged, seen, strict=True):
        rows = by_log.probs[:, 0].astype(int)
        np.testing.assert_array_equal(by_log.truth, by_brightness.truth)
        np.testing.assert_allclose(images[rows].mean(axis=(1, 2, 3)), by_brightness.probs[:, 0])
    # and the rows are not simply in order: episodes of different games interleave
    assert not all((np.diff(e.probs[:, 0]) == 1).all() for e in logged)
