"""Worlds by name: ``make_world("gridworld", num_envs=8, seed=0, noise="regional")``.

A world factory returns a vectorised world meeting
:class:`~noisybolt.perception.protocols.BoltObservable` (and, for training, a Gymnasium
:class:`~gymnasium.vector.VectorEnv` with same-step autoreset). Factories are registered
as ``"module:attribute"`` paths and imported only when asked for, so a world whose module
or dependencies are missing breaks only itself. Every factory takes the keywords
``num_envs``, ``seed``, ``noise`` and ``obs_mode`` plus its own.

Example:
    >>> world = make_world("gridworld", num_envs=2, seed=0, obs_mode="view")
    >>> world.num_envs, world.fluent_names[0], world.camera_spec.shape
    (2, 'on_edge', (48, 48, 3))
    >>> "breakout" in known_worlds()
    True
"""

from __future__ import annotations

import importlib
import inspect
from collections.abc import Callable
from typing import Any

from noisybolt.errors import BackendUnavailableError, ConfigError, UnknownNameError
from noisybolt.perception.noise import NoiseSpec
from noisybolt.perception.protocols import BoltObservable

__all__ = ["known_worlds", "make_world", "register_world"]

WorldFactory = Callable[..., BoltObservable]

_WORLDS: dict[str, str | WorldFactory] = {
    "gridworld": "noisybolt.envs.gridworld_vec:VectorGridworld",
    # Written separately (envs/breakout.py); the factory takes the same keywords.
    "breakout": "noisybolt.envs.breakout:make_breakout_world",
}


def known_worlds() -> tuple[str, ...]:
    """Registered world names, sorted."""
    return tuple(sorted(_WORLDS))


def register_world(name: str, factory: str | WorldFactory, *, overwrite: bool = False) -> None:
    """Register a world factory (a callable, or a lazy ``"module:attribute"`` path).

    Raises:
        ConfigError: if ``name`` is taken and ``overwrite`` is False, or a path is malformed.
    """
    if name in _WORLDS and not overwrite:
        raise ConfigError(f"world {name!r} is already registered; pass overwrite=True")
    if isinstance(factory, str) and factory.count(":") != 1:
        raise ConfigError(f"a world factory path is 'module:attribute', got {factory!r}")
    _WORLDS[name] = factory


def _resolve(name: str) -> WorldFactory:
    entry = _WORLDS[name]
    if not isinstance(entry, str):
        return entry
    module_name, _, attribute = entry.partition(":")
    try:
        module = importlib.import_module(module_name)
    except ModuleNotFoundError as exc:
        raise BackendUnavailableError(
            f"world {name!r} cannot be built here: importing {module_name} failed ({exc}); "
            f"install its dependencies or pick another of {', '.join(known_worlds())}"
        ) from exc
    try:
        factory: WorldFactory = getattr(module, attribute)
    except AttributeError:
        raise BackendUnavailableError(
            f"world {name!r}: {module_name} has no factory {attribute!r}"
        ) from None
    return factory


def make_world(
    name: str,
    *,
    num_envs: int = 1,
    seed: int | None = None,
    noise: NoiseSpec = "none",
    obs_mode: str | None = None,
    **kwargs: Any,
) -> BoltObservable:
    """Build a vectorised world by name.

    Args:
        name: one of :func:`known_worlds`.
        num_envs: number of environments in the batch.
        seed: seeds the world's randomness (the bolt camera's noise included).
        noise: the bolt camera's noise spec (see
            :func:`noisybolt.perception.noise.make_noise`).
        obs_mode: the agent's observation; None for the world's default.
        **kwargs: the world's own parameters (e.g. ``size`` for the gridworld).

    Raises:
        UnknownNameError: for a name outside :func:`known_worlds` (listing them).
        ConfigError: for a parameter the world does not take, or a bad value.
        BackendUnavailableError: if the world's module cannot be imported here.
    """
    if name not in _WORLDS:
        raise UnknownNameError(
            f"unknown world {name!r}; known: {', '.join(known_worlds())}",
            name=str(name),
            known=known_worlds(),
        )
    factory = _resolve(name)
    arguments: dict[str, Any] = {"num_envs": num_envs, "seed": seed, "noise": noise, **kwargs}
    if obs_mode is not None:
        arguments["obs_mode"] = obs_mode
    _check_arguments(name, factory, arguments)
    return factory(**arguments)


def _check_arguments(name: str, factory: WorldFactory, arguments: dict[str, Any]) -> None:
    try:
        parameters = inspect.signature(factory).parameters
    except (TypeError, ValueError):  # pragma: no cover - builtins without a signature
        return
    if any(p.kind is inspect.Parameter.VAR_KEYWORD for p in parameters.values()):
        return
    unknown = sorted(set(arguments) - set(parameters))
    if unknown:
        raise ConfigError(
            f"world {name!r} takes no parameter(s) {', '.join(unknown)}; it takes: "
            f"{', '.join(p for p in parameters if p != 'self')}"
        )
