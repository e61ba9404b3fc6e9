"""``scripts/breakout_table.py --pool K``: a run's last K evaluations pooled, with the
binomial interval of the share that cleared the column."""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from pathlib import Path
from types import ModuleType

import pytest


@pytest.fixture
def script(load_script: Callable[..., ModuleType]) -> ModuleType:
    return load_script("scripts/breakout_table.py")


def _record(frames: int, score: float, cleared: float, rows: list[float], n: int = 8) -> dict:
    compliance = {"clear_left_column": cleared, **{f"left_row{r}": v for r, v in enumerate(rows)}}
    return {
        "frames": frames,
        "n_episodes": n,
        "env_return_mean": score,
        "env_return_std": 1.0,
        "compliance": compliance,
        "false_acceptance": {},
    }


def test_wilson_interval_matches_the_formula_worked_by_hand(script: ModuleType) -> None:
    # 0 of 40: centre z^2/(2n) / (1 + z^2/n) = 0.048019/1.096040 = 0.04381, half the same
    low, high = script.wilson_interval(0, 40)
    assert low == 0.0 and high == pytest.approx(0.0876, abs=5e-4)
    # 4 of 8: symmetric about 1/2, half = 1.96 * sqrt(1/32 + 1.96^2/256) / 1.4802 = 0.2784
    low, high = script.wilson_interval(4, 8)
    assert (low + high) / 2 == pytest.approx(0.5)
    assert high - 0.5 == pytest.approx(1.96 * math.sqrt(1 / 32 + 1.96**2 / 256) / 1.4802, abs=1e-4)
    with pytest.raises(ValueError, match="at least one episode"):
        script.wilson_interval(0, 0)


def test_pooled_weighs_shares_by_episodes_and_takes_only_the_last_k(
    script: ModuleType,
) -> None:
    records = {
        r["frames"]: r
        for r in [
            _record(100_000, 99.0, 1.0, [1.0] * 6),  # older than the pool: left out
            _record(200_000, 10.0, 0.5, [1.0, 0.5, 0, 0, 0, 0], n=8),
            _record(300_000, 14.0, 0.25, [1.0, 1.0, 0, 0, 0, 0], n=4),
        ]
    }
    p = script.pooled(records, 2)
    assert (p["first"], p["last"], p["episodes"]) == (200_000, 300_000, 12)
    early = script.pooled(records, 2, upto=250_000)  # compared at equal frames
    assert (early["first"], early["last"], early["episodes"]) == (100_000, 200_000, 16)
    assert p["cleared"] == pytest.approx((0.5 * 8 + 0.25 * 4) / 12)  # 5 of 12 episodes
    assert (p["cleared_low"], p["cleared_high"]) == pytest.approx(script.wilson_interval(5, 12))
    assert p["score"] == pytest.approx(12.0) and p["score_se"] == pytest.approx(2.0)  # sd 2.83/√2
    assert p["bricks"] == pytest.approx(1.75) and p["bricks_se"] == pytest.approx(0.25)
    # Per brick, episode-weighted: row 1 went in 4 of 8 episodes, then in all 4.
    assert p["rows"] == pytest.approx([1.0, (0.5 * 8 + 1.0 * 4) / 12, 0, 0, 0, 0])
    assert script.pooled(records, 1)["score_se"] == 0.0
    with pytest.raises(ValueError, match=">= 1"):
        script.pooled(records, 0)


def test_pool_prints_a_row_per_run_and_says_which_have_no_evaluation(
    script: ModuleType, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    done, fresh = tmp_path / "done", tmp_path / "fresh"
    for run in (done, fresh):
        run.mkdir()
        (run / "config.json").write_text("{}")
    (done / "metrics.json").write_text(json.dumps([_record(100_000, 5.0, 0.0, [0.0] * 6)]))
    script.main(["--pool", "3", str(done), str(fresh)])
    rows = capsys.readouterr().out.splitlines()
    assert rows[2].startswith("| done | 100k–100k | 8 | 0% (0%–")
    assert rows[2].endswith("| 0% 0% 0% 0% 0% 0% |")
    assert rows[3] == "| fresh | no evaluation yet | | | | | |"
    with pytest.raises(SystemExit, match="holds no run"):
        script.main([str(tmp_path / "missing")])
