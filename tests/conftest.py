"""Shared test settings: one torch thread (see FACTS.md), Hypothesis profiles."""

from __future__ import annotations

import os

from hypothesis import HealthCheck, settings

os.environ.setdefault("OMP_NUM_THREADS", "1")

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


@pytest.fixture(autouse=True, scope="session")
def _private_cache_dir(tmp_path_factory: pytest.TempPathFactory) -> None:
    """Compiled DFAs and on-the-fly classifiers go to a temporary cache, not ~/.cache."""
    if "NOISYBOLT_CACHE_DIR" not in os.environ:
        os.environ["NOISYBOLT_CACHE_DIR"] = str(tmp_path_factory.mktemp("noisybolt-cache"))
