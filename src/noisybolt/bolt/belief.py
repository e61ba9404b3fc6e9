"""Belief tracking: a distribution over each spec's DFA states, from evidence over time.

Algorithm 1 (``tracking="threshold"``) believes a single frame: a fluent is true when its
probability is at least 0.5 on that frame, and an ``F(x)`` DFA that once takes the edge
into its accepting sink stays there, so one false positive pays for good. Belief tracking
(``tracking="belief"``) keeps, per environment and spec, a distribution over the DFA's
states and pays on it.

The model (an HMM, filtered forward exactly)
--------------------------------------------
For each spec the hidden state is the pair ``(q, sigma)``: the DFA state and the truth of
the fluents the DFA depends on (``sigma``, one chain state per *relevant* fluent of the
spec, so a spec over ``m`` of them has ``n_states * (min_dwell + 1)**m`` cells, whatever
the bolt's vocabulary). Per step:

1. every fluent's truth persists or switches (a Markov chain per fluent, the fluents
   independent a priori): ``P(on | off) = s * pi``, ``P(off | on) = s * (1 - pi)`` once it
   has been on ``min_dwell`` steps (before that it stays on),
   where ``pi`` is the fluent's base rate in play (its chain's stationary probability) and
   ``s`` its *switch rate* in ``(0, 1]`` (``1 - s`` is the lag-one autocorrelation of the
   truth; ``s = 1`` means no persistence). A *monotone* fluent (one that can only become
   true, such as "this brick is gone") never switches off;
2. the DFA moves on the new truth: ``q' = delta(q, sigma')`` (Algorithm 1's move, on each
   hypothesis instead of on the thresholded frame);
3. the frame's evidence weighs each hypothesis: fluent ``f``'s log likelihood ratio is
   ``kappa * (logit(p_f) - logit(pi_train_f))``, the detector's posterior odds divided by
   the prior odds it was trained under (Saerens, Latinne & Decaestecker 2002: a
   classifier's posterior carries its training prior; dividing it out leaves the
   likelihood ratio, and the filter's own prior, from the play base rate, takes its place);
4. normalise per spec.

Steps 1-2 are one constant linear map per spec (``[cells, cells]``) and step 3 one matrix
product with the fluents' log ratios, so a step is a handful of batched numpy calls over
``[n_specs, n_envs, cells]``.

Why this does not over-accumulate false evidence
------------------------------------------------
Li, Chen, Toro Icarte & McIlraith (NeurIPS 2024) update a belief over reward-machine states
independently each step (IBU): ``b'(q') = sum_q b(q) sum_sigma P(sigma | frame) [delta(q,
sigma) = q']``, with ``P(sigma | frame)`` from that frame alone. For a latching DFA
(``F(x)``) every frame with ``P(x) = 0.1`` moves another tenth of the remaining mass into
the accepting sink, and nothing ever moves it back: after 30 such frames the bolt is 96 %
sure of an event that never happened. They found IBU unreliable for this reason and
learnt the temporal dependencies instead (TDM). Here the temporal dependency is modelled:

* the belief is *joint* over the DFA state and the fluent truth that led there. Mass that
  a doubtful frame moved into the sink stays attached to "x was true then"; as x is
  persistent (or monotone), the following frames that say "x is false" are evidence
  against that hypothesis and take the mass back out, while IBU, which forgets which
  truth moved the mass, cannot;
* successive frames of one camera on a nearly unchanged world are not independent: the
  detector fails alike on alike views (the smudged region of the gridworld reads p = 0.6
  for as long as the agent stays there), and an HMM that multiplies their likelihoods
  counts one error many times. The truth chain bounds this: for "x stayed on" to gain on
  "x stayed off" over a run of frames, each frame's likelihood ratio must exceed
  ``P(off -> off) / P(on -> on) = (1 - s * pi) / (1 - s * (1 - pi))`` (about 2 for a
  rare fluent at the default ``s = 0.5``), so a run of doubtful frames below it never
  accumulates, however long; above it, only the excess accumulates. The onset of a rare
  fluent costs ``s * pi`` once, so it takes clear frames (or several) to believe it.
  ``max_log_ratio`` bounds what any one frame can say (an oracle's p = 1 is not
  infinite evidence), and ``evidence_weight`` (``kappa`` < 1) optionally tempers every
  frame (a power likelihood: ``n`` correlated frames count as ``kappa * n``);
* a fluent, once true, stays true at least ``min_dwell`` (2) steps: otherwise every
  frame, however clear its "no", leaves room for "x was true just then, unseen", and
  over a long episode those unseen blips add up (a ``G(!x)`` falsely broken, an ``F(x)``
  falsely met: IBU's accumulation again, by another road); with two frames needed the
  detector must miss twice in a row;
* the base rate enters once, as the prior of the truth chain, not once per frame.

With ``switch_rate=1`` and ``min_dwell=1`` (no persistence) the filter reduces to IBU on
base-rate-corrected frames; ``benchmarks/belief_tracking.py`` measures both.

Payment is then on the belief, not on a frame (see :class:`BeliefSettings`).

Example:
    >>> from noisybolt.logic import DFA
    >>> f_x = DFA.from_function(["x"], n_states=2, initial_state=0,
    ...     accepting=[False, True], delta=lambda q, m: 1 if q == 1 or m & 1 else 0)
    >>> engine = BeliefEngine([f_x], ["x"], BeliefSettings(base_rates=(0.1,)))
    >>> start = engine.reset_joint(np.array([[0.02]]))  # a clear "no" on the first frame
    >>> joint = engine.step_joint(start, np.array([[0.7]]))  # then one doubtful frame
    >>> round(float(engine.marginals(joint).accepting[0, 0]), 3)
    0.114
    >>> joint = engine.step_joint(joint, np.array([[0.02]]))  # a clear "no" takes it back
    >>> round(float(engine.marginals(joint).accepting[0, 0]), 3)
    0.006
    >>> joint = engine.step_joint(engine.step_joint(start, np.array([[0.99]])), np.array([[0.99]]))
    >>> round(float(engine.marginals(joint).accepting[0, 0]), 3)  # two clear frames of x
    0.998
    >>> joint = engine.step_joint(joint, np.array([[0.02]]))  # x over: the visit stays
    >>> round(float(engine.marginals(joint).accepting[0, 0]), 3)
    0.996
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Literal, NamedTuple, get_args

import numpy as np

from noisybolt.bolt._bits import popcount
from noisybolt.errors import BaseRateError, ConfidenceLevelError, ConfigError, UnknownNameError
from noisybolt.logic.dfa import DFA

__all__ = [
    "BELIEF_OBSERVATIONS",
    "MAX_BELIEF_CELLS",
    "TRACKING_MODES",
    "BeliefEngine",
    "BeliefMarginals",
    "BeliefObservation",
    "BeliefSettings",
    "Tracking",
    "check_tracking",
    "frames_to_believe",
]

#: How the bolt tracks its DFAs: ``"threshold"`` is Algorithm 1 (a fluent is true when
#: ``p >= 0.5`` on the frame); ``"belief"`` keeps a distribution over DFA states.
Tracking = Literal["threshold", "belief"]
#: The accepted values of :data:`Tracking`.
TRACKING_MODES: tuple[str, ...] = get_args(Tracking)
#: What the agent sees of the belief: the per-spec distributions (``"belief"``) or each
#: spec's most likely state (``"argmax"``, one-hot encoded by SB3 as ``MultiDiscrete``).
BeliefObservation = Literal["belief", "argmax"]
#: The accepted values of :data:`BeliefObservation`.
BELIEF_OBSERVATIONS: tuple[str, ...] = get_args(BeliefObservation)
#: The most cells (DFA states times truth assignments of its fluents) one spec may have:
#: a step costs about ``cells**2`` per environment for the largest spec.
MAX_BELIEF_CELLS = 1024
# Probabilities are clipped this far from 0 and 1 before taking logits (an oracle's 0/1).
_EPS = 1e-9


def check_tracking(tracking: object) -> str:
    """Returns ``tracking`` if it is one of :data:`TRACKING_MODES`.

    Raises:
        UnknownNameError: any other value.
    """
    if tracking not in TRACKING_MODES:
        raise UnknownNameError(
            f"unknown tracking mode {tracking!r}; use one of {list(TRACKING_MODES)} "
            "('threshold' is Algorithm 1, 'belief' tracks a distribution over DFA states)",
            name=str(tracking),
            known=TRACKING_MODES,
        )
    return str(tracking)


def _per_fluent(
    value: float | Sequence[float] | Mapping[str, float] | None,
    fluents: Sequence[str],
    default: float,
    what: str,
) -> np.ndarray:
    """float64 ``[n_fluents]`` from one number, a sequence in vocabulary order or a mapping."""
    n = len(fluents)
    if value is None:
        return np.full(n, default)
    if isinstance(value, Mapping):
        unknown = sorted(set(value) - set(fluents))
        if unknown:
            raise ConfigError(f"{what} names unknown fluent(s) {unknown}; known: {list(fluents)}")
        return np.array([float(value.get(f, default)) for f in fluents])
    if isinstance(value, (int, float, np.number)) and not isinstance(value, bool):
        return np.full(n, float(value))
    array = np.asarray(value, dtype=np.float64)
    if array.shape != (n,):
        raise ConfigError(
            f"{what} needs one value per fluent {list(fluents)} (or a mapping by name), "
            f"got shape {array.shape}"
        )
    return array


@dataclass(frozen=True)
class BeliefSettings:
    """The settings of belief tracking (see the module docstring for the model).

    Attributes:
        confidence: the confidence level: a spec counts as accepting (``info
            ["dfa_accepting"]``) and its reward is paid when the probability of the
            paid-for condition is at least this (the paper's high band, 0.9). In (0.5, 1).
        base_rates: each fluent's frequency in play (the truth chain's stationary prior;
            per fluent in vocabulary order, by name, or one number for all); None: the
            detector's training prior (no prior-shift correction). Estimate them without
            ground truth with :func:`noisybolt.perception.base_rates.estimate_base_rates`.
        training_prior: the frequency of each fluent in the detector's training set
            (0.5: balanced, as ``noisybolt``'s classifiers are trained).
        switch_rate: how fast each fluent's truth forgets its past, in (0, 1]: 1 means
            no persistence (each frame judged on its own), small values a truth that
            persists for about ``1 / switch_rate`` steps. The default, 0.5 (with
            ``min_dwell=2``), was chosen on the gridworld (benchmarks/belief_tracking.py,
            grid-glitch, seeds 123 and 7): 0.3 lost recall of two-frame corner visits
            (93-97 %); with ``min_dwell=1`` no rate kept both those and ``G(!x)``.
            :func:`~noisybolt.perception.base_rates.estimate_switch_rates` estimates
            per-fluent rates from unlabelled play.
        monotone: fluents that can only become true (a brick gone stays gone).
        min_dwell: once true, a fluent stays true at least this many steps (1 or more).
            The default, 2, says that a one-frame truth is not to be believed unseen:
            without it, every frame leaves room for "x was true just then and the
            detector missed it", and over a long episode those unseen blips add up to
            a false violation of ``G(!x)`` (or a false ``F(x)``); requiring two frames
            squares the detector's miss rate. 1 is the plain two-state chain.
        evidence_weight: ``kappa`` in (0, 1], how much one frame counts (see "Why this
            does not over-accumulate false evidence").
        max_log_ratio: the most one frame's log likelihood ratio may say, per fluent.
        observation: what the agent sees: ``"belief"`` (the distributions, a Box) or
            ``"argmax"`` (each spec's most likely state, a MultiDiscrete).

    Raises:
        ConfidenceLevelError: ``confidence`` outside (0.5, 1).
        BaseRateError: a base rate or training prior outside [0, 1] (or not finite).
        ConfigError: any other setting out of range.

    Example:
        >>> BeliefSettings().confidence
        0.9
        >>> BeliefSettings(confidence=1.0)
        Traceback (most recent call last):
        ...
        noisybolt.errors.ConfidenceLevelError: confidence level 1.0 is outside (0.5, 1): \
use e.g. 0.9 (the paper's high band)
    """

    confidence: float = 0.9
    base_rates: float | Sequence[float] | Mapping[str, float] | None = None
    training_prior: float | Sequence[float] | Mapping[str, float] = 0.5
    switch_rate: float | Sequence[float] | Mapping[str, float] = 0.5
    monotone: tuple[str, ...] = ()
    min_dwell: int = 2
    evidence_weight: float = 1.0
    max_log_ratio: float = 7.0
    observation: BeliefObservation = "belief"

    def __post_init__(self) -> None:
        c = self.confidence
        if isinstance(c, bool) or not isinstance(c, (int, float)) or not 0.5 < c < 1.0:
            raise ConfidenceLevelError(
                f"confidence level {c!r} is outside (0.5, 1): use e.g. 0.9 (the paper's high band)"
            )
        object.__setattr__(self, "confidence", float(c))
        if isinstance(self.min_dwell, bool) or not isinstance(self.min_dwell, int):
            raise ConfigError(f"min_dwell must be an integer >= 1, got {self.min_dwell!r}")
        if self.min_dwell < 1:
            raise ConfigError(f"min_dwell must be an integer >= 1, got {self.min_dwell!r}")
        if not 0.0 < self.evidence_weight <= 1.0:
            raise ConfigError(f"evidence_weight must be in (0, 1], got {self.evidence_weight!r}")
        if not self.max_log_ratio > 0.0 or not math.isfinite(self.max_log_ratio):
            raise ConfigError(f"max_log_ratio must be finite and > 0, got {self.max_log_ratio!r}")
        if self.observation not in BELIEF_OBSERVATIONS:
            raise ConfigError(
                f"belief observation {self.observation!r} is not one of {list(BELIEF_OBSERVATIONS)}"
            )
        if isinstance(self.monotone, str):
            raise ConfigError(f"monotone must be a sequence of fluent names, not {self.monotone!r}")
        object.__setattr__(self, "monotone", tuple(self.monotone))
        for name in ("base_rates", "training_prior"):
            _check_rates(getattr(self, name), name)

    def resolve(self, fluents: Sequence[str]) -> _FluentModel:
        """The per-fluent arrays of these settings over the vocabulary ``fluents``.

        Raises:
            ConfigError: a per-fluent setting of the wrong length or naming unknown fluents.
        """
        prior = _per_fluent(self.training_prior, fluents, 0.5, "training_prior")
        rates = _per_fluent(self.base_rates, fluents, 0.5, "base_rates")
        if self.base_rates is None:
            rates = prior.copy()
        switch = _per_fluent(self.switch_rate, fluents, 0.5, "switch_rate")
        if not np.all((switch > 0.0) & (switch <= 1.0)):
            raise ConfigError(f"switch_rate must be in (0, 1] per fluent, got {switch.tolist()}")
        unknown = sorted(set(self.monotone) - set(fluents))
        if unknown:
            raise ConfigError(f"monotone names unknown fluent(s) {unknown}; known: {list(fluents)}")
        monotone = np.array([f in self.monotone for f in fluents])
        # 0 and 1 are legal base rates (a fluent never or always true) but have no logit.
        rates = np.clip(rates, _EPS, 1.0 - _EPS)
        prior = np.clip(prior, _EPS, 1.0 - _EPS)
        on = switch * rates
        off = np.where(monotone, 0.0, switch * (1.0 - rates))
        return _FluentModel(rates=rates, prior_logit=_logit(prior), on=on, off=off)


def _check_rates(value: object, name: str) -> None:
    if value is None:
        return
    items = value.values() if isinstance(value, Mapping) else np.ravel(np.asarray(value))
    for item in items:
        if isinstance(item, bool) or not isinstance(item, (int, float, np.number)):
            raise BaseRateError(f"{name} must hold numbers in [0, 1], got {item!r}")
        if not math.isfinite(float(item)) or not 0.0 <= float(item) <= 1.0:
            raise BaseRateError(
                f"{name} must lie in [0, 1] (a fluent's frequency), got {float(item)!r}; "
                "estimate play base rates with noisybolt.perception.base_rates.estimate_base_rates"
            )


class _FluentModel(NamedTuple):
    rates: np.ndarray  # [k] play base rates (stationary truth prior)
    prior_logit: np.ndarray  # [k] logit of the detector's training prior
    on: np.ndarray  # [k] P(on | off) per step
    off: np.ndarray  # [k] P(off | on) per step


def _logit(p: np.ndarray) -> np.ndarray:
    return np.log(p) - np.log1p(-p)


class BeliefMarginals(NamedTuple):
    """What the bolt reads off the joint belief, per environment and spec.

    Attributes:
        states: float64 ``[n_envs, n_specs, max_states]``: the belief over each spec's DFA
            states (columns past a spec's own states are 0).
        accepting: float64 ``[n_envs, n_specs]``: probability of an accepting state.
        violated: float64 ``[n_envs, n_specs]``: probability of a rejecting sink.
    """

    states: np.ndarray
    accepting: np.ndarray
    violated: np.ndarray


class BeliefEngine:
    """Exact forward filtering of the joint (DFA state, fluent truth) of every spec.

    Stateless: it maps a joint belief (float64 ``[n_specs, n_envs, cells]``) and a frame's
    probabilities to the next joint belief; :class:`~noisybolt.bolt.RestrainingBolt` keeps
    it between steps.

    Args:
        dfas: the specs' DFAs (their vocabularies subsets of ``fluents``).
        fluents: the bolt's vocabulary, the column order of ``probs``.
        settings: the model's settings.

    Raises:
        ConfigError: a spec whose joint would exceed :data:`MAX_BELIEF_CELLS` cells, or a
            bad setting (see :meth:`BeliefSettings.resolve`).
    """

    def __init__(self, dfas: Sequence[DFA], fluents: Sequence[str], settings: BeliefSettings):
        self._settings = settings
        self._fluents = tuple(fluents)
        model = settings.resolve(self._fluents)
        self._model = model
        index = {f: i for i, f in enumerate(self._fluents)}
        dfas = tuple(dfas)
        n_specs, k = len(dfas), len(self._fluents)
        relevant = [[index[f] for f in dfa.relevant_fluents] for dfa in dfas]
        n_chain = settings.min_dwell + 1
        cells = [
            dfa.n_states * n_chain ** len(cols) for dfa, cols in zip(dfas, relevant, strict=True)
        ]
        for dfa, n in zip(dfas, cells, strict=True):
            if n > MAX_BELIEF_CELLS:
                raise ConfigError(
                    f"belief tracking of a DFA with {dfa.n_states} states over "
                    f"{len(dfa.relevant_fluents)} fluents (min_dwell {settings.min_dwell}) "
                    f"needs {n} cells, over "
                    f"MAX_BELIEF_CELLS={MAX_BELIEF_CELLS}; split the spec, lower min_dwell "
                    "to 1, or use tracking='threshold'"
                )
        n_cells = max(cells)
        q_max = max(dfa.n_states for dfa in dfas)
        self._n_cells = n_cells
        self._q_max = q_max
        self._n_states = tuple(dfa.n_states for dfa in dfas)
        self._move = np.zeros((n_specs, n_cells, n_cells))  # persistence, then DFA move
        self._start = np.zeros((n_specs, n_cells))  # the reset transition from q0
        self._bits = np.zeros((k, n_specs, n_cells))  # fluent f is true in cell c
        # Columns: the DFA state of the cell (one-hot), then accepting, then rejecting sink.
        self._readout = np.zeros((n_specs, n_cells, q_max + 2))
        self._letter_weights = np.zeros((k, n_specs), dtype=np.int64)
        self._support = np.zeros((n_specs, q_max, 1 << max(map(len, relevant))), dtype=np.uint64)
        for s, (dfa, cols) in enumerate(zip(dfas, relevant, strict=True)):
            self._build_spec(s, dfa, cols, model)

    def _build_spec(self, s: int, dfa: DFA, cols: list[int], model: _FluentModel) -> None:
        m, n_q = len(cols), dfa.n_states
        n_chain = self._settings.min_dwell + 1  # off, on for 1 .. min_dwell - 1 steps, held
        # A truth configuration: one chain state per relevant fluent, in base n_chain.
        configs = np.arange(n_chain**m, dtype=np.int64)
        digits = (configs[:, None] // n_chain ** np.arange(m)) % n_chain  # [C, m]
        on_bits = (digits > 0).astype(np.int64)
        letters = (on_bits << np.arange(m)).sum(axis=1) if m else configs
        positions = [dfa.fluents.index(self._fluents[c]) for c in cols]
        # The DFA's own letter of each relevant-fluent letter (irrelevant fluents false).
        all_letters = np.arange(1 << m, dtype=np.int64)
        all_bits = (all_letters[:, None] >> np.arange(m)) & 1
        full = (all_bits << np.array(positions, dtype=np.int64)).sum(axis=1) if m else all_letters
        states = np.repeat(np.arange(n_q), len(all_letters))
        nxt, support = dfa.step_batch(states, np.tile(full, n_q).astype(np.uint64))
        nxt = nxt.reshape(n_q, len(all_letters))
        support = support.reshape(n_q, len(all_letters))
        rel_support = np.zeros_like(support)
        for j, pos in enumerate(positions):
            rel_support |= ((support >> np.uint64(pos)) & np.uint64(1)) << np.uint64(j)
        self._support[s, :n_q, : len(all_letters)] = rel_support
        self._letter_weights[cols, s] = 1 << np.arange(m, dtype=np.int64)
        # Per fluent, the chain: off -> on (rate on); on for fewer than min_dwell steps ->
        # one step longer; held -> off (rate off). A product over fluents.
        chain = np.zeros((m, n_chain, n_chain))
        held = n_chain - 1
        chain[:, 0, 0], chain[:, 0, 1] = 1 - model.on[cols], model.on[cols]
        for i in range(1, held):
            chain[:, i, i + 1] = 1.0
        chain[:, held, held], chain[:, held, 0] = 1 - model.off[cols], model.off[cols]
        stay = np.ones((len(configs), len(configs)))
        for j in range(m):
            stay *= chain[j][digits[:, j][:, None], digits[:, j][None, :]]
        # On the first frame a fluent is off, or has just come on: it holds min_dwell
        # frames from there, as from any other onset, so a glitch on the reset frame is
        # refuted by the next frames as a glitch on any other is (were it "held", one
        # clear-looking first frame would latch F(x) for the episode).
        rates = model.rates[cols]
        prior_digit = np.where(digits == 1, rates, np.where(digits == 0, 1 - rates, 0.0))
        prior = np.prod(prior_digit, axis=1) if m else np.ones(1)
        n_c = len(configs)
        for q in range(n_q):
            for c in range(n_c):
                targets = nxt[q, letters] * n_c + configs  # cell (delta(q, c2), c2) per c2
                np.add.at(self._move[s, q * n_c + c], targets, stay[c])
        start_targets = nxt[dfa.initial_state, letters] * n_c + configs
        np.add.at(self._start[s], start_targets, prior)
        for j, c in enumerate(cols):
            self._bits[c, s, : n_q * n_c] = np.tile(on_bits[:, j], n_q)
        cell_q = np.repeat(np.arange(n_q), n_c)
        self._readout[s, np.arange(n_q * n_c), cell_q] = 1.0
        self._readout[s, : n_q * n_c, self._q_max] = dfa.accepting[cell_q]
        self._readout[s, : n_q * n_c, self._q_max + 1] = dfa.rejecting_sinks[cell_q]

    # ------------------------------------------------------------------ properties
    @property
    def settings(self) -> BeliefSettings:
        """The settings."""
        return self._settings

    @property
    def n_cells(self) -> int:
        """Cells of the joint per spec (padded to the largest spec)."""
        return self._n_cells

    @property
    def n_states(self) -> tuple[int, ...]:
        """DFA states per spec."""
        return self._n_states

    # ------------------------------------------------------------------ filtering
    def _evidence(self, probs: np.ndarray) -> np.ndarray:
        """float64 ``[n_specs, n_envs, cells]``: each cell's likelihood, up to a constant."""
        p = np.clip(probs, _EPS, 1.0 - _EPS)
        ratio = np.log(p) - np.log1p(-p) - self._model.prior_logit  # [n_envs, k]
        bound = self._settings.max_log_ratio
        ratio = self._settings.evidence_weight * np.clip(ratio, -bound, bound)
        k, n_specs, n_cells = self._bits.shape
        log_lik = (ratio @ self._bits.reshape(k, -1)).reshape(-1, n_specs, n_cells)
        log_lik = log_lik.transpose(1, 0, 2)
        return np.exp(log_lik - log_lik.max(axis=2, keepdims=True))

    def _observe(self, predicted: np.ndarray, probs: np.ndarray) -> np.ndarray:
        joint = predicted * self._evidence(probs)
        total = joint.sum(axis=2, keepdims=True)
        # Evidence can only underflow the whole mass if it contradicts every live
        # hypothesis beyond float range; keep the prediction then rather than divide by 0.
        bad = ~(total > 0.0)
        if bad.any():
            joint = np.where(bad, predicted, joint)
            total = np.where(bad, predicted.sum(axis=2, keepdims=True), total)
        return joint / total

    def reset_joint(self, probs: np.ndarray) -> np.ndarray:
        """The joint belief after the episode's first transition, on its first frame.

        Args:
            probs: float64 ``[n_envs, n_fluents]`` (checked by the caller).

        Returns:
            float64 ``[n_specs, n_envs, cells]``.
        """
        predicted = np.broadcast_to(
            self._start[:, None, :], (len(self._start), len(probs), self._n_cells)
        )
        return self._observe(predicted, probs)

    def step_joint(self, joint: np.ndarray, probs: np.ndarray) -> np.ndarray:
        """The joint belief after one more frame (see the module docstring)."""
        return self._observe(np.matmul(joint, self._move), probs)

    def marginals(self, joint: np.ndarray) -> BeliefMarginals:
        """The beliefs over DFA states and the accepting and violated probabilities."""
        read = np.matmul(joint, self._readout).transpose(1, 0, 2)  # [n_envs, n_specs, q+2]
        q = self._q_max
        return BeliefMarginals(
            states=read[:, :, :q], accepting=read[:, :, q], violated=read[:, :, q + 1]
        )

    def low_band_counts(self, truth: np.ndarray, low: np.ndarray) -> np.ndarray:
        """float64 ``[n_envs, n_specs, max_states]``: Algorithm 1's low-band count per state.

        From each DFA state, the edge Algorithm 1 would take on the frame (``truth``, bool
        ``[n_envs, n_fluents]``) has a support; the count is the number of its fluents in
        the low band (``low``, bool ``[n_envs, n_fluents]``). Padded states count 0.
        """
        letters = truth.astype(np.int64) @ self._letter_weights  # [n_envs, n_specs]
        low_letters = (low.astype(np.int64) @ self._letter_weights).view(np.uint64)
        n_specs = letters.shape[1]
        support = self._support[np.arange(n_specs)[None, :], :, letters]  # [E, S, q]
        return popcount(support & low_letters[:, :, None]).astype(np.float64)


def frames_to_believe(
    settings: BeliefSettings,
    fluents: Sequence[str],
    fluent: str,
    *,
    longest: int = 8,
    after: int = 3,
) -> tuple[int | None, float]:
    """How many frames in a row a *perfect* detector must show ``fluent`` true before the
    bolt, tracking ``F(fluent)`` under ``settings``, believes it happened.

    The frames: ``fluent`` clearly false twice, then clearly true ``n`` times, then
    clearly false ``after`` times (the visit over; 0 for a visit that ends the episode,
    which no later frame can refute); believed when the probability of acceptance is
    still at least ``settings.confidence`` at the end. A fluent that a world
    shows for fewer frames than this is never credited by belief tracking, however good
    the detector: ``min_dwell`` makes a shorter truth impossible a priori, and a rare
    fluent's onset costs more than one frame's evidence (``max_log_ratio``) can buy.

    Args:
        settings: the belief settings (per-fluent values over ``fluents``).
        fluents: the bolt's vocabulary.
        fluent: the fluent asked about.
        longest: the most frames tried.
        after: clearly false frames after the visit (0: it ends the episode).

    Returns:
        ``(n, p)``: the fewest frames ``n`` (None: not within ``longest``) and the
        probability of acceptance after a single frame of it.

    Example:
        >>> frames_to_believe(BeliefSettings(base_rates=0.1), ["x"], "x")
        (2, 0.05)
        >>> frames_to_believe(BeliefSettings(base_rates=0.1, min_dwell=1), ["x"], "x")
        (1, 0.965)
    """
    column = list(fluents).index(fluent)
    ever = DFA.from_function(
        [fluent],
        n_states=2,
        initial_state=0,
        accepting=[False, True],
        delta=lambda q, m: 1 if q == 1 or m & 1 else 0,
    )
    engine = BeliefEngine([ever], fluents, settings)
    single = 0.0
    for n in range(1, longest + 1):
        seen = np.zeros((2 + n + after, len(fluents)))  # [frames, n_fluents], others false
        seen[2 : 2 + n, column] = 1.0
        joint = engine.reset_joint(seen[:1])
        for frame in seen[1:]:
            joint = engine.step_joint(joint, frame[None, :])
        believed = float(engine.marginals(joint).accepting[0, 0])
        if n == 1:
            single = round(believed, 3)
        if believed >= settings.confidence:
            return n, single
    return None, single
