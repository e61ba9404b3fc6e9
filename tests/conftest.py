"""Shared test settings: one torch thread (see FACTS.md), Hypothesis profiles."""

from __future__ import annotations

import os

from hypothesis import HealthCheck, settings

os.environ.setdefault("OMP_NUM_THREADS", "1")

settings.register_profile(
    "default", deadline=None, suppress_health_check=[HealthCheck.too_slow], max_examples=100
)
settings.register_profile(
    "ci", deadline=None, suppress_health_check=[HealthCheck.too_slow], max_examples=100,
    derandomize=True,
)
settings.load_profile("ci" if os.environ.get("CI") else "default")

try:  # torch is heavy: only configure it when installed (always, with the dev extras).
    import torch

    torch.set_num_threads(1)
except ImportError:  # pragma: no cover
    pass
