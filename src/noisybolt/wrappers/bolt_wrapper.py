"""The restraining bolt as a Gymnasium wrapper around one environment."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Protocol, SupportsFloat, runtime_checkable

import gymnasium as gym
import numpy as np

from noisybolt.bolt import DEFAULT_THRESHOLDS, CostMode, Spec, Thresholds, confidence_bands
from noisybolt.errors import ConfigError
from noisybolt.logic.dfa import DFA
from noisybolt.perception.protocols import FluentDetector
from noisybolt.wrappers._common import bolt_info, build_bolt, dict_observation_space

__all__ = ["BoltObservableEnv", "RestrainingBoltWrapper"]


@runtime_checkable
class BoltObservableEnv(Protocol):
    """What a single (unwrapped) environment must offer to be bolted."""

    @property
    def fluent_names(self) -> tuple[str, ...]:
        """The world's fluent vocabulary."""
        ...

    def bolt_image(self) -> np.ndarray:
        """uint8 ``[H, W, C]``: what the bolt's (noisy) camera sees now."""
        ...

    def true_fluents(self) -> np.ndarray:
        """bool ``[n_fluents]``: the ground truth now (metrics only)."""
        ...


class RestrainingBoltWrapper(gym.Wrapper):
    """Adds a restraining bolt to an environment: DFA states in the observation, reward shaped.

    Each step the bolt looks through its own camera (``bolt_image``), the detector turns
    the image into fluent probabilities, and Algorithm 1 moves every spec's DFA and pays
    its reward. The trace starts at the first observation: ``reset`` already moves the
    DFAs, and that transition's reward is added to the first step's.

    Observation: ``Dict{"image": the env's observation, "dfa": MultiDiscrete}``.
    Reward: ``env reward + bolt reward``. ``info`` holds ``env_reward``, ``bolt_reward``,
    per spec ``bolt_terminal`` and ``bolt_low_confidence`` terms, ``fluent_probs``,
    ``confidence_bands``, ``dfa_states``, ``dfa_accepting``, ``dfa_violated``, and, from
    the world's ground truth (metrics only, never in the observation or reward),
    ``true_fluents``, ``true_dfa_states`` and ``true_accepting``.

    Args:
        env: an environment whose ``unwrapped`` meets :class:`BoltObservableEnv`.
        specs: the bolt's specifications (their rewards add up).
        detector: turns bolt images into probabilities over the world's fluents.
        dfas: pre-built DFAs (default: compile each spec's formula).
        thresholds: band thresholds (paper eq. 1).
        cost_mode: ``"count"`` or ``"proportional"``.
        end_on_violation: end the episode (``terminated``) when a spec's DFA enters a
            rejecting sink. Off by default, as in the paper.
    """

    def __init__(
        self,
        env: gym.Env,
        specs: Sequence[Spec],
        detector: FluentDetector,
        *,
        dfas: Sequence[DFA] | None = None,
        thresholds: Thresholds = DEFAULT_THRESHOLDS,
        cost_mode: CostMode = "count",
        end_on_violation: bool = False,
    ) -> None:
        super().__init__(env)
        world = env.unwrapped
        if not isinstance(world, BoltObservableEnv):
            raise ConfigError(
                f"{type(world).__name__} cannot be bolted: it needs fluent_names, "
                "bolt_image() and true_fluents() (see BoltObservableEnv)"
            )
        self._world: BoltObservableEnv = world
        self._detector = detector
        self._thresholds = thresholds
        parts = build_bolt(
            specs,
            detector,
            world.fluent_names,
            n_envs=1,
            dfas=dfas,
            thresholds=thresholds,
            cost_mode=cost_mode,
            end_on_violation=end_on_violation,
        )
        self.bolt = parts.bolt
        self._truth = parts.truth
        self.observation_space = dict_observation_space(env.observation_space, self.bolt.n_states)

    def _look(self) -> tuple[np.ndarray, np.ndarray]:
        truth = np.asarray(self._world.true_fluents(), dtype=bool)[None]
        images = np.asarray(self._world.bolt_image())[None]
        probs = self._detector.predict(images, truth=truth if self._detector.needs_truth else None)
        return probs, truth

    def _observation(self, image: Any, states: np.ndarray) -> dict[str, Any]:
        return {"image": image, "dfa": states.astype(np.int64)}

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, Any], dict[str, Any]]:
        """Resets the env and lets every DFA read the first observation."""
        obs, info = self.env.reset(seed=seed, options=options)
        probs, truth = self._look()
        out = self.bolt.reset(probs)
        self._truth.reset(truth)
        info = dict(info)
        info.update(
            fluent_probs=probs[0],
            dfa_states=out.next_states[0],
            true_dfa_states=self._truth.states[0].copy(),
            true_accepting=self._truth.accepting[0],
        )
        return self._observation(obs, self.bolt.states[0]), info

    def step(self, action: Any) -> tuple[dict[str, Any], SupportsFloat, bool, bool, dict[str, Any]]:
        """Steps the env, moves the DFAs, and returns the shaped reward."""
        obs, env_reward, terminated, truncated, info = self.env.step(action)
        probs, truth = self._look()
        done = np.array([terminated or truncated])
        out = self.bolt.step(probs, done=done)
        self._truth.step(truth)
        if out.terminate[0] and not (terminated or truncated):
            terminated = True
        info = dict(info)
        info.update(
            bolt_info(
                0,
                env_reward=float(env_reward),
                out=out,
                probs=probs,
                bands=confidence_bands(probs, self._thresholds),
                truth=truth,
                true_states=self._truth.states.copy(),
                true_accepting=self._truth.accepting,
            )
        )
        reward = float(env_reward) + float(out.total[0])
        return self._observation(obs, out.next_states[0]), reward, terminated, truncated, info
