"""benchmarks/budget_worlds.py and cost_budget_trade.py: the world a cost budget's trade is
measured on, and (slow) the trade itself."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def worlds(load_script: Callable[..., ModuleType]) -> ModuleType:
    return load_script("benchmarks/budget_worlds.py")


def test_the_toll_road_pays_the_episodes_own_saving_and_only_when_taken(
    worlds: ModuleType,
) -> None:
    env = worlds.toll()
    savings = []
    for seed in range(20):
        obs, info = env.reset(seed=seed)
        assert not info["true_fluents"].any()  # nothing taken at the start
        take = seed % 2
        obs2, reward, terminated, truncated, info = env.step(take)
        assert obs2[0] == obs[0] and terminated and not truncated
        assert reward == pytest.approx(float(obs[0]) if take else 0.0)
        assert bool(info["true_fluents"][0]) == bool(take)
        savings.append(float(obs[0]))
    assert min(savings) >= 0.0 and max(savings) <= 1.0 and len(set(savings)) == 20
    bounds = env.episode_return_bounds
    assert (bounds.low, bounds.high) == (0.0, 1.0)


@pytest.mark.parametrize(("d", "expected"), [(0.0, 0.0), (0.1, 0.095), (0.3, 0.255), (1.0, 0.5)])
def test_best_under_budget_by_hand(worlds: ModuleType, d: float, expected: float) -> None:
    # the toll road when the saving exceeds 1 - d: the integral of s over (1 - d, 1)
    assert worlds.best_under_budget(d) == pytest.approx(expected)


def test_the_threshold_policy_meets_its_budget_and_return(worlds: ModuleType) -> None:
    # Monte Carlo of the policy best_under_budget describes, on the world itself.
    env = worlds.toll()
    d, taken, total = 0.3, 0, 0.0
    n = 4000
    for seed in range(n):
        obs, _ = env.reset(seed=seed)
        take = int(obs[0] > 1.0 - d)
        taken += take
        total += env.step(take)[1]
    assert abs(taken / n - d) < 0.03
    assert abs(total / n - worlds.best_under_budget(d)) < 0.01


@pytest.mark.slow
def test_a_budget_trades_compliance_for_return(
    load_script: Callable[..., ModuleType], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """PPO with the built-in defaults at d = 0.3, one seed: the last model violates in
    about 30 % of episodes (ground truth) and earns more than the compliant policy's 0."""
    trade = load_script("benchmarks/cost_budget_trade.py")
    monkeypatch.syspath_prepend(str(ROOT / "benchmarks"))
    args = type("Args", (), {"out": str(tmp_path), "frames": 100_000, "eval_episodes": 500})
    record = trade.run_trial(0.3, "ppo", 0, args)
    assert abs(record["last"]["violation"] - 0.3) <= 0.1, record
    assert record["last"]["return"] > 0.15, record
    config = json.loads(next(tmp_path.rglob("config.json")).read_text())
    assert config["bolt"]["constraint"]["cost_limit"] == 0.3
    assert np.isfinite(record["kept"]["return"])
