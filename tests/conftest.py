"""Shared test settings: one torch thread (see FACTS.md), Hypothesis profiles, SB3's log
folder in one temporary folder; the repository's scripts as modules (``load_script``); a
user's world module in a test's own directory (``world_module``)."""

from __future__ import annotations

import atexit
import importlib.util
import os
import shutil
import sys
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path
from types import ModuleType

from hypothesis import HealthCheck, settings

os.environ.setdefault("OMP_NUM_THREADS", "1")
# SB3's learn() without a tensorboard folder makes a new empty tempdir/SB3-<time> folder
# per call (its logger.configure), which a test suite leaves behind by the hundred: they
# all go to one folder of this session, removed at exit.
if "SB3_LOGDIR" not in os.environ:
    os.environ["SB3_LOGDIR"] = tempfile.mkdtemp(prefix="noisybolt-tests-sb3-")
    atexit.register(shutil.rmtree, os.environ["SB3_LOGDIR"], ignore_errors=True)

settings.register_profile(
    "default", deadline=None, suppress_health_check=[HealthCheck.too_slow], max_examples=100
)
settings.register_profile(
    "ci",
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow],
    max_examples=100,
    derandomize=True,
)
settings.load_profile("ci" if os.environ.get("CI") else "default")

try:  # torch is heavy: only configure it when installed (always, with the dev extras).
    import torch

    torch.set_num_threads(1)
except ImportError:  # pragma: no cover
    pass


import pytest  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="session")
def load_script() -> Callable[..., ModuleType]:
    """Imports a script of the repository (``benchmarks/x.py``, ``scripts/y.py``,
    ``examples/z.py``: its path from the root) as a module, registered in ``sys.modules``
    under ``name`` (default: the file's stem), where its dataclasses, NamedTuples and
    process pools look their module up."""

    def load(relative: str, name: str | None = None) -> ModuleType:
        path = ROOT / relative
        spec = importlib.util.spec_from_file_location(name or path.stem, path)
        assert spec is not None and spec.loader is not None
        module = importlib.util.module_from_spec(spec)
        sys.modules[spec.name] = module
        spec.loader.exec_module(module)
        return module

    return load


@pytest.fixture(autouse=True, scope="session")
def _private_cache_dir(tmp_path_factory: pytest.TempPathFactory) -> None:
    """Compiled DFAs and on-the-fly classifiers go to a temporary cache, not ~/.cache."""
    if "NOISYBOLT_CACHE_DIR" not in os.environ:
        os.environ["NOISYBOLT_CACHE_DIR"] = str(tmp_path_factory.mktemp("noisybolt-cache"))


@pytest.fixture
def world_module(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> Iterator[Callable[[str, str], str]]:
    """Writes a user's world module into the test's own directory, made the current one
    (as ``--world module:function`` imports it), and returns its name; the module is
    forgotten again afterwards, and the import's addition to ``sys.path`` undone."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(sys, "path", list(sys.path))  # the import adds the folder to it
    written: list[str] = []

    def write(name: str, source: str) -> str:
        (tmp_path / f"{name}.py").write_text(source)
        shutil.rmtree(tmp_path / "__pycache__", ignore_errors=True)  # a rewrite is reread
        sys.modules.pop(name, None)
        written.append(name)
        return name

    yield write
    for name in written:
        sys.modules.pop(name, None)
