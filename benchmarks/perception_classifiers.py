"""Fluent classifiers: inference speed, training time, and confidence bands under noise.

Three measurements, all with one torch thread (FACTS.md):

1. **Inference** images/s (and ms/image) of :class:`ClassifierDetector.predict` at batch
   1, 8 and 64, for the gridworld camera (48x48 RGB, 7 fluents) and the Breakout camera
   (84x84 RGB, 1 fluent), each at its registry defaults. Target: well under 1 ms/image at
   batch 64.
2. **Training** the gridworld classifiers on clean images until every fluent's
   validation accuracy is >= 99%: collection time, training time, epochs, and the
   report on a fresh test set.
3. **Regional noise**: the same with the gridworld's default ``regional`` camera noise
   for a fixed number of epochs; the per-fluent band distribution of the predicted
   probability on true positives of a fresh test set. Target (issue 3, the paper's case
   4): ``bottom_left_corner`` mostly low-band (0.5 <= p <= 0.9), the others mostly
   high-band (p > 0.9).

Run: ``.venv/bin/python benchmarks/perception_classifiers.py`` (``--help`` for options;
``--quick`` for a smoke run). Prints tables and, with ``--json PATH``, writes the figures.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from collections.abc import Sequence
from typing import Any

import numpy as np
import torch

from noisybolt.perception.classifier import ClassifierDetector
from noisybolt.perception.dataset import collect_samples
from noisybolt.perception.metrics import ClassifierReport, build_report
from noisybolt.perception.protocols import CameraSpec
from noisybolt.perception.training import TrainingConfig, train_classifier

BATCHES = (1, 8, 64)
TARGET_ACCURACY = 0.99
DIM_FLUENT = "bottom_left_corner"


def cameras() -> dict[str, tuple[CameraSpec, tuple[str, ...]]]:
    """Camera spec and fluents of each world's bolt, as the registry builds them."""
    from noisybolt.envs import make_world

    out = {}
    for name in ("gridworld", "breakout"):
        world = make_world(name, num_envs=1, seed=0)
        out[name] = (world.camera_spec, tuple(world.fluent_names))
        world.close()
    return out


def inference(seconds: float) -> list[dict[str, Any]]:
    """images/s of an (untrained: same cost) detector per camera and batch size."""
    rows = []
    for world, (spec, fluents) in cameras().items():
        with torch.random.fork_rng(devices=[]):
            torch.manual_seed(0)
            detector = ClassifierDetector.untrained(fluent_names=fluents, camera_spec=spec)
        for batch in BATCHES:
            images = np.random.default_rng(0).integers(0, 256, (batch, *spec.shape), np.uint8)
            detector.predict(images)  # warm-up
            done, start = 0, time.perf_counter()
            while (elapsed := time.perf_counter() - start) < seconds:
                detector.predict(images)
                done += batch
            rows.append(
                {
                    "world": world,
                    "shape": list(spec.shape),
                    "batch": batch,
                    "images_per_s": done / elapsed,
                    "ms_per_image": 1e3 * elapsed / done,
                }
            )
    return rows


def _world(noise: str, *, num_envs: int, seed: int) -> Any:
    from noisybolt.envs import make_world

    return make_world("gridworld", num_envs=num_envs, seed=seed, noise=noise)


def train_gridworld(
    noise: str,
    *,
    samples: int,
    test_samples: int,
    epochs: int,
    target: float | None,
    seed: int,
) -> tuple[dict[str, Any], ClassifierReport]:
    """Collects, trains (to ``target`` if given) and reports on a fresh test set."""
    start = time.perf_counter()
    data = collect_samples(_world(noise, num_envs=16, seed=seed), num_samples=samples, seed=seed)
    collect_s = time.perf_counter() - start
    result = train_classifier(
        data,
        training=TrainingConfig(epochs=epochs, seed=seed, target_accuracy=target),
        progress=False,
    )
    test_seed = seed + 1_000_003
    test = collect_samples(
        _world(noise, num_envs=16, seed=test_seed), num_samples=test_samples, seed=test_seed
    )
    report = build_report(
        result.detector.predict(test.images), test.labels, fluent_names=test.fluent_names
    )
    summary = {
        "noise": noise,
        "camera_noise": data.camera_spec.noise,
        "samples": samples,
        "collect_s": collect_s,
        "train_s": result.seconds,
        "epochs_run": len(result.history),
        "reached_target": result.reached_target,
        "validation_min_accuracy": result.report.min_accuracy,
        "test": report.to_dict(),
    }
    return summary, report


def main(argv: Sequence[str] | None = None) -> int:
    """Runs the benchmark; returns 0, or 1 if a target was missed."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--samples", type=int, default=4000, help="training set size")
    parser.add_argument("--test-samples", type=int, default=4000, help="test set size")
    parser.add_argument("--epochs", type=int, default=30, help="most epochs per training")
    parser.add_argument("--seconds", type=float, default=2.0, help="per inference timing")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--noise", default="regional", help="the noisy run's camera noise")
    parser.add_argument("--skip-training", action="store_true", help="inference only")
    parser.add_argument("--quick", action="store_true", help="tiny sizes (smoke test)")
    parser.add_argument("--json", help="also write the figures to this file")
    args = parser.parse_args(argv)
    if args.quick:
        args.samples, args.test_samples, args.epochs, args.seconds = 200, 100, 2, 0.05
    torch.set_num_threads(1)
    print(
        f"# perception classifiers: {platform.processor() or platform.machine()}, "
        f"{os.cpu_count()} cpus, torch {torch.__version__}, 1 thread"
    )
    print(f"# command: {' '.join([sys.executable, *sys.argv])}")
    figures: dict[str, Any] = {"inference": inference(args.seconds)}
    print("\n## Inference (ClassifierDetector.predict, one torch thread)")
    print(f"{'camera':<10} {'shape':<12} {'batch':>5} {'images/s':>10} {'ms/image':>9}")
    for row in figures["inference"]:
        print(
            f"{row['world']:<10} {'x'.join(map(str, row['shape'])):<12} {row['batch']:>5d} "
            f"{row['images_per_s']:>10.0f} {row['ms_per_image']:>9.3f}"
        )
    ok = all(r["ms_per_image"] < 1.0 for r in figures["inference"] if r["batch"] == 64)
    if not args.skip_training:
        clean, clean_report = train_gridworld(
            "none",
            samples=args.samples,
            test_samples=args.test_samples,
            epochs=args.epochs,
            target=TARGET_ACCURACY,
            seed=args.seed,
        )
        figures["clean"] = clean
        print(
            f"\n## Gridworld, clean camera: train to >= {TARGET_ACCURACY:.0%} validation "
            "accuracy on every fluent"
        )
        print(
            f"collect {clean['samples']} samples: {clean['collect_s']:.1f} s; train: "
            f"{clean['train_s']:.1f} s, {clean['epochs_run']} epochs, reached: "
            f"{clean['reached_target']}"
        )
        print("fresh test set:")
        print(clean_report.format_table())
        ok &= bool(clean["reached_target"])
        noisy, noisy_report = train_gridworld(
            args.noise,
            samples=args.samples,
            test_samples=args.test_samples,
            epochs=args.epochs,
            target=None,
            seed=args.seed,
        )
        figures["noisy"] = noisy
        print(
            f"\n## Gridworld, camera noise {args.noise!r} ({noisy['camera_noise']}): "
            f"{noisy['epochs_run']} epochs, {noisy['train_s']:.1f} s"
        )
        print("fresh test set:")
        print(noisy_report.format_table())
        dim = noisy_report[DIM_FLUENT].positive_bands
        others = [f for f in noisy_report.fluents if f.name != DIM_FLUENT]
        target_met = dim.low > 0.5 and all(f.positive_bands.high > 0.5 for f in others)
        figures["noisy"]["band_target_met"] = target_met
        print(
            f"target ({DIM_FLUENT} mostly low-band, the others mostly high-band): "
            f"{'met' if target_met else 'NOT met'} ({DIM_FLUENT}: {dim.low:.1%} low, "
            f"{dim.high:.1%} high; lowest other high-band share "
            f"{min(f.positive_bands.high for f in others):.1%})"
        )
        ok &= target_met
    if args.json:
        with open(args.json, "w", encoding="utf-8") as handle:
            json.dump(figures, handle, indent=2, sort_keys=True)
    return 0 if ok or args.quick else 1


if __name__ == "__main__":
    sys.exit(main())
