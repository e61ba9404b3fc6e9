"""``noisybolt evaluate --no-ground-truth`` on a tiny run, and the estimate beside the
truth with its calibration when the truth is read."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from noisybolt.runs.config import TrainConfig


@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from noisybolt.runs import train

    config = TrainConfig.build(
        {
            "bolt.specs": ["edge", "avoid_top_right"],
            "bolt.reward": "paper",
            "detector.kind": "oracle",
            "frames": 64,
            "evaluation.freq": 0,
            "checkpoint_freq": 0,
            "evaluation.episodes": 1,
            "progress_bar": False,
            "world.n_envs": 2,
        }
    )
    run = tmp_path_factory.mktemp("estimate") / "run"
    train(config, run, log=lambda _: None)
    return run


def test_evaluate_without_ground_truth_reports_the_estimate_and_nothing_judged_from_truth(
    tiny_run: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from noisybolt.cli import main

    assert main(["evaluate", str(tiny_run), "--episodes", "4", "--no-ground-truth"]) == 0
    out = capsys.readouterr().out
    assert "compliance estimated from the bolt's evidence:" in out
    assert "no ground truth read" in out and "compliance [" not in out
    assert "beside the truth" not in out and "goal rate" not in out
    saved = json.loads((tiny_run / "evaluation-no-ground-truth.json").read_text())
    assert "compliance" not in saved and "false_acceptance" not in saved
    estimate = saved["compliance_estimate"]
    assert set(estimate["specs"]) == {"edge", "avoid_top_right"}
    for spec in estimate["specs"].values():
        assert spec["n_episodes"] == 4 and spec["low"] <= spec["rate"] <= spec["high"]
    assert "truth" not in estimate
    assert not (tiny_run / "compliance-reliability-no-ground-truth.png").exists()


def test_with_ground_truth_the_estimate_stands_beside_the_truth_with_its_calibration(
    tiny_run: Path, tmp_path: Path
) -> None:
    from noisybolt.runs.run_evaluation import evaluate_run

    picture = tmp_path / "reliability.png"
    report = evaluate_run(tiny_run, episodes=6, reliability=picture)
    compliance = report.compliance
    assert compliance is not None and report.ground_truth
    # The oracle detector is sure and right: its measured error model is perfect, and the
    # estimate is the truth, episode by episode.
    for name, outcomes in compliance.outcomes.items():
        np.testing.assert_allclose(compliance.estimates[name].per_episode, outcomes, atol=1e-6)
        assert compliance.truth[name] == report.result.compliance[name]
    assert compliance.ece == pytest.approx(0.0, abs=1e-6)
    assert picture.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    table = compliance.format_table()
    assert "true" in table.splitlines()[0] and "per-episode ECE 0.000" in table
    saved = json.loads((tiny_run / "evaluation.json").read_text())
    assert saved["compliance_estimate"]["per_episode_ece"] == pytest.approx(0.0, abs=1e-6)
