"""The fluents' dynamics the compliance estimate filters with, learnt without ground truth.

Each fluent's truth is a hidden chain with three states: *off, never on yet* (0), *on*
(1) and *off, on before* (2). The third state is the chain's memory: a route passes a
corner once, so the chance that a fluent comes on again after it went off (``again``) is
not the chance that it comes on the first time (``on``). Without the memory (``again``
None, or equal to ``on``), states 0 and 2 behave alike and the chain is the two-state one
(``P(true)`` first, ``P(on | off)``, ``P(off | on)``). With it, one confident but wrong
frame after a visit (a patch over the agent read as the corner again) is weighed against
how often the episodes truly come back, not how often they arrive.

:func:`fit_dynamics` learns the chains from the unlabelled episodes themselves
(Baum-Welch with the error model's emissions held fixed). See
:mod:`noisybolt.bolt.compliance`.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

from noisybolt.errors import ConfigError

__all__ = ["TRUTH", "FluentDynamics", "fit_dynamics"]

#: Each chain state's truth: off (never on yet), on, off (on before).
TRUTH = np.array([0, 1, 0], dtype=np.int64)
# Transition probabilities are kept this far from 0 and 1 when learnt: an event the
# episodes never showed is improbable, not impossible.
_FLOOR = 1e-6


class FluentDynamics(NamedTuple):
    """Each fluent's truth as a Markov chain (float64 ``[n_fluents]`` each).

    Attributes:
        start: ``P(true)`` on an episode's first frame.
        on: ``P(true at t + 1 | false at t)`` while it has not been true yet.
        off: ``P(false at t + 1 | true at t)``.
        again: ``P(true at t + 1 | false at t)`` once it has been true in the episode;
            None: as ``on`` (a chain without memory).
    """

    start: np.ndarray
    on: np.ndarray
    off: np.ndarray
    again: np.ndarray | None = None

    def select(self, cols: Sequence[int]) -> FluentDynamics:
        """The chains of the fluents ``cols``, in that order."""
        index = list(cols)
        return FluentDynamics(
            start=np.asarray(self.start, dtype=np.float64)[index],
            on=np.asarray(self.on, dtype=np.float64)[index],
            off=np.asarray(self.off, dtype=np.float64)[index],
            again=None if self.again is None else np.asarray(self.again, np.float64)[index],
        )

    def matrices(self) -> tuple[np.ndarray, np.ndarray]:
        """float64 ``[n_fluents, 3]`` first-frame and ``[n_fluents, 3, 3]`` transition
        probabilities over the chain states (off never on, on, off on before)."""
        start = np.asarray(self.start, dtype=np.float64)
        on = np.asarray(self.on, dtype=np.float64)
        off = np.asarray(self.off, dtype=np.float64)
        again = on if self.again is None else np.asarray(self.again, dtype=np.float64)
        zero = np.zeros_like(on)
        first = np.stack([1 - start, start, zero], -1)
        chain = np.stack(
            [
                np.stack([1 - on, on, zero], -1),
                np.stack([zero, 1 - off, off], -1),
                np.stack([zero, again, 1 - again], -1),
            ],
            1,
        )
        return first, chain


def padded(bands: Sequence[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """int64 ``[n, T, k]`` bands padded with 0, and int64 ``[n]`` lengths."""
    lengths = np.array([len(b) for b in bands], dtype=np.int64)
    if lengths.size == 0 or lengths.min() < 1:
        raise ConfigError("every episode needs at least one frame")
    k = bands[0].shape[1]
    out = np.zeros((len(bands), int(lengths.max()), k), dtype=np.int64)
    for i, b in enumerate(bands):
        out[i, : len(b)] = b
    return out, lengths


def step_emissions(
    x: np.ndarray, t: int, rates: np.ndarray, pairs: np.ndarray | None
) -> np.ndarray:
    """float64 ``[S, n, k, 2, 2]``: ``P(band of frame t | truth before, truth now)`` per
    draw, episode and fluent (row 0: the first frame, its truth before irrelevant).

    ``x``: int ``[n, T, k]`` bands; ``rates``: ``[S, k, 2, B]``; ``pairs``: ``[S, k, 2, 2,
    B, B]`` or None (each frame's band independent of the last's, given the truth).
    """
    k = x.shape[2]
    fluent = np.arange(k)[None, :]
    now = x[:, t]  # [n, k]
    if pairs is None or t == 0:
        marginal = rates[:, fluent, :, now]  # [n, k, S, 2] (advanced indices first)
        marginal = marginal.transpose(2, 0, 1, 3)  # [S, n, k, 2]
        return np.broadcast_to(marginal[:, :, :, None, :], (*marginal.shape[:3], 2, 2))
    before = x[:, t - 1]
    table = pairs[:, fluent, :, :, before, now]  # [n, k, S, 2, 2]
    out: np.ndarray = table.transpose(2, 0, 1, 3, 4)
    return out


def fit_dynamics(
    bands: Sequence[np.ndarray],
    rates: np.ndarray,
    *,
    pair_rates: np.ndarray | None = None,
    iterations: int = 40,
    memory: bool = False,
) -> FluentDynamics:
    """Each fluent's chain learnt from unlabelled episodes (Baum-Welch, emissions fixed).

    Args:
        bands: per episode, int ``[T, n_fluents]``: the band of each frame and fluent.
        rates: float ``[n_fluents, 2, n_bands]``: ``P(band | truth)`` (the error model).
        pair_rates: float ``[n_fluents, 2, 2, n_bands, n_bands]``: ``P(band | band before,
            truth before, truth now)`` (:meth:`ErrorModel.pair_rates`), or None.
        iterations: EM iterations.
        memory: learn ``again`` (coming on after having been on) apart from ``on``; False:
            one rate for both (``again`` None).

    Returns:
        The :class:`FluentDynamics` of maximum likelihood found (from a start at rate 0.1
        of switching and ``P(true) = 0.5``).

    Example:
        >>> rates = np.array([[[0.9, 0.1], [0.1, 0.9]]])  # right 9 times in 10
        >>> episodes = [np.repeat([[0], [1]], 20, axis=0)] * 10  # off 20 frames, then on
        >>> d = fit_dynamics(episodes, rates)
        >>> round(float(d.start[0]), 2), round(float(d.on[0]), 2), round(float(d.off[0]), 3)
        (0.0, 0.05, 0.0)
    """
    x, lengths = padded([np.asarray(b, dtype=np.int64) for b in bands])
    n, t_max, k = x.shape
    pairs = None if pair_rates is None else pair_rates[None]
    # emit[:, t, f, i, j]: P(band of frame t | chain state i before, j now)
    emit = np.stack(
        [
            step_emissions(x, t, rates[None], pairs)[0][..., TRUTH[:, None], TRUTH[None, :]]
            for t in range(t_max)
        ],
        1,
    )
    valid = np.arange(t_max)[None, :] < lengths[:, None]  # [n, T]
    dynamics = FluentDynamics(
        start=np.full(k, 0.5),
        on=np.full(k, 0.1),
        off=np.full(k, 0.1),
        again=np.full(k, 0.1) if memory else None,
    )
    for _ in range(iterations):
        first_state, a = dynamics.matrices()  # [k, 3], [k, 3, 3]
        alpha = np.zeros((n, t_max, k, 3))
        scale = np.ones((n, t_max, k))
        first = first_state[None] * emit[:, 0, :, 0, :]
        scale[:, 0] = first.sum(-1)
        alpha[:, 0] = first / scale[:, 0, :, None]
        for t in range(1, t_max):
            pred = np.einsum("nfi,fij,nfij->nfj", alpha[:, t - 1], a, emit[:, t])
            c = pred.sum(-1)
            live = valid[:, t, None]
            scale[:, t] = np.where(live, c, 1.0)
            alpha[:, t] = np.where(live[..., None], pred / c[..., None], alpha[:, t - 1])
        beta = np.ones((n, t_max, k, 3))
        for t in range(t_max - 2, -1, -1):
            back = np.einsum("fij,nfij,nfj->nfi", a, emit[:, t + 1], beta[:, t + 1])
            back /= scale[:, t + 1, :, None]
            beta[:, t] = np.where(valid[:, t + 1, None, None], back, beta[:, t + 1])
        gamma = alpha[:, 0] * beta[:, 0]
        gamma /= gamma.sum(-1, keepdims=True)
        # xi[n, t, f, i, j] for the transitions t -> t + 1 inside each episode
        xi = (
            alpha[:, :-1, :, :, None]
            * a[None, None]
            * emit[:, 1:]
            * (beta[:, 1:] / scale[:, 1:, :, None])[:, :, :, None, :]
        )
        xi *= valid[:, 1:, None, None, None]
        moves = xi.sum(axis=(0, 1))  # [k, 3, 3]
        if not memory:  # one "off" state: never on yet and on before pooled
            moves[:, 0] += moves[:, 2]
        with np.errstate(invalid="ignore", divide="ignore"):
            rates_of = {
                "on": moves[:, 0, 1] / moves[:, 0].sum(-1),
                "off": moves[:, 1, 2] / moves[:, 1].sum(-1),
                "again": moves[:, 2, 1] / moves[:, 2].sum(-1),
            }
        learnt = {
            name: np.clip(np.nan_to_num(r, nan=0.0), _FLOOR, 1 - _FLOOR)
            for name, r in rates_of.items()
        }
        dynamics = FluentDynamics(
            start=np.clip(gamma[:, :, 1].mean(0), _FLOOR, 1 - _FLOOR),
            on=learnt["on"],
            off=learnt["off"],
            again=learnt["again"] if memory else None,
        )
    return dynamics
