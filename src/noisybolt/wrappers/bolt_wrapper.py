"""The restraining bolt as a Gymnasium wrapper around one environment."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Protocol, SupportsFloat, runtime_checkable

import gymnasium as gym
import numpy as np

from noisybolt.bolt import (
    DEFAULT_THRESHOLDS,
    BeliefSettings,
    BoltSettings,
    CostMode,
    Spec,
    Thresholds,
    Tracking,
    confidence_bands,
    episode_costs,
)
from noisybolt.bolt.settings import settings_from_keywords
from noisybolt.envs.labels import (
    collect_labelled_samples,
    declares_goal_of,
    fluent_names_of,
    labels_from_info,
)
from noisybolt.logic.dfa import DFA
from noisybolt.perception.detectors import reseed_detector
from noisybolt.perception.protocols import FluentDetector
from noisybolt.wrappers._common import (
    EPISODE_COST_KEY,
    bolt_info,
    build_bolt,
    check_flat_observation,
    detector_output,
    dfa_view,
    dict_observation_space,
    observes_beliefs,
)
from noisybolt.wrappers._inputs import DetectorName, coerce_specs, resolve_detector

__all__ = ["BoltObservableEnv", "RestrainingBoltWrapper"]


@runtime_checkable
class BoltObservableEnv(Protocol):
    """What a single environment must declare to be bolted: its fluent vocabulary.

    The rest of the contract is its ``info`` at reset and step (``bolt_image`` and
    ``true_fluents``, see :mod:`noisybolt.perception.protocols`). Any Gymnasium env gets
    both from :class:`noisybolt.FluentLabels`; the shipped worlds have them natively.
    ``fluent_names`` is read with ``env.get_wrapper_attr``, so it may sit on any wrapper.
    """

    @property
    def fluent_names(self) -> tuple[str, ...]:
        """The world's fluent vocabulary, in the column order of ``info["true_fluents"]``."""
        ...


class RestrainingBoltWrapper(gym.Wrapper, gym.utils.RecordConstructorArgs):
    """Adds a restraining bolt to an environment: DFA states in the observation, reward shaped.

    Each step the bolt looks through its own camera (the env's ``info["bolt_image"]``),
    the detector turns the image into fluent probabilities, and Algorithm 1 moves every
    spec's DFA and pays its reward. The trace starts at the first observation: ``reset``
    already moves the DFAs, and that transition's reward is added to the first step's.

    Observation: ``Dict{"image": the env's observation, "dfa": MultiDiscrete}`` (with
    ``tracking="belief"``: ``"dfa"`` is a float32 Box of the beliefs over each spec's
    states, or their most likely states as a MultiDiscrete, see
    :class:`~noisybolt.bolt.BeliefSettings`).
    Reward: ``env reward + bolt reward``. ``info`` holds ``env_reward``, ``bolt_reward``,
    per spec ``bolt_terminal`` and ``bolt_low_confidence`` terms, ``fluent_probs``,
    ``confidence_bands``, ``dfa_states``, ``dfa_accepting``, ``dfa_violated``, and, from
    the world's ground truth (metrics only, never in the observation or reward),
    ``true_fluents``, ``true_dfa_states`` and ``true_accepting``. The reset's ``info``
    holds the same of the first letter but the rewards (the reset transition's reward is
    paid with the first step's).

    Args:
        env: a labelled environment (see :class:`BoltObservableEnv`), e.g. one wrapped
            in :class:`noisybolt.FluentLabels`.
        specs: the bolt's specifications (their rewards add up): :class:`Spec` s or LTLf
            formulas as text (text gets the paper's rewards: +1 per accepting step, a
            cost of 0.5 per low-confidence fluent on the edge taken).
        detector: turns bolt images into probabilities over the world's fluents: a
            :class:`FluentDetector`, or ``"oracle"``, ``"synthetic"`` (seeded Beta noise
            on the truth) or ``"classifier"`` (trained here on ``classifier_samples``
            images of the env played at random, which resets and plays the env).
        dfas: pre-built DFAs (default: compile each spec's formula).
        settings: the bolt's settings (:class:`~noisybolt.bolt.BoltSettings`): band
            thresholds (paper eq. 1), cost mode, reward scheme (e.g.
            ``RewardScheme("compliance", scale=...)``, whose progress terms are then
            added), tracking (``"belief"``: ``info["dfa_accepting"]`` is whether the
            probability of acceptance reaches the confidence level), ``end_on_violation``
            (end the episode, ``terminated``, when a spec's DFA enters a rejecting sink;
            off by default, as in the paper) and ``pay_at_truncation``. None: built from
            the keyword arguments ``thresholds``, ``cost_mode``, ``end_on_violation``,
            ``tracking`` and ``belief``, which stay for code written before it (giving
            both is refused).
        world_letters: true fluents the world produces (bool ``[n, n_fluents]``), so that
            a scheme's progress terms count only steps the world can take.
        seed: seeds a detector built by name.
        classifier_samples: images to train a ``"classifier"`` detector on.

    Raises:
        UnlabelledEnvError: the env declares no ``fluent_names`` (or, at reset or step,
            its ``info`` lacks the labels).
        UnknownFluentError: a spec reads a fluent the env does not have.
        UnknownNameError: an unknown detector name.

    Example:
        >>> import gymnasium as gym
        >>> from noisybolt import FluentLabels
        >>> lake = FluentLabels(
        ...     gym.make("FrozenLake-v1", render_mode="rgb_array", is_slippery=False),
        ...     fluents={"top_row": lambda lake: lake.s < 4},
        ... )
        >>> env = RestrainingBoltWrapper(lake, ["G(top_row)"], "oracle")
        >>> obs, info = env.reset(seed=0)
        >>> obs["dfa"].tolist(), info["true_accepting"].tolist()
        ([0], [True])
        >>> obs, reward, *_ = env.step(2)  # right: still on the top row
        >>> reward  # env reward 0, +1 accepting now, +1 carried from the reset transition
        2.0
    """

    def __init__(
        self,
        env: gym.Env,
        specs: Spec | str | Sequence[Spec | str],
        detector: FluentDetector | DetectorName,
        *,
        dfas: Sequence[DFA] | None = None,
        settings: BoltSettings | None = None,
        world_letters: np.ndarray | None = None,
        seed: int = 0,
        classifier_samples: int = 2000,
        thresholds: Thresholds = DEFAULT_THRESHOLDS,
        cost_mode: CostMode = "count",
        end_on_violation: bool = False,
        tracking: Tracking = "threshold",
        belief: BeliefSettings | None = None,
    ) -> None:
        gym.utils.RecordConstructorArgs.__init__(
            self,
            specs=specs,
            detector=detector,
            dfas=dfas,
            settings=settings,
            world_letters=world_letters,
            thresholds=thresholds,
            cost_mode=cost_mode,
            end_on_violation=end_on_violation,
            seed=seed,
            classifier_samples=classifier_samples,
            tracking=tracking,
            belief=belief,
        )
        super().__init__(env)
        settings = settings_from_keywords(
            settings,
            {
                "thresholds": thresholds,
                "cost_mode": cost_mode,
                "end_on_violation": end_on_violation,
                "tracking": tracking,
                "belief": belief,
            },
            owner="RestrainingBoltWrapper",
        )
        check_flat_observation(env.observation_space)  # before a classifier is trained
        fluent_names = fluent_names_of(env)
        specs = coerce_specs(specs)
        detector = resolve_detector(
            detector,
            fluent_names,
            seed=seed,
            samples=lambda: collect_labelled_samples(
                env, num_samples=classifier_samples, seed=seed
            ),
            specs=specs,
        )
        self._thresholds = settings.thresholds
        parts = build_bolt(
            specs,
            detector,
            fluent_names,
            n_envs=1,
            settings=settings,
            dfas=dfas,
            world_letters=world_letters,
        )
        self.bolt = parts.bolt
        self._truth = parts.truth
        self._detector = parts.detector
        self.observation_space = dict_observation_space(
            env.observation_space, self.bolt.n_states, beliefs=observes_beliefs(self.bolt)
        )

    def _look(self, info: dict[str, Any], where: str) -> tuple[np.ndarray, np.ndarray]:
        image, truth = labels_from_info(info, where=where)
        probs = detector_output(
            self._detector.predict(
                image[None], truth=truth[None] if self._detector.needs_truth else None
            ),
            self._detector,
            rows=1,
        )
        return probs, truth[None]

    def _observation(self, image: Any) -> dict[str, Any]:
        return {"image": image, "dfa": dfa_view(self.bolt)[0]}

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, Any], dict[str, Any]]:
        """Resets the env and lets every DFA read the first observation."""
        obs, info = self.env.reset(seed=seed, options=options)
        reseed_detector(self._detector, seed)  # seeded episodes see the same noise
        probs, truth = self._look(info, "reset")
        out = self.bolt.reset(probs)
        self._truth.reset(truth)
        info = dict(info)
        info.update(
            fluent_probs=probs[0],
            confidence_bands=confidence_bands(probs, self._thresholds)[0],
            dfa_states=out.next_states[0],
            dfa_accepting=out.accepting[0],
            dfa_violated=out.violated[0],
            true_dfa_states=self._truth.states[0].copy(),
            true_accepting=self._truth.accepting[0],
        )
        return self._observation(obs), info

    def step(self, action: Any) -> tuple[dict[str, Any], SupportsFloat, bool, bool, dict[str, Any]]:
        """Steps the env, moves the DFAs, and returns the shaped reward."""
        obs, env_reward, terminated, truncated, info = self.env.step(action)
        probs, truth = self._look(info, "step")
        done = np.array([terminated or truncated])
        out = self.bolt.step(probs, done=done)
        self._truth.step(truth)
        info = dict(info)
        if out.terminate[0] and not (terminated or truncated):
            terminated = True
            if declares_goal_of(self.env):  # ended by the bolt, not at the goal
                info.setdefault("is_success", False)
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
        if terminated or truncated:
            info[EPISODE_COST_KEY] = float(episode_costs(out.accepting, np.ones(1, bool))[0])
        reward = float(env_reward) + float(out.total[0])
        return self._observation(obs), reward, terminated, truncated, info
