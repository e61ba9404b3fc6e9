"""Checks of a run's specs on a world whose product can be explored: routes and scales.

Used by ``noisybolt check`` and ``noisybolt train``. The compliance scale itself is
decided once, by :func:`noisybolt.runs.resolution.resolve` (which every door calls: the
same config is paid the same scale from Python, the CLI, ``check`` and sweeps); what is
left here is what those doors *say* about a world: whether a compliant episode reaches
the goal.

Example:
    >>> from noisybolt.runs.training import DetectorConfig, TrainConfig
    >>> config = TrainConfig.create(specs=["F(bottom_left_corner)"],
    ...                             detector=DetectorConfig(kind="oracle"))
    >>> round(config.bolt.reward_scale, 2), with_exact_scale(config, log=None) is config
    (34.45, True)
    >>> goal_feasibility(config).steps
    8
"""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from noisybolt.errors import ConfigError, NoisyboltError, UnknownFluentError

if TYPE_CHECKING:
    from noisybolt.bolt.product import OptimalResult
    from noisybolt.runs.config import TrainConfig

__all__ = [
    "check_worlds", "exact_scale", "goal_feasibility", "tabular_settings", "with_exact_scale",
]  # fmt: skip


def _world(config: TrainConfig) -> Any:
    from noisybolt.envs import make_world

    return make_world(config.world_config.name, num_envs=1, seed=0, **config.world_settings)


def tabular_settings(config: TrainConfig, world: Any = None) -> dict[str, Any] | None:
    """The planner's world settings for ``config``'s world (``world``, if built already),
    or None if it is not tabular."""
    from noisybolt.envs.gridworld_tabular import tabular_gridworld_settings

    if world is not None:
        return tabular_gridworld_settings(world)
    world = _world(config)
    try:
        return tabular_gridworld_settings(world)
    finally:
        world.close()


def goal_feasibility(config: TrainConfig) -> OptimalResult | None:
    """The best compliant goal-reaching episode on a world whose
    product can be explored; None for other worlds."""
    from noisybolt.experiments.optimal import optimal_constrained_return

    settings = tabular_settings(config)
    if settings is None:
        return None
    formulas = [str(spec["formula"]) for spec in config.bolt.specs]
    try:
        return optimal_constrained_return(formulas, require_goal=True, **settings)
    except UnknownFluentError:
        return None  # training refuses the spec, naming the world's fluents


def exact_scale(config: TrainConfig) -> float | None:
    """The compliance scale computed on the world's product, as :func:`resolve
    <noisybolt.runs.resolution.resolve>` gives it to a config that names none; None where
    the product cannot be explored, no compliant episode reaches the goal (the bound from
    the world's returns then stands), or the scheme pays no scale (``paper``)."""
    from noisybolt.runs.resolution import compliance_scale_choice

    if config.bolt.reward == "paper":
        return None
    choice = compliance_scale_choice(config)
    return choice.scale if choice.exact else None


def with_exact_scale(config: TrainConfig, log: Callable[[str], None] | None = print) -> TrainConfig:
    """:func:`noisybolt.runs.resolution.resolve` (kept for the callers of the days when the
    CLI refined the scale of a config built from Python: every config is resolved alike
    now, and a resolved one comes back unchanged)."""
    from noisybolt.runs.resolution import resolve

    return resolve(config, log=log)


def check_worlds(configs: Mapping[str, TrainConfig]) -> None:
    """Builds each distinct world of ``configs`` once and compiles each config's specs over
    its fluents (cheap: unknown worlds, noise models and fluents are found before a sweep
    runs anything); a classifier file named must exist.

    Raises:
        ConfigError: naming the config (its key in ``configs``) and what is wrong.
    """
    from noisybolt.logic import compile_ltlf
    from noisybolt.runs.detectors import user_detector
    from noisybolt.runs.sections import is_detector_factory

    fluents: dict[str, tuple[str, ...]] = {}
    cameras: dict[str, Any] = {}
    detectors: set[tuple[str, str, int]] = set()
    for name, config in configs.items():
        key = json.dumps(
            [config.world_config.name, config.world_settings], sort_keys=True, default=str
        )
        try:
            if key not in fluents:
                world = _world(config)
                fluents[key] = tuple(world.fluent_names)
                cameras[key] = world.camera_spec
                world.close()
            for spec in config.spec_objects():
                compile_ltlf(spec.formula, fluents[key])  # cached: cheap after the first
            kind, seed = config.detector.kind, config.detector.seed
            if is_detector_factory(kind) and (kind, key, seed) not in detectors:
                # A user's detector is made once per world: one that cannot be made (or
                # lacks a fluent) is named now, not in every trial.
                user_detector(
                    kind,
                    fluent_names=fluents[key],
                    camera_spec=cameras[key],
                    seed=seed,
                    kwargs=config.detector.kwargs,
                )
                detectors.add((kind, key, seed))
        except (NoisyboltError, TypeError) as error:
            raise ConfigError(f"{name}: {error}") from None
        path = config.detector.path
        if config.detector.kind == "classifier" and path and not Path(path).exists():
            raise ConfigError(f"{name}: no classifier file at {path}")
