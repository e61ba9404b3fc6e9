"""scripts/breakout_runs.py: Breakout runs kept across sessions and their summary."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
import zipfile
from collections.abc import Callable
from pathlib import Path
from types import ModuleType

import pytest


@pytest.fixture
def script(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, load_script: Callable[..., ModuleType]
) -> ModuleType:
    module = load_script("scripts/breakout_runs.py")
    monkeypatch.setattr(module, "RESULTS", tmp_path / "results")
    monkeypatch.setattr(module, "CLASSIFIERS", tmp_path / "results" / "classifiers")
    # The tests' background runs at the suite's own priority: at the lowest they starve
    # on a busy machine (their session's share goes to every other session first).
    monkeypatch.setattr(module, "NICE", 0)
    return module


def _record(frames: int, cleared: float, rows: list[float], score: float) -> dict:
    compliance = {"clear_left_column": cleared}
    compliance |= {f"left_row{r}": rate for r, rate in enumerate(rows)}
    return {
        "frames": frames,
        "compliance": compliance,
        "false_acceptance": {"clear_left_column": 0.0, "left_row5": 0.25},
        "env_return_mean": score,
        "env_return_std": 1.0,
        "n_episodes": 8,
    }


def _run(path: Path, config: dict, metrics: list[dict]) -> Path:
    path.mkdir(parents=True)
    (path / "config.json").write_text(json.dumps(config))
    (path / "metrics.json").write_text(json.dumps(metrics))
    (path / "command.txt").write_text("noisybolt train ... --resume\n")
    return path


def test_summary_reads_the_last_evaluation_of_each_run(script: ModuleType) -> None:
    results = script.RESULTS
    ram = {
        "world": "breakout-ram",
        "algo": "ppo",
        "seed": 1,
        "bolted": True,
        "reward": "paper",
        "world_kwargs": {"noise": "gaussian:sigma=40+occlusion:count=2,size=0.25"},
        "tracking": "belief",
        "hyperparams": {"normalize_reward": "split", "bolt_weight": 5.0},
    }
    image = {"world": "breakout", "algo": "dqn", "seed": 0, "bolted": False}
    rows = [0.0, 0.0, 0.125, 0.25, 0.75, 0.875]
    # evaluations out of order: the last is the one with the most frames
    _run(
        results / "ram-b1",
        ram,
        [_record(200_000, 0.5, rows, 30.0), _record(100_000, 0.0, [0.0] * 6, 3.0)],
    )
    _run(results / "img-u0", image, [_record(50_000, 0.0, [], 1.5)])
    with zipfile.ZipFile(results / "img-u0" / "init_model.zip", "w") as archive:  # --init-from
        archive.writestr("data", json.dumps({"num_timesteps": 1_800_000}))
    _run(results / "empty", ram, [])  # no evaluation yet: no entry
    entries = script.summary(results)
    assert [e["run"] for e in entries] == ["img-u0", "ram-b1"]
    image_entry, ram_entry = entries
    assert ram_entry == {
        "run": "ram-b1",
        "agent": "ram",
        "algo": "ppo",
        "seed": 1,
        "bolted": True,
        "frames": 200_000,
        "column_cleared_share": 0.5,
        "left_bricks_gone": 2.0,  # 0.125 + 0.25 + 0.75 + 0.875
        "score": 30.0,
        "bolt_false_acceptance": 0.25,
        "episodes": 8,
        "reward": "paper",
        "camera": "gaussian:sigma=40+occlusion:count=2,size=0.25",
        "tracking": "belief",
        "normalize_reward": "split",
        "bolt_weight": 5.0,
        "frames_before": 0,  # from random weights
    }
    assert image_entry["frames_before"] == 1_800_000  # its source's, from the copy it keeps
    assert image_entry["agent"] == "image" and image_entry["bolted"] is False
    assert (image_entry["camera"], image_entry["tracking"]) == ("none", "threshold")
    assert image_entry["left_bricks_gone"] is None  # no per-brick specs
    assert (image_entry["normalize_reward"], image_entry["bolt_weight"]) == (False, 1.0)
    assert json.loads((results / "summary.json").read_text()) == entries


def test_agent_is_read_from_the_world_and_its_obs_mode(script: ModuleType) -> None:
    assert script._agent({"world": "breakout"}) == "image"
    assert script._agent({"world": "breakout", "world_kwargs": {"obs_mode": "ram"}}) == "ram"
    assert script._agent({"world": "breakout-ram"}) == "ram"
    bits = {"world": "breakout-ram", "world_kwargs": {"obs_mode": "ram_bits"}}
    assert script._agent(bits) == "ram_bits"
    assert script._agent({"world": "breakout-ram", "world_kwargs": {"obs_mode": "stack"}}) == (
        "image"
    )


def test_keep_then_restore_gives_back_the_checkpoint(script: ModuleType, tmp_path: Path) -> None:
    config = {"world": "breakout-ram", "algo": "ppo", "seed": 0, "detector": {"kind": "oracle"}}
    run = _run(tmp_path / "runs" / "ram-b0", config, [_record(100, 0.0, [0.0] * 6, 1.0)])
    checkpoints = run / "checkpoints"
    (checkpoints / "step_000000000100").mkdir(parents=True)
    (checkpoints / "step_000000000100" / "model.zip").write_bytes(b"model at 100")
    (checkpoints / "step_000000000100" / "state.json").write_text("{}")
    (checkpoints / "latest.json").write_text(
        json.dumps({"folder": "step_000000000100", "frames": 100})
    )
    script.keep(run)
    kept = script.RESULTS / "ram-b0"
    assert (kept / "checkpoints" / "step_000000000100" / "model.zip").read_bytes() == (
        b"model at 100"
    )
    assert json.loads((kept / "config.json").read_text()) == config
    # a newer checkpoint replaces the kept one
    (checkpoints / "step_000000000100").rename(checkpoints / "step_000000000200")
    (checkpoints / "step_000000000200" / "model.zip").write_bytes(b"model at 200")
    (checkpoints / "latest.json").write_text(
        json.dumps({"folder": "step_000000000200", "frames": 200})
    )
    script.keep(run)
    assert sorted(p.name for p in (kept / "checkpoints").iterdir()) == [
        "latest.json",
        "step_000000000200",
    ]
    fresh = tmp_path / "elsewhere"
    script.restore("ram-b0", fresh)
    restored = fresh / "ram-b0"
    assert (restored / "checkpoints" / "step_000000000200" / "model.zip").read_bytes() == (
        b"model at 200"
    )
    assert json.loads((restored / "checkpoints" / "latest.json").read_text())["frames"] == 200
    # a run directory further on than what was kept is left alone
    (restored / "checkpoints" / "latest.json").write_text(
        json.dumps({"folder": "step_000000000300", "frames": 300})
    )
    script.restore("ram-b0", fresh)
    assert json.loads((restored / "checkpoints" / "latest.json").read_text())["frames"] == 300


def _wait_for(pid: int, log: Path, timeout_s: float = 300.0) -> None:
    """Waits for a background run to exit (its log in the failure message)."""
    deadline = time.monotonic() + timeout_s
    while os.waitpid(pid, os.WNOHANG) == (0, 0):  # still going
        assert time.monotonic() < deadline, log.read_text()
        time.sleep(0.5)


def test_resume_restores_a_kept_run_and_continues_it_in_the_background(
    script: ModuleType, tmp_path: Path
) -> None:
    from noisybolt.runs import DetectorConfig, TrainConfig, train

    runs = tmp_path / "runs"
    config = TrainConfig.create(
        specs=["edge"], detector=DetectorConfig(kind="oracle"), frames=512, eval_freq=0,
        eval_episodes=2, checkpoint_freq=256, progress_bar=False, overrides={"n_steps": 32},
    )  # fmt: skip
    train(config, runs / "grid", log=lambda _: None)
    saved = json.loads((runs / "grid" / "config.json").read_text())
    saved["frames"] = 1024  # as if it had been stopped halfway through a longer budget
    (runs / "grid" / "config.json").write_text(json.dumps(saved))
    script.keep(runs / "grid")
    shutil.rmtree(runs)  # a new machine: runs/ is gone
    pids = tmp_path / "breakout.pids"
    pid = script.resume("grid", runs, pids, settings=("frames=1536",))
    assert pids.read_text() == f"{pid} grid\n"
    _wait_for(pid, runs / "bk-grid.log")
    log = (runs / "bk-grid.log").read_text()
    assert "resuming" in log and "from 512 frames" in log
    # the setting given to the resume (a longer budget) over the saved 1024
    assert json.loads((runs / "grid" / "summary.json").read_text())["frames"] == 1536
    with pytest.raises(SystemExit, match="neither kept"):
        script.resume("nothing", runs, pids)


def test_start_runs_a_new_training_in_the_background_and_refuses_a_taken_name(
    script: ModuleType, tmp_path: Path
) -> None:
    runs, pids = tmp_path / "runs", tmp_path / "breakout.pids"
    train_args = ["--spec", "edge", "--detector", "oracle", "--frames", "256", "--eval-freq", "0"]
    train_args += ["--hp", "n_steps=32", "--seed", "3"]
    pid = script.start("grid", train_args, runs, pids)
    assert pids.read_text() == f"{pid} grid\n"
    _wait_for(pid, runs / "bk-grid.log")
    saved = json.loads((runs / "grid" / "config.json").read_text())
    assert saved["seed"] == 3 and saved["frames"] == 256  # the arguments it was given
    assert "--out" in (runs / "grid" / "command.txt").read_text()
    assert json.loads((runs / "grid" / "summary.json").read_text())["frames"] == 256
    with pytest.raises(SystemExit, match="already a run"):
        script.start("grid", train_args, runs, pids)  # never over an existing run
    for flag in (["--out", "elsewhere"], ["--resume"]):
        with pytest.raises(SystemExit, match=f"leave {flag[0]} out"):
            script.start("other", [*train_args, *flag], runs, pids)
    assert not (runs / "other").exists() and pids.read_text() == f"{pid} grid\n"


def test_stop_terminates_the_recorded_runs_and_empties_the_file(
    script: ModuleType, tmp_path: Path
) -> None:
    sleeper = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(120)"])
    pids = tmp_path / "breakout.pids"
    pids.write_text(f"{sleeper.pid} sleeper\n999999999 long-gone\n")
    assert script.stop(pids, wait_s=0.0) == [sleeper.pid]
    assert sleeper.wait(timeout=30) == -signal.SIGTERM
    assert pids.read_text() == ""
