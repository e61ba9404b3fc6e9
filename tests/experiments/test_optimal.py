"""Exact R^c_max: hand-computed optima, replays in the real env, and brute force.

The 6x6 room (4x4 floor): start (1, 1) facing east, goal (4, 4), top-right corner
t = (4, 1), bottom-left corner b = (1, 4); every step pays -1.5, entering the goal +100.
"""

from __future__ import annotations

import copy
import doctest
from pathlib import Path

import numpy as np
import pytest

import noisybolt.experiments as experiments
from noisybolt.bolt import Spec
from noisybolt.envs.gridworld import GRIDWORLD_FLUENTS, GridAction, GridworldEnv
from noisybolt.errors import ConfigError, SpecSyntaxError, UnknownFluentError
from noisybolt.experiments import optimal
from noisybolt.experiments.optimal import (
    OptimalResult,
    SpecOptimum,
    format_optima_table,
    optimal_constrained_return,
    optimal_unconstrained_return,
)
from noisybolt.logic import DFA, compile_ltlf, masks_from_bool_matrix

T, B = "top_right_corner", "bottom_left_corner"
TOP_RIGHT, BOTTOM_LEFT, GOAL = (4, 1), (1, 4), (4, 4)
STEP, GOAL_REWARD, LIMIT = -1.5, 100.0, 4 * 6**2
ONCE_T = f"F({T} & X(!F({T})))"
EXCLUSIVE = f"(F({T} & X(!F({T}))) & !F({B})) | (F({B} & X(!F({B}))) & !F({T}))"
F, L, R, N = GridAction.FORWARD, GridAction.LEFT, GridAction.RIGHT, GridAction.NOOP


@pytest.fixture(autouse=True)
def private_cache(
    tmp_path_factory: pytest.TempPathFactory, monkeypatch: pytest.MonkeyPatch
) -> Path:
    """Compiled DFAs go to a temporary cache, never ~/.cache."""
    directory = tmp_path_factory.getbasetemp() / "dfa-cache"
    monkeypatch.setenv("NOISYBOLT_CACHE_DIR", str(directory))
    return directory


def goal_return(n_steps: int) -> float:
    """The env's return of an episode entering the goal on step ``n_steps``."""
    return n_steps * STEP + GOAL_REWARD


# ------------------------------------------------------------------ hand-computed optima


def test_unconstrained_is_the_shortest_path() -> None:
    # 3 forward, turn right, 3 forward: 7 steps.
    result = optimal_unconstrained_return()
    assert result.value == goal_return(7) == 89.5
    assert result.steps == 7
    assert result.actions == (F, F, F, R, F, F, F)
    assert result.path == ((1, 1), (2, 1), (3, 1), TOP_RIGHT, (4, 2), (4, 3), GOAL)
    assert len(result.states) == 8
    assert result.states[0] == (1, 1, 0) and result.states[-1][:2] == GOAL
    assert result.reaches_goal and result.feasible
    assert result.step_limit == LIMIT and result.formulas == ()


def test_avoiding_the_top_right_corner_costs_one_turn() -> None:
    # Turn right, 3 forward, turn left, 3 forward: 8 steps (6 moves need 2 turns
    # unless the path runs east then south, which passes the corner).
    result = optimal_constrained_return([f"!F({T})"])
    assert result.value == goal_return(8) == 88.0
    assert result.steps == 8
    assert TOP_RIGHT not in result.path
    assert result.path[-1] == GOAL


def test_always_on_edge_is_free_in_an_empty_room() -> None:
    # The shortest path runs along the top and right walls: every cell is on the edge.
    result = optimal_constrained_return(["G(on_edge)"])
    assert result.value == goal_return(7)
    assert all(x in (1, 4) or y in (1, 4) for x, y in result.path)


def test_top_right_once_is_met_by_the_shortest_path() -> None:
    # F(t & X(!F(t))): t is visited and the trace goes on past its last visit; the
    # shortest path turns on t (two steps there) and leaves it for the goal.
    result = optimal_constrained_return([ONCE_T])
    assert result.value == goal_return(7)
    assert TOP_RIGHT in result.path


def test_exclusive_corner_spec_goes_via_the_top_right_corner() -> None:
    result = optimal_constrained_return([EXCLUSIVE])
    assert result.value == goal_return(7)
    assert TOP_RIGHT in result.path and BOTTOM_LEFT not in result.path


def test_exclusive_corner_spec_without_the_top_right_goes_via_the_bottom_left() -> None:
    result = optimal_constrained_return([EXCLUSIVE, f"!F({T})"])
    assert result.value == goal_return(8)
    assert BOTTOM_LEFT in result.path and TOP_RIGHT not in result.path


def test_several_specs_must_all_hold() -> None:
    # On the edge and never on t: down the left wall and along the bottom one.
    result = optimal_constrained_return(["G(on_edge)", f"!F({T})"])
    assert result.value == goal_return(8)
    assert result.actions == (R, F, F, F, L, F, F, F)
    assert result.path == ((1, 1), (1, 2), (1, 3), BOTTOM_LEFT, (2, 4), (3, 4), GOAL)


def test_the_trace_starts_at_reset() -> None:
    # The DFAs read the start state (facing east) before the first action.
    assert not optimal_constrained_return(["!facing_right"]).feasible
    result = optimal_constrained_return(["facing_right & X(facing_down)"])
    assert result.actions[0] == R and result.value == goal_return(8)


def test_impossible_spec_has_no_compliant_episode() -> None:
    result = optimal_constrained_return([f"G({T})"])  # the start is not t
    assert not result.feasible
    assert result.value is None and result.steps is None
    assert result.actions == () and result.path == () and not result.reaches_goal


def test_spec_met_only_by_staying_away_from_the_goal() -> None:
    # F(G(t)): the episode must end on t, so it must be truncated there.
    result = optimal_constrained_return([f"F(G({T}))"])
    assert result.value == LIMIT * STEP == -216.0
    assert result.steps == LIMIT and not result.reaches_goal
    assert result.path[-1] == TOP_RIGHT
    assert not optimal_constrained_return([f"F(G({T}))"], require_goal=True).feasible
    assert optimal_constrained_return([f"F(G({T}))"], max_steps=10).value == 10 * STEP


def test_edge_without_either_corner_can_only_wait_out_the_clock() -> None:
    # Every on-edge route to the goal passes t or b.
    specs = ["G(on_edge)", f"!F({T})", f"!F({B})"]
    result = optimal_constrained_return(specs)
    assert result.value == LIMIT * STEP and not result.reaches_goal
    assert not optimal_constrained_return(specs, require_goal=True).feasible


def test_step_limit_is_honoured() -> None:
    # 7 steps are needed: with 6 the best episode is truncated; with 7 the goal is
    # entered on the last step (terminated and truncated at once).
    short = optimal_unconstrained_return(max_steps=6)
    assert short.value == 6 * STEP and short.steps == 6 and not short.reaches_goal
    assert not optimal_unconstrained_return(max_steps=6, require_goal=True).feasible
    exact = optimal_unconstrained_return(max_steps=7)
    assert exact.value == goal_return(7) and exact.reaches_goal


def test_room_size_and_rewards_are_parameters() -> None:
    # 5x5 room: goal (3, 3) is 2 forward, turn right, 2 forward away.
    result = optimal_unconstrained_return(size=5, step_reward=-1.0, goal_reward=10.0)
    assert result.value == 10.0 - 5.0 and result.steps == 5
    assert result.step_limit == 4 * 5**2


def test_ties_go_to_the_shorter_episode() -> None:
    # Free steps: every route to the goal returns goal_reward, the shortest is chosen.
    result = optimal_unconstrained_return(step_reward=0.0)
    assert result.value == GOAL_REWARD and result.steps == 7


# ---------------------------------------------------------------- replays in the env


def replay(result: OptimalResult, *, max_steps: int | None = None) -> tuple[float, list, bool]:
    """Plays ``result.actions`` in a real GridworldEnv: (return, true trace, ended)."""
    env = GridworldEnv(max_steps=max_steps)
    env.reset(seed=0)
    trace = [env.true_fluents()]
    total, ended = 0.0, False
    for k, action in enumerate(result.actions):
        assert not ended, "the episode ended before the actions ran out"
        _, reward, terminated, truncated, _ = env.step(action)
        total += float(reward)
        trace.append(env.true_fluents())
        assert (env.agent_pos[0], env.agent_pos[1], env.agent_dir) == result.states[k + 1]
        ended = terminated or truncated
        if k == len(result.actions) - 1:
            assert terminated == result.reaches_goal
    return total, trace, ended


@pytest.mark.parametrize(
    ("specs", "max_steps"),
    [
        ([], None),
        ([f"!F({T})"], None),
        (["G(on_edge)"], None),
        ([ONCE_T], None),
        ([EXCLUSIVE], None),
        ([EXCLUSIVE, f"!F({T})"], None),
        ([f"F(G({T}))"], None),
        (["G(on_edge)", f"!F({T})", f"!F({B})"], 20),
    ],
)
def test_replayed_actions_earn_the_value_and_comply(
    specs: list[str], max_steps: int | None
) -> None:
    result = optimal_constrained_return(specs, max_steps=max_steps)
    total, trace, ended = replay(result, max_steps=max_steps)
    assert ended
    assert total == result.value
    for formula in specs:
        dfa = compile_ltlf(formula, GRIDWORLD_FLUENTS)
        letters = [dict(zip(GRIDWORLD_FLUENTS, map(bool, row), strict=True)) for row in trace]
        assert dfa.accepts(letters), formula


# ------------------------------------------------------------ brute force on the env


def all_episodes(size: int, max_steps: int) -> list[tuple[float, np.ndarray, bool, int]]:
    """Every episode of the real env up to ``max_steps``: (return, true trace, goal, steps)."""
    root = GridworldEnv(size=size, max_steps=max_steps)
    root.reset(seed=0)
    episodes = []
    stack = [(root, [root.true_fluents()], 0.0)]
    while stack:
        env, trace, total = stack.pop()
        for action in GridAction:
            child = copy.deepcopy(env)
            _, reward, terminated, truncated, _ = child.step(action)
            step_trace, step_total = [*trace, child.true_fluents()], total + float(reward)
            if terminated or truncated:
                episodes.append((step_total, np.array(step_trace), terminated, len(trace)))
            else:
                stack.append((child, step_trace, step_total))
    return episodes


BRUTE_FORCE_SPECS: list[list[str]] = [
    [],
    [f"!F({T})"],
    ["G(on_edge)"],
    ["F(!on_edge)"],
    [f"F(G({T}))"],
    [ONCE_T],
    [EXCLUSIVE],
    [f"G({T})"],
    ["F(facing_up)", f"!F({B})"],
    ["G(!facing_down)"],
    ["facing_right & X(facing_down)"],  # the trace starts at reset, facing east
    ["!facing_right"],
]


@pytest.fixture(scope="module")
def small_room_episodes() -> list[tuple[float, np.ndarray, bool, int]]:
    return all_episodes(size=5, max_steps=6)  # 4**6 action sequences at most


@pytest.mark.parametrize("require_goal", [False, True])
def test_equals_brute_force_over_every_episode(
    small_room_episodes: list[tuple[float, np.ndarray, bool, int]], require_goal: bool
) -> None:
    for specs in BRUTE_FORCE_SPECS:
        dfas = [compile_ltlf(f, GRIDWORLD_FLUENTS) for f in specs]
        best: tuple[float, int] | None = None
        for total, trace, goal, steps in small_room_episodes:
            if require_goal and not goal:
                continue
            masks = masks_from_bool_matrix(trace)
            if all(dfa.accepting[final_state(dfa, masks)] for dfa in dfas):
                best = max(best or (total, -steps), (total, -steps))
        result = optimal_constrained_return(specs, size=5, max_steps=6, require_goal=require_goal)
        if best is None:
            assert not result.feasible, specs
        else:
            assert (result.value, result.steps) == (best[0], -best[1]), specs


def final_state(dfa: DFA, masks: np.ndarray) -> int:
    q = dfa.initial_state
    for mask in masks:
        q = int(dfa.next_state[q, int(mask)])
    return q


# ---------------------------------------------------------------------- inputs


def test_spec_objects_and_dfas_are_accepted() -> None:
    formula = f"!F({T})"
    spec = Spec(formula, terminal_reward=1.0, low_confidence_cost=0.5)
    own_order = compile_ltlf(formula, [T, "on_edge"])  # a sub-vocabulary, any order
    for item in (spec, own_order):
        result = optimal_constrained_return([item])
        assert result.value == goal_return(8)


def test_bad_input_is_rejected_up_front() -> None:
    with pytest.raises(ConfigError, match="wrap a single spec"):
        optimal_constrained_return(f"!F({T})")  # a str is a sequence, of letters
    with pytest.raises(ConfigError, match="LTLf text"):
        optimal_constrained_return([42])  # type: ignore[list-item]
    with pytest.raises(SpecSyntaxError):
        optimal_constrained_return(["F(("])
    with pytest.raises(UnknownFluentError):
        optimal_constrained_return(["F(on_goal)"])
    with pytest.raises(UnknownFluentError):
        optimal_constrained_return([compile_ltlf("F(a)", ["a"])])
    with pytest.raises(ConfigError):
        optimal_constrained_return([], size=3)
    with pytest.raises(ConfigError):
        optimal_constrained_return([], max_steps=0)


# ----------------------------------------------------------- paper table and API


def test_paper_specs_table() -> None:
    rows = optimal.paper_spec_optima()
    assert [r.name for r in rows] == list(optimal.PAPER_TABLE1_RC_MAX)
    assert [r.result.value for r in rows] == [89.5, 88.0, 89.5, 89.5]
    assert [r.paper_value for r in rows] == [94.0, 82.0, 92.0, 92.0]
    table = format_optima_table(rows)
    lines = table.splitlines()
    assert len(lines) == 2 + len(rows)
    # Every row has the header's 5 cells: the | of a formula is escaped.
    assert {line.replace("\\|", "").count("|") for line in lines} == {6}


def test_table_says_infeasible() -> None:
    row = SpecOptimum("never", f"G({T})", optimal_constrained_return([f"G({T})"]), 0.0)
    assert "| infeasible | - |" in format_optima_table([row])


def test_public_api() -> None:
    assert set(optimal.__all__) <= set(experiments.__all__)
    for name in optimal.__all__:
        assert getattr(experiments, name) is getattr(optimal, name)
    with pytest.raises(AttributeError):
        _ = experiments.no_such_name


def test_docstring_examples() -> None:
    failures, tried = doctest.testmod(optimal, optionflags=doctest.ELLIPSIS)
    assert tried > 0 and failures == 0
