"""``normalize_reward: split``: the world's rewards and the bolt's, normalised apart.

SB3's :class:`~stable_baselines3.common.vec_env.VecNormalize` divides each reward by the
running standard deviation of the discounted return. A learner paid the ``compliance``
scheme's rewards (a spec is worth more than the width of the world's returns) then sees
that deviation set by the rare large bolt payments, and the world's own rewards shrink to
almost nothing beside them: on Breakout a milestone is worth 237.6 clipped points, and
the point a brick is worth, the signal that teaches keeping the ball in play, was ~1 % of
a normalised unit (``results/breakout/README.md``). The bolted agents then played worse
than the unbolted ones without taking more of the bricks the bolt wanted.

:class:`SplitRewardNormalize` keeps two running returns, one of the world's rewards and
one of the bolt's, divides each stream by its own deviation, clips each, and pays the
sum. Each stream is then worth about one unit per standard
deviation of its own return, whatever the reward scale: multiplying every bolt reward by
a constant leaves what the learner sees unchanged (tested; up to SB3's running-variance
prior, a variance of 1 weighing 1e-4 of a step). What is given up is the
``compliance`` scheme's lexicographic order: a spec is no longer worth more than any
world return by construction, but as much as its own variation says; the learner trades
the two. Where the bolt pays nothing (an unbolted run's bolt pays 0), this is plain
``VecNormalize`` (tested, step for step).

How the two are traded is then the one free choice, and ``bolt_weight`` ``w`` (the
hyperparameter, default 1) makes it: the learner is paid
``(2 / (1 + w)) * (world_n + w * bolt_n)`` of the normalised, clipped streams, so a weight
of 5 makes a deviation of the bolt's return worth five of the world's, whatever either's
units (a reward scale cannot do this here: it is normalised away). The two weights add up
to 2 whatever ``w``, as at ``w = 1``: the mix changes, not the size of the rewards. A
weight on the bolt's stream alone grows the value targets ``w``-fold, and with them the
value loss, which shares the agent's features with the policy and, under gradient-norm
clipping, crowds the policy's gradient out: the first Breakout runs weighed that way
(``w = 5``) lost their game within 300k frames (from 23 points a game to 1.5) where their
unbolted control kept it. An unbolted run (its bolt pays 0) is normalised with weight 1
whatever its ``bolt_weight``, as the control of a weighted run should be: plain
``VecNormalize``.

The shares are what the bolt reports in ``info`` (``env_reward``, ``bolt_reward``, which
:class:`~noisybolt.wrappers.BoltVecEnv` writes on every step, training included); a step
without them is refused, and they must add up to the reward the normaliser receives,
which holds for noisybolt's stack (nothing between the bolt and the normaliser changes
rewards) and is checked each step.

On-policy learners only: SB3's replay buffer stores the summed reward and normalises it
as it samples (``VecNormalize.normalize_reward``), which cannot tell the streams apart.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from stable_baselines3.common.running_mean_std import RunningMeanStd
from stable_baselines3.common.vec_env import VecEnv, VecNormalize
from stable_baselines3.common.vec_env.base_vec_env import VecEnvStepReturn

from noisybolt.wrappers._common import BOLT_REWARD_KEY, ENV_REWARD_KEY

__all__ = ["SplitRewardNormalize"]


class SplitRewardNormalize(VecNormalize):
    """Rewards only: ``clip(world / sd_world) + clip(bolt / sd_bolt)``, the two weighed
    ``2 / (1 + bolt_weight)`` and ``2 * bolt_weight / (1 + bolt_weight)`` (module text).

    ``ret_rms`` and ``returns`` are the world stream's statistics, as in
    :class:`VecNormalize`; ``bolt_ret_rms`` and ``bolt_returns`` the bolt's.
    ``normalize_reward`` (what an off-policy buffer would call) is refused: it cannot
    split a summed reward.
    """

    def __init__(
        self,
        venv: VecEnv,
        *,
        gamma: float = 0.99,
        clip_reward: float = 10.0,
        epsilon: float = 1e-8,
        bolt_weight: float = 1.0,
    ) -> None:
        if not bolt_weight > 0:
            raise ValueError(f"bolt_weight must be > 0, got {bolt_weight!r}")
        super().__init__(
            venv,
            training=True,
            norm_obs=False,
            norm_reward=True,
            clip_reward=clip_reward,
            gamma=gamma,
            epsilon=epsilon,
        )
        self.bolt_ret_rms = RunningMeanStd(shape=())
        self.bolt_returns = np.zeros(self.num_envs)
        self.bolt_weight = float(bolt_weight)
        # the two streams' weights: w's mix, adding up to 2 as at w = 1 (module text)
        self._weights = (2 / (1 + self.bolt_weight), 2 * self.bolt_weight / (1 + self.bolt_weight))

    def step_wait(self) -> VecEnvStepReturn:
        obs, rewards, dones, infos = self.venv.step_wait()
        assert isinstance(obs, (np.ndarray, dict))  # a VecEnv's observations (for mypy)
        self.old_obs = obs
        self.old_reward = rewards
        world, bolt = self._shares(np.asarray(rewards, dtype=np.float64), infos)
        if self.training:
            self._update_reward(world)
            self.bolt_returns = self.bolt_returns * self.gamma + bolt
            self.bolt_ret_rms.update(self.bolt_returns)
        world_weight, bolt_weight = self._weights
        scaled = world_weight * self._scaled(world, self.ret_rms) + bolt_weight * self._scaled(
            bolt, self.bolt_ret_rms
        )
        self.returns[dones] = 0
        self.bolt_returns[dones] = 0
        return obs, scaled.astype(np.float32), dones, infos

    @staticmethod
    def _shares(rewards: np.ndarray, infos: list[dict[str, Any]]) -> tuple[np.ndarray, np.ndarray]:
        """The world's and the bolt's shares of each reward, as the bolt reported them.

        Read from ``info`` rather than by subtraction: the summed reward is float32, and
        ``238.6 - 237.6`` in float32 leaves ~1e-5 that a world stream of zeros (tiny
        deviation) would blow up.

        Raises:
            RuntimeError: an info lacks a share (no bolt below), or the shares do not add
                up to the reward (a wrapper between the bolt and the normaliser changed the
                rewards).
        """
        try:
            bolt = np.array([info[BOLT_REWARD_KEY] for info in infos], dtype=np.float64)
            world = np.array([info[ENV_REWARD_KEY] for info in infos], dtype=np.float64)
        except KeyError as missing:
            raise RuntimeError(
                f"a step's info lacks {missing}: normalize_reward=split reads the world's "
                "and the bolt's shares of each reward from the info the restraining bolt "
                "(BoltVecEnv) writes, and needs it below the normaliser"
            ) from None
        if not np.allclose(world + bolt, rewards, rtol=1e-5, atol=1e-5):
            raise RuntimeError(
                f"rewards {rewards.tolist()} are not the world's {world.tolist()} plus the "
                f"bolt's {bolt.tolist()}: a wrapper between the bolt and the normaliser "
                "changed them, which normalize_reward=split cannot split"
            )
        return world, bolt

    def _scaled(self, reward: np.ndarray, stats: RunningMeanStd) -> np.ndarray:
        return np.clip(
            reward / np.sqrt(stats.var + self.epsilon), -self.clip_reward, self.clip_reward
        )

    def normalize_reward(self, reward: np.ndarray) -> np.ndarray:
        raise TypeError(
            "SplitRewardNormalize cannot normalise a summed reward after the fact (its world "
            "and bolt shares are normalised apart, as they are stepped): an off-policy "
            "learner's replay buffer needs normalize_reward true, not split"
        )

    def reset(self) -> Any:
        obs = super().reset()
        self.bolt_returns = np.zeros(self.num_envs)
        return obs
