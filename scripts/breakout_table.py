"""Markdown table of Breakout runs' periodic evaluations, side by side.

    .venv/bin/python scripts/breakout_table.py runs/breakout-ms-bolted runs/breakout-ms-unbolted

Per evaluation (rows: frames): each run's game score (mean ± std over the evaluation's
episodes), the share of episodes that cleared the whole left column (``clear_left_column``
from ground truth), and the mean number of the left column's bricks gone at the end of an
episode (the sum of the ``left_row*`` compliance rates, also from ground truth), and the
bolt's false acceptances: the share of episodes in which some spec's DFA, run on what the
bolt perceived, ended accepting while the true trace did not (the largest over the specs;
"—" for runs recorded before the bolt's view was kept).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path


def _records(run: Path) -> dict[int, dict]:
    return {int(r["frames"]): r for r in json.loads((run / "metrics.json").read_text())}


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


def main(argv: list[str]) -> None:
    runs = [Path(a) for a in argv]
    records = [_records(r) for r in runs]
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
    main(sys.argv[1:])
