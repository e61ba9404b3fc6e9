"""Progress shaping over each spec's DFA: potential-based, so it never changes what is optimal.

Algorithm 1 pays nothing before a spec is satisfied, so a detour that a spec asks for
(visit a corner, then the goal) gets no signal until it is complete. Progress shaping
adds, on every bolt transition ``q -> q'``, the potential-based term of Ng, Harada &
Russell (ICML 1999)::

    F(q, q') = gamma * Phi(q') - Phi(q)        (Phi of the state after the episode's
                                                last transition is 0: the absorbing end)

with a potential from the DFA state's distance to acceptance (as in Camacho et al.,
IJCAI 2019, "LTL and Beyond", and Toro Icarte et al.'s reward-machine shaping)::

    Phi(q) = -scale * d(q) / (d_max + 1)       d(q) = fewest letters to an accepting state
    Phi(q) = -scale                             where no accepting state is reachable

so moving one letter closer to acceptance pays about ``scale / (d_max + 1)`` at once and
falling into a rejecting sink costs about what the spec is worth. Over an episode the
terms telescope to ``-Phi(q_0)``, which no action changes: with ``gamma`` the learner's
discount, every policy's value moves by the same amount, and the optimal policy is the
same with and without shaping (tested by value iteration on the gridworld's product).

Example:
    >>> import numpy as np
    >>> from noisybolt.logic import compile_ltlf
    >>> shaping = ProgressShaping([compile_ltlf("F(a & X(F(b)))", ["a", "b"])],
    ...                           scales=[30.0], gamma=1.0)
    >>> sorted(set(shaping.potentials[0].tolist()))
    [-20.0, -10.0, 0.0]
    >>> q0 = shaping.dfas[0].initial_state
    >>> q1 = shaping.dfas[0].step(q0, {"a": True, "b": False})
    >>> shaping(np.array([[q0]]), np.array([[q1]]), done=np.array([False])).tolist()
    [[10.0]]
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from noisybolt.errors import ConfigError
from noisybolt.logic.analysis import distance_to_acceptance
from noisybolt.logic.dfa import DFA

__all__ = ["ProgressShaping", "progress_potential"]


def progress_potential(dfa: DFA, scale: float) -> np.ndarray:
    """float64 ``[n_states]``: ``Phi`` of each DFA state (see the module docstring)."""
    distance = distance_to_acceptance(dfa)
    d_max = int(distance.max(initial=0))
    potential = np.where(distance >= 0, -scale * distance / (d_max + 1), -scale)
    return potential.astype(np.float64) + 0.0  # + 0.0: no -0.0 for accepting states


class ProgressShaping:
    """Potential-based progress shaping for several specs, batched over environments.

    Args:
        dfas: the specs' DFAs, in the bolt's order.
        scales: per spec, the reward its acceptance is worth (the potential's range).
        gamma: the learner's discount factor (shaping is policy-invariant only with it).

    Raises:
        ConfigError: a negative or non-finite scale, a gamma outside (0, 1], or a
            different number of DFAs and scales.
    """

    def __init__(self, dfas: Sequence[DFA], *, scales: Sequence[float], gamma: float) -> None:
        dfas, scales = tuple(dfas), tuple(float(s) for s in scales)
        if len(dfas) != len(scales):
            raise ConfigError(f"progress shaping: {len(dfas)} DFAs but {len(scales)} scales")
        for scale in scales:
            if not math.isfinite(scale) or scale < 0:
                raise ConfigError(f"progress shaping: a scale must be finite and >= 0, got {scale}")
        if not (isinstance(gamma, (int, float)) and 0.0 < gamma <= 1.0):
            raise ConfigError(f"progress shaping: gamma must be in (0, 1], got {gamma!r}")
        self._dfas = dfas
        self._gamma = float(gamma)
        self._potentials = tuple(
            progress_potential(d, s) for d, s in zip(dfas, scales, strict=True)
        )
        offsets = np.cumsum((0, *(d.n_states for d in dfas[:-1])), dtype=np.int64)
        self._offsets = offsets
        self._flat = np.concatenate(self._potentials) if dfas else np.zeros(0)

    @property
    def dfas(self) -> tuple[DFA, ...]:
        """The DFAs shaped, in order."""
        return self._dfas

    @property
    def gamma(self) -> float:
        """The discount factor the shaping is invariant for."""
        return self._gamma

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
        """float64 ``[n_envs, n_specs]``: ``F`` of the transitions ``states -> next_states``.

        ``done`` (bool ``[n_envs]``) marks transitions that end the episode: the state
        after them is the absorbing end, whose potential is 0.
        """
        after = np.where(done[:, None], 0.0, self.potential(next_states))
        return self._gamma * after - self.potential(states)
