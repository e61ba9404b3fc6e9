"""Chosen trials of the world suite, in order, in one process.

``world_suite.py`` runs every (world, spec, algorithm, seed) of the worlds it is given;
this runs the ones named, each as ``world_suite.run_trial`` trains it (the same folders,
the same record), with the same ``--set`` and ``--hp`` settings for all:

    cd benchmarks && ../.venv/bin/python world_suite_trials.py --out ../runs/ws \\
        --set bolt.reward=constrained -- lake8:0:2:ppo lava:u:0:ppo

A trial is ``WORLD:SPEC:SEED:ALGO``: ``SPEC`` the index of the spec in
``unseen_worlds.WORLDS`` (``u``: the unbolted control). Each prints its record as it
ends, with its wall time (a trial that fails prints its error and the next one runs).
"""

from __future__ import annotations

import argparse
import time
import traceback
from collections.abc import Sequence

import world_suite as ws


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", required=True, help="the world suite's output folder")
    parser.add_argument("--set", action="append", default=[], metavar="PATH=VALUE")
    parser.add_argument("--hp", action="append", default=[], metavar="KEY=VALUE")
    parser.add_argument("--frames", type=int, default=0, help="0: each world's own budget")
    parser.add_argument("--eval-episodes", type=int, default=20)
    parser.add_argument("--detector", default="synthetic")
    parser.add_argument("trials", nargs="+", metavar="WORLD:SPEC:SEED:ALGO")
    args = parser.parse_args(argv)
    ws._load_worlds()
    for text in args.trials:
        try:
            world, index, seed, algo = text.split(":")
            world_path = f"unseen_worlds:{world}"
            spec = None if index == "u" else ws.WORLD_SPECS[world_path][int(index)]
        except (ValueError, KeyError, IndexError):
            parser.error(f"a trial is WORLD:SPEC:SEED:ALGO with a known world, got {text!r}")
        trial = argparse.Namespace(
            out=args.out,
            collect=False,
            detector=args.detector,
            frames=args.frames,
            eval_freq=10_000,
            eval_episodes=args.eval_episodes,
            hp=args.hp,
            set=args.set,
        )
        started = time.perf_counter()
        try:
            record: object = ws.run_trial(world_path, spec, algo, int(seed), trial)
        except Exception as error:  # one failed trial must not stop the others
            traceback.print_exc()
            record = f"FAILED {error!r}"
        print(text, f"{time.perf_counter() - started:.0f}s", record, flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
