"""What a world's episode can return: the bound the ``compliance`` reward scheme scales from.

A world declares it with a method ``return_bounds() -> ReturnBounds`` (the
:class:`DeclaresReturnBounds` contract): the least and the most one episode's
(undiscounted) environment return can be, from its reward range and horizon. The shipped
worlds declare theirs; a user's Gymnasium env declares them through
``FluentLabels(env, ..., return_bounds=(least, most))``. A world that does not can still
be trained under the ``compliance`` scheme with an explicit scale (``--reward-scale``), or
under ``paper``.

Example:
    >>> from noisybolt.envs import make_world
    >>> world_return_bounds(make_world("gridworld", num_envs=1))
    ReturnBounds(low=-216.0, high=98.5)
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

from noisybolt.bolt.schemes import ReturnBounds

__all__ = ["DeclaresReturnBounds", "episode_return_bounds", "world_return_bounds"]


@runtime_checkable
class DeclaresReturnBounds(Protocol):
    """A world that states the range of its episodes' returns."""

    def return_bounds(self) -> ReturnBounds | None:
        """Bounds on one episode's undiscounted environment return (None: unknown)."""
        ...


def world_return_bounds(world: object) -> ReturnBounds | None:
    """The world's declared :class:`ReturnBounds`, or None if it declares none."""
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
