"""The gridworld's on-the-fly classifier: cheaper trunks against the current one.

Each architecture is trained exactly as ``noisybolt train`` trains the cached classifier
(:func:`noisybolt.runs.detectors.make_detector`: 4,000 images collected from the
gridworld with its default ``regional`` noise by 16 environments, 30 epochs, data and
training seeded by the detector's seed), for several seeds, then reported on a fresh
test set of the same camera (its own seed): per fluent accuracy, AUROC, expected
calibration error, and the confidence bands of true positives (case 4's premise:
``bottom_left_corner`` mostly in the low band, the others high). Beside it, the
milliseconds of one ``predict`` call at 8 and 32 images, one torch thread.

    .venv/bin/python benchmarks/classifier_architectures.py [--seeds 3] [--test-samples 4000]
        [--architectures 32x32,16x16]
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

import numpy as np
import torch

from noisybolt.envs import make_world
from noisybolt.perception.classifier import ClassifierConfig, ClassifierDetector
from noisybolt.perception.dataset import collect_samples
from noisybolt.perception.metrics import build_report
from noisybolt.perception.training import TrainingConfig, train_classifier

SAMPLES, EPOCHS, TILE = 4000, 30, 8
LOW_FLUENT = "bottom_left_corner"


def architecture(name: str) -> ClassifierConfig:
    """``"32x32"``: tile-reading convolutions of 32 then 32 channels (``/h32``: hidden)."""
    channels, _, hidden = name.partition("/h")
    return ClassifierConfig(
        channels=tuple(int(c) for c in channels.split("x")),
        patch=TILE,
        hidden=int(hidden) if hidden else 64,
    )


def predict_ms(detector: ClassifierDetector, images: np.ndarray, batch: int) -> float:
    x = images[:batch]
    detector.predict(x)
    times = []
    for _ in range(5):
        start, n = time.perf_counter(), 0
        while time.perf_counter() - start < 0.2:
            detector.predict(x)
            n += 1
        times.append((time.perf_counter() - start) / n * 1e3)
    return min(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--test-samples", type=int, default=4000)
    parser.add_argument("--architectures", default="32x32,16x16")
    args = parser.parse_args()
    torch.set_num_threads(1)
    names = args.architectures.split(",")
    tester = make_world("gridworld", num_envs=16, seed=1000, noise="regional")
    test = collect_samples(tester, num_samples=args.test_samples, seed=1000)
    rows: dict[str, list[dict[str, float]]] = {name: [] for name in names}
    timing: dict[str, tuple[float, float]] = {}
    for seed in range(args.seeds):
        collector = make_world("gridworld", num_envs=16, seed=seed, noise="regional")
        data = collect_samples(collector, num_samples=SAMPLES, seed=seed)
        for name in names:
            result = train_classifier(
                data,
                config=architecture(name),
                training=TrainingConfig(epochs=EPOCHS, seed=seed),
                progress=False,
            )
            probs = result.detector.predict(test.images)
            report = build_report(probs, test.labels, fluent_names=test.fluent_names)
            row: dict[str, float] = {"train_s": result.seconds}
            for f in report.fluents:
                row[f"{f.name}:acc"] = f.accuracy
                row[f"{f.name}:auroc"] = f.auroc
                row[f"{f.name}:ece"] = f.ece
                row[f"{f.name}:high"] = f.positive_bands.high
                row[f"{f.name}:low"] = f.positive_bands.low
            rows[name].append(row)
            if name not in timing:
                timing[name] = (
                    predict_ms(result.detector, test.images, 8),
                    predict_ms(result.detector, test.images, 32),
                )
            print(f"seed {seed} {name}: trained in {result.seconds:.1f} s", flush=True)
    print(
        f"\nGridworld classifier, regional noise, {SAMPLES} training images, {EPOCHS} epochs, "
        f"{args.seeds} seeds; fresh test set of {args.test_samples}; mean (min-max) over seeds; "
        f"load average {os.getloadavg()[0]:.1f}"
    )
    for name in names:
        ms8, ms32 = timing[name]
        n_params = sum(
            p.numel() for p in ClassifierDetector.untrained(
                fluent_names=test.fluent_names, camera_spec=test.camera_spec,
                config=architecture(name)
            ).model.parameters()
        )  # fmt: skip
        print(
            f"\n== {name}: predict {ms8:.3f} ms (8 images), {ms32:.3f} ms (32 images); "
            f"{n_params:,} parameters"
        )
        print(f"{'fluent':<20} {'accuracy':>20} {'AUROC':>20} {'ECE':>20} {'TP high / low':>22}")
        for fluent in test.fluent_names:

            def cell(key: str, runs: list[dict[str, float]] = rows[name], f: str = fluent) -> str:
                values = [r[f"{f}:{key}"] for r in runs]
                return f"{statistics.mean(values):.4f} ({min(values):.3f}-{max(values):.3f})"

            high = statistics.mean(r[f"{fluent}:high"] for r in rows[name])
            low = statistics.mean(r[f"{fluent}:low"] for r in rows[name])
            print(
                f"{fluent:<20} {cell('acc'):>20} {cell('auroc'):>20} {cell('ece'):>20} "
                f"{high:>10.3f} / {low:.3f}"
            )


if __name__ == "__main__":
    main()
