"""Helpers of the logic tests: MONA detection, exhaustive traces, batch acceptance."""

from __future__ import annotations

import itertools
import shutil
from collections.abc import Iterator

import numpy as np
import pytest

from noisybolt.logic import DFA

HAVE_MONA = shutil.which("mona") is not None
needs_mona = pytest.mark.skipif(
    not HAVE_MONA, reason="MONA is not installed (apt-get install mona)"
)
#: Backends whose results the tests compare ("bdd" always runs).
BACKENDS = ["mona", "bdd"] if HAVE_MONA else ["bdd"]


def all_traces(n_fluents: int, length: int) -> np.ndarray:
    """bool ``[2**(n_fluents*length), length, n_fluents]``: every trace of that length."""
    letters = np.array(list(itertools.product([False, True], repeat=n_fluents)), dtype=bool)
    index = np.array(list(itertools.product(range(len(letters)), repeat=length)), dtype=np.int64)
    return letters[index].reshape(-1, length, n_fluents)


def run_batch(dfa: DFA, truth: np.ndarray) -> np.ndarray:
    """bool ``[n_traces]``: acceptance of many traces ``[n, length, n_fluents]`` via step_batch."""
    weights = np.left_shift(np.uint64(1), np.arange(truth.shape[2], dtype=np.uint64))
    masks = (truth.astype(np.uint64) * weights).sum(axis=2, dtype=np.uint64)
    states = np.full(truth.shape[0], dfa.initial_state, dtype=np.int64)
    for t in range(truth.shape[1]):
        states, _ = dfa.step_batch(states, masks[:, t])
    return dfa.accepting[states]


def as_letters(truth: np.ndarray, fluents: list[str]) -> Iterator[list[dict[str, bool]]]:
    """Traces ``[n, length, k]`` as lists of mappings, for the scalar APIs."""
    for trace in truth:
        yield [dict(zip(fluents, map(bool, letter), strict=True)) for letter in trace]


def same_automaton(left: DFA, right: DFA) -> bool:
    """Identical vocabulary, initial state, acceptance and diagram arrays."""
    return (
        left.fluents == right.fluents
        and left.initial_state == right.initial_state
        and np.array_equal(left.accepting, right.accepting)
        and all(np.array_equal(a, b) for a, b in zip(left.diagram, right.diagram, strict=True))
    )
