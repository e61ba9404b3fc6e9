"""Worlds by factory path: ``noisybolt train --world MODULE:FACTORY``, evaluated in a new
process from what config.json recorded; bad paths refused before anything is written."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
import yaml

from noisybolt.agents.hyperparams import load_hyperparams
from noisybolt.cli import build_parser, main
from noisybolt.envs import check_world, make_single_world, make_world
from noisybolt.errors import ConfigError, UnknownNameError, WorldFactoryError

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
WORLD = "frozenlake:make_lake"

BAD_WORLDS = """
import gymnasium as gym

def plain():
    return gym.make("FrozenLake-v1")

def vector():
    return gym.make_vec("FrozenLake-v1", num_envs=2)

def broken():
    return gym.make("NoSuchEnv-v0")

NOT_A_FUNCTION = 3
"""


def _reward_args() -> list[str]:
    # A user world declares no return bounds: pay the paper's rewards where schemes exist.
    help_text = build_parser().format_help() + _train_help()
    return ["--reward", "paper"] if "--reward " in help_text else []


def _train_help() -> str:
    parser = build_parser()
    for action in parser._subparsers._group_actions:  # type: ignore[union-attr]
        train = action.choices.get("train")  # type: ignore[union-attr]
        if train is not None:
            return str(train.format_help())
    return ""


@pytest.fixture
def in_examples(monkeypatch: pytest.MonkeyPatch) -> None:
    # As a user would run it: from the folder holding the module, not on sys.path.
    monkeypatch.chdir(EXAMPLES)
    monkeypatch.setattr(sys, "path", [p for p in sys.path if p not in ("", str(EXAMPLES))])
    monkeypatch.delitem(sys.modules, "frozenlake", raising=False)


def test_a_factory_world_is_built_from_its_path(in_examples: None) -> None:
    check_world(WORLD)
    world = make_world(WORLD, num_envs=3, seed=4)
    world.reset()
    assert world.fluent_names == ("top_row", "at_goal")
    assert world.true_fluents().tolist() == [[True, False]] * 3
    assert world.camera_spec.shape == (256, 256, 3)
    single = make_single_world(WORLD)
    assert single.reset(seed=0)[1]["true_fluents"].tolist() == [True, False]
    with pytest.raises(ConfigError, match="takes no setting 'noise' \\(give the factory a noise"):
        make_world(WORLD, num_envs=1, noise="gaussian:sigma=5")


PARAMETRISED = """
import gymnasium as gym
import noisybolt


def make(top=4, noise="none"):
    env = gym.make("FrozenLake-v1", render_mode="rgb_array", is_slippery=False)
    fluents = {"far": lambda e: e.unwrapped.s >= top}
    return noisybolt.FluentLabels(env, fluents=fluents, noise=noise, return_bounds=(0, 1))
"""


def test_a_factory_takes_the_world_settings_it_names_as_keywords(
    world_module: Any, tmp_path: Path
) -> None:
    world_module("paramlake", PARAMETRISED)
    far = lambda **settings: make_world("paramlake:make", num_envs=1, seed=0, **settings)  # noqa: E731
    for settings, expected in (({}, False), ({"top": 0}, True)):
        world = far(**settings)
        world.reset(seed=0)
        assert world.true_fluents().tolist() == [[expected]]
    assert far(noise="gaussian:sigma=5").camera_spec.noise != far().camera_spec.noise
    with pytest.raises(ConfigError, match=r"no setting 'size'; it takes \['top', 'noise'\]"):
        far(size=3)
    # From the command line: --set world.kwargs.top=0, recorded, so resume rebuilds it.
    out = tmp_path / "run"
    argv = ["train", "--world", "paramlake:make", "--spec", "F(far)", "--detector", "oracle"]
    argv += ["--set", "world.kwargs.top=0", "--frames", "64", "--eval-freq", "0"]
    argv += ["--n-envs", "2", "--hp", "n_steps=32"]  # one rollout within the 64 frames
    assert main([*argv, "--eval-episodes", "1", "--no-progress", "--out", str(out)]) == 0
    assert json.loads((out / "config.json").read_text())["world"]["kwargs"] == {"top": 0}
    summary = json.loads((out / "summary.json").read_text())
    assert summary["final"]["compliance"]["F(far)"] == 1.0  # far from the start, by top=0


def test_a_factory_world_without_its_own_file_gets_the_documented_defaults() -> None:
    files = Path(__file__).resolve().parents[2] / "src/noisybolt/configs/hyperparams"
    defaults = yaml.safe_load((files / "_default.yaml").read_text())
    for algo in ("ppo", "a2c", "dqn"):
        assert load_hyperparams(WORLD, algo) == defaults[algo]
    with pytest.raises(UnknownNameError, match="built-in worlds are"):
        load_hyperparams("lake", "ppo")  # a plain name still has to be registered


def test_an_hp_file_replaces_the_builtin_table(tmp_path: Path) -> None:
    path = tmp_path / "mine.yaml"
    path.write_text("ppo:\n  n_envs: 2\n  n_steps: 16\n")
    assert load_hyperparams("gridworld", "ppo", {"n_epochs": 3}, hp_file=path) == {
        "n_envs": 2,
        "n_steps": 16,
        "n_epochs": 3,
    }
    with pytest.raises(ConfigError, match="needs an entry 'dqn'"):
        load_hyperparams("gridworld", "dqn", hp_file=path)
    path.write_text("ppo:\n  warp_speed: 9\n")
    with pytest.raises(ConfigError, match="warp_speed"):
        load_hyperparams("gridworld", "ppo", hp_file=path)


@pytest.mark.parametrize(
    ("world", "message"),
    [
        ("no_such_module:make", "importing no_such_module failed"),
        ("badworlds:missing", "has no function 'missing'"),
        ("badworlds:NOT_A_FUNCTION", "has no function 'NOT_A_FUNCTION'"),
        ("badworlds:plain", "without labels; return noisybolt.FluentLabels"),
        ("badworlds:vector", "must return one Gymnasium env"),
        ("badworlds:broken", "the factory raised NameNotFound"),
        ("badworlds:", "'package.module:factory'"),
    ],
)
def test_bad_factory_paths_are_named_before_anything_is_written(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    world: str,
    message: str,
) -> None:
    (tmp_path / "badworlds.py").write_text(BAD_WORLDS)
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(sys, "path", list(sys.path))  # the import adds the folder to it
    monkeypatch.delitem(sys.modules, "badworlds", raising=False)
    out = tmp_path / "run"
    argv = ["train", "--world", world, "--spec", "F(a)", "--frames", "64", "--out", str(out)]
    assert main([*argv, *_reward_args()]) == 2
    assert message in capsys.readouterr().err
    assert not out.exists()
    with pytest.raises(WorldFactoryError):
        make_world(world, num_envs=1)


def test_train_then_evaluate_in_a_new_process(
    in_examples: None, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "run"
    argv = ["train", "--world", WORLD, "--spec", "X(G(!top_row))", "--frames", "256"]
    argv += ["--detector", "oracle"]
    argv += ["--n-envs", "2", "--hp", "n_steps=64", "--hp", "batch_size=64"]
    argv += ["--eval-freq", "0", "--eval-episodes", "2", "--no-progress", "--out", str(out)]
    assert main([*argv, *_reward_args()]) == 0, capsys.readouterr().err
    config = json.loads((out / "config.json").read_text())
    assert config["world"]["name"] == WORLD
    assert config["world"]["n_envs"] == 2
    assert config["algorithm"]["hyperparams"]["gamma"] == 0.99  # from _default.yaml
    evaluated = subprocess.run(
        [
            sys.executable,
            "-m",
            "noisybolt",
            "evaluate",
            str(out),
            "--episodes",
            "3",
            "--trust-code",
        ],
        cwd=EXAMPLES,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert evaluated.returncode == 0, evaluated.stderr
    record = json.loads((out / "evaluation.json").read_text())
    assert record["n_episodes"] == 3
    assert 0.0 <= record["goal_rate"] <= 1.0
    gif = tmp_path / "episode.gif"
    again = ["--world", WORLD]  # the run's world given again: the user vouches for it
    assert main(["evaluate", str(out), "--episodes", "1", "--gif", str(gif), *again]) == 0
    assert gif.stat().st_size > 0  # the env's render beside the bolt's camera
    heatmap = tmp_path / "heatmap.png"
    assert main(["evaluate", str(out), "--episodes", "2", "--heatmap", str(heatmap), *again]) == 0
    assert heatmap.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"  # the lake's 4x4 cells, drawn


UNGRIDDED = """
import gymnasium as gym
import noisybolt

def lake():
    env = gym.make("FrozenLake-v1", render_mode="rgb_array", is_slippery=False)
    return noisybolt.FluentLabels(env, fluents={"top_row": lambda e: e.s < 4})
"""


def test_heatmap_of_a_world_without_a_grid_is_refused_with_how_to_declare_one(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "ungridded.py").write_text(UNGRIDDED)
    monkeypatch.chdir(tmp_path)
    monkeypatch.delitem(sys.modules, "ungridded", raising=False)
    out = tmp_path / "run"
    argv = ["train", "--world", "ungridded:lake", "--spec", "G(!top_row)", "--frames", "128"]
    argv += ["--detector", "oracle", "--n-envs", "2", "--hp", "n_steps=64"]
    argv += ["--hp", "batch_size=64", "--eval-freq", "0", "--no-progress", "--out", str(out)]
    assert main([*argv, *_reward_args()]) == 0, capsys.readouterr().err
    capsys.readouterr()
    heatmap = tmp_path / "heatmap.png"
    evaluate = ["evaluate", str(out), "--episodes", "1", "--heatmap", str(heatmap)]
    assert main([*evaluate, "--trust-code"]) == 2
    err = capsys.readouterr().err
    assert "declares no grid" in err and "GridLayout" in err
    assert not heatmap.exists()
