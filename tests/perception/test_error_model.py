"""A detector's error model: counted by hand, recorded by training on held-out images,
absent from classifier files saved before (used as before), refused by name where
nothing measures it."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from noisybolt.errors import MissingErrorModelError, UnknownFluentError
from noisybolt.perception.classifier import ClassifierDetector, load_classifier
from noisybolt.perception.dataset import FluentDataset
from noisybolt.perception.detectors import OracleDetector
from noisybolt.perception.error_model import (
    ERROR_MODEL_NOTE,
    error_model_of,
    measure_error_model,
    record_labelled_play,
    recorded_error_model,
)
from noisybolt.perception.protocols import CameraSpec
from noisybolt.perception.training import TrainingConfig, train_classifier


def test_bands_and_successions_are_counted_by_hand() -> None:
    probs = np.array([[0.05, 0.95], [0.3, 0.6], [0.95, 0.2]])
    truth = np.array([[False, True], [False, True], [True, False]])
    sequence = (np.array([[0.05], [0.6], [0.6], [0.95]]), np.array([[0], [0], [1], [1]], bool))
    model = measure_error_model(
        probs[:, :1], truth[:, :1], fluent_names=("a",), sequences=[sequence]
    )
    # bands: p < 0.1, < 0.5, < 0.9, >= 0.9; rows: truth false, truth true
    assert model.counts.tolist() == [[[1, 1, 0, 0], [0, 0, 0, 1]]]
    pairs = model.pair_counts
    assert pairs is not None and pairs.sum() == 3
    assert pairs[0, 0, 0, 0, 2] == 1  # false -> false, band 0 -> band 2
    assert pairs[0, 0, 1, 2, 2] == 1  # false -> true, band 2 -> band 2
    assert pairs[0, 1, 1, 2, 3] == 1  # true -> true, band 2 -> band 3


def _toy_data(n: int = 160, seed: int = 0) -> FluentDataset:
    rng = np.random.default_rng(seed)
    lit = rng.random(n) < 0.5
    images = np.where(lit[:, None, None, None], 220, 30).astype(np.uint8)
    images = np.broadcast_to(images, (n, 8, 8, 3)).copy()
    return FluentDataset(
        images=images,
        labels=lit[:, None],
        fluent_names=("lit",),
        camera_spec=CameraSpec("toy", 8, 8),
    )


def test_a_trained_classifier_records_its_error_model_on_its_held_out_images(
    tmp_path: Path,
) -> None:
    data = _toy_data()
    result = train_classifier(data, training=TrainingConfig(epochs=3, seed=0), progress=False)
    model = recorded_error_model(result.detector)
    assert model is not None and model.fluent_names == ("lit",)
    assert model.counts.sum() == result.detector.training["validation_samples"]
    path = tmp_path / "c.safetensors"
    result.detector.save(path)
    again = recorded_error_model(load_classifier(path))
    assert again is not None
    np.testing.assert_array_equal(again.counts, model.counts)
    assert error_model_of(result.detector) is not None


def test_a_classifier_saved_before_error_models_loads_and_is_measured_on_what_is_given(
    tmp_path: Path,
) -> None:
    detector = ClassifierDetector.untrained(
        fluent_names=("lit",), camera_spec=CameraSpec("toy", 8, 8)
    )
    detector.training = {"validation_accuracy": {"lit": 0.5}}  # an older file's notes
    path = tmp_path / "old.safetensors"
    detector.save(path)
    old = load_classifier(path)
    assert ERROR_MODEL_NOTE not in old.training and recorded_error_model(old) is None
    with pytest.raises(MissingErrorModelError, match="labelled images"):
        error_model_of(old)
    model = error_model_of(old, labelled=_toy_data(40, seed=1))
    assert model.counts.sum() == 40


def test_a_users_detector_without_labelled_images_is_refused_with_what_to_give() -> None:
    with pytest.raises(MissingErrorModelError, match=r"labelled=FluentDataset|--labelled"):
        error_model_of(OracleDetector(("a", "b")))


def test_labelled_images_that_lack_a_detector_fluent_are_refused_by_name() -> None:
    with pytest.raises(UnknownFluentError, match="dark") as info:
        error_model_of(OracleDetector(("lit", "dark")), labelled=_toy_data(10))
    assert info.value.unknown == ("dark",)


def test_labelled_play_gives_whole_episodes_in_time_order() -> None:
    from noisybolt.envs import make_world

    world = make_world("gridworld", num_envs=4, seed=3)
    detector = OracleDetector(world.fluent_names)
    sequences = record_labelled_play(world, detector, episodes=6, seed=3)
    world.close()
    assert len(sequences) == 6
    for probs, truth in sequences:
        assert probs.shape == truth.shape and probs.shape[1] == 7
        np.testing.assert_array_equal(probs >= 0.5, truth)  # the oracle is sure and right
        # the gridworld's episodes start at (1, 1) facing east: on the edge, facing right
        assert truth[0].tolist() == [True, False, False, False, False, False, True]
    model = error_model_of(detector, sequences=sequences)
    assert model.pair_counts is not None
    frames = sum(len(p) for p, _ in sequences)
    assert model.pair_counts[0].sum() == frames - len(sequences)
