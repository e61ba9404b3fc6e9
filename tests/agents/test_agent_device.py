"""Where the agent's network trains (``algorithm.device``) and in what number format its
features extractor computes (``algorithm.precision``): each checked by path in the config,
refused by name where the machine lacks the GPU or native bfloat16, changeable on resume;
a GPU run evaluates on a machine without one, a bfloat16 run on one without bfloat16; and
bfloat16 features stay close to float32's from the same weights."""

from __future__ import annotations

import json
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import torch

from noisybolt.agents.extractor import BoltFeaturesExtractor
from noisybolt.envs import make_world
from noisybolt.errors import ConfigError
from noisybolt.perception.detectors import OracleDetector
from noisybolt.runs import models, train
from noisybolt.runs.config import RESUMABLE_KEYS, TrainConfig
from noisybolt.runs.environments import make_env
from noisybolt.runs.legacy import LEGACY_DEFAULTS
from noisybolt.runs.models import compute_dtype, make_model, native_bfloat16, torch_device
from noisybolt.runs.run_evaluation import load_run_model
from noisybolt.runs.rundir import RunDirectory

#: Whether this CPU computes bfloat16 natively (AVX512-BF16 or AMX).
NATIVE = native_bfloat16("cpu")


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
    probe = make_world(config.world_config.name, num_envs=1, seed=0)
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


def _extractors(model: object) -> list[BoltFeaturesExtractor]:
    policy = model.policy  # type: ignore[attr-defined]
    return [m for m in policy.modules() if isinstance(m, BoltFeaturesExtractor)]


def _as_if(monkeypatch: pytest.MonkeyPatch, native: bool) -> None:
    monkeypatch.setattr(models, "native_bfloat16", lambda device: native)


def test_the_precision_is_checked_by_its_path() -> None:
    assert _config().algorithm.precision == "float32"
    assert _config(**{"algorithm.precision": "bfloat16"}).algorithm.precision == "bfloat16"
    for bad in ("bf16", "float16", "FLOAT32", 32, None):
        with pytest.raises(ConfigError, match=r"algorithm\.precision must be"):
            _config(**{"algorithm.precision": bad})


def test_old_runs_computed_in_float32_and_a_resume_may_change_it() -> None:
    assert LEGACY_DEFAULTS["algorithm.precision"] == "float32"
    assert "algorithm.precision" in RESUMABLE_KEYS
    saved = _config(**{"algorithm.precision": "bfloat16"}).to_dict()
    del saved["algorithm"]["precision"]  # a run saved before the setting existed
    assert TrainConfig.from_dict(saved).algorithm.precision == "float32"


def test_bfloat16_is_refused_where_it_would_be_emulated(monkeypatch: pytest.MonkeyPatch) -> None:
    assert compute_dtype("float32", "cpu") is None
    _as_if(monkeypatch, native=True)
    assert compute_dtype("bfloat16", "cpu") is torch.bfloat16
    _as_if(monkeypatch, native=False)
    assert compute_dtype("float32", "cpu") is None
    with pytest.raises(ConfigError, match=r"no native bfloat16.*--set algorithm\.precision="):
        compute_dtype("bfloat16", "cpu")


def test_bfloat16_features_are_float32_and_close_to_float32s() -> None:
    space = gym.spaces.Dict(
        {
            "image": gym.spaces.Box(0, 255, (4, 84, 84), np.uint8),
            "dfa": gym.spaces.MultiDiscrete([2, 3]),
        }
    )
    torch.manual_seed(0)
    extractor = BoltFeaturesExtractor(space, cnn="atari2013", image_features=256)
    image = torch.randint(0, 256, (16, 4, 84, 84)).float() / 255
    obs = {"image": image, "dfa": torch.tensor([[1.0, 0.0, 0.0, 0.0, 1.0]] * 16)}
    exact = extractor(obs).detach()
    extractor.compute_dtype = torch.bfloat16
    rounded = extractor(obs).detach()
    assert rounded.dtype == torch.float32
    assert all(p.dtype == torch.float32 for p in extractor.parameters())
    # the DFA states pass through untouched; the image features to bfloat16's rounding
    # (8 bits of mantissa: ~0.4 % per product, ~1 % after two convolutions and a layer)
    assert torch.equal(rounded[:, 256:], exact[:, 256:])
    error = (rounded[:, :256] - exact[:, :256]).norm() / exact[:, :256].norm()
    assert 0 < float(error) < 0.03
    # the gradient reaches the float32 weights, pointing where float32's does
    grads = []
    for dtype in (None, torch.bfloat16):
        extractor.zero_grad()
        extractor.compute_dtype = dtype
        extractor(obs)[:, :256].square().mean().backward()
        grads.append(torch.cat([p.grad.flatten() for p in extractor.parameters()]))
    assert float(torch.nn.functional.cosine_similarity(*grads, dim=0)) > 0.99


@pytest.mark.skipif(not NATIVE, reason="this CPU computes bfloat16 only by emulation")
def test_a_bfloat16_run_trains_resumes_in_float32_and_evaluates_anywhere(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    out = tmp_path / "run"
    train(_config(**{"algorithm.precision": "bfloat16"}), out, log=lambda _: None)
    saved = json.loads((out / "config.json").read_text())
    assert saved["algorithm"]["precision"] == "bfloat16"
    config = TrainConfig.from_dict(saved)
    model = load_run_model(RunDirectory(out), config)
    assert [e.compute_dtype for e in _extractors(model)] == [torch.bfloat16]
    # a machine that would emulate bfloat16 evaluates the run in float32 (same weights) ...
    _as_if(monkeypatch, native=False)
    model = load_run_model(RunDirectory(out), config)
    assert [e.compute_dtype for e in _extractors(model)] == [None]
    # ... refuses to go on training it so, naming the way out, and resumes it in float32
    saved["frames"] = 384
    with pytest.raises(ConfigError, match=r"--set algorithm\.precision=float32"):
        train(TrainConfig.from_dict(saved), out, resume=True, log=lambda _: None)
    saved["algorithm"]["precision"] = "float32"
    train(TrainConfig.from_dict(saved), out, resume=True, log=lambda _: None)
    resumed = json.loads((out / "config.json").read_text())
    assert resumed["algorithm"]["precision"] == "float32"
    assert json.loads((out / "checkpoints" / "latest.json").read_text())["frames"] >= 384
