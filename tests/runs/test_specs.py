"""Built-in specs, spec groups, and Breakout's per-brick milestones paid by a real bolt."""

from __future__ import annotations

import numpy as np
import pytest

from noisybolt.errors import UnknownFluentError
from noisybolt.runs import TrainConfig
from noisybolt.runs.resolution import resolve
from noisybolt.runs.specs import SPEC_GROUPS, expand_specs, resolve_spec


def test_groups_expand_in_place_and_leave_the_rest() -> None:
    mapping = {"formula": "F(a)"}
    out = expand_specs(["edge", " left_column_milestones ", "G(x)", mapping])
    assert out == [
        "edge",
        "clear_left_column",
        *(f"left_row{r}" for r in (5, 4, 3, 2, 1, 0)),
        "G(x)",
        mapping,
    ]
    assert expand_specs([]) == []


def test_milestone_specs_pay_once_per_brick() -> None:
    spec = resolve_spec("left_row3")
    assert (spec.formula, spec.name) == ("F(left_gone_row3)", "left_row3")
    assert (spec.reward_timing, spec.terminal_reward, spec.low_confidence_cost) == (
        "on_entry",
        1.0,
        0.5,
    )
    assert resolve_spec("clear_left_column").reward_timing == "every_step"  # the paper's


def test_a_group_names_breakout_specs_in_a_training_config() -> None:
    config = resolve(TrainConfig.create(world="breakout", specs=["left_column_milestones"]))
    assert [s.name for s in config.spec_objects()] == list(SPEC_GROUPS["left_column_milestones"])


def test_milestones_need_the_per_brick_fluents() -> None:
    from noisybolt.envs import make_world
    from noisybolt.logic import compile_ltlf

    world = make_world("breakout", num_envs=1, seed=0, fluents=["brick_clear_left"])
    with pytest.raises(UnknownFluentError, match="left_gone_row2"):
        compile_ltlf(resolve_spec("left_row2").formula, world.fluent_names)


def test_knocking_out_a_left_brick_pays_its_milestone_once() -> None:
    from stable_baselines3.common.vec_env import VecMonitor

    from noisybolt.envs import SB3VecEnv, make_world
    from noisybolt.envs.breakout import BRICK_COLUMNS, BRICK_ROWS, set_bricks
    from noisybolt.perception.detectors import OracleDetector
    from noisybolt.wrappers import BoltVecEnv

    world = make_world("breakout", num_envs=1, seed=0, noop_max=0, repeat_action_probability=0)
    specs = [resolve_spec(s) for s in expand_specs(["left_column_milestones"])]
    env = BoltVecEnv(
        VecMonitor(SB3VecEnv(world)),  # type: ignore[arg-type]
        specs,
        OracleDetector(world.fluent_names),
        world=world,
    )
    env.reset()
    noop = np.zeros(1, dtype=np.int64)
    for _ in range(12):  # past the frames in which the game rebuilds its wall
        _, reward, *_ = env.step(noop)
        assert reward[0] == 0.0
    wall = np.ones((BRICK_ROWS, BRICK_COLUMNS), dtype=bool)
    wall[5, 0] = False  # the bottom brick of the left column
    set_bricks(world._ales[0], wall)
    _, reward, _, infos = env.step(noop)
    paid = dict(zip([s.name for s in specs], infos[0]["bolt_terminal"], strict=True))
    assert paid == {s.name: (1.0 if s.name == "left_row5" else 0.0) for s in specs}
    assert reward[0] == 1.0  # no game points: the brick was removed, not hit
    _, reward, _, infos = env.step(noop)
    assert reward[0] == 0.0 and not infos[0]["bolt_terminal"].any()
    names = [s.name for s in specs]
    assert infos[0]["true_accepting"][names.index("left_row5")]
    assert not infos[0]["true_accepting"][names.index("clear_left_column")]
