"""Markdown table of Breakout runs' periodic evaluations, side by side.

    .venv/bin/python scripts/breakout_table.py runs/breakout-ms-bolted runs/breakout-ms-unbolted

Per evaluation (rows: frames): each run's game score (mean ± std over the evaluation's
episodes), the share of episodes that cleared the whole left column (``clear_left_column``
from ground truth), and the mean number of the left column's bricks gone at the end of an
episode (the sum of the ``left_row*`` compliance rates, also from ground truth), and the
bolt's false acceptances: the share of episodes in which some spec's DFA, run on what the
bolt perceived, ended accepting while the true trace did not (the largest over the specs;
"—" for runs recorded before the bolt's view was kept).

    .venv/bin/python scripts/breakout_table.py --pool 5 runs/breakout-ram-ppo-*-seed[01]

``--pool K`` prints one row per run instead, over its last K evaluations together (one
evaluation's 8 episodes read a 50 % share to within about ±18 points; K of them pooled
narrow that by sqrt(K)): the frames they span, the episodes, the share that cleared the
column with its 95 % Wilson interval, the mean score and left bricks gone with the
standard error of the evaluations' means (the records keep each evaluation's means, not
its episodes), and the share of episodes that took each of the column's bricks, top row
first (where a player stops on the way up). A learning run still improves across those
evaluations: keep K small against the run's length.
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
from pathlib import Path


def _records(run: Path) -> dict[int, dict]:
    """A run's evaluations by frames ({} before its first evaluation)."""
    path = run / "metrics.json"
    if not path.exists():
        if not (run / "config.json").exists():
            raise SystemExit(f"{run} holds no run (no config.json)")
        return {}
    return {int(r["frames"]): r for r in json.loads(path.read_text())}


def _cell(record: dict | None) -> list[str]:
    if record is None:
        return ["", "", "", ""]
    rates = record["compliance"]
    bricks = sum(v for k, v in rates.items() if k.startswith("left_row"))
    cleared = rates.get("clear_left_column")
    return [
        f"{record['env_return_mean']:.1f} ± {record['env_return_std']:.1f}",
        "—" if cleared is None else f"{cleared:.0%}",
        f"{bricks:.2f}" if any(k.startswith("left_row") for k in rates) else "—",
        _false_acceptance(record),
    ]


def _false_acceptance(record: dict) -> str:
    false = record.get("false_acceptance") or {}
    return f"{max(false.values()):.0%}" if false else "—"


def wilson_interval(successes: float, n: int, z: float = 1.96) -> tuple[float, float]:
    """The 95 % Wilson score interval of a binomial share ``successes / n``.

    Example:
        >>> [round(x, 3) for x in wilson_interval(0, 40)]
        [0.0, 0.088]
    """
    if n <= 0:
        raise ValueError(f"a share needs at least one episode, got n={n}")
    p = successes / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return max(0.0, centre - half), min(1.0, centre + half)


def pooled(records: dict[int, dict], last: int, upto: int | None = None) -> dict[str, float]:
    """A run's last ``last`` evaluations (at or below ``upto`` frames, so that runs that
    trained for different lengths compare at the same frames) together: frames spanned,
    episodes, column share (episode-weighted) and its Wilson interval, mean score and left
    bricks gone with the standard error of the evaluations' means (0 for one evaluation)."""
    if last < 1:
        raise ValueError(f"--pool takes a number of evaluations >= 1, got {last}")
    kept = sorted(f for f in records if upto is None or f <= upto)
    chosen = [records[f] for f in kept[-last:]]
    if not chosen:
        raise ValueError("the run has no evaluation yet")
    episodes = [int(r["n_episodes"]) for r in chosen]
    n = sum(episodes)
    cleared = sum(
        r["compliance"].get("clear_left_column", 0.0) * e
        for r, e in zip(chosen, episodes, strict=True)
    )
    scores = [float(r["env_return_mean"]) for r in chosen]
    bricks = [
        sum(v for k, v in r["compliance"].items() if k.startswith("left_row")) for r in chosen
    ]

    rows = sorted(k for k in chosen[0]["compliance"] if k.startswith("left_row"))
    by_row = [
        sum(r["compliance"].get(k, 0.0) * e for r, e in zip(chosen, episodes, strict=True)) / n
        for k in rows
    ]

    def se(values: list[float]) -> float:
        return statistics.stdev(values) / math.sqrt(len(values)) if len(values) > 1 else 0.0

    low, high = wilson_interval(cleared, n)
    return {
        "first": min(int(r["frames"]) for r in chosen),
        "last": max(int(r["frames"]) for r in chosen),
        "episodes": n,
        "cleared": cleared / n,
        "cleared_low": low,
        "cleared_high": high,
        "score": statistics.fmean(scores),
        "score_se": se(scores),
        "bricks": statistics.fmean(bricks),
        "bricks_se": se(bricks),
        "rows": by_row,  # left_row0 (top) .. left_row5: the share of episodes it went
    }


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("runs", nargs="+", type=Path)
    parser.add_argument(
        "--pool", type=int, default=0, metavar="K", help="pool the last K evaluations per run"
    )
    parser.add_argument(
        "--upto",
        type=int,
        default=None,
        metavar="FRAMES",
        help="with --pool: only evaluations at or below FRAMES (runs compared at equal frames)",
    )
    args = parser.parse_args(argv)
    runs: list[Path] = args.runs
    records = [_records(r) for r in runs]
    if args.pool:
        print(
            "| run | frames | episodes | column cleared (95 % CI) | score | left bricks gone "
            "| each brick gone, top row first |"
        )
        print("|---|---|---:|---|---:|---:|---|")
        for run, rec in zip(runs, records, strict=True):
            if not rec or (args.upto is not None and min(rec) > args.upto):
                print(f"| {run.name} | no evaluation yet | | | | | |")
                continue
            p = pooled(rec, args.pool, args.upto)
            print(
                f"| {run.name} | {p['first'] // 1000}k–{p['last'] // 1000}k | {p['episodes']} | "
                f"{p['cleared']:.0%} ({p['cleared_low']:.0%}–{p['cleared_high']:.0%}) | "
                f"{p['score']:.1f} ± {p['score_se']:.1f} | "
                f"{p['bricks']:.2f} ± {p['bricks_se']:.2f} | "
                + " ".join(f"{share:.0%}" for share in p["rows"])
                + " |"
            )
        return
    header = ["frames"]
    for run in runs:
        header += [f"{run.name}: score", "column cleared", "left bricks gone", "bolt false acc."]
    print("| " + " | ".join(header) + " |")
    print("|" + "---:|" * len(header))
    for frames in sorted(set().union(*records)):
        row = [f"{frames // 1000}k"]
        for rec in records:
            row += _cell(rec.get(frames))
        print("| " + " | ".join(row) + " |")


if __name__ == "__main__":
    main()
