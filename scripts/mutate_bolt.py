"""Mutation check of the bolt: break Algorithm 1 on purpose and see which tests notice.

    .venv/bin/python scripts/mutate_bolt.py                 # the default targets below
    .venv/bin/python scripts/mutate_bolt.py tests/wrappers  # other test paths
    .venv/bin/python scripts/mutate_bolt.py --list          # the mutations, nothing run

Each mutation rewrites one line of ``src/noisybolt/bolt/`` in a *copy* of the repository
(``src``, ``tests`` and ``pyproject.toml`` in a temporary directory, imported first
through ``PYTHONPATH``), never in the working tree, so it is safe beside other work. The
tests run on the copy with ``-m "not slow"`` and stop at the first failure; a mutation
that no test notices is a hole in the suite. A mutation whose line is not found (the
source moved on) is reported as such, not as caught. The table goes to stdout as
Markdown; the exit status is 1 if some mutation survived or could not be applied.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DEFAULT_TARGETS = ("tests/wrappers/test_bolt_reward_by_hand.py",)


@dataclass(frozen=True)
class Mutation:
    """One deliberate bug: ``old`` (exactly once in ``path``) becomes ``new``."""

    name: str
    path: str
    old: str
    new: str


_ENGINE = "src/noisybolt/bolt/engine.py"
_BOLT = "src/noisybolt/bolt/restraining_bolt.py"
MUTATIONS = (
    Mutation(
        "truth threshold: p > 0.5 instead of p >= 0.5",
        _ENGINE,
        "truth = probs >= self._thresholds.truth",
        "truth = probs > self._thresholds.truth",
    ),
    Mutation(
        "low-confidence threshold: p < 0.9 instead of p <= 0.9",
        _ENGINE,
        "low = truth & (probs <= self._thresholds.high)",
        "low = truth & (probs < self._thresholds.high)",
    ),
    Mutation(
        "low-confidence band flipped: the high band is charged",
        _ENGINE,
        "low = truth & (probs <= self._thresholds.high)",
        "low = truth & (probs > self._thresholds.high)",
    ),
    Mutation(
        "cost sign (count mode): a low-confidence fluent pays",
        _ENGINE,
        "low_term = 0.0 - n_low * self._cost",
        "low_term = 0.0 + n_low * self._cost",
    ),
    Mutation(
        "cost sign (proportional mode): a low-confidence fluent pays",
        _ENGINE,
        "low_term = 0.0 - scaled * self._cost",
        "low_term = 0.0 + scaled * self._cost",
    ),
    Mutation(
        "reward timing: on_entry pays on every accepting step",
        _ENGINE,
        "(self._on_entry & (~was_accepting | first[:, None]))",
        "self._on_entry",
    ),
    Mutation(
        "reward timing: the first transition is no entry",
        _ENGINE,
        "(self._on_entry & (~was_accepting | first[:, None]))",
        "(self._on_entry & ~was_accepting)",
    ),
    Mutation(
        "reward timing: episode_end pays before the episode ends",
        _ENGINE,
        "(self._episode_end & ended[:, None])",
        "self._episode_end",
    ),
    Mutation(
        "reward timing: the reset transition's reward is not carried",
        _BOLT,
        "out = out._replace(carried=carried, total=out.total + carried)",
        "out = out._replace(carried=carried, total=out.total)",
    ),
    Mutation(
        "DFA next state: the DFA never moves",
        _ENGINE,
        "return self._flat_next[cells], self._flat_support[cells]",
        "return states.copy(), self._flat_support[cells]",
    ),
    Mutation(
        "DFA next state: the edge of the letter with its first fluent flipped",
        _ENGINE,
        "return self._flat_next[cells], self._flat_support[cells]",
        "return self._flat_next[cells ^ 1], self._flat_support[cells]",
    ),
)


def _copy_repository(into: Path) -> None:
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc", ".pytest_cache", "*.egg-info")
    for name in ("src", "tests"):
        shutil.copytree(ROOT / name, into / name, ignore=ignore)
    shutil.copy2(ROOT / "pyproject.toml", into / "pyproject.toml")


def _run_tests(copy: Path, targets: list[str]) -> tuple[int, str]:
    env = {**os.environ, "PYTHONPATH": str(copy / "src")}
    command = [sys.executable, "-m", "pytest", "-q", "-x", "-p", "no:cacheprovider"]
    command += ["-m", "not slow", *targets]
    proc = subprocess.run(command, cwd=copy, env=env, capture_output=True, text=True)
    failed = re.findall(r"^FAILED (\S+)", proc.stdout, flags=re.MULTILINE)
    summary = failed[0] if failed else proc.stdout.strip().splitlines()[-1:]
    return proc.returncode, summary if isinstance(summary, str) else " ".join(summary)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("targets", nargs="*", default=list(DEFAULT_TARGETS))
    parser.add_argument("--list", action="store_true", help="print the mutations and stop")
    args = parser.parse_args(argv)
    if args.list:
        for m in MUTATIONS:
            print(f"{m.name}\n    {m.path}: {m.old!r} -> {m.new!r}")
        return 0

    holes = 0
    with tempfile.TemporaryDirectory(prefix="mutate-bolt-") as tmp:
        copy = Path(tmp)
        _copy_repository(copy)
        probe = subprocess.run(
            [sys.executable, "-c", "import noisybolt; print(noisybolt.__file__)"],
            cwd=copy,
            env={**os.environ, "PYTHONPATH": str(copy / "src")},
            capture_output=True,
            text=True,
            check=True,
        ).stdout.strip()
        if not probe.startswith(str(copy)):
            print(f"error: the copy is not the package imported ({probe})", file=sys.stderr)
            return 2
        code, summary = _run_tests(copy, args.targets)
        if code != 0:
            print(f"error: the unmutated tests fail: {summary}", file=sys.stderr)
            return 2
        print(f"Targets: {' '.join(args.targets)}\n")
        print("| mutation | file | caught by (first failing test) | s |")
        print("|---|---|---|---|")
        for m in MUTATIONS:
            path = copy / m.path
            original = path.read_text()
            if original.count(m.old) != 1:
                holes += 1
                print(f"| {m.name} | {m.path} | NOT APPLIED: line not found once | - |")
                continue
            path.write_text(original.replace(m.old, m.new))
            try:
                start = time.monotonic()
                code, summary = _run_tests(copy, args.targets)
                seconds = time.monotonic() - start
            finally:
                path.write_text(original)
            caught = code != 0
            holes += not caught
            verdict = summary if caught else f"SURVIVED ({summary})"
            print(f"| {m.name} | {m.path} | {verdict} | {seconds:.0f} |", flush=True)
    return 1 if holes else 0


if __name__ == "__main__":
    sys.exit(main())
