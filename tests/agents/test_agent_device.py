"""Where the agent's network trains (``algorithm.device``): checked by path in the config,
refused by name where the machine lacks the GPU, changeable on resume, and a GPU run
evaluates on a machine without one."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import torch

from noisybolt.agents.config import LEGACY_DEFAULTS, RESUMABLE_KEYS, TrainConfig
from noisybolt.agents.environments import make_env
from noisybolt.agents.models import make_model, torch_device
from noisybolt.agents.run_evaluation import load_run_model
from noisybolt.agents.training import train
from noisybolt.envs import make_world
from noisybolt.errors import ConfigError
from noisybolt.perception.detectors import OracleDetector
from noisybolt.rundir import RunDirectory


def _config(**overrides: object) -> TrainConfig:
    return TrainConfig.build(
        {
            "bolt.specs": ["edge"],
            "bolt.reward": "paper",
            "detector.kind": "oracle",
            "frames": 256,
            "checkpoint_freq": 128,
            "evaluation.freq": 0,
            "evaluation.episodes": 1,
            "progress_bar": False,
            "algorithm.hyperparams.n_steps": 32,
            **overrides,
        }
    )


def _without_gpus(monkeypatch: pytest.MonkeyPatch, count: int = 0) -> None:
    monkeypatch.setattr(torch.cuda, "is_available", lambda: count > 0)
    monkeypatch.setattr(torch.cuda, "device_count", lambda: count)


def test_the_device_is_checked_by_its_path() -> None:
    assert _config().algorithm.device == "cpu" and _config().device == "cpu"
    assert _config(**{"algorithm.device": "cuda:1"}).algorithm.device == "cuda:1"
    for bad in ("gpu", "cuda:", "cuda:x", "CPU", 0):
        with pytest.raises(ConfigError, match=r"algorithm\.device must be"):
            _config(**{"algorithm.device": bad})


def test_old_runs_trained_on_the_cpu_and_a_resume_may_move_them() -> None:
    assert LEGACY_DEFAULTS["algorithm.device"] == "cpu"
    assert "algorithm.device" in RESUMABLE_KEYS
    saved = _config(**{"algorithm.device": "cuda"}).to_dict()
    del saved["algorithm"]["device"]  # a run saved before the setting existed
    assert TrainConfig.from_dict(saved).algorithm.device == "cpu"


def test_a_gpu_the_machine_lacks_is_refused_with_what_to_do(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    assert torch_device("cpu") == "cpu"
    _without_gpus(monkeypatch, count=1)
    assert torch_device("cuda") == "cuda" and torch_device("cuda:0") == "cuda:0"
    with pytest.raises(ConfigError, match=r"sees 1 CUDA device.*--set algorithm\.device=cpu"):
        torch_device("cuda:1")
    _without_gpus(monkeypatch)
    with pytest.raises(ConfigError, match=r"algorithm\.device is cuda, but torch .* sees 0"):
        torch_device("cuda")
    config = _config(**{"algorithm.device": "cuda"})
    probe = make_world(config.world, num_envs=1, seed=0)
    names = tuple(probe.fluent_names)
    probe.close()
    env = make_env(config, OracleDetector(names), training=True)
    try:
        with pytest.raises(ConfigError, match=r"--set algorithm\.device=cpu"):
            make_model(config, env)
        # a trial (rebuilding a saved model's objects) never needs the GPU
        assert str(make_model(config, env, trial=True).device) == "cpu"
    finally:
        env.close()


def test_a_run_trained_for_a_gpu_evaluates_on_a_machine_without_one(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    out = tmp_path / "run"
    train(_config(), out, log=lambda _: None)
    # As if trained on a GPU machine: its config names the GPU.
    saved = json.loads((out / "config.json").read_text())
    saved["algorithm"]["device"] = "cuda"
    (out / "config.json").write_text(json.dumps(saved))
    _without_gpus(monkeypatch)
    config = TrainConfig.from_dict(saved)
    model = load_run_model(RunDirectory(out), config)
    assert str(model.device) == "cpu"
    saved["frames"] = 512  # a resume to train on, still asking for the GPU
    with pytest.raises(ConfigError, match=r"--set algorithm\.device=cpu"):
        train(TrainConfig.from_dict(saved), out, resume=True, log=lambda _: None)
