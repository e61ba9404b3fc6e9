"""The gridworld as a tabular world: every (agent state, action) stepped once, recorded.

The planner of :mod:`noisybolt.bolt.product` (exact R^c_max, exact compliance scales)
plans over a :class:`~noisybolt.bolt.product.TabularWorld`; this module builds the
gridworld's. The dynamics are not re-implemented: every ``(state, action)`` is stepped
once in a real :class:`~noisybolt.envs.gridworld.GridworldEnv` (placing the agent through
MiniGrid's public ``agent_pos`` / ``agent_dir``), and its rewards, terminations and
ground-truth fluents are what the planner uses.

Example:
    >>> model = gridworld_model(size=6)
    >>> len(model.states), model.states[model.start], model.step_limit
    (64, (1, 1, 0), 144)
"""

from __future__ import annotations

from functools import lru_cache
from typing import Any

import numpy as np

from noisybolt.bolt.product import TabularWorld
from noisybolt.envs.gridworld import GRIDWORLD_FLUENTS, GridAction, GridworldConfig, GridworldEnv
from noisybolt.envs.gridworld_vec import VectorGridworld

__all__ = ["gridworld_model", "tabular_gridworld_settings", "tabular_model"]


def gridworld_model(
    *,
    size: int = 6,
    max_steps: int | None = None,
    step_reward: float = -1.5,
    goal_reward: float = 100.0,
) -> TabularWorld:
    """The gridworld of these settings as a :class:`~noisybolt.bolt.product.TabularWorld`
    (states ``(x, y, heading)``, positions ``(x, y)``, fluents in
    :data:`~noisybolt.envs.gridworld.GRIDWORLD_FLUENTS` order); cached.

    Raises:
        ConfigError: a bad world setting.
    """
    config = GridworldConfig(
        size=size, max_steps=max_steps, step_reward=step_reward, goal_reward=goal_reward
    )
    return _stepped_model(config.size, config.max_steps, config.step_reward, config.goal_reward)


@lru_cache(maxsize=16)
def _stepped_model(
    size: int, max_steps: int | None, step_reward: float, goal_reward: float
) -> TabularWorld:
    """Steps every (agent state, action) once in a real GridworldEnv and records it."""
    env = GridworldEnv(
        size=size, max_steps=max_steps, step_reward=step_reward, goal_reward=goal_reward
    )
    try:
        env.reset(seed=0)
        start = (int(env.agent_pos[0]), int(env.agent_pos[1]), int(env.agent_dir))
        # Every cell the agent may stand on, as the env's grid says (floor and goal).
        cells = [
            (x, y)
            for x in range(env.width)
            for y in range(env.height)
            if (obj := env.grid.get(x, y)) is None or obj.can_overlap()
        ]
        states = tuple((x, y, d) for x, y in cells for d in range(4))
        index = {s: i for i, s in enumerate(states)}
        n_actions = len(GridAction)
        next_index = np.empty((len(states), n_actions), dtype=np.intp)
        reward = np.empty((len(states), n_actions), dtype=np.float64)
        terminated = np.empty((len(states), n_actions), dtype=bool)
        fluents = np.empty((len(states), len(GRIDWORLD_FLUENTS)), dtype=bool)
        for i, (x, y, d) in enumerate(states):
            env.agent_pos, env.agent_dir = (x, y), d
            fluents[i] = env.true_fluents()
            for a in range(n_actions):
                env.reset()  # a fresh episode (step count 0), then the agent is placed
                env.agent_pos, env.agent_dir = (x, y), d
                _, r, term, _, _ = env.step(a)
                reached = (int(env.agent_pos[0]), int(env.agent_pos[1]), int(env.agent_dir))
                next_index[i, a] = index[reached]
                reward[i, a] = r
                terminated[i, a] = term
        step_limit = env.config.step_limit
    finally:
        env.close()
    for array in (next_index, reward, terminated, fluents):
        array.setflags(write=False)
    return TabularWorld(
        states=states,
        next_index=next_index,
        reward=reward,
        terminated=terminated,
        fluents=fluents,
        fluent_names=tuple(GRIDWORLD_FLUENTS),
        start=index[start],
        step_limit=step_limit,
        positions=tuple((x, y) for x, y, _ in states),
    )


def tabular_gridworld_settings(world: object) -> dict[str, Any] | None:
    """The planner's world settings (size, max_steps, step and goal rewards) of a
    vectorised gridworld, or None for a world the planner cannot explore."""
    if not isinstance(world, VectorGridworld) or world.config.start_heading != "east":
        return None
    config = world.config
    return {
        "size": config.size,
        "max_steps": config.max_steps,
        "step_reward": config.step_reward,
        "goal_reward": config.goal_reward,
    }


def tabular_model(world: object) -> TabularWorld | None:
    """A built world as a :class:`~noisybolt.bolt.product.TabularWorld`, or None where it
    cannot be enumerated (today: every world but the vectorised gridworld)."""
    settings = tabular_gridworld_settings(world)
    return None if settings is None else gridworld_model(**settings)
