"""Compile time of LTLf specs with both backends (MONA and the pure-Python BDD backend).

Times :func:`noisybolt.logic.compile_ltlf` with the cache off (parse, backend, minimisation,
canonical numbering, dense tables when they fit) on:

* the paper's five specifications (gridworld and Breakout);
* the family ``G(a1 -> F(b1)) & ... & G(ak -> F(bk))`` for k = 1 .. ``--max-pairs`` (2k
  fluents, 2**k states); k = 10 is issue 2's 20-fluent target ("well under a second with
  MONA").

Each cell is the median of ``--repeats`` compiles after one warm-up compile (which pays the
imports and MONA's version probe). A cell reads ``timeout`` when the backend gave up within
``--timeout`` seconds, ``failed`` when it failed otherwise (MONA aborts on very large
products, around k = 17 per FACTS.md), ``n/a`` when MONA is not installed. The last column is
the time to load the same DFA from a warm disk cache.

Run: ``.venv/bin/python benchmarks/compile_time.py`` (``--help`` for the options).
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import sys
import tempfile
import time
from collections.abc import Sequence

from noisybolt.errors import BackendUnavailableError, CompilationError
from noisybolt.logic import compile_ltlf
from noisybolt.logic.mona import find_mona, mona_version
from noisybolt.logic.progression import bdd_backend_version

PAPER = [
    "G(on_edge)",
    "!F(top_right_corner)",
    "F(top_right_corner & X(!F(top_right_corner)))",
    "(F(t & X(!F(t))) & !F(b)) | (F(b & X(!F(b))) & !F(t))",
    "F(brick_clear_left)",
]


def response_family(k: int) -> str:
    """``G(a1 -> F(b1)) & ... & G(ak -> F(bk))``: 2k fluents, 2**k states."""
    return " & ".join(f"G(a{i} -> F(b{i}))" for i in range(1, k + 1))


def time_compile(formula: str, backend: str, repeats: int, timeout: float) -> tuple[str, str]:
    """(median seconds or why not, the DFA's shape)."""
    try:
        dfa = compile_ltlf(formula, backend=backend, timeout=timeout, cache=False)  # type: ignore[arg-type]
        times = []
        for _ in range(repeats):
            started = time.perf_counter()
            compile_ltlf(formula, backend=backend, timeout=timeout, cache=False)  # type: ignore[arg-type]
            times.append(time.perf_counter() - started)
    except BackendUnavailableError:
        return "n/a", ""
    except CompilationError as error:
        return ("timeout" if "within" in str(error) else "failed"), ""
    shape = f"{dfa.n_states} states" + (", compact" if dfa.is_compact else "")
    return f"{statistics.median(times):.4f}", shape


def time_cached(formula: str, directory: str, repeats: int) -> str:
    compile_ltlf(formula, cache=directory)
    times = []
    for _ in range(repeats):
        started = time.perf_counter()
        compile_ltlf(formula, cache=directory)
        times.append(time.perf_counter() - started)
    return f"{statistics.median(times):.4f}"


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeats", type=int, default=5, help="timed compiles per cell")
    parser.add_argument("--max-pairs", type=int, default=12, help="largest k of the family")
    parser.add_argument("--timeout", type=float, default=60.0, help="seconds per compile")
    args = parser.parse_args(argv)

    mona = find_mona()
    print(f"python {platform.python_version()}, {platform.machine()}, {os.cpu_count()} cpus")
    print(f"mona: {mona_version(mona) if mona else 'not installed'}; bdd: {bdd_backend_version()}")
    print(f"command: {' '.join([sys.executable, *sys.argv])}")
    print("median seconds per compile_ltlf(..., cache=False)\n")
    header = f"{'formula':58} {'fluents':>7} {'mona s':>8} {'bdd s':>8}  {'cached s':>8}  dfa"
    print(header)
    print("-" * len(header))
    rows = [(f, f) for f in PAPER] + [
        (f"G(ai -> F(bi)), i = 1..{k}", response_family(k)) for k in range(1, args.max_pairs + 1)
    ]
    with tempfile.TemporaryDirectory() as directory:
        for label, formula in rows:
            n_fluents = len(compile_ltlf(formula, backend="bdd", cache=False).fluents)
            mona_s, mona_shape = time_compile(formula, "mona", args.repeats, args.timeout)
            bdd_s, bdd_shape = time_compile(formula, "bdd", args.repeats, args.timeout)
            cached = time_cached(formula, directory, args.repeats)
            shape = mona_shape or bdd_shape
            print(f"{label:58} {n_fluents:7d} {mona_s:>8} {bdd_s:>8}  {cached:>8}  {shape}")
            sys.stdout.flush()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
