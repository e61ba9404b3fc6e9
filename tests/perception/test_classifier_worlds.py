"""Classifiers and datasets against the real worlds: fit checks, and (slow) learning targets."""

from __future__ import annotations

import numpy as np
import pytest

from noisybolt.envs import make_world
from noisybolt.errors import IncompatibleError
from noisybolt.perception.classifier import ClassifierConfig, load_classifier
from noisybolt.perception.dataset import collect_samples, load_dataset, save_dataset
from noisybolt.perception.metrics import build_report
from noisybolt.perception.training import TrainingConfig, train_classifier


def test_files_refuse_a_world_they_were_not_made_for(tmp_path):
    world = make_world("gridworld", num_envs=4, seed=0, noise="regional")
    data = collect_samples(world, num_samples=40, seed=0)
    result = train_classifier(
        data,
        config=ClassifierConfig(channels=(4,), pool=2, hidden=8),
        training=TrainingConfig(epochs=1),
        progress=False,
    )
    result.detector.save(tmp_path / "c.safetensors")
    save_dataset(data, tmp_path / "d.npz")
    same = make_world("gridworld", num_envs=2, seed=5, noise="regional")
    detector = load_classifier(tmp_path / "c.safetensors", world=same)
    assert detector.predict(same.bolt_images()).shape == (2, 7)
    load_dataset(tmp_path / "d.npz", world=same)
    clean = make_world("gridworld", num_envs=1, seed=0)
    with pytest.raises(IncompatibleError, match="camera noise differs"):
        load_classifier(tmp_path / "c.safetensors", world=clean)
    with pytest.raises(IncompatibleError, match="camera noise differs"):
        load_dataset(tmp_path / "d.npz", world=clean)
    breakout = make_world("breakout", num_envs=1, seed=0)
    with pytest.raises(
        IncompatibleError, match=r"missing \['brick_clear_left', 'left_gone_row0'"
    ) as info:
        load_classifier(tmp_path / "c.safetensors", world=breakout)
    assert "camera world differs" in str(info.value)
    assert "camera height differs" in str(info.value)
    smaller = make_world("gridworld", num_envs=1, seed=0, noise="regional", camera_tile_size=4)
    with pytest.raises(IncompatibleError, match="camera height differs"):
        load_classifier(tmp_path / "c.safetensors", world=smaller)


def _train_and_test(noise: str, *, target: float | None, seed: int = 0):
    data = collect_samples(
        make_world("gridworld", num_envs=16, seed=seed, noise=noise), num_samples=4000, seed=seed
    )
    result = train_classifier(
        data,
        training=TrainingConfig(epochs=30, seed=seed, target_accuracy=target),
        progress=False,
    )
    test = collect_samples(
        make_world("gridworld", num_envs=16, seed=seed + 99, noise=noise),
        num_samples=2000,
        seed=seed + 99,
    )
    probs = result.detector.predict(test.images)
    return result, build_report(probs, test.labels, fluent_names=test.fluent_names)


@pytest.mark.slow
def test_gridworld_classifiers_reach_99_percent_on_clean_images():
    result, report = _train_and_test("none", target=0.99)
    assert result.reached_target
    assert report.min_accuracy >= 0.99
    assert all(f.auroc > 0.999 for f in report.fluents)


@pytest.mark.slow
def test_regional_noise_dims_bottom_left_corner_only():
    """The paper's case 4: b seen only with low confidence, the others clearly."""
    _, report = _train_and_test("regional", target=None)
    dim = report["bottom_left_corner"]
    assert dim.positive_bands.low > 0.5
    assert dim.positive_bands.high < 0.3
    for fluent in report.fluents:
        if fluent.name != "bottom_left_corner":
            assert fluent.positive_bands.high > 0.8, fluent
            assert fluent.accuracy > 0.98, fluent
    assert np.isfinite(dim.ece) and dim.auroc > 0.9
