"""Starting a run's network from a saved agent (``algorithm.init_from``): the new run's
policy is the saved one's tensor for tensor, it keeps a copy of what it started from, a
resume never reads the source again, a source of other specs starts it playing as the
source did at its specs' start, and a source that does not fit is refused by name."""

from __future__ import annotations

import copy
import io
import json
import shutil
import zipfile
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest
import torch

from noisybolt.errors import ConfigError, CorruptFileError, IncompatibleError, NoCheckpointError
from noisybolt.runs import train, training
from noisybolt.runs.config import RESUMABLE_KEYS, TrainConfig
from noisybolt.runs.legacy import LEGACY_DEFAULTS
from noisybolt.runs.warm_start import (
    INIT_MODEL,
    InitialWeights,
    apply_initial_weights,
    find_initial_model,
    read_initial_weights,
)


def _config(**overrides: object) -> TrainConfig:
    settings = {
        "bolt.specs": ["edge"],
        "detector.kind": "oracle",
        "frames": 256,
        "checkpoint_freq": 128,
        "evaluation.freq": 0,
        "evaluation.episodes": 1,
        "progress_bar": False,
        "algorithm.hyperparams.n_steps": 32,
        **overrides,
    }
    if settings.get("algorithm.name") == "dqn":
        del settings["algorithm.hyperparams.n_steps"]
    return TrainConfig.build(settings)


def _policy(model_zip: Path) -> dict[str, torch.Tensor]:
    with zipfile.ZipFile(model_zip) as archive:
        return torch.load(io.BytesIO(archive.read("policy.pth")), weights_only=True)


def _perturb(model_zip: Path) -> None:
    """Rewrites a saved agent with every weight moved by 0.5 (another agent, same network)."""
    with zipfile.ZipFile(model_zip) as archive:
        entries = {name: archive.read(name) for name in archive.namelist()}
    policy = torch.load(io.BytesIO(entries["policy.pth"]), weights_only=True)
    buffer = io.BytesIO()
    torch.save({k: v + 0.5 if v.is_floating_point() else v for k, v in policy.items()}, buffer)
    entries["policy.pth"] = buffer.getvalue()
    with zipfile.ZipFile(model_zip, "w") as archive:
        for name, content in entries.items():
            archive.writestr(name, content)


def _same(a: dict[str, torch.Tensor], b: dict[str, torch.Tensor]) -> bool:
    return a.keys() == b.keys() and all(torch.equal(a[k], b[k]) for k in a)


@pytest.fixture(scope="module")
def source(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A trained PPO run (gridworld, ``edge``) to start from."""
    out = tmp_path_factory.mktemp("warm") / "source"
    train(_config(), out, log=lambda _: None)
    return out


@pytest.fixture
def started(monkeypatch: pytest.MonkeyPatch) -> list[dict[str, torch.Tensor]]:
    """The policy each training starts to learn with (recorded as ``_learn`` gets it)."""
    seen: list[dict[str, torch.Tensor]] = []
    learn = training._learn

    def spy(config: TrainConfig, run: object, model: Any, *args: Any, **kwargs: Any) -> Any:
        seen.append({k: v.clone() for k, v in model.policy.state_dict().items()})
        return learn(config, run, model, *args, **kwargs)

    monkeypatch.setattr(training, "_learn", spy)
    return seen


@pytest.fixture
def policies(monkeypatch: pytest.MonkeyPatch) -> list[Any]:
    """A copy of the policy each training starts to learn with."""
    seen: list[Any] = []
    learn = training._learn

    def spy(config: TrainConfig, run: object, model: Any, *args: Any, **kwargs: Any) -> Any:
        seen.append(copy.deepcopy(model.policy))
        return learn(config, run, model, *args, **kwargs)

    monkeypatch.setattr(training, "_learn", spy)
    return seen


def _outputs(policy: Any, images: torch.Tensor, states: np.ndarray) -> torch.Tensor:
    """Action probabilities and values of a policy (PPO) or Q-values (DQN)."""
    obs = {"image": images, "dfa": torch.as_tensor(states)}
    with torch.no_grad():
        if hasattr(policy, "q_net"):
            return policy.q_net(obs)
        probs = policy.get_distribution(obs).distribution.probs
        return torch.cat([probs, policy.predict_values(obs)], dim=1)


@pytest.mark.parametrize("algo", ["ppo", "dqn"])
def test_an_agent_of_other_specs_starts_playing_as_the_source_did_at_its_start(
    algo: str, tmp_path: Path, policies: list[Any]
) -> None:
    overrides = {"algorithm.name": algo, "frames": 256}
    source = tmp_path / "source"
    train(_config(**overrides), source, log=lambda _: None)  # specs: G(on_edge)
    # the source's own network, as a run of its specs starts from it (tested above)
    same = _config(**overrides, **{"algorithm.init_from": str(source)})
    train(same, tmp_path / "same", log=lambda _: None)
    theirs = policies[-1]
    lines: list[str] = []
    specs = ["avoid_top_right", "F(top_right_corner) & F(on_edge)"]  # DFAs of 2 and 4 states
    out = tmp_path / "respecified"
    settings = {**overrides, "algorithm.init_from": str(source), "bolt.specs": specs}
    train(_config(**settings), out, log=lines.append)
    mine = policies[-1]
    assert mine.observation_space["dfa"].nvec.tolist() == [2, 4]
    assert theirs.observation_space["dfa"].nvec.tolist() == [2]
    rng = np.random.default_rng(0)
    space = theirs.observation_space["image"]
    images = torch.as_tensor(rng.integers(0, 256, (64, *space.shape)), dtype=torch.float32)
    # G(on_edge)'s DFA: 0 while on the edge (its first state), 1 once it left it (a sink)
    first, left = np.zeros((64, 1), dtype=np.int64), np.ones((64, 1), dtype=np.int64)
    expected = _outputs(theirs, images, first)
    assert not torch.allclose(expected, _outputs(theirs, images, left), atol=1e-4)  # it reads them
    for states in ([0, 0], [1, 3], [0, 2]):  # whatever state the new specs are in
        new_states = np.tile(np.asarray(states, dtype=np.int64), (64, 1))
        assert torch.allclose(_outputs(mine, images, new_states), expected, atol=1e-5)
    assert any("trained with the specs ['G(on_edge)']: it plays as it did" in x for x in lines)
    assert (out / INIT_MODEL).read_bytes() == (source / "model.zip").read_bytes()
    assert not _same(_policy(out / "model.zip"), _policy(source / "model.zip"))


def test_a_run_starts_from_the_saved_policy_and_keeps_a_copy(
    source: Path, tmp_path: Path, started: list[dict[str, torch.Tensor]]
) -> None:
    lines: list[str] = []
    out = tmp_path / "fine-tuned"
    config = _config(**{"algorithm.init_from": str(source), "seed": 7})
    result = train(config, out, log=lines.append)
    saved = _policy(source / "model.zip")
    assert _same(started[-1], saved)
    assert not _same(_policy(out / "model.zip"), saved)  # and then it learnt
    assert (out / INIT_MODEL).read_bytes() == (source / "model.zip").read_bytes()
    assert result.frames == 256  # its own frames, from 0
    assert json.loads((out / "config.json").read_text())["algorithm"]["init_from"] == str(source)
    assert any(f"starts from {source / 'model.zip'} (a PPO agent trained 256" in x for x in lines)
    # without it, the same settings start from the seed's random weights
    plain = tmp_path / "plain"
    train(_config(**{"seed": 7}), plain, log=lambda _: None)
    assert not _same(started[-1], saved)
    assert not (plain / INIT_MODEL).exists()


def test_a_running_source_gives_its_latest_checkpoint_and_a2c_starts_from_ppo(
    source: Path, tmp_path: Path, started: list[dict[str, torch.Tensor]]
) -> None:
    running = tmp_path / "running"
    shutil.copytree(source, running)
    (running / "model.zip").unlink()  # as while it trains: checkpoints only
    latest = json.loads((running / "checkpoints" / "latest.json").read_text())["folder"]
    _perturb(running / "checkpoints" / latest / "model.zip")  # not the final model's weights
    assert find_initial_model(running) == running / "checkpoints" / latest / "model.zip"
    assert find_initial_model(running / "checkpoints" / latest) == (
        running / "checkpoints" / latest / "model.zip"
    )
    out = tmp_path / "a2c"
    config = _config(
        **{
            "algorithm.name": "a2c",
            "algorithm.init_from": str(running),
            "algorithm.hyperparams.n_steps": 8,
        }
    )
    train(config, out, log=lambda _: None)
    checkpoint = _policy(running / "checkpoints" / latest / "model.zip")
    assert _same(started[-1], checkpoint)
    assert not _same(checkpoint, _policy(source / "model.zip"))


def test_the_source_is_read_before_the_minutes_of_checks(
    source: Path,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    started: list[dict[str, torch.Tensor]],
) -> None:
    """A checkpoint its run rotates away while the new run checks its bolt (the set-up
    plays the world, may train a classifier) still starts the new run."""
    copy = tmp_path / "source"
    shutil.copytree(source, copy)
    prepare = training.prepare_bolt

    def rotated(*args: Any, **kwargs: Any) -> Any:
        shutil.rmtree(copy)
        return prepare(*args, **kwargs)

    monkeypatch.setattr(training, "prepare_bolt", rotated)
    train(_config(**{"algorithm.init_from": str(copy)}), tmp_path / "run", log=lambda _: None)
    assert _same(started[-1], _policy(source / "model.zip"))


def test_a_resume_never_reads_the_source_again(source: Path, tmp_path: Path) -> None:
    copy = tmp_path / "source"
    shutil.copytree(source, copy)
    out = tmp_path / "run"
    train(_config(**{"algorithm.init_from": str(copy)}), out, log=lambda _: None)
    shutil.rmtree(copy)
    saved = TrainConfig.from_dict(json.loads((out / "config.json").read_text()))
    result = train(saved.override({"frames": 384}), out, resume=True, log=lambda _: None)
    assert result.frames >= 384
    # and a restart forgets the copy of the old source before failing on the missing one
    with pytest.raises(ConfigError, match="does not exist"):
        train(saved, out, restart=True, log=lambda _: None)
    assert (out / INIT_MODEL).exists()  # nothing was written: the check came first


def test_old_runs_started_from_random_weights_and_a_resume_cannot_change_it() -> None:
    assert LEGACY_DEFAULTS["algorithm.init_from"] is None
    assert "algorithm.init_from" not in RESUMABLE_KEYS
    for bad in ("", "  "):
        with pytest.raises(ConfigError, match=r"algorithm\.init_from must be the path"):
            _config(**{"algorithm.init_from": bad})
    with pytest.raises(ConfigError, match=r"algorithm\.init_from must be a string or null"):
        _config(**{"algorithm.init_from": 3})


def test_sources_that_do_not_fit_are_refused_by_name(source: Path, tmp_path: Path) -> None:
    def weights(path: Path, **overrides: object) -> object:
        return read_initial_weights(_config(**{"algorithm.init_from": str(path), **overrides}))

    with pytest.raises(ConfigError, match="does not exist; give a run directory"):
        weights(tmp_path / "nowhere")
    (tmp_path / "empty").mkdir()
    with pytest.raises(NoCheckpointError, match=r"holds no model\.zip and no checkpoint"):
        weights(tmp_path / "empty")
    (tmp_path / "junk.zip").write_bytes(b"not a zip")
    with pytest.raises(CorruptFileError, match="is not a readable saved agent"):
        weights(tmp_path / "junk.zip")
    # its run directory says other specs: their DFAs need the world's fluents
    other = weights(source, **{"bolt.specs": ["avoid_top_right"]})
    assert isinstance(other, InitialWeights) and other.source_specs == ("G(on_edge)",)
    model: Any = SimpleNamespace(policy=torch.nn.Linear(1, 1))
    with pytest.raises(IncompatibleError, match=r"specs \['G\(on_edge\)'\].*world's fluents"):
        apply_initial_weights(model, other)
    with pytest.raises(IncompatibleError, match=r"'G\(on_edge\)', which does not compile"):
        apply_initial_weights(model, other, ("top_right_corner",))
    with pytest.raises(IncompatibleError, match="DQN"):
        weights(source, **{"algorithm.name": "dqn"})
    other_world = tmp_path / "other-world"
    shutil.copytree(source, other_world)
    saved = json.loads((other_world / "config.json").read_text())
    saved["world"]["name"] = "breakout-ram"
    (other_world / "config.json").write_text(json.dumps(saved))
    with pytest.raises(IncompatibleError, match="world 'breakout-ram'"):
        weights(other_world)


def test_a_bare_model_file_must_fit_the_network_tensor_for_tensor(
    source: Path, tmp_path: Path
) -> None:
    bare = tmp_path / "agent.zip"  # no run directory around it: only the tensors can tell
    shutil.copy(source / "model.zip", bare)
    config = _config(
        **{"algorithm.init_from": str(bare), "bolt.specs": ["edge", "avoid_top_right"]}
    )
    with pytest.raises(IncompatibleError, match=r"does not fit this run's \(shaped otherwise"):
        train(config, tmp_path / "run", log=lambda _: None)
    assert not (tmp_path / "run").exists()  # refused before anything was written
