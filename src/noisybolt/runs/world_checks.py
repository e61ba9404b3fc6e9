"""The cheap checks of a run against its world, made before anything costly: the
agent can read the world's observation, the algorithm can act in its actions, and every
spec compiles over its fluents (named errors listing the world's fluents). They run
before the compliance scale's random play (:func:`noisybolt.runs.resolution.resolve`) and
before a classifier is trained (:func:`~noisybolt.runs.environments.prepare_bolt`), so
this module imports neither: a run's config reaches it as :class:`CheckedRun`, the few
settings the checks read.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from types import SimpleNamespace
from typing import Any, Protocol

from noisybolt.agents.extractor import check_agent_observation
from noisybolt.agents.hyperparams import check_action_space
from noisybolt.bolt.spec import Spec, check_satisfiable, vacuous_message
from noisybolt.errors import SpecSyntaxError, UnknownFluentError
from noisybolt.logic import compile_ltlf
from noisybolt.runs.sections import AlgorithmConfig, BoltConfig, WorldConfig

__all__ = ["CheckedRun", "check_specs_against_world", "check_world_fits", "check_world_spaces"]


class CheckedRun(Protocol):
    """What the checks read of a run's config
    (:class:`~noisybolt.runs.config.TrainConfig` is one)."""

    @property
    def world_config(self) -> WorldConfig:
        """The world section (``world_config.name``: its name or factory path)."""

    @property
    def algorithm(self) -> AlgorithmConfig:
        """The algorithm section (``algorithm.name``)."""

    @property
    def bolt(self) -> BoltConfig:
        """The bolt section (``bolt.specs``: the specs as given, their fields)."""

    def spec_objects(self) -> list[Spec]:
        """The specs as the bolt pays them."""


def check_world_spaces(config: CheckedRun, world: Any) -> None:
    """The agent can read the world's observation and the algorithm act in its actions.

    Raises:
        ConfigError: an observation the agents cannot read (a Dict, a 2-D Box), or an
            algorithm that cannot act there (DQN on continuous actions).
    """
    agent_space = getattr(world, "single_observation_space", None)
    if agent_space is not None:
        check_agent_observation(agent_space, world=config.world_config.name)
    actions = getattr(world, "single_action_space", None)
    if actions is not None:
        check_action_space(config.algorithm.name, actions, world=config.world_config.name)


def check_world_fits(config: CheckedRun, world: Any) -> None:
    """The cheap checks of a run against its world, for before anything costly (the
    compliance scale's random play, a classifier's training): the agent can read the
    world's observation and the algorithm act in its actions, and every spec compiles
    over its fluents.

    Raises:
        ConfigError: an observation the agents cannot read, or an algorithm that cannot
            act there; UnknownFluentError, UnsatisfiableSpecError, SpecSyntaxError: a spec.
    """
    check_world_spaces(config, world)
    # The specs as given: their rewards may wait for the scale this check comes before.
    given = [
        SimpleNamespace(formula=spec["formula"], name=spec.get("name") or spec["formula"])
        for spec in config.bolt.specs
    ]
    check_specs_against_world(config, tuple(world.fluent_names), log=lambda _: None, specs=given)


def check_specs_against_world(
    config: CheckedRun,
    fluent_names: Sequence[str],
    *,
    log: Callable[[str], None] = print,
    specs: Sequence[Any] | None = None,
) -> list[Any]:
    """Compiles every spec over the world's fluents (errors list the world's fluents).

    Raises:
        UnsatisfiableSpecError: no trace satisfies a spec. A spec that every trace
            satisfies gets a warning through ``log`` (the bolt would ask for nothing).
    """
    dfas = []
    specs_checked = list(config.spec_objects() if specs is None else specs)
    for spec in specs_checked:
        try:
            dfas.append(compile_ltlf(spec.formula, fluent_names))
        except RecursionError:
            raise SpecSyntaxError(
                f"spec {spec.name!r} is nested too deeply to compile; write it with fewer "
                "nested operators",
                formula=spec.formula,
            ) from None
        except UnknownFluentError as error:
            raise UnknownFluentError(
                f"spec {spec.name!r} uses fluent(s) {list(error.unknown)} that the world "
                f"{config.world_config.name!r} does not have; this world's fluents are "
                f"{list(fluent_names)}",
                unknown=error.unknown,
                known=tuple(fluent_names),
            ) from None
    for spec in check_satisfiable(specs_checked, dfas, world=config.world_config.name):
        log(f"warning: {vacuous_message(spec)}")
    return dfas
