"""Fault injection: trainings SIGKILLed at random moments, resumed, and still whole.

Twenty train/resume cycles per algorithm (PPO, and DQN with its replay buffer), each
process killed after a random delay (seeded), wherever it happens to be: importing,
validating, training, evaluating, or midway through writing a checkpoint. A cycle resumes
from the latest checkpoint, or starts over (``--restart``) when the killed run had none
yet. The last cycle runs to its end. Then the run must hold the frames asked, a valid
``metrics.json`` increasing in frames, and no partial file.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

pytestmark = pytest.mark.slow

CYCLES = 20


def _argv(run: Path, algo: str, mode: list[str]) -> list[str]:
    hp = ["--hp", "n_steps=32"] if algo == "ppo" else ["--hp", "learning_starts=64"]
    return [
        sys.executable,
        "-m",
        "noisybolt",
        "train",
        "--spec",
        "edge",
        "--detector",
        "oracle",
        "--reward",
        "paper",
        "--algo",
        algo,
        "--frames",
        "4096",
        "--checkpoint-freq",
        "256",
        "--eval-freq",
        "512",
        "--eval-episodes",
        "2",
        *hp,
        "--no-progress",
        "--out",
        str(run),
        *mode,
    ]


def _mode(run: Path) -> list[str]:
    if (run / "checkpoints" / "latest.json").exists():
        return ["--resume"]
    if (run / "config.json").exists():
        return ["--restart"]  # killed before its first checkpoint
    return []


@pytest.mark.parametrize("algo", ["ppo", "dqn"])
def test_runs_killed_at_random_moments_resume_whole(tmp_path: Path, algo: str) -> None:
    rng = np.random.default_rng(14)
    run = tmp_path / "run"
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    # One whole run first, timed: the kills land at random shares of it (start-up
    # included), so that they reach into training on a fast machine and a slow one alike.
    started = time.monotonic()
    whole = subprocess.run(_argv(run, algo, []), capture_output=True, env=env, check=False)
    assert whole.returncode == 0, whole.stderr.decode()
    duration = time.monotonic() - started
    _check_whole(run)
    import shutil

    shutil.rmtree(run)
    outcomes = []
    for _ in range(CYCLES):
        proc = subprocess.Popen(
            _argv(run, algo, _mode(run)),
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            env=env,
        )
        deadline = time.monotonic() + float(rng.uniform(0.1, 1.1)) * duration
        while time.monotonic() < deadline and proc.poll() is None:
            time.sleep(0.05)
        if proc.poll() is None:
            proc.send_signal(signal.SIGKILL)
        proc.wait()
        err = proc.stderr.read().decode() if proc.stderr else ""
        assert proc.returncode in (0, -signal.SIGKILL), err
        outcomes.append(proc.returncode)
        if proc.returncode == 0:  # finished: start the next cycle from scratch
            summary = json.loads((run / "summary.json").read_text())
            assert summary["frames"] == 4096
            _check_whole(run)
            shutil.rmtree(run)
    assert outcomes.count(-signal.SIGKILL) >= CYCLES // 2  # the kills did land
    final = subprocess.run(_argv(run, algo, _mode(run)), capture_output=True, env=env, check=False)
    assert final.returncode == 0, final.stderr.decode()
    assert json.loads((run / "summary.json").read_text())["frames"] == 4096
    _check_whole(run)


def _check_whole(run: Path) -> None:
    metrics = json.loads((run / "metrics.json").read_text())
    frames = [m["frames"] for m in metrics]
    assert frames == sorted(set(frames)) and frames[-1] == 4096
    assert frames == list(range(512, 4097, 512))
    assert not [p for p in run.rglob("*.tmp")], "a partial file was left"
    latest = json.loads((run / "checkpoints" / "latest.json").read_text())
    assert latest["frames"] == 4096
    assert [p.name for p in (run / "checkpoints").iterdir() if p.is_dir()] == [latest["folder"]]
