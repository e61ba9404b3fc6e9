"""A run saved before a setting existed still resumes: LEGACY_DEFAULTS says what it meant."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from noisybolt.agents.config import LEGACY_DEFAULTS, RESUMABLE_KEYS, TrainConfig
from noisybolt.errors import ConfigError
from noisybolt.rundir import RunDirectory


def test_a_config_saved_before_belief_tracking_resumes_under_threshold_tracking(
    tmp_path: Path,
) -> None:
    config = TrainConfig.create(world="gridworld", specs=["edge"], reward="paper")
    saved = config.to_dict()
    del saved["tracking"], saved["confidence"]  # what a run of early December 2026 wrote
    run = RunDirectory(tmp_path / "run")
    run.path.mkdir()
    (run.path / "config.json").write_text(json.dumps(saved))
    run.check_same_config(config.to_dict(), ignore=RESUMABLE_KEYS, defaults=LEGACY_DEFAULTS)
    assert TrainConfig.from_dict(saved).tracking == "threshold"
    # a run resumed under belief tracking would change the bolt halfway: refused
    belief = {**config.to_dict(), "tracking": "belief"}
    with pytest.raises(ConfigError, match="tracking"):
        run.check_same_config(belief, ignore=RESUMABLE_KEYS, defaults=LEGACY_DEFAULTS)


def test_every_setting_added_since_the_oldest_kept_run_has_a_legacy_default() -> None:
    # The oldest config.json kept in the repository (a Breakout run of 2026-12-01): a field
    # that config lacks was added later, and runs saved before it resume only if
    # LEGACY_DEFAULTS says what they meant by it (tracking and confidence once did not).
    oldest = Path(__file__).resolve().parents[2] / "results/breakout/ppo-bolted/config.json"
    saved = set(json.loads(oldest.read_text()))
    fields = set(TrainConfig.__dataclass_fields__)
    assert saved <= fields | {"detector"}, saved - fields  # the kept run is a config at all
    missing = sorted(fields - saved - set(LEGACY_DEFAULTS))
    assert not missing, (
        f"TrainConfig fields {missing} are newer than the oldest kept run: add what a run "
        "saved before them meant to LEGACY_DEFAULTS, or old runs stop resuming"
    )
