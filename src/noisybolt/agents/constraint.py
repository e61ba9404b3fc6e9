"""The ``constrained`` scheme in training: an SB3 callback that learns the bolt's price.

The learner is one of SB3's on-policy algorithms, unchanged (PPO, A2C): what the
constraint changes is the reward the bolt pays, ``R + λ * compliance terms``, with
``λ`` the :class:`~noisybolt.bolt.LagrangeMultiplier` (see :mod:`noisybolt.bolt.constraint`
for the scheme and its update rule). :class:`LagrangianCallback` does the bookkeeping:

* every step it reads the cost of each episode that ended (``info["bolt_episode_cost"]``,
  the specs the episode leaves unsatisfied as the bolt sees them: never ground truth);
* it sums each game's world rewards (``info["env_reward"]``), so that a multiplier that
  waits for the world's returns to differ (``bolt.constraint.wait``) sees them;
* the *first* cost (where the annealed budget starts) is the mean over the episodes
  *begun* in the first ``window`` frames once the multiplier learns (at a fresh run's
  start, or after the window it woke in), and at least each game's first begun then,
  every one of them waited for to its end: chosen by when they began, not by when they
  ended, since a window's ended episodes are the short ones first. With ``window`` 0,
  each game's first episode. Episodes not ended :data:`FIRST_COST_PATIENCE` of the
  run's frames after the window are left out of it;
* at the end of a rollout, once at least ``bolt.constraint.window`` frames have been
  trained since the last update, it updates ``λ`` from the mean cost of the episodes
  ended over them (none ended: no update, the frames count towards the next), and sets
  every training bolt's price to it, so the next rollout is collected, and the update
  that follows learns, at the new price. The window makes the measurement the same for
  a learner that updates every 40 frames (A2C) and one that updates every 1,024 (PPO):
  see :attr:`~noisybolt.bolt.CostLimit.window`;
* where the compliance scale rests on bounds estimated by random play
  (``bolt.constraint.rescale``), the price is raised as the world's returns seen in
  training outrun the scale (:meth:`~noisybolt.bolt.LagrangeMultiplier.scale_factor`);
* it logs ``constraint/multiplier``, ``constraint/scale_factor`` and
  ``constraint/episode_cost``, and its state is saved
  with the run's checkpoints (:meth:`state_dict`) and restored on resume.

The price is applied to the rewards as they are collected (the multiplier moves once per
rollout, between collection and update, as PPO-Lagrangian's does once per epoch), so
each rollout is learned with the price it was collected at. DQN is refused: its replay
buffer would mix rewards of many prices.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.vec_env import VecEnv

from noisybolt.agents.pipeline import GroupedVecEnv
from noisybolt.bolt import CostLimit, LagrangeMultiplier
from noisybolt.errors import ConfigError
from noisybolt.wrappers import ENV_REWARD_KEY, EPISODE_COST_KEY, BoltVecEnv

__all__ = ["FIRST_COST_PATIENCE", "LagrangianCallback", "bolted_envs"]

#: The longest share of the run's frames the first cost waits, past its window, for the
#: episodes it counts to end (see :class:`LagrangianCallback`); then those that have
#: ended make it (a world without a time limit need not end one).
FIRST_COST_PATIENCE = 0.05


def bolted_envs(venv: VecEnv) -> list[BoltVecEnv]:
    """Every :class:`~noisybolt.wrappers.BoltVecEnv` in a stack of ``VecEnv`` wrappers
    (through each group of a :class:`~noisybolt.agents.pipeline.GroupedVecEnv`).

    Raises:
        ConfigError: the stack holds no bolt.
    """
    found: list[BoltVecEnv] = []
    stack: list[Any] = [venv]
    while stack:
        env = stack.pop()
        if isinstance(env, BoltVecEnv):
            found.append(env)
        elif isinstance(env, GroupedVecEnv):
            stack.extend(env.groups)
        elif hasattr(env, "venv"):
            stack.append(env.venv)
    if not found:
        raise ConfigError(
            "the constrained scheme prices the bolt's payments, but the training env holds "
            "no BoltVecEnv"
        )
    return found


class LagrangianCallback(BaseCallback):
    """Learns the ``constrained`` scheme's multiplier from the episodes' costs.

    Args:
        limit: the cost budget and the multiplier's gains.
        frames: the run's frames (the budget is annealed over a share of them).
        state: a saved :meth:`state_dict` (a resumed run's); None starts afresh.
        scale: the resolved compliance scale (the bolts' payments at price 1): with
            ``limit.rescale``, the price is raised as the world's returns outrun it
            (:meth:`~noisybolt.bolt.LagrangeMultiplier.scale_factor`); None: never raised.

    Attributes:
        multiplier: the :class:`~noisybolt.bolt.LagrangeMultiplier`.
    """

    def __init__(
        self,
        limit: CostLimit,
        *,
        frames: int,
        state: Mapping[str, Any] | None = None,
        scale: float | None = None,
    ) -> None:
        super().__init__(verbose=0)
        self.multiplier = LagrangeMultiplier(limit, state=state)
        self.frames = int(frames)
        self.base_scale = scale
        self._costs: list[float] = []
        self._returns: list[float] = []
        self._running: np.ndarray | None = None  # each game's world return so far
        self._bolts: list[BoltVecEnv] = []
        self._last_update = 0
        # While the first cost is measured (see _measure_first): the counted episodes'
        # (cost, world return), whether each game's running episode counts, whether each
        # game has ended a counted one, and the frames at which the measurement began.
        # _counting None: not measuring it.
        self._first: list[tuple[float, float]] = []
        self._counting: np.ndarray | None = None
        self._counted = np.zeros(0, dtype=bool)
        self._first_since = 0

    def _init_callback(self) -> None:
        env = self.model.get_env()
        assert env is not None
        self._bolts = bolted_envs(env)
        self._last_update = int(self.model.num_timesteps)
        multiplier = self.multiplier
        if multiplier.updates == 0 or (not multiplier.waiting and multiplier.first_cost is None):
            # learn() begins every game afresh (a new run, or a resumed one's reset)
            self._measure_first(began=True, n_envs=env.num_envs)
        self._set_price()

    def _measure_first(self, *, began: bool, n_envs: int) -> None:
        """Begins measuring the first cost: over the episodes *begun* in the next
        ``window`` frames (whatever their length, each waited for to its end), and at
        least each game's first begun from now. ``began``: the games' running episodes
        begin now (a fresh run's first reset), else they began before and do not count."""
        self._first = []
        self._counting = np.full(n_envs, began)
        self._counted = np.zeros(n_envs, dtype=bool)
        self._first_since = int(self.model.num_timesteps)

    @property
    def _window(self) -> float:
        """The fewest frames a measured cost pools (``bolt.constraint.window``; 0: none)."""
        return self.multiplier.limit.window or 0

    def _first_measured(self, now: int) -> bool:
        """Whether every episode the first cost counts has ended."""
        assert self._counting is not None
        done = now >= self._first_since + self._window and bool(self._counted.all())
        return done and not self._counting.any()

    @property
    def scale_factor(self) -> float:
        """How far the price's scale stands above the resolved one (1: not raised)."""
        if self.base_scale is None:
            return 1.0
        return self.multiplier.scale_factor(self.base_scale)

    def _set_price(self) -> None:
        price = self.multiplier.value * self.scale_factor
        for bolt in self._bolts:
            bolt.price = price

    def _on_step(self) -> bool:
        dones = np.asarray(self.locals["dones"], dtype=bool)
        infos = self.locals["infos"]
        if self._running is None or len(self._running) != len(dones):
            self._running = np.zeros(len(dones))
        self._running += [float(info.get(ENV_REWARD_KEY, 0.0)) for info in infos]
        counting = self._counting
        ended = np.flatnonzero(dones).tolist()
        if ended and counting is not None:
            # The next episode of a game that ends one now begins within the window (or
            # is the first the game begins since the measurement began): it counts.
            within = int(self.model.num_timesteps) < self._first_since + self._window
        for row in ended:
            cost = infos[row].get(EPISODE_COST_KEY)
            if counting is None:
                if cost is not None:
                    self._costs.append(float(cost))
                    self._returns.append(float(self._running[row]))
            else:
                if counting[row] and cost is not None:
                    self._first.append((float(cost), float(self._running[row])))
                    self._counted[row] = True
                counting[row] = within or not self._counted[row]
            self._running[row] = 0.0
        return True

    def _on_rollout_end(self) -> None:
        now = int(self.model.num_timesteps)
        frames = now - self._last_update
        multiplier = self.multiplier
        if self._counting is not None:
            patience = now - self._first_since >= self._window + FIRST_COST_PATIENCE * self.frames
            if self._first and frames > 0 and (self._first_measured(now) or patience):
                costs, returns = zip(*self._first, strict=True)
                self._update(float(np.mean(costs)), frames, list(returns))
                self._counting = None
                self._costs, self._returns = [], []
        elif self._costs and frames > 0 and frames >= self._window:
            waiting = multiplier.waiting
            self._update(float(np.mean(self._costs)), frames, self._returns)
            self._costs, self._returns = [], []
            if waiting and not multiplier.waiting and self._running is not None:
                # Woken by this window: the first cost is of the games' next episodes.
                self._measure_first(began=False, n_envs=len(self._running))
        self._set_price()
        self.logger.record("constraint/multiplier", multiplier.value)
        self.logger.record("constraint/scale_factor", self.scale_factor)

    def _update(self, cost: float, frames: int, returns: list[float]) -> None:
        progress = int(self.model.num_timesteps) / max(self.frames, 1)
        self.multiplier.update(cost, frames=frames, progress=progress, returns=returns)
        self.logger.record("constraint/budget", self.multiplier.budget(progress))
        self.logger.record("constraint/episode_cost", cost)
        self.logger.record("constraint/waiting", float(self.multiplier.waiting))
        self._last_update = int(self.model.num_timesteps)

    def state_dict(self) -> dict[str, Any]:
        """What a checkpoint keeps: the multiplier's state (the costs of a rollout under
        way are not kept: a resume starts a fresh rollout)."""
        return self.multiplier.state_dict()
