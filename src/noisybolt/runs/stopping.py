"""Stop when solved: end training after ``k`` consecutive evaluations at a threshold.

In Stable-Baselines3's callback style (``StopTrainingOnRewardThreshold``): the callback
is a child of an evaluating callback, is stepped once after each evaluation, reads that
evaluation's score from its parent, and returns False to end ``learn()``. Asking for
several evaluations *in a row* is what makes the rule safe for a sampled policy: a single
lucky evaluation of 20 episodes does not stop a run whose next one would fail.

With SB3's own ``EvalCallback`` it reads the mean episode return::

    stop = StopWhenSolved(threshold=0.9, consecutive=3)
    model.learn(10_000, callback=EvalCallback(eval_env, callback_after_eval=stop))

A callback of one's own passes a ``score`` function of itself (noisybolt's training
callback passes the evaluation's success rate), or calls :meth:`StopWhenSolved.record`
with each evaluation's score.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import Any

from stable_baselines3.common.callbacks import BaseCallback

from noisybolt.errors import ConfigError

__all__ = ["StopWhenSolved", "trailing_streak"]


def _mean_reward(parent: Any) -> float:
    """SB3 ``EvalCallback``'s score: the last evaluation's mean return."""
    return float(parent.last_mean_reward)


def trailing_streak(scores: Iterable[float], threshold: float) -> int:
    """How many of the last ``scores`` in a row are at or above ``threshold``.

    A resumed run continues its streak from its saved evaluations.

    Example:
        >>> trailing_streak([1.0, 0.5, 0.96, 1.0], 0.95)
        2
        >>> trailing_streak([1.0, 0.5], 0.95)
        0
    """
    streak = 0
    for score in scores:
        streak = streak + 1 if score >= threshold else 0
    return streak


class StopWhenSolved(BaseCallback):
    """Ends training once ``consecutive`` evaluations in a row score ``>= threshold``.

    Args:
        threshold: the score an evaluation must reach (inclusive).
        consecutive: evaluations in a row that must reach it (k >= 1).
        score: reads the latest evaluation's score from the parent callback; default:
            ``parent.last_mean_reward`` (SB3's ``EvalCallback``).
        streak: evaluations already in a row at the threshold (a resumed run's).
        not_before: frames before which no streak stops training (they still count
            towards it): where an exploration schedule still runs (A2C's entropy bonus
            falling, DQN's epsilon), the policy judged solved is not yet the one the
            schedule ends with. Measured on Table 1's exclusive-corner row (A2C, its
            entropy bonus falling from 0.05 to 0 over 50k frames, six seeds): stopped
            when solved, at 29k frames on average, the seeds' sampled policies complied in
            97 % of episodes on average and one seed fell below 95 %; trained to 60k, all
            six complied in every episode, in the optimal 7 steps.
        verbose: 1 prints a line when it stops training.

    Attributes:
        streak: qualifying evaluations in a row so far.
        evaluations: evaluations seen.
        stopped_at: ``num_timesteps`` when it ended training (None while it has not).

    Raises:
        ConfigError: ``consecutive < 1`` or a negative ``streak``.
    """

    def __init__(
        self,
        *,
        threshold: float,
        consecutive: int = 1,
        score: Callable[[Any], float] | None = None,
        streak: int = 0,
        not_before: int = 0,
        verbose: int = 0,
    ) -> None:
        super().__init__(verbose=verbose)
        if int(consecutive) < 1:
            raise ConfigError(
                f"stop when solved: consecutive must be >= 1 evaluation, got {consecutive} "
                "(to train the whole budget, leave the stopping rule off)"
            )
        if int(streak) < 0:
            raise ConfigError(f"stop when solved: streak must be >= 0, got {streak}")
        self.threshold = float(threshold)
        self.consecutive = int(consecutive)
        self.score = score or _mean_reward
        self.streak = int(streak)
        self.not_before = int(not_before)
        self.evaluations = 0
        self.stopped_at: int | None = None

    @property
    def solved(self) -> bool:
        """Whether the streak has reached ``consecutive``."""
        return self.streak >= self.consecutive

    def record(self, score: float, *, frames: int | None = None) -> bool:
        """Counts one evaluation's score (taken after ``frames`` frames: default, the
        model's count when last stepped); returns whether training should continue."""
        self.evaluations += 1
        self.streak = self.streak + 1 if float(score) >= self.threshold else 0
        at = int(self.num_timesteps if frames is None else frames)
        if not self.solved or at < self.not_before:
            return True
        if self.stopped_at is None:
            self.stopped_at = at
            if self.verbose >= 1:
                print(
                    f"stopping: {self.streak} evaluations in a row at or above "
                    f"{self.threshold:g} ({self.stopped_at:,} frames)"
                )
        return False

    def _on_step(self) -> bool:
        if self.parent is None:
            raise ConfigError(
                "StopWhenSolved is stepped after each evaluation by an evaluating callback: "
                "pass it as EvalCallback(callback_after_eval=...), or call record(score)"
            )
        return self.record(self.score(self.parent))
