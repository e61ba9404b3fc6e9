"""A benchmark before and after a change, in one run: two source trees, interleaved rounds.

Runs ``benchmarks/SCRIPT`` of an older tree (``--before``, e.g. a ``git worktree`` of the
commit before the change, with ``PYTHONPATH=BEFORE/src``) and of a newer one (``--after``,
default this tree) in turns, ``--rounds`` times each (the order alternates every round),
so a load that comes and goes on a shared machine hits both alike. Each script prints its
figures as lines ending in numbers (``label  123,456  1.2x``); the figures of a label are
the trailing numeric columns of its line (columns are two or more spaces apart). Prints,
per label, the median of each figure before and after, and after / before of the first.

    git worktree add --detach /tmp/nb_before <commit before the change>
    .venv/bin/python benchmarks/before_after.py --before /tmp/nb_before --rounds 3 \\
        -- benchmarks/perception_world.py --seconds 0.5 --repeats 3
"""

from __future__ import annotations

import argparse
import os
import re
import statistics
import subprocess
import sys
from pathlib import Path

_NUMBER = re.compile(r"^[+-]?[\d,]*\.?\d+[x%]?$")


def figures(output: str) -> dict[str, list[float]]:
    """``{label: trailing numbers}`` of every output line that ends in numbers."""
    out: dict[str, list[float]] = {}
    for line in output.splitlines():
        tokens = re.split(r"\s{2,}", line.strip())  # columns: two or more spaces apart
        values: list[float] = []
        while tokens and _NUMBER.match(tokens[-1]):
            values.insert(0, float(tokens.pop().rstrip("x%").replace(",", "")))
        if values and tokens:
            out["  ".join(tokens)] = values
    return out


def run(tree: Path, script: str, args: list[str]) -> dict[str, list[float]]:
    env = dict(os.environ, PYTHONPATH=str(tree / "src"))
    done = subprocess.run(
        [sys.executable, str(tree / script), *args],
        env=env,
        cwd=tree,
        capture_output=True,
        text=True,
        check=False,
    )
    if done.returncode not in (0, 1):  # perception_world exits 1 when a target is missed
        raise SystemExit(f"{tree / script} failed ({done.returncode}):\n{done.stderr[-2000:]}")
    return figures(done.stdout)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--before", type=Path, required=True, help="the older source tree")
    parser.add_argument(
        "--after", type=Path, default=None, help="the newer source tree (default: this one)"
    )
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("script", help="the benchmark, relative to a tree's root")
    parser.add_argument("args", nargs=argparse.REMAINDER, help="its arguments (after --)")
    options = parser.parse_args(argv)
    args = [a for a in options.args if a != "--"]
    after = options.after or Path(__file__).resolve().parent.parent
    trees = {"before": options.before.resolve(), "after": after.resolve()}
    results: dict[str, list[dict[str, list[float]]]] = {"before": [], "after": []}
    for r in range(options.rounds):
        for name in ("before", "after") if r % 2 == 0 else ("after", "before"):
            results[name].append(run(trees[name], options.script, args))
            print(f"round {r + 1}: {name} done", file=sys.stderr, flush=True)
    print(f"# {options.script} {' '.join(args)}: median of {options.rounds} interleaved rounds")
    print(f"# before: {trees['before']}; after: {trees['after']}")
    width = max(len(label) for label in results["after"][0])
    print(f"{'figure':<{width}}  {'before':>24}  {'after':>24}  {'after/before':>12}")
    for label in results["after"][0]:
        runs = {name: [r[label] for r in results[name] if label in r] for name in results}
        if not runs["before"]:
            continue
        med = {
            name: [statistics.median(column) for column in zip(*rows, strict=True)]
            for name, rows in runs.items()
        }
        ratio = med["after"][0] / med["before"][0] if med["before"][0] else float("nan")
        shown = {name: "  ".join(f"{v:,.6g}" for v in med[name]) for name in med}
        print(f"{label:<{width}}  {shown['before']:>24}  {shown['after']:>24}  {ratio:>12.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
