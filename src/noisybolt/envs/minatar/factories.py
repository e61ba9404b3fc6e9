"""The registry's factory for ``"minatar-breakout"``.

It builds one :class:`~noisybolt.envs.minatar.config.MinAtarBreakoutConfig` from its
keywords and forwards it; a keyword that is no setting of it is refused as the registry
refuses a world's unknown parameters, naming the ones it takes.
"""

from __future__ import annotations

from dataclasses import fields
from typing import Any

from noisybolt.envs.minatar.config import MinAtarBreakoutConfig
from noisybolt.envs.minatar.world import WORLD_NAME, MinAtarBreakoutWorld
from noisybolt.errors import ConfigError

__all__ = ["make_minatar_breakout_world"]

#: The agent's one observation here: MinAtar's board (the registry passes ``obs_mode``).
_OBS_MODES = (None, "board")


def make_minatar_breakout_world(
    *,
    num_envs: int = 8,
    seed: int | None = None,
    noise: Any = None,
    obs_mode: str | None = None,
    **settings: Any,
) -> MinAtarBreakoutWorld:
    """The registry's factory for ``"minatar-breakout"`` (``make_world("minatar-breakout",
    ...)``).

    Args:
        num_envs: number of games.
        seed: seeds the games and the camera noise.
        noise: the bolt camera's noise (a :mod:`noisybolt.perception.noise` spec, model or
            callable).
        obs_mode: None or ``"board"``: the agent sees MinAtar's board, its only view.
        **settings: the other settings of :class:`MinAtarBreakoutConfig` (``fluents``,
            ``game``, ``sticky_action_prob``, ``tile_size``, ``max_episode_steps``,
            ``shard``).

    Raises:
        ConfigError: a keyword :class:`MinAtarBreakoutConfig` does not take, another
            ``obs_mode``, or an out-of-range setting.
        UnknownNameError: a MinAtar game without fluents here.
        MissingDependencyError: ``minatar`` is not installed.

    Example:
        >>> world = make_minatar_breakout_world(num_envs=1, seed=3, fluents=["brick_clear_left"])
        >>> world.fluent_names, world.camera_spec.shape, world.single_action_space
        (('brick_clear_left',), (40, 40, 3), Discrete(3))
        >>> make_minatar_breakout_world(difficulty=2)  # doctest: +ELLIPSIS
        Traceback (most recent call last):
        ...
        noisybolt.errors.ConfigError: world 'minatar-breakout' takes no parameter(s) difficulty; ...
    """
    if obs_mode not in _OBS_MODES:
        raise ConfigError(
            f"world {WORLD_NAME!r}: obs_mode must be 'board' (MinAtar's state), got {obs_mode!r}"
        )
    known = [f.name for f in fields(MinAtarBreakoutConfig)]
    unknown = sorted(set(settings) - set(known))
    if unknown:
        raise ConfigError(
            f"world {WORLD_NAME!r} takes no parameter(s) {', '.join(unknown)}; it takes: "
            f"{', '.join(known)}, obs_mode"
        )
    given = {"num_envs": num_envs, "seed": seed, "noise": noise}
    return MinAtarBreakoutWorld(MinAtarBreakoutConfig(**(given | settings)))
