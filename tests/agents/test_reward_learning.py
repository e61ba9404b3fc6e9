"""The compliance and constrained schemes teach a detour that the paper's rewards do not (slow:
trains)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from types import ModuleType

import pytest

from noisybolt.runs import DetectorConfig, TrainConfig, train

BOTH_CORNERS = "F(top_right_corner) & F(bottom_left_corner)"  # a 16-step detour, not 7


def _run(tmp_path: Path, reward: str, algo: str = "ppo") -> float:
    config = TrainConfig.create(
        specs=[BOTH_CORNERS],
        algo=algo,
        reward=reward,
        detector=DetectorConfig(kind="oracle"),
        frames=60_000,
        eval_freq=5_000,
        eval_episodes=20,
        checkpoint_freq=0,
        keep_best=True,
        progress_bar=False,
    )
    result = train(config, tmp_path / reward, log=lambda _: None)
    assert result.final.goal_rate >= 0.95
    return result.final.compliance[BOTH_CORNERS]


@pytest.mark.slow
def test_both_corners_are_visited_under_the_compliance_scheme_only(tmp_path: Path) -> None:
    assert _run(tmp_path, "compliance") >= 0.95
    # The default for PPO, on the gridworld's exact scale: the budget at the limit and the
    # price in full from the first update (with the budget annealed over half the run, no
    # seed of three ever complied: the direct route had settled by 20k frames).
    assert _run(tmp_path, "constrained") >= 0.95
    # +1 per accepting step pays 1 for the 9 extra steps (13.5) of the detour: the paper's
    # rewards make the shortcut optimal, and PPO takes it.
    assert _run(tmp_path, "paper") <= 0.05


@pytest.mark.slow
def test_a_slice_of_the_spec_suite(
    tmp_path: Path, capsys: pytest.CaptureFixture, load_script: Callable[..., ModuleType]
) -> None:
    module = load_script("benchmarks/spec_suite.py")  # its process pool pickles by module
    argv = [
        "--specs",
        "24",
        "--only",
        "s06-existence-globally+universality-after",
        "s22-existence-globally",
        "--algos",
        "ppo",
        "--seeds",
        "1",
        "--schemes",
        "compliance",
        "--detector",
        "oracle",
        "--workers",
        "1",
        "--out",
        str(tmp_path),
    ]
    assert module.main(argv) == 0
    out = capsys.readouterr().out
    assert "suite [compliance] PPO: 2/2 specs followed in every seed" in out
