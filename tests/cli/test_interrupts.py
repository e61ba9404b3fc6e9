"""A sweep stopped by SIGTERM (``kill``, a batch scheduler's notice) stops as Ctrl-C stops
it: the running trial saves a checkpoint, the command says how to resume in one line
(no traceback) and exits 130, and the same command then finishes the trial."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import yaml

SWEEP = {
    "name": "stopped",
    "base": {
        "detector": {"kind": "oracle"},
        "frames": 2_000_000,  # far more than the test waits for
        "eval_freq": 0,
        "eval_episodes": 2,
        "checkpoint_freq": 0,  # only the interruption writes one
    },
    "rows": [{"name": "edge", "specs": ["edge"], "algo": "a2c"}],
    "seeds": 1,
}


def _noisybolt(*argv: str, start_new_session: bool = False) -> subprocess.Popen[str]:
    """``noisybolt ARGV`` in a process of its own (one torch thread), its output piped."""
    return subprocess.Popen(
        [sys.executable, "-m", "noisybolt", *argv],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "OMP_NUM_THREADS": "1"},
        start_new_session=start_new_session,
    )


def _wait_for(path: Path, process: subprocess.Popen[str], seconds: float = 120.0) -> None:
    deadline = time.monotonic() + seconds
    while not path.exists():
        assert process.poll() is None, process.communicate()
        assert time.monotonic() < deadline, f"{path} never appeared"
        time.sleep(0.2)


def test_sigterm_stops_a_sweep_with_a_checkpoint_and_one_line(tmp_path: Path) -> None:
    config, out = tmp_path / "stopped.yaml", tmp_path / "sweep"
    config.write_text(yaml.safe_dump(SWEEP))
    process = _noisybolt("sweep", str(config), "--out", str(out))
    trial = out / "trials" / "edge" / "seed-0"
    _wait_for(trial / "tensorboard" / "run_1", process)  # learn() has begun
    time.sleep(1.0)
    process.send_signal(signal.SIGTERM)
    _, err = process.communicate(timeout=120)
    assert process.returncode == 130, err
    assert "Traceback" not in err
    assert "sweep stopped interrupted" in err and "same command to resume" in err
    checkpoint = json.loads((trial / "checkpoints" / "latest.json").read_text())
    assert checkpoint["frames"] > 0
    assert "interrupted at" in (trial / "log.txt").read_text()
    assert not (trial / "summary.json").exists()  # not finished: the same command resumes


def _group_gone(pgid: int, seconds: float = 20.0) -> bool:
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        try:
            os.killpg(pgid, 0)
        except ProcessLookupError:
            return True
        time.sleep(0.2)
    return False


def test_sigterm_to_the_whole_group_of_a_world_in_workers_keeps_a_checkpoint(
    tmp_path: Path,
) -> None:
    # `timeout`, `kill -TERM -PGID` and batch schedulers signal every process of the
    # group: the trainer, its world's workers and their fork server. Evaluations every 512
    # frames take most of the time, so the signal most likely lands in one (in the
    # evaluation world's workers). The trainer must still save, say so and exit 130, and
    # leave no process behind.
    out = tmp_path / "run"
    process = _noisybolt(
        "train", "--world", "breakout-ram", "--spec", "left_row5", "--reward", "paper",
        "--detector", "oracle", "--frames", "2m", "--eval-freq", "512", "--eval-episodes", "4",
        "--checkpoint-freq", "0", "--no-progress", "--set", "world.workers=2", "--out", str(out),
        start_new_session=True,
    )  # fmt: skip
    _wait_for(out / "tensorboard" / "run_1", process)  # learn() has begun
    time.sleep(3.0)
    os.killpg(process.pid, signal.SIGTERM)
    stdout, err = process.communicate(timeout=120)
    assert process.returncode == 130, err
    assert "Traceback" not in err
    assert "interrupted at" in stdout and "checkpoint saved" in stdout
    checkpoint = json.loads((out / "checkpoints" / "latest.json").read_text())
    assert checkpoint["frames"] > 0
    assert _group_gone(process.pid), "a worker or the fork server outlived the training"
