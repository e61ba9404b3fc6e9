"""A run saved before a setting existed, or before the schema was nested, still loads and
resumes: its flat config.json converts, and LEGACY_DEFAULTS says what it meant."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import pytest

from noisybolt.agents.hyperparams import WORLD_KEYS
from noisybolt.errors import ConfigError
from noisybolt.runs.config import TrainConfig, schema_paths
from noisybolt.runs.legacy import FLAT_PATHS, LEGACY_DEFAULTS, nested_config
from noisybolt.runs.rundir import RunDirectory
from noisybolt.runs.schema import flatten
from noisybolt.runs.training import check_same_config

RESULTS = Path(__file__).resolve().parents[2] / "results"
#: The oldest config.json kept in the repository (a Breakout run of 2026-12-01).
OLDEST = RESULTS / "breakout/ppo-bolted/config.json"


def _flat(config: TrainConfig) -> dict[str, object]:
    """``config`` as the flat config.json that noisybolt wrote before schema 2."""
    nested = config.to_dict()
    flat: dict[str, object] = {
        k: nested[k] for k in ("seed", "frames", "checkpoint_freq", "progress_bar", "detector")
    }
    for name, path in FLAT_PATHS.items():
        section, key = path.split(".")
        flat[name] = nested[section][key]
    world = {k: v for k, v in nested["world"].items() if k in WORLD_KEYS and v}
    flat["hyperparams"] = {**nested["algorithm"]["hyperparams"], **world}
    return flat


def test_a_config_saved_before_belief_tracking_resumes_under_threshold_tracking(
    tmp_path: Path,
) -> None:
    config = TrainConfig.create(world="gridworld", specs=["edge"], reward="paper")
    saved = _flat(config)
    del saved["tracking"], saved["confidence"]  # what a run of early December 2026 wrote
    run = RunDirectory(tmp_path / "run")
    run.path.mkdir()
    (run.path / "config.json").write_text(json.dumps(saved))
    check_same_config(run, config)
    assert TrainConfig.from_dict(saved).tracking == "threshold"
    assert TrainConfig.from_dict(saved) == config
    # a run resumed under belief tracking would change the bolt halfway: refused by path
    with pytest.raises(ConfigError, match=r"bolt\.tracking: saved 'threshold', now 'belief'"):
        check_same_config(run, config.override({"bolt.tracking": "belief"}))


def test_every_setting_added_since_the_oldest_kept_run_has_a_legacy_default() -> None:
    # A setting that the oldest kept config lacks was added later, and runs saved before
    # it resume only if LEGACY_DEFAULTS says what they meant by it (tracking and
    # confidence once did not). The world settings that rode among the hyperparameters
    # meant False or the file's n_envs when absent: the schema's defaults.
    saved = json.loads(OLDEST.read_text())
    unknown = set(saved) - set(FLAT_PATHS) - {"seed", "frames", "checkpoint_freq"}
    assert unknown <= {"progress_bar", "detector", "hyperparams"}, unknown
    present = {FLAT_PATHS.get(k, k) for k in saved} | {f"world.{k}" for k in WORLD_KEYS}
    present |= {f"detector.{k}" for k in saved["detector"]} | {"algorithm.hyperparams"}
    missing = sorted(set(schema_paths()) - present - set(LEGACY_DEFAULTS))
    assert not missing, (
        f"settings {missing} are newer than the oldest kept run: add what a run saved "
        "before them meant to LEGACY_DEFAULTS, or old runs stop resuming"
    )


def _kept_configs(nested: bool) -> list[Path]:
    return [
        path
        for path in sorted(RESULTS.rglob("config.json"))
        if ("schema" in json.loads(path.read_text())) == nested
    ]


@pytest.mark.parametrize("path", _kept_configs(False), ids=lambda p: str(p.relative_to(RESULTS)))
def test_every_kept_flat_config_loads_and_round_trips(path: Path) -> None:
    saved = json.loads(path.read_text())
    config = TrainConfig.from_dict(saved)
    assert config.world_config.name == saved["world"] and config.frames == saved["frames"]
    assert config.world_config.n_envs == saved["hyperparams"]["n_envs"]
    assert "n_envs" not in config.algorithm.hyperparams  # a world setting, in the world section
    assert config.bolt.tracking == saved.get("tracking", "threshold")
    assert TrainConfig.from_dict(config.to_dict()) == config
    assert nested_config(config.to_dict()) == config.to_dict()


@pytest.mark.parametrize("path", _kept_configs(True), ids=lambda p: str(p.relative_to(RESULTS)))
def test_every_kept_nested_config_loads_as_saved(path: Path) -> None:
    # Kept runs saved under schema 2 (the spec suite's trials) read strictly and write back
    # as saved, plus any setting added since, at what LEGACY_DEFAULTS says they meant by it.
    saved = _paths(json.loads(path.read_text()))
    loaded = _paths(TrainConfig.from_dict(json.loads(path.read_text())).to_dict())
    assert {k: loaded[k] for k in saved} == saved
    assert {k: v for k, v in loaded.items() if k not in saved} == {
        k: LEGACY_DEFAULTS[k] for k in loaded if k not in saved
    }


def _paths(config: dict[str, object]) -> dict[str, object]:
    """A nested config.json's settings by schema path (``world.n_envs``)."""
    return flatten(TrainConfig, {k: v for k, v in config.items() if k != "schema"})


def test_a_run_saved_with_a_flat_config_resumes_and_evaluates(tmp_path: Path) -> None:
    from noisybolt.runs import train
    from noisybolt.runs.run_evaluation import evaluate_run

    config = TrainConfig.build(
        {"bolt.specs": ["edge"], "bolt.reward": "paper", "detector.kind": "oracle",
         "frames": 64, "evaluation.freq": 0, "checkpoint_freq": 0, "evaluation.episodes": 1,
         "progress_bar": False, "world.n_envs": 2}
    )  # fmt: skip
    run = tmp_path / "old"
    train(config, run, log=lambda _: None)
    (run / "config.json").write_text(json.dumps(_flat(config)))  # as saved before schema 2
    assert evaluate_run(run, episodes=2).result.n_episodes == 2
    result = train(config.override({"frames": 128}), run, resume=True, log=lambda _: None)
    assert result.frames == 128
    saved = json.loads((run / "config.json").read_text())
    assert saved["schema"] == 2 and saved["frames"] == 128  # rewritten in today's form
    with pytest.raises(ConfigError, match=r"algorithm\.hyperparams\.gamma"):
        train(
            config.override({"frames": 256, "algorithm.hyperparams.gamma": 0.5}),
            run,
            resume=True,
            log=lambda _: None,
        )


def test_the_flat_names_of_old_files_are_create_keywords_and_deprecated_attributes() -> None:
    config = TrainConfig.create(specs=["edge"], reward="paper", eval_freq=7)
    assert config.evaluation.freq == 7
    with pytest.warns(DeprecationWarning, match="read config.evaluation.freq"):
        assert config.eval_freq == 7
    # no flat name is a field of today's config: the one list is FLAT_PATHS
    assert not set(FLAT_PATHS) & {f.name for f in dataclasses.fields(TrainConfig)}
