"""Resolving a run's config: what only playing the world can tell.

:func:`resolve` is the one resolver every door calls (``train()``, ``noisybolt train``,
``noisybolt check``, sweeps and ``reproduce``); a :class:`~noisybolt.runs.config.TrainConfig`
is data, and building one plays no world. It asks two things of the world, answered from
the world's name and settings:

- :func:`small_integer_image_top`: whether a user's world's uint8 "images" are small
  integers (MiniGrid's symbolic grid) rather than pixels;
- :func:`choose_compliance_scale`: the ``compliance`` scheme's scale: exact on the
  product of a tabular world and the specs' DFAs (:mod:`noisybolt.bolt.product`), else
  from the world's declared return bounds, else from bounds estimated by seeded random
  play (with an :class:`~noisybolt.errors.EstimatedBoundsWarning`).
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import replace
from typing import Any, NamedTuple

import gymnasium as gym
import numpy as np

from noisybolt.bolt import compliance_scale
from noisybolt.bolt.constraint_choices import (
    WAIT,
    budget_anneal,
    price_search,
    start_price,
)
from noisybolt.bolt.product import exact_compliance_scale
from noisybolt.bolt.schemes import COMPLIANCE_MARGIN
from noisybolt.envs import make_world
from noisybolt.envs.bounds import estimate_return_bounds, world_return_bounds
from noisybolt.envs.gridworld_tabular import tabular_model
from noisybolt.envs.registry import is_factory_path
from noisybolt.errors import EstimatedBoundsWarning, SmallIntegerImagesWarning
from noisybolt.logic import compile_ltlf
from noisybolt.runs.config import TrainConfig
from noisybolt.runs.world_checks import check_world_fits

__all__ = [
    "ESTIMATE_STEPS",
    "EXACT_FLOOR_SHARE",
    "SMALL_INTEGER_IMAGE_MAX",
    "ScaleChoice",
    "choose_compliance_scale",
    "compliance_scale_choice",
    "resolve",
    "small_integer_image_top",
]

#: The largest value an image observation may show in random play and still be read as
#: small integers (MiniGrid's symbolic grid: object, colour and state indices, <= 10),
#: not as pixels.
SMALL_INTEGER_IMAGE_MAX = 31
#: Random-play steps (8 envs together) behind a world's estimated return bounds.
ESTIMATE_STEPS = 4096
#: The exact scale's floor, as a share of the width of the world's returns: what a spec
#: the shortest route already follows is still paid for staying on it.
EXACT_FLOOR_SHARE = 0.1


def small_integer_image_top(world: str, world_kwargs: Mapping[str, Any]) -> int | None:
    """The largest value a world's uint8 ``[H, W, C]`` image observation shows at reset
    and in 64 steps of seeded random play (2 envs); None for any other observation.

    SB3 takes any uint8 ``[H, W, C]`` Box for pixels and divides it by 255; MiniGrid's
    symbolic grid divided so reaches the network as values under 0.04, and PPO then
    barely learns (the MiniGrid example reached goal and compliance 100 % at 40k frames
    with the integers kept). A top of at most :data:`SMALL_INTEGER_IMAGE_MAX` means the
    integers should be kept.
    """
    probe: Any = make_world(world, num_envs=2, seed=0, **world_kwargs)
    try:
        space = probe.single_observation_space
        if not (
            isinstance(space, gym.spaces.Box) and space.dtype == np.uint8 and len(space.shape) == 3
        ):
            return None
        obs, _ = probe.reset(seed=0)
        probe.action_space.seed(0)
        top = int(np.max(obs))
        for _ in range(64):
            obs, *_ = probe.step(probe.action_space.sample())
            top = max(top, int(np.max(obs)))
        return top
    finally:
        probe.close()


class ScaleChoice(NamedTuple):
    """The ``compliance`` scheme's scale for a run, and where it came from.

    Attributes:
        scale: what each spec's acceptance is worth.
        bound: the scale from the world's return bounds (declared, or estimated by random
            play): enough whatever the world, and the cap of the exact scale.
        exact: ``scale`` was computed on the product of the tabular world and the specs'
            DFAs (:func:`noisybolt.bolt.product.exact_compliance_scale`).
        estimated: the bounds behind ``bound`` were estimated by random play.
    """

    scale: float
    bound: float
    exact: bool
    estimated: bool


def choose_compliance_scale(
    world: str,
    settings: Mapping[str, Any],
    *,
    formulas: Sequence[str],
    gamma: float,
    pay_on_change: bool,
    clipped: bool = False,
    check: Callable[[Any], None] | None = None,
) -> ScaleChoice:
    """The ``compliance`` scale of a run on ``world`` (built with ``settings``).

    Exact on the product where the world is tabular (the gridworld) and a compliant
    episode reaches its goal; else :func:`~noisybolt.bolt.compliance_scale` of the
    world's declared return bounds; else of bounds estimated by seeded random play, with
    an :class:`~noisybolt.errors.EstimatedBoundsWarning`.

    With ``clipped`` (``world.clip_reward``) the learner is paid the game's rewards
    clipped to their sign, so the bounds are those of the clipped return (Breakout: 0 to
    216 bricks, not its 864 points), and the product (which plans on the world's own
    rewards) is not used.

    Args:
        world: the world's name or factory path.
        settings: what the world is built with (``world.kwargs`` and its conventions).
        formulas: the specs' LTLf formulas.
        gamma: the learner's discount (the exact scale makes its optimum comply).
        pay_on_change: the scheme's timing (``bolt.pay_on_change``).
        clipped: the learner is paid rewards clipped to their sign.
        check: called with the built world before anything costly (random play, the
            product): the run's cheap checks (:func:`~noisybolt.runs.world_checks.
            check_world_fits`), so a spec or a space that cannot run is refused first.
    """
    probe: Any = make_world(world, num_envs=1, seed=0, **settings)
    try:
        if check is not None:
            check(probe)
        bounds = world_return_bounds(probe, clipped=clipped)
        model = None if clipped else tabular_model(probe)
        fluents = tuple(probe.fluent_names)
    finally:
        probe.close()
    estimated = bounds is None
    if bounds is None:
        bounds = _estimated_bounds(world, settings, clipped=clipped)
    bound = compliance_scale(bounds)
    if model is None:
        return ScaleChoice(scale=bound, bound=bound, exact=False, estimated=estimated)
    exact = exact_compliance_scale(
        model,
        [compile_ltlf(formula, fluents) for formula in formulas],
        gamma=gamma,
        floor=EXACT_FLOOR_SHARE * bounds.width if bounds.width > 0 else 1.0,
        cap=bound,
        pay_on_change=pay_on_change,
    )
    if exact is None:  # no compliant episode reaches the goal: the bound stands
        return ScaleChoice(scale=bound, bound=bound, exact=False, estimated=estimated)
    return ScaleChoice(scale=exact, bound=bound, exact=True, estimated=estimated)


def resolve(config: TrainConfig, *, log: Callable[[str], None] | None = None) -> TrainConfig:
    """``config`` with what only its world can tell decided: the one resolver every door
    calls.

    ``train()``, ``noisybolt train``, ``noisybolt check``, sweeps and ``reproduce`` resolve
    a config here, so a config is paid the same whichever door it came in by. What is decided:

    - the scale of a scheme that pays one (``bolt.reward_scale``, where None): on a
      tabular world (the gridworld), exact on the product of the world and the specs'
      DFAs, else from the world's return bounds (declared, or estimated by random play);
      the specs and spaces are checked against the world before anything costly
      (:func:`compliance_scale_choice`); under the ``constrained`` scheme, with it how the
      multiplier moves (``bolt.constraint.lr``, ``kp``, ``release``, ``window``, where not
      given: :func:`~noisybolt.bolt.constraint_choices.price_search`: searched where a spec
      is kept by doing nothing and the scale is from bounds, else asserted; the price's
      span ``decades`` 0, linear), and the budget's anneal
      (``bolt.constraint.anneal``, where not given:
      :func:`~noisybolt.bolt.constraint_choices.budget_anneal`: none, the budget at the limit
      from the first rollout, where no spec is kept by doing nothing and the scale is
      exact, else over half the run) and the price the multiplier starts learning from
      (``bolt.constraint.start``: :func:`~noisybolt.bolt.constraint_choices.start_price`, in full
      on those same runs, else ``initial``);
      how long the multiplier waits for the world's returns to differ
      (``bolt.constraint.wait``, where not given: :data:`~noisybolt.bolt.constraint_choices.WAIT`),
      and whether the price's scale is kept above the returns seen in training
      (``bolt.constraint.rescale``: the compliance margin where the bounds were estimated
      by random play, else 0);
    - for a user's world (a factory path) whose uint8 images are small integers,
      ``algorithm.hyperparams.policy_kwargs.normalize_images`` false (with a
      :class:`~noisybolt.errors.SmallIntegerImagesWarning`), unless the hyperparameters
      name it.

    Idempotent: what a config names (a scale, ``normalize_images``) is kept, so a resolved
    config comes back unchanged. A config is data; this is where the world is played.

    Args:
        log: told where a scale computed on the product came from.

    Example:
        >>> both = "F(top_right_corner) & F(bottom_left_corner)"
        >>> from noisybolt.runs.config import TrainConfig
        >>> config = resolve(TrainConfig.build({"bolt.specs": [both]}))  # the gridworld: exact
        >>> round(config.bolt.reward_scale, 2), resolve(config) is config
        (58.45, True)
    """
    params = config.algorithm.hyperparams
    policy_kwargs = dict(params.get("policy_kwargs") or {})
    if is_factory_path(config.world_config.name) and "normalize_images" not in policy_kwargs:
        top = small_integer_image_top(config.world_config.name, config.world_config.kwargs)
        if top is not None and top <= SMALL_INTEGER_IMAGE_MAX:
            kept = {**policy_kwargs, "normalize_images": False}
            algorithm = replace(config.algorithm, hyperparams={**params, "policy_kwargs": kept})
            config = replace(config, algorithm=algorithm)
            warnings.warn(
                f"the {config.world_config.name!r} world's image observations are small integers "
                "(at "
                f"most {top} in random play, like MiniGrid's symbolic grid), not pixels: "
                "they reach the network as they are (policy_kwargs.normalize_images=false; "
                "pass --hp policy_kwargs.normalize_images=true to divide them by 255 after "
                "all)",
                SmallIntegerImagesWarning,
                stacklevel=3,
            )
    if config.bolt.reward != "paper" and config.bolt.reward_scale is None:
        choice = compliance_scale_choice(config)
        bolt = replace(config.bolt, reward_scale=choice.scale)
        if bolt.reward == "constrained":
            constraint = dict(bolt.constraint)
            idle_keeps = _kept_by_doing_nothing(config)
            if constraint.get("decades") is None:
                # The price is linear in the multiplier (a saved run keeps its span).
                constraint["decades"] = 0.0
            if constraint.get("anneal") is None:
                # The budget's anneal: none where every spec asks for something and the
                # scale is exact (a detour priced before the direct route settles).
                constraint["anneal"] = budget_anneal(
                    exact=choice.exact, kept_by_doing_nothing=idle_keeps
                )
            if constraint.get("start") is None:
                # The price asked once the multiplier learns: in full where no spec is
                # kept by doing nothing and the scale is exact (a detour priced as the
                # agent first meets it, at a price known to be just enough).
                constraint["start"] = start_price(
                    exact=choice.exact,
                    kept_by_doing_nothing=idle_keeps,
                    initial=float(constraint.get("initial", 0.0)),
                )
            if constraint.get("wait") is None:
                # A fresh run waits for the world's returns to differ (WAIT); a saved one
                # (its scale named) keeps what it was: no wait where the key is absent.
                constraint["wait"] = WAIT
            search = price_search(exact=choice.exact, kept_by_doing_nothing=idle_keeps)
            for key, value in search.items():
                # How the multiplier moves: searched where a price could teach standing
                # still on a scale from bounds, else asserted. A saved run keeps what it
                # names (absent keys: as before).
                if constraint.get(key) is None:
                    constraint[key] = value
            if constraint.get("rescale") is None:
                # The price's scale kept above the returns seen where random play's
                # estimate is all the run knows of them.
                constraint["rescale"] = COMPLIANCE_MARGIN if choice.estimated else 0.0
            bolt = replace(bolt, constraint=constraint)
        config = replace(config, bolt=bolt)
        if choice.exact and log is not None:
            log(
                f"compliance scale computed on the {config.world_config.name}'s product: "
                f"{choice.scale:g} "
                f"(the bound from its return range: {choice.bound:g})"
            )
    return config


def _kept_by_doing_nothing(config: TrainConfig) -> bool:
    """Whether an episode without events keeps one of the run's specs (its DFA accepts the
    empty trace): then standing still complies with it, and a price can teach that."""
    return any(
        bool(dfa.accepting[dfa.initial_state])
        for dfa in (compile_ltlf(str(spec["formula"])) for spec in config.bolt.specs)
    )


def compliance_scale_choice(config: TrainConfig) -> ScaleChoice:
    """The scale :func:`resolve` gives ``config`` where it names none (whatever it names),
    with the bound from the world's returns beside it; the run's cheap checks
    (:func:`~noisybolt.runs.world_checks.check_world_fits`: spaces, specs over the
    world's fluents) come first.

    Raises:
        ConfigError, UnknownFluentError, UnsatisfiableSpecError, SpecSyntaxError: as
            :func:`~noisybolt.runs.world_checks.check_world_fits`.
    """
    return choose_compliance_scale(
        config.world_config.name,
        config.world_settings,
        formulas=[str(spec["formula"]) for spec in config.bolt.specs],
        gamma=float(config.algorithm.hyperparams.get("gamma", 0.99)),
        pay_on_change=config.bolt.pay_on_change,
        clipped=config.world_config.clip_reward,
        check=lambda world: check_world_fits(config, world),
    )


def _estimated_bounds(world: str, settings: Mapping[str, Any], *, clipped: bool) -> Any:
    """Bounds on a world's returns from seeded random play, said so in a warning.

    A user's env rarely knows its bounds; refusing to train would send every new user to
    a flag. Random play's returns are an estimate, said so, not a bound."""
    env: Any = make_world(world, num_envs=8, seed=0, **settings)
    try:
        estimate = estimate_return_bounds(env, steps=ESTIMATE_STEPS, seed=0, clipped=clipped)
    finally:
        env.close()
    if clipped:
        what = "its episodes' returns with the rewards clipped to their sign (world.clip_reward)"
        advice = "pass --reward-scale S (S above the widest gap between two episodes' "
        advice += "clipped returns)"
    else:
        what = "its episodes' returns"
        advice = "declare the bounds (FluentLabels(..., return_bounds=(least, most))) or "
        advice += "pass --reward-scale S (S above the widest gap between two episodes' returns)"
    warnings.warn(
        f"the {world!r} world declares no bounds on {what}; the compliance scale "
        f"{compliance_scale(estimate.bounds):g} rests on bounds {estimate.describe()}. A "
        f"trained agent may return more than random play: {advice}",
        EstimatedBoundsWarning,
        stacklevel=4,
    )
    return estimate.bounds
