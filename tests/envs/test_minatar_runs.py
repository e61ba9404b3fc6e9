"""scripts/minatar_runs.py: the plan of issue 48's MinAtar runs and their summary."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from types import ModuleType

import pytest

from noisybolt.cli import build_parser
from noisybolt.cli.train import train_overrides
from noisybolt.runs.config import TrainConfig


@pytest.fixture
def script(load_script: Callable[..., ModuleType]) -> ModuleType:
    return load_script("scripts/minatar_runs.py")


def test_the_plan_is_three_seeds_of_each_run_and_every_command_builds_a_config(
    script: ModuleType,
) -> None:
    kinds = sorted({(run.algo, run.kind) for run in script.PLAN.values()})
    assert kinds == [
        ("dqn", "clear"),
        ("dqn", "control"),
        ("ppo", "clear"),
        ("ppo", "control"),
        ("ppo", "order"),
    ]
    assert len(script.PLAN) == 15 and {r.seed for r in script.PLAN.values()} == {0, 1, 2}
    parser = build_parser()
    for name, run in script.PLAN.items():
        args = parser.parse_args(["train", *run.train_args(), "--out", f"runs/{name}"])
        config = TrainConfig.build(train_overrides(args))
        names = [spec["name"] for spec in config.bolt.specs]
        assert names[:4] == ["clear_left_column", "left_row0", "left_row1", "left_row2"]
        assert ("left_first" in names) == (run.kind != "clear")
        assert config.bolt.bolted == run.bolted and config.world_config.name == "minatar-breakout"


def _run(path: Path, *, algo: str, bolted: bool, specs: list[str], seed: int = 0) -> None:
    path.mkdir(parents=True)
    config = {
        "algorithm": {"name": algo},
        "seed": seed,
        "world": {"name": "minatar-breakout", "kwargs": {"noise": "gaussian:sigma=40"}},
        "bolt": {"bolted": bolted, "tracking": "belief", "specs": [{"name": s} for s in specs]},
    }
    rates = {s: 0.5 for s in specs} | {"clear_left_column": 0.75}
    metrics = [
        {"frames": 10, "compliance": {}, "env_return_mean": 0.0, "n_episodes": 64},
        {
            "frames": 20,
            "compliance": rates,
            "false_acceptance": {s: 0.03 for s in specs},
            "env_return_mean": 12.5,
            "env_return_std": 2.0,
            "n_episodes": 64,
        },
    ]
    (path / "config.json").write_text(json.dumps(config))
    (path / "metrics.json").write_text(json.dumps(metrics))


def test_summary_lists_every_run_under_each_spec_it_measures(
    script: ModuleType, tmp_path: Path
) -> None:
    clear = ["clear_left_column", "left_row0", "left_row1", "left_row2"]
    _run(tmp_path / "ppo-clear-bolted-seed0", algo="ppo", bolted=True, specs=clear)
    _run(tmp_path / "ppo-order-bolted-seed0", algo="ppo", bolted=True, specs=[*clear, "left_first"])
    _run(
        tmp_path / "ppo-control-unbolted-seed0",
        algo="ppo",
        bolted=False,
        specs=[*clear, "left_first"],
    )
    entries = script.summary(tmp_path)
    assert json.loads((tmp_path / "summary.json").read_text()) == entries
    got = [(e["spec"], e["run"]) for e in entries]
    assert got == [
        ("clear_left_column", "ppo-clear-bolted-seed0"),
        ("clear_left_column", "ppo-control-unbolted-seed0"),
        ("left_first", "ppo-order-bolted-seed0"),
        ("left_first", "ppo-control-unbolted-seed0"),
    ]
    first = entries[0]
    for key in ("spec", "algo", "seed", "bolted", "games", "column_cleared_share", "score_mean"):
        assert key in first
    assert (first["games"], first["column_cleared_share"], first["score_mean"]) == (64, 0.75, 12.5)
    assert first["frames"] == 20 and first["bolt_false_acceptance"] == 0.03
    assert entries[1]["bolt_false_acceptance"] is None  # a control has no bolt
    assert entries[2]["spec_share"] == 0.5 and entries[2]["camera"] == "gaussian:sigma=40"
