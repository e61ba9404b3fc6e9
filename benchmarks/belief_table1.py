"""Table 1's rows under belief tracking: ``reproduce table1``'s sweep with ``tracking="belief"``.

The same eight rows x seeds, detector (the classifier on the smudged camera), paper
reward scheme, budgets, evaluations and stop-when-solved as ``noisybolt reproduce table1``;
only the bolt's tracking differs (``TrainConfig.tracking = "belief"``, the default belief
settings: the detector's training prior as base rate, confidence 0.9). Resumes when run
again (the sweep's own resume), then writes ``table1.md/csv/json`` in the output folder.

    nice -n 19 .venv/bin/python benchmarks/belief_table1.py runs/table1-belief [--seeds 3]
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import torch

from noisybolt.experiments.sweeps import SweepConfig
from noisybolt.experiments.sweeps.run import run_sweep
from noisybolt.experiments.table1 import table1_sweep, write_table1


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", help="the sweep's folder (resumed if it exists)")
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    torch.set_num_threads(1)
    source = dict(table1_sweep(seeds=args.seeds).source)
    source["base"] = {**source["base"], "bolt.tracking": "belief"}
    source["name"] = "table1-belief"
    sweep = SweepConfig.from_dict(source)
    started, load = time.perf_counter(), os.getloadavg()[0]
    run_sweep(sweep, args.out, backend="local", workers=args.workers, argv=sys.argv)
    first = sweep.trials[0].config  # the base's settings, as every trial holds them
    settings = {
        "seeds": list(sweep.seeds),
        "detector": first.detector.kind,
        "noise": first.world_kwargs["noise"],
        "final_eval_episodes": sweep.final_eval_episodes,
        "eval_episodes": first.eval_episodes,
        "keep_best": first.keep_best,
        "stop_after": first.stop_after,
        "frames_scale": 1.0,
        "frames": {t.row: t.config.frames for t in sweep.trials},
        "eval_freq": {t.row: t.config.eval_freq for t in sweep.trials},
        "backend": "local",
        "workers": args.workers,
        "cpus": os.cpu_count(),
        "load_average_at_start": round(load, 2),
        "wall_seconds": round(time.perf_counter() - started, 1),
    }
    write_table1(args.out, settings=settings)


if __name__ == "__main__":
    main()
