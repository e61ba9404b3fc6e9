"""How often a policy truly complies, estimated from the bolt's own evidence.

Without ground truth a deployed bolt has its detector's outputs only. This module turns
an episode's whole sequence of them into ``P(the spec is truly satisfied | what the bolt
saw)``, and a set of episodes into a compliance rate with an interval.

The model (a hidden Markov model, filtered forward exactly)
-----------------------------------------------------------
* **The error model** (:class:`ErrorModel`): per fluent, how the detector's probability
  falls into confidence bands when the fluent is false and when it is true, counted on
  held-out labelled images. A frame's evidence is the band it falls in, weighed by
  ``P(band | truth)``: the detector's own probability is not trusted, only how its
  bands behaved on images whose truth was known (so a classifier that reads 0.6 on every
  true positive under a smudge, and 0.6 on almost no negative, is believed exactly as
  much as it was right). The counts are Dirichlet posteriors (a Jeffreys prior, 0.5 per
  cell): few held-out positives mean uncertain rates, and :meth:`ErrorModel.sample` draws
  them. Optionally (``pair_counts``, counted on labelled episodes) it also says how a
  frame's band follows the last one's given the truth on both: a smudge that reads
  "maybe" reads it again while the agent stays under it, whatever the truth, so a run of
  such frames is not taken for as many independent pieces of evidence.
* **The fluents' dynamics** (:class:`FluentDynamics`, in
  :mod:`noisybolt.bolt.compliance_dynamics`): each fluent's truth is a Markov chain
  (``P(true)`` on the first frame, ``P(on | off)`` and ``P(off | on)`` per step, and
  ``again``, ``P(on | off)`` once it has been on: a route passes a corner once, so a
  return is not as likely as an arrival), the fluents independent. The chain is what lets
  a world's persistence speak: the gridworld's position fluents hold for several frames,
  so one doubtful frame among clear ones is a glitch, not a visit, and one confident
  frame after a visit is weighed against how often the episodes truly come back.
  :func:`fit_dynamics` learns the chains from the unlabelled episodes themselves
  (Baum-Welch with the error model's emissions held fixed): no ground truth is needed.
* **The DFA** moves on the hidden truth (the trace starts at the first observation, as
  the bolt's does): the hidden state is the pair ``(q, sigma)``, the DFA state and the
  chain states of the fluents the spec depends on, and the filter is exact over it.

An episode's estimate is the probability that its last hidden DFA state accepts, given
every frame; it is averaged over draws of the error model (the posterior predictive), so
the rates' uncertainty is in it.

Aggregating (:func:`aggregate_compliance`)
------------------------------------------
The compliance rate is the mean of the episodes' estimates. Its interval draws, many
times: error rates from their posterior, each episode's truth from its probability under
them, and Bayesian-bootstrap weights over the episodes (Rubin 1981); the rate's 5 % and
95 % quantiles are the 90 % interval for *the policy's* compliance rate. ``episodes_low``
and ``episodes_high`` leave the bootstrap out: an interval for the share of *these*
episodes that complied. Where the camera cannot tell, the episodes' probabilities sit
away from 0 and 1 and the drawn truths vary: the interval widens.

What the model leaves out: a fluent's truth may depend on another's (a corner is on the
edge), and errors correlated over more than one frame. ``benchmarks/
compliance_estimates.py`` measures what they cost.

Example:
    >>> from noisybolt.logic import DFA
    >>> f_x = DFA.from_function(["x"], n_states=2, initial_state=0,
    ...     accepting=[False, True], delta=lambda q, m: 1 if q == 1 or m & 1 else 0)
    >>> # Bands: p < 0.5 and p >= 0.5. Right 9 times in 10 on both sides.
    >>> model = ErrorModel(fluent_names=("x",), edges=(0.5,),
    ...                    counts=np.array([[[90.0, 10.0], [10.0, 90.0]]]), pseudo_count=0.0)
    >>> still = FluentDynamics(start=np.array([0.5]), on=np.array([0.0]), off=np.array([0.0]))
    >>> p = satisfaction_probabilities(f_x, ("x",), [np.array([[0.7]])], model.rates()[None],
    ...                                still)
    >>> round(float(p[0, 0]), 3)  # one frame, "x" seen: 0.5 * 0.9 / (0.5 * 0.9 + 0.5 * 0.1)
    0.9
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from noisybolt.bolt.compliance_dynamics import (
    TRUTH,
    FluentDynamics,
    fit_dynamics,
    padded,
    step_emissions,
)
from noisybolt.bolt.compliance_intervals import ComplianceEstimate, aggregate_compliance
from noisybolt.errors import ConfigError, MissingErrorModelError, UnknownFluentError
from noisybolt.logic.dfa import DFA

__all__ = [
    "DEFAULT_EDGES",
    "ComplianceEstimate",
    "ErrorModel",
    "FluentDynamics",
    "aggregate_compliance",
    "estimate_compliance",
    "fit_dynamics",
    "satisfaction_probabilities",
]

#: The band edges an error model counts in by default: the paper's two thresholds (0.5,
#: 0.9) and 0.1, which splits "absent" into a clear no and a doubtful one (on the smudged
#: gridworld camera the corner's positives that fall below 0.5 fall mostly above 0.1).
DEFAULT_EDGES: tuple[float, ...] = (0.1, 0.5, 0.9)


@dataclass(frozen=True, eq=False)
class ErrorModel:
    """A detector's confusion per fluent and confidence band, counted on labelled images.

    Band ``b`` holds the probabilities ``edges[b - 1] <= p < edges[b]`` (band 0 those
    below ``edges[0]``, the last those at or above ``edges[-1]``).

    Attributes:
        fluent_names: the fluents, in the order of ``counts``' first axis.
        edges: the band edges, increasing, inside (0, 1).
        counts: float64 ``[n_fluents, 2, n_bands]``: labelled images per fluent, truth
            (0: false, 1: true) and band.
        pseudo_count: the Dirichlet prior's count per cell (0.5: Jeffreys'), added to
            ``counts`` for the rates and their draws.

    Raises:
        ConfigError: edges not increasing inside (0, 1), counts of the wrong shape or
            negative, a fluent with no image of one of its truth values and no prior.

    Example:
        >>> model = ErrorModel(fluent_names=("x",), edges=(0.5,),
        ...                    counts=np.array([[[8.0, 2.0], [1.0, 9.0]]]))
        >>> model.rates().round(3).tolist()  # P(band | x false), P(band | x true)
        [[[0.773, 0.227], [0.136, 0.864]]]
        >>> model.bands(np.array([[0.3], [0.5]])).tolist()
        [[0], [1]]
    """

    fluent_names: tuple[str, ...]
    edges: tuple[float, ...]
    counts: np.ndarray
    pseudo_count: float = 0.5
    pair_counts: np.ndarray | None = None
    pair_prior: float = 2.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "fluent_names", tuple(self.fluent_names))
        object.__setattr__(self, "edges", tuple(float(e) for e in self.edges))
        edges = np.array(self.edges)
        if edges.size == 0 or not (np.all(np.diff(edges) > 0) and edges[0] > 0 and edges[-1] < 1):
            raise ConfigError(f"band edges must increase inside (0, 1), got {list(self.edges)}")
        counts = np.array(self.counts, dtype=np.float64)
        shape = (len(self.fluent_names), 2, edges.size + 1)
        if counts.shape != shape:
            raise ConfigError(
                f"counts must have shape {shape} [fluents, truth, band], got {counts.shape}"
            )
        if not np.all(np.isfinite(counts)) or np.any(counts < 0):
            raise ConfigError("counts must be finite and >= 0")
        if self.pseudo_count < 0:
            raise ConfigError(f"pseudo_count must be >= 0, got {self.pseudo_count}")
        empty = counts.sum(axis=2) + self.pseudo_count * shape[2] <= 0
        if empty.any():
            f, t = map(int, np.argwhere(empty)[0])
            raise ConfigError(
                f"no labelled image shows {self.fluent_names[f]!r} {'true' if t else 'false'}:"
                " its error rates are unknown; measure the detector on images that show both"
            )
        counts.setflags(write=False)
        object.__setattr__(self, "counts", counts)
        if self.pair_counts is not None:
            pairs = np.array(self.pair_counts, dtype=np.float64)
            pair_shape = (shape[0], 2, 2, shape[2], shape[2])
            if pairs.shape != pair_shape:
                raise ConfigError(
                    f"pair_counts must have shape {pair_shape} [fluents, truth before, truth "
                    f"now, band before, band now], got {pairs.shape}"
                )
            if not np.all(np.isfinite(pairs)) or np.any(pairs < 0):
                raise ConfigError("pair_counts must be finite and >= 0")
            pairs.setflags(write=False)
            object.__setattr__(self, "pair_counts", pairs)
        if not self.pair_prior > 0:
            raise ConfigError(f"pair_prior must be > 0, got {self.pair_prior}")

    @property
    def temporal(self) -> bool:
        """Whether it holds successive frames' confusion (``pair_counts``)."""
        return self.pair_counts is not None

    @property
    def n_bands(self) -> int:
        """The number of bands."""
        return len(self.edges) + 1

    def bands(self, probs: np.ndarray) -> np.ndarray:
        """int64 band indices of ``probs`` (any shape)."""
        return np.searchsorted(np.array(self.edges), np.asarray(probs, np.float64), side="right")

    def rates(self) -> np.ndarray:
        """float64 ``[n_fluents, 2, n_bands]``: the posterior mean of ``P(band | truth)``."""
        alpha = self.counts + self.pseudo_count
        return alpha / alpha.sum(axis=2, keepdims=True)

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """float64 ``[n, n_fluents, 2, n_bands]``: ``n`` draws of the rates from their
        Dirichlet posteriors."""
        alpha = np.broadcast_to(self.counts + self.pseudo_count, (n, *self.counts.shape))
        draws = rng.gamma(np.maximum(alpha, 1e-12))
        # A cell with neither count nor prior stays at 0 (the gamma of ~0 is ~0).
        draws = np.where(alpha > 0, draws, 0.0)
        return draws / draws.sum(axis=3, keepdims=True)

    def pair_rates(self, rates: np.ndarray) -> np.ndarray | None:
        """float64 ``[..., n_fluents, 2, 2, n_bands, n_bands]``: ``P(band now | band before,
        truth before, truth now)``, the posterior mean given marginal ``rates`` (``[...,
        n_fluents, 2, n_bands]``, e.g. draws of :meth:`sample`) as the prior's centre; None
        without ``pair_counts``."""
        if self.pair_counts is None:
            return None
        alpha = self.pair_counts + self.pair_prior * rates[..., None, :, None, :]
        return alpha / alpha.sum(axis=-1, keepdims=True)

    def sample_pairs(self, rng: np.random.Generator, rates: np.ndarray) -> np.ndarray | None:
        """Draws of :meth:`pair_rates`, one per draw of ``rates`` (``[n, n_fluents, 2,
        n_bands]``): Dirichlet, centred on that draw's marginal rates (a hierarchical
        prior: where successive frames were rarely seen, the marginal confusion speaks)."""
        if self.pair_counts is None:
            return None
        alpha = self.pair_counts + self.pair_prior * rates[:, :, None, :, None, :]
        draws = rng.gamma(np.maximum(alpha, 1e-12))
        return draws / draws.sum(axis=-1, keepdims=True)

    def restrict(self, fluents: Sequence[str], *, what: str = "the estimate") -> ErrorModel:
        """The model of ``fluents`` only, in that order.

        Raises:
            UnknownFluentError: a fluent the model has no measurements of.
        """
        missing = tuple(f for f in fluents if f not in self.fluent_names)
        if missing:
            raise UnknownFluentError(
                f"{what} needs the detector's error rates of {list(missing)}, which its error "
                f"model (fluents {list(self.fluent_names)}) lacks: measure the detector on "
                "labelled images that include them "
                "(noisybolt.perception.error_model.measure_error_model)",
                unknown=missing,
                known=self.fluent_names,
            )
        rows = [self.fluent_names.index(f) for f in fluents]
        return ErrorModel(
            fluent_names=tuple(fluents),
            edges=self.edges,
            counts=self.counts[rows],
            pseudo_count=self.pseudo_count,
            pair_counts=None if self.pair_counts is None else self.pair_counts[rows],
            pair_prior=self.pair_prior,
        )

    def to_dict(self) -> dict[str, Any]:
        """A JSON-able dict (what a classifier file keeps in its training notes)."""
        return {
            "fluent_names": list(self.fluent_names),
            "edges": list(self.edges),
            "counts": {
                name: {"false": row[0].tolist(), "true": row[1].tolist()}
                for name, row in zip(self.fluent_names, self.counts, strict=True)
            },
            "pseudo_count": self.pseudo_count,
            **(
                {}
                if self.pair_counts is None
                else {"pair_counts": self.pair_counts.tolist(), "pair_prior": self.pair_prior}
            ),
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> ErrorModel:
        """The model :meth:`to_dict` wrote.

        Raises:
            ConfigError: not such a dict.
        """
        try:
            names = tuple(str(n) for n in data["fluent_names"])
            counts = [[data["counts"][n]["false"], data["counts"][n]["true"]] for n in names]
            return cls(
                fluent_names=names,
                edges=tuple(data["edges"]),
                counts=np.array(counts, dtype=np.float64),
                pseudo_count=float(data.get("pseudo_count", 0.5)),
                pair_counts=None
                if data.get("pair_counts") is None
                else np.array(data["pair_counts"], dtype=np.float64),
                pair_prior=float(data.get("pair_prior", 2.0)),
            )
        except (KeyError, TypeError, ValueError) as error:
            if isinstance(error, ConfigError):
                raise
            raise ConfigError(f"not an error model ({type(error).__name__}: {error})") from error


def satisfaction_probabilities(
    dfa: DFA,
    fluents: Sequence[str],
    episodes: Sequence[np.ndarray],
    rates: np.ndarray,
    dynamics: FluentDynamics,
    *,
    pair_rates: np.ndarray | None = None,
    edges: Sequence[float] = (0.5,),
) -> np.ndarray:
    """``P(the DFA accepts the true trace | the frames)`` per error-model draw and episode.

    Args:
        dfa: the spec's DFA (its relevant fluents among ``fluents``).
        fluents: the column order of the episodes' probabilities, of ``rates`` and
            ``dynamics``.
        episodes: per episode, the detector's probabilities float ``[T, n_fluents]``
            (row 0: the first observation), or int band indices of the same shape.
        rates: float ``[n_draws, n_fluents, 2, n_bands]``: ``P(band | truth)`` per draw.
        dynamics: the fluents' chains.
        pair_rates: float ``[n_draws, n_fluents, 2, 2, n_bands, n_bands]``: ``P(band |
            band before, truth before, truth now)`` per draw, or None (frames independent
            given the truth).
        edges: the band edges of float ``episodes`` (ignored for band indices).

    Returns:
        float64 ``[n_draws, n_episodes]``.
    """
    fluents = tuple(fluents)
    cols = [fluents.index(f) for f in dfa.relevant_fluents]
    m = len(cols)
    # A configuration: each relevant fluent's chain state (off never on, on, off on
    # before), the first fluent the most significant of m base-3 digits.
    n_configs, n_q = 3**m, dfa.n_states
    configs = np.arange(n_configs, dtype=np.int64)
    digits = (configs[:, None] // 3 ** np.arange(m - 1, -1, -1)) % 3  # [C, m]
    bits = TRUTH[digits]  # [C, m]: each fluent's truth
    positions = np.array([dfa.fluents.index(fluents[c]) for c in cols], dtype=np.int64)
    letters = (bits << positions).sum(axis=1) if m else np.zeros(1, dtype=np.int64)
    states = np.repeat(np.arange(n_q), n_configs)
    nxt, _ = dfa.step_batch(states, np.tile(letters, n_q).astype(np.uint64))
    nxt = np.asarray(nxt, dtype=np.int64).reshape(n_q, n_configs)
    # The DFA's move on the new configuration: [q, c', q'] = [delta(q, c') = q'].
    move = np.zeros((n_q, n_configs, n_q))
    move[np.repeat(np.arange(n_q), n_configs), np.tile(configs, n_q), nxt.ravel()] = 1.0
    first_state, chain = dynamics.select(cols).matrices()  # [m, 3], [m, 3, 3]
    accepting = np.asarray(dfa.accepting, dtype=np.float64)
    arrays = [np.asarray(e) for e in episodes]
    if arrays and np.issubdtype(arrays[0].dtype, np.floating):
        grid = np.array(edges, dtype=np.float64)
        arrays = [np.searchsorted(grid, a, side="right") for a in arrays]
    x, lengths = padded(arrays)
    x = x[:, :, cols]
    rates = rates[:, cols]
    pairs = None if pair_rates is None else pair_rates[:, cols]
    n_draws, n = rates.shape[0], len(arrays)

    def evidence(t: int) -> np.ndarray:  # [S, n, m, 3, 3]: P(frame t | state before, now)
        emit = step_emissions(x, t, rates, pairs)  # [S, n, m, 2, 2] over truths
        out: np.ndarray = emit[..., TRUTH[:, None], TRUTH[None, :]]
        return out

    # belief [S, n, q, c]: after the first frame (the trace's first letter)
    seen = evidence(0)[:, :, :, 0, :] * first_state  # [S, n, m, 3]
    first = np.ones((n_draws, n, n_configs))
    for j in range(m):
        first *= seen[:, :, j][:, :, digits[:, j]]
    belief = np.einsum("snc,cr->snrc", first, move[dfa.initial_state])
    belief /= belief.sum(axis=(2, 3), keepdims=True)
    for t in range(1, int(lengths.max())):
        live = (lengths > t)[None, :, None, None]
        weights = chain * evidence(t)  # [S, n, m, 3, 3]
        # The chains move one fluent at a time (they are independent): digit j of the
        # configuration is axis 1 of [S * n, q * 3^j, 3, 3^(m - j - 1)].
        moved = belief
        for j in range(m):
            shaped = moved.reshape(n_draws, n, n_q * 3**j, 3, 3 ** (m - j - 1))
            moved = np.matmul(shaped.swapaxes(3, 4), weights[:, :, j, None]).swapaxes(3, 4)
        moved = moved.reshape(belief.shape)
        stepped = np.zeros_like(moved)
        for q in range(n_q):  # from q, configuration c goes to delta(q, c): no two alike
            stepped[:, :, nxt[q], configs] += moved[:, :, q]
        moved = stepped
        total = moved.sum(axis=(2, 3), keepdims=True)
        # Evidence that every hypothesis forbids (a rate drawn at 0): keep the belief.
        ok = total > 0
        updated = np.where(ok, moved / np.where(ok, total, 1.0), belief)
        belief = np.where(live, updated, belief)
    out: np.ndarray = belief.sum(axis=3) @ accepting
    return out


def estimate_compliance(
    dfas: Mapping[str, DFA],
    fluents: Sequence[str],
    episodes: Sequence[np.ndarray],
    error_model: ErrorModel,
    *,
    dynamics: FluentDynamics | None = None,
    memory: bool = True,
    n_draws: int = 64,
    level: float = 0.9,
    seed: int = 0,
) -> dict[str, ComplianceEstimate]:
    """Each spec's estimated compliance rate over ``episodes`` (see the module docstring).

    Args:
        dfas: the specs' DFAs by name.
        fluents: the column order of the episodes' probabilities.
        episodes: per episode, the detector's probabilities float ``[T, n_fluents]``.
        error_model: the detector's error model (it must cover the specs' fluents).
        dynamics: the fluents' chains (over ``fluents``); None: learnt from ``episodes``
            (:func:`fit_dynamics`).
        memory: the learnt chains tell coming on again after having been on from coming
            on the first time (:class:`FluentDynamics`' ``again``); False: one rate.
        n_draws: draws of the error model.
        level: the intervals' probability.
        seed: seeds the draws.

    Raises:
        UnknownFluentError: a spec's fluent the episodes' columns or the error model lack.
        MissingErrorModelError: a spec's fluent that no labelled image showed true (or
            false) when the error model was measured.
        ConfigError: no episodes, or episodes of another width.
    """
    fluents = tuple(fluents)
    needed = sorted({f for dfa in dfas.values() for f in dfa.relevant_fluents})
    absent = tuple(f for f in needed if f not in fluents)
    if absent:
        raise UnknownFluentError(
            f"the specs use {list(absent)}, which the detector's outputs {list(fluents)} lack:"
            " use a detector that predicts every fluent the specs name",
            unknown=absent,
            known=fluents,
        )
    if not episodes:
        raise ConfigError("estimating compliance needs at least one episode")
    arrays = [np.asarray(e, dtype=np.float64) for e in episodes]
    if any(a.ndim != 2 or a.shape[1] != len(fluents) or len(a) == 0 for a in arrays):
        raise ConfigError(f"every episode must be [T >= 1, {len(fluents)}] probabilities")
    used = tuple(f for f in fluents if f in needed)
    model = error_model.restrict(used, what="the compliance estimate")
    unseen = [
        f"{f} {'true' if t else 'false'}"
        for f, row in zip(used, model.counts, strict=True)
        for t in (0, 1)
        if row[t].sum() == 0
    ]
    if unseen:
        raise MissingErrorModelError(
            f"the detector's error model was measured on no labelled image showing "
            f"{', '.join(unseen)}: what it reads then is unknown, and so is compliance with "
            "specs over it; measure it on labelled images that show each fluent true and false"
        )
    cols = [fluents.index(f) for f in used]
    bands = [model.bands(a[:, cols]) for a in arrays]
    if dynamics is None:
        mean = model.rates()
        dynamics = fit_dynamics(bands, mean, pair_rates=model.pair_rates(mean), memory=memory)
    else:
        dynamics = dynamics.select(cols)
    rng = np.random.default_rng(seed)
    rates = model.sample(rng, n_draws)
    pairs = model.sample_pairs(rng, rates)
    out = {}
    for name, dfa in dfas.items():
        draws = satisfaction_probabilities(dfa, used, bands, rates, dynamics, pair_rates=pairs)
        out[name] = aggregate_compliance(draws, rng=rng, level=level)
    return out
