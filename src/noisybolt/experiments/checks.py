"""Checks of a run's specs on a world whose product can be explored: routes and scales.

Used by ``noisybolt check``, ``noisybolt train`` and sweeps (trials take the same scale a
``train`` of theirs would), so the compliance scheme's scale is the same whichever way a
run is started. The Python API's :class:`~noisybolt.agents.training.TrainConfig` (a lower
layer) takes the scale from the world's return bounds; :func:`with_exact_scale` refines it.

Example:
    >>> from noisybolt.agents.training import DetectorConfig, TrainConfig
    >>> config = TrainConfig.create(specs=["F(bottom_left_corner)"],
    ...                             detector=DetectorConfig(kind="oracle"))
    >>> round(config.reward_scale, 2), round(with_exact_scale(config, log=None).reward_scale, 2)
    (345.95, 34.45)
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
    from noisybolt.agents.training import TrainConfig
    from noisybolt.experiments.optimal import OptimalResult

__all__ = [
    "check_worlds", "exact_scale", "goal_feasibility", "tabular_settings", "with_exact_scale",
]  # fmt: skip


def _world(config: TrainConfig) -> Any:
    from noisybolt.envs import make_world

    return make_world(config.world, num_envs=1, seed=0, **config.world_settings)


def tabular_settings(config: TrainConfig, world: Any = None) -> dict[str, Any] | None:
    """The planner's world settings for ``config``'s world (``world``, if built already),
    or None if it is not tabular."""
    from noisybolt.experiments.optimal import tabular_gridworld_settings

    return tabular_gridworld_settings(_world(config) if world is None else world)


def goal_feasibility(config: TrainConfig) -> OptimalResult | None:
    """The best compliant goal-reaching episode on a world whose
    product can be explored; None for other worlds."""
    from noisybolt.experiments.optimal import optimal_constrained_return

    settings = tabular_settings(config)
    if settings is None:
        return None
    formulas = [spec.formula for spec in config.spec_objects()]
    try:
        return optimal_constrained_return(formulas, require_goal=True, **settings)
    except UnknownFluentError:
        return None  # training refuses the spec, naming the world's fluents


def exact_scale(config: TrainConfig) -> float | None:
    """The compliance scale computed on the world's product
    (:func:`~noisybolt.experiments.optimal.exact_compliance_scale`), below the bound the
    config holds; None where the product cannot be explored or no compliant episode
    reaches the goal (the bound then stands)."""
    from noisybolt.envs.bounds import world_return_bounds
    from noisybolt.experiments.optimal import exact_compliance_scale

    if config.reward != "compliance" or config.reward_scale is None:
        return None
    world = _world(config)
    settings = tabular_settings(config, world)
    if settings is None:
        return None
    bounds = world_return_bounds(world)
    floor = 0.1 * bounds.width if bounds is not None else 1.0
    formulas = [spec.formula for spec in config.spec_objects()]
    gamma = float(config.hyperparams.get("gamma", 0.99))
    try:
        return exact_compliance_scale(
            formulas,
            gamma=gamma,
            floor=floor,
            cap=float(config.reward_scale),
            pay_on_change=config.pay_on_change,
            **settings,
        )
    except UnknownFluentError:
        return None  # training refuses the spec, naming the world's fluents


def with_exact_scale(config: TrainConfig, log: Callable[[str], None] | None = print) -> TrainConfig:
    """``config`` with its compliance scale computed on the product where that is possible
    (unchanged otherwise, or under the paper scheme); ``log`` says which it chose."""
    scale = exact_scale(config)
    if scale is None:
        return config
    if log is not None:
        log(
            f"compliance scale computed on the {config.world}'s product: {scale:g} (the bound "
            f"from its return range: {config.reward_scale:g})"
        )
    return config.override({"bolt.reward_scale": scale})


def check_worlds(configs: Mapping[str, TrainConfig]) -> None:
    """Builds each distinct world of ``configs`` once and compiles each config's specs over
    its fluents (cheap: unknown worlds, noise models and fluents are found before a sweep
    runs anything); a classifier file named must exist.

    Raises:
        ConfigError: naming the config (its key in ``configs``) and what is wrong.
    """
    from noisybolt.agents.detectors import user_detector
    from noisybolt.agents.sections import is_detector_factory
    from noisybolt.logic import compile_ltlf

    fluents: dict[str, tuple[str, ...]] = {}
    cameras: dict[str, Any] = {}
    detectors: set[tuple[str, str, int]] = set()
    for name, config in configs.items():
        key = json.dumps([config.world, config.world_settings], sort_keys=True, default=str)
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
