"""``scripts/ray-cluster.sh`` end to end on this machine: a Ray head of its own (own ports,
own temp dir, 2 CPUs), a tiny sweep sent to it with ``--address``, its table, and that
head stopped by its own processes (``ray stop`` would stop every Ray instance of the
user: other tests' and other sweeps' included)."""

from __future__ import annotations

import contextlib
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest
import yaml

pytest.importorskip("ray", reason="the cluster script needs Ray: pip install 'ray[tune]'")
psutil = pytest.importorskip("psutil", reason="installed with Ray")

ROOT = Path(__file__).resolve().parents[2]
SWEEP = {
    "name": "on-a-cluster",
    "base": {"detector": {"kind": "oracle"}, "specs": ["edge"], "frames": 512,
             "eval_freq": 256, "eval_episodes": 4, "checkpoint_freq": 256},
    "rows": [{"name": "ppo", "algo": "ppo", "hyperparams": {"n_steps": 64}}],
    "seeds": 2,
}  # fmt: skip


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


def _script(*args: str) -> list[str]:
    return ["sh", str(ROOT / "scripts" / "ray-cluster.sh"), *args]


@pytest.mark.slow  # a Ray head started and stopped: over a minute (make test-slow)
def test_the_cluster_script_runs_a_sweep_on_its_own_head_and_stops_only_it(
    tmp_path: Path,
) -> None:
    start = time.perf_counter()
    # Short: Ray's socket paths under the temp dir must stay within 107 bytes.
    temp_dir = tempfile.mkdtemp(prefix="nbray-")
    env = {**os.environ, "VENV": str(Path(sys.executable).parent.parent)}
    env.update(RAY_USAGE_STATS_ENABLED="0", PYTHONUNBUFFERED="1")
    env.pop("RAY_ADDRESS", None)
    port = _free_port()
    options = ["--num-cpus", "2", "--temp-dir", temp_dir, "--disable-usage-stats", "--block"]
    options += ["--ray-client-server-port", str(_free_port())]
    options += ["--dashboard-agent-listen-port", str(_free_port())]
    head_log = tmp_path / "head.log"
    with open(head_log, "w") as out:
        head = subprocess.Popen(
            _script("head", str(port), *options),
            cwd=ROOT, env=env, stdout=out, stderr=subprocess.STDOUT, start_new_session=True,
        )  # fmt: skip
    cluster: list[psutil.Process] = []
    try:
        deadline = time.monotonic() + 120
        while "Ray runtime started" not in head_log.read_text():
            assert head.poll() is None, head_log.read_text()
            assert time.monotonic() < deadline, head_log.read_text()
            time.sleep(0.5)
        config = tmp_path / "tiny.yaml"
        config.write_text(yaml.safe_dump(SWEEP))
        out_dir = tmp_path / "shared" / "tiny"  # the storage path all nodes would share
        sweep = subprocess.run(
            _script("sweep", str(config), str(out_dir)),
            cwd=ROOT, env={**env, "RAY_ADDRESS": f"127.0.0.1:{port}"},
            capture_output=True, text=True, timeout=480,
        )  # fmt: skip
        cluster = psutil.Process(head.pid).children(recursive=True)
        assert sweep.returncode == 0, sweep.stdout + sweep.stderr
        assert "| ppo | ppo | edge | 2/2 | 0 |" in sweep.stdout
        assert "ray: 2 trials on 2 CPUs" in sweep.stdout + sweep.stderr
        table = (out_dir / "results.md").read_text()
        assert "| ppo | ppo | edge | 2/2 | 0 |" in table
        assert f"--address 127.0.0.1:{port}" in (out_dir / "command.txt").read_text()
        for seed in (0, 1):
            assert (out_dir / "trials" / "ppo" / f"seed-{seed}" / "model.zip").exists()
        assert any((out_dir / "ray").iterdir())  # Tune's experiment, for a resume
        # The trials ran in this head's workers (their logs are in its session), not in a
        # Ray the driver started itself.
        logs = Path(temp_dir) / "session_latest" / "logs"
        assert list(logs.glob("worker-*")), sorted(p.name for p in logs.iterdir())
    finally:
        with contextlib.suppress(psutil.NoSuchProcess):
            cluster += psutil.Process(head.pid).children(recursive=True)
        with contextlib.suppress(ProcessLookupError):
            os.killpg(head.pid, signal.SIGTERM)  # `ray start --block` stops what it started
        try:
            head.wait(timeout=60)
        except subprocess.TimeoutExpired:
            os.killpg(head.pid, signal.SIGKILL)
            head.wait()
        _, alive = psutil.wait_procs(set(cluster), timeout=30)
        for process in alive:  # only this head's processes
            process.kill()
        shutil.rmtree(temp_dir, ignore_errors=True)
    assert not alive, f"the head left {[p.pid for p in alive]} running"
    print(f"ray cluster script, head to stop: {time.perf_counter() - start:.1f} s")
