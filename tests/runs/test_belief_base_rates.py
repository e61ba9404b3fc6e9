"""Belief tracking in a run estimates each fluent's base rate in play from the detector
alone (prior shift, Saerens et al. 2002) and builds every env of the run with it."""

from __future__ import annotations

import numpy as np
import pytest

from noisybolt.envs import make_world
from noisybolt.perception.classifier import ClassifierDetector
from noisybolt.perception.dataset import FluentDataset
from noisybolt.perception.protocols import CameraSpec
from noisybolt.perception.training import TrainingConfig, train_classifier
from noisybolt.runs.config import DetectorConfig, TrainConfig
from noisybolt.runs.environments import make_env, prepare_bolt
from noisybolt.runs.play import BASE_RATE_PLAY
from noisybolt.runs.resolution import resolve


def _config(kind: str = "synthetic", **kwargs: object) -> TrainConfig:
    return resolve(
        TrainConfig.create(
            world="gridworld",
            specs=["edge"],
            detector=DetectorConfig(kind=kind),
            frames=64,
            progress_bar=False,
            **kwargs,  # type: ignore[arg-type]
        )
    )


def _truth_frequencies(config: TrainConfig) -> np.ndarray:
    """Each fluent's frequency in the same seeded random play, from ground truth: every
    state reached, the last states of the episodes it ended included."""
    n_envs, steps = BASE_RATE_PLAY
    world = make_world("gridworld", num_envs=n_envs, seed=config.seed + 1)
    world.reset(seed=config.seed + 1)
    world.action_space.seed(config.seed + 1)
    seen = [np.asarray(world.true_fluents())]
    for _ in range(steps):
        _, _, terminated, truncated, info = world.step(world.action_space.sample())
        ended = np.logical_or(terminated, truncated)
        if ended.any():
            seen.append(np.asarray(info["final_info"]["true_fluents"])[ended])
        seen.append(np.asarray(world.true_fluents()))
    return np.concatenate(seen).mean(axis=0)


def test_an_exact_detector_gives_the_frequencies_of_play_floored_at_one_percent() -> None:
    # The oracle's 0/1 probabilities are their own posterior under any prior: EM's fixed
    # point is each fluent's frequency in the seeded random play, by hand from the truth.
    config = _config("oracle", tracking="belief", seed=3)
    setup = prepare_bolt(config, seed=config.seed, log=lambda _: None)
    assert setup.belief is not None
    truth = _truth_frequencies(config)
    np.testing.assert_allclose(setup.belief.base_rates, np.maximum(truth, 0.01), atol=1e-6)


def test_base_rates_are_estimated_without_labels_close_to_the_truth_of_play() -> None:
    # The synthetic detector's Beta noise is not a calibrated posterior, so EM is only
    # close: within 0.03 of the truth's frequency (measured: 0.021 at most, seed 3).
    config = _config(tracking="belief", seed=3)
    lines: list[str] = []
    setup = prepare_bolt(config, seed=config.seed, log=lines.append)
    assert setup.belief is not None and setup.belief.confidence == config.bolt.confidence
    rates = np.asarray(setup.belief.base_rates)
    truth = _truth_frequencies(config)
    np.testing.assert_allclose(rates, np.maximum(truth, 0.01), atol=0.03)
    assert any("base rates in play" in line for line in lines)
    # Training and evaluation estimate the same (seeded by the run's seed).
    again = prepare_bolt(config, seed=config.seed + 10_000, log=lambda _: None)
    assert again.belief == setup.belief


def test_threshold_tracking_estimates_nothing() -> None:
    assert prepare_bolt(_config(), seed=0, log=lambda _: None).belief is None


def test_every_env_of_the_run_tracks_with_the_estimated_rates() -> None:
    config = _config(tracking="belief")
    setup = prepare_bolt(config, seed=0, log=lambda _: None)
    for training in (True, False):
        env = make_env(
            config,
            setup.detector,
            training=training,
            n_envs=2,
            dfas=setup.dfas,
            letters=setup.letters,
            belief=setup.belief,
        )
        bolted = env
        while not hasattr(bolted, "bolt"):
            bolted = bolted.venv  # type: ignore[attr-defined]
        assert bolted.bolt.belief_settings == setup.belief
        env.close()


def test_a_trained_classifier_records_the_prior_its_probabilities_carry() -> None:
    rng = np.random.default_rng(0)
    spec = CameraSpec("toy", 8, 8)
    labels = np.zeros((40, 2), dtype=bool)
    labels[:10, 0] = True  # a: 1 in 4 images
    labels[:30, 1] = True  # b: 3 in 4
    images = rng.integers(0, 256, size=(40, 8, 8, 3), dtype=np.uint8)
    data = FluentDataset(
        images=images, labels=labels, fluent_names=("a", "b"), camera_spec=spec, seed=0
    )
    training = TrainingConfig(epochs=1, seed=0, validation_fraction=0.25)
    detector = train_classifier(data, training=training).detector
    split = data.split(0.25, seed=0)
    expected = tuple(float(m) for m in split.train.labels.mean(axis=0))
    assert detector.training_prior == pytest.approx(expected)
    # A file written before the prior was recorded: unknown, not guessed.
    old = ClassifierDetector(
        model=detector.model, fluent_names=("a", "b"), camera_spec=spec, training={}
    )
    assert old.training_prior is None


def test_a_world_declaring_monotone_fluents_has_them_believed_monotone() -> None:
    # Breakout's bricks gone stay gone: the run's belief is told so, fluent by fluent; the
    # gridworld declares none (an agent leaves a corner).
    breakout = resolve(
        TrainConfig.create(
            world="breakout-ram",
            specs=["left_row5", "clear_left_column"],
            detector=DetectorConfig(kind="oracle"),
            tracking="belief",
            frames=64,
            progress_bar=False,
        )
    )
    lines: list[str] = []
    setup = prepare_bolt(breakout, seed=0, log=lines.append)
    world = make_world("breakout-ram", num_envs=1, seed=0)
    assert setup.belief is not None
    assert setup.belief.monotone == world.monotone_fluents == world.fluent_names
    assert any("monotone (true once" in line for line in lines)
    grid = prepare_bolt(_config("oracle", tracking="belief"), seed=0, log=lambda _: None)
    assert grid.belief is not None and grid.belief.monotone == ()
    subset = make_world("breakout-ram", num_envs=1, seed=0, fluents=["left_gone_row5"])
    assert subset.monotone_fluents == ("left_gone_row5",)
