"""The on-disk DFA cache: hits, keys, corrupt entries, and processes compiling at once."""

from __future__ import annotations

import multiprocessing
import random
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from logic_helpers import BACKENDS, same_automaton

from noisybolt.logic import DFA, compile_ltlf
from noisybolt.logic import compiler as compiler_module
from noisybolt.logic.cache import cache_directory

FLUENTS = ["a", "b", "c"]


def entries(directory: Path) -> list[Path]:
    return sorted(directory.glob("*.npz"))


def forbid_compiling(monkeypatch: pytest.MonkeyPatch) -> None:
    def fail(*args: object, **kwargs: object) -> None:
        raise AssertionError("compiled although the entry was cached")

    monkeypatch.setattr(compiler_module, "compile_progression", fail)
    monkeypatch.setattr(compiler_module, "compile_mona", fail)


def test_hit_skips_the_backend(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    first = compile_ltlf("G(a -> F(b))", FLUENTS, backend="bdd", cache=tmp_path)
    assert len(entries(tmp_path)) == 1
    forbid_compiling(monkeypatch)
    # Same formula up to spacing: same entry, but the DFA keeps the caller's text.
    again = compile_ltlf("G( a->F b )", FLUENTS, backend="bdd", cache=tmp_path)
    assert same_automaton(first, again) and again.formula == "G( a->F b )"
    assert not again.is_compact and np.array_equal(again.support, first.support)


def test_key_parts(tmp_path: Path) -> None:
    compile_ltlf("F(a)", ["a"], backend="bdd", cache=tmp_path)
    compile_ltlf("F(a)", ["a", "b"], backend="bdd", cache=tmp_path)  # other vocabulary
    compile_ltlf("F(b)", ["a", "b"], backend="bdd", cache=tmp_path)  # other formula
    for backend in BACKENDS:
        compile_ltlf("F(b)", ["a", "b"], backend=backend, cache=tmp_path)
    assert len(entries(tmp_path)) == 2 + len(BACKENDS)


def test_default_directory(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.setenv("NOISYBOLT_CACHE_DIR", str(tmp_path / "here"))
    assert cache_directory(True) == tmp_path / "here"
    compile_ltlf("F(a)", backend="bdd")
    assert len(entries(tmp_path / "here")) == 1
    monkeypatch.delenv("NOISYBOLT_CACHE_DIR")
    assert cache_directory(True) == Path.home() / ".cache" / "noisybolt" / "dfa"
    assert cache_directory(False) is None
    assert cache_directory(str(tmp_path)) == tmp_path


@pytest.mark.parametrize(
    "damage",
    [
        lambda path, other: path.write_bytes(b"not an npz at all"),
        lambda path, other: path.write_bytes(path.read_bytes()[: len(path.read_bytes()) // 2]),
        lambda path, other: path.write_bytes(b""),
        lambda path, other: path.write_bytes(other.read_bytes()),  # another formula's entry
    ],
    ids=["garbage", "truncated", "empty", "foreign"],
)
def test_corrupt_entry_is_rebuilt(tmp_path: Path, damage: Any) -> None:
    other_dir = tmp_path / "other"
    compile_ltlf("G(b)", FLUENTS, backend="bdd", cache=other_dir)
    expected = compile_ltlf("F(a & X(b))", FLUENTS, backend="bdd", cache=False)
    compile_ltlf("F(a & X(b))", FLUENTS, backend="bdd", cache=tmp_path)
    (path,) = entries(tmp_path)
    damage(path, entries(other_dir)[0])
    rebuilt = compile_ltlf("F(a & X(b))", FLUENTS, backend="bdd", cache=tmp_path)
    assert same_automaton(rebuilt, expected)
    with np.load(path, allow_pickle=False) as entry:  # rewritten whole
        assert entry["root"].shape == (expected.n_states,)


def test_inconsistent_arrays_are_rebuilt(tmp_path: Path) -> None:
    expected = compile_ltlf("a U b", FLUENTS, backend="bdd", cache=tmp_path)
    (path,) = entries(tmp_path)
    with np.load(path, allow_pickle=False) as entry:
        arrays = dict(entry)
    arrays["hi"] = arrays["lo"]  # a well-formed file holding a broken diagram
    np.savez(path, **arrays)
    assert same_automaton(compile_ltlf("a U b", FLUENTS, backend="bdd", cache=tmp_path), expected)


def test_unwritable_cache_warns_and_compiles(tmp_path: Path) -> None:
    not_a_directory = tmp_path / "file"
    not_a_directory.write_text("")
    with pytest.warns(RuntimeWarning, match="could not write the DFA cache"):
        dfa = compile_ltlf("F(a)", backend="bdd", cache=not_a_directory)
    assert dfa.accepts([{"a": True}])


def test_compact_dfa_round_trip(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    formula = " & ".join(f"G(a{i} -> F(b{i}))" for i in range(1, 11))
    first = compile_ltlf(formula, backend="bdd", cache=tmp_path)
    forbid_compiling(monkeypatch)
    again = compile_ltlf(formula, backend="bdd", cache=tmp_path)
    assert again.is_compact and same_automaton(first, again)


# ---------------------------------------------------------------- concurrency
CONCURRENT = [
    "F(a & b)",
    "G(a -> F(b))",
    "!F(c)",
    "a U (b & X(c))",
    "G(a) | F(b & c)",
    "F(a & X(!F(a)))",
    "(F(a & X(!F(a))) & !F(b)) | (F(b & X(!F(b))) & !F(a))",
    "X(X(c)) & WX(a)",
    "a R (b | c)",
    "G(F(a) -> F(c))",
]


def compile_in_order(job: tuple[str, str | bool, int]) -> list[tuple[str, list[list[int]], int]]:
    """Worker: compiles every formula in a seeded order, twice; returns their arrays."""
    backend, cache, seed = job
    order = CONCURRENT * 2
    random.Random(seed).shuffle(order)
    out = []
    for formula in order:
        dfa = compile_ltlf(formula, FLUENTS, backend=backend, cache=cache)  # type: ignore[arg-type]
        arrays = [dfa.accepting.astype(int).tolist(), *(a.tolist() for a in dfa.diagram)]
        out.append((formula, arrays, dfa.initial_state))
    return out


def arrays_of(dfa: DFA) -> list[list[int]]:
    return [dfa.accepting.astype(int).tolist(), *(a.tolist() for a in dfa.diagram)]


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("cached", [True, False], ids=["shared-cache", "no-cache"])
def test_processes_compiling_at_once_get_their_own_automata(
    tmp_path: Path, backend: str, cached: bool
) -> None:
    # ltlf2dfa's own I/O fails exactly this: parallel compiles read each other's programs.
    expected = {
        f: arrays_of(compile_ltlf(f, FLUENTS, backend=backend, cache=False)) for f in CONCURRENT
    }
    # Not "fork": this test runs in a process that other tests may have left with threads
    # (torch's, a summary writer's), and a child forked from it can die or hang on a lock
    # held at the fork (seen: two pool workers dead, the map waiting forever).
    methods = multiprocessing.get_all_start_methods()
    context = multiprocessing.get_context("forkserver" if "forkserver" in methods else "spawn")
    cache: str | bool = str(tmp_path) if cached else False
    with context.Pool(3) as pool:
        results = pool.map(compile_in_order, [(backend, cache, seed) for seed in range(3)])
    for result in results:
        assert len(result) == 2 * len(CONCURRENT)
        for formula, arrays, initial in result:
            assert arrays == expected[formula] and initial == 0, formula
    if cached:
        assert len(entries(tmp_path)) == len(CONCURRENT)
        assert not list(tmp_path.glob(".tmp-*"))  # no temporary file left behind
