"""Sweeps: validation before anything runs, a 2x2 grid, retries and failures, resume, Ray."""

from __future__ import annotations

import csv
import dataclasses
import doctest
import json
from pathlib import Path
from typing import Any

import pytest
import yaml

from noisybolt.cli import main
from noisybolt.errors import ConfigError
from noisybolt.experiments import sweeps as sweep_module
from noisybolt.experiments.sweeps import (
    SweepConfig,
    TrialTask,
    builtin_sweeps,
    collect_sweep,
    load_sweep,
    run_sweep,
)
from noisybolt.experiments.sweeps.run import longest_first

# Tiny trials: 1024 frames, oracle detector, 4 evaluation episodes (about a second each).
TINY_BASE: dict[str, Any] = {
    "detector": {"kind": "oracle"},
    "frames": 1024,
    "eval_freq": 512,
    "eval_episodes": 4,
    "checkpoint_freq": 512,
}
GRID: dict[str, Any] = {
    "name": "grid",
    "base": TINY_BASE,
    "rows": [
        {"name": "edge-ppo", "specs": ["edge"], "algo": "ppo", "hyperparams": {"n_steps": 64}},
        {"name": "avoid-a2c", "specs": ["avoid_top_right"], "algo": "a2c"},
    ],
    "seeds": 2,
}


def _quiet(_: str) -> None:
    pass


def _sweep(**changes: Any) -> SweepConfig:
    return SweepConfig.from_dict({**GRID, **changes})


@pytest.fixture(scope="module")
def grid_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The 2x2 grid (2 rows x 2 seeds), run once through the CLI for this module."""
    folder = tmp_path_factory.mktemp("sweeps")
    config = folder / "grid.yaml"
    config.write_text(yaml.safe_dump(GRID))
    assert main(["sweep", str(config), "--out", str(folder / "grid")]) == 0
    return folder / "grid"


# ---------------------------------------------------------------------- validation
@pytest.mark.parametrize(
    ("changes", "match"),
    [
        ({"rowz": []}, r"unknown config key rowz; known: \["),
        ({"rows": []}, "non-empty list"),
        ({"rows": [{"specs": ["edge"]}]}, "needs a 'name'"),
        ({"rows": [{"name": "a b", "specs": ["edge"]}]}, "needs a 'name' matching"),
        ({"rows": [{"name": "a", "specs": ["edge"]}] * 2}, "two rows are named 'a'"),
        ({"rows": [{"name": "a", "specs": ["edge"], "lr": 1}]}, r"row 'a': unknown config key lr"),
        ({"rows": [{"name": "a", "specs": ["edge"], "seed": 1}]}, "list seeds under 'seeds'"),
        ({"rows": [{"name": "a"}]}, "no specs"),
        ({"rows": [{"name": "a", "specs": []}]}, "give at least one spec"),
        ({"rows": [{"name": "a", "specs": ["edge"], "algo": "sac"}]}, "unknown algorithm 'sac'"),
        (
            {"rows": [{"name": "a", "specs": ["edge"], "hyperparams": {"n_stepz": 8}}]},
            "unknown hyperparameter 'n_stepz'",
        ),
        (
            {"rows": [{"name": "a", "specs": ["edge"], "frames": 0}]},
            "frames must be an integer >= 1",
        ),
        ({"rows": [{"name": "a", "specs": ["edge"], "frames": "lots"}]}, "not a frame count"),
        (
            {"rows": [{"name": "a", "specs": ["edge"], "frames": True}]},
            "config key frames must be an integer",
        ),
        (
            {"rows": [{"name": "a", "specs": ["edge"], "eval_freq": -1}]},
            "evaluation.freq must be an integer >= 0",
        ),
        ({"rows": [{"name": "a", "specs": ["F(flying)"]}]}, "flying"),
        (
            {"rows": [{"name": "a", "specs": ["edge"], "world_kwargs": {"noise": "fog"}}]},
            "fog",
        ),
        ({"rows": [{"name": "a", "specs": ["edge"], "world": "mars"}]}, "world 'mars'"),
        (
            {"rows": [{"name": "a", "specs": ["edge"], "detector": {"kind": "psychic"}}]},
            "unknown detector 'psychic'",
        ),
        (
            {"rows": [{"name": "a", "specs": ["edge"], "detector": {"colour": 1}}]},
            "unknown config key detector.colour",
        ),
        (
            {
                "rows": [
                    {
                        "name": "a",
                        "specs": ["edge"],
                        "detector": {"kind": "classifier", "path": "/no/such.st"},
                    }
                ]
            },
            "no classifier file",
        ),
        ({"seeds": 0}, "seeds must be >= 1"),
        ({"seeds": [0, 0]}, "seeds must be distinct"),
        ({"seeds": [-1]}, "non-negative"),
        ({"retries": -1}, "retries must be an integer >= 0"),
        ({"resources": {"gpus": 1}}, r"unknown config key resources\.gpus"),
        ({"resources": {"cpus": 0}}, "cpus must be a number > 0"),
        ({"settings": {"seed": [1, 2]}}, "vary seeds with 'seeds'"),
        ({"settings": {"learning_rate": [1e-3]}}, "unknown config key learning_rate"),
        ({"settings": {"frames.x": [1]}}, "config key frames is not a mapping"),
        ({"settings": {"cost_mode": []}}, "non-empty list"),
        ({"settings": {"cost_mode": ["count", "count"]}}, "lists a value twice"),
        ({"settings": {"cost_mode": ["count", "sometimes"]}}, "bolt.cost_mode must be one of"),
        ({"base": {"frames": 1024, "success_threshold": 2}}, "success_threshold"),
        # Types come from the config schema's dataclasses: no second schema to drift.
        (
            {"base": {"eval_episodes": "many"}},
            "base: config key evaluation.episodes must be an integer, got 'many'",
        ),
        ({"base": {"keep_best": 1}}, "base: config key evaluation.keep_best must be true or"),
        ({"base": {"reward_scale": "big"}}, "bolt.reward_scale must be a number or null"),
        ({"base": {"world_kwargs": ["noise"]}}, "config key world.kwargs must be a mapping"),
        ({"base": {"bolt": {"trackin": "belief"}}}, "unknown config key bolt.trackin"),
    ],
)
def test_bad_sweep_configs_are_refused_before_anything_runs(
    changes: dict[str, Any], match: str
) -> None:
    with pytest.raises(ConfigError, match=match):
        _sweep(**changes)


def test_bad_config_through_the_cli_exits_2_and_writes_nothing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    config = tmp_path / "bad.yaml"
    config.write_text(yaml.safe_dump({**GRID, "rows": [{"name": "a", "specs": ["F(flying)"]}]}))
    assert main(["sweep", str(config), "--out", str(tmp_path / "out")]) == 2
    assert "flying" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()
    (tmp_path / "broken.yaml").write_text("rows: [unclosed")
    assert main(["sweep", str(tmp_path / "broken.yaml")]) == 2
    assert "not valid YAML" in capsys.readouterr().err
    assert main(["sweep", str(tmp_path / "missing.yaml")]) == 2
    assert "built-in sweeps" in capsys.readouterr().err
    out = str(tmp_path / "out")
    assert main(["sweep", str(config), "--out", out, "--address", "auto"]) == 2  # needs ray


def test_trials_cross_rows_settings_and_seeds_with_deterministic_ids() -> None:
    sweep = _sweep(
        settings={"world_kwargs.noise": ["none", "regional"], "hyperparams.gamma": [0.9]},
        seeds=[3, 5],
    )
    ids = [t.trial_id for t in sweep.trials]
    assert len(ids) == 2 * 2 * 1 * 2
    assert ids[:3] == [
        "edge-ppo/noise=none,gamma=0.9/seed-3",
        "edge-ppo/noise=none,gamma=0.9/seed-5",
        "edge-ppo/noise=regional,gamma=0.9/seed-3",
    ]
    trial = sweep.trials[2]
    assert trial.group == "edge-ppo/noise=regional,gamma=0.9"
    assert trial.config.world_config.kwargs == {"noise": "regional"}
    assert trial.config.seed == 3
    # Base, row and axis merge: the row's n_steps and the axis's gamma both apply.
    assert trial.config.algorithm.hyperparams["n_steps"] == 64
    assert trial.config.algorithm.hyperparams["gamma"] == 0.9
    assert trial.config.frames == 1024 and trial.config.progress_bar is False
    assert [t.trial_id for t in _sweep(settings={}).trials] == [
        "edge-ppo/seed-0",
        "edge-ppo/seed-1",
        "avoid-a2c/seed-0",
        "avoid-a2c/seed-1",
    ]


def test_parallel_workers_start_the_largest_budgets_first_in_grid_order_among_equals(
    tmp_path: Path,
) -> None:
    rows = [
        {"name": "short", "specs": ["edge"], "algo": "ppo", "frames": 512},
        {"name": "long", "specs": ["edge"], "algo": "a2c", "frames": 4096},
        {"name": "middle", "specs": ["edge"], "algo": "ppo", "frames": 1024},
    ]
    sweep = _sweep(rows=rows, seeds=2)
    tasks = [TrialTask(t.to_dict(), str(tmp_path / t.trial_id)) for t in sweep.trials]
    assert [t.trial_id for t in longest_first(tasks)] == [
        "long/seed-0",
        "long/seed-1",
        "middle/seed-0",
        "middle/seed-1",
        "short/seed-0",
        "short/seed-1",
    ]


def test_builtin_sweeps_validate(tmp_path: Path) -> None:
    assert {"edge_algorithms", "corner_noise"} <= set(builtin_sweeps())
    for name in builtin_sweeps():
        sweep = load_sweep(name)
        assert sweep.name == name and sweep.trials
    assert len(load_sweep("corner_noise").trials) == 12
    path = tmp_path / "mine.yaml"
    path.write_text(yaml.safe_dump({k: v for k, v in GRID.items() if k != "name"}))
    assert load_sweep(path).name == "mine"


def test_module_doctests_pass() -> None:
    assert doctest.testmod(sweep_module, optionflags=doctest.ELLIPSIS).failed == 0


def test_experiments_package_exports_each_name_from_its_module() -> None:
    import importlib

    import noisybolt.experiments as experiments

    for name in experiments.__all__:
        module = importlib.import_module(f"noisybolt.experiments.{experiments._SOURCES[name]}")
        assert name in module.__all__
        assert getattr(experiments, name) is getattr(module, name)
    for module_name in ("sweeps", "sweeps.ray_tune", "table1", "case4", "report", "reporting"):
        module = importlib.import_module(f"noisybolt.experiments.{module_name}")
        assert all(hasattr(module, name) for name in module.__all__), module_name


# ---------------------------------------------------------------------- local backend
def test_local_grid_writes_every_trial_and_one_table(grid_dir: Path) -> None:
    sweep = json.loads((grid_dir / "sweep.json").read_text())
    assert [t["id"] for t in sweep["trials"]] == [
        "edge-ppo/seed-0",
        "edge-ppo/seed-1",
        "avoid-a2c/seed-0",
        "avoid-a2c/seed-1",
    ]
    for trial in sweep["trials"]:
        run = grid_dir / "trials" / trial["id"]
        assert (run / "summary.json").exists() and (run / "model.zip").exists()
        config = json.loads((run / "config.json").read_text())
        assert config["seed"] == trial["seed"] and config["frames"] == 1024
        outcome = json.loads((run / "trial.json").read_text())
        assert outcome["status"] == "done" and outcome["attempts"] == []
    assert (grid_dir / "command.txt").read_text().startswith("noisybolt sweep ")

    results = json.loads((grid_dir / "results.json").read_text())
    groups = {g["group"]: g for g in results["groups"]}
    assert list(groups) == ["edge-ppo", "avoid-a2c"]
    edge = groups["edge-ppo"]
    assert edge["n_done"] == 2 and edge["n_failed"] == 0 and edge["algo"] == "ppo"
    # The table's numbers are the mean and (ddof=0) std over the seeds' final evaluations.
    finals = [
        json.loads((grid_dir / "trials" / f"edge-ppo/seed-{s}" / "summary.json").read_text())[
            "final"
        ]
        for s in (0, 1)
    ]
    returns = [f["env_return_mean"] for f in finals]
    assert edge["env_return"]["mean"] == pytest.approx(sum(returns) / 2)
    assert edge["env_return"]["std"] == pytest.approx(abs(returns[0] - returns[1]) / 2)
    assert edge["compliance_edge"]["mean"] == pytest.approx(
        sum(f["compliance"]["edge"] for f in finals) / 2
    )
    table = (grid_dir / "results.md").read_text()
    assert "| edge-ppo | ppo | edge | 2/2 | 0 |" in table
    assert "| avoid-a2c | a2c | avoid_top_right | 2/2 | 0 |" in table
    # The CSV holds results.json's groups, flattened: one form for both.
    with open(grid_dir / "results.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert list(rows[0])[:10] == [
        "group", "row", "algo", "specs", "n_trials", "n_done", "n_failed",
        "env_return_mean", "env_return_std", "env_return_n",
    ]  # fmt: skip
    assert [r["group"] for r in rows] == ["edge-ppo", "avoid-a2c"]
    assert float(rows[0]["env_return_mean"]) == edge["env_return"]["mean"]
    assert float(rows[0]["compliance_edge_mean"]) == edge["compliance_edge"]["mean"]
    assert rows[0]["compliance_avoid_top_right_mean"] == ""  # not a spec of edge-ppo


def test_running_again_reuses_finished_trials_untouched(grid_dir: Path) -> None:
    files = sorted((grid_dir / "trials").rglob("*"))
    before = {p: p.stat().st_mtime_ns for p in files if p.is_file()}
    lines: list[str] = []
    result = run_sweep(_sweep(), grid_dir, log=lines.append)
    assert "4 already finished, 0 to run" in lines[0]
    assert result.n_done == 4
    after = {p: p.stat().st_mtime_ns for p in files if p.is_file()}
    assert after == before


def test_crashing_trial_is_retried_then_reported_failed_while_others_are_kept(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    import noisybolt.runs.training as training

    real_train = training.train
    calls: list[str] = []

    def flaky_train(config: Any, run_dir: Any, **kwargs: Any) -> Any:
        calls.append(Path(run_dir).parent.name)
        if config.algorithm.name == "a2c":
            raise RuntimeError("simulated crash in a2c")
        return real_train(config, run_dir, **kwargs)

    monkeypatch.setattr(training, "train", flaky_train)
    config = tmp_path / "grid.yaml"
    config.write_text(yaml.safe_dump({**GRID, "seeds": 1, "retries": 2}))
    assert main(["sweep", str(config), "--out", str(tmp_path / "out")]) == 1
    assert calls == ["edge-ppo", "avoid-a2c", "avoid-a2c", "avoid-a2c"]  # 1 try + 2 retries

    result = collect_sweep(tmp_path / "out")
    status = {r.trial_id: r.status for r in result.records}
    assert status == {"edge-ppo/seed-0": "done", "avoid-a2c/seed-0": "failed"}
    failed = result.records[1]
    assert failed.failed_attempts == 3
    assert failed.error == "RuntimeError: simulated crash in a2c"
    outcome = json.loads((failed.run_dir / "trial.json").read_text())
    assert outcome["status"] == "failed" and len(outcome["attempts"]) == 3
    assert "Traceback" in outcome["attempts"][-1]["traceback"]
    groups = {g.group: g for g in result.groups}
    assert groups["avoid-a2c"].n_failed == 1 and "env_return" not in groups["avoid-a2c"].stats
    assert groups["edge-ppo"].n_done == 1 and "env_return" in groups["edge-ppo"].stats
    table = (tmp_path / "out" / "results.md").read_text()
    assert "| avoid-a2c | a2c | avoid_top_right | 0/1 | 1 |" in table
    assert "`avoid-a2c/seed-0`: RuntimeError: simulated crash in a2c" in table

    # Fixed, the sweep runs again: only the failed trial trains.
    monkeypatch.setattr(training, "train", real_train)
    lines: list[str] = []
    result = run_sweep(load_sweep(config), tmp_path / "out", log=lines.append)
    assert "1 already finished, 1 to run" in lines[0]
    assert result.n_done == 2 and result.n_failed == 0
    assert capsys.readouterr().out.count("simulated crash") >= 1


def test_interrupted_trial_resumes_from_its_checkpoint(tmp_path: Path) -> None:
    from noisybolt.runs import train

    sweep = _sweep(rows=[GRID["rows"][0]], seeds=1)
    (trial,) = sweep.trials
    run_dir = tmp_path / "out" / "trials" / trial.trial_id
    # What an interruption leaves: a run with a checkpoint at 512 frames, no summary.
    train(dataclasses.replace(trial.config, frames=512), run_dir, log=_quiet)
    (run_dir / "summary.json").unlink()
    first = json.loads((run_dir / "metrics.json").read_text())
    # Told apart from a trial not started: how far it got, and that it will resume.
    (tmp_path / "out" / "sweep.json").write_text(json.dumps(sweep.to_dict()))
    (record,) = collect_sweep(tmp_path / "out", write=False).records
    assert (record.status, record.checkpoint_frames) == ("interrupted", 512)

    lines: list[str] = []
    result = run_sweep(sweep, tmp_path / "out", log=lines.append)
    assert "1 to run (here; 1 from their checkpoints)" in lines[0]
    assert result.n_done == 1 and result.records[0].frames == 1024
    assert result.records[0].checkpoint_frames is None
    assert "resuming" in (run_dir / "log.txt").read_text()
    metrics = json.loads((run_dir / "metrics.json").read_text())
    assert metrics[: len(first)] == first and metrics[-1]["frames"] == 1024


def test_trial_directory_trained_with_other_settings_is_refused(grid_dir: Path) -> None:
    changed = _sweep(base={**TINY_BASE, "eval_episodes": 6})
    with pytest.raises(
        ConfigError, match=r"edge-ppo/seed-0: the config differs in \['evaluation.episodes'\]"
    ):
        run_sweep(changed, grid_dir, log=_quiet)


def test_workers_run_on_a_local_ray_like_one_after_the_other_and_leave_no_process(
    grid_dir: Path, tmp_path: Path
) -> None:
    ray = pytest.importorskip("ray", reason="--workers > 1 runs on Ray Tune")
    psutil = pytest.importorskip("psutil", reason="installed with Ray")
    assert not ray.is_initialized()  # this test starts (and must stop) its own Ray
    before = set(psutil.Process().children(recursive=True))
    lines: list[str] = []
    result = run_sweep(
        _sweep(rows=[GRID["rows"][1]]), tmp_path / "two", workers=2, log=lines.append
    )
    assert "2 to run (Ray Tune, 2 at once)" in lines[0], lines
    assert any("ray: 2 trials on 2 CPUs" in line for line in lines), lines
    assert result.n_done == 2 and not ray.is_initialized()
    # The same trials as the grid's, trained one after the other in this process.
    sequential = [r for r in collect_sweep(grid_dir, write=False).records if r.row == "avoid-a2c"]
    assert [r.final for r in result.records] == [r.final for r in sequential]
    started = set(psutil.Process().children(recursive=True)) - before
    _, alive = psutil.wait_procs(started, timeout=30)  # Ray's own processes, shut down
    assert not alive, [p.cmdline() for p in alive]


def test_workers_without_ray_say_how_to_install_it_before_anything_runs(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import sys

    from noisybolt.errors import BackendUnavailableError

    monkeypatch.setitem(sys.modules, "ray", None)  # what `import ray` does where it is missing
    with pytest.raises(BackendUnavailableError, match=r"noisybolt\[ray\].*--workers 1"):
        run_sweep(_sweep(), tmp_path / "out", workers=2, log=_quiet)
    assert not (tmp_path / "out").exists()


def test_unknown_backend_is_a_config_error(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="unknown backend 'slurm'"):
        run_sweep(_sweep(), tmp_path, backend="slurm")


def test_the_docs_sweep_example_is_a_valid_sweep() -> None:
    import re

    page = Path(__file__).resolve().parents[2] / "docs" / "tutorials" / "sweeps.md"
    example = re.search(r"```yaml\n(.*?)```", page.read_text(), re.S)
    assert example is not None
    sweep = SweepConfig.from_dict(yaml.safe_load(example.group(1)))
    assert len(sweep.trials) == 2 * 2 * 3  # rows x cost modes x seeds
    assert sweep.trials[-1].trial_id == "a2c/cost_mode=proportional/seed-2"
    assert sweep.trials[-1].config.algorithm.hyperparams["learning_rate"] == 0.0007


def test_a_trial_that_kept_its_failures_in_failure_json_still_reads(tmp_path: Path) -> None:
    from noisybolt.experiments.sweeps import TrialDirectory

    folder = TrialDirectory(tmp_path / "trial")
    folder.path.mkdir()
    old = {"error": "RuntimeError", "message": "RuntimeError: old", "traceback": "Traceback"}
    (folder.path / "failure.json").write_text(json.dumps({"attempts": [old]}))
    (folder.path / "trial.json").write_text(json.dumps({"status": "failed", "seconds": 1.0}))
    assert folder.outcome() == {"attempts": [old], "status": "failed", "seconds": 1.0}
    folder.end(2.0, RuntimeError("new"))  # trial.json now holds every attempt
    outcome = json.loads((folder.path / "trial.json").read_text())
    assert [a["message"] for a in outcome["attempts"]] == ["RuntimeError: old", "RuntimeError: new"]
    assert outcome["status"] == "failed" and outcome["seconds"] == 2.0


def test_a_users_detector_that_cannot_be_made_is_refused_before_anything_runs(
    world_module: Any,
) -> None:
    # Made once per world and seed while the sweep is checked, not failing in every trial.
    world_module("sweepdetectors", "def broken(fluent_names):\n    raise OSError('no sensor')\n")
    base = {**TINY_BASE, "detector": {"kind": "sweepdetectors:broken"}}
    with pytest.raises(ConfigError, match=r"trial 'edge-ppo/seed-0'.*OSError: no sensor"):
        _sweep(base=base)
