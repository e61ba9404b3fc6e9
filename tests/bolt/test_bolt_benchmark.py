"""The bolt benchmark runs (tiny sizes) and checks Algorithm 1 against the augmented DFA."""

from __future__ import annotations

from collections.abc import Callable
from types import ModuleType

import pytest


def test_bolt_step_benchmark_runs_on_tiny_sizes(
    capsys: pytest.CaptureFixture[str], load_script: Callable[..., ModuleType]
) -> None:
    module = load_script("benchmarks/bolt_step.py")
    args = ["--envs", "4", "--max-fluents", "3", "--repeats", "1", "--min-time", "0.0001"]
    module.main(args)
    out = capsys.readouterr().out
    assert "alg1 us" in out and "aug edges" in out
    assert "t(3)/t(1)" in out
    # edge counts of F(a1 & ... & an)'s augmented DFA: 2^n + n 2^(n-1) + 1
    assert all(f" {edges} " in out for edges in (4, 9, 21))
