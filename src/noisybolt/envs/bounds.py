"""What a world's episode can return: the bound the ``compliance`` reward scheme scales from.

A world declares it with a method ``return_bounds() -> ReturnBounds`` (the
:class:`DeclaresReturnBounds` contract): the least and the most one episode's
(undiscounted) environment return can be, from its reward range and horizon. The shipped
worlds declare theirs; a user's Gymnasium env declares them through
``FluentLabels(env, ..., return_bounds=(least, most))``. A world that does not can still
be trained under the ``compliance`` scheme with an explicit scale (``--reward-scale``), or
under ``paper``; without either, :func:`estimate_return_bounds` estimates the bounds from
random play (an estimate, said so when it is used: a trained agent may return more than
random play showed).

A learner that sees the rewards clipped to their sign (the Atari convention,
``world.clip_reward``) is paid another return than the game's score: a world whose
rewards may be clipped declares that return's bounds too, with a method
``clipped_return_bounds() -> ReturnBounds`` (Breakout: one clipped point per brick,
0 to 216, where its score runs to 864). The compliance scale of a run that clips comes
from those (:func:`world_return_bounds` with ``clipped=True``), or from random play with
the rewards clipped.

Example:
    >>> from noisybolt.envs import make_world
    >>> world_return_bounds(make_world("gridworld", num_envs=1))
    ReturnBounds(low=-216.0, high=98.5)
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

import numpy as np

from noisybolt.bolt.schemes import ReturnBounds
from noisybolt.errors import ConfigError

__all__ = [
    "DeclaresReturnBounds",
    "EstimatedBounds",
    "episode_return_bounds",
    "estimate_return_bounds",
    "world_return_bounds",
]

#: How far an estimate from random play is raised above the best return random play showed,
#: in widths of what it showed: a trained agent returns more than random play (reaching a
#: goal random play seldom reaches), while random play's worst episodes (long, costly, cut
#: by the time limit) are already about as bad as a policy's get.
ESTIMATE_MARGIN = 0.5


@runtime_checkable
class DeclaresReturnBounds(Protocol):
    """A world that states the range of its episodes' returns."""

    def return_bounds(self) -> ReturnBounds | None:
        """Bounds on one episode's undiscounted environment return (None: unknown)."""
        ...


def world_return_bounds(world: object, *, clipped: bool = False) -> ReturnBounds | None:
    """The world's declared :class:`ReturnBounds`, or None if it declares none.

    ``clipped``: the bounds of the return of its rewards clipped to their sign
    (``clipped_return_bounds()``), which a world that declares only its score's bounds
    does not state (None): clipping maps the rewards to -1, 0 and 1, so the score's
    bounds say nothing of them.
    """
    if clipped:
        declared = getattr(world, "clipped_return_bounds", None)
        return declared() if callable(declared) else None
    return world.return_bounds() if isinstance(world, DeclaresReturnBounds) else None


def episode_return_bounds(
    *, step_reward: tuple[float, float], horizon: int, bonus: tuple[float, float] = (0.0, 0.0)
) -> ReturnBounds:
    """Bounds from a per-step reward range, a horizon and a once-per-episode bonus range.

    Args:
        step_reward: ``(least, most)`` reward of one step.
        horizon: the most steps an episode takes (it takes at least one).
        bonus: ``(least, most)`` extra reward paid at most once (a goal), 0 if never.

    Example:
        >>> episode_return_bounds(step_reward=(-1.5, -1.5), horizon=144, bonus=(0.0, 100.0))
        ReturnBounds(low=-216.0, high=98.5)
    """
    lo, hi = step_reward
    low = min(lo, lo * horizon) + min(bonus[0], 0.0)
    high = max(hi, hi * horizon) + max(bonus[1], 0.0)
    return ReturnBounds(low, high)


@dataclass(frozen=True)
class EstimatedBounds:
    """Return bounds estimated from random play (see :func:`estimate_return_bounds`).

    Attributes:
        bounds: the estimate, raised by :data:`ESTIMATE_MARGIN` widths on top.
        episodes: episodes that ended during random play.
        steps: environment steps played (all envs together).
        observed: ``(least, most)`` return of the episodes that ended, or of the steps
            played when none ended.
        longest: the longest episode seen, in steps (ended or still running at the end).
    """

    bounds: ReturnBounds
    episodes: int
    steps: int
    observed: tuple[float, float]
    longest: int

    def describe(self) -> str:
        """One line for a log: the estimate and what it rests on."""
        lo, hi = self.observed
        text = (
            f"estimated from {self.episodes} random-play episodes ({self.steps} steps; returns "
            f"{lo:g} to {hi:g}, longest {self.longest} steps), raised to "
            f"[{self.bounds.low:g}, {self.bounds.high:g}]"
        )
        if lo == hi and self.bounds.width > 0:
            # e.g. Acrobot: -1 every step, every random episode cut at the time limit.
            text += (
                " (random play returned the same every time: the width is one step's reward"
                " times the longest episode, as an agent may end an episode sooner)"
            )
        elif lo == hi:
            # e.g. a sparse goal random play never reached: the gap a trained agent can
            # open is unknown, and the scale falls back to 1.
            text += " (random play returned the same every time: it says nothing of the gap)"
        return text


def estimate_return_bounds(
    world: Any, *, steps: int = 4096, seed: int = 0, clipped: bool = False
) -> EstimatedBounds:
    """Bounds on an episode's return estimated from uniformly random play of ``world``.

    For a world that declares none: the range of the returns of the episodes random play
    ends (with same-step autoreset, as the vector worlds step), its top raised by
    :data:`ESTIMATE_MARGIN` times its width, the width never less than one step's reward
    range. A world whose rewards are dense and grow with skill (a trained agent returning
    many times what random play does, as in CartPole) is not bounded this way: declare its
    bounds (``return_bounds=``) or give the scale.
    When no episode ends within the budget, the steps played stand in for an episode.
    It is an estimate, not a bound: a trained agent may return more than random play
    showed, so the ``compliance`` scheme built on it says so, and a world that knows its
    bounds should declare them.

    Args:
        world: a vectorised labelled world (``num_envs``, ``action_space``, ``reset``,
            ``step``), as :func:`noisybolt.envs.make_world` builds.
        steps: environment steps to play, all envs together.
        seed: seeds the world's reset and the sampled actions.
        clipped: the bounds of the rewards clipped to their sign (what a learner with
            ``world.clip_reward`` is paid).

    Raises:
        ConfigError: a non-positive ``steps``, or rewards that are not finite.

    Example:
        >>> from noisybolt.envs import make_world
        >>> estimate = estimate_return_bounds(make_world("gridworld", num_envs=4), steps=2048)
        >>> estimate.bounds.low < -100 < estimate.bounds.high
        True
    """
    if isinstance(steps, bool) or not isinstance(steps, int) or steps < 1:
        raise ConfigError(f"steps must be a positive integer, got {steps!r}")
    n = int(world.num_envs)
    world.reset(seed=seed)
    world.action_space.seed(seed)
    running = np.zeros(n)  # [n_envs] return of the episode under way
    length = np.zeros(n, dtype=np.int64)  # [n_envs] its steps so far
    returns: list[float] = []
    longest = 0
    step_lo, step_hi = np.inf, -np.inf
    played = 0
    for _ in range(max(1, steps // n)):
        _, reward, terminated, truncated, _ = world.step(world.action_space.sample())
        reward = np.asarray(reward, dtype=np.float64).reshape(n)
        if not np.all(np.isfinite(reward)):
            raise ConfigError(f"the world paid a non-finite reward in random play: {reward}")
        if clipped:
            reward = np.sign(reward)
        step_lo, step_hi = min(step_lo, float(reward.min())), max(step_hi, float(reward.max()))
        running += reward
        length += 1
        played += n
        ended = np.asarray(terminated, dtype=bool) | np.asarray(truncated, dtype=bool)
        if ended.any():
            returns.extend(running[ended].tolist())
            longest = max(longest, int(length[ended].max()))
            running[ended] = 0.0
            length[ended] = 0
    longest = max(longest, int(length.max()))
    # No episode ended: what the steps played returned stands in for an episode's return.
    seen = returns if returns else running.tolist()
    lo, hi = float(min(seen)), float(max(seen))
    width = max(hi - lo, step_hi - step_lo)
    if width == 0.0:
        # Every episode returned the same and every step paid the same reward r (Acrobot:
        # -1 a step, every random episode cut at the time limit). The returns still differ
        # by r for each step an agent ends an episode sooner or later, so the width is
        # |r| over the longest episode's steps; where r is 0 (a sparse goal random play
        # never reached) nothing says how wide, and the scale falls back to 1.
        width = max(abs(step_lo), abs(step_hi)) * max(longest - 1, 1)
    if width == 0.0:
        return EstimatedBounds(ReturnBounds(lo, hi), len(returns), played, (lo, hi), longest)
    high = lo + width + ESTIMATE_MARGIN * width
    return EstimatedBounds(ReturnBounds(lo, high), len(returns), played, (lo, hi), longest)
