"""Time per environment-step of Algorithm 1 and of the explicit augmented DFA.

For n = 1 … 16 fluents on one edge (the spec ``F(a1 & … & an)``, a 2-state DFA whose edge
0 -> 1 has n fluents), steps a batch of environments from state 0 and reports the median
time per environment-step of:

* ``alg1``: :meth:`BoltEngine.step` (Algorithm 1 alone: probability checks, bands, edge
  lookup, low-confidence count, timing);
* ``bolt``: :meth:`RestrainingBolt.step` (the same plus the episode bookkeeping), which is
  what a wrapper calls every step;
* ``aug``: :meth:`AugmentedDFA.step_batch` on the expanded DFA of the paper's Fig. 2a,
  whose state 0 has ``2**n`` edges to state 1 and ``n * 2**(n-1)`` self-loops;

with each one's ratio t(n)/t(1), the augmented DFA's edge count and build time. Half the
environments see every fluent true (a mix of low and high confidence), the other half
uniform probabilities, so both edges and the cost are exercised.

Run: ``.venv/bin/python benchmarks/bolt_step.py`` (``--help`` for the options).
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import sys
import time
from collections.abc import Callable, Sequence
from functools import partial

import numpy as np

from noisybolt.bolt import AugmentedDFA, BoltEngine, RestrainingBolt, Spec
from noisybolt.logic import DFA

#: Targets from issue 2: Algorithm 1 flat in n, and fast.
MAX_RATIO = 2.0
MAX_US_PER_ENV_STEP = 2.0


def eventually_all(n: int) -> DFA:
    """The DFA of ``F(a1 & … & an)``: state 0 until all hold at once, then accepting sink 1."""
    everything = (1 << n) - 1
    return DFA.from_function(
        [f"a{i}" for i in range(1, n + 1)],
        n_states=2,
        initial_state=0,
        accepting=[False, True],
        delta=lambda q, m: 1 if q == 1 or m == everything else 0,
        formula=f"F({' & '.join(f'a{i}' for i in range(1, n + 1))})",
    )


def bench_probs(n_envs: int, n_fluents: int, seed: int = 0) -> np.ndarray:
    """Half the environments with every fluent true (low or high), half uniform."""
    rng = np.random.default_rng(seed)
    probs = rng.uniform(0.0, 1.0, size=(n_envs, n_fluents))
    probs[: n_envs // 2] = rng.uniform(0.5, 1.0, size=(n_envs // 2, n_fluents))
    return probs


class Timed:
    """A callable timed in rounds: each round runs it ``number`` times (>= ``min_time`` s)."""

    def __init__(self, fn: Callable[[], object], *, min_time: float) -> None:
        self.fn = fn
        self.samples: list[float] = []
        fn()  # warm up
        self.number = 1
        while True:
            start = time.perf_counter()
            for _ in range(self.number):
                fn()
            elapsed = time.perf_counter() - start
            if elapsed >= min_time:
                break
            grow = min_time / elapsed * 1.2 if elapsed > 0 else 10.0
            self.number = max(self.number + 1, int(self.number * min(10.0, grow)))

    def round(self) -> None:
        """Appends the mean time of one call over one round."""
        start = time.perf_counter()
        for _ in range(self.number):
            self.fn()
        self.samples.append((time.perf_counter() - start) / self.number)

    @property
    def median(self) -> float:
        """Median over the rounds of the time of one call (seconds)."""
        return statistics.median(self.samples)


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--envs", type=int, default=64, help="batch size (default 64)")
    parser.add_argument("--max-fluents", type=int, default=16, help="largest n (default 16)")
    parser.add_argument("--repeats", type=int, default=7, help="repeats; median (default 7)")
    parser.add_argument(
        "--min-time", type=float, default=0.02, help="seconds per repeat at least (0.02)"
    )
    parser.add_argument(
        "--max-augmented-edges",
        type=int,
        default=2_000_000,
        help="skip the augmented DFA beyond this many edges (default 2e6)",
    )
    args = parser.parse_args(argv)
    n_envs = args.envs

    command = ["benchmarks/bolt_step.py", *(argv if argv is not None else sys.argv[1:])]
    print(f"# command: python {' '.join(command)}")
    print(
        f"# python {platform.python_version()}, numpy {np.__version__}, "
        f"{platform.machine()}, {os.cpu_count()} cpus; {n_envs} envs, 1 spec, "
        f"median of {args.repeats} repeats; times in microseconds per environment-step"
    )
    header = (
        f"{'n':>3} {'alg1 us':>9} {'ratio':>6} {'bolt us':>9} {'ratio':>6} "
        f"{'aug us':>11} {'ratio':>9} {'aug edges':>10} {'aug build s':>11}"
    )
    print(header, flush=True)
    timers: dict[int, dict[str, Timed]] = {}
    edges: dict[int, int] = {}
    builds: dict[int, float] = {}
    for n in range(1, args.max_fluents + 1):
        dfa = eventually_all(n)
        spec = Spec(dfa.formula, terminal_reward=10.0, low_confidence_cost=2.0)
        probs = bench_probs(n_envs, n, seed=n)
        states = np.zeros((n_envs, 1), dtype=np.int64)
        engine = BoltEngine([spec], [dfa], dfa.fluents)
        bolt = RestrainingBolt([spec], dfa.fluents, dfas=[dfa], n_envs=n_envs)
        bolt.reset(probs)
        timers[n] = {
            "alg1": Timed(partial(engine.step, states, probs), min_time=args.min_time),
            "bolt": Timed(partial(bolt.step, probs), min_time=args.min_time),
        }
        edges[n] = 2**n + n * 2 ** (n - 1) + 1
        if edges[n] <= args.max_augmented_edges:
            start = time.perf_counter()
            aug = AugmentedDFA.from_dfa(dfa, terminal_reward=10.0, low_confidence_cost=2.0)
            builds[n] = time.perf_counter() - start
            assert aug.n_edges == edges[n]
            expected = engine.step(states, probs)
            got = aug.step_batch(states[:, 0], probs)
            assert np.array_equal(got.next_states, expected.next_states[:, 0])
            assert np.allclose(got.reward, expected.total)
            timers[n]["aug"] = Timed(
                partial(aug.step_batch, states[:, 0], probs), min_time=args.min_time
            )
    # Interleaved rounds, so that a burst of load on the machine hits every n alike.
    for _ in range(args.repeats):
        for per_n in timers.values():
            for timer in per_n.values():
                timer.round()

    results = {
        n: {key: timer.median / n_envs for key, timer in per_n.items()}
        for n, per_n in timers.items()
    }
    base = results[1]
    for n, row in results.items():

        def ratio(key: str, row: dict[str, float] = row) -> str:
            return f"{row[key] / base[key]:.2f}" if key in row and key in base else "-"

        aug_us = f"{row['aug'] * 1e6:11.2f}" if "aug" in row else f"{'skipped':>11}"
        build_s = f"{builds[n]:11.3f}" if n in builds else f"{'-':>11}"
        print(
            f"{n:>3} {row['alg1'] * 1e6:9.3f} {ratio('alg1'):>6} {row['bolt'] * 1e6:9.3f} "
            f"{ratio('bolt'):>6} {aug_us} {ratio('aug'):>9} {edges[n]:>10} {build_s}"
        )

    last = results[args.max_fluents]
    ok = True
    for key, label in (("alg1", "Algorithm 1 (BoltEngine.step)"), ("bolt", "RestrainingBolt.step")):
        ratio_value = last[key] / base[key]
        worst = max(r[key] for r in results.values()) * 1e6
        flat = ratio_value <= MAX_RATIO
        fast = worst < MAX_US_PER_ENV_STEP
        ok = ok and flat and fast
        print(
            f"# {label}: t({args.max_fluents})/t(1) = {ratio_value:.2f} "
            f"(target <= {MAX_RATIO}: {'met' if flat else 'MISSED'}); slowest "
            f"{worst:.3f} us per env-step (target < {MAX_US_PER_ENV_STEP}: "
            f"{'met' if fast else 'MISSED'})"
        )
    largest = max((n for n, r in results.items() if "aug" in r), default=None)
    if largest is not None:
        print(
            f"# augmented DFA: t({largest})/t(1) = {results[largest]['aug'] / base['aug']:.1f}; "
            f"{results[largest]['aug'] / results[largest]['alg1']:.0f}x Algorithm 1 at n={largest}"
        )
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
