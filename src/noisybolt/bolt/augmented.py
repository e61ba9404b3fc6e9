"""The explicit augmented DFA of the paper's Fig. 2a: a reference for Algorithm 1.

The paper splits each fluent ``e`` into ``e_h`` (seen with high confidence), ``e_l`` (low
confidence) and ``!e`` (absent), and rewrites every edge of the DFA over these: an edge
whose guard has ``n_e`` positive fluents becomes ``2**n_e`` edges, each with its reward
(terminal reward of the target, minus the cost of its low-confidence fluents) computed
once. Algorithm 1 gets the same result without building any of this; this module builds
it honestly, so that tests can check the two agree and the benchmark can show the
exponential growth.

Construction, per edge ``q -> q'`` of the original DFA with guard ``g`` over its support
``S`` (the fluents ``g`` depends on):

1. ``g`` is written as a sum of *disjoint* cubes over ``S`` (Shannon expansion in
   vocabulary order), e.g. ``F(e & t)``'s self-loop ``!e | !t`` becomes ``!e`` and
   ``e & !t``;
2. in each cube, every positive literal ``f`` is split into ``f_h`` and ``f_l`` (the
   paper's ``2**n_e``), a negative literal stays ``!f``, and every support fluent the cube
   leaves free is split into ``f_l`` and ``!f_l`` ("not low": absent or high) because
   Algorithm 1 charges for every low-confidence fluent of the support, constrained by the
   cube or not;
3. each resulting edge gets ``reward = terminal_reward * [q' accepting]
   - low_confidence_cost * (number of its _l literals)`` (the ``every_step`` timing and
   the ``count`` cost mode; the proportional cost depends on the exact probability, which
   no finite relabelling of the edges can encode).

An *expanded letter* is a pair of bitmasks over the fluents, ``truth`` (``p >= truth``)
and ``low`` (low band). Stepping is what a textbook DFA does with an edge list: scan the
edges leaving ``q`` for the one whose augmented guard the expanded letter satisfies. For
``F(a1 & ... & an)`` state 0 has ``2**n`` edges to state 1 and ``n * 2**(n-1)`` self-loops.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from noisybolt.bolt._bits import popcount, scatter_bits
from noisybolt.bolt.bands import DEFAULT_THRESHOLDS, Thresholds, check_probs
from noisybolt.logic.dfa import DFA

__all__ = ["AugmentedDFA", "AugmentedEdge", "AugmentedStep"]

# Largest [envs x edges] block compared at once while stepping (bounds temporary memory).
_BLOCK_CELLS = 1 << 20


class AugmentedEdge(NamedTuple):
    """One edge of the augmented DFA, for people to read.

    Attributes:
        src: source state.
        dst: destination state.
        guard: a conjunction over augmented literals: ``f_h`` (high), ``f_l`` (low),
            ``!f`` (absent), ``!f_l`` (not low: absent or high); ``true`` if empty.
        n_low: number of ``f_l`` literals.
        reward: the reward precomputed for the edge.
    """

    src: int
    dst: int
    guard: str
    n_low: int
    reward: float


class AugmentedStep(NamedTuple):
    """One step of the augmented DFA for a batch.

    Attributes:
        next_states: int64 ``[n_envs]``.
        reward: float64 ``[n_envs]``, the taken edge's precomputed reward.
        n_low: int64 ``[n_envs]``, the taken edge's number of low-confidence literals.
        edge: int64 ``[n_envs]``, index of the taken edge.
    """

    next_states: np.ndarray
    reward: np.ndarray
    n_low: np.ndarray
    edge: np.ndarray


def _disjoint_cubes(guard: np.ndarray, var: int = 0, fixed: int = 0, value: int = 0) -> list:
    """Disjoint cubes ``(fixed_mask, value_mask)`` covering a boolean function.

    ``guard[j]`` is the function at assignment ``j`` of the remaining variables (bit 0 of
    ``j`` is variable ``var``); splits on the lowest variable first.
    """
    if guard.all():
        return [(fixed, value)]
    if not guard.any():
        return []
    bit = 1 << var
    return _disjoint_cubes(guard[0::2], var + 1, fixed | bit, value) + _disjoint_cubes(
        guard[1::2], var + 1, fixed | bit, value | bit
    )


@dataclass(frozen=True, eq=False)
class AugmentedDFA:
    """The augmented DFA of Fig. 2a, with rewards on its edges, built from a DFA.

    Build one with :meth:`from_dfa`. Edges are held as arrays sorted by source state;
    edge ``i`` leaves ``src[i]`` for ``dst[i]`` and is taken by an expanded letter
    ``(truth, low)`` iff ``truth & truth_care[i] == truth_value[i]`` and
    ``low & low_care[i] == low_value[i]``.

    Attributes:
        fluents: the DFA's vocabulary (the column order of ``probs``).
        initial_state: as in the DFA.
        accepting: bool ``[n_states]``.
        thresholds: the band thresholds that make expanded letters.
        terminal_reward: reward for edges into accepting states.
        low_confidence_cost: cost of each low-confidence literal.
        src, dst: int64 ``[n_edges]``.
        truth_care, truth_value, low_care, low_value: uint64 ``[n_edges]`` masks.
        n_low: int64 ``[n_edges]``.
        reward: float64 ``[n_edges]``.
        edge_offsets: int64 ``[n_states + 1]``; state ``q``'s edges are
            ``edge_offsets[q]:edge_offsets[q + 1]``.

    Example:
        >>> f_e_and_t = DFA.from_function(["e", "t"], n_states=2, initial_state=0,
        ...     accepting=[False, True], delta=lambda q, m: 1 if q == 1 or m == 0b11 else 0)
        >>> aug = AugmentedDFA.from_dfa(f_e_and_t, terminal_reward=10.0,
        ...                             low_confidence_cost=2.0)
        >>> [(e.guard, e.reward) for e in aug.edges() if (e.src, e.dst) == (0, 1)]
        [('e_h & t_h', 10.0), ('e_l & t_h', 8.0), ('e_h & t_l', 8.0), ('e_l & t_l', 6.0)]
        >>> aug.step_batch(np.array([0]), np.array([[0.7, 0.95]])).reward.tolist()
        [8.0]
    """

    fluents: tuple[str, ...]
    initial_state: int
    accepting: np.ndarray
    thresholds: Thresholds
    terminal_reward: float
    low_confidence_cost: float
    src: np.ndarray
    dst: np.ndarray
    truth_care: np.ndarray
    truth_value: np.ndarray
    low_care: np.ndarray
    low_value: np.ndarray
    n_low: np.ndarray
    reward: np.ndarray
    edge_offsets: np.ndarray

    @classmethod
    def from_dfa(
        cls,
        dfa: DFA,
        *,
        terminal_reward: float,
        low_confidence_cost: float,
        thresholds: Thresholds = DEFAULT_THRESHOLDS,
    ) -> AugmentedDFA:
        """Expands every edge of ``dfa`` (which must have dense tables).

        Raises:
            ValueError: the DFA has no dense tables (its vocabulary is too large for a
                reference implementation anyway).
        """
        try:
            next_state, support = np.asarray(dfa.next_state), np.asarray(dfa.support)
        except (AttributeError, ValueError, RuntimeError, MemoryError) as exc:
            raise ValueError(
                f"the augmented DFA needs dense tables; this DFA over {dfa.n_fluents} fluents "
                "has none"
            ) from exc
        parts: dict[str, list[np.ndarray]] = {
            k: [] for k in ("src", "dst", "tc", "tv", "lc", "lv", "n_low")
        }
        for q in range(dfa.n_states):
            row = next_state[q]
            for target in np.unique(row):
                supp = int(support[q, int(np.argmax(row == target))])
                positions = np.array([i for i in range(dfa.n_fluents) if supp >> i & 1])
                local = np.arange(1 << len(positions), dtype=np.uint64)
                guard = row[scatter_bits(local, positions).astype(np.int64)] == target
                full = (1 << len(positions)) - 1
                for fixed, value in _disjoint_cubes(guard):
                    split = value | (full & ~fixed)  # positive literals and free fluents
                    split_bits = np.array([i for i in range(len(positions)) if split >> i & 1])
                    combos = np.arange(1 << len(split_bits), dtype=np.uint64)
                    low_local = scatter_bits(combos, split_bits)
                    n = combos.size
                    parts["src"].append(np.full(n, q))
                    parts["dst"].append(np.full(n, int(target)))
                    parts["tc"].append(np.full(n, _scatter_int(fixed, positions), np.uint64))
                    parts["tv"].append(np.full(n, _scatter_int(value, positions), np.uint64))
                    parts["lc"].append(np.full(n, supp, dtype=np.uint64))
                    parts["lv"].append(scatter_bits(low_local, positions))
                    parts["n_low"].append(popcount(low_local))
        arrays = {k: np.concatenate(v) for k, v in parts.items()}
        order = np.argsort(arrays["src"], kind="stable")
        arrays = {k: v[order] for k, v in arrays.items()}
        accepting = np.asarray(dfa.accepting, dtype=bool)
        reward = terminal_reward * accepting[arrays["dst"]] - low_confidence_cost * arrays["n_low"]
        offsets = np.searchsorted(arrays["src"], np.arange(dfa.n_states + 1))
        return cls(
            fluents=tuple(dfa.fluents),
            initial_state=dfa.initial_state,
            accepting=accepting,
            thresholds=thresholds,
            terminal_reward=float(terminal_reward),
            low_confidence_cost=float(low_confidence_cost),
            src=arrays["src"].astype(np.int64),
            dst=arrays["dst"].astype(np.int64),
            truth_care=arrays["tc"],
            truth_value=arrays["tv"],
            low_care=arrays["lc"],
            low_value=arrays["lv"],
            n_low=arrays["n_low"].astype(np.int64),
            reward=reward.astype(np.float64),
            edge_offsets=offsets.astype(np.int64),
        )

    @property
    def n_states(self) -> int:
        """Number of states (as in the original DFA)."""
        return int(self.accepting.shape[0])

    @property
    def n_fluents(self) -> int:
        """Size of the vocabulary."""
        return len(self.fluents)

    @property
    def n_edges(self) -> int:
        """Total number of augmented edges."""
        return int(self.src.shape[0])

    def out_degree(self, state: int) -> int:
        """Number of augmented edges leaving ``state``."""
        return int(self.edge_offsets[state + 1] - self.edge_offsets[state])

    def expanded_letters(self, probs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(truth, low)`` uint64 ``[n_envs]`` masks: each environment's expanded letter."""
        probs = check_probs(probs, n_fluents=self.n_fluents, fluents=self.fluents)
        truth = probs >= self.thresholds.truth
        low = truth & (probs <= self.thresholds.high)
        weights = np.left_shift(1, np.arange(self.n_fluents, dtype=np.int64))
        return (
            (truth.astype(np.int64) @ weights).view(np.uint64),
            (low.astype(np.int64) @ weights).view(np.uint64),
        )

    def step_batch(self, states: Sequence[int] | np.ndarray, probs: np.ndarray) -> AugmentedStep:
        """Steps each environment along the augmented edge its expanded letter satisfies.

        Args:
            states: int ``[n_envs]`` current states.
            probs: float ``[n_envs, n_fluents]`` fluent probabilities.

        Raises:
            ValueError: bad ``probs`` or a state out of range.
        """
        truth, low = self.expanded_letters(probs)
        states = np.asarray(states)
        if not np.issubdtype(states.dtype, np.integer) or states.shape != truth.shape:
            raise ValueError(f"states must be an int array of shape {truth.shape}")
        bad = (states < 0) | (states >= self.n_states)
        if bad.any():
            env = int(np.flatnonzero(bad)[0])
            raise ValueError(f"states[{env}] = {int(states[env])} is not in 0..{self.n_states - 1}")
        edge = np.empty(states.shape, dtype=np.int64)
        for q in np.unique(states):
            envs = np.flatnonzero(states == q)
            lo, hi = int(self.edge_offsets[q]), int(self.edge_offsets[q + 1])
            block = max(1, _BLOCK_CELLS // max(1, hi - lo))
            for start in range(0, envs.size, block):
                rows = envs[start : start + block]
                t, lw = truth[rows, None], low[rows, None]
                match = ((t & self.truth_care[lo:hi]) == self.truth_value[lo:hi]) & (
                    (lw & self.low_care[lo:hi]) == self.low_value[lo:hi]
                )
                counts = match.sum(axis=1)
                if np.any(counts != 1):  # pragma: no cover - would be a construction bug
                    raise RuntimeError(f"augmented DFA: {counts} edges match in state {q}")
                edge[rows] = lo + match.argmax(axis=1)
        return AugmentedStep(self.dst[edge], self.reward[edge], self.n_low[edge], edge)

    def edges(self, state: int | None = None) -> list[AugmentedEdge]:
        """The augmented edges (of one state, or all), for people to read."""
        lo, hi = (0, self.n_edges) if state is None else self.edge_offsets[state : state + 2]
        return [self._edge(i) for i in range(int(lo), int(hi))]

    def _edge(self, i: int) -> AugmentedEdge:
        literals = []
        tc, tv, lc, lv = (
            int(a[i]) for a in (self.truth_care, self.truth_value, self.low_care, self.low_value)
        )
        for bit, name in enumerate(self.fluents):
            if not lc >> bit & 1:
                continue
            is_low = lv >> bit & 1
            if tc >> bit & 1:
                literals.append(
                    (f"{name}_l" if is_low else f"{name}_h") if tv >> bit & 1 else f"!{name}"
                )
            else:
                literals.append(f"{name}_l" if is_low else f"!{name}_l")
        return AugmentedEdge(
            int(self.src[i]),
            int(self.dst[i]),
            " & ".join(literals) or "true",
            int(self.n_low[i]),
            float(self.reward[i]),
        )


def _scatter_int(value: int, positions: np.ndarray) -> int:
    """Moves bit ``i`` of ``value`` to bit ``positions[i]``."""
    return sum(1 << int(p) for i, p in enumerate(positions) if value >> i & 1)
