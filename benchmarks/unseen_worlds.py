"""Gymnasium worlds noisybolt was not written for, each with a spec, for the world suite.

Each factory is what a user would write: the env as Gymnasium makes it (a time limit
where the env has none), fluents as functions of its state, the env's own render as the
bolt's camera, ``success`` for goal rates, and nothing tuned; no return bounds are
declared (the ``compliance`` scheme then estimates them from random play), except where a
world says otherwise. ``WORLDS`` pairs each factory path with specs over its fluents, each
with a compliant route to the goal. Used by ``benchmarks/world_suite.py``; each is also a
``noisybolt train --world unseen_worlds:NAME`` from this folder.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

from noisybolt import FluentLabels, GridLayout


def _small(env: gym.Env) -> Any:
    """The env's render, one pixel in eight each way (the toy-text renders are large)."""
    return env.render()[::8, ::8]


def _cell(columns: int) -> Any:
    return lambda env: (int(env.s) % columns, int(env.s) // columns)


def lake8() -> FluentLabels:
    """FrozenLake 8x8, not slippery; the bolt wants the right column kept clear but for the
    goal, or the bottom-left cell visited (a long detour round the holes)."""
    env = gym.make("FrozenLake-v1", map_name="8x8", is_slippery=False, render_mode="rgb_array")
    fluents = {
        "right_col": lambda e: e.s % 8 == 7,
        "bottom_left": lambda e: e.s == 56,
        "at_goal": lambda e: e.s == 63,
    }
    grid = GridLayout(width=8, height=8, position=_cell(8), goal=(7, 7), start=(0, 0))
    return FluentLabels(env, fluents=fluents, camera=_small, success="at_goal", grid=grid)


def cliff() -> FluentLabels:
    """CliffWalking (-1 a step, -100 and back to the start for a fall), 100-step limit; the
    bolt wants the row along the cliff avoided (the safe path, two steps longer)."""
    env = gym.make("CliffWalking-v1", render_mode="rgb_array", max_episode_steps=100)
    fluents = {
        "cliff_row": lambda e: e.s // 12 == 2 and 0 < e.s % 12 < 11,
        "top_row": lambda e: e.s < 12,
        "at_goal": lambda e: e.s == 47,
    }
    grid = GridLayout(width=12, height=4, position=_cell(12), goal=(11, 3), start=(0, 3))
    return FluentLabels(env, fluents=fluents, camera=_small, success="at_goal", grid=grid)


def _minigrid_6x6(level: str, fluents: dict[str, Any]) -> FluentLabels:
    """A 6x6 MiniGrid level as a user would label it: the agent's own partial view as its
    image, the bolt's camera the whole grid at 4 pixels a tile, the goal at (4, 4)."""
    import minigrid  # noqa: F401  (registers the MiniGrid levels)
    from minigrid.wrappers import ImgObsWrapper

    env = ImgObsWrapper(gym.make(level, render_mode="rgb_array"))
    grid = GridLayout(
        width=6,
        height=6,
        position=lambda e: (int(e.agent_pos[0]), int(e.agent_pos[1])),
        walls=True,
        goal=(4, 4),
        start=(1, 1),
    )

    def camera(wrapped: gym.Env) -> Any:
        return wrapped.unwrapped.get_frame(highlight=False, tile_size=4)

    return FluentLabels(env, fluents=fluents, camera=camera, success="at_goal", grid=grid)


def room() -> FluentLabels:
    """MiniGrid's Empty-6x6 (the agent's own partial view as its image); the bolt wants the
    bottom-left corner visited, or the right column kept clear until then."""
    fluents = {
        "bottom_left": lambda e: tuple(e.agent_pos) == (1, 4),
        "right_col": lambda e: e.agent_pos[0] == 4,
        "at_goal": lambda e: tuple(e.agent_pos) == (4, 4),
    }
    return _minigrid_6x6("MiniGrid-Empty-6x6-v0", fluents)


def lava() -> FluentLabels:
    """MiniGrid's LavaGapS6 (a lava column with one gap, the gap's row drawn each episode;
    stepping into lava ends the episode unpaid; the agent's own partial view as its
    image); the bolt wants the lava never entered (which the task itself asks: a safety
    spec the world already pays for), or the bottom-left corner visited before the goal
    (a detour back through the gap)."""
    import minigrid  # noqa: F401  (registers the MiniGrid levels)
    from minigrid.core.world_object import Lava

    fluents = {
        "in_lava": lambda e: isinstance(e.grid.get(*e.agent_pos), Lava),
        "bottom_left": lambda e: tuple(e.agent_pos) == (1, 4),
        "at_goal": lambda e: tuple(e.agent_pos) == (4, 4),
    }
    return _minigrid_6x6("MiniGrid-LavaGapS6-v0", fluents)


def acrobot() -> FluentLabels:
    """Acrobot (-1 a step until the tip is swung above the bar, 500 steps at most); the
    bolt wants the tip swung out to the left at least once (x < -1), or the first link
    never spun faster than 6 rad/s. Its bounds are declared (-500 to 0)."""
    env = gym.make("Acrobot-v1", render_mode="rgb_array")

    def tip_x(e: Any) -> float:
        t1, t2 = e.state[0], e.state[1]
        return float(np.sin(t1) + np.sin(t1 + t2))

    fluents = {
        "tip_left": lambda e: e.state is not None and tip_x(e) < -1.0,
        "fast": lambda e: e.state is not None and abs(float(e.state[2])) > 6.0,
    }
    return FluentLabels(env, fluents=fluents, camera=_small, return_bounds=(-500, 0))


def cartpole() -> FluentLabels:
    """CartPole (+1 a step balanced, 500 at most); the bolt wants the cart to visit the
    left side of the track (x < -0.5) while balancing. Its bounds are declared: a trained
    agent returns many times what random play does."""
    env = gym.make("CartPole-v1", render_mode="rgb_array")
    fluents = {
        "left_side": lambda e: e.state is not None and e.state[0] < -0.5,
        "right_side": lambda e: e.state is not None and e.state[0] > 0.5,
    }

    return FluentLabels(env, fluents=fluents, camera=_small, return_bounds=(0, 500))


#: factory path → (specs over its fluents, each with a compliant route to the goal).
WORLDS: dict[str, tuple[str, ...]] = {
    "unseen_worlds:lake8": ("G(!right_col | at_goal)", "F(bottom_left)"),
    "unseen_worlds:cliff": ("G(!cliff_row)", "F(top_row)"),
    "unseen_worlds:room": ("F(bottom_left)", "!right_col U bottom_left"),
    "unseen_worlds:cartpole": ("F(left_side)", "G(!right_side)"),
    "unseen_worlds:lava": ("G(!in_lava)", "F(bottom_left)"),
    "unseen_worlds:acrobot": ("G(!fast)", "F(tip_left)"),
}


#: Frames each world's trials train for: enough that the unbolted control learns the task
#: in most seeds (measured with PPO, the fallback hyperparameters; the world suite's
#: README table says how many seeds' controls did). FrozenLake 8x8 and CliffWalking pay
#: nothing (or only step costs) until the goal is first found by chance: at 100k frames
#: PPO's control found it in one seed of two on each; the lava room's control of seed 0
#: found the gap at 90k of 150k frames.
FRAMES: dict[str, int] = {
    "unseen_worlds:lake8": 300_000,
    "unseen_worlds:cliff": 300_000,
    "unseen_worlds:room": 150_000,
    "unseen_worlds:cartpole": 100_000,
    "unseen_worlds:lava": 300_000,
    "unseen_worlds:acrobot": 100_000,
}
