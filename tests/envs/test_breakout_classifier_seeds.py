"""benchmarks/breakout_classifier_seeds.py: its recorded episodes name their images."""

from __future__ import annotations

from collections.abc import Callable
from types import ModuleType

import numpy as np

from noisybolt.envs import make_world


class _Brightness:
    """A detector whose one "probability" is each image's mean pixel."""

    needs_truth = False

    def predict(self, images: np.ndarray, *, truth: np.ndarray | None = None) -> np.ndarray:
        return np.asarray(images, dtype=np.float64).mean(axis=(1, 2, 3))[:, None]


def test_the_image_log_rows_name_the_images_each_frame_showed(
    load_script: Callable[..., ModuleType],
) -> None:
    bench = load_script("benchmarks/breakout_classifier_seeds.py")
    bt = bench.bt  # the sibling benchmark it imports

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
