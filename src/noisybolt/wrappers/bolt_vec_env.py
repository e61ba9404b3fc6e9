"""The restraining bolt over a batch of environments, for training (SB3 ``VecEnv``).

One step reads every environment's bolt view, runs the fluent detector once on the
whole batch, and moves every DFA with the vectorised Algorithm 1. It gives exactly the
rewards and observations of ``n_envs`` separate :class:`RestrainingBoltWrapper` s (tested).

What the bolt sees is the world's batched ``info`` and nothing else (the contract of
:mod:`noisybolt.perception.protocols`): ``info["bolt_image"]`` and
``info["true_fluents"]`` at reset and step. The world is a Gymnasium vector env under an
:class:`~noisybolt.envs.sb3.SB3VecEnv`, whose :attr:`~noisybolt.envs.sb3.SB3VecEnv.batched_info`
hands the bolt that ``info`` as the world gave it, before SB3's per-env dicts are made:
the images stay one array (no split and restack each step), and a world's deferred camera
renders once, when the bolt reads it. SB3 wrappers in between (``VecMonitor``, reward
clipping) see the SB3 side as usual.

Auto-reset: the world starts an ended episode's successor in the same step (SB3's
convention too: the old episode's last observation is in
``infos[i]["terminal_observation"]``). The bolt must read that episode's last view to
finish its trace: it is in ``info["final_info"]`` under the same keys. The DFAs then
restart on the new episode's first view, and the reward of that first transition is paid
with the environment's next step.
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
    BoltSettings,
    CostMode,
    Spec,
    Thresholds,
    Tracking,
    confidence_bands,
    episode_costs,
)
from noisybolt.bolt.settings import settings_from_keywords
from noisybolt.envs.deferred import DeferredArray
from noisybolt.envs.labels import batched_labels_from_info, carries
from noisybolt.envs.sb3 import SB3VecEnv
from noisybolt.errors import ConfigError, UnlabelledEnvError
from noisybolt.logic.dfa import DFA
from noisybolt.perception.detectors import reads_images, reseed_detector
from noisybolt.perception.protocols import BOLT_PROBS_KEY, FINAL_INFO_KEY, FluentDetector
from noisybolt.wrappers._common import (
    EPISODE_COST_KEY,
    bolt_info,
    build_bolt,
    check_flat_observation,
    detector_output,
    dfa_view,
    dict_observation_space,
    observes_beliefs,
    reward_shares,
)

__all__ = ["BOLT_CARRIED_KEY", "BOLT_DONE_KEY", "FLUENT_PROBS_KEY", "BoltVecEnv"]

#: ``transition_records``: the ``info`` entries of what the bolt's transition of a step
#: read (float64 ``[n_fluents]``; bool: its episode ended with this step, the world's
#: ``done``; float: the reward of the reset transition paid with this step).
FLUENT_PROBS_KEY = "fluent_probs"
BOLT_DONE_KEY = "bolt_done"
BOLT_CARRIED_KEY = "bolt_carried"


class BoltVecEnv(VecEnvWrapper):
    """Adds a restraining bolt to a vectorised world (see the module docstring).

    Args:
        venv: the world as an SB3 ``VecEnv``: an :class:`~noisybolt.envs.sb3.SB3VecEnv`
            over a labelled Gymnasium vector env, possibly wrapped (e.g. in ``VecMonitor``:
            put monitors *below* the bolt so they record environment returns).
        specs: the bolt's specifications.
        detector: fluent detector, called once per step on the whole batch.
        world: the Gymnasium vector env under ``venv``'s ``SB3VecEnv``, if the caller
            wants it checked (None: taken from ``venv``).
        dfas: pre-built DFAs (default: compile each spec's formula).
        settings: the bolt's settings (:class:`~noisybolt.bolt.BoltSettings`: bands, cost
            mode, reward scheme and its progress terms, tracking, ending); its
            ``end_on_violation`` must be False here (see the error it raises). None: built
            from the keyword arguments of old (``thresholds``, ``cost_mode``,
            ``end_on_violation``, ``pay_at_truncation``, ``tracking``, ``belief``, and
            ``progress_gamma`` with ``shaping``: the compliance scheme's progress terms at
            each spec's own reward; see
            :func:`~noisybolt.bolt.settings.settings_from_keywords`); giving both is
            refused.
        world_letters: true fluents the world produces (bool ``[n, n_fluents]``, e.g.
            from random play), so progress terms count only steps the world can take.
        info_records: whether each step's ``infos`` get the bolt's records (reward parts,
            fluent probabilities and bands, the bolt's and the true DFA states: see
            :func:`~noisybolt.wrappers._common.bolt_info`). False leaves them out, but for
            the reward's two shares (``env_reward``, ``bolt_reward``: what
            ``normalize_reward: split`` reads), and does not track the true DFAs, for a
            learner that reads none of them (training: SB3 reads only the monitor's, the
            time limit's and the terminal observation's entries, and evaluation runs on
            envs of its own, with records); observations, rewards and dones are the same
            either way (tested).
        transition_records: whether each step's ``infos`` also get what the bolt's
            transition read, so a learner can replay it from other DFA states
            (counterfactual experience, :mod:`noisybolt.agents.counterfactual`): the
            fluent probabilities (:data:`FLUENT_PROBS_KEY`), whether the bolt's episode
            ended (:data:`BOLT_DONE_KEY`) and the reward carried from its reset
            (:data:`BOLT_CARRIED_KEY`), beside the reward's two shares.

    Raises:
        ConfigError: ``venv`` is not an ``SB3VecEnv`` (possibly wrapped), or ``world`` is
            not the world under it.
        UnlabelledEnvError: the world names no ``fluent_names`` (or, at reset or step, its
            ``info`` lacks the labels).
    """

    def __init__(
        self,
        venv: VecEnv,
        specs: Sequence[Spec],
        detector: FluentDetector,
        *,
        world: object | None = None,
        dfas: Sequence[DFA] | None = None,
        settings: BoltSettings | None = None,
        world_letters: np.ndarray | None = None,
        info_records: bool = True,
        transition_records: bool = False,
        thresholds: Thresholds = DEFAULT_THRESHOLDS,
        cost_mode: CostMode = "count",
        end_on_violation: bool = False,
        progress_gamma: float | None = None,
        shaping: bool = True,
        pay_at_truncation: bool = True,
        tracking: Tracking = "threshold",
        belief: BeliefSettings | None = None,
    ) -> None:
        settings = settings_from_keywords(
            settings,
            {
                "thresholds": thresholds,
                "cost_mode": cost_mode,
                "end_on_violation": end_on_violation,
                "pay_at_truncation": pay_at_truncation,
                "tracking": tracking,
                "belief": belief,
                "progress_gamma": progress_gamma,
                "shaping": shaping,
            },
            owner="BoltVecEnv",
            specs=specs,
        )
        if settings.end_on_violation:
            # Ending an episode that the world did not end needs a per-environment reset,
            # which the SB3 VecEnv interface does not offer.
            raise ConfigError(
                "end_on_violation is not supported by the batched bolt; use "
                "RestrainingBoltWrapper around single environments for it"
            )
        check_flat_observation(venv.observation_space)
        source = venv.unwrapped
        if not isinstance(source, SB3VecEnv):
            raise ConfigError(
                f"the batched bolt reads a Gymnasium vector env's batched info through "
                f"SB3VecEnv, but {type(source).__name__} is at the bottom of venv: build it as "
                "SB3VecEnv(world) (SB3 wrappers on top are fine); for your own Gymnasium env "
                "use noisybolt.make_bolted_vec_env"
            )
        if world is not None and world is not source.venv:
            raise ConfigError(
                f"world ({type(world).__name__}) is not the vector env under venv's SB3VecEnv "
                f"({type(source.venv).__name__}); leave it out"
            )
        try:
            fluent_names = tuple(source.fluent_names)
        except AttributeError:
            raise UnlabelledEnvError(
                f"{type(source.venv).__name__} names no fluent_names: a bolted vector env "
                "names its fluents and puts the bolt's labels in its info (see "
                "noisybolt.perception.protocols); for your own Gymnasium env use "
                "noisybolt.make_bolted_vec_env"
            ) from None
        parts = build_bolt(
            specs,
            detector,
            fluent_names,
            n_envs=venv.num_envs,
            settings=settings,
            dfas=dfas,
            world_letters=world_letters,
        )
        self.bolt = parts.bolt
        self._truth = parts.truth
        self._source = source
        self._detector = parts.detector
        # A world that runs this bolt's own detector beside its camera (WorkerWorld with
        # the run's classifier) puts its probabilities in info: read, not recomputed.
        self._world_probs = getattr(source.venv, "detector", None) is detector
        # A detector that reads the truth only is handed the world's images unrendered,
        # and so are a world's probabilities' images.
        self._reads_images = reads_images(parts.detector) and not self._world_probs
        self._thresholds = settings.thresholds
        self._records = bool(info_records)
        self._transition_records = bool(transition_records)
        # Whether a time limit's cut is paid as an end: what a replay of the bolt's
        # transitions needs to know (noisybolt.agents.counterfactual).
        self.pay_at_truncation = settings.pay_at_truncation
        super().__init__(
            venv,
            observation_space=dict_observation_space(
                venv.observation_space, self.bolt.n_states, beliefs=observes_beliefs(self.bolt)
            ),
        )

    @property
    def price(self) -> float:
        """The bolt's price (:attr:`~noisybolt.bolt.RestrainingBolt.price`): what its specs'
        payments are multiplied by; the ``constrained`` scheme sets it while training."""
        return self.bolt.price

    @price.setter
    def price(self, value: float) -> None:
        self.bolt.price = value

    @property
    def world(self) -> Any:
        """The bolted world: the Gymnasium vector env under the ``SB3VecEnv``."""
        return self._source.venv

    def _labels(self, where: str, rows: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """The world's labels in its info of this reset or step (with ``rows``: the ended
        episodes' last ones, from ``final_info``)."""
        info = self._source.batched_info
        if rows is not None:
            info = info.get(FINAL_INFO_KEY, {})
        return batched_labels_from_info(
            info, self.num_envs, where=where, rows=rows, read_images=self._reads_images
        )

    def _probs(self, images: np.ndarray, truth: np.ndarray) -> np.ndarray:
        probs = self._detector.predict(images, truth=truth if self._detector.needs_truth else None)
        return detector_output(probs, self._detector, rows=len(images))

    def _probs_of_world(self, where: str, rows: np.ndarray | None = None) -> np.ndarray:
        """The detector's probabilities the world computed (``_world_probs``) of this
        reset's or step's views (with ``rows``: of ``final_info``, the ended games' last
        views there, this step's elsewhere)."""
        info = self._source.batched_info
        if rows is not None:
            info = info.get(FINAL_INFO_KEY, {})
        if not carries(info, BOLT_PROBS_KEY, rows):
            raise UnlabelledEnvError(
                f"the world's info at {where} has no {BOLT_PROBS_KEY!r} although the world "
                "runs the bolt's detector (its detector attribute): its workers must put "
                "the probabilities beside the images"
            )
        return detector_output(info[BOLT_PROBS_KEY], self._detector, rows=self.num_envs)

    def _obs(self, image: Any, dfa: np.ndarray) -> dict[str, Any]:
        return {"image": image, "dfa": dfa.copy()}

    def seed(self, seed: int | None = None) -> Sequence[int | None]:
        """Seeds the next reset of the environments (SB3's ``VecEnv.seed``) and restarts
        the detector's noise from ``seed`` (:func:`~noisybolt.perception.detectors.
        reseed_detector`)."""
        reseed_detector(self._detector, seed)
        return self.venv.seed(seed)

    def reset(self) -> VecEnvObs:
        """Resets every environment; every DFA reads its first observation."""
        obs = self.venv.reset()
        images, truth = self._labels("reset")
        probs = self._probs_of_world("reset") if self._world_probs else self._probs(images, truth)
        out = self.bolt.reset(probs)
        if self._records:
            self._truth.reset(truth)
            # What the single wrapper's reset info says of the first letter, per env.
            bands = confidence_bands(probs, self._thresholds)
            self.reset_infos = [
                {
                    "true_fluents": truth[i],
                    "fluent_probs": probs[i],
                    "confidence_bands": bands[i],
                    "dfa_states": out.next_states[i],
                    "dfa_accepting": out.accepting[i],
                    "dfa_violated": out.violated[i],
                    "true_dfa_states": self._truth.states[i].copy(),
                    "true_accepting": self._truth.accepting[i],
                }
                for i in range(self.num_envs)
            ]
        return self._obs(obs, dfa_view(self.bolt))

    def step_wait(self) -> VecEnvStepReturn:
        """Steps the world, moves the DFAs, shapes rewards, restarts ended episodes."""
        obs, env_rewards, dones, infos = self.venv.step_wait()
        dones = np.asarray(dones, dtype=bool)
        n = self.num_envs
        images, truth = self._labels("step")
        ended = np.flatnonzero(dones)
        # The step's transition reads each ended episode's last observation, not the new
        # episode's first; keep the new ones for the restart below.
        first_truth = truth
        truncated = np.zeros(n, dtype=bool)  # SB3 flags a time limit's cut in the info
        if ended.size:
            last_images, last_truth = self._labels("step", rows=ended)
            truth = truth.copy()
            truth[ended] = last_truth[ended]
            if self._world_probs:  # this step's views: the new episodes' first ones
                now = self._probs_of_world("step")
                probs, first_probs = now.copy(), now[ended]
                probs[ended] = self._probs_of_world("step", rows=ended)[ended]
            else:
                # One detector call for the ended episodes' last views and the new
                # episodes' first views together (a call on a few images costs mostly its
                # overhead): rows [0, n) are the views the step's transition reads, rows
                # n.. the first views of the new episodes. Assembled in one buffer, one
                # copy of the images (when read: a detector of the truth only is handed
                # the batch unrendered).
                batch = _views_batch(images, last_images, ended)
                both = self._probs(batch, np.concatenate([truth, first_truth[ended]]))
                probs, first_probs = both[:n], both[n:]
            for row in ended.tolist():
                truncated[row] = bool(infos[row].get("TimeLimit.truncated"))
        elif self._world_probs:
            probs = self._probs_of_world("step")
        else:
            probs = self._probs(images, truth)
        out = self.bolt.step(probs, done=dones, truncated=truncated)
        rewards = np.asarray(env_rewards, dtype=np.float64) + out.total
        infos = list(infos)
        if self._records:
            self._truth.step(truth)
            bands = confidence_bands(probs, self._thresholds)
            true_states, true_accepting = self._truth.states.copy(), self._truth.accepting
            for i, info in enumerate(infos):
                info.update(  # the world's own dict for this step: extended in place
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
        else:
            # The reward's two shares, always: a learner's normaliser may read them
            # (``normalize_reward: split``, noisybolt.wrappers.SplitRewardNormalize).
            for i, info in enumerate(infos):
                info.update(reward_shares(env_rewards[i], out.total[i]))
        if self._transition_records:
            for i, info in enumerate(infos):
                info[FLUENT_PROBS_KEY] = probs[i]
                info[BOLT_DONE_KEY] = bool(dones[i])
                info[BOLT_CARRIED_KEY] = float(out.carried[i])
        if ended.size:
            final_view = dfa_view(self.bolt)  # the ended episodes' last view, before restarting
            costs = episode_costs(out.accepting, dones)
            for row in ended.tolist():
                info = infos[row]
                info[EPISODE_COST_KEY] = float(costs[row])
                if "terminal_observation" in info:
                    info["terminal_observation"] = self._obs(
                        info["terminal_observation"], final_view[row]
                    )
            # Rows outside the mask are checked but not read: zeros will do.
            full = np.zeros_like(probs)
            full[ended] = first_probs
            self.bolt.reset(full, env_mask=dones)
            if self._records:
                self._truth.reset(first_truth, env_mask=dones)
                # The new episodes' first letters, as reset() records them: the step's
                # info describes the ended episodes' last (a compliance estimate needs
                # every frame of an episode, its first included).
                first_bands = confidence_bands(first_probs, self._thresholds)
                for j, row in enumerate(ended.tolist()):
                    self.reset_infos[row] = {
                        "true_fluents": first_truth[row],
                        "fluent_probs": first_probs[j],
                        "confidence_bands": first_bands[j],
                    }
        return self._obs(obs, dfa_view(self.bolt)), rewards.astype(np.float32), dones, infos


def _views_batch(images: Any, last_images: Any, ended: np.ndarray) -> Any:
    """``[n + len(ended), H, W, C]``: the step's views with the ended episodes' last ones in
    their rows, then the ended envs' new first views; deferred if ``images`` is."""
    n = len(images)
    shape = (n + ended.size, *images.shape[1:])

    def assemble() -> np.ndarray:
        now = np.asarray(images)
        batch = np.empty(shape, dtype=now.dtype)
        batch[:n] = now
        batch[ended] = np.asarray(last_images)[ended]
        batch[n:] = now[ended]
        return batch

    if isinstance(images, DeferredArray):
        return DeferredArray(assemble, shape=shape, dtype=images.dtype)
    return assemble()
