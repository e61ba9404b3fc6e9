"""The classifier benchmark runs end to end on tiny sizes."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from types import ModuleType

import pytest


def test_classifier_benchmark_runs_on_tiny_sizes(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, load_script: Callable[..., ModuleType]
) -> None:
    module = load_script("benchmarks/perception_classifiers.py")
    figures = tmp_path / "figures.json"
    assert module.main(["--quick", "--json", str(figures)]) == 0
    out = capsys.readouterr().out
    assert "images/s" in out and "bottom_left_corner" in out and "target" in out
    data = json.loads(figures.read_text())
    assert {row["batch"] for row in data["inference"]} == {1, 8, 64}
    assert {row["world"] for row in data["inference"]} == {"gridworld", "breakout"}
    assert data["noisy"]["camera_noise"]["name"] == "regional"
