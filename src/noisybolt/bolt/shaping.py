"""The compliance scheme's progress terms over each spec's DFA: graded outcome and shaping.

Algorithm 1 pays nothing before a spec is satisfied, so a detour that a spec asks for
(visit a corner, then the goal) gets no signal until it is complete. The ``compliance``
reward scheme (:mod:`noisybolt.bolt.schemes`) pays each spec ``scale`` for an accepted
episode (as the DFA comes to accept, the engine's ``on_change`` timing, or at the end,
``episode_end``) and, with this module:

* a *graded outcome*: an episode that ends short of acceptance is charged by how far it
  is, ``Phi(q_T)``, with the potential of a DFA state from its distance to acceptance::

      Phi(q) = -scale * d(q) / (d_max + 1)   d(q): fewest letters to an accepting state
      Phi(q) = 0                              where no accepting state is reachable

* a *violation charge*, ``-scale``, on the transition that makes acceptance impossible
  (into a rejecting sink), paid when it happens: the outcome is settled then, and a
  violated episode has nothing left to gain from delaying its end;
* *progress shaping* (optional), the potential-based term of Ng, Harada & Russell
  (ICML 1999) with that potential (as Camacho et al., IJCAI 2019, shape reward machines)::

      F(q, q') = gamma * Phi(q') - Phi(q)     (Phi after the episode's last transition: 0)

  so each letter closer to acceptance pays about ``scale / (d_max + 1)`` at once.

Which discount: the bolt of ``noisybolt train`` uses ``gamma = 1``
(:attr:`~noisybolt.runs.training.TrainConfig.progress_gamma`). The scheme's objective is
undiscounted (compliance first is a statement about whole episodes), and with ``gamma < 1``
a state short of acceptance, whose potential is negative, pays ``(1 - gamma) * |Phi|`` for
every step it is held (Ng's terms then take it back at the end): measured on
``F(top_right_corner) & F(bottom_left_corner)``, PPO learnt to wander with one corner
visited, 100+-step episodes, instead of finishing. With ``gamma = 1`` progress is paid when
it is made and nothing for waiting; for a learner that discounts, the shaping is then
invariant for the undiscounted objective, not exactly for its discounted one.

Over an episode the shaping terms sum (discounted) to ``gamma^T * 0 - Phi(q_0)``, which
no action changes, so the optimal policy of the scheme is the same with and without
shaping (tested by value iteration on the gridworld's product). Without shaping, the
graded outcome and the violation charge alone already rank episodes: accepted (+scale)
above unfinished (down to ``-scale * d_max / (d_max + 1)``) above violated (-scale).

Example:
    >>> import numpy as np
    >>> from noisybolt.logic import compile_ltlf
    >>> dfa = compile_ltlf("F(a & X(F(b)))", ["a", "b"])
    >>> terms = ProgressShaping([dfa], scales=[30.0], gamma=1.0)
    >>> sorted(set(terms.potentials[0].tolist()))
    [-20.0, -10.0, 0.0]
    >>> q0 = dfa.initial_state
    >>> q1 = dfa.step(q0, {"a": True, "b": False})
    >>> terms(np.array([[q0]]), np.array([[q1]]), done=np.array([False])).tolist()  # progress
    [[10.0]]
    >>> terms(np.array([[q0]]), np.array([[q1]]), done=np.array([True])).tolist()  # ends there
    [[10.0]]
    >>> ProgressShaping([dfa], scales=[30.0], gamma=1.0, shaping=False)(
    ...     np.array([[q0]]), np.array([[q1]]), done=np.array([True])).tolist()  # end charge
    [[-10.0]]
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from noisybolt.errors import ConfigError
from noisybolt.logic.analysis import distance_to_acceptance
from noisybolt.logic.dfa import DFA

__all__ = ["ProgressShaping", "progress_potential"]


def progress_potential(dfa: DFA, scale: float, letters: np.ndarray | None = None) -> np.ndarray:
    """float64 ``[n_states]``: ``Phi`` of each DFA state (see the module docstring).

    ``letters``: the letters the world produces, as bitmasks over ``dfa.fluents`` (see
    :func:`~noisybolt.logic.distance_to_acceptance`); None for every letter.
    """
    distance = distance_to_acceptance(dfa, letters)
    d_max = int(distance.max(initial=0))
    potential = np.where(distance >= 0, -scale * distance / (d_max + 1), 0.0)
    return potential.astype(np.float64) + 0.0  # + 0.0: no -0.0 for accepting states


class ProgressShaping:
    """The compliance scheme's progress terms for several specs, batched over environments.

    Args:
        dfas: the specs' DFAs, in the bolt's order.
        scales: per spec, the reward its acceptance is worth.
        gamma: the learner's discount factor (shaping is policy-invariant only with it).
        shaping: add the potential-based shaping term; False keeps only the graded
            outcome and the violation charge.
        letters: per spec, the letters the world produces (bitmasks over its DFA's
            fluents), so distances count only steps the world can take; None (or a None
            entry) for every letter.

    Raises:
        ConfigError: a negative or non-finite scale, a gamma outside (0, 1], or a
            different number of DFAs and scales.
    """

    def __init__(
        self,
        dfas: Sequence[DFA],
        *,
        scales: Sequence[float],
        gamma: float,
        shaping: bool = True,
        letters: Sequence[np.ndarray | None] | None = None,
    ) -> None:
        dfas, scales = tuple(dfas), tuple(float(s) for s in scales)
        per_spec = tuple(letters) if letters is not None else (None,) * len(dfas)
        if len(per_spec) != len(dfas):
            raise ConfigError(f"progress shaping: {len(dfas)} DFAs but {len(per_spec)} letter sets")
        if len(dfas) != len(scales):
            raise ConfigError(f"progress shaping: {len(dfas)} DFAs but {len(scales)} scales")
        for scale in scales:
            if not math.isfinite(scale) or scale < 0:
                raise ConfigError(f"progress shaping: a scale must be finite and >= 0, got {scale}")
        if isinstance(gamma, bool) or not isinstance(gamma, (int, float)) or not 0 < gamma <= 1:
            raise ConfigError(f"progress shaping: gamma must be in (0, 1], got {gamma!r}")
        self._dfas = dfas
        self._gamma = float(gamma)
        self._shaping = bool(shaping)
        self._potentials = tuple(
            progress_potential(d, s, m) for d, s, m in zip(dfas, scales, per_spec, strict=True)
        )
        self._offsets = np.cumsum((0, *(d.n_states for d in dfas[:-1])), dtype=np.int64)
        self._flat = np.concatenate(self._potentials)
        # What violating costs, as a potential: -scale on the states that cannot accept.
        dead = [distance_to_acceptance(d) < 0 for d in dfas]
        self._dead_cost = np.concatenate([s * d for s, d in zip(scales, dead, strict=True)])

    @property
    def dfas(self) -> tuple[DFA, ...]:
        """The DFAs, in order."""
        return self._dfas

    @property
    def gamma(self) -> float:
        """The discount factor the shaping is invariant for."""
        return self._gamma

    @property
    def shaping(self) -> bool:
        """Whether the potential-based shaping term is added."""
        return self._shaping

    @property
    def potentials(self) -> tuple[np.ndarray, ...]:
        """Per spec, ``Phi`` of each of its DFA's states."""
        return self._potentials

    def potential(self, states: np.ndarray) -> np.ndarray:
        """float64 ``[n_envs, n_specs]``: ``Phi`` of int DFA states ``[n_envs, n_specs]``."""
        return self._flat[states + self._offsets]

    def __call__(
        self, states: np.ndarray, next_states: np.ndarray, *, done: np.ndarray
    ) -> np.ndarray:
        """float64 ``[n_envs, n_specs]``: the terms of the transitions ``states -> next_states``.

        ``done`` (bool ``[n_envs]``) marks transitions that end the episode.
        """
        before, after = self.potential(states), self.potential(next_states)
        cells, next_cells = states + self._offsets, next_states + self._offsets
        violation = self._dead_cost[cells] - self._dead_cost[next_cells]  # -scale on entry
        ended = done[:, None]
        end_charge = np.where(ended, after, 0.0)
        if not self._shaping:
            return violation + end_charge
        shaping = np.where(ended, 0.0, self._gamma * after) - before
        return violation + end_charge + shaping
