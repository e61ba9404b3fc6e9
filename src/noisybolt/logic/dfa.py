"""The immutable DFA that every other layer steps.

A :class:`DFA` reads letters that are truth assignments over an ordered fluent vocabulary.
An assignment is packed into an integer bitmask: bit ``i`` is ``fluents[i]``. One step is
an array lookup, ``next_state[q, mask]``, and ``support[q, mask]`` is the bitmask of the
fluents that the guard of the edge taken from ``q`` *depends on* (its boolean support, not
how a backend happened to print it). Algorithm 1 of the paper charges for exactly those.

Dense tables have ``n_states * 2**n_fluents`` cells. Backends build DFAs whose vocabulary
is too large for that (see :data:`DENSE_TABLE_LIMIT`) in a compact form instead; every
public method works on both.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from noisybolt.errors import UnknownFluentError

__all__ = [
    "DENSE_TABLE_LIMIT",
    "DFA",
    "MAX_FLUENTS",
    "Edge",
    "assignment_to_mask",
    "masks_from_bool_matrix",
    "support_from_table",
]

#: Largest vocabulary a DFA accepts: assignments are packed into unsigned 64-bit masks.
MAX_FLUENTS = 63
#: Largest dense transition table (cells) built eagerly.
DENSE_TABLE_LIMIT = 1 << 22


class Edge(NamedTuple):
    """One edge of a DFA, as shown to people.

    Attributes:
        src: source state.
        dst: destination state.
        guard: the guard as a readable boolean formula over fluent names.
        support: the fluents the guard depends on, in vocabulary order.
    """

    src: int
    dst: int
    guard: str
    support: tuple[str, ...]


def assignment_to_mask(assignment: Mapping[str, bool], fluents: Sequence[str]) -> int:
    """Packs a truth assignment into a bitmask over ``fluents``.

    Fluents missing from ``assignment`` are false.

    Raises:
        UnknownFluentError: ``assignment`` names a fluent outside ``fluents``.

    Example:
        >>> assignment_to_mask({"a": True, "c": True}, ["a", "b", "c"])
        5
    """
    index = {name: i for i, name in enumerate(fluents)}
    unknown = tuple(sorted(set(assignment) - set(index)))
    if unknown:
        raise UnknownFluentError(
            f"unknown fluent(s) {list(unknown)} in assignment; the vocabulary is {list(fluents)}",
            unknown=unknown,
            known=tuple(fluents),
        )
    mask = 0
    for name, value in assignment.items():
        if value:
            mask |= 1 << index[name]
    return mask


def masks_from_bool_matrix(truth: np.ndarray) -> np.ndarray:
    """Packs a boolean matrix ``[n, n_fluents]`` into uint64 masks ``[n]`` (bit i = column i).

    Example:
        >>> masks_from_bool_matrix(np.array([[True, False, True], [False, True, False]]))
        array([5, 2], dtype=uint64)
    """
    truth = np.asarray(truth, dtype=bool)
    if truth.ndim != 2:
        raise ValueError(f"expected a [n, n_fluents] boolean matrix, got shape {truth.shape}")
    weights = np.left_shift(np.uint64(1), np.arange(truth.shape[1], dtype=np.uint64))
    return (truth.astype(np.uint64) * weights).sum(axis=1, dtype=np.uint64)


def support_from_table(next_state: np.ndarray) -> np.ndarray:
    """Computes the guard support of every cell of a dense transition table.

    For a cell ``(q, a)`` with ``t = next_state[q, a]``, fluent ``v`` is in the support iff
    the guard ``{b : next_state[q, b] == t}`` changes when bit ``v`` of ``b`` is flipped.

    Args:
        next_state: int array ``[n_states, 2**n_fluents]``.

    Returns:
        uint64 array of the same shape.
    """
    n_states, n_letters = next_state.shape
    n_fluents = int(n_letters).bit_length() - 1
    if 1 << n_fluents != n_letters:
        raise ValueError(f"table width {n_letters} is not a power of two")
    letters = np.arange(n_letters)
    support = np.zeros(next_state.shape, dtype=np.uint64)
    for q in range(n_states):
        row = next_state[q]
        for t in np.unique(row):
            guard = row == t
            mask = np.uint64(0)
            for v in range(n_fluents):
                if np.any(guard != guard[letters ^ (1 << v)]):
                    mask |= np.uint64(1 << v)
            support[q, guard] = mask
    return support


@dataclass(frozen=True, eq=False)
class DFA:
    """A complete deterministic finite automaton over truth assignments of ``fluents``.

    Build one with :func:`noisybolt.logic.compile_ltlf` or, for tests and hand-made
    automata, :meth:`DFA.from_table` / :meth:`DFA.from_function`.

    Attributes:
        fluents: ordered vocabulary; bit ``i`` of an assignment mask is ``fluents[i]``.
        initial_state: the state before any letter (the empty trace).
        accepting: bool ``[n_states]``.
        next_state: int64 ``[n_states, 2**n_fluents]``.
        support: uint64 ``[n_states, 2**n_fluents]``, the support mask of each cell's guard.
        formula: the formula the DFA was compiled from ("" for hand-made automata).

    Example:
        >>> dfa = DFA.from_function(["a"], n_states=2, initial_state=0,
        ...                         accepting=[False, True],
        ...                         delta=lambda q, mask: 1 if q == 1 or mask & 1 else 0)
        >>> dfa.accepts([{"a": False}, {"a": True}])
        True
        >>> dfa.step(0, {"a": False})
        0
    """

    fluents: tuple[str, ...]
    initial_state: int
    accepting: np.ndarray
    next_state: np.ndarray
    support: np.ndarray
    formula: str = ""
    _index: dict[str, int] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        fluents = tuple(self.fluents)
        if len(fluents) > MAX_FLUENTS:
            raise ValueError(f"at most {MAX_FLUENTS} fluents are supported, got {len(fluents)}")
        if len(set(fluents)) != len(fluents):
            raise ValueError(f"duplicate fluent names in {list(fluents)}")
        accepting = np.asarray(self.accepting, dtype=bool)
        next_state = np.asarray(self.next_state, dtype=np.int64)
        support = np.asarray(self.support, dtype=np.uint64)
        n_states = accepting.shape[0]
        if next_state.shape != (n_states, 1 << len(fluents)):
            raise ValueError(
                f"next_state has shape {next_state.shape}, expected {(n_states, 1 << len(fluents))}"
            )
        if support.shape != next_state.shape:
            raise ValueError(f"support has shape {support.shape}, expected {next_state.shape}")
        if next_state.size and (next_state.min() < 0 or next_state.max() >= n_states):
            raise ValueError("next_state refers to a state that does not exist")
        if not 0 <= self.initial_state < n_states:
            raise ValueError(f"initial_state {self.initial_state} is not in 0..{n_states - 1}")
        for name, array in (("accepting", accepting), ("next_state", next_state), ("support", support)):
            array.setflags(write=False)
            object.__setattr__(self, name, array)
        object.__setattr__(self, "fluents", fluents)
        object.__setattr__(self, "initial_state", int(self.initial_state))
        object.__setattr__(self, "_index", {name: i for i, name in enumerate(fluents)})

    # ----------------------------------------------------------------- construction
    @classmethod
    def from_table(
        cls,
        fluents: Sequence[str],
        *,
        initial_state: int,
        accepting: Sequence[bool] | np.ndarray,
        next_state: np.ndarray,
        formula: str = "",
    ) -> DFA:
        """Builds a DFA from a dense table ``[n_states, 2**n_fluents]``, computing supports."""
        next_state = np.asarray(next_state, dtype=np.int64)
        return cls(
            fluents=tuple(fluents),
            initial_state=initial_state,
            accepting=np.asarray(accepting, dtype=bool),
            next_state=next_state,
            support=support_from_table(next_state),
            formula=formula,
        )

    @classmethod
    def from_function(
        cls,
        fluents: Sequence[str],
        *,
        n_states: int,
        initial_state: int,
        accepting: Sequence[bool] | np.ndarray,
        delta: Callable[[int, int], int],
        formula: str = "",
    ) -> DFA:
        """Builds a DFA from a transition function ``delta(state, assignment_mask)``."""
        n_letters = 1 << len(fluents)
        table = np.array(
            [[delta(q, a) for a in range(n_letters)] for q in range(n_states)], dtype=np.int64
        )
        return cls.from_table(
            fluents,
            initial_state=initial_state,
            accepting=accepting,
            next_state=table,
            formula=formula,
        )

    # ----------------------------------------------------------------- properties
    @property
    def n_states(self) -> int:
        """Number of states."""
        return int(self.accepting.shape[0])

    @property
    def n_fluents(self) -> int:
        """Size of the vocabulary."""
        return len(self.fluents)

    @property
    def accepting_sinks(self) -> np.ndarray:
        """bool ``[n_states]``: accepting states no letter leaves (satisfied for good)."""
        return self._sinks() & self.accepting

    @property
    def rejecting_sinks(self) -> np.ndarray:
        """bool ``[n_states]``: non-accepting states no letter leaves (violated for good)."""
        return self._sinks() & ~self.accepting

    def _sinks(self) -> np.ndarray:
        return np.all(self.next_state == np.arange(self.n_states)[:, None], axis=1)

    # ----------------------------------------------------------------- stepping
    def mask(self, assignment: Mapping[str, bool]) -> int:
        """Packs ``assignment`` into this DFA's bitmask (missing fluents are false)."""
        return assignment_to_mask(assignment, self.fluents)

    def step(self, q: int, assignment: Mapping[str, bool]) -> int:
        """Returns the state reached from ``q`` on one letter."""
        if not 0 <= q < self.n_states:
            raise ValueError(f"state {q} is not in 0..{self.n_states - 1}")
        return int(self.next_state[q, self.mask(assignment)])

    def step_batch(self, states: np.ndarray, masks: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Steps many (state, letter) pairs at once.

        Args:
            states: int ``[n]`` current states.
            masks: uint64 ``[n]`` assignment bitmasks over :attr:`fluents`.

        Returns:
            ``(next_states [n] int64, support [n] uint64)``: the successor and the support
            mask of the guard of the edge taken.
        """
        states = np.asarray(states, dtype=np.int64)
        letters = np.asarray(masks).astype(np.int64)
        return self.next_state[states, letters], self.support[states, letters]

    def run(self, trace: Iterable[Mapping[str, bool]], *, start: int | None = None) -> int:
        """Returns the state reached after reading ``trace`` from ``start`` (default initial)."""
        q = self.initial_state if start is None else start
        for letter in trace:
            q = self.step(q, letter)
        return q

    def accepts(self, trace: Iterable[Mapping[str, bool]]) -> bool:
        """Whether the DFA accepts the finite ``trace`` (a sequence of assignments)."""
        return bool(self.accepting[self.run(trace)])

    # ----------------------------------------------------------------- display
    def edges(self) -> list[Edge]:
        """The edges ``(src, dst)`` with their guards, for people to read."""
        result = []
        for q in range(self.n_states):
            row = self.next_state[q]
            for t in np.unique(row):
                letters = np.flatnonzero(row == t)
                supp = int(self.support[q, letters[0]])
                names = tuple(f for i, f in enumerate(self.fluents) if supp >> i & 1)
                result.append(Edge(q, int(t), self._guard_text(letters, supp), names))
        return result

    def _guard_text(self, letters: np.ndarray, supp: int) -> str:
        """A sum of products over the support fluents (one product per distinct minterm)."""
        positions = [i for i in range(self.n_fluents) if supp >> i & 1]
        if not positions:
            return "true"
        minterms = sorted({tuple(int(a) >> i & 1 for i in positions) for a in letters})
        products = []
        for minterm in minterms:
            literals = [
                self.fluents[i] if bit else f"!{self.fluents[i]}"
                for i, bit in zip(positions, minterm, strict=True)
            ]
            products.append(" & ".join(literals))
        if len(products) == 1:
            return products[0]
        return " | ".join(f"({p})" if len(positions) > 1 else p for p in products)

    def describe(self) -> str:
        """A multi-line description: states, initial, accepting, sinks and edges."""
        lines = [
            f"DFA for {self.formula or '<hand-made>'} over {list(self.fluents)}",
            f"  states: {self.n_states}, initial: {self.initial_state}, "
            f"accepting: {np.flatnonzero(self.accepting).tolist()}",
            f"  accepting sinks: {np.flatnonzero(self.accepting_sinks).tolist()}, "
            f"rejecting sinks: {np.flatnonzero(self.rejecting_sinks).tolist()}",
        ]
        for edge in self.edges():
            lines.append(f"  {edge.src} -> {edge.dst}  [{edge.guard}]  support={list(edge.support)}")
        return "\n".join(lines)
