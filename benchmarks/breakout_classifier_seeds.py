"""How the bolt's on-the-fly Breakout classifier reads a trained agent's games, per seed.

A run trains its classifier on the fly (``noisybolt train --detector classifier``: 4,000
images of random play and scripted walls, 30 epochs, seeded by the run's seed) and the bolt
then watches the agent's own games, which random play and the scripted walls only
approximate. For each classifier seed this reports, under one camera:

- **test accuracy** per fluent on fresh images collected the same way (seed 1000): what a
  user can see without a trained agent;
- **agent frames** per fluent: the share of a trained run's frames read at p >= 0.5 where
  the fluent is true (hits) and where it is false (false alarms);
- the bolt on those games, replayed as in ``belief_tracking.py``: **recall** of belief
  tracking (of the episodes whose true trace accepted a spec, the share the bolt accepted
  too) and the **false acceptance** of threshold and belief tracking (the largest over the
  specs). Belief tracking as ``noisybolt train --tracking belief`` sets it up: the default
  settings, base rates by EM on random play against the classifier's training prior, and
  with ``--monotone`` the world's monotone fluents, as runs pass them since dd942c4
  (without it, as runs did before).

The agent's episodes are recorded once (its policy on ground-truth DFA states, sampled
actions; :func:`belief_tracking.agent_play`) and every classifier reads the same frames.
The classifiers are those ``noisybolt train --seed S`` uses (cached, or trained here into
the same cache): with ``--restarts 1`` each seed's single classifier, with ``--restarts 3``
the one kept of up to three (``detector.restarts``).

    .venv/bin/python benchmarks/breakout_classifier_seeds.py --seeds 0,1,2 \\
        --agent results/breakout/breakout-ram-ppo-bolted-seed0 \\
        --agent results/breakout/breakout-ram-ppo-bolted-seed1 --episodes 16 [--restarts 3]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from noisybolt.envs import make_world
from noisybolt.perception.base_rates import belief_settings_from_play
from noisybolt.perception.dataset import collect_samples
from noisybolt.perception.metrics import build_report
from noisybolt.runs.detectors import DetectorConfig, make_detector
from noisybolt.runs.specs import expand_specs, resolve_spec

sys.path.insert(0, str(Path(__file__).resolve().parent))  # its sibling, when loaded by path
import belief_tracking as bt  # the recording and the replay

WORLD = "breakout-ram"
TEST_SEED = 1000


class ImageLog:
    """A stand-in detector for recording: it keeps every image it is shown and answers
    with the image's index as its one "probability", so a recorded episode's rows name
    its images (``images[episode.probs[:, 0]]``)."""

    needs_truth = False

    def __init__(self) -> None:
        self.images: list[np.ndarray] = []

    def predict(self, images: np.ndarray, *, truth: np.ndarray | None = None) -> np.ndarray:
        first = len(self.images)
        self.images.extend(np.array(images))
        return np.arange(first, len(self.images), dtype=np.float64)[:, None]


def record_agents(
    runs: list[str], noise: str, episodes: int, n_envs: int
) -> tuple[list[Any], np.ndarray]:
    """The agents' episodes (rows name images) and the images, ``uint8 [frames, S, S, 3]``."""
    log = ImageLog()
    recorded = []
    for run in runs:
        world, agent = bt.agent_play(run, noise, 123, n_envs)
        recorded += bt.record(world, log, episodes, 123, 4, agent=agent)
    return recorded, np.stack(log.images)


def classifier(seed: int, noise: str, world: Any, **settings: int) -> Any:
    """The classifier ``noisybolt train --world breakout-ram --noise NOISE --seed SEED``
    uses with the ``detector`` settings given (``restarts``, ``samples``, ``epochs``; its
    world kwargs hold the noise only, as a run's do)."""
    return make_detector(
        DetectorConfig(kind="classifier", seed=seed, **settings),
        world=WORLD,
        world_kwargs={"noise": noise},
        fluent_names=world.fluent_names,
        camera_spec=world.camera_spec,
        progress=False,
        log=lambda line: print(f"  seed {seed}: {line.splitlines()[0]}", flush=True),
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--seeds", default="0,1,2", help="classifier seeds, comma-separated")
    parser.add_argument("--agent", action="append", required=True, metavar="RUN_DIR")
    parser.add_argument("--episodes", type=int, default=16, help="per agent")
    parser.add_argument("--n-envs", type=int, default=8)
    parser.add_argument(
        "--setting",
        default="breakout-occlusion",
        choices=("breakout-occlusion", "breakout-sigma50"),
        help="the bolt camera (belief_tracking.py's settings)",
    )
    parser.add_argument("--test-samples", type=int, default=2000)
    parser.add_argument(
        "--monotone",
        action="store_true",
        help="belief tracking told the world's monotone fluents (a brick gone stays gone), "
        "as runs are since dd942c4",
    )
    parser.add_argument("--samples", type=int, default=4000, help="detector.samples")
    parser.add_argument("--epochs", type=int, default=30, help="detector.epochs")
    parser.add_argument(
        "--restarts",
        type=int,
        default=1,
        help="detector.restarts: 1, each seed's one classifier (as runs saved before "
        "restarts existed); 3, the classifier a new run gets",
    )
    args = parser.parse_args()
    import torch

    torch.set_num_threads(1)
    noise = bt.BREAKOUT_CAMERAS[args.setting]
    seeds = [int(s) for s in args.seeds.split(",")]
    start = time.perf_counter()
    episodes, images = record_agents(args.agent, noise, args.episodes, args.n_envs)
    truth = np.concatenate([e.truth for e in episodes])
    world = make_world(WORLD, num_envs=args.n_envs, seed=123, noise=noise, fire_on_reset=True)
    fluents = tuple(world.fluent_names)
    specs = tuple(resolve_spec(n) for n in expand_specs(["left_column_milestones"]))
    test = collect_samples(
        make_world(WORLD, num_envs=16, seed=TEST_SEED, noise=noise),
        num_samples=args.test_samples,
        seed=TEST_SEED,
    )
    print(
        f"### {args.setting}, detector restarts={args.restarts} samples={args.samples} "
        f"epochs={args.epochs}: {len(episodes)} episodes "
        f"of {', '.join(args.agent)} "
        f"({len(images):,} frames; recorded in {time.perf_counter() - start:.0f} s); "
        f"frames where each fluent is true: "
        + ", ".join(f"{f} {int(n)}" for f, n in zip(fluents, truth.sum(axis=0), strict=True)),
        flush=True,
    )
    short = [f.replace("left_gone_", "").replace("brick_clear_left", "clear") for f in fluents]
    rows = []
    for seed in seeds:
        detector = classifier(
            seed, noise, world, restarts=args.restarts, samples=args.samples, epochs=args.epochs
        )
        report = build_report(detector.predict(test.images), test.labels, fluent_names=fluents)
        accuracy = [fluent.accuracy for fluent in report.fluents]
        probs = detector.predict(images).astype(np.float64)
        seen = [bt.Episode(probs[e.probs[:, 0].astype(int)], e.truth) for e in episodes]
        read = np.concatenate([e.probs for e in seen]) >= 0.5
        hits = [read[truth[:, k], k].mean() if truth[:, k].any() else np.nan for k in range(7)]
        alarms = [read[~truth[:, k], k].mean() for k in range(7)]
        # base rates as `noisybolt train --tracking belief` estimates them: EM on random
        # play against the classifier's training prior, the default belief settings
        calibration = bt.record(world, detector, 24, 124, 4)
        prior = getattr(detector, "training_prior", None)
        belief = belief_settings_from_play(
            [e.probs for e in calibration],
            training_prior=0.5 if prior is None else prior,
            monotone=world.monotone_fluents if args.monotone else (),
        )
        threshold = bt.rates(*bt.replay(seen, specs, fluents, tracking="threshold"))
        believed = bt.rates(*bt.replay(seen, specs, fluents, tracking="belief", belief=belief))
        rows.append((seed, accuracy, hits, alarms, threshold, believed))
    print("\n| seed | test accuracy (" + ", ".join(short) + ") | agent frames read gone where gone"
          " | false alarms per frame, worst | belief recall (" + ", ".join(s.name for s in specs)
          + ") | false acc. threshold / belief, worst |")  # fmt: skip
    print("|---:|---|---|---:|---|---|")
    for seed, accuracy, hits, alarms, threshold, believed in rows:
        worst = specs[int(np.argmax(believed[0]))].name
        print(
            f"| {seed} | {' '.join(f'{a:.3f}' for a in accuracy)} "
            f"| {' '.join('n/a' if np.isnan(h) else f'{h:.2f}' for h in hits)} "
            f"| {max(alarms):.3f} "
            f"| {' '.join(bt._pct(r) for r in believed[1])} "
            f"| {threshold[0].max():.0%} / {believed[0].max():.0%} ({worst}) |"
        )


if __name__ == "__main__":
    main()
