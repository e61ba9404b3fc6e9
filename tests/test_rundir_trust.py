"""Runs you can trust (issue 14): each numbered item of the issue's "Why", as a new user hit it.

Every test here failed on commit 0e550d5 and passes since:

1. two writers into one run directory; a resume that loads another run's checkpoint;
2. ``--resume`` without a usable checkpoint retrained from zero;
3. bad input left config.json and command.txt behind, blocking the corrected command;
4. tracebacks (exit 1) instead of named errors (exit 2); ``report`` on corrupt files;
5. loading a run directory ran code from it (``tests/runs/test_safe_loading.py``);
6. the wrapper stack was assembled in two places (``make_env`` now owns it).

And valid runs are unchanged: a fixed-seed row of Table 1 gives the numbers it gave on
0e550d5.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from noisybolt.cli import main
from noisybolt.errors import ConfigError, CorruptFileError
from noisybolt.runs import DetectorConfig, TrainConfig, train


def _quiet(_: str) -> None:
    pass


def _config(**kwargs: object) -> TrainConfig:
    defaults: dict[str, object] = {
        "specs": ["edge"],
        "detector": DetectorConfig(kind="oracle"),
        "frames": 1024,
        "eval_freq": 512,
        "eval_episodes": 2,
        "checkpoint_freq": 512,
        "progress_bar": False,
        "overrides": {"n_steps": 64},
        "reward": "paper",  # the CLI and the API agree on its rewards (no computed scale)
    }
    defaults.update(kwargs)
    return TrainConfig.create(**defaults)  # type: ignore[arg-type]


def _train_argv(out: Path, *extra: str) -> list[str]:
    return [
        "train",
        "--spec",
        "edge",
        "--detector",
        "oracle",
        "--frames",
        "1024",
        "--eval-freq",
        "512",
        "--eval-episodes",
        "2",
        "--checkpoint-freq",
        "512",
        "--hp",
        "n_steps=64",
        "--reward",
        "paper",
        "--no-progress",
        "--out",
        str(out),
        *extra,
    ]


@pytest.fixture(scope="module")
def finished_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A finished tiny PPO run (1,024 frames, checkpoints every 512), copied per test."""
    run = tmp_path_factory.mktemp("trust") / "run"
    assert main(_train_argv(run)) == 0
    assert TrainConfig.from_dict(json.loads((run / "config.json").read_text())) == _config()
    return run


@pytest.fixture
def run_copy(finished_run: Path, tmp_path: Path) -> Path:
    import shutil

    target = tmp_path / "run"
    shutil.copytree(finished_run, target)
    return target


# ------------------------------------------------------------------ 1. two writers
def test_a_second_writer_is_refused_naming_the_holder(tmp_path: Path) -> None:
    from noisybolt.errors import RunLockedError

    run = tmp_path / "run"
    argv = [sys.executable, "-m", "noisybolt", *_train_argv(run)]
    argv[argv.index("1024")] = "10m"  # runs until killed
    proc = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    latest = run / "checkpoints" / "latest.json"
    try:
        while not latest.exists():
            assert proc.poll() is None, proc.stderr.read().decode() if proc.stderr else ""
            time.sleep(0.2)
        with pytest.raises(RunLockedError, match=rf"pid {proc.pid}\b") as info:
            train(_config(frames=100_000), run, resume=True, log=_quiet)
        assert "noisybolt train" in str(info.value)
    finally:
        proc.kill()
        proc.wait()
    # The holder is gone (its lock went with it): the run resumes.
    result = train(
        TrainConfig.from_dict({**json.loads((run / "config.json").read_text()), "frames": 2048}),
        run,
        resume=True,
        log=_quiet,
    )
    assert result.frames >= 2048


def test_resume_refuses_a_checkpoint_of_another_algorithm(run_copy: Path) -> None:
    # What two concurrent writers left on 0e550d5: the config of an A2C run beside the
    # checkpoints of a PPO run. Resuming loaded the PPO checkpoint as A2C.
    config = _config(algo="a2c", frames=2048, overrides={"n_steps": 64})
    (run_copy / "config.json").write_text(json.dumps(_config(algo="a2c").to_dict()))
    with pytest.raises(CorruptFileError, match="ppo"):
        train(config, run_copy, resume=True, log=_quiet)


# ------------------------------------------------------------------ 2. resume without checkpoint
@pytest.mark.parametrize("damage", ["no checkpoints folder", "latest names a missing model"])
def test_resume_without_a_usable_checkpoint_is_refused(run_copy: Path, damage: str) -> None:
    import shutil

    if damage == "no checkpoints folder":
        shutil.rmtree(run_copy / "checkpoints")
    else:
        latest = json.loads((run_copy / "checkpoints" / "latest.json").read_text())
        (run_copy / "checkpoints" / latest["folder"] / "model.zip").unlink()
    before = (run_copy / "model.zip").read_bytes(), (run_copy / "metrics.json").read_text()
    assert main(_train_argv(run_copy, "--frames", "2048", "--resume")) == 2
    assert ((run_copy / "model.zip").read_bytes(), (run_copy / "metrics.json").read_text()) == (
        before
    )


def test_restart_starts_a_run_over(run_copy: Path, capsys: pytest.CaptureFixture[str]) -> None:
    import shutil

    shutil.rmtree(run_copy / "checkpoints")
    assert main(_train_argv(run_copy, "--restart")) == 0
    metrics = json.loads((run_copy / "metrics.json").read_text())
    assert [m["frames"] for m in metrics] == [512, 1024]
    assert (run_copy / "checkpoints" / "latest.json").exists()


# ------------------------------------------------------------------ 3. nothing written on bad input
@pytest.mark.parametrize(
    "extra",
    [
        ["--hp", "learning_rate=abc"],
        ["--hp", "n_steps=0"],
        ["--n-envs", "0"],
        ["--spec", "edge"],  # a second --spec edge
        ["--hp", "gamma=2"],
    ],
    ids=["learning_rate=abc", "n_steps=0", "n_envs=0", "duplicate spec", "gamma=2"],
)
def test_bad_input_writes_nothing_and_exits_2(
    tmp_path: Path, extra: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "run"
    assert main(_train_argv(out, *extra)) == 2
    assert "error:" in capsys.readouterr().err
    assert not (out / "config.json").exists() and not (out / "command.txt").exists()
    if extra == ["--n-envs", "0"]:  # once: the corrected command is not blocked
        assert main(_train_argv(out, "--frames", "512", "--eval-freq", "0")) == 0


# ------------------------------------------------------------------ 4. named errors, exit 2
def _nested(depth: int) -> str:
    return "!(" * depth + "on_edge" + ")" * depth


@pytest.mark.parametrize(
    "extra",
    [
        ["--spec", _nested(250)],
        ["--seed", "-1"],
        ["--detector", "classifier", "--classifier", "does-not-exist.safetensors"],
    ],
    ids=["formula nested 250 deep", "seed -1", "missing classifier file"],
)
def test_bad_values_are_named_errors_with_exit_2(
    tmp_path: Path, extra: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "run"
    assert main(_train_argv(out, *extra)) == 2
    err = capsys.readouterr().err
    assert "error:" in err and "Traceback" not in err
    assert not (out / "config.json").exists()


def test_out_naming_a_file_is_a_named_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "a-file"
    out.write_text("mine")
    assert main(_train_argv(out)) == 2
    assert "a-file" in capsys.readouterr().err
    assert out.read_text() == "mine"


def _latest_folder(run: Path) -> Path:
    return (
        run
        / "checkpoints"
        / json.loads((run / "checkpoints" / "latest.json").read_text())["folder"]
    )


def _truncate(path: Path) -> None:
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])


@pytest.mark.parametrize("name", ["latest.json", "state.json", "model.zip", "vecnormalize"])
def test_resume_from_a_truncated_file_names_it(
    run_copy: Path, name: str, capsys: pytest.CaptureFixture[str]
) -> None:
    folder = _latest_folder(run_copy)
    if name == "latest.json":
        target = run_copy / "checkpoints" / "latest.json"
    elif name == "vecnormalize":
        (target,) = folder.glob("vecnormalize*")
    else:
        target = folder / name
    _truncate(target)
    assert main(_train_argv(run_copy, "--frames", "2048", "--resume")) == 2
    err = capsys.readouterr().err
    assert target.name in err and "Traceback" not in err


def test_evaluate_from_a_truncated_model_names_it(
    run_copy: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    _truncate(run_copy / "model.zip")
    assert main(["evaluate", str(run_copy), "--episodes", "2"]) == 2
    assert "model.zip" in capsys.readouterr().err


@pytest.mark.parametrize("name", ["summary.json", "metrics.json"])
def test_report_refuses_a_corrupt_file(
    run_copy: Path, name: str, capsys: pytest.CaptureFixture[str]
) -> None:
    _truncate(run_copy / name)
    assert main(["report", str(run_copy)]) == 2
    assert name in capsys.readouterr().err


def test_a_pointer_outside_the_run_directory_is_refused(run_copy: Path, tmp_path: Path) -> None:
    import shutil

    outside = tmp_path / "elsewhere"
    shutil.copytree(_latest_folder(run_copy), outside)
    latest = run_copy / "checkpoints" / "latest.json"
    data = json.loads(latest.read_text())
    latest.write_text(json.dumps({**data, "folder": "../../elsewhere"}))
    with pytest.raises(CorruptFileError, match="outside"):
        train(_config(frames=2048), run_copy, resume=True, log=_quiet)
    (run_copy / "model.zip").unlink()  # evaluate would fall back to the latest checkpoint
    with pytest.raises(CorruptFileError, match="outside"):
        from noisybolt.runs.run_evaluation import evaluate_run

        evaluate_run(run_copy, episodes=2)


# ------------------------------------------------------------------ 6. one wrapper stack
def test_make_env_owns_the_training_stack() -> None:
    from stable_baselines3.common.vec_env import VecNormalize

    from noisybolt.perception.detectors import OracleDetector
    from noisybolt.runs.environments import make_env
    from noisybolt.wrappers import BoltVecEnv

    config = _config(overrides={"n_steps": 64, "normalize_reward": True})
    from noisybolt.envs import make_world

    detector = OracleDetector(make_world(config.world_config.name, num_envs=1, seed=0).fluent_names)
    training_env = make_env(config, detector, training=True)
    assert isinstance(training_env, VecNormalize)
    assert training_env.num_envs == config.world_config.n_envs
    evaluation_env = make_env(config, detector, training=False, n_envs=2)
    assert isinstance(evaluation_env, BoltVecEnv) and evaluation_env.num_envs == 2
    with pytest.raises(TypeError, match="frozen"):
        config.bolt.thresholds["truth"] = 0.7  # type: ignore[index]


# ------------------------------------------------------------------ valid runs unchanged
def test_a_fixed_seed_table1_row_gives_the_numbers_it_gave_before(tmp_path: Path) -> None:
    # Recorded on 0e550d5 (before this changes) with this exact command.
    argv = [
        "reproduce",
        "table1",
        "--rows",
        "edge-ppo",
        "--seeds",
        "1",
        "--frames",
        "1024",
        "--detector",
        "oracle",
        "--eval-freq",
        "512",
        "--eval-episodes",
        "4",
        "--final-episodes",
        "8",
        "--out",
        str(tmp_path / "t1"),
    ]
    assert main(argv) == 0
    trial = tmp_path / "t1" / "trials" / "edge-ppo" / "seed-0"
    metrics = json.loads((trial / "metrics.json").read_text())
    assert [(m["frames"], m["env_return_mean"], m["length_mean"]) for m in metrics] == [
        (512, -118.375, 112.25),
        (1024, -62.25, 91.5),
    ]
    final = json.loads((trial / "evaluation.json").read_text())
    assert (final["env_return_mean"], final["length_mean"], final["goal_rate"]) == (
        -96.75,
        114.5,
        0.75,
    )
    assert final["compliance"] == {"edge": 0.125}
    assert not os.path.exists(trial / "vecnormalize.pkl")  # statistics are no pickle now


@pytest.mark.parametrize("name", ["noisybolt.io", "noisybolt.runs.rundir", "noisybolt.runs.config"])
def test_docstring_examples_run(name: str) -> None:
    import doctest
    import importlib

    result = doctest.testmod(importlib.import_module(name), optionflags=doctest.ELLIPSIS)
    assert result.attempted > 0 and result.failed == 0


@pytest.mark.parametrize(
    ("change", "path"),
    [
        ({"frames": "many"}, "frames"),
        ({"detector": {"kind": "oracle", "sampels": 10}}, "detector.sampels"),
        ({"detector": {"kind": "oracle", "samples": 1.5}}, "detector.samples"),
        ({"keep_best": 1}, "keep_best"),
        ({"colour": "red"}, "colour"),
    ],
)
def test_a_saved_config_is_read_strictly_naming_the_key(
    change: dict[str, object], path: str
) -> None:
    data = {**_config().to_dict(), **change}
    with pytest.raises(ConfigError, match=path.replace(".", r"\.")):
        TrainConfig.from_dict(data)


def test_a_sweep_trial_killed_before_its_first_checkpoint_starts_over(tmp_path: Path) -> None:
    # A trial whose directory holds config.json but no checkpoint has nothing to resume
    # (a resume is refused): the sweep starts it over instead.
    from noisybolt.experiments.sweeps.trials import TrialTask, run_trial
    from noisybolt.runs.rundir import RunDirectory

    config = _config(frames=512, eval_freq=0, checkpoint_freq=0)
    folder = tmp_path / "trial"
    RunDirectory(folder).write_config(config.to_dict())
    trial = {"id": "t", "group": "g", "row": "r", "seed": 0, "settings": {}}
    run_trial(TrialTask(trial={**trial, "config": config.to_dict()}, run_dir=str(folder)))
    assert json.loads((folder / "summary.json").read_text())["frames"] == 512
    assert [m["frames"] for m in json.loads((folder / "metrics.json").read_text())] == [512]


def test_each_start_records_the_software_it_ran_on(tmp_path: Path) -> None:
    from importlib import metadata

    from noisybolt.runs.rundir import RunDirectory

    run = RunDirectory(tmp_path / "run")
    run.path.mkdir()
    run.record_versions(frames=0)
    (run.path / "versions.json").write_text('{"half": ')  # torn by hand: started again
    run.record_versions(frames=0)
    run.record_versions(frames=2048)
    records = json.loads((run.path / "versions.json").read_text())
    assert [r["frames"] for r in records] == [0, 2048]
    assert records[0]["packages"]["torch"] == metadata.version("torch")
    assert records[0]["python"] == ".".join(map(str, sys.version_info[:3]))
