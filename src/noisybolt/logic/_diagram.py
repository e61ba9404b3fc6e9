"""Shared multi-terminal BDDs ("guard diagrams") holding a DFA's transition function.

A :class:`GuardDiagram` is the compact form of a DFA's transitions: for each state a root
node of one shared, reduced, ordered decision diagram whose inner nodes test one fluent
and whose leaves are successor states. It is what MONA prints with ``-xw`` and what the
BDD backend builds, and it stays small when the dense table ``n_states * 2**n_fluents``
does not.

Conventions (checked by :func:`validate`):

* node ``s < n_states`` is the leaf of state ``s`` (``var = -1``, ``lo = hi = s``);
* inner nodes test ``var`` (a fluent index) and go to ``lo`` when it is false, ``hi``
  when true;
* the diagram is ordered: ``rank`` is a permutation of the fluents, and along every path
  the rank of the tested fluent strictly *decreases* (highest rank nearest the roots).
  Compilers use the formula's order of first occurrence (MONA's default, which keeps
  related fluents together; a bad order can blow a diagram up a hundredfold); tables use
  the vocabulary order. A depth-first walk taking ``lo`` first meets the letters in
  lexicographic order of their bits by decreasing rank, so for a given order the state
  numbering of :func:`canonicalise` is the same for every backend;
* the diagram is reduced: no inner node has ``lo == hi``, so a state whose transitions
  all go to one state has that state's leaf as root.

Everything here is vectorised over nodes with numpy, level by level (by ascending
rank, which is a topological order: children have smaller ranks than parents).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import numpy as np

__all__ = ["GuardDiagram"]


class GuardDiagram(NamedTuple):
    """Node arrays of a shared multi-terminal BDD (see the module docstring).

    Attributes:
        var: int64 ``[n_nodes]``, fluent tested by each node; -1 at leaves.
        lo: int64 ``[n_nodes]``, child when the fluent is false (the state at a leaf).
        hi: int64 ``[n_nodes]``, child when the fluent is true (the state at a leaf).
        root: int64 ``[n_states]``, the node of each state's transition function.
        rank: int64 ``[n_fluents]``, position of each fluent in the variable order
            (larger = nearer the roots).
    """

    var: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    root: np.ndarray
    rank: np.ndarray

    @property
    def n_states(self) -> int:
        """Number of states (= number of leaves)."""
        return int(self.root.shape[0])

    @property
    def n_nodes(self) -> int:
        """Number of nodes, leaves included."""
        return int(self.var.shape[0])

    def node_rank(self) -> np.ndarray:
        """int64 ``[n_nodes]``: rank of each node's fluent (-1 at leaves)."""
        if self.rank.size == 0:
            return np.full(self.var.shape, -1, dtype=np.int64)
        return np.where(self.var >= 0, self.rank[np.maximum(self.var, 0)], -1)

    def levels(self, *, top_down: bool = False) -> list[np.ndarray]:
        """Inner nodes grouped by rank, bottom-up (children first) unless ``top_down``."""
        inner = np.arange(self.n_states, self.n_nodes)
        ranks = self.node_rank()[inner]
        order = np.argsort(ranks, kind="stable")
        inner, ranks = inner[order], ranks[order]
        cuts = np.flatnonzero(np.diff(ranks)) + 1
        groups = np.split(inner, cuts) if inner.size else []
        return groups[::-1] if top_down else groups


def order_rank(top_down: list[int], n_fluents: int) -> np.ndarray:
    """Ranks for a variable order listing fluents from the roots down.

    Fluents not listed (never tested) take the lowest ranks, in vocabulary order.
    """
    rest = sorted(set(range(n_fluents)) - set(top_down), reverse=True)
    rank = np.empty(n_fluents, dtype=np.int64)
    rank[list(top_down) + rest] = np.arange(n_fluents - 1, -1, -1)
    return rank


def leaves_only(n_states: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Node arrays holding just the leaves ``0 .. n_states - 1``."""
    ids = np.arange(n_states, dtype=np.int64)
    return np.full(n_states, -1, dtype=np.int64), ids.copy(), ids.copy()


def validate(diagram: GuardDiagram, n_fluents: int) -> None:
    """Checks the conventions of the module docstring.

    Raises:
        ValueError: naming the first convention broken.
    """
    var, lo, hi, root, rank = (np.asarray(a) for a in diagram)
    n_states = root.shape[0]
    if rank.shape != (n_fluents,) or not np.array_equal(np.sort(rank), np.arange(n_fluents)):
        raise ValueError("rank must be a permutation of the fluent indices")
    n_nodes = var.shape[0]
    if not all(a.ndim == 1 for a in (var, lo, hi, root, rank)):
        raise ValueError("guard diagram arrays must be one-dimensional")
    if lo.shape[0] != n_nodes or hi.shape[0] != n_nodes or n_nodes < n_states:
        raise ValueError("guard diagram arrays have inconsistent lengths")
    states = np.arange(n_states)
    if not (
        np.all(var[:n_states] == -1)
        and np.all(lo[:n_states] == states)
        and np.all(hi[:n_states] == states)
    ):
        raise ValueError("nodes 0..n_states-1 must be the leaves of states 0..n_states-1")
    if root.size and (root.min() < 0 or root.max() >= n_nodes):
        raise ValueError("a state's root is not a node of the diagram")
    inner = slice(n_states, n_nodes)
    v, low, high = var[inner], lo[inner], hi[inner]
    if v.size == 0:
        return
    if v.min() < 0 or v.max() >= n_fluents:
        raise ValueError(f"a node tests a fluent outside 0..{n_fluents - 1}")
    if min(low.min(), high.min()) < 0 or max(low.max(), high.max()) >= n_nodes:
        raise ValueError("a node's child is not a node of the diagram")
    if np.any(low == high):
        raise ValueError("the diagram is not reduced (a node has equal children)")
    node_rank = diagram.node_rank()
    if np.any(node_rank[low] >= node_rank[inner]) or np.any(node_rank[high] >= node_rank[inner]):
        raise ValueError("the diagram is not ordered (ranks must decrease downwards)")


def hash_cons(
    diagram: GuardDiagram, leaf_label: np.ndarray, n_labels: int, *, build: bool = True
) -> tuple[np.ndarray, tuple[np.ndarray, np.ndarray, np.ndarray] | None]:
    """Reduces a diagram whose leaves are relabelled, sharing equal sub-diagrams.

    Leaf ``s`` becomes leaf ``leaf_label[s]`` of a diagram with ``n_labels`` leaves. Two
    nodes get the same new id iff they denote the same function of the letter, so the
    ids alone answer "same transitions?" (used by minimisation).

    Args:
        diagram: an ordered diagram (it need not be reduced).
        leaf_label: int ``[n_states]`` new leaf of every old leaf, in ``0 .. n_labels-1``.
        n_labels: number of leaves of the result.
        build: also return the node arrays of the result.

    Returns:
        ``(new_id [n_nodes], (var, lo, hi) or None)``. The arrays may hold nodes that no
        root reaches; :func:`compact` drops them.
    """
    var, lo, hi = diagram.var, diagram.lo, diagram.hi
    n_states = diagram.n_states
    new_id = np.empty(var.shape[0], dtype=np.int64)
    new_id[:n_states] = leaf_label
    out_var, out_lo, out_hi = ([a] for a in leaves_only(n_labels))
    next_id = n_labels
    base = np.int64(var.shape[0] + n_labels + 1)
    for nodes in diagram.levels():
        low, high = new_id[lo[nodes]], new_id[hi[nodes]]
        same = low == high
        new_id[nodes[same]] = low[same]
        keep = ~same
        if not keep.any():
            continue
        keys, inverse = np.unique(low[keep] * base + high[keep], return_inverse=True)
        new_id[nodes[keep]] = next_id + inverse.reshape(-1)
        next_id += keys.size
        if build:
            out_var.append(np.full(keys.size, var[nodes[0]], dtype=np.int64))
            out_lo.append(keys // base)
            out_hi.append(keys % base)
    if not build:
        return new_id, None
    return new_id, (np.concatenate(out_var), np.concatenate(out_lo), np.concatenate(out_hi))


def compact(
    arrays: tuple[np.ndarray, np.ndarray, np.ndarray],
    root: np.ndarray,
    n_states: int,
    rank: np.ndarray,
) -> GuardDiagram:
    """Keeps the nodes reachable from ``root`` (plus all leaves), renumbered in order.

    Order-preserving renumbering keeps hash-consed ids canonical: nodes of one level are
    sorted by their (already canonical) children.
    """
    var, lo, hi = arrays
    n_nodes = var.shape[0]
    reached = np.zeros(n_nodes, dtype=bool)
    reached[:n_states] = True
    reached[root] = True
    whole = GuardDiagram(var, lo, hi, np.arange(n_states), rank)
    for level in whole.levels(top_down=True):  # parents before children
        nodes = level[reached[level]]
        reached[lo[nodes]] = True
        reached[hi[nodes]] = True
    renumber = np.cumsum(reached) - 1
    return GuardDiagram(
        var=var[reached].copy(),
        lo=renumber[lo[reached]],
        hi=renumber[hi[reached]],
        root=renumber[root],
        rank=rank,
    )


def moore_classes(diagram: GuardDiagram, accepting: np.ndarray) -> np.ndarray:
    """Myhill-Nerode classes of the states by Moore's partition refinement.

    Each round, a state's signature is its class and the hash-consed id of its transition
    function with leaves replaced by classes; a round costs one vectorised pass per
    fluent level, and there are at most ``n_states`` rounds (far fewer in practice).

    Returns:
        int64 ``[n_states]`` class of each state (equal iff language-equivalent).
    """
    classes = np.unique(np.asarray(accepting, dtype=np.int64), return_inverse=True)[1]
    classes = classes.reshape(-1)
    n_classes = int(classes.max()) + 1 if classes.size else 0
    while True:
        ids, _ = hash_cons(diagram, classes, n_classes, build=False)
        signature = classes * np.int64(ids.max() + 1) + ids[diagram.root]
        refined = np.unique(signature, return_inverse=True)[1].reshape(-1)
        n_refined = int(refined.max()) + 1
        if n_refined == n_classes:
            return refined
        classes, n_classes = refined, n_refined


def reachable(diagram: GuardDiagram, initial: int) -> np.ndarray:
    """bool ``[n_states]``: the states some trace leads to from ``initial``."""
    levels = diagram.levels(top_down=True)
    found = np.zeros(diagram.n_states, dtype=bool)
    found[initial] = True
    frontier = np.array([initial])
    while frontier.size:
        marked = np.zeros(diagram.n_nodes, dtype=bool)
        marked[diagram.root[frontier]] = True
        for level in levels:
            nodes = level[marked[level]]
            marked[diagram.lo[nodes]] = True
            marked[diagram.hi[nodes]] = True
        leaves = np.flatnonzero(marked[: diagram.n_states])
        frontier = leaves[~found[leaves]]
        found[frontier] = True
    return found


def bfs_order(diagram: GuardDiagram, initial: int, n_reachable: int) -> list[int]:
    """States reachable from ``initial`` in canonical breadth-first order.

    A state's successors are taken in the order in which a ``lo``-first depth-first walk
    of its diagram meets them (smallest letter first, in the diagram's variable order;
    see the module docstring). Stops walking once all ``n_reachable`` states are found.
    """
    lo, hi, root = (a.tolist() for a in (diagram.lo, diagram.hi, diagram.root))
    n_states = len(root)
    order = [initial]
    seen = {initial}
    head = 0
    while head < len(order) and len(order) < n_reachable:
        q = order[head]
        head += 1
        visited: set[int] = set()
        stack = [root[q]]
        while stack:
            node = stack.pop()
            if node < n_states:
                if node not in seen:
                    seen.add(node)
                    order.append(node)
                continue
            if node in visited:
                continue
            visited.add(node)
            stack.append(hi[node])
            stack.append(lo[node])
    return order


def canonicalise(
    diagram: GuardDiagram, accepting: np.ndarray, initial: int
) -> tuple[GuardDiagram, np.ndarray, int]:
    """The minimal DFA with canonical numbering.

    Minimises (Moore), drops unreachable states, numbers states breadth-first from the
    initial one (successors in the order of :func:`bfs_order`) and shares nodes canonically. Two
    backends that build the same language over the same vocabulary thus produce
    identical arrays.

    Returns:
        ``(diagram, accepting, initial_state)`` with ``initial_state == 0``.
    """
    accepting = np.asarray(accepting, dtype=bool)
    classes = moore_classes(diagram, accepting)
    n_classes = int(classes.max()) + 1
    ids, arrays = hash_cons(diagram, classes, n_classes)
    assert arrays is not None
    class_root = np.empty(n_classes, dtype=np.int64)
    class_root[classes] = ids[diagram.root]
    class_accepting = np.zeros(n_classes, dtype=bool)
    class_accepting[classes] = accepting
    quotient = compact(arrays, class_root, n_classes, diagram.rank)
    n_reachable = np.unique(classes[reachable(diagram, initial)]).size
    order = np.asarray(bfs_order(quotient, int(classes[initial]), n_reachable), dtype=np.int64)
    n_new = order.size
    number = np.zeros(n_classes, dtype=np.int64)  # unreachable classes: never reached
    number[order] = np.arange(n_new)
    relabelled = quotient._replace(root=np.arange(n_classes))
    ids, arrays = hash_cons(relabelled, number, n_new)
    assert arrays is not None
    final = compact(arrays, ids[quotient.root[order]], n_new, diagram.rank)
    return final, class_accepting[order], 0


def from_table(next_state: np.ndarray) -> GuardDiagram:
    """Builds the reduced diagram of a dense table ``[n_states, 2**n_fluents]``.

    Letters pair up bit by bit from bit 0 (the bottom of the order) upwards.
    """
    table = np.asarray(next_state, dtype=np.int64)
    n_states, n_letters = table.shape
    n_fluents = n_letters.bit_length() - 1
    var_arr, lo_arr, hi_arr = leaves_only(n_states)
    var_parts, lo_parts, hi_parts = [var_arr], [lo_arr], [hi_arr]
    next_id = n_states
    current = table  # node ids, [n_states, 2**(n_fluents - v)]
    for v in range(n_fluents):
        pairs = current.reshape(n_states, -1, 2)
        low, high = pairs[..., 0], pairs[..., 1]
        same = low == high
        merged = low.copy()
        if not same.all():
            base = np.int64(next_id + 1)
            keys, inverse = np.unique(low[~same] * base + high[~same], return_inverse=True)
            merged[~same] = next_id + inverse.reshape(-1)
            var_parts.append(np.full(keys.size, v, dtype=np.int64))
            lo_parts.append(keys // base)
            hi_parts.append(keys % base)
            next_id += keys.size
        current = merged
    return GuardDiagram(
        var=np.concatenate(var_parts),
        lo=np.concatenate(lo_parts),
        hi=np.concatenate(hi_parts),
        root=current.reshape(n_states),
        rank=np.arange(n_fluents, dtype=np.int64),
    )


def dense_table(diagram: GuardDiagram, letter_bit: dict[int, int], n_bits: int) -> np.ndarray:
    """The successor of every (state, letter) over the letters of ``letter_bit``.

    Splits all roots on one fluent at a time, from the top of the order down, doubling the
    array each time (total work about twice the table), then puts the letter bits in place
    with one transpose.

    Args:
        diagram: the transitions.
        letter_bit: fluent -> its bit in the letter index, for every fluent of the index
            (the identity for a full table; consecutive bits for a projection onto the
            tested fluents). It must include every fluent the diagram tests.
        n_bits: number of bits of the letter index (``len(letter_bit)``).

    Returns:
        int64 ``[n_states, 2**n_bits]``.
    """
    var, lo, hi, root, rank = diagram
    if len(letter_bit) != n_bits:
        raise ValueError("letter_bit must give a bit to each of the n_bits fluents")
    order = sorted(letter_bit, key=lambda v: -rank[v])  # the top of the order first
    n_states = root.shape[0]
    node = root[:, None]
    for v in order:
        splits = var[node] == v
        low = np.where(splits, lo[node], node)
        high = np.where(splits, hi[node], node)
        node = np.concatenate([low, high], axis=1)  # the new bit is the slowest so far
    # Axis 1 + (m - 1 - j) of the split array is fluent order[j]; in the result, bit b is
    # axis 1 + (n_bits - 1 - b) (the most significant bit first, as in C order).
    split = node.reshape((n_states,) + (2,) * n_bits)
    source_axis = {letter_bit[v]: n_bits - j for j, v in enumerate(order)}
    axes = [0] + [source_axis[b] for b in range(n_bits - 1, -1, -1)]
    return np.ascontiguousarray(split.transpose(axes)).reshape(n_states, 1 << n_bits)


def support_from_table(next_state: np.ndarray) -> np.ndarray:
    """Computes the guard support of every cell of a dense transition table.

    For a cell ``(q, a)`` with ``t = next_state[q, a]``, fluent ``v`` is in the support iff
    the guard ``{b : next_state[q, b] == t}`` changes when bit ``v`` of ``b`` is flipped,
    i.e. iff some letter of the guard has its ``v``-neighbour outside it. So each cell
    collects the bits whose flip changes its successor, and each edge ``(q, t)`` is the
    OR of its cells' collections.

    Args:
        next_state: int array ``[n_states, 2**n_fluents]``.

    Returns:
        uint64 array of the same shape.
    """
    table = np.asarray(next_state, dtype=np.int64)
    n_states, n_letters = table.shape
    n_fluents = int(n_letters).bit_length() - 1
    if 1 << n_fluents != n_letters:
        raise ValueError(f"table width {n_letters} is not a power of two")
    dtype = next(
        t for t in (np.uint8, np.uint16, np.uint32, np.uint64) if n_fluents <= 8 * t().itemsize
    )
    flips = np.zeros(table.shape, dtype=dtype)
    for v in range(n_fluents):
        # Letters with bit v clear and set, side by side, as views of the table.
        pairs = table.reshape(n_states, -1, 2, 1 << v)
        differs = pairs[:, :, 0, :] != pairs[:, :, 1, :]
        both = np.repeat(differs[:, :, None, :], 2, axis=2).reshape(table.shape)
        flips |= np.left_shift(both, v, dtype=dtype)
    edge = np.arange(n_states, dtype=np.int64)[:, None] * max(n_states, 1) + table
    if n_states * n_states <= 4 * table.size:  # edges index a small array directly
        per_edge = np.zeros(n_states * n_states, dtype=dtype)
        np.bitwise_or.at(per_edge, edge.reshape(-1), flips.reshape(-1))
        return per_edge[edge].astype(np.uint64)
    keys, inverse = np.unique(edge, return_inverse=True)
    per_edge = np.zeros(keys.size, dtype=dtype)
    np.bitwise_or.at(per_edge, inverse.reshape(-1), flips.reshape(-1))
    return per_edge[inverse.reshape(table.shape)].astype(np.uint64)


def max_depth(diagram: GuardDiagram) -> int:
    """Largest number of inner nodes on a path from a root to a leaf."""
    lo, hi = diagram.lo, diagram.hi
    depth = np.zeros(diagram.n_nodes, dtype=np.int64)
    for nodes in diagram.levels():
        depth[nodes] = 1 + np.maximum(depth[lo[nodes]], depth[hi[nodes]])
    return int(depth.max()) if depth.size else 0


class EdgeInspector:
    """Exact guards of single edges of a (possibly huge) diagram, computed on demand.

    The guard of edge ``(q, t)`` is the indicator ``[delta(q, .) == t]``. It is reduced
    into a private unique table restricted to the nodes that can reach leaf ``t`` (known
    from per-node reachability bitsets), so a query costs about the number of nodes on
    the paths from ``q`` to ``t``, not the size of ``q``'s diagram. Its support is then
    the set of fluents its reduced diagram tests: exact, whatever the printing.
    """

    # Reachability bitsets cost n_nodes * n_states bits; beyond this, walk unpruned.
    MAX_BITSET_BITS = 1 << 30

    def __init__(self, diagram: GuardDiagram) -> None:
        self._var, self._lo, self._hi, self._root = (
            a.tolist() for a in (diagram.var, diagram.lo, diagram.hi, diagram.root)
        )
        self._n_states = diagram.n_states
        self._reach: list[int] | None = None
        if diagram.n_nodes * max(diagram.n_states, 1) <= self.MAX_BITSET_BITS:
            self._reach = self._reachability(diagram)
        # Indicator nodes: id -> (var, lo, hi); ids 0 and 1 are the constants.
        self._nodes: list[tuple[int, int, int]] = [(-1, 0, 0), (-1, 1, 1)]
        self._unique: dict[tuple[int, int, int], int] = {}
        self._support: dict[int, int] = {0: 0, 1: 0}
        self._edges: dict[tuple[int, int], int] = {}

    def _reachability(self, diagram: GuardDiagram) -> list[int]:
        reach = [1 << s for s in range(diagram.n_states)] + [0] * (
            diagram.n_nodes - diagram.n_states
        )
        for node in np.concatenate([[], *diagram.levels()]).astype(np.int64).tolist():
            reach[node] = reach[self._lo[node]] | reach[self._hi[node]]
        return reach

    def targets(self, q: int) -> list[int]:
        """The successors of ``q``, in the order of :func:`bfs_order`."""
        seen: list[int] = []
        found: set[int] = set()
        visited: set[int] = set()
        stack = [self._root[q]]
        while stack:
            node = stack.pop()
            if node < self._n_states:
                if node not in found:
                    found.add(node)
                    seen.append(node)
            elif node not in visited:
                visited.add(node)
                stack.append(self._hi[node])
                stack.append(self._lo[node])
        return seen

    def guard(self, q: int, t: int) -> int:
        """Id of the reduced guard of edge ``(q, t)`` in the private unique table."""
        key = (q, t)
        cached = self._edges.get(key)
        if cached is not None:
            return cached
        var, lo, hi, n_states = self._var, self._lo, self._hi, self._n_states
        reach, bit = self._reach, 1 << t
        memo: dict[int, int] = {}

        def reduce(node: int) -> int:
            if node < n_states:
                return 1 if node == t else 0
            if reach is not None and not reach[node] & bit:
                return 0
            found = memo.get(node)
            if found is not None:
                return found
            low, high = reduce(lo[node]), reduce(hi[node])
            if low == high:
                result = low
            else:
                triple = (var[node], low, high)
                result = self._unique.get(triple, -1)
                if result < 0:
                    result = len(self._nodes)
                    self._nodes.append(triple)
                    self._unique[triple] = result
            memo[node] = result
            return result

        result = reduce(self._root[q])
        self._edges[key] = result
        return result

    def support(self, q: int, t: int) -> int:
        """Bitmask of the fluents the guard of edge ``(q, t)`` depends on."""
        return self._support_of(self.guard(q, t))

    def _support_of(self, node: int) -> int:
        found = self._support.get(node)
        if found is None:
            v, low, high = self._nodes[node]
            found = (1 << v) | self._support_of(low) | self._support_of(high)
            self._support[node] = found
        return found

    def cubes(self, q: int, t: int) -> list[dict[int, bool]]:
        """The guard of ``(q, t)`` as disjoint cubes (fluent index -> value), one per path."""
        result: list[dict[int, bool]] = []

        def walk(node: int, cube: dict[int, bool]) -> None:
            if node == 1:
                result.append(dict(cube))
            elif node > 1:
                v, low, high = self._nodes[node]
                cube[v] = False
                walk(low, cube)
                cube[v] = True
                walk(high, cube)
                del cube[v]

        walk(self.guard(q, t), {})
        return result


def letter_lookup(bits: list[int]) -> Callable[[np.ndarray], np.ndarray]:
    """A vectorised bit-gather: packs bits ``bits[j]`` of uint64 masks into bit ``j``.

    Uses one 256-entry table per byte of the mask that holds a gathered bit.
    """
    tables: list[tuple[np.uint64, np.ndarray]] = []
    for byte in sorted({b // 8 for b in bits}):
        table = np.zeros(256, dtype=np.int64)
        for j, b in enumerate(bits):
            if b // 8 == byte:
                table |= ((np.arange(256) >> (b % 8)) & 1) << j
        tables.append((np.uint64(8 * byte), table))

    def gather(masks: np.ndarray) -> np.ndarray:
        out = np.zeros(masks.shape, dtype=np.int64)
        for shift, table in tables:
            out |= table[((masks >> shift) & np.uint64(0xFF)).astype(np.intp)]
        return out

    return gather


class RawAutomaton(NamedTuple):
    """What a backend hands back before minimisation and canonical numbering."""

    diagram: GuardDiagram
    accepting: np.ndarray
    initial_state: int
