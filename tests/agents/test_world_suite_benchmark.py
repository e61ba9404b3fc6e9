"""benchmarks/world_suite.py: the "task kept" accounting, each bolted trial against the
unbolted control of its own seed."""

from __future__ import annotations

import argparse
from collections.abc import Callable
from pathlib import Path
from types import ModuleType

import pytest


@pytest.fixture(scope="module")
def suite(load_script: Callable[..., ModuleType]) -> ModuleType:
    return load_script("benchmarks/world_suite.py")


def _record(world: str, seed: int, *, bolted: bool, compliance: float, goal, ret: float) -> dict:
    return {
        "world": world, "spec": "s" if bolted else None, "algo": "ppo", "seed": seed,
        "bolted": bolted, "compliance": compliance, "goal_rate": goal, "env_return": ret,
    }  # fmt: skip


def test_each_bolted_trial_is_judged_against_its_own_seeds_control(suite: ModuleType) -> None:
    records = [
        # lake seed 0: the control reaches the goal; the bolted agent complies and does too
        _record("lake", 0, bolted=False, compliance=0.0, goal=1.0, ret=1.0),
        _record("lake", 0, bolted=True, compliance=1.0, goal=0.95, ret=0.95),
        # lake seed 1: the control fails the task: not counted, whatever the bolted agent does
        _record("lake", 1, bolted=False, compliance=0.0, goal=0.5, ret=0.5),
        _record("lake", 1, bolted=True, compliance=1.0, goal=0.0, ret=0.0),
        # room seed 0: complies but stands still (goal 0): counted, not kept
        _record("room", 0, bolted=False, compliance=1.0, goal=1.0, ret=0.9),
        _record("room", 0, bolted=True, compliance=1.0, goal=0.0, ret=0.0),
        # acrobot: a return task above the floor -500: -140 keeps 90 % of -100's 400
        _record("acrobot", 0, bolted=False, compliance=0.0, goal=None, ret=-100.0),
        _record("acrobot", 0, bolted=True, compliance=1.0, goal=None, ret=-140.0),
        _record("acrobot", 0, bolted=True, compliance=1.0, goal=None, ret=-141.0),
        # a bolted trial with no control of its seed is not counted
        _record("room", 5, bolted=True, compliance=1.0, goal=1.0, ret=1.0),
    ]
    kept, counted, per_world = suite.task_kept(records, 0.95)
    assert (kept, counted) == (2, 4)
    assert per_world == {"lake": (1, 1), "room": (0, 1), "acrobot": (1, 2)}


def test_a_trial_that_does_the_task_but_breaks_the_spec_is_not_kept(suite: ModuleType) -> None:
    records = [
        _record("lake", 0, bolted=False, compliance=0.0, goal=1.0, ret=1.0),
        _record("lake", 0, bolted=True, compliance=0.9, goal=1.0, ret=1.0),
    ]
    assert suite.task_kept(records, 0.95)[:2] == (0, 1)


@pytest.mark.slow
def test_a_slice_of_the_suite_a_constrained_agent_keeps_the_rooms_task_and_its_detour(
    suite: ModuleType, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """One trial of the world suite as it is measured (PPO, the built-in defaults, the
    synthetic detector, 150k frames, seed 0): in MiniGrid's empty room the bolt asks for
    the bottom-left corner first. Under the constrained scheme the agent complies and
    still reaches the goal, as its unbolted control does (measured: 100 % and 100 %; at the
    multiplier's earlier rate of 0.02 a 1,000 frames it settled on the direct route and
    complied in 0 %)."""
    monkeypatch.chdir(tmp_path)  # run_trial moves to benchmarks/: the test's cwd comes back
    suite._load_worlds()
    args = argparse.Namespace(
        out=str(tmp_path), collect=False, detector="synthetic", frames=150_000,
        eval_freq=10_000, eval_episodes=20, hp=[], set=["bolt.reward=constrained"],
    )  # fmt: skip
    record = suite.run_trial("unseen_worlds:room", "F(bottom_left)", "ppo", 0, args)
    assert record["compliance"] >= 0.95
    assert record["goal_rate"] >= 0.9


def test_layered_folders_read_each_trial_from_the_last_layer_that_holds_it(
    load_script: Callable[..., ModuleType], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    root = Path(__file__).resolve().parents[2]
    monkeypatch.syspath_prepend(str(root / "benchmarks"))
    compare = load_script("benchmarks/world_suite_compare.py")
    compare.ws._load_worlds()
    trial = Path("room/a2c/spec1/seed2")  # re-run in the window's round: 100 % compliant
    older, newer = tmp_path / "older", tmp_path / "newer"
    for layer, source in ((older, "defaults/constrained"), (newer, "window")):
        (layer / trial).mkdir(parents=True)
        for name in ("summary.json", "config.json"):
            (layer / trial / name).write_bytes(
                (root / "results/world_suite" / source / trial / name).read_bytes()
            )
    world, spec = "unseen_worlds:room", "!right_col U bottom_left"
    first = compare._record([older], world, spec, "a2c", 2)
    layered = compare._record([older, newer], world, spec, "a2c", 2)
    assert (first["compliance"], layered["compliance"]) == (0.5, 1.0)
    # a trial no later layer holds comes from the earlier one; none at all: None
    assert compare._record([newer, older], world, spec, "a2c", 2)["compliance"] == 0.5
    assert compare._record([older, newer], world, spec, "a2c", 1) is None
