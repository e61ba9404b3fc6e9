"""Without the MONA binary, ``backend="auto"`` compiles with the pure-Python BDD progression
and says so once per process (:class:`BackendFallbackWarning`, naming the fix); with MONA
installed, or with the BDD backend asked for by name, nothing is said."""

from __future__ import annotations

import os
import subprocess
import sys
import warnings
from pathlib import Path

import pytest
from logic_helpers import needs_mona

from noisybolt.errors import BackendFallbackWarning
from noisybolt.logic import compile_ltlf
from noisybolt.logic import compiler as compiler_module


@pytest.fixture
def unannounced(monkeypatch: pytest.MonkeyPatch) -> None:
    """This process has not yet said that it compiles without MONA."""
    monkeypatch.setattr(compiler_module, "_fallback_announced", False)


@pytest.fixture
def no_mona(monkeypatch: pytest.MonkeyPatch, tmp_path: Path, unannounced: None) -> None:
    """No ``mona`` on PATH."""
    monkeypatch.setenv("PATH", str(tmp_path))
    assert compiler_module.find_mona() is None


def _fallback_warnings(caught: list[warnings.WarningMessage]) -> list[str]:
    return [str(w.message) for w in caught if issubclass(w.category, BackendFallbackWarning)]


def test_said_once_for_two_compilations_with_the_fix(no_mona: None) -> None:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        first = compile_ltlf("F(a & b)", ["a", "b"], cache=False)
        second = compile_ltlf("G(a -> X(b))", ["a", "b"], cache=False)
    (message,) = _fallback_warnings(caught)
    assert "MONA is not installed" in message and "pure-Python" in message
    assert "apt-get install mona" in message and "make mona" in message
    # The pure-Python backend compiled both: the same DFAs it gives by name.
    assert (
        first.n_states == compile_ltlf("F(a & b)", ["a", "b"], backend="bdd", cache=False).n_states
    )
    assert second.accepts([{"a": True}, {"b": True}])
    assert not second.accepts([{"a": True}, {"b": False}])
    # The warning points at the caller, not at the compiler's own code.
    (warning,) = [w for w in caught if issubclass(w.category, BackendFallbackWarning)]
    assert warning.filename == __file__


def test_said_once_also_when_the_dfa_comes_from_the_cache(no_mona: None, tmp_path: Path) -> None:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        for _ in range(2):
            compile_ltlf("F(a)", ["a"], cache=tmp_path / "cache")
    assert len(_fallback_warnings(caught)) == 1


def test_nothing_said_for_the_bdd_backend_asked_for_by_name(no_mona: None) -> None:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        compile_ltlf("F(a)", ["a"], backend="bdd", cache=False)
    assert _fallback_warnings(caught) == []


@needs_mona
def test_nothing_said_with_mona_installed(
    unannounced: None, capsys: pytest.CaptureFixture[str]
) -> None:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        compile_ltlf("F(a & b)", ["a", "b"], cache=False)
        compile_ltlf("G(a -> X(b))", ["a", "b"], cache=False)
    assert _fallback_warnings(caught) == []
    assert capsys.readouterr() == ("", "")


def test_the_cli_prints_one_plain_line_without_mona(tmp_path: Path) -> None:
    """``noisybolt check`` on two specs, in a process with no ``mona`` on PATH: one line
    "noisybolt check: warning: MONA is not installed ...", and both specs checked."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONWARNINGS"}
    env.update(PATH=str(tmp_path), NOISYBOLT_CACHE_DIR=str(tmp_path / "cache"))
    done = subprocess.run(
        [sys.executable, "-m", "noisybolt", "check", "--spec", "F(top_right_corner)",
         "--spec", "F(top_right_corner) & G(on_edge)"],
        cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stdout + done.stderr
    said = [line for line in done.stderr.splitlines() if "MONA is not installed" in line]
    assert len(said) == 1, done.stderr
    assert said[0].startswith("noisybolt check: warning: MONA is not installed")
    assert done.stdout.count("satisfiable") >= 2
