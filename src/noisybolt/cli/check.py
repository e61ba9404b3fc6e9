"""``noisybolt check``: what a spec asks of a world, before any training.

For each spec: whether it is satisfiable (else training is refused), whether every trace
satisfies it (a warning: the bolt asks for nothing), its DFA's size and how many steps
its start is from acceptance. Where the world's product can be explored exactly (the
gridworld), also: whether some episode reaches the goal while complying, its return
R^c_max beside the unconstrained R_max, the ``compliance`` scheme's scale computed on
the product, and whether the optimal policy of that scheme complies.
"""

from __future__ import annotations

import argparse
import warnings
from typing import Any

__all__ = ["register"]


def register(subparsers: Any) -> None:
    """Adds ``noisybolt check``."""
    check = subparsers.add_parser(
        "check",
        help="check specs against a world: satisfiable, vacuous, a compliant route to the goal",
        description=__doc__.split("\n\n")[1] if __doc__ else None,
    )
    check.add_argument(
        "--world",
        default=None,
        help="world name or factory path package.module:factory (default: the gridworld)",
    )
    check.add_argument(
        "--spec", action="append", default=[], metavar="NAME|FORMULA", help="repeat for several"
    )
    check.add_argument("--specs-file", default=None, help="a YAML file of specs")
    check.add_argument("--algo", default="ppo", help="whose discount the scheme is planned for")
    check.add_argument("--noise", default=None, help="the bolt camera's noise (world default)")
    check.add_argument(
        "--detector",
        default="oracle",
        help="the detector to build and check against the world: oracle (default), "
        "synthetic, or your own as package.module:function (a classifier is trained by "
        "`noisybolt train`, not here)",
    )
    check.add_argument(
        "--reward-scale",
        type=float,
        default=None,
        help="the compliance scheme's scale to check (default: the world's own)",
    )
    check.set_defaults(func=_check)


def _checked_detector(kind: str) -> str:
    from noisybolt.errors import ConfigError

    if kind == "classifier":
        raise ConfigError(
            "check builds no classifier (training one takes minutes): check with the oracle "
            "(the default), and `noisybolt train --detector classifier` trains and checks it"
        )
    return kind


def _check(args: argparse.Namespace) -> int:
    from noisybolt.envs.registry import DEFAULT_WORLD
    from noisybolt.errors import ConfigError, EstimatedBoundsWarning
    from noisybolt.experiments.checks import goal_feasibility, tabular_settings
    from noisybolt.experiments.optimal import optimal_unconstrained_return, scheme_optimum
    from noisybolt.logic import distance_to_acceptance
    from noisybolt.runs.config import DetectorConfig, TrainConfig
    from noisybolt.runs.environments import prepare_bolt
    from noisybolt.runs.presentation import spec_worths
    from noisybolt.runs.resolution import compliance_scale_choice, resolve
    from noisybolt.runs.specs import load_specs_file

    args.world = args.world or DEFAULT_WORLD
    specs: list[Any] = list(args.spec)
    if args.specs_file:
        specs += load_specs_file(args.specs_file)
    if not specs:
        raise ConfigError("give at least one --spec (or a --specs-file)")
    common: dict[str, Any] = {
        "world": args.world,
        "specs": specs,
        "algo": args.algo,
        "detector": DetectorConfig(kind=_checked_detector(args.detector)),
        "world_kwargs": {} if args.noise is None else {"noise": args.noise},
    }
    # Resolved as noisybolt train resolves it (the scale it would pay). A world that
    # declares no return bounds gets a scale from random play: say so.
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", EstimatedBoundsWarning)
        config = resolve(TrainConfig.create(**common, reward_scale=args.reward_scale))
    for warning in caught:
        if issubclass(warning.category, EstimatedBoundsWarning):
            print(f"note: {warning.message}")
        else:
            warnings.warn_explicit(
                warning.message, warning.category, warning.filename, warning.lineno
            )
    lines: list[str] = []
    setup = prepare_bolt(config, seed=0, log=lines.append)  # refuses unsatisfiable specs
    if args.detector != "oracle":
        print(
            f"detector {args.detector}: built, matched to the world's fluents "
            f"{list(setup.detector.fluent_names)}"
        )
    for spec, dfa in zip(config.spec_objects(), setup.dfas, strict=True):
        distance = int(distance_to_acceptance(dfa)[dfa.initial_state])
        print(
            f"spec {spec.name!r}: satisfiable; DFA of {dfa.n_states} "
            f"state{'' if dfa.n_states == 1 else 's'}, "
            f"{distance} letter(s) from acceptance at the start"
        )
    for line in lines:
        print(line)
    best = goal_feasibility(config)
    if best is None:
        print(f"world {args.world} cannot be explored exactly here: no route check")
        if config.bolt.reward != "paper":
            print(
                f"compliance scale: {config.bolt.reward_scale:g}; complying is worth "
                f"{spec_worths(config)}"
            )
        return 0
    settings = tabular_settings(config)
    assert settings is not None
    r_max = optimal_unconstrained_return(require_goal=True, **settings)
    if best.value is None:
        print(
            "no episode reaches the goal while complying with every spec: training would "
            "teach the agent to trade the goal for the bolt"
        )
        return 1
    print(
        f"compliant route to the goal: yes, R^c_max {best.value:g} in {best.steps} steps "
        f"(unconstrained R_max {r_max.value:g} in {r_max.steps} steps)"
    )
    assert config.bolt.reward_scale is not None  # resolved: what noisybolt train pays this config
    scale = config.bolt.reward_scale
    bound = compliance_scale_choice(config).bound
    gamma = float(config.algorithm.hyperparams.get("gamma", 0.99))
    formulas = [spec.formula for spec in config.spec_objects()]
    optimum = scheme_optimum(
        formulas, scale=scale, gamma=gamma, pay_on_change=config.bolt.pay_on_change, **settings
    )
    given = "given; " if args.reward_scale is not None else ""
    print(
        f"compliance scheme: scale {scale:g} ({given}bound {bound:g}); its optimal "
        f"policy (gamma {gamma:g}) {'complies' if optimum.complies else 'does NOT comply'}"
        f"{' and reaches the goal' if optimum.reaches_goal else ''} in {optimum.steps} steps"
    )
    if len({spec.terminal_reward for spec in config.spec_objects()}) > 1:
        print(
            f"note: training pays {spec_worths(config)} (specs with a reward_scale of "
            f"their own); the optimum above pays every spec {scale:g}"
        )
    return 0
