"""Loading a run directory never runs code from it (issue 14, "Why" item 5).

On 0e550d5 SB3 unpickled every ``:serialized:`` entry of model.zip with cloudpickle, and the
normaliser and replay buffer were plain pickles: evaluating a shared run directory ran
whatever its author put there. Each test crafts a payload that would create a file when
unpickled and checks that the file is never created.
"""

from __future__ import annotations

import base64
import json
import pickle
import shutil
import zipfile
from pathlib import Path

import numpy as np
import pytest

from noisybolt.cli import main
from noisybolt.errors import CorruptFileError
from noisybolt.runs import DetectorConfig, TrainConfig, train


def _quiet(_: str) -> None:
    pass


def _config(**kwargs: object) -> TrainConfig:
    defaults: dict[str, object] = {
        "specs": ["edge"],
        "detector": DetectorConfig(kind="oracle"),
        "frames": 512,
        "eval_freq": 0,
        "eval_episodes": 2,
        "checkpoint_freq": 256,
        "progress_bar": False,
        "overrides": {"n_steps": 32},
    }
    defaults.update(kwargs)
    return TrainConfig.create(**defaults)  # type: ignore[arg-type]


class _WritesAFile:
    """Unpickling this creates ``path``: the payload a malicious run directory would hold."""

    def __init__(self, path: Path) -> None:
        self.path = str(path)

    def __reduce__(self) -> tuple[object, tuple[str, str]]:
        return (open, (self.path, "w"))


def _payload(path: Path) -> bytes:
    return pickle.dumps(_WritesAFile(path))


def _poison_model(model_zip: Path, key: str, target: Path) -> None:
    """Rewrites ``model_zip``'s ``data`` entry so that ``key`` unpickles to a file write."""
    with zipfile.ZipFile(model_zip) as archive:
        members = {name: archive.read(name) for name in archive.namelist()}
    data = json.loads(members["data"])
    data[key] = {
        ":type:": "<class 'function'>",
        ":serialized:": base64.b64encode(_payload(target)).decode(),
    }
    members["data"] = json.dumps(data).encode()
    with zipfile.ZipFile(model_zip, "w") as archive:
        for name, content in members.items():
            archive.writestr(name, content)


@pytest.fixture(scope="module")
def ppo_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    run = tmp_path_factory.mktemp("safe") / "ppo"
    train(_config(overrides={"n_steps": 32, "normalize_reward": True}), run, log=_quiet)
    return run


@pytest.fixture(scope="module")
def dqn_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    run = tmp_path_factory.mktemp("safe") / "dqn"
    train(_config(algo="dqn", overrides={"learning_starts": 64}), run, log=_quiet)
    return run


@pytest.fixture
def run_copy(ppo_run: Path, tmp_path: Path) -> Path:
    shutil.copytree(ppo_run, tmp_path / "run")
    return tmp_path / "run"


@pytest.mark.parametrize("key", ["lr_schedule", "policy_class", "observation_space"])
def test_evaluating_a_model_with_a_pickled_payload_does_not_run_it(
    run_copy: Path, tmp_path: Path, key: str
) -> None:
    target = tmp_path / "pwned"
    _poison_model(run_copy / "model.zip", key, target)
    assert main(["evaluate", str(run_copy), "--episodes", "2"]) == 0
    assert not target.exists()


def test_an_unknown_serialized_entry_is_refused_unread(
    run_copy: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    target = tmp_path / "pwned"
    _poison_model(run_copy / "model.zip", "surprise", target)
    assert main(["evaluate", str(run_copy), "--episodes", "2"]) == 2
    assert "surprise" in capsys.readouterr().err
    assert not target.exists()


def test_resuming_a_poisoned_checkpoint_does_not_run_it(run_copy: Path, tmp_path: Path) -> None:
    target = tmp_path / "pwned"
    latest = json.loads((run_copy / "checkpoints" / "latest.json").read_text())
    _poison_model(run_copy / "checkpoints" / latest["folder"] / "model.zip", "lr_schedule", target)
    config = TrainConfig.from_dict({**json.loads((run_copy / "config.json").read_text())})
    result = train(
        TrainConfig.from_dict({**config.to_dict(), "frames": 1024}), run_copy, resume=True
    )
    assert result.frames == 1024
    assert not target.exists()


def test_statistics_and_buffers_are_stored_without_pickle(ppo_run: Path, dqn_run: Path) -> None:
    files = [p for run in (ppo_run, dqn_run) for p in run.rglob("*") if p.is_file()]
    assert not [p for p in files if p.suffix in (".pkl", ".pickle")]
    normaliser = next(ppo_run.glob("checkpoints/step_*/vecnormalize.npz"))
    buffer = next(dqn_run.glob("checkpoints/step_*/replay_buffer.npz"))
    for path in (normaliser, buffer):
        with np.load(path, allow_pickle=False) as archive:  # raises on any object array
            assert archive.files


def test_an_old_pickled_normaliser_is_refused_with_what_to_do(
    run_copy: Path, tmp_path: Path
) -> None:
    target = tmp_path / "pwned"
    folder = next((run_copy / "checkpoints").glob("step_*"))
    for stats in folder.glob("vecnormalize*"):
        stats.unlink()
    (folder / "vecnormalize.pkl").write_bytes(_payload(target))
    config = TrainConfig.from_dict(json.loads((run_copy / "config.json").read_text()))
    with pytest.raises(CorruptFileError, match=r"vecnormalize\.pkl.*--restart"):
        train(TrainConfig.from_dict({**config.to_dict(), "frames": 1024}), run_copy, resume=True)
    assert not target.exists()


def test_a_dqn_run_resumes_with_its_replay_buffer(dqn_run: Path, tmp_path: Path) -> None:
    from noisybolt.runs.checkpoints import load_replay_buffer
    from noisybolt.runs.models import make_model

    run = tmp_path / "run"
    shutil.copytree(dqn_run, run)
    folder = next((run / "checkpoints").glob("step_*"))
    config = TrainConfig.from_dict(json.loads((run / "config.json").read_text()))
    model = make_model(config, _env(config))
    load_replay_buffer(model, folder / "replay_buffer.npz")
    assert (
        model.replay_buffer is not None
        and model.replay_buffer.pos == 512 // config.world_config.n_envs
    )
    result = train(TrainConfig.from_dict({**config.to_dict(), "frames": 768}), run, resume=True)
    assert result.frames == 768


def _env(config: TrainConfig) -> object:
    from noisybolt.envs import make_world
    from noisybolt.perception.detectors import OracleDetector
    from noisybolt.runs.environments import make_env

    fluents = make_world(config.world_config.name, num_envs=1, seed=0).fluent_names
    return make_env(config, OracleDetector(fluents), training=True)


@pytest.mark.parametrize("algo", ["ppo", "dqn"])
def test_a_trusted_old_run_converts_and_resumes(
    ppo_run: Path, dqn_run: Path, tmp_path: Path, algo: str
) -> None:
    # A run as an older noisybolt saved it: the normaliser pickled whole, the replay
    # buffer with SB3's save_replay_buffer. Refused as is; converted by its owner, resumed.
    from stable_baselines3.common.save_util import save_to_pkl
    from stable_baselines3.common.vec_env import VecNormalize

    from noisybolt.runs.checkpoints import _main, load_normaliser

    run = tmp_path / "run"
    shutil.copytree(ppo_run if algo == "ppo" else dqn_run, run)
    config = TrainConfig.from_dict(json.loads((run / "config.json").read_text()))
    folder = next((run / "checkpoints").glob("step_*"))
    if algo == "ppo":
        env = _env(config)
        assert isinstance(env, VecNormalize)
        load_normaliser(env, folder / "vecnormalize.npz")
        expected = float(env.ret_rms.var.item())
        (folder / "vecnormalize.npz").unlink()
        with (folder / "vecnormalize.pkl").open("wb") as handle:
            pickle.dump(env, handle)
    else:
        from noisybolt.runs.checkpoints import load_replay_buffer
        from noisybolt.runs.models import make_model

        model = make_model(config, _env(config))
        load_replay_buffer(model, folder / "replay_buffer.npz")
        (folder / "replay_buffer.npz").unlink()
        save_to_pkl(folder / "replay_buffer.pkl", model.replay_buffer)  # type: ignore[attr-defined]
    more = TrainConfig.from_dict({**config.to_dict(), "frames": 1024})
    with pytest.raises(CorruptFileError, match="--trust-pickles"):
        train(more, run, resume=True, log=_quiet)
    assert _main([str(run), "--trust-pickles"]) == 0
    assert not list(run.rglob("*.pkl"))
    if algo == "ppo":
        env = _env(config)
        load_normaliser(env, folder / "vecnormalize.npz")  # type: ignore[arg-type]
        assert float(env.ret_rms.var.item()) == expected  # type: ignore[attr-defined]
    assert train(more, run, resume=True, log=_quiet).frames == 1024
