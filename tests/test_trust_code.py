"""A shared run is data (issue 46): the code a run directory names is not followed when
the run is loaded, unless the user says so.

Each door that loads a run (``evaluate``, ``train --resume``, a sweep's resume,
``report``, their Python functions) is tried with the issue's payloads: a detector factory
path ``os:system`` whose keywords are a shell command, and a world factory path to a
module placed in the current directory that writes a file when imported. Without consent
nothing runs and nothing is written; with consent (``--trust-code``, ``trust_code=True``,
or the same reference given again) the run behaves as before the issue.
"""

from __future__ import annotations

import json
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from noisybolt.cli import main
from noisybolt.errors import ConfigError, DetectorFactoryError, UntrustedCodeError
from noisybolt.runs.config import TrainConfig
from noisybolt.runs.rundir import RunDirectory
from noisybolt.runs.trust import check_code_trusted, code_references


def _saved_config() -> dict[str, object]:
    config = TrainConfig.build(
        {
            "bolt.specs": ["edge"],
            "bolt.reward": "paper",
            "detector.kind": "oracle",
            "frames": 1024,
            "world.n_envs": 2,
            "algorithm.hyperparams.n_steps": 64,
            "evaluation.freq": 0,
        }
    )
    return config.to_dict()


def _snapshot(folder: Path) -> dict[str, bytes]:
    return {
        str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()
    }


class Payload:
    """A run directory whose config names code, and the file that code would write."""

    def __init__(self, root: Path, kind: str) -> None:
        self.root, self.kind = root, kind
        self.marker = root / "pwned"
        self.run = root / "run"
        self.run.mkdir()
        data = _saved_config()
        if kind == "detector":
            self.reference = "os:system"
            data["detector"] = {
                **data["detector"],  # type: ignore[dict-item]
                "kind": self.reference,
                "kwargs": {"command": f"touch {self.marker}"},
            }
            self.flag = ["--detector", self.reference]
        else:
            # A module beside the run, found through the current directory: importing it
            # is enough to run it.
            module = f"evilworld_{abs(hash(str(root))) % 10**8}"
            (root / f"{module}.py").write_text(
                f"open({str(self.marker)!r}, 'w').write('imported')\n"
                "def make():\n    raise RuntimeError('the factory ran')\n"
            )
            self.reference = f"{module}:make"
            data["world"] = {**data["world"], "name": self.reference}  # type: ignore[dict-item]
            self.flag = ["--world", self.reference]
        RunDirectory(self.run).write_config(data)
        self.data = data
        (self.run / "checkpoints").mkdir()
        (self.run / "checkpoints" / "latest.json").write_text('{"folder": "step_512"}')
        self.before = _snapshot(self.root)

    def untouched(self) -> bool:
        """Nothing ran (no marker) and nothing was written anywhere under the root."""
        return not self.marker.exists() and _snapshot(self.root) == self.before


@pytest.fixture(params=["detector", "world"])
def payload(
    request: pytest.FixtureRequest, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> Iterator[Payload]:
    # Run from the folder holding the run (and the world's module), as a user would.
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(sys, "path", [p for p in sys.path if p not in ("", str(tmp_path))])
    yield Payload(tmp_path, request.param)


# ------------------------------------------------------------------ refused without consent
def test_evaluate_refuses_naming_each_reference_and_how_to_consent(
    payload: Payload, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["evaluate", str(payload.run), "--episodes", "2"]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    assert repr(payload.reference) in err
    assert "--trust-code" in err and " ".join(payload.flag) in err
    assert payload.untouched()
    assert str(payload.root) not in sys.path  # the current directory was not searched


def test_resume_refuses_before_anything_runs(
    payload: Payload, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = ["train", "--out", str(payload.run), "--resume", "--frames", "2048", "--no-progress"]
    assert main(argv) == 2
    assert repr(payload.reference) in capsys.readouterr().err
    assert payload.untouched()


def test_the_python_doors_refuse_with_a_named_error(payload: Payload) -> None:
    from noisybolt.runs import train
    from noisybolt.runs.run_evaluation import evaluate_run

    with pytest.raises(UntrustedCodeError, match="trust_code=True") as info:
        evaluate_run(payload.run, episodes=2)
    assert info.value.references == (f"{_path(payload)} = {payload.reference!r}",)
    with pytest.raises(UntrustedCodeError):
        TrainConfig.resumed(payload.data, {"frames": 2048})
    # A resume of a run whose config was swapped for one naming code: refused while
    # comparing, before the saved config is loaded.
    config = TrainConfig.from_dict(_saved_config())
    with pytest.raises(UntrustedCodeError):
        train(config, payload.run, resume=True, log=lambda _: None)
    assert payload.untouched()


def test_a_sweeps_resume_refuses_a_trial_directory_naming_code(payload: Payload) -> None:
    from noisybolt.experiments.sweeps import SweepConfig, run_sweep

    base = {"detector": {"kind": "oracle"}, "frames": 1024, "specs": ["edge"], "reward": "paper"}
    sweep = SweepConfig.from_dict(
        {"base": base, "rows": [{"name": "ppo", "algo": "ppo"}], "seeds": 1},
        name="s",
        check_worlds=False,
    )
    (trial,) = sweep.trials
    folder = payload.root / "sweep" / "trials" / trial.trial_id
    folder.mkdir(parents=True)
    for name in ("config.json", "checkpoints"):
        (payload.run / name).rename(folder / name)
    payload.before = _snapshot(payload.root)
    with pytest.raises(UntrustedCodeError):
        run_sweep(sweep, payload.root / "sweep", log=lambda _: None)
    assert payload.untouched()


def test_report_follows_no_code(payload: Payload, capsys: pytest.CaptureFixture[str]) -> None:
    # A config that could only load by building its world (the compliance scale left to
    # be computed from it): the report reads it as data all the same.
    data = json.loads((payload.run / "config.json").read_text())
    data["bolt"] = {**data["bolt"], "reward": "compliance", "reward_scale": None}
    (payload.run / "config.json").write_text(json.dumps(data))
    main(["report", str(payload.run), "--no-html"])
    assert "Traceback" not in capsys.readouterr().err
    assert not payload.marker.exists()


def test_a_module_beside_the_run_is_not_imported_by_a_new_process(tmp_path: Path) -> None:
    # `python -m` puts the current directory on sys.path itself: still nothing is imported.
    payload = Payload(tmp_path, "world")
    done = subprocess.run(
        [sys.executable, "-m", "noisybolt", "evaluate", "run", "--episodes", "2"],
        cwd=payload.root,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 2, done.stderr
    assert "UntrustedCodeError" not in done.stderr and "--trust-code" in done.stderr
    assert payload.untouched()


# ------------------------------------------------------------------ followed with consent
@pytest.mark.parametrize("consent", ["--trust-code", "the same reference"])
def test_with_consent_the_code_is_followed_as_before(
    payload: Payload, consent: str, capsys: pytest.CaptureFixture[str]
) -> None:
    extra = ["--trust-code"] if consent == "--trust-code" else payload.flag
    assert main(["evaluate", str(payload.run), "--episodes", "2", *extra]) == 2
    err = capsys.readouterr().err
    assert payload.marker.exists()  # what the issue saw: the code ran
    if payload.kind == "detector":
        assert "returned 'int', not a fluent detector" in err
    else:
        assert "the factory raised RuntimeError: the factory ran" in err


def test_resume_with_consent_follows_the_code(
    payload: Payload, capsys: pytest.CaptureFixture[str]
) -> None:
    # As before the issue: the world is built (its module imported) before the checkpoint
    # is read; the detector after it (and this run holds no checkpoint).
    argv = ["train", "--out", str(payload.run), "--resume", "--frames", "2048", "--no-progress"]
    for consent in (["--trust-code"], payload.flag):
        assert main([*argv, *consent]) == 2
        err = capsys.readouterr().err
        if payload.kind == "world":
            assert "the factory raised RuntimeError" in err and payload.marker.exists()
        else:
            assert "latest.json is corrupt" in err


def test_the_python_api_consents_with_trust_code(payload: Payload) -> None:
    from noisybolt.runs.run_evaluation import evaluate_run

    with pytest.raises(ConfigError) as info:
        evaluate_run(payload.run, episodes=2, trust_code=True)
    assert not isinstance(info.value, UntrustedCodeError)
    assert payload.marker.exists()
    if payload.kind == "detector":
        assert isinstance(info.value, DetectorFactoryError)


# ------------------------------------------------------------------ the references
def _path(payload: Payload) -> str:
    return "detector.kind" if payload.kind == "detector" else "world.name"


@pytest.mark.parametrize(
    ("data", "expected"),
    [
        ({"world": {"name": "gridworld"}, "detector": {"kind": "oracle"}}, []),
        ({"world": {"name": "m:f"}, "detector": {"kind": "d:g"}}, ["world.name", "detector.kind"]),
        ({"world": "pkg.mod:make", "algo": "ppo"}, ["world.name"]),  # a legacy flat config
        ({"world": {"name": 3}, "detector": ["x:y"]}, []),  # not a config: loading says why
        ("not a mapping", []),
    ],
)
def test_code_references_are_read_from_both_forms(data: object, expected: list[str]) -> None:
    assert [r.path for r in code_references(data)] == expected


def test_a_reference_given_again_with_another_value_is_no_consent() -> None:
    data = {"world": {"name": "mymod:make"}}
    assert check_code_trusted(data, given={"world.name": "mymod:make"})
    with pytest.raises(UntrustedCodeError, match="--world mymod:make"):
        check_code_trusted(data, given={"world.name": "mymod:other"})
    assert check_code_trusted({"world": {"name": "gridworld"}}) == ()


def test_trust_code_is_refused_for_a_new_run(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "run"
    assert main(["train", "--spec", "edge", "--out", str(out), "--trust-code"]) == 2
    assert "--resume" in capsys.readouterr().err
    assert not out.exists()


def test_a_classifier_directorys_world_is_not_followed_unasked(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(sys, "path", [p for p in sys.path if p not in ("", str(tmp_path))])
    payload = Payload(tmp_path, "world")
    folder = payload.root / "classifiers"
    RunDirectory(folder).write_config({"collect": {"world": payload.reference, "samples": 8}})
    payload.before = _snapshot(payload.root)
    assert main(["classifiers", "report", "--out", str(folder)]) == 2
    assert "--trust-code" in capsys.readouterr().err
    assert payload.untouched()
    assert main(["classifiers", "report", "--out", str(folder), "--trust-code"]) == 2
    assert "the factory raised RuntimeError" in capsys.readouterr().err
    assert payload.marker.exists()


def test_the_refusal_lists_every_reference_and_the_flags_that_consent() -> None:
    data = {"world": {"name": "mymod:make"}, "detector": {"kind": "os:system"}}
    with pytest.raises(UntrustedCodeError) as info:
        check_code_trusted(data, source="run r")
    message = str(info.value)
    assert "world.name = 'mymod:make', detector.kind = 'os:system'" in message
    assert "--world mymod:make --detector os:system" in message and "--trust-code" in message
    assert info.value.references == ("world.name = 'mymod:make'", "detector.kind = 'os:system'")
    assert check_code_trusted(data, trust_code=True) == code_references(data)
