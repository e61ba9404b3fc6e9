"""compile_ltlf: hand-computed automata, both backends, and every way a backend can fail."""

from __future__ import annotations

import os
import stat
import time
from pathlib import Path

import numpy as np
import pytest
from logic_helpers import BACKENDS, HAVE_MONA, needs_mona, same_automaton

from noisybolt.errors import BackendUnavailableError, CompilationError
from noisybolt.logic import DFA, compile_ltlf, holds
from noisybolt.logic.compiler import resolve_backend
from noisybolt.logic.mona import parse_mona_output

TWENTY = " & ".join(f"G(a{i} -> F(b{i}))" for i in range(1, 11))


def compile_both(formula: str, fluents: list[str] | None = None) -> list[DFA]:
    return [compile_ltlf(formula, fluents, backend=b, cache=False) for b in BACKENDS]


def support_names(dfa: DFA, q: int, assignment: dict[str, bool]) -> set[str]:
    mask = dfa.mask(assignment)
    return {f for i, f in enumerate(dfa.fluents) if int(dfa.support[q, mask]) >> i & 1}


@pytest.mark.parametrize("backend", BACKENDS)
def test_eventually_a_and_b(backend: str) -> None:
    dfa = compile_ltlf("F(a & b)", backend=backend, cache=False)
    # The empty-trace state behaves like "not yet": minimisation merges them.
    assert dfa.n_states == 2 and dfa.initial_state == 0
    assert dfa.accepting.tolist() == [False, True]
    assert dfa.next_state.tolist() == [[0, 0, 0, 1], [1, 1, 1, 1]]
    assert support_names(dfa, 0, {"a": True, "b": True}) == {"a", "b"}  # the edge 0 -> 1
    assert support_names(dfa, 0, {"a": True}) == {"a", "b"}  # its complement 0 -> 0
    assert support_names(dfa, 1, {}) == set()
    assert dfa.accepting_sinks.tolist() == [False, True]
    assert not dfa.rejecting_sinks.any()
    edges = {(e.src, e.dst): e for e in dfa.edges()}
    assert edges[0, 1].guard == "a & b" and edges[0, 1].support == ("a", "b")
    assert edges[1, 1].guard == "true" and edges[1, 1].support == ()


@pytest.mark.parametrize("backend", BACKENDS)
def test_always_e(backend: str) -> None:
    dfa = compile_ltlf("G(e)", backend=backend, cache=False)
    # MONA's semantics: the empty trace satisfies G(e), so the initial state accepts.
    assert dfa.n_states == 2 and dfa.accepting.tolist() == [True, False]
    assert dfa.next_state.tolist() == [[1, 0], [1, 1]]
    assert dfa.rejecting_sinks.tolist() == [False, True]
    assert not dfa.accepting_sinks.any()


@pytest.mark.parametrize("backend", BACKENDS)
def test_dont_care_fluent(backend: str) -> None:
    dfa = compile_ltlf("F(a)", ["a", "z"], backend=backend, cache=False)
    assert dfa.fluents == ("a", "z") and dfa.relevant_fluents == ("a",)
    assert dfa.next_state.tolist() == [[0, 1, 0, 1], [1, 1, 1, 1]]
    assert support_names(dfa, 0, {"z": True}) == {"a"}
    assert support_names(dfa, 0, {"a": True, "z": True}) == {"a"}


@pytest.mark.parametrize("backend", BACKENDS)
def test_strong_next(backend: str) -> None:
    dfa = compile_ltlf("X(a)", backend=backend, cache=False)
    # empty trace -> first letter -> (rejecting sink on !a, accepting sink on a)
    assert dfa.next_state.tolist() == [[1, 1], [2, 3], [2, 2], [3, 3]]
    assert dfa.accepting.tolist() == [False, False, False, True]
    assert dfa.rejecting_sinks.tolist() == [False, False, True, False]


@pytest.mark.parametrize("backend", BACKENDS)
def test_constants(backend: str) -> None:
    for formula, accepts in (("true", True), ("false", False)):
        dfa = compile_ltlf(formula, backend=backend, cache=False)
        assert dfa.n_states == 1 and dfa.fluents == ()
        assert bool(dfa.accepting[0]) is accepts and dfa.next_state.tolist() == [[0]]


# The paper's five specifications (gridworld and Breakout), with traces to check them.
PAPER = {
    "G(on_edge)": [([{"on_edge": True}] * 3, True), ([{"on_edge": True}, {}], False)],
    "!F(top_right_corner)": [([{}] * 4, True), ([{}, {"top_right_corner": True}], False)],
    "F(top_right_corner & X(!F(top_right_corner)))": [
        ([{"top_right_corner": True}, {}], True),
        ([{"top_right_corner": True}], False),  # X is strong: no next position
        ([{"top_right_corner": True}, {}, {"top_right_corner": True}], False),
    ],
    "(F(t & X(!F(t))) & !F(b)) | (F(b & X(!F(b))) & !F(t))": [
        ([{"t": True}, {}], True),
        ([{"b": True}, {}, {}], True),
        ([{"t": True}, {"b": True}, {}], False),
        ([{"t": True, "b": True}, {}], False),
    ],
    "F(brick_clear_left)": [([{}, {"brick_clear_left": True}], True), ([{}], False)],
}
PAPER_STATES = {
    "G(on_edge)": 2,
    "!F(top_right_corner)": 2,
    "F(top_right_corner & X(!F(top_right_corner)))": 3,
    "(F(t & X(!F(t))) & !F(b)) | (F(b & X(!F(b))) & !F(t))": 6,
    "F(brick_clear_left)": 2,
}


@pytest.mark.parametrize("formula", list(PAPER))
def test_paper_specs(formula: str) -> None:
    dfas = compile_both(formula)
    for dfa in dfas:
        assert dfa.n_states == PAPER_STATES[formula]
        for trace, expected in PAPER[formula]:
            assert dfa.accepts(trace) is expected is holds(formula, trace)
    assert all(same_automaton(dfas[0], other) for other in dfas[1:])


def test_numbering_is_breadth_first_by_smallest_letter() -> None:
    # F(t & X(!F(t))): 0 empty/waiting; on t (letter 1) -> 1 "t seen, need !t after"...
    dfa = compile_ltlf("F(t & X(!F(t)))", backend="bdd", cache=False)
    order = [dfa.initial_state]
    for q in order:
        for t in dict.fromkeys(dfa.next_state[q].tolist()):
            if t not in order:
                order.append(t)
    assert order == list(range(dfa.n_states))


def test_twenty_fluents_both_backends() -> None:
    dfas = compile_both(TWENTY)
    for dfa in dfas:
        assert dfa.n_fluents == 20 and dfa.n_states == 1024 and dfa.is_compact
    assert all(same_automaton(dfas[0], other) for other in dfas[1:])


@pytest.mark.slow  # a timing: the default suite asserts no speeds (benchmarks/compile_time.py)
@needs_mona
def test_twenty_fluents_with_mona_well_under_a_second() -> None:
    compile_ltlf("F(a)", backend="mona", cache=False)  # imports and MONA's version, once
    elapsed = []
    for _ in range(3):
        started = time.perf_counter()
        compile_ltlf(TWENTY, backend="mona", cache=False)
        elapsed.append(time.perf_counter() - started)
    assert min(elapsed) < 0.5, elapsed  # measured ~0.06 s on 2 cores


# ---------------------------------------------------------------- backends and failures
def fake_mona(directory: Path, body: str, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A ``mona`` first on PATH that prints a banner without arguments, else runs ``body``."""
    monkeypatch.setenv("PATH", f"{directory}{os.pathsep}{os.environ['PATH']}")
    script = directory / "mona"
    script.write_text(
        f'#!/bin/sh\nif [ $# -eq 0 ]; then echo "MONA v0.0-fake"; exit 0; fi\n{body}\n'
    )
    script.chmod(script.stat().st_mode | stat.S_IEXEC)
    return script


def test_mona_missing(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.setenv("PATH", str(tmp_path))
    with pytest.raises(BackendUnavailableError, match="sudo apt-get install mona"):
        compile_ltlf("F(a)", backend="mona", cache=False)
    assert resolve_backend("auto") == "bdd"
    dfa = compile_ltlf("F(a)", cache=False)  # auto falls back to the BDD backend
    assert dfa.accepts([{}, {"a": True}])


def test_mona_crash(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    fake_mona(tmp_path, "kill -ABRT $$", monkeypatch)
    with pytest.raises(CompilationError, match="SIGABRT") as caught:
        compile_ltlf("G(a -> F(b))", backend="mona", cache=False)
    assert caught.value.formula == "G(a -> F(b))"


def test_mona_error_status(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    fake_mona(tmp_path, 'echo "out of memory" >&2; exit 3', monkeypatch)
    with pytest.raises(
        CompilationError, match=r"status 3 while compiling 'F\(a\)':\nout of memory"
    ):
        compile_ltlf("F(a)", backend="mona", cache=False)


def test_mona_timeout(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    # A stub that would answer nothing for a minute: only the timeout gives this error.
    fake_mona(tmp_path, "exec sleep 60", monkeypatch)
    with pytest.raises(CompilationError, match=r"within 0\.3 s") as caught:
        compile_ltlf("F(a)", backend="mona", timeout=0.3, cache=False)
    assert caught.value.formula == "F(a)"


def test_mona_garbage(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    fake_mona(tmp_path, 'echo "hello"', monkeypatch)
    with pytest.raises(CompilationError, match="unreadable MONA output"):
        compile_ltlf("F(a)", backend="mona", cache=False)


MONA_F_A_AND_B = """MONA DFA
number of variables: 2
variables: A B
orders: 2 2
states: 3
initial: 0
bdd nodes: 4
final: 0 -1 1
behaviour: 0 1 3
bdd:
 -1 1 0
 0 0 2
 1 0 3
 -1 2 0
end
"""


def test_parse_mona_output() -> None:
    raw = parse_mona_output(MONA_F_A_AND_B, ["a", "b"], formula="F(a & b)")
    assert raw.initial_state == 1 and raw.accepting.tolist() == [False, False, True]
    for broken, why in [
        (MONA_F_A_AND_B.replace("states: 3", "states: 4"), "sizes"),
        (MONA_F_A_AND_B.replace(" 1 0 3", " 1 0 9"), "child"),
        (MONA_F_A_AND_B.replace("A B", "A C"), "not a fluent"),
        (MONA_F_A_AND_B.replace("final: 0 -1 1", "final: 0 0 1"), "acceptance"),
        (MONA_F_A_AND_B.replace("end\n", ""), "'end'"),
        (MONA_F_A_AND_B.replace(" 0 0 2", " 1 0 2"), "order"),
    ]:
        with pytest.raises(CompilationError, match=why):
            parse_mona_output(broken, ["a", "b"], formula="F(a & b)")


def test_bdd_backend_timeout() -> None:
    with pytest.raises(CompilationError, match="did not finish") as caught:
        compile_ltlf(TWENTY, backend="bdd", timeout=1e-6, cache=False)
    assert caught.value.formula == TWENTY


def test_bad_arguments() -> None:
    with pytest.raises(ValueError, match="backend must be one of"):
        compile_ltlf("F(a)", backend="spot", cache=False)  # type: ignore[arg-type]
    for timeout in (0, -1.0, float("nan"), "10"):
        with pytest.raises(ValueError, match="timeout"):
            compile_ltlf("F(a)", timeout=timeout, cache=False)  # type: ignore[arg-type]


@pytest.mark.skipif(not HAVE_MONA, reason="needs MONA")
def test_auto_is_mona_when_installed() -> None:
    assert resolve_backend("auto") == "mona"


def test_describe_mentions_everything() -> None:
    text = compile_ltlf("G(e)", backend="bdd", cache=False).describe()
    assert "states: 2, initial: 0, accepting: [0]" in text
    assert "rejecting sinks: [1]" in text and "0 -> 1  [!e]  support=['e']" in text
    assert np.array_equal(compile_ltlf("G(e)", backend="bdd", cache=False).accepting, [True, False])
