"""The wheel keeps working without the source tree.

``python -m build`` makes an sdist and a wheel (the wheel built from the sdist, so both
are checked), with no deprecation printed; the wheel carries its package data and its
licence; installed into a fresh virtual environment (no system site-packages, nothing of
the checkout's .venv), its ``noisybolt`` command runs from a folder outside the checkout:
``--version``, ``check`` (without MONA: the pure-Python backend, said once),
``demo --walkthrough`` and a 2k-frame ``train``.

A fresh install of every dependency takes minutes (about 2.5 on 2 busy cores), so this
is a slow test, which CI runs as a step of its own (``make test-wheel``, after
``make test``; ``make test-slow`` runs it too). PyTorch is installed first at the
version the project pins, which pip finds locally where a wheel of it is provided, instead
of resolving a new (CUDA) build.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import venv
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

pytestmark = pytest.mark.slow


def _pin(name: str) -> str:
    """``name==version`` as constraints.txt pins it."""
    for line in (ROOT / "constraints.txt").read_text().splitlines():
        if line.split("==")[0].strip().lower() == name:
            return line.strip()
    raise AssertionError(f"{name} is not pinned in constraints.txt")


def _run(args: list[str | Path], cwd: Path, timeout: float = 900, **env_changes: str) -> str:
    # A clean environment for the child: no PYTHONPATH into the checkout, no active venv.
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    env["PIP_DISABLE_PIP_VERSION_CHECK"] = "1"
    env.update(env_changes)
    done = subprocess.run(
        [str(a) for a in args],
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        timeout=timeout,
    )
    output = done.stdout + done.stderr
    assert done.returncode == 0, f"{' '.join(map(str, args))} failed:\n{output[-4000:]}"
    return output


def test_the_wheel_installs_and_runs_in_a_fresh_environment(tmp_path: Path) -> None:
    fresh = tmp_path / "venv"
    venv.create(fresh, with_pip=True, system_site_packages=False)
    python = fresh / "bin" / "python"
    work = tmp_path / "work"  # outside the checkout: nothing is imported from src/
    work.mkdir()

    # Build: sdist, then the wheel from it, in an isolated build environment.
    _run([python, "-m", "pip", "install", "-q", "build"], cwd=work)
    dist = tmp_path / "dist"
    log = _run([python, "-m", "build", "--outdir", dist, ROOT], cwd=work)
    assert not re.search(r"deprecat", log, re.IGNORECASE), log
    (wheel,) = dist.glob("noisybolt-*.whl")
    assert len(list(dist.glob("noisybolt-*.tar.gz"))) == 1

    with zipfile.ZipFile(wheel) as archive:
        names = set(archive.namelist())
        metadata = next(n for n in names if n.endswith(".dist-info/METADATA"))
        meta = archive.read(metadata).decode()
    for data in (
        "noisybolt/py.typed",
        "noisybolt/configs/hyperparams/_default.yaml",
        "noisybolt/configs/hyperparams/gridworld.yaml",
        "noisybolt/configs/sweeps/edge_algorithms.yaml",
    ):
        assert data in names, data
    assert any(n.endswith(".dist-info/licenses/LICENSE") for n in names)
    assert "License-Expression: MIT" in meta
    for field in (
        "Classifier: Topic :: Scientific/Engineering :: Artificial Intelligence",
        "Classifier: Programming Language :: Python :: 3.11",
        "Project-URL: Documentation",
        "Project-URL: Changelog",
        "Provides-Extra: ray",
        "Provides-Extra: bench",
        "Provides-Extra: docs",
    ):
        assert field in meta, field

    # Install: the pinned PyTorch first, then the wheel under the project's constraints
    # (--no-compile: no byte-compiling of every installed module, which nothing here needs).
    constraints = ROOT / "constraints.txt"
    _run([python, "-m", "pip", "install", "-q", "--no-compile", _pin("torch")], cwd=work)
    _run([python, "-m", "pip", "install", "-q", "--no-compile", wheel, "-c", constraints], cwd=work)

    noisybolt = fresh / "bin" / "noisybolt"
    version = _run([noisybolt, "--version"], cwd=work)
    shown = _run([python, "-c", "import noisybolt; print(noisybolt.__file__)"], cwd=work)
    assert str(fresh) in shown, "noisybolt was imported from outside the fresh environment"
    import noisybolt as checkout

    assert version.strip() == f"noisybolt {checkout.__version__}"

    # Without the MONA binary (a PATH of the fresh environment only, an empty DFA cache)
    # the pure-Python backend compiles the specs, and says so once. (MONA, where installed,
    # is the backend of the walkthrough and the training run below.)
    no_mona = _run(
        [noisybolt, "check", "--spec", "edge", "--spec", "F(top_right_corner) & G(on_edge)"],
        cwd=work,
        PATH=str(fresh / "bin"),
        NOISYBOLT_CACHE_DIR=str(tmp_path / "cache"),
    )
    assert no_mona.count("satisfiable") >= 2, no_mona
    assert no_mona.count("noisybolt check: warning: MONA is not installed") == 1, no_mona

    walkthrough = _run([noisybolt, "demo", "--walkthrough"], cwd=work)
    assert "Algorithm 1" in walkthrough and "ground truth" in walkthrough

    _run(
        [noisybolt, "train", "--spec", "edge", "--detector", "oracle", "--algo", "a2c",
         "--frames", "2k", "--out", "runs/edge"],
        cwd=work,
    )  # fmt: skip
    run = work / "runs" / "edge"
    assert (run / "model.zip").exists()
    assert json.loads((run / "config.json").read_text())["frames"] == 2000
