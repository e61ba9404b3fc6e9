"""The immutable DFA that every other layer steps.

A :class:`DFA` reads letters that are truth assignments over an ordered fluent vocabulary.
An assignment is packed into an integer bitmask: bit ``i`` is ``fluents[i]``. One step is
an array lookup, ``next_state[q, mask]``, and ``support[q, mask]`` is the bitmask of the
fluents that the guard of the edge taken from ``q`` *depends on* (its boolean support, not
how a backend happened to print it). Algorithm 1 of the paper charges for exactly those.

Every DFA holds its transitions as a :class:`GuardDiagram` (a shared multi-terminal BDD,
the form MONA prints). Dense tables have ``n_states * 2**n_fluents`` cells; they are built
only while that is at most :data:`DENSE_TABLE_LIMIT`. Beyond it the DFA is *compact*
(:attr:`DFA.is_compact`): :attr:`DFA.next_state` and :attr:`DFA.support` raise
:class:`~noisybolt.errors.DenseTableError`, and :meth:`DFA.step_batch` uses a dense table
over just the fluents the diagram tests when that fits, else walks the diagram with
exact supports computed per edge on first use. Every other method works on both forms.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from typing import Any, NamedTuple

import numpy as np

from noisybolt.errors import DenseTableError, UnknownFluentError
from noisybolt.logic import _diagram
from noisybolt.logic._diagram import GuardDiagram

__all__ = [
    "DENSE_TABLE_LIMIT",
    "DFA",
    "MAX_FLUENTS",
    "Edge",
    "GuardDiagram",
    "assignment_to_mask",
    "masks_from_bool_matrix",
    "support_from_table",
]

#: Largest vocabulary a DFA accepts: assignments are packed into unsigned 64-bit masks.
MAX_FLUENTS = 63
#: Largest dense transition table (cells) built eagerly.
DENSE_TABLE_LIMIT = 1 << 22

support_from_table = _diagram.support_from_table


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


def _read_only(array: np.ndarray) -> np.ndarray:
    array.setflags(write=False)
    return array


class _Dense(NamedTuple):
    """Dense tables over the letters ``gather(mask)`` (``gather`` None: the mask itself)."""

    next_state: np.ndarray
    support: np.ndarray
    gather: Callable[[np.ndarray], np.ndarray] | None


class DFA:
    """A complete deterministic finite automaton over truth assignments of ``fluents``.

    Build one with :func:`noisybolt.logic.compile_ltlf` or, for tests and hand-made
    automata, :meth:`DFA.from_table` / :meth:`DFA.from_function` /
    :meth:`DFA.from_diagram`. Instances are immutable (their arrays are read-only).

    Attributes:
        fluents: ordered vocabulary; bit ``i`` of an assignment mask is ``fluents[i]``.
        initial_state: the state before any letter (the empty trace).
        accepting: bool ``[n_states]``.
        diagram: the transitions as a :class:`GuardDiagram`.
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

    def __init__(
        self,
        *,
        fluents: Sequence[str],
        initial_state: int,
        accepting: Sequence[bool] | np.ndarray,
        diagram: GuardDiagram,
        formula: str = "",
        next_state: np.ndarray | None = None,
    ) -> None:
        """Checks and freezes the parts; prefer the ``from_*`` constructors.

        Args:
            fluents: ordered vocabulary.
            initial_state: state of the empty trace.
            accepting: bool ``[n_states]``.
            diagram: reduced ordered diagram of the transitions (see :mod:`._diagram`).
            formula: source formula, for display.
            next_state: the dense table when the caller already has it (it must agree
                with ``diagram``).

        Raises:
            ValueError: the parts are inconsistent.
        """
        if isinstance(fluents, str):
            raise TypeError("fluents must be a sequence of names, not one string")
        self.fluents: tuple[str, ...] = tuple(fluents)
        if len(self.fluents) > MAX_FLUENTS:
            raise ValueError(f"at most {MAX_FLUENTS} fluents are supported, got {len(fluents)}")
        if len(set(self.fluents)) != len(self.fluents):
            raise ValueError(f"duplicate fluent names in {list(self.fluents)}")
        self.accepting = _read_only(np.array(accepting, dtype=bool).reshape(-1))
        self.diagram = GuardDiagram(
            *(_read_only(np.array(a, dtype=np.int64).reshape(-1)) for a in diagram)
        )
        if self.diagram.n_states != self.n_states:
            raise ValueError(
                f"the diagram has {self.diagram.n_states} states, accepting has {self.n_states}"
            )
        _diagram.validate(self.diagram, self.n_fluents)
        if not 0 <= int(initial_state) < self.n_states:
            raise ValueError(f"initial_state {initial_state} is not in 0..{self.n_states - 1}")
        self.initial_state = int(initial_state)
        self.formula = str(formula)
        self._index = {name: i for i, name in enumerate(self.fluents)}
        self._tested = sorted(set(self.diagram.var[self.n_states :].tolist()))
        self._depth = _diagram.max_depth(self.diagram)
        self._inspector: _diagram.EdgeInspector | None = None
        self._full: _Dense | None = None
        self._projected: _Dense | None = None
        if next_state is not None:
            table = _read_only(np.array(next_state, dtype=np.int64))
            if table.shape != (self.n_states, 1 << self.n_fluents):
                raise ValueError(
                    f"next_state has shape {table.shape}, "
                    f"expected {(self.n_states, 1 << self.n_fluents)}"
                )
            self._full = _Dense(table, _read_only(support_from_table(table)), None)
        elif self.n_states << self.n_fluents <= DENSE_TABLE_LIMIT:
            bits = {v: v for v in range(self.n_fluents)}
            table = _diagram.dense_table(self.diagram, bits, self.n_fluents)
            self._full = _Dense(_read_only(table), _read_only(support_from_table(table)), None)
        elif self.n_states << len(self._tested) <= DENSE_TABLE_LIMIT:
            bits = {v: j for j, v in enumerate(self._tested)}
            table = _diagram.dense_table(self.diagram, bits, len(bits))
            support = self._unproject(support_from_table(table))
            gather = _diagram.letter_lookup(self._tested)
            self._projected = _Dense(_read_only(table), _read_only(support), gather)
        self._frozen = True

    def __setattr__(self, name: str, value: Any) -> None:
        # Public attributes are fixed once built; private ones are lazily filled caches.
        if not name.startswith("_") and getattr(self, "_frozen", False):
            raise AttributeError(f"DFA is immutable: cannot set {name!r}")
        object.__setattr__(self, name, value)

    def __delattr__(self, name: str) -> None:
        raise AttributeError(f"DFA is immutable: cannot delete {name!r}")

    def _unproject(self, support: np.ndarray) -> np.ndarray:
        """Maps supports over projected bits back to vocabulary bits."""
        out = np.zeros_like(support)
        for j, v in enumerate(self._tested):
            out |= ((support >> np.uint64(j)) & np.uint64(1)) << np.uint64(v)
        return out

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
        """Builds a DFA from a dense table ``[n_states, 2**n_fluents]``, computing supports.

        The states keep their numbers (no minimisation).
        """
        table = np.asarray(next_state, dtype=np.int64)
        n_states = np.asarray(accepting).reshape(-1).shape[0]
        if table.ndim != 2 or table.shape != (n_states, 1 << len(fluents)):
            raise ValueError(
                f"next_state has shape {table.shape}, expected {(n_states, 1 << len(fluents))}"
            )
        if table.size and (table.min() < 0 or table.max() >= n_states):
            raise ValueError("next_state refers to a state that does not exist")
        return cls(
            fluents=fluents,
            initial_state=initial_state,
            accepting=accepting,
            diagram=_diagram.from_table(table),
            formula=formula,
            next_state=table,
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
        ).reshape(n_states, n_letters)
        return cls.from_table(
            fluents,
            initial_state=initial_state,
            accepting=accepting,
            next_state=table,
            formula=formula,
        )

    @classmethod
    def from_diagram(
        cls,
        fluents: Sequence[str],
        *,
        initial_state: int,
        accepting: Sequence[bool] | np.ndarray,
        diagram: GuardDiagram,
        formula: str = "",
        minimise: bool = False,
    ) -> DFA:
        """Builds a DFA from a guard diagram (the form backends produce).

        Args:
            fluents: ordered vocabulary; the diagram's ``var`` indexes it.
            initial_state: state of the empty trace.
            accepting: bool ``[n_states]``.
            diagram: ordered diagram (reduced unless ``minimise``).
            formula: source formula, for display.
            minimise: minimise, drop unreachable states and number the states
                canonically (breadth-first from the initial state, successors by
                first letter leading there, reading letters as bit strings in the diagram's
                variable order), so equal languages give equal arrays.
        """
        if minimise:
            diagram, accepting, initial_state = _diagram.canonicalise(
                GuardDiagram(*(np.asarray(a, dtype=np.int64) for a in diagram)),
                np.asarray(accepting, dtype=bool),
                int(initial_state),
            )
        return cls(
            fluents=fluents,
            initial_state=initial_state,
            accepting=accepting,
            diagram=diagram,
            formula=formula,
        )

    def __reduce__(self) -> tuple[Any, ...]:
        # Lazily built caches are dropped; the dense table travels only if it was given.
        table = self._full.next_state if self._full is not None else None
        if table is not None and self.n_states << self.n_fluents <= DENSE_TABLE_LIMIT:
            table = None
        return (
            _restore,
            (self.fluents, self.initial_state, self.accepting, self.diagram, self.formula, table),
        )

    def __repr__(self) -> str:
        form = "compact" if self.is_compact else "dense"
        return (
            f"DFA(formula={self.formula!r}, fluents={list(self.fluents)}, "
            f"n_states={self.n_states}, {form})"
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
    def is_compact(self) -> bool:
        """Whether the dense tables are too large to hold (see :data:`DENSE_TABLE_LIMIT`)."""
        return self._full is None

    @property
    def relevant_fluents(self) -> tuple[str, ...]:
        """The fluents some transition depends on, in vocabulary order."""
        return tuple(self.fluents[v] for v in self._tested)

    @property
    def next_state(self) -> np.ndarray:
        """int64 ``[n_states, 2**n_fluents]``: successor of each (state, assignment mask).

        Raises:
            DenseTableError: the DFA is compact.
        """
        return self._dense().next_state

    @property
    def support(self) -> np.ndarray:
        """uint64 ``[n_states, 2**n_fluents]``: support mask of each cell's guard.

        Raises:
            DenseTableError: the DFA is compact.
        """
        return self._dense().support

    def _dense(self) -> _Dense:
        if self._full is None:
            raise DenseTableError(
                f"this DFA has {self.n_states} states over {self.n_fluents} fluents: a dense "
                f"table would have {self.n_states << self.n_fluents} cells, over "
                f"DENSE_TABLE_LIMIT={DENSE_TABLE_LIMIT}, so it is held compactly. Use step, "
                "step_batch, accepts, edges or the diagram instead of next_state/support."
            )
        return self._full

    @property
    def accepting_sinks(self) -> np.ndarray:
        """bool ``[n_states]``: accepting states no letter leaves (satisfied for good)."""
        return self._sinks() & self.accepting

    @property
    def rejecting_sinks(self) -> np.ndarray:
        """bool ``[n_states]``: non-accepting states no letter leaves (violated for good)."""
        return self._sinks() & ~self.accepting

    def _sinks(self) -> np.ndarray:
        # The diagram is reduced: a constant transition function is a bare leaf.
        return self.diagram.root == np.arange(self.n_states)

    # ----------------------------------------------------------------- stepping
    def mask(self, assignment: Mapping[str, bool]) -> int:
        """Packs ``assignment`` into this DFA's bitmask (missing fluents are false)."""
        return assignment_to_mask(assignment, self.fluents)

    def step(self, q: int, assignment: Mapping[str, bool]) -> int:
        """Returns the state reached from ``q`` on one letter."""
        if not 0 <= q < self.n_states:
            raise ValueError(f"state {q} is not in 0..{self.n_states - 1}")
        return self._successor(q, self.mask(assignment))

    def _successor(self, q: int, mask: int) -> int:
        if self._full is not None:
            return int(self._full.next_state[q, mask])
        var, lo, hi, root = self.diagram.var, self.diagram.lo, self.diagram.hi, self.diagram.root
        node = int(root[q])
        while node >= self.n_states:
            node = int(hi[node] if mask >> int(var[node]) & 1 else lo[node])
        return node

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
        if self._full is not None:
            letters = np.asarray(masks).astype(np.int64)
            return self._full.next_state[states, letters], self._full.support[states, letters]
        masks = np.asarray(masks).astype(np.uint64)
        if self._projected is not None:
            assert self._projected.gather is not None
            letters = self._projected.gather(masks)
            dense = self._projected
            return dense.next_state[states, letters], dense.support[states, letters]
        return self._walk(states, masks)

    def _walk(self, states: np.ndarray, masks: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        var, lo, hi, root = self.diagram.var, self.diagram.lo, self.diagram.hi, self.diagram.root
        node = root[states]
        for _ in range(self._depth):
            bit = (masks >> np.maximum(var[node], 0).astype(np.uint64)) & np.uint64(1)
            node = np.where(bit.astype(bool), hi[node], lo[node])
        edges = states * np.int64(self.n_states) + node
        unique, inverse = np.unique(edges, return_inverse=True)
        inspector = self._edge_inspector()
        support = np.array(
            [inspector.support(int(e) // self.n_states, int(e) % self.n_states) for e in unique],
            dtype=np.uint64,
        )
        return node, support[inverse.reshape(-1)]

    def _edge_inspector(self) -> _diagram.EdgeInspector:
        if self._inspector is None:
            self._inspector = _diagram.EdgeInspector(self.diagram)
        return self._inspector

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
    def iter_edges(self, states: Iterable[int] | None = None) -> Iterator[Edge]:
        """Yields the edges ``(src, dst)`` with exact guards, state by state.

        Successors of a state come in canonical order (see :meth:`from_diagram`). A compact DFA
        may have very many edges: iterate and stop, or pass ``states``.
        """
        inspector = self._edge_inspector()
        for q in range(self.n_states) if states is None else states:
            for t in inspector.targets(int(q)):
                supp = inspector.support(int(q), t)
                names = tuple(f for i, f in enumerate(self.fluents) if supp >> i & 1)
                yield Edge(int(q), t, self._guard_text(inspector.cubes(int(q), t)), names)

    def edges(self) -> list[Edge]:
        """All edges ``(src, dst)`` with their guards, for people to read."""
        return list(self.iter_edges())

    def _guard_text(self, cubes: list[dict[int, bool]]) -> str:
        """A disjoint sum of products, literals in vocabulary order."""
        if cubes == [{}]:
            return "true"
        if not cubes:
            return "false"
        products = [
            " & ".join(self.fluents[v] if cube[v] else f"!{self.fluents[v]}" for v in sorted(cube))
            for cube in cubes
        ]
        if len(products) == 1:
            return products[0]
        return " | ".join(f"({p})" if " & " in p else p for p in products)

    def describe(self, max_edges: int = 200) -> str:
        """A multi-line description: states, initial, accepting, sinks and edges.

        Args:
            max_edges: print at most this many edges, then say how many were left out.
        """
        accepting = np.flatnonzero(self.accepting).tolist()
        lines = [
            f"DFA for {self.formula or '<hand-made>'} over {list(self.fluents)}"
            + (" (compact)" if self.is_compact else ""),
            f"  states: {self.n_states}, initial: {self.initial_state}, "
            f"accepting: {_abbreviate(accepting)}",
            f"  accepting sinks: {_abbreviate(np.flatnonzero(self.accepting_sinks).tolist())}, "
            f"rejecting sinks: {_abbreviate(np.flatnonzero(self.rejecting_sinks).tolist())}",
        ]
        for shown, edge in enumerate(self.iter_edges()):
            if shown == max_edges:
                lines.append(f"  ... further edges left out (shown {max_edges})")
                break
            guard = edge.guard
            if len(guard) > 160:  # a disjoint cover can have very many products
                guard = f"{guard[:150]} ... ({guard.count(' | ') + 1} products)"
            lines.append(f"  {edge.src} -> {edge.dst}  [{guard}]  support={list(edge.support)}")
        return "\n".join(lines)


def _abbreviate(items: list[int], limit: int = 20) -> str:
    if len(items) <= limit:
        return str(items)
    return f"[{', '.join(map(str, items[:limit]))}, ... ({len(items)} in all)]"


def _restore(
    fluents: tuple[str, ...],
    initial_state: int,
    accepting: np.ndarray,
    diagram: GuardDiagram,
    formula: str,
    next_state: np.ndarray | None,
) -> DFA:
    return DFA(
        fluents=fluents,
        initial_state=initial_state,
        accepting=accepting,
        diagram=GuardDiagram(*diagram),
        formula=formula,
        next_state=next_state,
    )
