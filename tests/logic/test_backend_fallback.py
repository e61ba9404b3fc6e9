"""Under ``backend="auto"`` the BDD progression takes over when MONA times out or fails."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from noisybolt.errors import CompilationError
from noisybolt.logic import compile_ltlf
from noisybolt.logic import compiler as compiler_module

FORMULA = "G(a -> X(b)) & F(a)"


@pytest.fixture
def mona_that_times_out(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """MONA "installed" but timing out on every formula; returns the formulas it was given."""
    given: list[str] = []

    def times_out(parsed: Any, vocabulary: Any, *, formula: str, **_: Any) -> Any:
        given.append(formula)
        raise CompilationError(f"MONA did not finish compiling {formula!r}", formula=formula)

    monkeypatch.setattr(compiler_module, "find_mona", lambda: "/usr/bin/mona")
    monkeypatch.setattr(compiler_module, "require_mona", lambda: "/usr/bin/mona")
    monkeypatch.setattr(compiler_module, "mona_version", lambda _: "MONA v1.4-test")
    monkeypatch.setattr(compiler_module, "compile_mona", times_out)
    return given


def test_auto_falls_back_to_the_progression_and_caches_its_dfa(
    mona_that_times_out: list[str], tmp_path: Path
) -> None:
    expected = compile_ltlf(FORMULA, ["a", "b"], backend="bdd", cache=False)
    dfa = compile_ltlf(FORMULA, ["a", "b"], backend="auto", cache=tmp_path)
    assert mona_that_times_out == [FORMULA]
    assert dfa.n_states == expected.n_states
    np.testing.assert_array_equal(dfa.accepting, expected.accepting)
    words = [[{"a": True}, {"b": True}], [{"a": True}, {"a": False}], [{"b": True}]]
    assert [dfa.accepts(w) for w in words] == [expected.accepts(w) for w in words]
    # The next compile finds the progression's DFA in the cache: MONA is not run again.
    compile_ltlf(FORMULA, ["a", "b"], backend="auto", cache=tmp_path)
    assert mona_that_times_out == [FORMULA]


def test_mona_asked_for_by_name_does_not_fall_back(mona_that_times_out: list[str]) -> None:
    with pytest.raises(CompilationError, match="MONA did not finish"):
        compile_ltlf(FORMULA, ["a", "b"], backend="mona", cache=False)


def test_when_both_fail_the_error_names_both(
    mona_that_times_out: list[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    def fails(*_: Any, formula: str, **__: Any) -> Any:
        raise CompilationError("progression ran out of time", formula=formula)

    monkeypatch.setattr(compiler_module, "compile_progression", fails)
    with pytest.raises(CompilationError, match=r"neither backend compiled .*progression ran out"):
        compile_ltlf(FORMULA, ["a", "b"], backend="auto", cache=False)
