"""What a DFA's graph says about its formula: satisfiable, vacuous, how far from acceptance.

Our traces start at the first observation (DESIGN.md), so a formula matters only on
traces of one letter or more: the empty trace (the DFA's initial state) never pays.

* :func:`is_satisfiable`: some non-empty trace is accepted (an accepting state is
  reachable from the initial state in one step or more).
* :func:`is_valid`: every non-empty trace is accepted (every state reachable in one step
  or more is accepting): the spec asks for nothing.
* :func:`distance_to_acceptance`: the fewest letters from each state to an accepting
  state (``-1`` where none is reachable: a rejecting sink, or a state that only leads to
  them), the basis of progress shaping (Camacho et al., IJCAI 2019).

The graph has an edge ``q -> q'`` when *some* letter moves ``q`` to ``q'``; whether a
world can produce that letter is the world's business (``noisybolt check`` explores it).

Example:
    >>> from noisybolt.logic import compile_ltlf
    >>> dfa = compile_ltlf("F(a & X(F(b)))", ["a", "b"])
    >>> is_satisfiable(dfa), is_valid(dfa)
    (True, False)
    >>> int(distance_to_acceptance(dfa)[dfa.initial_state])
    2
    >>> is_satisfiable(compile_ltlf("F(a) & G(!a)", ["a"]))
    False
    >>> is_valid(compile_ltlf("a | !a", ["a"]))
    True
"""

from __future__ import annotations

from collections import deque

import numpy as np

from noisybolt.logic.dfa import DFA

__all__ = ["distance_to_acceptance", "is_satisfiable", "is_valid", "reachable_states", "successors"]


def successors(dfa: DFA) -> tuple[tuple[int, ...], ...]:
    """For each state, the states some letter moves it to (sorted, without repeats)."""
    out: list[set[int]] = [set() for _ in range(dfa.n_states)]
    for edge in dfa.iter_edges():
        out[edge.src].add(edge.dst)
    return tuple(tuple(sorted(s)) for s in out)


def reachable_states(dfa: DFA, *, min_letters: int = 1) -> np.ndarray:
    """bool ``[n_states]``: states some trace of at least ``min_letters`` letters reaches.

    ``min_letters`` is 0 or 1: with 1 (the default) the initial state counts only if some
    letter leads back to it.
    """
    if min_letters not in (0, 1):
        raise ValueError(f"min_letters must be 0 or 1, got {min_letters!r}")
    succ = successors(dfa)
    seen = np.zeros(dfa.n_states, dtype=bool)
    frontier = deque(succ[dfa.initial_state] if min_letters else (dfa.initial_state,))
    while frontier:
        q = frontier.popleft()
        if seen[q]:
            continue
        seen[q] = True
        frontier.extend(t for t in succ[q] if not seen[t])
    return seen


def is_satisfiable(dfa: DFA) -> bool:
    """Whether some trace of one letter or more is accepted."""
    return bool(np.any(reachable_states(dfa) & dfa.accepting))


def is_valid(dfa: DFA) -> bool:
    """Whether every trace of one letter or more is accepted (the spec asks for nothing)."""
    return bool(np.all(dfa.accepting[reachable_states(dfa)]))


def distance_to_acceptance(dfa: DFA, letters: np.ndarray | None = None) -> np.ndarray:
    """int64 ``[n_states]``: fewest letters from each state to an accepting one.

    0 for accepting states, ``-1`` for states from which no accepting state is reachable.
    Breadth-first search backwards from the accepting states.

    Args:
        dfa: the automaton.
        letters: the letters a world can produce, as bitmasks over ``dfa.fluents`` (int
            ``[n]``); None for every letter. A world rarely produces them all (the agent is
            never in two corners at once), so distances over its own letters say better
            how far a state is from acceptance. A state that cannot reach acceptance
            over those letters keeps its distance over all letters (the sample may have
            missed a letter the world can produce).

    Example:
        >>> from noisybolt.logic import compile_ltlf
        >>> dfa = compile_ltlf("F(a) & F(b)", ["a", "b"])
        >>> int(distance_to_acceptance(dfa)[dfa.initial_state])  # one letter: a & b
        1
        >>> int(distance_to_acceptance(dfa, np.array([0b00, 0b01, 0b10]))[dfa.initial_state])
        2
    """
    every = _distances(dfa, successors(dfa))
    if letters is None:
        return every
    masks = np.unique(np.asarray(letters, dtype=np.uint64))
    succ = []
    for q in range(dfa.n_states):
        reached, _ = dfa.step_batch(np.full(len(masks), q), masks)
        succ.append(tuple(sorted({int(t) for t in reached})))
    own = _distances(dfa, tuple(succ))
    return np.where((own < 0) & (every >= 0), every, own)


def _distances(dfa: DFA, succ: tuple[tuple[int, ...], ...]) -> np.ndarray:
    predecessors: list[list[int]] = [[] for _ in range(dfa.n_states)]
    for q, targets in enumerate(succ):
        for t in targets:
            predecessors[t].append(q)
    distance = np.full(dfa.n_states, -1, dtype=np.int64)
    frontier = deque(int(q) for q in np.flatnonzero(dfa.accepting))
    distance[list(frontier)] = 0
    while frontier:
        q = frontier.popleft()
        for p in predecessors[q]:
            if distance[p] < 0:
                distance[p] = distance[q] + 1
                frontier.append(p)
    return distance
