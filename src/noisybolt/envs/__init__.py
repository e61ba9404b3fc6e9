"""Worlds with their ground-truth fluents, as the agent and the restraining bolt see them.

- :mod:`noisybolt.envs.gridworld`: the paper's 6x6 gridworld as a MiniGrid env (the
  reference form), its fluents and the bolt's camera;
- :mod:`noisybolt.envs.gridworld_vec`: the same world natively vectorised (the training
  default), a Gymnasium vector env with same-step autoreset;
- :mod:`noisybolt.envs.sb3`: the SB3 ``VecEnv`` adapter;
- :mod:`noisybolt.envs.registry`: worlds by name;
- :mod:`noisybolt.envs.labels`: :class:`FluentLabels`, any Gymnasium env made bolt-ready.

Importing this package registers the Gymnasium ids ``noisybolt/Gridworld-6x6-v0`` and
``noisybolt/Gridworld-v0`` (any size through keyword arguments); both have a vector entry
point, so ``gymnasium.make_vec(id, num_envs=64)`` gives the vectorised form.
"""

from __future__ import annotations

import gymnasium as gym

from noisybolt.envs.gridworld import GRIDWORLD_FLUENTS, GridAction, GridworldEnv
from noisybolt.envs.gridworld_vec import VectorGridworld
from noisybolt.envs.labels import FluentLabels
from noisybolt.envs.layout import GridLayout
from noisybolt.envs.registry import (
    DEFAULT_WORLD,
    check_world,
    known_worlds,
    make_single_world,
    make_world,
    register_world,
)
from noisybolt.envs.sb3 import SB3VecEnv

__all__ = [
    "DEFAULT_WORLD",
    "GRIDWORLD_FLUENTS",
    "GYM_IDS",
    "FluentLabels",
    "GridAction",
    "GridLayout",
    "GridworldEnv",
    "SB3VecEnv",
    "VectorGridworld",
    "check_world",
    "known_worlds",
    "make_single_world",
    "make_world",
    "register_gym_envs",
    "register_world",
]

#: The Gymnasium ids registered by :func:`register_gym_envs`.
GYM_IDS: tuple[str, ...] = ("noisybolt/Gridworld-6x6-v0", "noisybolt/Gridworld-v0")


def register_gym_envs() -> None:
    """Register the gridworld's Gymnasium ids (idempotent; done on import)."""
    entry = "noisybolt.envs.gridworld:GridworldEnv"
    vector_entry = "noisybolt.envs.gridworld_vec:VectorGridworld"
    for env_id, kwargs in zip(GYM_IDS, ({"size": 6}, {}), strict=True):
        if env_id not in gym.registry:
            gym.register(
                id=env_id, entry_point=entry, vector_entry_point=vector_entry, kwargs=kwargs
            )


register_gym_envs()
