"""The registry's factories for Breakout: ``"breakout"``, ``"breakout-ram"`` and the
labelled one-game env of ``"breakout-ram"`` for recordings.

Each builds one :class:`~noisybolt.envs.breakout.config.BreakoutConfig` from its keywords
and forwards it; a keyword that is no setting of it is refused as the registry refuses a
world's unknown parameters, naming the ones it takes.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import fields
from typing import Any

from noisybolt.envs.breakout.adapter import BreakoutEnv
from noisybolt.envs.breakout.config import BreakoutConfig
from noisybolt.envs.breakout.world import BreakoutWorld
from noisybolt.errors import ConfigError

__all__ = ["make_breakout_ram_env", "make_breakout_ram_world", "make_breakout_world"]


def _config(world: str, settings: Mapping[str, Any]) -> BreakoutConfig:
    """The :class:`BreakoutConfig` of ``settings``, the keywords world ``world`` was given.

    Raises:
        ConfigError: a keyword that is no field of :class:`BreakoutConfig`, naming those
            that are (as :func:`~noisybolt.envs.registry.make_world` does for a factory
            whose signature lists its parameters), or a bad value.
    """
    known = [f.name for f in fields(BreakoutConfig)]
    unknown = sorted(set(settings) - set(known))
    if unknown:
        raise ConfigError(
            f"world {world!r} takes no parameter(s) {', '.join(unknown)}; it takes: "
            f"{', '.join(known)}"
        )
    return BreakoutConfig(**settings)


def make_breakout_world(
    *,
    num_envs: int = 8,
    seed: int | None = None,
    noise: Any = None,
    obs_mode: str | None = None,
    **settings: Any,
) -> BreakoutWorld:
    """The registry's factory for ``"breakout"`` (``make_world("breakout", ...)``).

    Args:
        num_envs: number of games.
        seed: seeds the games and the camera noise.
        noise: the bolt camera's noise (see
            :func:`~noisybolt.envs.breakout.camera.resolve_noise`).
        obs_mode: the agent's observation: None or ``"stack"`` (the standard preprocessed
            grayscale frame stack), ``"ram"`` (the 128 RAM bytes) or ``"ram_bits"`` (their
            1,024 bits); see :func:`make_breakout_ram_world`.
        **settings: the other settings of :class:`BreakoutConfig` (``left_columns``,
            ``fluents``, ``camera_size``, ``frame_skip``, ``noop_max``,
            ``repeat_action_probability``, ``frame_stack``, ``screen_size``,
            ``max_episode_frames``, ``fire_on_reset``, ``left_head_start``, ``shard``).

    Raises:
        ConfigError: a keyword :class:`BreakoutConfig` does not take, an unknown
            ``obs_mode`` or an out-of-range setting.

    Example:
        >>> world = make_breakout_world(num_envs=1, seed=3, fluents=["brick_clear_left"])
        >>> world.fluent_names, world.camera_spec.shape
        (('brick_clear_left',), (84, 84, 3))
    """
    obs_mode = "stack" if obs_mode is None else obs_mode
    given = {"num_envs": num_envs, "seed": seed, "noise": noise, "obs_mode": obs_mode}
    return BreakoutWorld(_config("breakout", given | settings))


def make_breakout_ram_world(*, obs_mode: str | None = "ram", **settings: Any) -> BreakoutWorld:
    """The registry's factory for ``"breakout-ram"``: Breakout whose agent reads the RAM.

    The same game, fluents and bolt camera as ``"breakout"`` (the bolt still looks through
    its noisy camera and classifier), but the agent observes the console's 128 RAM bytes
    (``obs_mode="ram"``), which a small dense network reads several times faster than
    convolutions read frames. A world of its own name so that it has its own
    hyperparameters (``configs/hyperparams/breakout-ram.yaml``).

    Args:
        obs_mode: ``"ram"`` (default), ``"ram_bits"`` or ``"stack"``.
        **settings: every other keyword of :func:`make_breakout_world` (the settings of
            :class:`BreakoutConfig`).

    Raises:
        ConfigError: a keyword :class:`BreakoutConfig` does not take, or a bad value.

    Example:
        >>> world = make_breakout_ram_world(num_envs=2, seed=0)
        >>> obs, _ = world.reset(seed=0)
        >>> obs.shape, obs.dtype, world.bolt_images().shape
        ((2, 128), dtype('float32'), (2, 84, 84, 3))
        >>> world.close()
    """
    return BreakoutWorld(_config("breakout-ram", settings | {"obs_mode": obs_mode or "ram"}))


def make_breakout_ram_env(**settings: Any) -> BreakoutEnv:
    """One labelled game of ``"breakout-ram"`` (for recordings): :class:`BreakoutEnv`
    observing the RAM unless ``obs_mode`` says otherwise."""
    settings["obs_mode"] = settings.get("obs_mode") or "ram"
    return BreakoutEnv(**settings)
