"""The classifier benchmark runs end to end on tiny sizes."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parents[2] / "benchmarks" / "perception_classifiers.py"


def test_classifier_benchmark_runs_on_tiny_sizes(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    spec = importlib.util.spec_from_file_location("perception_classifiers_benchmark", SCRIPT)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    figures = tmp_path / "figures.json"
    assert module.main(["--quick", "--json", str(figures)]) == 0
    out = capsys.readouterr().out
    assert "images/s" in out and "bottom_left_corner" in out and "target" in out
    data = json.loads(figures.read_text())
    assert {row["batch"] for row in data["inference"]} == {1, 8, 64}
    assert {row["world"] for row in data["inference"]} == {"gridworld", "breakout"}
    assert data["noisy"]["camera_noise"]["name"] == "regional"
