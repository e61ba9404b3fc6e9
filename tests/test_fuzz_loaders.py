"""Every loader of a run's files, fuzzed (issue 46): whatever a file holds, loading it
returns what it describes or raises a named error (:class:`~noisybolt.errors.NoisyboltError`:
``ConfigError`` or its kin), which the command line turns into exit 2 with a sentence;
never another exception (a traceback), and nothing is written.

The loaders: ``config.json`` (schema 2 and the flat form of older runs), specs files,
sweep files, ``--set PATH=VALUE``, ``checkpoints/latest.json`` and classifier files.
Each is fed documents mutated from a valid one (a value replaced by another of any JSON
type, a key removed or added) and arbitrary data. The default suite runs a few hundred
cases per loader (:data:`FAST`); ``make test-slow`` runs 10,000 per loader (:data:`SLOW`).
"""

from __future__ import annotations

import copy
import json
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
import yaml
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from noisybolt.errors import NoisyboltError

ROOT = Path(__file__).resolve().parents[1]
_QUIET = [HealthCheck.too_slow, HealthCheck.function_scoped_fixture, HealthCheck.data_too_large]
settings.register_profile(
    "fuzz", max_examples=200, deadline=None, suppress_health_check=_QUIET, derandomize=True
)
settings.register_profile("fuzz-slow", settings.get_profile("fuzz"), max_examples=10_000)
#: The default suite's cases per loader; :data:`SLOW`: the slow suite's.
FAST = settings(settings.get_profile("fuzz"))
SLOW = settings(settings.get_profile("fuzz-slow"))


# ------------------------------------------------------------------ strategies
_SCALARS = (
    st.none()
    | st.booleans()
    | st.integers(min_value=-(2**70), max_value=2**70)
    | st.sampled_from([0, 1, -1, 2, 64, 2**31, 2**63, 10**9])
    | st.floats(allow_nan=True, allow_infinity=True)
    | st.text(max_size=12)
    | st.sampled_from(
        [
            "",
            "gridworld",
            "oracle",
            "ppo",
            "dqn",
            "belief",
            "compliance",
            "paper",
            "edge",
            "F(on_edge)",
            "G(!(",
            "step_512",
            "../x",
            "a\x00b",
            "1e400",
            "m:f",
            "os:system",
        ]
    )
)
JSON = st.recursive(
    _SCALARS,
    lambda inner: (
        st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=10), inner, max_size=3)
    ),
    max_leaves=6,
)


def _places(doc: Any, path: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    """Every path to a value inside ``doc`` (dict keys and list indices), ``()`` for it."""
    out = [path]
    if isinstance(doc, dict):
        for key, value in doc.items():
            out += _places(value, (*path, key))
    elif isinstance(doc, list):
        for i, value in enumerate(doc):
            out += _places(value, (*path, i))
    return out


@st.composite
def mutated(draw: st.DrawFn, base: Any, *, max_changes: int = 3) -> Any:
    """``base`` with one to ``max_changes`` changes: a value replaced by any JSON value, a
    key removed, or an unknown key added."""
    doc = copy.deepcopy(base)
    for _ in range(draw(st.integers(1, max_changes))):
        path = draw(st.sampled_from(_places(doc)))
        if not path:
            return draw(JSON)
        parent = doc
        for step in path[:-1]:
            parent = parent[step]
        action = draw(st.sampled_from(["replace", "replace", "delete", "add"]))
        if action == "replace":
            parent[path[-1]] = draw(JSON)
        elif action == "delete":
            del parent[path[-1]]
        elif isinstance(parent, dict):
            parent[draw(st.text(max_size=10))] = draw(JSON)
        else:
            parent.append(draw(JSON))
    return doc


def _named_or_fine(load: Callable[[], Any]) -> Any:
    """``load()``'s value, or None where it raised a named error; anything else fails."""
    try:
        return load()
    except NoisyboltError:
        return None


def _snapshot(folder: Path) -> dict[str, bytes]:
    return {str(p): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


# ------------------------------------------------------------------ config.json
def _nested_base() -> list[dict[str, Any]]:
    from noisybolt.runs.config import TrainConfig

    base = {"bolt.specs": ["edge"], "detector.kind": "oracle", "frames": 4096}
    base |= {"evaluation.freq": 2048}
    return [
        TrainConfig.build({**base, "bolt.reward": "paper"}).to_dict(),
        TrainConfig.build(
            {**base, "algorithm.name": "dqn", "bolt.tracking": "belief", "bolt.reward": "paper"}
        ).to_dict(),
    ]


_FLAT = ROOT / "results/spec_suite/trials/compliance/a2c/s03-precedence-before/seed0/config.json"
CONFIGS = [*_nested_base(), json.loads(_FLAT.read_text())]


def _load_config(doc: Any, folder: Path) -> None:
    from noisybolt.runs.config import TrainConfig
    from noisybolt.runs.rundir import RunDirectory
    from noisybolt.runs.trust import code_references

    code_references(doc)  # never raises: whatever is not a config names no code
    before = _snapshot(folder)
    run = RunDirectory(folder)
    (folder / "config.json").write_text(json.dumps(doc))
    _named_or_fine(lambda: TrainConfig.from_dict(run.read_config()))
    assert _snapshot(folder) == {**before, **_snapshot(folder)}  # only the file written


config_docs = st.sampled_from(CONFIGS).flatmap(mutated) | JSON


@FAST
@given(doc=config_docs)
def test_config_json(doc: Any, tmp_path: Path) -> None:
    _load_config(doc, tmp_path)


@pytest.mark.slow
@SLOW
@given(doc=config_docs)
def test_config_json_slow(doc: Any, tmp_path: Path) -> None:
    _load_config(doc, tmp_path)


@FAST
@given(data=st.binary(max_size=64) | st.text(max_size=64).map(str.encode))
def test_config_json_bytes(data: bytes, tmp_path: Path) -> None:
    from noisybolt.runs.config import TrainConfig
    from noisybolt.runs.rundir import RunDirectory

    (tmp_path / "config.json").write_bytes(data)
    _named_or_fine(lambda: TrainConfig.from_dict(RunDirectory(tmp_path).read_config()))


# ------------------------------------------------------------------ specs files
SPECS_FILE = {
    "specs": [
        "edge",
        {"formula": "F(top_right_corner)", "name": "corner", "reward_scale": 500},
        {"formula": "!F(bottom_left_corner)", "low_confidence_cost": 2.0},
    ]
}
specs_docs = mutated(SPECS_FILE).map(yaml.safe_dump) | st.text(max_size=80)


def _load_specs(text: str, folder: Path) -> None:
    from noisybolt.runs.config import TrainConfig
    from noisybolt.runs.specs import load_specs_file

    path = folder / "specs.yaml"
    path.write_text(text)
    specs = _named_or_fine(lambda: load_specs_file(path))
    if specs is not None:  # then the run the CLI builds from them
        _named_or_fine(lambda: TrainConfig.build({"bolt.specs": specs, "bolt.reward": "paper"}))


@FAST
@given(text=specs_docs)
@example(text="specs:\n- name: []\n  reward_scale: 500\n")  # found: TypeError
@example(text="specs:\n- {null: 1, formula: F(a)}\n")
def test_specs_file(text: str, tmp_path: Path) -> None:
    _load_specs(text, tmp_path)


@pytest.mark.slow
@SLOW
@given(text=specs_docs)
def test_specs_file_slow(text: str, tmp_path: Path) -> None:
    _load_specs(text, tmp_path)


# ------------------------------------------------------------------ sweep files
SWEEP_FILE = {
    "name": "fuzz",
    "base": {"detector": {"kind": "oracle"}, "frames": 4096, "specs": ["edge"], "reward": "paper"},
    "rows": [{"name": "a2c", "algo": "a2c"}],
    "seeds": [3],
    "settings": {"bolt.tracking": ["belief"]},
    "final_eval_episodes": 4,
}
sweep_docs = mutated(SWEEP_FILE).map(yaml.safe_dump) | st.text(max_size=80)


def _load_sweep(text: str, folder: Path) -> None:
    from noisybolt.experiments.sweeps import load_sweep

    path = folder / "sweep.yaml"
    path.write_text(text)
    _named_or_fine(lambda: load_sweep(path, check_worlds=False))


@FAST
@given(text=sweep_docs)
@example(text="?")  # found: {None: None} raised TypeError
def test_sweep_file(text: str, tmp_path: Path) -> None:
    _load_sweep(text, tmp_path)


@pytest.mark.slow
@SLOW
@given(text=sweep_docs)
def test_sweep_file_slow(text: str, tmp_path: Path) -> None:
    _load_sweep(text, tmp_path)


# ------------------------------------------------------------------ --set PATH=VALUE
def _paths() -> list[str]:
    from noisybolt.runs.config import schema_paths

    # The world's name and the reward scheme are left alone: a valid one builds a world.
    return [p for p in schema_paths() if p not in ("world.name", "bolt.reward")]


assignments = st.one_of(
    st.tuples(st.sampled_from(_paths()), st.text(max_size=16) | _SCALARS.map(yaml.safe_dump)).map(
        "=".join
    ),
    st.text(max_size=24).filter(lambda t: not t.startswith(("world.name", "bolt.reward"))),
)


def _load_assignment(item: str) -> None:
    from noisybolt.cli.train import config_assignments
    from noisybolt.runs.config import TrainConfig

    given_ = _named_or_fine(lambda: config_assignments([("--set", item)]))
    if given_ is not None and not {"world.name", "bolt.reward"} & set(given_):
        base = {"bolt.specs": ["edge"], "bolt.reward": "paper", "detector.kind": "oracle"}
        _named_or_fine(lambda: TrainConfig.build({**base, **given_}))


@FAST
@given(item=assignments)
def test_set_assignment(item: str) -> None:
    _load_assignment(item)


@pytest.mark.slow
@SLOW
@given(item=assignments)
def test_set_assignment_slow(item: str) -> None:
    _load_assignment(item)


# ------------------------------------------------------------------ checkpoints/latest.json
@pytest.fixture(scope="module")
def checkpointed(tmp_path_factory: pytest.TempPathFactory) -> Path:
    run = tmp_path_factory.mktemp("checkpointed")
    folder = run / "checkpoints" / "step_512"
    folder.mkdir(parents=True)
    (folder / "model.zip").write_bytes(b"PK")
    (folder / "state.json").write_text('{"frames": 512}')
    return run


LATEST = {"folder": "step_512", "frames": 512}
latest_docs = mutated(LATEST) | JSON


def _load_latest(doc: Any, run: Path) -> None:
    from noisybolt.runs.checkpoints import latest_checkpoint
    from noisybolt.runs.rundir import RunDirectory

    (run / "checkpoints" / "latest.json").write_text(json.dumps(doc))
    before = _snapshot(run)
    _named_or_fine(lambda: latest_checkpoint(RunDirectory(run)))
    assert _snapshot(run) == before


@FAST
@given(doc=latest_docs)
@example(doc={"folder": "step_512\x00", "frames": 512})  # found: ValueError
def test_latest_checkpoint(doc: Any, checkpointed: Path) -> None:
    _load_latest(doc, checkpointed)


@pytest.mark.slow
@SLOW
@given(doc=latest_docs)
def test_latest_checkpoint_slow(doc: Any, checkpointed: Path) -> None:
    _load_latest(doc, checkpointed)


# ------------------------------------------------------------------ classifier files
@pytest.fixture(scope="module")
def classifier(tmp_path_factory: pytest.TempPathFactory) -> tuple[dict[str, Any], Any, bytes]:
    """A valid classifier file's noisybolt header, its tensors and its bytes."""
    import torch

    from noisybolt.perception.classifier import ClassifierConfig, ClassifierDetector
    from noisybolt.perception.protocols import CameraSpec

    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(0)
        detector = ClassifierDetector.untrained(
            fluent_names=("a", "b"),
            camera_spec=CameraSpec("toy", 12, 10),
            config=ClassifierConfig(channels=(4, 8)),
        )
    path = tmp_path_factory.mktemp("classifier") / "c.safetensors"
    detector.save(path)
    data = path.read_bytes()
    (length,) = __import__("struct").unpack("<Q", data[:8])
    header = json.loads(json.loads(data[8 : 8 + length])["__metadata__"]["noisybolt"])
    from safetensors.torch import load as load_tensors

    return header, load_tensors(data), data


@st.composite
def classifier_bytes(draw: st.DrawFn, valid: tuple[dict[str, Any], Any, bytes]) -> bytes:
    header, tensors, data = valid
    how = draw(st.sampled_from(["header", "header", "bytes", "truncate"]))
    if how == "header":  # the weights and their digest kept: the header's fields fuzzed
        from safetensors.torch import save

        doc = draw(mutated(header))
        text = json.dumps(doc) if not isinstance(doc, str) or draw(st.booleans()) else doc
        return bytes(save(tensors, metadata={"noisybolt": text}))
    if how == "truncate":
        return data[: draw(st.integers(0, len(data)))]
    out = bytearray(data)
    for _ in range(draw(st.integers(1, 4))):
        out[draw(st.integers(0, len(out) - 1))] = draw(st.integers(0, 255))
    return bytes(out)


def _load_classifier(data: bytes, folder: Path) -> None:
    from noisybolt.perception.classifier import load_classifier
    from noisybolt.perception.protocols import CameraSpec

    path = folder / "c.safetensors"
    path.write_bytes(data)
    detector = _named_or_fine(lambda: load_classifier(path))
    if detector is not None:  # then as a run reads it: checked against its world
        _named_or_fine(
            lambda: load_classifier(
                path, fluent_names=("a", "b"), camera_spec=CameraSpec("toy", 12, 10)
            )
        )


def test_classifier_file(classifier: tuple[dict[str, Any], Any, bytes], tmp_path: Path) -> None:
    from safetensors.torch import save

    header, tensors, _ = classifier
    found = {**header, "fluent_names": [[], "b"]}  # found: TypeError past the load's check

    @FAST
    @given(data=classifier_bytes(classifier))
    @example(data=bytes(save(tensors, metadata={"noisybolt": json.dumps(found)})))
    def check(data: bytes) -> None:
        _load_classifier(data, tmp_path)

    check()


@pytest.mark.slow
def test_classifier_file_slow(
    classifier: tuple[dict[str, Any], Any, bytes], tmp_path: Path
) -> None:
    @SLOW
    @given(data=classifier_bytes(classifier))
    def check(data: bytes) -> None:
        _load_classifier(data, tmp_path)

    check()


# ------------------------------------------------------------------ the command line
@pytest.mark.parametrize(
    "case",
    ["config.json", "specs file", "sweep file", "--set", "latest.json", "classifier file"],
)
def test_the_command_line_says_exit_2_for_each_loader(
    case: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from noisybolt.cli import main

    run = tmp_path / "run"
    run.mkdir()
    train = ["train", "--spec", "edge", "--detector", "oracle", "--reward", "paper"]
    if case == "config.json":
        (run / "config.json").write_text('{"world": {"name": 3}, "frames": NaN}')
        argv = ["evaluate", str(run)]
    elif case == "specs file":
        (tmp_path / "s.yaml").write_text("specs: [{formula: 3, colour: red}]")
        argv = [*train, "--specs-file", str(tmp_path / "s.yaml"), "--out", str(run / "new")]
    elif case == "sweep file":
        (tmp_path / "w.yaml").write_text("rows: {name: 3}\nseeds: -1")
        argv = ["sweep", str(tmp_path / "w.yaml"), "--out", str(run / "new")]
    elif case == "--set":
        argv = [*train, "--set", "algorithm.hyperparams.gamma=[1, {}]", "--out", str(run / "new")]
    elif case == "latest.json":
        (run / "config.json").write_text(json.dumps(CONFIGS[0]))
        (run / "checkpoints").mkdir()
        (run / "checkpoints" / "latest.json").write_text('{"folder": "a\\u0000b", "frames": 1}')
        argv = ["train", "--out", str(run), "--resume", "--frames", "8192", "--no-progress"]
    else:
        (tmp_path / "c.safetensors").write_bytes(b"\x10\x00\x00\x00\x00\x00\x00\x00{}")
        argv = [*train, "--detector", "classifier", "--classifier", str(tmp_path / "c.safetensors")]
        argv += ["--frames", "4096", "--out", str(run / "new")]
    before = _snapshot(tmp_path)
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "error:" in err and "Traceback" not in err
    assert _snapshot(tmp_path) == before
    assert math.isfinite(len(err))
