"""What the single and the batched bolt wrappers share: checks, spaces and info records."""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from typing import Any

import gymnasium as gym
import numpy as np

from noisybolt.bolt import BoltSettings, BoltStep, RestrainingBolt, Spec
from noisybolt.bolt.bands import check_probs
from noisybolt.bolt.spec import check_satisfiable, vacuous_message
from noisybolt.errors import DetectorOutputError, ObservationSpaceError, UnknownBaseRatesWarning
from noisybolt.logic import compile_ltlf
from noisybolt.logic.dfa import DFA
from noisybolt.perception.detectors import match_fluents
from noisybolt.perception.protocols import FluentDetector

__all__ = [
    "BOLT_REWARD_KEY",
    "ENV_REWARD_KEY",
    "BoltParts",
    "TruthTracker",
    "bolt_info",
    "build_bolt",
    "check_flat_observation",
    "detector_output",
    "dfa_view",
    "dict_observation_space",
    "observes_beliefs",
    "reward_shares",
]

#: The ``info`` entries holding a step's reward as the world paid it and as the bolt added
#: to it; every bolted step reports both (:func:`reward_shares`), records or not.
ENV_REWARD_KEY = "env_reward"
BOLT_REWARD_KEY = "bolt_reward"
#: The ``info`` entry of an episode's last step that holds its cost: how many specs it
#: leaves unsatisfied as the bolt sees them (:func:`~noisybolt.bolt.episode_costs`), read
#: by the ``constrained`` scheme's multiplier.
EPISODE_COST_KEY = "bolt_episode_cost"

# Band codes are computed once per batch by the wrappers (``confidence_bands``).


class TruthTracker:
    """Every spec's DFA run on the world's *true* fluents: did the agent really comply?

    Metrics only: it never touches the observation or the reward. It is plain DFA
    stepping (no probabilities, bands or rewards), so it costs a few microseconds a step.
    The trace starts at the first observation, as the bolt's does.
    """

    def __init__(self, dfas: Sequence[DFA], world_fluents: Sequence[str], *, n_envs: int) -> None:
        index = {name: i for i, name in enumerate(world_fluents)}
        self._dfas = tuple(dfas)
        self._columns = [np.array([index[f] for f in dfa.fluents], dtype=np.intp) for dfa in dfas]
        self._weights = [np.left_shift(1, np.arange(len(c), dtype=np.int64)) for c in self._columns]
        self._initial = np.array([dfa.initial_state for dfa in dfas], dtype=np.int64)
        self.states = np.tile(self._initial, (n_envs, 1))

    def _masks(self, truth: np.ndarray, s: int) -> np.ndarray:
        return truth[:, self._columns[s]].astype(np.int64) @ self._weights[s]

    def reset(self, truth: np.ndarray, env_mask: np.ndarray | None = None) -> None:
        """Starts the traces of the masked environments on their first observation."""
        rows = np.arange(len(truth)) if env_mask is None else np.flatnonzero(env_mask)
        for s, dfa in enumerate(self._dfas):
            start = np.full(len(rows), self._initial[s])
            self.states[rows, s] = dfa.step_batch(start, self._masks(truth[rows], s))[0]

    def step(self, truth: np.ndarray) -> None:
        """Moves every trace one letter (``truth`` is bool ``[n_envs, n_fluents]``)."""
        for s, dfa in enumerate(self._dfas):
            self.states[:, s] = dfa.step_batch(self.states[:, s], self._masks(truth, s))[0]

    @property
    def accepting(self) -> np.ndarray:
        """bool ``[n_envs, n_specs]``: whether each true trace is accepted now."""
        return np.stack(
            [dfa.accepting[self.states[:, s]] for s, dfa in enumerate(self._dfas)], axis=1
        )


class BoltParts:
    """The bolt that shapes the reward, the tracker of the true DFA states, and the
    detector with its columns in the world's order (:func:`~noisybolt.perception.
    detectors.match_fluents`)."""

    def __init__(self, bolt: RestrainingBolt, truth: TruthTracker, detector: Any) -> None:
        self.bolt = bolt
        self.truth = truth
        self.detector = detector


def build_bolt(
    specs: Sequence[Spec],
    detector: FluentDetector,
    world_fluents: Sequence[str],
    *,
    n_envs: int,
    settings: BoltSettings,
    dfas: Sequence[DFA] | None = None,
    world_letters: np.ndarray | None = None,
) -> BoltParts:
    """Checks that specs, detector and world agree, and builds the bolt and its twin.

    ``settings``: the bolt's (:class:`~noisybolt.bolt.BoltSettings`); the specs are paid
    as its scheme says, with its progress terms. ``world_letters``: true fluents the world
    produces (bool ``[n, n_fluents]``, e.g. from random play), so progress counts only
    steps the world can take.

    Every spec's DFA is checked (:func:`~noisybolt.bolt.spec.check_satisfiable`); a spec
    true of every trace gets a ``UserWarning`` only if its DFA is compiled here: whoever
    passes ``dfas`` has compiled them, and says so itself (``noisybolt train`` and
    ``check`` print it).

    Raises:
        UnknownFluentError: a spec reads a fluent the world does not have (the message
            lists the world's fluents).
        UnsatisfiableSpecError: no trace satisfies a spec.
        IncompatibleError: the detector lacks some of the world's fluents
            (:func:`~noisybolt.perception.detectors.match_fluents`).
    """
    world_fluents = tuple(world_fluents)
    detector = match_fluents(detector, world_fluents)  # its columns by name
    specs = settings.paid(specs)
    compiled_here = dfas is None
    if dfas is None:
        dfas = [compile_ltlf(spec.formula, world_fluents) for spec in specs]
    for spec in check_satisfiable(specs, dfas):
        if compiled_here:
            # Worded as the CLI's line (prepare_bolt), which covers the dfas it passes here.
            warnings.warn(vacuous_message(spec), UserWarning, stacklevel=3)
    terms = settings.progress_terms(dfas, specs, fluents=world_fluents, letters=world_letters)
    belief = settings.belief_settings
    if belief is not None and belief.base_rates is None:
        warnings.warn(
            UnknownBaseRatesWarning(
                "belief tracking without base_rates takes each fluent's frequency in play "
                "to be the detector's training prior (0.5): a rare fluent's onset then "
                "costs little, and faint but steady readings of it (p = 0.2 on every "
                "frame) add up to a false F(x) within a few hundred steps; estimate the "
                "rates from the detector on unlabelled play with noisybolt.perception."
                "base_rates.belief_settings_from_play (noisybolt train does so itself), "
                "or give them: BeliefSettings(base_rates={fluent: rate})"
            ),
            stacklevel=4,  # the caller of the wrapper that called build_bolt
        )
    # The specs are paid already: the bolt's scheme would pay them again, to the same.
    bolt = RestrainingBolt(
        specs, world_fluents, dfas=dfas, settings=settings, n_envs=n_envs, shaping=terms
    )
    return BoltParts(bolt, TruthTracker(bolt.dfas, world_fluents, n_envs=n_envs), detector)


def detector_output(probs: Any, detector: FluentDetector, *, rows: int) -> np.ndarray:
    """A detector's ``predict`` output as the bolt reads it and ``info["fluent_probs"]``
    keeps it: float64 ``[rows, n_fluents]`` in [0, 1]. A list or a torch tensor (on any
    device, with or without gradients) is converted; anything else is refused by name.

    Raises:
        DetectorOutputError: the wrong shape or dtype, NaN, or a value outside [0, 1].

    Example:
        >>> from noisybolt.perception.detectors import OracleDetector
        >>> detector_output([[0.25, 1.0]], OracleDetector(("a", "b")), rows=1)
        array([[0.25, 1.  ]])
        >>> detector_output([[1, 0]], OracleDetector(("a", "b")), rows=1)  # doctest: +ELLIPSIS
        Traceback (most recent call last):
        ...
        noisybolt.errors.DetectorOutputError: OracleDetector.predict gave what the bolt ...
    """
    if hasattr(probs, "detach") and hasattr(probs, "cpu"):  # a torch tensor
        probs = probs.detach().cpu().numpy()
    names = tuple(detector.fluent_names)
    try:
        return check_probs(probs, n_envs=rows, n_fluents=len(names), fluents=names)
    except ValueError as error:
        raise DetectorOutputError(
            f"{type(detector).__name__}.predict gave what the bolt cannot read: {error} "
            f"(for {rows} image(s) and the fluents {list(names)})"
        ) from None


#: The observations the bolt puts under ``"image"``: SB3, which one-hot encodes the
#: ``"dfa"`` beside it, takes no space nested inside a ``Dict``.
FLAT_SPACES = (
    gym.spaces.Box,
    gym.spaces.Discrete,
    gym.spaces.MultiDiscrete,
    gym.spaces.MultiBinary,
)


def check_flat_observation(space: gym.Space) -> None:
    """Refuses an env observation the bolted ``Dict{"image", "dfa"}`` cannot carry to a
    learner: a ``Dict``, ``Tuple`` or other structured space would be nested under
    ``"image"``, which SB3 refuses (``NotImplementedError: Nested observation spaces``).

    Raises:
        ObservationSpaceError: naming the space and how to reduce it.

    Example:
        >>> check_flat_observation(gym.spaces.Box(0, 255, (8, 8, 3), np.uint8))
        >>> check_flat_observation(gym.spaces.Tuple((gym.spaces.Discrete(2),)))
        Traceback (most recent call last):
        ...
        noisybolt.errors.ObservationSpaceError: the env's observation space \
Tuple(Discrete(2)) would be nested under the bolt's "image" entry, ...
    """
    if isinstance(space, FLAT_SPACES):
        return
    raise ObservationSpaceError(
        f"the env's observation space {space} would be nested under the bolt's \"image\" "
        "entry, and SB3 takes no nested spaces: reduce it in the env you bolt to a Box "
        "(an image or a vector) or a Discrete/MultiDiscrete/MultiBinary state: keep its "
        "image (MiniGrid: minigrid.wrappers.ImgObsWrapper) or flatten it "
        "(gymnasium.wrappers.FlattenObservation)"
    )


def dict_observation_space(
    image_space: gym.Space, n_states: Sequence[int], *, beliefs: bool = False
) -> gym.spaces.Dict:
    """``Dict{"image": the world's observation, "dfa": ...}``.

    ``"dfa"`` is ``MultiDiscrete(n_states)`` (the DFA states; SB3 one-hot encodes it), or
    with ``beliefs`` a float32 ``Box(0, 1, (sum(n_states),))`` holding each spec's
    distribution over its states, concatenated (what a one-hot becomes under doubt).
    """
    dfa: gym.Space
    if beliefs:
        dfa = gym.spaces.Box(0.0, 1.0, (int(np.sum(n_states)),), dtype=np.float32)
    else:
        dfa = gym.spaces.MultiDiscrete(np.asarray(n_states, dtype=np.int64))
    return gym.spaces.Dict({"image": image_space, "dfa": dfa})


def observes_beliefs(bolt: RestrainingBolt) -> bool:
    """Whether the agent sees the bolt's beliefs (a Box) rather than DFA states."""
    settings = bolt.belief_settings
    return settings is not None and settings.observation == "belief"


def dfa_view(bolt: RestrainingBolt) -> np.ndarray:
    """``[n_envs, ...]``: the ``"dfa"`` entry of every environment's observation now.

    int64 DFA states (threshold tracking, or belief tracking observed as its most likely
    states), or float32 concatenated beliefs (belief tracking observed as beliefs).
    """
    if observes_beliefs(bolt):
        return bolt.beliefs.astype(np.float32)
    return bolt.states


def reward_shares(env_reward: float, bolt_reward: float) -> dict[str, float]:
    """A step's reward in its two shares, the ``info`` entries every bolted step reports
    (a learner's normaliser may read them: ``normalize_reward: split``)."""
    return {ENV_REWARD_KEY: float(env_reward), BOLT_REWARD_KEY: float(bolt_reward)}


def bolt_info(
    index: int,
    *,
    env_reward: float,
    out: BoltStep,
    probs: np.ndarray,
    bands: np.ndarray,
    truth: np.ndarray,
    true_states: np.ndarray,
    true_accepting: np.ndarray,
) -> dict[str, object]:
    """The ``info`` entries one environment's step reports (arrays are per spec/fluent).

    Batched arrays are sliced, not copied: each entry is a view of row ``index``.
    """
    return {
        **reward_shares(env_reward, out.total[index]),
        "bolt_terminal": out.terminal[index],
        "bolt_low_confidence": out.low_confidence[index],
        "bolt_progress": out.progress[index],
        "bolt_carried": float(out.carried[index]),
        "fluent_probs": probs[index],
        "true_fluents": truth[index],
        "confidence_bands": bands[index],
        "dfa_states": out.next_states[index],
        "dfa_accepting": out.accepting[index],
        "dfa_violated": out.violated[index],
        "true_dfa_states": true_states[index],
        "true_accepting": true_accepting[index],
    }
