"""``noisybolt train``'s options are overrides of the run config schema: each flag stands
for one schema path (FLAG_PATHS), ``--set PATH=VALUE`` for any, and nothing else
describes a run."""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

import pytest

from noisybolt.cli import build_parser, main
from noisybolt.cli.train import FLAG_PATHS, train_overrides
from noisybolt.runs.config import TrainConfig, schema_paths

#: Options that do not describe the run (where it goes, what is resumed, files that
#: resolve into the schema's values).
NOT_SETTINGS = {
    "--out", "--resume", "--restart", "--retrain-classifier", "--specs-file", "--hp-file",
    "--set", "--spec-set", "--help", "--trust-code",
}  # fmt: skip
BASE = ["--spec", "edge", "--reward", "paper", "--detector", "oracle"]


def _train_parser() -> argparse.ArgumentParser:
    subparsers = next(
        a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction)
    )
    return subparsers.choices["train"]


def _config(*argv: str) -> TrainConfig:
    args = build_parser().parse_args(["train", *BASE, *argv])
    return TrainConfig.build(train_overrides(args), hp_file=args.hp_file)


def test_every_train_option_is_a_schema_path_or_says_why_not() -> None:
    paths = set(schema_paths())
    for action in _train_parser()._actions:
        for option in action.option_strings:
            if not option.startswith("--") or option in NOT_SETTINGS:
                continue
            assert option in FLAG_PATHS, f"{option} describes the run but maps to no path"
            path = FLAG_PATHS[option]
            assert action.dest == path or option == "--hp", option  # --hp KEY=VALUE
            assert path in paths or path.rsplit(".", 1)[0] in paths, (option, path)


def _at(config: TrainConfig, path: str) -> Any:
    node: Any = config.to_dict()
    for part in path.split("."):
        node = node.get(part)
    return node


@pytest.mark.parametrize(
    ("argv", "path", "value"),
    [
        (["--world", "breakout"], "world.name", None),
        (["--noise", "regional"], "world.kwargs.noise", "regional"),
        (["--obs-mode", "view"], "world.kwargs.obs_mode", "view"),
        (["--n-envs", "3"], "world.n_envs", 3),
        (["--spec", "avoid_top_right"], "bolt.specs", None),
        (["--reward", "compliance", "--reward-scale", "7"], "bolt.reward_scale", 7.0),
        (["--tracking", "belief"], "bolt.tracking", "belief"),
        # (the schema refuses a confidence that threshold tracking would ignore)
        (["--tracking", "belief", "--confidence", "0.95"], "bolt.confidence", 0.95),
        (["--cost-mode", "proportional"], "bolt.cost_mode", "proportional"),
        (["--unbolted"], "bolt.bolted", False),
        (["--classifier", "cls.st"], "detector.path", "cls.st"),
        (["--low-confidence", "on_edge"], "detector.low_confidence", ["on_edge"]),
        (["--algo", "a2c"], "algorithm.name", "a2c"),
        (["--hp", "gamma=0.9"], "algorithm.hyperparams.gamma", 0.9),
        (["--init-from", "runs/a"], "algorithm.init_from", "runs/a"),
        (["--frames", "5k"], "frames", 5000),
        (["--seed", "4"], "seed", 4),
        (["--seed", "4"], "detector.seed", 4),
        (["--eval-freq", "0"], "evaluation.freq", 0),
        (["--eval-episodes", "3"], "evaluation.episodes", 3),
        (["--checkpoint-freq", "2k"], "checkpoint_freq", 2000),
        (["--last-model"], "evaluation.keep_best", False),
        (["--reward", "constrained", "--cost-limit", "0.2"], "bolt.constraint.cost_limit", 0.2),
        (["--no-progress"], "progress_bar", False),
        (["--set", "evaluation.envs=8"], "evaluation.envs", 8),
        (["--set", "bolt.thresholds.high=0.95"], "bolt.thresholds.high", 0.95),
        (["--tracking", "belief", "--set", "bolt.tracking=threshold"], "bolt.tracking", None),
    ],
)
def test_each_flag_sets_its_schema_path(argv: list[str], path: str, value: Any) -> None:
    config = _config(*argv)
    default = _config()
    if path == "bolt.specs":
        assert [s["name"] for s in _at(config, path)] == ["edge", "avoid_top_right"]
    elif path == "world.name":
        assert config.world_config.name == "breakout" and config.world_config.fire_on_reset
    elif value is None:  # --set is applied after the flags
        assert _at(config, path) == "threshold"
    else:
        assert _at(config, path) == value != _at(default, path)


def test_the_flags_left_out_leave_the_schemas_defaults() -> None:
    config = _config()
    defaults = TrainConfig.build(
        {"bolt.specs": ["edge"], "bolt.reward": "paper", "detector.kind": "oracle"}
    )
    assert config == defaults


def test_a_bad_set_is_refused_by_path_and_leaves_nothing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "run"
    for argv, message in [
        (["--set", "evaluation.env=8"], "unknown config key evaluation.env"),
        (["--set", "evaluation.envs=many"], "evaluation.envs must be an integer"),
        (["--set", "evaluation.envs"], "is not of the form KEY=VALUE"),
        (["--hp", "gamma=2"], "gamma=2 is out of range"),
    ]:
        assert main(["train", *BASE, *argv, "--out", str(out)]) == 2
        assert message in capsys.readouterr().err
        assert not out.exists()


def test_a_run_saved_before_a_setting_existed_resumes_with_its_own_command(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # The Breakout runs were started before detector.restarts (default 3, one classifier
    # before it): their own command with --resume was refused as "saved 1, now 3".
    out = tmp_path / "run"
    command = [
        "train", *BASE, "--frames", "64", "--eval-freq", "0", "--eval-episodes", "1",
        "--set", "world.n_envs=2", "--no-progress", "--out", str(out),
    ]  # fmt: skip
    assert main(command) == 0
    saved = json.loads((out / "config.json").read_text())
    assert saved["detector"].pop("restarts") == 3
    (out / "config.json").write_text(json.dumps(saved))
    capsys.readouterr()
    assert main([*command, "--frames", "128", "--resume"]) == 0
    assert json.loads((out / "config.json").read_text())["detector"]["restarts"] == 1
    # a setting given on the command line is the user's, and a different one is refused
    assert main([*command, "--frames", "192", "--resume", "--set", "detector.restarts=3"]) == 2
    assert "detector.restarts: saved 1, now 3" in capsys.readouterr().err


def test_a_resume_takes_every_setting_it_is_not_given_from_the_run(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "run"
    started = [
        "train", "--spec", "edge", "--spec", "F(top_right_corner)", "--reward", "paper",
        "--detector", "oracle", "--algo", "a2c", "--seed", "3", "--frames", "64",
        "--eval-freq", "32", "--eval-episodes", "1", "--set", "world.n_envs=2",
        "--no-progress", "--out", str(out),
    ]  # fmt: skip
    assert main(started) == 0
    first = json.loads((out / "config.json").read_text())
    capsys.readouterr()
    # only where the run is and how far to go: specs, algorithm, seed, evaluation kept
    assert main(["train", "--out", str(out), "--frames", "128", "--resume", "--no-progress"]) == 0
    again = json.loads((out / "config.json").read_text())
    assert again == {**first, "frames": 128}
    # a resume to as many frames as the run has trained would train nothing: refused,
    # and config.json keeps its target
    assert main(["train", "--out", str(out), "--frames", "100", "--resume"]) == 2
    err = capsys.readouterr().err
    trained = json.loads((out / "checkpoints" / "latest.json").read_text())["frames"]
    assert trained >= 128  # whole rollouts: A2C's 2 envs x 5 steps pass 128 at 130
    assert f"it has trained {trained} already" in err and "noisybolt evaluate" in err
    assert json.loads((out / "config.json").read_text())["frames"] == 128
    # its own target resumes though it lies below the frames trained: a run interrupted
    # past its last rollout (a sweep's trial) is finished, its summary written again
    # (as if stopped before its final evaluation: the checkpoint's history lacks it)
    (out / "summary.json").unlink()
    latest = json.loads((out / "checkpoints" / "latest.json").read_text())["folder"]
    state_path = out / "checkpoints" / latest / "state.json"
    state = json.loads(state_path.read_text())
    assert state["history"][-1]["frames"] == trained
    state_path.write_text(json.dumps({**state, "history": state["history"][:-1]}))
    assert main(["train", "--out", str(out), "--resume", "--no-progress"]) == 0
    assert json.loads((out / "summary.json").read_text())["frames"] == trained
    assert json.loads((out / "metrics.json").read_text())[-1]["frames"] == trained
    # a setting given with another value is still refused, by name
    assert main(["train", "--out", str(out), "--frames", "192", "--resume", "--algo", "ppo"]) == 2
    assert "algorithm.name: saved 'a2c', now 'ppo'" in capsys.readouterr().err


def test_specs_may_come_from_a_file_alone_and_none_at_all_is_a_clear_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    specs = tmp_path / "specs.yaml"
    specs.write_text("- edge\n- formula: F(top_right_corner)\n  name: tr\n")
    out = tmp_path / "run"
    argv = ["--detector", "oracle", "--frames", "64", "--eval-freq", "0", "--eval-episodes", "1"]
    argv += ["--set", "world.n_envs=2", "--no-progress"]
    assert main(["train", "--specs-file", str(specs), *argv, "--out", str(out)]) == 0
    names = [s["name"] for s in json.loads((out / "config.json").read_text())["bolt"]["specs"]]
    assert names == ["edge", "tr"]
    assert main(["train", *argv, "--out", str(tmp_path / "none")]) == 2
    assert "give at least one --spec" in capsys.readouterr().err
    assert not (tmp_path / "none").exists()


def test_options_the_run_would_ignore_are_refused_and_fluents_named(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    base = ["train", "--spec", "edge", "--frames", "64", "--set", "world.n_envs=2"]
    for argv, message in [
        (["--detector", "oracle", "--low-confidence", "on_edge"], "the oracle detector would"),
        (["--detector", "synthetic", "--low-confidence", "on_egde"], "names ['on_egde']"),
        # the other options a setting of another kind would ignore
        (["--detector", "synthetic", "--classifier", "c.safetensors"], "the synthetic detector"),
        (["--detector", "oracle", "--confidence", "0.8"], "with threshold tracking it would"),
        (["--detector", "oracle", "--min-dwell", "1"], "with threshold tracking it would"),
        (["--detector", "oracle", "--reward", "paper", "--no-shaping"], "the paper scheme has"),
    ]:
        out = tmp_path / "-".join(argv)
        assert main([*base, *argv, "--out", str(out)]) == 2
        err = capsys.readouterr().err
        assert message in err and argv[2] in err
        assert not out.exists()


def test_the_scheme_line_follows_the_checks(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # How the bolt pays is said once the run can start: not above an unrelated error.
    base = ["train", "--detector", "oracle", "--frames", "64", "--eval-freq", "0"]
    base += ["--eval-episodes", "1", "--set", "world.n_envs=2", "--no-progress"]
    bad = ["--spec", "F(lava)", "--reward", "paper", "--out", str(tmp_path / "bad")]
    assert main([*base, *bad]) == 2
    printed = capsys.readouterr()
    assert "'lava'" in printed.err and "reward scheme" not in printed.out
    assert main([*base, "--spec", "edge", "--reward", "paper", "--out", str(tmp_path / "ok")]) == 0
    assert "reward scheme: paper (each spec's terminal reward" in capsys.readouterr().out
    assert main([*base, "--spec", "edge", "--unbolted", "--out", str(tmp_path / "off")]) == 0
    assert "unbolted: the specs are tracked for compliance only" in capsys.readouterr().out


def test_min_dwell_reaches_the_belief_bolt(tmp_path: Path) -> None:
    from noisybolt.runs import TrainConfig
    from noisybolt.runs.environments import prepare_bolt

    argv = ["train", "--spec", "edge", "--detector", "oracle", "--tracking", "belief"]
    argv += ["--min-dwell", "1", "--frames", "64", "--eval-freq", "0", "--eval-episodes", "1"]
    out = tmp_path / "run"
    assert main([*argv, "--set", "world.n_envs=2", "--no-progress", "--out", str(out)]) == 0
    saved = json.loads((out / "config.json").read_text())
    assert saved["bolt"]["min_dwell"] == 1
    setup = prepare_bolt(TrainConfig.from_dict(saved), seed=0, log=lambda _: None)
    assert setup.belief is not None and setup.belief.min_dwell == 1  # through the EM too
    assert main([*argv, "--min-dwell", "0", "--out", str(tmp_path / "bad")]) == 2  # the last
    assert not (tmp_path / "bad").exists()


def test_a_belief_run_is_recorded_and_drawn_with_its_own_bolt(
    tmp_path: Path, recwarn: pytest.WarningsRecorder
) -> None:
    # The recording's policy sees beliefs, as in training (it crashed on the DFA states'
    # shape), and loading the model warns of no missing base rates (the run has them).
    from noisybolt.errors import UnknownBaseRatesWarning

    out = tmp_path / "run"
    argv = ["train", "--spec", "edge", "--detector", "oracle", "--tracking", "belief"]
    argv += ["--frames", "64", "--eval-freq", "0", "--eval-episodes", "1", "--no-progress"]
    assert main([*argv, "--set", "world.n_envs=2", "--out", str(out)]) == 0
    gif, heatmap = tmp_path / "b.gif", tmp_path / "h.png"
    evaluate = ["evaluate", str(out), "--episodes", "2", "--gif", str(gif)]
    assert main([*evaluate, "--heatmap", str(heatmap)]) == 0
    assert gif.stat().st_size > 0 and heatmap.stat().st_size > 0
    assert not [w for w in recwarn if w.category is UnknownBaseRatesWarning]


def test_a_threshold_run_is_evaluated_under_belief_tracking_beside_its_own(
    tmp_path: Path,
) -> None:
    out = tmp_path / "run"
    argv = ["train", "--spec", "edge", "--detector", "oracle", "--frames", "64"]
    argv += ["--eval-freq", "0", "--eval-episodes", "1", "--no-progress"]
    assert main([*argv, "--set", "world.n_envs=2", "--out", str(out)]) == 0
    assert main(["evaluate", str(out), "--episodes", "2", "--tracking", "belief"]) == 0
    (written,) = out.glob("evaluation-*.json")
    record = json.loads(written.read_text())
    assert record["overrides"] == {"bolt.tracking": "belief"}
    assert not (out / "evaluation.json").exists()  # the run's own is not overwritten
    with pytest.raises(SystemExit):
        main(["evaluate", str(out), "--tracking", "beleif"])
