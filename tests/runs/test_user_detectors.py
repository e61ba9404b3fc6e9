"""A user's own detector: matched to the world's fluents by name, and made from a factory
path by ``noisybolt train --detector module:function`` (recorded, so resume rebuilds it)."""

from __future__ import annotations

import json
import re
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from noisybolt.cli import main
from noisybolt.envs.gridworld import GridworldEnv
from noisybolt.errors import (
    ConfigError,
    DetectorFactoryError,
    IncompatibleError,
    UnknownNameError,
)
from noisybolt.perception.detectors import (
    FluentsByName,
    SyntheticDetector,
    match_fluents,
)
from noisybolt.runs import DetectorConfig
from noisybolt.runs.detectors import user_detector
from noisybolt.runs.specs import resolve_spec
from noisybolt.wrappers import RestrainingBoltWrapper

SPECS = [resolve_spec("edge"), resolve_spec("one_corner_once")]


class Reversed:
    """A synthetic detector that names the world's fluents in reverse order."""

    needs_truth = True

    def __init__(self, fluent_names: tuple[str, ...], seed: int) -> None:
        self.inner = SyntheticDetector(fluent_names, seed=seed)
        self.fluent_names = tuple(reversed(fluent_names))

    def reseed(self, seed: int) -> None:  # as the bolts call it on reset(seed=)
        self.inner.reseed(seed)

    def predict(self, images: np.ndarray, *, truth: np.ndarray | None = None) -> Any:
        assert truth is not None  # handed in this detector's own (reversed) order
        return self.inner.predict(images, truth=truth[:, ::-1])[:, ::-1]


class ByImage:
    """Reads no truth; names one fluent the world lacks, which is ignored."""

    needs_truth = False

    def __init__(self, fluent_names: tuple[str, ...]) -> None:
        self.fluent_names = ("sky_visible", *fluent_names)

    def predict(self, images: np.ndarray, *, truth: np.ndarray | None = None) -> Any:
        assert truth is None
        n = len(self.fluent_names)
        return np.tile(np.linspace(0.0, 1.0, n), (len(images), 1))


def test_a_reordered_detector_bolts_as_the_exact_one_does() -> None:
    # Same seeds, same actions: the same probabilities, DFA states and rewards.
    fluents = GridworldEnv().fluent_names
    exact = RestrainingBoltWrapper(GridworldEnv(), SPECS, SyntheticDetector(fluents, seed=3))
    matched = RestrainingBoltWrapper(GridworldEnv(), SPECS, Reversed(fluents, seed=3))
    assert isinstance(matched._detector, FluentsByName)
    (_, a), (_, b) = exact.reset(seed=5), matched.reset(seed=5)
    np.testing.assert_array_equal(a["fluent_probs"], b["fluent_probs"])
    rng = np.random.default_rng(0)
    for _ in range(40):
        action = int(rng.integers(4))
        ra, rb = exact.step(action), matched.step(action)
        assert ra[1:4] == rb[1:4]
        for key in ("fluent_probs", "dfa_states"):
            np.testing.assert_array_equal(ra[4][key], rb[4][key])
        if ra[2] or ra[3]:
            exact.reset(seed=6), matched.reset(seed=6)


def test_extra_fluents_are_ignored_unless_the_detector_reads_their_truth() -> None:
    fluents = GridworldEnv().fluent_names
    matched = match_fluents(ByImage(fluents), fluents)
    probs = matched.predict(np.zeros((2, 4, 4, 3), np.uint8))
    np.testing.assert_allclose(probs, np.tile(np.linspace(0, 1, len(fluents) + 1)[1:], (2, 1)))
    reader = SyntheticDetector(("sky_visible", *fluents), seed=0)
    with pytest.raises(IncompatibleError, match=r"reads the ground truth of \['sky_visible'\]"):
        match_fluents(reader, fluents)


def test_a_detector_lacking_a_world_fluent_is_refused_naming_it() -> None:
    fluents = GridworldEnv().fluent_names
    partial = SyntheticDetector(fluents[1:], seed=0)
    with pytest.raises(IncompatibleError, match=re.escape(f"it lacks [{fluents[0]!r}]")):
        RestrainingBoltWrapper(GridworldEnv(), SPECS, partial)


DETECTORS = """
import numpy as np
from noisybolt.perception.detectors import SyntheticDetector

calls = []

def by_names(fluent_names):
    calls.append(("by_names", tuple(fluent_names)))
    return SyntheticDetector(fluent_names, seed=0)

class Seeded:
    def __init__(self, fluent_names, seed):
        calls.append(("Seeded", seed))
        self.inner = SyntheticDetector(tuple(reversed(fluent_names)), seed=seed)
        self.fluent_names = self.inner.fluent_names
        self.needs_truth = True
        self.training_prior = 0.3

    def predict(self, images, *, truth=None):
        return self.inner.predict(images, truth=truth)

def everything(**kwargs):
    calls.append(("everything", sorted(kwargs)))
    return SyntheticDetector(kwargs["fluent_names"], seed=kwargs["seed"])

def not_a_detector():
    return 42

def broken(fluent_names):
    raise RuntimeError("no sensor attached")

class Thresholded(Seeded):
    def __init__(self, fluent_names, seed, threshold):
        super().__init__(fluent_names, seed)
        calls.append(("Thresholded", threshold))
"""


def test_a_factory_is_called_with_the_keywords_it_names(
    world_module: Callable[[str, str], str],
) -> None:
    name = world_module("userdetectors", DETECTORS)
    fluents = GridworldEnv().fluent_names
    made = {
        f: user_detector(f"{name}:{f}", fluent_names=fluents, camera_spec=None, seed=7)
        for f in ("by_names", "Seeded", "everything")
    }
    import userdetectors  # type: ignore[import-not-found]

    assert userdetectors.calls == [
        ("by_names", fluents),
        ("Seeded", 7),
        ("everything", ["camera_spec", "fluent_names", "seed"]),
    ]
    assert all(d.fluent_names == fluents for d in made.values())
    assert isinstance(made["Seeded"], FluentsByName) and made["Seeded"].training_prior == 0.3
    with pytest.raises(DetectorFactoryError, match="returned 'int', not a fluent detector"):
        user_detector(f"{name}:not_a_detector", fluent_names=fluents, camera_spec=None, seed=0)
    with pytest.raises(DetectorFactoryError, match="RuntimeError: no sensor attached"):
        user_detector(f"{name}:broken", fluent_names=fluents, camera_spec=None, seed=0)
    with pytest.raises(DetectorFactoryError, match="has no function 'missing'"):
        user_detector(f"{name}:missing", fluent_names=fluents, camera_spec=None, seed=0)
    # Other arguments come from detector.kwargs; none the factory lacks, none of its own.
    made = user_detector(
        f"{name}:Thresholded", fluent_names=fluents, camera_spec=None, seed=1,
        kwargs={"threshold": 0.3},
    )  # fmt: skip
    assert userdetectors.calls[-1] == ("Thresholded", 0.3) and made.fluent_names == fluents
    with pytest.raises(DetectorFactoryError, match="takes no keyword 'gain'"):
        user_detector(f"{name}:Thresholded", fluent_names=fluents, camera_spec=None, seed=1,
                      kwargs={"threshold": 0.3, "gain": 2})  # fmt: skip
    with pytest.raises(DetectorFactoryError, match="would replace what the run hands"):
        user_detector(f"{name}:everything", fluent_names=fluents, camera_spec=None, seed=1,
                      kwargs={"seed": 3})  # fmt: skip
    with pytest.raises(DetectorFactoryError, match=r"detector\.kwargs \(--set detector\.kwargs"):
        user_detector(f"{name}:Thresholded", fluent_names=fluents, camera_spec=None, seed=1)
    with pytest.raises(ConfigError, match="the oracle detector takes none"):
        DetectorConfig(kind="oracle", kwargs={"threshold": 0.3})
    with pytest.raises(UnknownNameError, match=r"factory path 'package\.module:function'"):
        DetectorConfig(kind="user-detectors:by_names")


def test_train_and_resume_rebuild_the_users_detector(
    world_module: Callable[[str, str], str], tmp_path: Path
) -> None:
    name = world_module("userdetectors", DETECTORS)
    out = tmp_path / "run"
    argv = ["train", "--spec", "edge", "--detector", f"{name}:Seeded", "--seed", "4"]
    argv += ["--eval-freq", "0", "--eval-episodes", "1", "--set", "world.n_envs=2"]
    assert main([*argv, "--frames", "64", "--no-progress", "--out", str(out)]) == 0
    assert json.loads((out / "config.json").read_text())["detector"]["kind"] == f"{name}:Seeded"
    import userdetectors

    assert ("Seeded", 4) in userdetectors.calls
    userdetectors.calls.clear()
    resume = ["train", "--out", str(out), "--resume", "--frames", "128", "--no-progress"]
    assert main(resume) == 2  # the run names code: followed only with the user's word
    assert not userdetectors.calls
    assert main([*resume, "--trust-code"]) == 0
    assert userdetectors.calls and userdetectors.calls[0] == ("Seeded", 4)
    started = json.loads((out / "versions.json").read_text())  # the start, then the resume
    assert [r["frames"] for r in started] == [0, 64]
    assert "--resume" in started[1]["command"] and "--resume" not in started[0]["command"]
    # command.txt keeps the command that set the run up (the resume's says only --resume)
    assert f"--detector {name}:Seeded" in (out / "command.txt").read_text()


def test_a_detector_the_bolt_cannot_call_is_refused_saying_how_to_write_it() -> None:
    fluents = GridworldEnv().fluent_names

    class NoTruth:
        fluent_names = fluents
        needs_truth = False

        def predict(self, images: np.ndarray) -> np.ndarray:
            return np.zeros((len(images), len(fluents)))

    class OneString(NoTruth):
        fluent_names = "on_edge"  # type: ignore[assignment]

    with pytest.raises(IncompatibleError, match=r"predict\(self, images, \*, truth=None\)"):
        match_fluents(NoTruth(), fluents)
    with pytest.raises(IncompatibleError, match="must be a sequence of names"):
        match_fluents(OneString(), fluents)
