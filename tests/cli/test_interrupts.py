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


def _wait_for(path: Path, process: subprocess.Popen[str], seconds: float = 120.0) -> None:
    deadline = time.monotonic() + seconds
    while not path.exists():
        assert process.poll() is None, process.communicate()
        assert time.monotonic() < deadline, f"{path} never appeared"
        time.sleep(0.2)


def test_sigterm_stops_a_sweep_with_a_checkpoint_and_one_line(tmp_path: Path) -> None:
    config, out = tmp_path / "stopped.yaml", tmp_path / "sweep"
    config.write_text(yaml.safe_dump(SWEEP))
    command = [sys.executable, "-m", "noisybolt", "sweep", str(config), "--out", str(out)]
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    process = subprocess.Popen(
        command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env
    )
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
