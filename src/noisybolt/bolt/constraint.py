"""Compliance as a constraint: a cost budget and the Lagrange multiplier that keeps it.

The ``compliance`` scheme (:mod:`noisybolt.bolt.schemes`) prices every violation at a
fixed ``scale`` wider than the world's returns, from the first frame on. Where the task
must be found by exploration, that price teaches "do nothing" before the task is ever
seen: the violations of a random policy are met at once, the goal seldom (FrozenLake,
CliffWalking, a lava room: bolted agents complied and stood still while the unbolted
control of the same seed reached the goal).

The ``constrained`` scheme asks instead: maximise the world's return *subject to* the
expected cost of an episode staying within a budget ``d``. An episode's cost is the
number of specs it does not satisfy, as the bolt sees them: a spec whose DFA entered a
rejecting sink (violated for good), or ended the episode short of acceptance. The
Lagrangian relaxation pays the learner ``R + price * compliance terms``, where the
compliance terms are the ``compliance`` scheme's (acceptance, violation charge, graded
outcome, progress shaping: every one of them linear in the scale) and
``price = multiplier * scale``. The multiplier ``λ`` is learned (Ray, Achiam & Amodei
2019; Stooke, Achiam & Abbeel, ICML 2020, "Responsive Safety in RL by PID Lagrangian
Methods"): it starts at 0, so the task is learned as the unbolted agent learns it, rises
while the measured episode cost exceeds ``d`` and falls back while it is below. It is
capped at 1: at ``λ = 1`` the price is the compliance scale, whose optimum complies
whenever a compliant policy exists (the compliance scheme's guarantee), and a higher
price changes no optimum, only how hard the learning is.

The update is Stooke et al.'s PID form on the error ``e = J_c - d`` (``J_c``: the mean
cost of the episodes ended since the last update, over ``n`` frames)::

    I   <- clip(I + lr * e * n / 1000, 0, 1)    integral: the plain Lagrangian ascent
    λ   =  clip(kp * e + I + kd * max(0, J_c - J_c_prev), 0, 1)

**The budget is annealed.** A random policy breaks most specs, and any price at all on
those early breaks teaches that doing nothing is safest before the task is ever found:
measured on MiniGrid's lava gap room with ``G(!in_lava)`` (PPO, 150k frames, a budget
of 0.02 from the start), the price rose to 0.13 of the scale within 10k frames, and the
agent stood still to the time limit (goal 0 %) while the unbolted control of the same
seed reached the goal in every episode from 90k frames, complying on its own. So the
budget starts at the first cost measured and falls linearly to ``cost_limit`` over the
first ``anneal`` share of the run's frames: the agent is asked to comply a little more
every rollout rather than all at once, and pays nothing while its cost falls at least
that fast, as a learner of the task's cost does on its own where the task and the spec
agree::

    d(t) = cost_limit + (J_c(first) - cost_limit) * max(0, 1 - t / (anneal * frames))

Where every spec asks the agent to do something (``F(x)``, ``!a U b``) and the scale is
exact (the gridworld's product), standing still breaks the specs too, a price cannot teach
it, and the full price is known to be just enough: the budget is the limit from the first
rollout and the price starts in full
(:func:`~noisybolt.bolt.constraint_choices.budget_anneal`,
:func:`~noisybolt.bolt.constraint_choices.start_price`), since
annealed it lets the direct route settle before the detour is priced, and a settled
policy does not find the detour. On a scale from bounds (a worst case) the budget is
annealed whatever the specs.

**The multiplier waits for the task.** While every episode has returned the same (a
sparse goal not found yet: FrozenLake, a lava room, Acrobot), the world gives the learner
nothing to trade compliance against, and a price of any size is all it sees: reward
normalisation divides by the deviation of returns the price alone makes, and PPO
normalises its advantages, so a thousandth of the scale teaches as much as the whole
scale, and it teaches avoiding the cost (standing still) before the goal is ever found.
Measured on FrozenLake 8x8 (``G(!right_col | at_goal)``, PPO seed 2, 100k frames):
priced from the first rollout, the agent first reached the goal at 70k frames and had
lost it again by 100k; the same bolt priced at 0 reached it in 75 % of episodes at 20k
frames, as the unbolted control of the seed did. So the multiplier (``wait``, a share of
the run) stays at ``initial`` until the world's returns differ between episodes, or the
wait is over, and then learns as above, its budget annealed over ``anneal`` of the frames
left. Where the returns differ from the first rollout (step costs, falls, a pole that
drops), nothing waits.

**The first cost is measured on whole episodes begun once awake**, where the annealed
budget starts: the episodes a window ends first are the short ones (MiniGrid's room,
``!right_col U bottom_left``, A2C seed 0: a first cost of 0 from a few quick compliant
episodes put the price at the full scale from 15k frames on, compliance 35 %). So the
window in which the multiplier wakes teaches it nothing, and the first cost pools the
episodes begun over the next ``window`` frames, each waited for to its end
(:class:`~noisybolt.agents.constraint.LagrangianCallback`).

The integral's rate is per 1,000 frames, not per update, so that a learner that updates
every 40 frames (A2C) and one that updates every 1,024 (PPO) raise the price alike.
``kp`` (1 by default) prices at once a cost above the (annealed) budget, and takes the
price back as the cost falls below it; ``kd`` (0) reacts to how fast the cost rises.
Measured with the integral alone (``kp = 0``; PPO, the gridworld's spec suite, 60k
frames, seed 0): six of 24 specs never complied, four of them because the agent had
learnt the shortest route (the cost held at ~0.9 while the budget fell) before the
integral had raised the price (0.21 at 15k frames); with ``kp = 1`` the price was 0.72 by
then and those four complied by 30k frames (the other two are the bolt's camera fooled,
priced or not). Tried and dropped: the proportional term on the cost above the *first*
cost only (a learner learning to break the specs more often than random play), which
left those four as the integral alone had (random play's first cost there is already
1). What ``kp`` cannot mend: on the lava room (``G(!in_lava)``, PPO seed 0, 150k frames)
the cost fell slower than the budget before the gap to the goal was found, the price
rose to 0.35 at 33k frames and the agent stood still for the rest of the run (goal 0 %,
against 30 % with the integral alone and 100 % for the unbolted control): a budget
annealed over a share of the run asks for compliance on the clock, not on the task's
progress, so a run must be long enough for the task to be found within the anneal.

**Where a price could teach standing still, it is searched, not asserted.** On a scale
from the world's return bounds with a spec that an episode without events keeps, the
full price is a worst case: past about half of it a violation outweighs the whole task,
and the learner's best reply is to stand still. There the proportional term is off, the
integral climbs slowly (``lr`` 0.02), it falls back as fast as it rose once the cost is
met (``release``: with a budget near 0 the plain error would leave a price in place for
the rest of the run, the agent standing still), and each measured cost pools the
episodes of at least 1,000 frames (``window``). Measured on FrozenLake 8x8 with A2C:
:func:`~noisybolt.bolt.constraint_choices.price_search`.

The multiplier is a small object of its own, apart from any learner (OmniSafe's layout);
its state is a dict of floats, saved with a run's checkpoints and restored on resume.

Example:
    >>> limit = CostLimit(cost_limit=0.1, lr=0.5, kp=0.0, anneal=0.0)
    >>> lagrange = LagrangeMultiplier(limit)
    >>> lagrange.value
    0.0
    >>> round(lagrange.update(0.9), 2)  # cost above the budget: the price rises
    0.4
    >>> round(lagrange.update(0.5), 2)
    0.6
    >>> round(lagrange.update(0.0), 2)  # below it: the price falls back
    0.55
    >>> lagrange.update(5.0)  # never above 1: the compliance scheme's own price
    1.0

    With the defaults' anneal and proportional gain, over a run of 10,000 frames:

    >>> annealed = LagrangeMultiplier(CostLimit(cost_limit=0.02, lr=0.1, kp=1.0, anneal=0.5))
    >>> annealed.update(0.6, progress=0.0)  # the first cost: where the budget starts
    0.0
    >>> round(annealed.update(0.9, progress=0.1), 3)  # above the budget: priced at once
    0.458
    >>> annealed.update(0.3, progress=0.2)  # below it: the price falls back
    0.0
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from noisybolt.bolt.constraint_choices import ANNEAL, KP, LR
from noisybolt.errors import ConfigError

__all__ = [
    "CONSTRAINT_KEYS",
    "OPTIONAL_KEYS",
    "CostLimit",
    "LagrangeMultiplier",
    "episode_costs",
]

LN10 = math.log(10.0)


#: The settings of :class:`CostLimit` that may be None (chosen by
#: :func:`~noisybolt.runs.resolve` for a fresh run; absent from runs saved before them).
OPTIONAL_KEYS: tuple[str, ...] = (
    "lr",
    "kp",
    "anneal",
    "decades",
    "wait",
    "start",
    "window",
    "release",
    "rescale",
)

#: The settings of :class:`CostLimit`, as ``bolt.constraint`` in a run's config names them.
CONSTRAINT_KEYS: tuple[str, ...] = ("cost_limit", "kd", "initial", *OPTIONAL_KEYS)


def _number(name: str, value: object) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ConfigError(f"bolt.constraint.{name} must be a number, got {value!r}")
    if not math.isfinite(value):
        raise ConfigError(f"bolt.constraint.{name} must be finite, got {value!r}")
    return float(value)


@dataclass(frozen=True, kw_only=True)
class CostLimit:
    """The cost budget of the ``constrained`` scheme and how its multiplier learns.

    Attributes:
        cost_limit: ``d``, the expected number of specs an episode may leave unsatisfied
            (as the bolt sees them), ``>= 0``; 0 asks for compliance in every episode, but
            then the price never falls back once complying (the cost cannot go below 0).
            The default, 0.02, asks for 98 % and lets the price ease off while the
            agent complies, so the world's return is weighed again.
        lr: the integral gain, the multiplier's learning rate (``> 0``): how much it rises
            per 1,000 frames trained at a cost one above the budget. With the budget
            annealed, a cost that falls on its own is never priced, and one that does not
            fall is priced quickly: measured at 0.02 on MiniGrid's room with
            ``F(bottom_left)`` (PPO), the price reached 0.14 only at 37k frames, after the
            policy had settled on the direct route, and it never found the detour even at
            price 1; the compliance scheme, priced from the start, had. None (the
            default): chosen by :func:`~noisybolt.runs.resolve`
            (:func:`~noisybolt.bolt.constraint_choices.price_search`); a multiplier given
            None learns at :data:`~noisybolt.bolt.constraint_choices.LR`.
        kp: the proportional gain (``>= 0``): a cost above the budget is priced at once.
            None (the default): chosen by :func:`~noisybolt.runs.resolve`, as ``lr``; a
            multiplier given None uses :data:`~noisybolt.bolt.constraint_choices.KP`.
        kd: the derivative gain, on rises of the cost only (``>= 0``).
        initial: the multiplier at the start of training, in ``[0, 1]`` (0: the task is
            learned first, compliance is asked as the cost is measured).
        anneal: the share of the run's frames, in ``[0, 1]``, over which the budget falls
            from the first measured cost to ``cost_limit`` (0: ``cost_limit`` from the
            start). None (the default): chosen by :func:`~noisybolt.runs.resolve`
            (:func:`~noisybolt.bolt.constraint_choices.budget_anneal`: 0 where no spec is kept
            by doing nothing and the scale is exact, else
            :data:`~noisybolt.bolt.constraint_choices.ANNEAL`); a multiplier given None
            anneals over :data:`~noisybolt.bolt.constraint_choices.ANNEAL`, as every run
            did before the choice existed.
        decades: how many powers of ten the price spans (``>= 0``): the PID's output
            ``u`` in ``[0, 1]`` is priced ``(10 ** (decades * u) - 1) / (10 ** decades -
            1)`` of the compliance scale, so that equal steps of ``u`` multiply the price
            by about equal factors, searching the order of magnitude a violation must
            cost, and a cost just above the budget is priced just above 0 (continuous at
            0; ``10 ** (-decades * (1 - u))``, which jumps to a thousandth of the scale
            for any ``u > 0``, kept FrozenLake's seed 1 from its compliant route, goal
            5 %, and Acrobot's ``G(!fast)`` at the control's compliance: with this form
            11 of the world suite's 12 PPO trials of a ``G`` spec keep the task, against
            9, at the second round's gains). 0: the price is ``u`` itself, linear: what
            :func:`~noisybolt.runs.resolve` gives a run since the price is searched where
            it could teach standing still
            (:func:`~noisybolt.bolt.constraint_choices.price_search`); None prices
            linearly too.
        wait: the longest share of the run's frames, in ``[0, 1]``, that the multiplier
            waits (at ``initial``, learning nothing, its budget's anneal not begun) for
            the world to pay the learner returns that differ between episodes. While
            every episode has returned the same (a sparse goal not yet found), there is
            nothing to trade compliance against, and any price at all is the only signal
            the learner gets: reward normalisation and PPO's advantage normalisation
            make even a thousandth of the scale a full unit, and the learner learns to
            avoid the cost (standing still) before it ever sees the task. Once the
            returns differ, or the wait is over, the multiplier learns as without it,
            its budget annealed over ``anneal`` of the frames then left. 0: no wait.
            None (the default): :data:`~noisybolt.bolt.constraint_choices.WAIT` for a
            run :func:`~noisybolt.runs.resolve` resolves afresh, 0 for a multiplier
            given None and for runs saved before the setting existed.
        start: the integral (the price asked, in ``[0, 1]``) from the first cost measured
            once awake, until costs below the budget ease it. None (the default): the
            integral goes on from ``initial``. :func:`~noisybolt.runs.resolve` gives 1
            where no spec is kept by doing nothing and the scale is exact
            (:func:`~noisybolt.bolt.constraint_choices.start_price`: a detour asked for
            in full from the first measured cost, as the compliance scheme asks it),
            else ``initial``.
        window: the fewest frames (``>= 0``) whose ended episodes the multiplier pools
            into one measured cost: the callback learns once that many frames have been
            trained since the last update (and an episode ended), not every rollout. The
            proportional term prices the error of one measurement at once, and the price
            is convex over decades: a measurement from the one or two episodes a 40-frame
            A2C rollout ends is a 0 or a 1, priced near nothing or in full at random, and
            the mean price of such a walk is set by its spikes. None (the default): for a
            run :func:`~noisybolt.runs.resolve` resolves afresh,
            :data:`~noisybolt.bolt.constraint_choices.WINDOW` where the compliance scale
            is from the world's return bounds and 0 where it is exact (see
            :func:`~noisybolt.bolt.constraint_choices.price_search`); 0 (every rollout, as
            before the setting existed) for a multiplier given None and for runs saved
            before it.
        release: how fast the integral falls while the cost is under the budget
            (``[0, 1]``): the error it learns from is then at most ``-release * (budget -
            cost) / budget``, so that at a cost of 0 it falls at ``lr`` per 1,000 frames,
            as fast as a cost one above the budget raises it. (Symmetric within half the
            budget instead, A2C on the toll road kept its budget at ``d`` 0.1, 10-11.5 %
            against 14-15 %, but six of the eight world-suite trials that lost the task
            were on ``G`` specs at 0.02: not adopted until measured on held-out seeds.)
            0 (a multiplier given None, runs saved before the setting): the plain error,
            ``cost - budget``, which with a budget near 0 leaves a price in place for the
            rest of a run once the cost is met, even where meeting it cost the task (the
            agent stood still):
            the dual's own remedy, a price that falls where the constraint is slack,
            then never comes. None (the default): chosen by
            :func:`~noisybolt.runs.resolve`
            (:func:`~noisybolt.bolt.constraint_choices.price_search`).
        rescale: where the compliance scale rests on bounds estimated by random play,
            the margin (``>= 0``) by which the price's scale is kept above the widest gap
            between two training episodes' world returns seen so far
            (:meth:`LagrangeMultiplier.scale_factor`), so that at ``λ = 1`` complying
            still outweighs the task (FrozenLake 8x8: random play never reaches the
            goal, the scale fell to 1, and the model a run kept broke ``G(!right_col |
            at_goal)`` in every episode). 0 (a multiplier given None, runs saved before
            it, bounds declared, a scale given): as resolved. None (the default): chosen
            by :func:`~noisybolt.runs.resolve` (1.1 where the bounds were estimated).

    Raises:
        ConfigError: a value that is not a finite number, a negative limit or gain, a
            learning rate ``<= 0``, or an initial multiplier or anneal share outside
            ``[0, 1]``; each names the setting and what to give.
    """

    cost_limit: float = 0.02
    lr: float | None = None
    kp: float | None = None
    kd: float = 0.0
    initial: float = 0.0
    anneal: float | None = None
    decades: float | None = None
    wait: float | None = None
    start: float | None = None
    window: float | None = None
    release: float | None = None
    rescale: float | None = None

    def __post_init__(self) -> None:
        for name in CONSTRAINT_KEYS:
            if name in OPTIONAL_KEYS and getattr(self, name) is None:
                continue
            object.__setattr__(self, name, _number(name, getattr(self, name)))
        if self.cost_limit < 0:
            raise ConfigError(
                f"bolt.constraint.cost_limit must be >= 0 (the specs an episode may leave "
                f"unsatisfied, on average), got {self.cost_limit}"
            )
        if self.lr is not None and self.lr <= 0:
            raise ConfigError(
                f"bolt.constraint.lr (the multiplier's learning rate) must be > 0, got {self.lr}"
            )
        for name in ("kp", "kd", "decades", "window", "rescale"):
            if getattr(self, name) is not None and getattr(self, name) < 0:
                raise ConfigError(f"bolt.constraint.{name} must be >= 0, got {getattr(self, name)}")
        for name in ("initial", "anneal", "wait", "start", "release"):
            value = getattr(self, name)
            if value is not None and not 0.0 <= value <= 1.0:
                raise ConfigError(
                    f"bolt.constraint.{name} must be in [0, 1], got {getattr(self, name)}"
                )

    def price(self, u: float) -> float:
        """The share of the compliance scale paid at the PID's output ``u`` in ``[0, 1]``
        (see ``decades``).

        Example:
            >>> [round(CostLimit(decades=3).price(u), 4) for u in (0.0, 0.01, 0.5, 1.0)]
            [0.0, 0.0001, 0.0307, 1.0]
            >>> CostLimit().price(0.5)  # linear
            0.5
        """
        if u <= 0:
            return 0.0
        u = min(u, 1.0)
        if not self.decades:
            return u
        return float(math.expm1(self.decades * u * LN10) / math.expm1(self.decades * LN10))

    def budget(self, progress: float, first_cost: float | None) -> float:
        """The budget at ``progress`` (frames trained / the run's frames) for a run whose
        first measured cost was ``first_cost`` (None: not measured yet).

        Example:
            >>> CostLimit(cost_limit=0.1, anneal=0.5).budget(0.25, first_cost=0.9)
            0.5
        """
        anneal = ANNEAL if self.anneal is None else self.anneal
        if first_cost is None or anneal == 0 or first_cost <= self.cost_limit:
            return self.cost_limit
        left = max(0.0, 1.0 - progress / anneal)
        return self.cost_limit + (first_cost - self.cost_limit) * left

    @classmethod
    def from_mapping(cls, values: Mapping[str, Any]) -> CostLimit:
        """From ``bolt.constraint``'s dict; an unknown key is refused by name."""
        unknown = sorted(set(values) - set(CONSTRAINT_KEYS))
        if unknown:
            raise ConfigError(
                f"unknown config key(s) bolt.constraint.{unknown}; known: {list(CONSTRAINT_KEYS)}"
            )
        return cls(**dict(values))


class LagrangeMultiplier:
    """The learned multiplier ``λ`` in ``[0, 1]`` (see the module docstring).

    Args:
        limit: the budget and gains.
        state: a saved :meth:`state_dict` to continue from (None: start at
            ``limit.initial``).

    Raises:
        ConfigError: a saved state that is not the one :meth:`state_dict` writes.
    """

    def __init__(self, limit: CostLimit, state: Mapping[str, Any] | None = None) -> None:
        if not isinstance(limit, CostLimit):
            raise ConfigError(f"limit must be a CostLimit, got {limit!r}")
        self.limit = limit
        self._integral = limit.initial
        self._value = limit.price(limit.initial)
        self._last_cost: float | None = None
        self._first_cost: float | None = None
        self._updates = 0
        # Where (a share of the run) the multiplier began to learn; None while it waits.
        self._woke_at: float | None = None if limit.wait else 0.0
        # The least and most world returns seen while waiting.
        self._returns_seen: tuple[float, float] | None = None
        if state is not None:
            self.load_state_dict(state)

    @property
    def value(self) -> float:
        """``λ``: the share of the compliance scale the bolt pays now."""
        return self._value

    @property
    def updates(self) -> int:
        """How many measured costs the multiplier has been given (waiting or learning)."""
        return self._updates

    @property
    def waiting(self) -> bool:
        """Whether the multiplier still waits for the world's returns to differ
        (:attr:`CostLimit.wait`)."""
        return self._woke_at is None

    @property
    def woke_at(self) -> float | None:
        """The share of the run at which the multiplier began to learn (None: waiting)."""
        return self._woke_at

    def budget(self, progress: float) -> float:
        """The budget at ``progress`` (frames trained / the run's frames), annealed from
        the first cost measured once awake over ``anneal`` of the frames then left."""
        woke = self._woke_at if self._woke_at is not None else float(progress)
        since = (float(progress) - woke) / (1.0 - woke) if woke < 1.0 else 1.0
        return self.limit.budget(max(0.0, since), self._first_cost)

    @property
    def first_cost(self) -> float | None:
        """The first cost measured (where the annealed budget starts); None before."""
        return self._first_cost

    def update(
        self,
        mean_episode_cost: float,
        *,
        frames: int = 1000,
        progress: float = 1.0,
        returns: Sequence[float] | np.ndarray | None = None,
    ) -> float:
        """Learns from the mean cost of the episodes ended over the last ``frames`` frames
        trained, at ``progress`` (frames trained / the run's frames: where the annealed
        budget stands); returns the new ``λ``.

        ``returns``: those episodes' world returns (the bolt's payments left out). While
        the multiplier waits (:attr:`CostLimit.wait`) it learns nothing until the returns
        seen differ or ``progress`` reaches the wait; None counts as returns that differ.

        Raises:
            ConfigError: a cost that is negative or not finite, or ``frames`` < 1.
        """
        cost = float(mean_episode_cost)
        if not math.isfinite(cost) or cost < 0:
            raise ConfigError(f"an episode cost must be finite and >= 0, got {mean_episode_cost!r}")
        if isinstance(frames, bool) or not isinstance(frames, (int, np.integer)) or frames < 1:
            raise ConfigError(f"frames must be an integer >= 1, got {frames!r}")
        self._see(returns)
        if self._woke_at is None:
            if not self._wakes(returns, float(progress)):
                return self._value
            if self._woke_at:
                # Woken by this window's returns: its episodes began before, so its cost is
                # no first cost (the short episodes end first, and a first cost measured on
                # them starts the anneal low). The caller measures the first cost on
                # episodes begun from now (LagrangianCallback: those begun in its window).
                self._updates += 1
                return self._value
        limit = self.limit
        if self._first_cost is None:
            self._first_cost = cost
            if limit.start is not None:
                self._integral = limit.start
        budget = self.budget(float(progress))
        error = cost - budget
        falling = error
        if error < 0 and limit.release:
            falling = min(error, -limit.release * (budget - cost) / budget)
        lr = LR if limit.lr is None else limit.lr
        kp = KP if limit.kp is None else limit.kp
        step = lr * falling * (int(frames) / 1000)
        self._integral = min(max(0.0, self._integral + step), 1.0)
        rise = 0.0 if self._last_cost is None else max(0.0, cost - self._last_cost)
        u = min(max(0.0, kp * error + self._integral + limit.kd * rise), 1.0)
        self._value = limit.price(u)
        self._last_cost = cost
        self._updates += 1
        return self._value

    def _see(self, returns: Sequence[float] | np.ndarray | None) -> None:
        """Widens the least and most world returns seen by those of the episodes given."""
        if returns is None:
            return
        values = np.asarray(returns, dtype=np.float64).ravel()
        values = values[np.isfinite(values)]
        if values.size:
            lo, hi = float(values.min()), float(values.max())
            if self._returns_seen is not None:
                lo, hi = min(lo, self._returns_seen[0]), max(hi, self._returns_seen[1])
            self._returns_seen = (lo, hi)

    @property
    def returns_seen(self) -> tuple[float, float] | None:
        """The least and most world returns of the episodes measured so far (None: none)."""
        return self._returns_seen

    def scale_factor(self, scale: float) -> float:
        """How far the price's scale is raised above ``scale`` (the resolved compliance
        scale) by the returns seen: ``max(1, rescale * gap / scale)``, ``gap`` the widest
        difference between two measured episodes' world returns (1 without ``rescale``).

        Example:
            >>> lagrange = LagrangeMultiplier(CostLimit(rescale=1.1, anneal=0.0))
            >>> lagrange.scale_factor(1.0)  # nothing seen yet
            1.0
            >>> _ = lagrange.update(1.0, returns=[0.0, 0.0, 1.0])  # a goal found
            >>> round(lagrange.scale_factor(1.0), 2)  # 1.1 times the gap of 1
            1.1
            >>> lagrange.scale_factor(5.0)  # a scale above the gap stays
            1.0
        """
        margin = self.limit.rescale or 0.0
        if not margin or self._returns_seen is None or scale <= 0:
            return 1.0
        gap = self._returns_seen[1] - self._returns_seen[0]
        return max(1.0, margin * gap / scale)

    def _wakes(self, returns: Sequence[float] | np.ndarray | None, progress: float) -> bool:
        """Whether the wait ends now (the returns seen differ, or the wait is over); if so,
        notes where."""
        if returns is None:
            differ = True
        else:
            seen = self._returns_seen
            differ = seen is not None and seen[1] - seen[0] > 1e-9 * max(1.0, abs(seen[0]))
        wait = self.limit.wait or 0.0
        if differ or progress >= wait:
            # Returns that differ in the first rollout measured: no wait at all, the
            # budget annealed from the run's start as without it.
            self._woke_at = 0.0 if self._updates == 0 else min(max(progress, 0.0), 1.0)
            return True
        self._updates += 1  # a rollout measured while waiting
        return False

    def state_dict(self) -> dict[str, Any]:
        """JSON-able state (floats, an int and None): what a checkpoint keeps."""
        return {
            "value": self._value,
            "integral": self._integral,
            "last_cost": self._last_cost,
            "first_cost": self._first_cost,
            "updates": self._updates,
            "woke_at": self._woke_at,
            "returns_seen": None if self._returns_seen is None else list(self._returns_seen),
        }

    def load_state_dict(self, state: Mapping[str, Any]) -> None:
        """Continues from a :meth:`state_dict`.

        Raises:
            ConfigError: a state with missing or unknown keys or out-of-range values.
        """
        required = {"value", "integral", "last_cost", "first_cost", "updates"}
        # woke_at and returns_seen: states saved before the wait existed lack them (their
        # multiplier learned from the first rollout: awake from 0).
        if not isinstance(state, Mapping) or not required <= set(state) <= required | {
            "woke_at",
            "returns_seen",
        }:
            raise ConfigError(
                f"a Lagrange multiplier's saved state must hold value, integral, last_cost, "
                f"first_cost and updates (and woke_at, returns_seen), got {state!r}"
            )
        numbers = {}
        for key in ("value", "integral"):
            value = state[key]
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise ConfigError(f"multiplier state {key} must be a number, got {value!r}")
            if not 0.0 <= value <= 1.0:
                raise ConfigError(f"multiplier state {key} must be in [0, 1], got {value!r}")
            numbers[key] = float(value)
        costs = {}
        for key in ("last_cost", "first_cost"):
            cost = state[key]
            if cost is not None and (
                isinstance(cost, bool)
                or not isinstance(cost, (int, float))
                or not math.isfinite(cost)
                or cost < 0
            ):
                raise ConfigError(f"multiplier state {key} must be None or >= 0, got {cost!r}")
            costs[key] = None if cost is None else float(cost)
        updates = state["updates"]
        if isinstance(updates, bool) or not isinstance(updates, int) or updates < 0:
            raise ConfigError(f"multiplier state updates must be an integer >= 0, got {updates!r}")
        woke_at = state.get("woke_at", 0.0)
        if woke_at is not None and (
            isinstance(woke_at, bool)
            or not isinstance(woke_at, (int, float))
            or not 0.0 <= woke_at <= 1.0
        ):
            raise ConfigError(
                f"multiplier state woke_at must be None or in [0, 1], got {woke_at!r}"
            )
        seen = state.get("returns_seen")
        if seen is not None:
            if (
                not isinstance(seen, (list, tuple))
                or len(seen) != 2
                or not all(
                    isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
                    for v in seen
                )
                or seen[0] > seen[1]
            ):
                raise ConfigError(
                    f"multiplier state returns_seen must be None or [least, most], got {seen!r}"
                )
            seen = (float(seen[0]), float(seen[1]))
        self._value, self._integral = numbers["value"], numbers["integral"]
        self._last_cost, self._first_cost = costs["last_cost"], costs["first_cost"]
        self._updates = updates
        self._woke_at = None if woke_at is None else float(woke_at)
        self._returns_seen = seen


def episode_costs(accepting: np.ndarray, ended: np.ndarray) -> np.ndarray:
    """float64 ``[n_envs]``: each ended episode's cost, the specs it leaves unsatisfied
    (0 for the rows that did not end).

    Args:
        accepting: bool ``[n_envs, n_specs]``, whether each spec counts as accepting after
            the step (the bolt's view: its DFA states, or its beliefs at the confidence).
        ended: bool ``[n_envs]``, the episodes that end with the step.

    Example:
        >>> import numpy as np
        >>> episode_costs(np.array([[True, False], [False, False]]), np.array([True, False]))
        array([1., 0.])
    """
    accepting = np.asarray(accepting, dtype=bool)
    ended = np.asarray(ended, dtype=bool)
    return np.where(ended, (~accepting).sum(axis=1), 0).astype(np.float64)
