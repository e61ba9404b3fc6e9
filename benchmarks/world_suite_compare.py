"""Two reward schemes on the world suite, side by side with the unbolted controls.

Reads finished trials (their ``summary.json``) from world-suite output folders laid out as
``world_suite.py`` writes them (``WORLD/ALGO/specN|unbolted/seedS``), one folder per
scheme (or ``FOLDER+FOLDER+...``: layers, a trial found in a later one replacing the
earlier one's, as a round that re-ran some trials leaves them), and prints one row per
(world, spec, algorithm, seed) that has a control:
compliance / goal rate / return of the control, then of each scheme; then, per scheme, the
"task kept" line of :func:`world_suite.task_kept` (each bolted trial against the control of
its own seed).

    cd benchmarks && ../.venv/bin/python world_suite_compare.py \\
        --controls ../runs/ws-compliance \\
        compliance=../runs/ws-compliance constrained=../runs/ws-constrained4
    ../.venv/bin/python world_suite_compare.py --algos ppo,a2c --seeds 3 \\
        --controls ../results/world_suite/defaults/controls \\
        now=../results/world_suite/defaults/constrained+../results/world_suite/searched+../results/world_suite/window
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import world_suite as ws


def _record(roots: Sequence[Path], world_path: str, spec: str | None, algo: str, seed: int) -> Any:
    """The finished trial's record as ``world_suite.py`` reads it, from the last of the
    layered folders that holds it (None: not finished in any)."""
    for root in reversed(roots):
        args = argparse.Namespace(out=str(root), collect=True)
        record = ws.run_trial(world_path, spec, algo, seed, args)
        if record is not None:
            return record
    return None


def _cell(record: dict[str, Any] | None) -> str:
    if record is None:
        return "–"
    goal = "–" if record["goal_rate"] is None else f"{record['goal_rate']:.0%}"
    return f"{record['compliance']:.0%} / {goal} / {record['env_return']:.2f}"


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--controls", type=Path, required=True, help="folder of the controls")
    parser.add_argument("--seeds", type=int, default=2)
    parser.add_argument("--algos", default="ppo,a2c")
    parser.add_argument("schemes", nargs="+", metavar="NAME=FOLDER")
    args = parser.parse_args(argv)
    # absolute: run_trial reads from the folder holding unseen_worlds.py
    schemes = [
        (name, [Path(folder).resolve() for folder in folders.split("+")])
        for name, _, folders in (text.partition("=") for text in args.schemes)
    ]
    controls = [args.controls.resolve()]
    ws._load_worlds()
    print(
        "| world | spec | algo | seed | control: compliance / goal / return | "
        + " | ".join(name for name, _ in schemes)
        + " |"
    )
    print("|---|---|---|---:|---|" + "---|" * len(schemes))
    per_scheme: dict[str, list[dict[str, Any]]] = {name: [] for name, _ in schemes}
    for world_path, specs in ws.WORLD_SPECS.items():
        world = world_path.split(":")[1]
        for algo in args.algos.split(","):
            for seed in range(args.seeds):
                control = _record(controls, world_path, None, algo, seed)
                if control is None:
                    continue
                for spec in specs:
                    found = [_record(root, world_path, spec, algo, seed) for _, root in schemes]
                    if all(r is None for r in found):
                        continue
                    for (name, _), record in zip(schemes, found, strict=True):
                        if record is not None:
                            per_scheme[name] += [control, record]
                    print(
                        f"| {world} | `{spec}` | {algo.upper()} | {seed} | {_cell(control)} | "
                        + " | ".join(_cell(r) for r in found)
                        + " |"
                    )
    print()
    for name, records in per_scheme.items():
        kept, counted, per_world = ws.task_kept(records, 0.95)
        worlds = ", ".join(f"{w} {k}/{n}" for w, (k, n) in sorted(per_world.items()))
        print(f"{name}: task kept {kept}/{counted} ({worlds})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
