"""The restraining bolt over a batch of environments, for training (SB3 ``VecEnv``).

One step renders every environment's bolt view, runs the fluent detector once on the
whole batch, and moves every DFA with the vectorised Algorithm 1. It gives exactly the
rewards and observations of ``n_envs`` separate :class:`RestrainingBoltWrapper` s (tested).

Auto-reset: an SB3 ``VecEnv`` returns, for an environment whose episode just ended, the
*next* episode's first observation, and the old episode's last one in
``infos[i]["terminal_observation"]``. The bolt must read that last observation to finish
the old episode's trace, so the world must also show it: through methods
``final_bolt_images()`` and ``final_true_fluents()`` (batched, rows of environments that
did not end equal to the current view; see
:class:`~noisybolt.perception.protocols.AutoresetBoltObservable`).
The DFAs then restart on the new episode's first observation, and the reward of that
first transition is paid with the environment's next step.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from stable_baselines3.common.vec_env import VecEnv, VecEnvWrapper
from stable_baselines3.common.vec_env.base_vec_env import VecEnvObs, VecEnvStepReturn

from noisybolt.bolt import (
    DEFAULT_THRESHOLDS,
    BeliefSettings,
    CostMode,
    Spec,
    Thresholds,
    Tracking,
    confidence_bands,
)
from noisybolt.errors import ConfigError
from noisybolt.logic.dfa import DFA
from noisybolt.perception.protocols import AutoresetBoltObservable, FluentDetector
from noisybolt.wrappers._common import (
    bolt_info,
    build_bolt,
    dfa_view,
    dict_observation_space,
    observes_beliefs,
)

__all__ = ["BoltVecEnv"]


class BoltVecEnv(VecEnvWrapper):
    """Adds a restraining bolt to a vectorised world (see the module docstring).

    Args:
        venv: the world as an SB3 ``VecEnv`` (possibly wrapped, e.g. in ``VecMonitor``:
            put monitors *below* the bolt so they record environment returns).
        specs: the bolt's specifications.
        detector: fluent detector, called once per step on the whole batch.
        world: the object meeting :class:`AutoresetBoltObservable` (default
            ``venv.unwrapped``).
        dfas, thresholds, cost_mode: as in :class:`~noisybolt.wrappers.RestrainingBoltWrapper`.
        progress_gamma, shaping, world_letters, pay_at_truncation: the compliance scheme's
            progress terms and its ending (see
            :func:`~noisybolt.wrappers._common.build_bolt`); None for none.
        end_on_violation: must be False here (see the error it raises).
        tracking, belief: ``"threshold"`` (Algorithm 1) or ``"belief"`` tracking and its
            settings, as in :class:`~noisybolt.wrappers.RestrainingBoltWrapper`.
    """

    def __init__(
        self,
        venv: VecEnv,
        specs: Sequence[Spec],
        detector: FluentDetector,
        *,
        world: AutoresetBoltObservable | None = None,
        dfas: Sequence[DFA] | None = None,
        thresholds: Thresholds = DEFAULT_THRESHOLDS,
        cost_mode: CostMode = "count",
        end_on_violation: bool = False,
        progress_gamma: float | None = None,
        shaping: bool = True,
        world_letters: np.ndarray | None = None,
        pay_at_truncation: bool = True,
        tracking: Tracking = "threshold",
        belief: BeliefSettings | None = None,
    ) -> None:
        if end_on_violation:
            # Ending an episode that the world did not end needs a per-environment reset,
            # which the SB3 VecEnv interface does not offer.
            raise ConfigError(
                "end_on_violation is not supported by the batched bolt; use "
                "RestrainingBoltWrapper around single environments for it"
            )
        world = world if world is not None else venv.unwrapped  # type: ignore[assignment]
        if not isinstance(world, AutoresetBoltObservable):
            raise ConfigError(
                f"{type(world).__name__} cannot be bolted: it needs fluent_names, num_envs, "
                "camera_spec, bolt_images(), true_fluents(), final_bolt_images() and "
                "final_true_fluents() (see AutoresetBoltObservable); for your own Gymnasium "
                "env use noisybolt.make_bolted_vec_env"
            )
        parts = build_bolt(
            specs,
            detector,
            world.fluent_names,
            n_envs=venv.num_envs,
            dfas=dfas,
            thresholds=thresholds,
            cost_mode=cost_mode,
            end_on_violation=end_on_violation,
            progress_gamma=progress_gamma,
            shaping=shaping,
            world_letters=world_letters,
            pay_at_truncation=pay_at_truncation,
            tracking=tracking,
            belief=belief,
        )
        self.bolt = parts.bolt
        self._truth = parts.truth
        self._world = world
        self._detector = detector
        self._thresholds = thresholds
        super().__init__(
            venv,
            observation_space=dict_observation_space(
                venv.observation_space, self.bolt.n_states, beliefs=observes_beliefs(self.bolt)
            ),
        )

    @property
    def world(self) -> AutoresetBoltObservable:
        """The bolted world."""
        return self._world

    def _probs(self, images: np.ndarray, truth: np.ndarray) -> np.ndarray:
        return self._detector.predict(images, truth=truth if self._detector.needs_truth else None)

    def _obs(self, image: Any, dfa: np.ndarray) -> dict[str, Any]:
        return {"image": image, "dfa": dfa.copy()}

    def reset(self) -> VecEnvObs:
        """Resets every environment; every DFA reads its first observation."""
        obs = self.venv.reset()
        truth = np.asarray(self._world.true_fluents(), dtype=bool)
        probs = self._probs(self._world.bolt_images(), truth)
        self.bolt.reset(probs)
        self._truth.reset(truth)
        return self._obs(obs, dfa_view(self.bolt))

    def step_wait(self) -> VecEnvStepReturn:
        """Steps the world, moves the DFAs, shapes rewards, restarts ended episodes."""
        obs, env_rewards, dones, infos = self.venv.step_wait()
        dones = np.asarray(dones, dtype=bool)
        images = self._world.bolt_images()
        truth = np.asarray(self._world.true_fluents(), dtype=bool)
        ended = np.flatnonzero(dones)
        # The step's transition reads each ended episode's last observation, not the new
        # episode's first; keep the new ones for the restart below.
        first_images, first_truth = images, truth
        if ended.size:
            images = self._world.final_bolt_images()
            truth = np.asarray(self._world.final_true_fluents(), dtype=bool)
            # One detector call for the ended episodes' last views and the new episodes'
            # first views together: a call on a few images costs mostly its overhead.
            both = self._probs(
                np.concatenate([images, first_images[ended]]),
                np.concatenate([truth, first_truth[ended]]),
            )
            probs, first_probs = both[: self.num_envs], both[self.num_envs :]
        else:
            probs = self._probs(images, truth)
        # SB3's convention: a time limit's cut is flagged in the step's info.
        truncated = np.array([bool(info.get("TimeLimit.truncated")) for info in infos])
        out = self.bolt.step(probs, done=dones, truncated=truncated & dones)
        final_view = dfa_view(self.bolt)  # the ended episodes' last view, before restarting
        self._truth.step(truth)
        true_states, true_accepting = self._truth.states.copy(), self._truth.accepting
        rewards = np.asarray(env_rewards, dtype=np.float64) + out.total
        bands = confidence_bands(probs, self._thresholds)
        infos = list(infos)
        for i in range(self.num_envs):
            info = infos[i]  # the world's own dict for this step: extended in place
            info.update(
                bolt_info(
                    i,
                    env_reward=float(env_rewards[i]),
                    out=out,
                    probs=probs,
                    bands=bands,
                    truth=truth,
                    true_states=true_states,
                    true_accepting=true_accepting,
                )
            )
            if dones[i] and "terminal_observation" in info:
                info["terminal_observation"] = self._obs(
                    info["terminal_observation"], final_view[i]
                )
        if ended.size:
            # Rows outside the mask are checked but not read: zeros will do.
            full = np.zeros_like(probs)
            full[ended] = first_probs
            self.bolt.reset(full, env_mask=dones)
            self._truth.reset(first_truth, env_mask=dones)
        return self._obs(obs, dfa_view(self.bolt)), rewards.astype(np.float32), dones, infos
