"""What a run's config says to its user: the reward scheme in one line, what complying
with each spec pays, and the warning where an on-policy learner would see large rewards
unnormalised."""

from __future__ import annotations

import warnings
from typing import Any

from noisybolt.agents.hyperparams import SPLIT
from noisybolt.errors import UnnormalizedRewardWarning
from noisybolt.runs.config import ON_POLICY, TrainConfig

__all__ = [
    "UNNORMALIZED_WORTH_LIMIT",
    "describe_scheme",
    "spec_worths",
    "warn_of_unnormalized_rewards",
]


def describe_scheme(config: TrainConfig) -> str:
    """One line saying how the run's bolt pays (the scale chosen, for ``compliance``)."""
    if not config.bolt.bolted:
        return "unbolted: the specs are tracked for compliance only, with no rewards"
    if config.bolt.reward == "paper":
        return "reward scheme: paper (each spec's terminal reward on every accepting step)"
    if config.bolt.reward == "constrained":
        limit = config.bolt.cost_limit
        return (
            f"reward scheme: constrained, the world's return subject to at most "
            f"{limit.cost_limit:g} unsatisfied spec(s) an episode on average (as the bolt "
            f"sees them; --cost-limit to change it): the specs are paid as under the "
            f"compliance scheme ({'with' if config.bolt.shaping else 'without'} progress "
            f"shaping), at a learned multiplier (0 to 1, from {limit.initial:g}) times "
            f"{spec_worths(config)} (scale {config.bolt.reward_scale:g}), which rises only while "
            "the episodes' cost exceeds the budget"
        )
    shaping = "with" if config.bolt.shaping else "without"
    when = (
        "as soon as it accepts (taken back if it stops; nothing where an episode starts)"
        if config.bolt.pay_on_change
        else "at the episode's end"
    )
    text = (
        f"reward scheme: compliance, {shaping} progress shaping; complying is worth, {when}, "
        f"{spec_worths(config)} (scale {config.bolt.reward_scale:g}; "
        "--reward-scale, or a spec's own reward_scale, to change it)"
    )
    if config.algorithm.hyperparams.get("normalize_reward") == SPLIT:
        weight = config.algorithm.hyperparams.get("bolt_weight")
        text += (
            "; the learner sees the bolt's rewards normalised apart from the world's "
            "(normalize_reward split): the scale does not change what it learns, and "
            "complying is traded against the world's return rather than put first, "
            + (
                "the two weighed equally (--hp bolt_weight to weigh the bolt's more)"
                if weight is None
                else f"the bolt's weighed {weight:g} times the world's (bolt_weight; the "
                "learner's rewards keep their size, their mix changes)"
            )
        )
    return text


#: A compliance worth above which an on-policy learner without ``normalize_reward`` is
#: warned (:func:`warn_of_unnormalized_rewards`); the learners' own rewards are ~1.
UNNORMALIZED_WORTH_LIMIT = 10.0


def warn_of_unnormalized_rewards(config: TrainConfig) -> None:
    """Warns (:class:`~noisybolt.errors.UnnormalizedRewardWarning`) where PPO or A2C is
    paid the compliance scheme's rewards, more than :data:`UNNORMALIZED_WORTH_LIMIT` a
    spec, with ``normalize_reward`` off.

    Measured (CartPole, ``F(far_left)``, scale 550, 100k frames): PPO, seeds 0 and 1,
    compliance 25 % and 44 % without it, 88 % and 88 % with it; A2C, seed 0, 0 % and
    94 %. On Breakout (scale 950) PPO's policy stood still without it (approximate KL ~0,
    value loss ~10^4). DQN is not warned: unnormalised it failed on CartPole (0 % against
    100 %) but followed 23 of the gridworld suite's 24 specs, whose world pays rewards as
    large as the scale.
    """
    if (
        not config.bolt.bolted
        or config.bolt.reward == "paper"
        or config.algorithm.name not in ON_POLICY
    ):
        return
    if config.algorithm.hyperparams.get("normalize_reward"):
        return
    worth = max(spec.terminal_reward for spec in config.spec_objects())
    if worth <= UNNORMALIZED_WORTH_LIMIT:
        return
    warnings.warn(
        f"the compliance scheme pays up to {worth:g} a spec, and {config.algorithm.name.upper()}'s "
        "rewards are not normalised (normalize_reward false): value targets that large "
        "can swamp the policy's share of each gradient step (on CartPole and Breakout the "
        "policy barely learnt). "
        "Pass --hp normalize_reward=true (or a smaller --reward-scale)",
        UnnormalizedRewardWarning,
        stacklevel=2,
    )


def spec_worths(config: Any) -> str:
    """What complying with each spec pays: one figure when all are paid alike, else each
    spec's (one with a ``reward_scale`` of its own, from ``--spec-set`` or a specs file).

    Example:
        >>> from types import SimpleNamespace as N
        >>> spec = lambda name, worth: N(name=name, formula=name, terminal_reward=worth)
        >>> spec_worths(N(spec_objects=lambda: [spec("edge", 20.0), spec("tr", 20.0)]))
        '20 per spec'
        >>> spec_worths(N(spec_objects=lambda: [spec("edge", 20.0), spec("tr", 50.0)]))
        'edge 20, tr 50'
    """
    specs = config.spec_objects()
    worths = {spec.terminal_reward for spec in specs}
    if len(worths) == 1:
        return f"{worths.pop():g} per spec"
    return ", ".join(f"{spec.name or spec.formula} {spec.terminal_reward:g}" for spec in specs)
