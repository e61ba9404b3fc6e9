"""The ``constrained`` scheme in training: an SB3 callback that learns the bolt's price.

The learner is one of SB3's on-policy algorithms, unchanged (PPO, A2C): what the
constraint changes is the reward the bolt pays, ``R + λ * compliance terms``, with
``λ`` the :class:`~noisybolt.bolt.LagrangeMultiplier` (see :mod:`noisybolt.bolt.constraint`
for the scheme and its update rule). :class:`LagrangianCallback` does the bookkeeping:

* every step it reads the cost of each episode that ended (``info["bolt_episode_cost"]``,
  the specs the episode leaves unsatisfied as the bolt sees them: never ground truth);
* it sums each game's world rewards (``info["env_reward"]``), so that a multiplier that
  waits for the world's returns to differ (``bolt.constraint.wait``) sees them;
* at the end of a rollout, once at least ``bolt.constraint.window`` frames have been
  trained since the last update, it updates ``λ`` from the mean cost of the episodes
  ended over them (none ended: no update, the frames count towards the next), and sets
  every training bolt's price to it, so the next rollout is collected, and the update
  that follows learns, at the new price. The window makes the measurement the same for
  a learner that updates every 40 frames (A2C) and one that updates every 1,024 (PPO):
  see :attr:`~noisybolt.bolt.CostLimit.window`;
* it logs ``constraint/multiplier`` and ``constraint/episode_cost``, and its state is saved
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

__all__ = ["LagrangianCallback", "bolted_envs"]


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

    Attributes:
        multiplier: the :class:`~noisybolt.bolt.LagrangeMultiplier`.
    """

    def __init__(
        self, limit: CostLimit, *, frames: int, state: Mapping[str, Any] | None = None
    ) -> None:
        super().__init__(verbose=0)
        self.multiplier = LagrangeMultiplier(limit, state=state)
        self.frames = int(frames)
        self._costs: list[float] = []
        self._returns: list[float] = []
        self._running: np.ndarray | None = None  # each game's world return so far
        self._bolts: list[BoltVecEnv] = []
        self._last_update = 0

    def _init_callback(self) -> None:
        env = self.model.get_env()
        assert env is not None
        self._bolts = bolted_envs(env)
        self._last_update = int(self.model.num_timesteps)
        self._set_price()

    def _set_price(self) -> None:
        for bolt in self._bolts:
            bolt.price = self.multiplier.value

    def _on_step(self) -> bool:
        dones = np.asarray(self.locals["dones"], dtype=bool)
        infos = self.locals["infos"]
        if self._running is None or len(self._running) != len(dones):
            self._running = np.zeros(len(dones))
        self._running += [float(info.get(ENV_REWARD_KEY, 0.0)) for info in infos]
        for row in np.flatnonzero(dones).tolist():
            cost = infos[row].get(EPISODE_COST_KEY)
            if cost is not None:
                self._costs.append(float(cost))
                self._returns.append(float(self._running[row]))
            self._running[row] = 0.0
        return True

    def _on_rollout_end(self) -> None:
        frames = int(self.model.num_timesteps) - self._last_update
        window = self.multiplier.limit.window or 0
        if self._costs and frames > 0 and frames >= window:
            cost = float(np.mean(self._costs))
            progress = int(self.model.num_timesteps) / max(self.frames, 1)
            self.multiplier.update(cost, frames=frames, progress=progress, returns=self._returns)
            self.logger.record("constraint/budget", self.multiplier.budget(progress))
            self._last_update = int(self.model.num_timesteps)
            self.logger.record("constraint/episode_cost", cost)
            self.logger.record("constraint/waiting", float(self.multiplier.waiting))
            self._costs, self._returns = [], []
        self._set_price()
        self.logger.record("constraint/multiplier", self.multiplier.value)

    def state_dict(self) -> dict[str, Any]:
        """What a checkpoint keeps: the multiplier's state (the costs of a rollout under
        way are not kept: a resume starts a fresh rollout)."""
        return self.multiplier.state_dict()
