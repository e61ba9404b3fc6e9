"""Atari training conventions that must sit on the right side of the bolt.

SB3's ``AtariWrapper`` clips rewards to their sign and ends the *learner's* episode when
a life is lost (``EpisodicLifeEnv``). Both help learning a great deal, but neither can be
applied to the world as a whole here:

- Clipping must touch the game's score only, not the bolt's rewards, so
  :class:`ClipGameReward` goes *below* :class:`~noisybolt.wrappers.BoltVecEnv` (above the
  ``VecMonitor`` that records the true score).
- A lost life must not end the bolt's episode: the specs speak of whole games (the left
  column is cleared over several lives), and restarting the DFAs at each life would pay
  an ``F(...)`` milestone again for a brick that is already gone. So
  :class:`LifeLossTerminal` goes *above* the bolt: it only tells the learner ``done``
  (no bootstrapping past a lost life), while the game and the DFAs carry on; the
  observation after the lost life is the game's real next one, which is also what
  off-policy replay stores as the transition's next observation.

Evaluation runs the plain game (neither wrapper), so scores and compliance are the real
ones.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from stable_baselines3.common.vec_env import VecEnv, VecEnvWrapper
from stable_baselines3.common.vec_env.base_vec_env import VecEnvObs, VecEnvStepReturn

__all__ = ["ClipGameReward", "LifeLossTerminal"]


class ClipGameReward(VecEnvWrapper):
    """Rewards replaced by their sign (-1, 0, +1), as DQN's Atari recipe does.

    The original reward is kept in ``infos[i]["unclipped_reward"]``.
    """

    def reset(self) -> VecEnvObs:
        return self.venv.reset()

    def step_wait(self) -> VecEnvStepReturn:
        obs, rewards, dones, infos = self.venv.step_wait()
        for info, reward in zip(infos, rewards, strict=True):
            info["unclipped_reward"] = float(reward)
        return obs, np.sign(rewards).astype(rewards.dtype), dones, infos


class LifeLossTerminal(VecEnvWrapper):
    """``done`` for the learner when a game loses a life; the game itself goes on.

    Args:
        venv: the (bolted) environments.
        lives: returns the lives left in every game, int ``[num_envs]``, read after each
            step (e.g. ``BreakoutWorld.lives``); a game that really ended is ``done``
            already and its new game's lives are taken as the new reference.

    A lost life is marked ``infos[i]["life_lost"] = True``; no ``terminal_observation``
    is added, since the observation returned is the real next one of the same game.
    """

    def __init__(self, venv: VecEnv, lives: Callable[[], np.ndarray]) -> None:
        super().__init__(venv)
        self._read_lives = lives
        self._lives = np.zeros(venv.num_envs, dtype=np.int64)

    def _current_lives(self) -> np.ndarray:
        lives = np.asarray(self._read_lives(), dtype=np.int64)
        if lives.shape != (self.num_envs,):
            raise ValueError(f"lives() must return [{self.num_envs}] values, got {lives.shape}")
        return lives

    def reset(self) -> VecEnvObs:
        obs = self.venv.reset()
        self._lives = self._current_lives()
        return obs

    def step_wait(self) -> VecEnvStepReturn:
        obs, rewards, dones, infos = self.venv.step_wait()
        lives = self._current_lives()
        lost = ~dones & (lives < self._lives)
        for i in np.flatnonzero(lost):
            infos[i]["life_lost"] = True
        self._lives = lives
        return obs, rewards, dones | lost, infos
