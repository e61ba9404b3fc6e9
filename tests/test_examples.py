"""The examples run as a user would run them, with fast settings, and do what they say."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest

import noisybolt

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def _user_lines(path: Path) -> int:
    """Lines of code a user writes: no blanks, comments, docstring or __main__ demo."""
    text = path.read_text().split('if __name__ == "__main__":')[0]
    body = text.split('"""', 2)[2]  # after the module docstring
    return sum(1 for line in body.splitlines() if line.strip() and not line.strip().startswith("#"))


def test_frozenlake_is_bolted_in_under_20_lines() -> None:
    assert _user_lines(EXAMPLES / "frozenlake.py") < 20


def test_frozenlake_agent_reaches_the_goal_by_the_route_the_bolt_wants(
    load_script: Callable[..., ModuleType],
) -> None:
    lake = load_script("examples/frozenlake.py", "example_frozenlake")
    model = lake.train(frames=6144, seed=0)  # learned in 6k frames for seeds 0, 1 and 2
    env = noisybolt.RestrainingBoltWrapper(lake.make_lake(), [lake.SPEC], "oracle")
    obs, info = env.reset(seed=0)
    route, done = [], False
    while not done:
        action, _ = model.predict(obs, deterministic=True)
        obs, _, terminated, truncated, info = env.step(int(action))
        route.append(int(obs["image"]))
        done = terminated or truncated
    assert info["is_success"] is True  # the goal, cell 15
    assert info["true_accepting"].tolist() == [True]  # complied: never back on the top row
    assert route == [4, 8, 9, 13, 14, 15]  # six steps: the shortest compliant route


def test_minigrid_room_is_bolted_with_fluents_of_the_agents_cell(
    load_script: Callable[..., ModuleType],
) -> None:
    room = load_script("examples/minigrid_empty.py", "example_minigrid_empty")
    left, right, forward = 0, 1, 2  # MiniGrid's turn left, turn right, move forward

    def run(actions: list[int]) -> tuple[float, bool, dict]:
        env = noisybolt.RestrainingBoltWrapper(room.make_room(), [room.SPEC], "oracle")
        env.reset(seed=0)  # top-left cell, facing east; the goal is bottom-right
        total, terminated = 0.0, False
        for action in actions:
            _, reward, terminated, _, info = env.step(action)
            total += float(reward)
        return total, terminated, info

    # Down the left wall, then across: 6 actions; MiniGrid pays 1 - 0.9 * 6/100, the bolt 1.
    total, terminated, info = run([right, forward, forward, left, forward, forward])
    assert terminated and info["is_success"] is True
    assert info["true_accepting"].tolist() == [True]
    assert total == pytest.approx(1 - 0.9 * 6 / 100 + 1.0)
    # Along the top wall: one action shorter, but the bolt pays nothing.
    total, terminated, info = run([forward, forward, right, forward, forward])
    assert terminated and info["is_success"] is True
    assert info["true_accepting"].tolist() == [False]
    assert total == pytest.approx(1 - 0.9 * 5 / 100)


@pytest.mark.parametrize(
    ("state", "expected", "done"),
    [
        # (theta1, theta2, dtheta1, dtheta2) set, then one step: the fluents of the state
        # reached (0.2 s on). Both links up: the tip 2 above the pivot, the goal.
        ((np.pi, 0.0, 0.0, 0.0), {"tip_high"}, True),
        ((-np.pi / 2, 0.0, 0.0, 0.0), {"left"}, False),  # still ~80 degrees to the left
        ((np.pi / 2, 0.0, 0.0, 0.0), {"right"}, False),
        # Hanging, turning at 6 rad/s: past the 5 rad/s limit, and ~1 rad on, to the right.
        ((0.0, 0.0, 6.0, 0.0), {"fast", "right"}, False),
    ],
)
def test_acrobot_fluents_read_the_state_reached(
    load_script: Callable[..., ModuleType],
    state: tuple[float, ...],
    expected: set[str],
    done: bool,
) -> None:
    acrobot = load_script("examples/acrobot.py", "example_acrobot")
    env = acrobot.make_acrobot()
    env.reset(seed=0)
    env.unwrapped.state = np.array(state)
    _, reward, terminated, _, info = env.step(1)
    true = {name for name, on in zip(env.fluent_names, info["true_fluents"], strict=True) if on}
    assert true == expected
    assert (terminated, reward) == (done, 0.0 if done else -1.0)
    assert info.get("is_success", False) is done
    bounds = env.episode_return_bounds
    assert (bounds.low, bounds.high) == (-500.0, 0.0)
