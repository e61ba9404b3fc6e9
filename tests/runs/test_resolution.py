"""One resolve() for every door: the same config gets the same compliance scale from
Python's train(), ``noisybolt train``, ``noisybolt check`` and a sweep; resolving is
idempotent, a config is data (building one plays no world), and a resumed run keeps the
scale its config.json holds."""

from __future__ import annotations

import doctest
import json
import re
from pathlib import Path
from typing import Any

import pytest

from noisybolt.bolt import product
from noisybolt.cli import main
from noisybolt.envs import gridworld_tabular
from noisybolt.errors import ConfigError
from noisybolt.experiments.optimal import exact_compliance_scale
from noisybolt.experiments.sweeps import SweepConfig
from noisybolt.runs import resolution, train
from noisybolt.runs.config import TrainConfig
from noisybolt.runs.legacy import nested_config
from noisybolt.runs.resolution import compliance_scale_choice, resolve

RESULTS = Path(__file__).resolve().parents[2] / "results"
BOTH = "F(top_right_corner) & F(bottom_left_corner)"
#: A run small enough to train in a test: one PPO rollout of 2 x 32 frames.
TINY: dict[str, Any] = {
    "bolt.specs": [BOTH],
    "detector.kind": "oracle",
    "frames": 64,
    "world.n_envs": 2,
    "algorithm.hyperparams.n_steps": 32,
    "algorithm.hyperparams.batch_size": 32,
    "evaluation.freq": 0,
    "evaluation.episodes": 1,
    "checkpoint_freq": 0,
    "progress_bar": False,
}
TINY_ARGV = [
    "--spec", BOTH, "--detector", "oracle", "--frames", "64", "--n-envs", "2",
    "--hp", "n_steps=32", "--hp", "batch_size=32", "--eval-freq", "0", "--eval-episodes", "1",
    "--checkpoint-freq", "0", "--no-progress",
]  # fmt: skip


def _saved_scale(run: Path) -> float:
    return float(json.loads((run / "config.json").read_text())["bolt"]["reward_scale"])


def _quiet(_: str) -> None:
    pass


def test_every_door_pays_the_same_config_the_exact_scale(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    built = resolve(TrainConfig.build(TINY))
    # F(t) & F(b) on the gridworld: the scale computed on its product, far below the bound
    # from its return range (345.95, what Python's train() paid before one resolver).
    gamma = float(built.hyperparams.get("gamma", 0.99))
    exact = exact_compliance_scale([BOTH], gamma=gamma, floor=31.45, cap=345.95)
    assert exact is not None and built.reward_scale is not None
    assert built.reward_scale == pytest.approx(exact)
    assert round(exact, 2) == 58.45 and round(compliance_scale_choice(built).bound, 2) == 345.95
    scales: dict[str, float] = {"resolve(TrainConfig.build)": built.reward_scale}

    # Python: train() on the built config, and on the same config left unresolved.
    train(built, tmp_path / "python", log=_quiet)
    scales["train(built)"] = _saved_scale(tmp_path / "python")
    data = built.to_dict()
    data["bolt"]["reward_scale"] = None
    unresolved = TrainConfig.from_dict(data)
    assert unresolved.bolt.reward_scale is None
    train(unresolved, tmp_path / "unresolved", log=_quiet)
    scales["train(unresolved)"] = _saved_scale(tmp_path / "unresolved")

    # The CLI.
    assert main(["train", *TINY_ARGV, "--out", str(tmp_path / "cli")]) == 0
    assert "compliance scale computed on the gridworld's product" in capsys.readouterr().out
    scales["noisybolt train"] = _saved_scale(tmp_path / "cli")

    # noisybolt check says the scale that train pays.
    assert main(["check", "--spec", BOTH]) == 0
    said = re.search(r"compliance scheme: scale (\S+) \(bound (\S+)\)", capsys.readouterr().out)
    assert said is not None and float(said[2]) == pytest.approx(345.95)
    scales["noisybolt check"] = float(said[1])

    # A sweep's trial.
    sweep = SweepConfig.from_dict(
        {
            "base": {
                "specs": [BOTH], "detector": {"kind": "oracle"}, "frames": 64,
                "world": {"n_envs": 2}, "hyperparams": {"n_steps": 32, "batch_size": 32},
            },
            "rows": [{"name": "both"}],
        },
        name="doors",
    )  # fmt: skip
    scales["sweep trial"] = float(sweep.trials[0].config.bolt.reward_scale)  # type: ignore[arg-type]

    assert {door: round(scale, 9) for door, scale in scales.items()} == {
        door: round(exact, 9) for door in scales
    }


def test_resolving_is_idempotent_and_keeps_what_a_config_names() -> None:
    config = resolve(TrainConfig.build(TINY))
    assert resolve(config) is config  # a resolved config comes back unchanged
    named = TrainConfig.build({**TINY, "bolt.reward_scale": 7.0})
    assert named.reward_scale == 7.0 and resolve(named) is named
    paper = TrainConfig.build({**TINY, "bolt.reward": "paper"})
    assert paper.reward_scale is None and resolve(paper) is paper
    # Unresolved (a scale set back to None): resolve() gives what it gave before.
    again = config.override({"bolt.reward_scale": None})
    assert again.bolt.reward_scale is None and resolve(again) == config


def test_a_config_is_data_building_one_plays_no_world(monkeypatch: pytest.MonkeyPatch) -> None:
    def refuse(*args: Any, **kwargs: Any) -> None:
        raise AssertionError("a world was built")

    monkeypatch.setattr(resolution, "make_world", refuse)
    built = TrainConfig.build(TINY)  # validated whole, not resolved: no world built
    data = built.to_dict()
    config = TrainConfig.from_dict(data)
    assert config.bolt.reward_scale is None and config.bolt.specs == built.specs
    with pytest.raises(ConfigError, match=r"not resolved yet: noisybolt.runs.resolve\(config\)"):
        config.spec_objects()
    with pytest.raises(AssertionError, match="a world was built"):
        resolve(config)


def test_reproduce_is_resolved_without_playing_a_world(monkeypatch: pytest.MonkeyPatch) -> None:
    # Table 1 and case 4 pay the paper scheme: resolution has nothing to decide, so their
    # configs (and numbers) are what they were.
    from noisybolt.experiments.case4 import case4_sweep
    from noisybolt.experiments.table1 import table1_sweep

    def refuse(*args: Any, **kwargs: Any) -> None:
        raise AssertionError("resolution built a world")

    monkeypatch.setattr(resolution, "make_world", refuse)
    for sweep in (table1_sweep(seeds=1), case4_sweep(seeds=1)):
        for trial in sweep.trials:
            assert trial.config.bolt.reward == "paper" and trial.config.bolt.reward_scale is None
            assert resolve(trial.config) is trial.config


def test_a_resumed_run_keeps_the_scale_its_config_json_holds(tmp_path: Path) -> None:
    # A run paid the bound (as Python's train() paid before one resolver) resumes with it.
    run = tmp_path / "run"
    assert main(["train", *TINY_ARGV, "--reward-scale", "345.95", "--out", str(run)]) == 0
    assert main(["train", *TINY_ARGV, "--frames", "128", "--resume", "--out", str(run)]) == 0
    saved = json.loads((run / "config.json").read_text())
    assert saved["frames"] == 128 and saved["bolt"]["reward_scale"] == 345.95
    # From Python, the scale today's resolution gives differs: refused by name.
    with pytest.raises(ConfigError, match=r"bolt\.reward_scale: saved 345\.95"):
        train(TrainConfig.build({**TINY, "frames": 192}), run, resume=True, log=_quiet)


def test_settings_a_run_would_ignore_are_refused_by_the_schema() -> None:
    cases: list[tuple[dict[str, Any], str]] = [
        ({"bolt.confidence": 0.8}, r"bolt\.confidence 0\.8 \(--confidence\).*threshold"),
        ({"bolt.min_dwell": 1}, r"bolt\.min_dwell 1 \(--min-dwell\)"),
        ({"bolt.reward": "paper", "bolt.shaping": False}, "the paper scheme has none"),
    ]
    for given, message in cases:
        with pytest.raises(ConfigError, match=message):
            TrainConfig.build({**TINY, **given})
    belief = TrainConfig.build({**TINY, "bolt.tracking": "belief", "bolt.confidence": 0.8})
    assert belief.confidence == 0.8
    # The same rule where a resume gives settings again.
    with pytest.raises(ConfigError, match=r"bolt\.min_dwell 1 \(--min-dwell\)"):
        TrainConfig.resumed(TrainConfig.build(TINY).to_dict(), {"bolt.min_dwell": 1})


def _kept_configs() -> list[Path]:
    return sorted(RESULTS.rglob("config.json"))


SECTIONS = ("world", "bolt", "detector", "algorithm", "evaluation")


def _pruned(loaded: dict[str, Any], saved: dict[str, Any]) -> dict[str, Any]:
    """``loaded`` with only the settings ``saved`` holds (a setting added since is not in
    an older file)."""
    return {
        key: {k: loaded[key][k] for k in value} if key in SECTIONS else loaded[key]
        for key, value in saved.items()
    }


@pytest.mark.parametrize("path", _kept_configs(), ids=lambda p: str(p.relative_to(RESULTS)))
def test_every_kept_config_loads_resolves_and_round_trips(
    path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # The world suite's trials name the factories of benchmarks/unseen_worlds.py, which
    # their commands ran from: resolving them builds those worlds.
    monkeypatch.syspath_prepend(str(RESULTS.parent / "benchmarks"))
    text = path.read_text()
    saved = json.loads(text)
    config = TrainConfig.from_dict(saved)
    assert resolve(config) is config  # a saved config is resolved: nothing to decide again
    assert TrainConfig.from_dict(config.to_dict()) == config
    assert nested_config(config.to_dict()) == config.to_dict()
    if "schema" in saved:  # written back as saved, byte for byte
        written = _pruned(config.to_dict(), saved)
        assert json.dumps(written, indent=2, sort_keys=True) + "\n" == text


def test_the_kept_gridworld_runs_were_paid_what_resolution_computes_today() -> None:
    # noisybolt train's and the spec suite's runs (their scale computed on the product):
    # resolving them again from scratch gives the scale they hold, so they resume as kept.
    paid: dict[str, float] = {}
    for path in _kept_configs():
        config = TrainConfig.from_dict(json.loads(path.read_text()))
        if config.world_config.name != "gridworld" or config.bolt.reward == "paper":
            continue
        unresolved = config.override({"bolt.reward_scale": None})
        # What the scale depends on: the world's settings, the specs, the timing, gamma.
        key = json.dumps(
            [unresolved.world_settings, [s["formula"] for s in unresolved.bolt.specs]],
            sort_keys=True,
        )
        key += f" {unresolved.bolt.pay_on_change} {unresolved.algorithm.hyperparams.get('gamma')}"
        if key not in paid:  # resolved once for each
            paid[key] = float(resolve(unresolved).reward_scale)  # type: ignore[arg-type]
        assert paid[key] == pytest.approx(config.bolt.reward_scale, abs=1e-9), path
    assert len(paid) >= 20


def test_there_are_kept_configs_of_both_forms() -> None:
    kept = [json.loads(path.read_text()) for path in _kept_configs()]
    assert any("schema" in data for data in kept) and any("schema" not in data for data in kept)


@pytest.mark.parametrize("module", [product, gridworld_tabular, resolution])
def test_the_examples_run(module: Any) -> None:
    failures, _ = doctest.testmod(module, optionflags=doctest.ELLIPSIS)
    assert failures == 0
