"""The learner: built from a run's config, saved, and loaded without running code.

SB3's ``model.zip`` holds the weights (loaded by torch with ``weights_only=True``: no code)
and a JSON ``data`` entry in which every object that JSON cannot hold (the policy class,
the spaces, the schedules, the last observation) is a base64 cloudpickle, ``:serialized:``,
that ``BaseAlgorithm.load`` would unpickle. A pickle can call anything, so a shared run
directory would be code. :func:`load_model` passes every serialized key in
``custom_objects`` instead, with the value rebuilt from the run's own config (a trial
construction of the same model on the same spaces), and refuses a key it cannot rebuild.
"""

from __future__ import annotations

import io
import json
import zipfile
from pathlib import Path
from typing import Any

import torch
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.vec_env import VecEnv

from noisybolt.agents.counterfactual import replay_buffer_settings
from noisybolt.agents.extractor import BoltFeaturesExtractor, check_cnn
from noisybolt.agents.hyperparams import (
    META_KEYS,
    algorithm_class,
    check_action_space,
    frame_schedules,
)
from noisybolt.agents.pipeline import overlapped_class
from noisybolt.agents.policies import policy_class
from noisybolt.errors import ConfigError, CorruptFileError, UnsafeFileError
from noisybolt.runs.config import TrainConfig

__all__ = [
    "ALGO_KEY",
    "compute_dtype",
    "load_model",
    "make_model",
    "native_bfloat16",
    "read_model_data",
    "save_model",
    "set_precision",
    "torch_device",
]

#: The entry of a saved model's ``data`` naming its algorithm (plain JSON).
ALGO_KEY = "noisybolt_algo"


def torch_device(requested: str) -> str:
    """``requested`` (an ``algorithm.device``: ``cpu``, ``cuda``, ``cuda:N``) if this
    machine has it.

    Raises:
        ConfigError: a GPU this machine's torch does not see (a CPU build of torch, no
            driver, or fewer GPUs than the index); say how to train on the CPU instead.
    """
    if requested == "cpu":
        return requested
    import torch

    count = torch.cuda.device_count() if torch.cuda.is_available() else 0
    index = int(requested.partition(":")[2] or 0)
    if index >= count:
        build = " (a CPU build)" if torch.version.cuda is None else ""
        raise ConfigError(
            f"algorithm.device is {requested}, but torch {torch.__version__}{build} sees "
            f"{count} CUDA device(s) here; train on the CPU with --set algorithm.device=cpu "
            "(a resumed run may change it)"
        )
    return requested


def compute_dtype(precision: str, device: str) -> torch.dtype | None:
    """The dtype the agent's features extractor computes in for ``algorithm.precision``
    on ``device`` (a :func:`torch_device`): None for ``float32`` (no autocast),
    ``torch.bfloat16`` where the device computes it natively.

    Raises:
        ConfigError: ``bfloat16`` on a device without native bfloat16 (a CPU without
            AVX512-BF16 or AMX, an older GPU), where torch would emulate it, slower than
            float32; say how to train in float32.
    """
    if precision == "float32":
        return None
    if not native_bfloat16(device):
        raise ConfigError(
            f"algorithm.precision is {precision}, but this machine's {device} has no native "
            "bfloat16 (a CPU needs AVX512-BF16 or AMX): torch would emulate it, slower than "
            "float32; train with --set algorithm.precision=float32 (a resumed run may change "
            "it)"
        )
    return torch.bfloat16


def native_bfloat16(device: str) -> bool:
    """Whether ``device`` (``cpu``, ``cuda``, ``cuda:N``) computes bfloat16 natively: on the
    CPU, oneDNN's check for AVX512-BF16 or AMX; on a GPU, torch's (Ampere or newer), not
    counting emulation."""
    if device == "cpu":
        return torch.backends.mkldnn.is_available() and bool(
            torch.ops.mkldnn._is_mkldnn_bf16_supported()
        )
    if not torch.cuda.is_available():
        return False
    index = int(device.partition(":")[2] or 0)
    with torch.cuda.device(index):  # the run's GPU, not the current one
        return bool(torch.cuda.is_bf16_supported(including_emulation=False))


def set_precision(model: BaseAlgorithm, dtype: torch.dtype | None) -> None:
    """Makes every features extractor of ``model``'s policy (PPO's shared one, DQN's
    online and target networks') compute in ``dtype`` (None: float32)."""
    for module in model.policy.modules():
        if isinstance(module, BoltFeaturesExtractor):
            module.compute_dtype = dtype


def make_model(
    config: TrainConfig,
    env: VecEnv,
    *,
    tensorboard_log: str | None = None,
    trial: bool = False,
) -> BaseAlgorithm:
    """The SB3 model of ``config`` on ``env`` (seeded by the run's seed).

    ``trial``: a model built only to check the hyperparameters against the env's spaces
    or to rebuild a saved model's objects (a one-transition replay buffer, so a trial of
    an Atari DQN does not reserve gigabytes); it computes in float32, whatever
    ``algorithm.precision`` says.

    Raises:
        ConfigError: SB3 or torch refuse the hyperparameters (the message is theirs), or
            the machine lacks the run's precision (:func:`compute_dtype`).
    """
    params = {k: v for k, v in config.algorithm.hyperparams.items() if k not in META_KEYS}
    # Schedules given in frames (DQN's exploration_frames) as SB3's fractions of this run.
    params.update(frame_schedules(config.algorithm.hyperparams, frames=config.frames))
    policy_kwargs = dict(params.pop("policy_kwargs", {}) or {})
    extractor_kwargs = dict(policy_kwargs.pop("features_extractor_kwargs", {}) or {})
    if config.algorithm.hyperparams.get("image_features") is not None:
        extractor_kwargs["image_features"] = int(config.algorithm.hyperparams["image_features"])
    if config.algorithm.hyperparams.get("cnn") is not None:
        check_cnn(config.algorithm.hyperparams["cnn"])
        extractor_kwargs["cnn"] = str(config.algorithm.hyperparams["cnn"])
    policy_kwargs["features_extractor_class"] = BoltFeaturesExtractor
    policy_kwargs["features_extractor_kwargs"] = extractor_kwargs
    if trial and "buffer_size" in params:
        params["buffer_size"] = 1
    if config.algorithm.counterfactual:
        # Its buffer replays the bolt's transitions: it is rebuilt from the run's env on
        # load (a trial model's kwargs, as every serialized entry is), never unpickled.
        params.update(
            replay_buffer_settings(
                env, samples=config.algorithm.counterfactual_samples, seed=config.seed
            )
        )
    check_action_space(config.algorithm.name, env.action_space, world=config.world_config.name)
    device = "cpu" if trial else torch_device(config.algorithm.device)
    dtype = None if trial else compute_dtype(config.algorithm.precision, device)
    cls = run_algorithm_class(config)
    try:
        model = cls(
            policy_class(config.algorithm.name),  # type: ignore[arg-type]
            env,
            policy_kwargs=policy_kwargs,
            seed=config.seed,
            verbose=0,
            # a trial only rebuilds objects: it never needs (or holds) the GPU
            device=device,
            tensorboard_log=tensorboard_log,
            **params,
        )
    except (TypeError, ValueError, AssertionError, RuntimeError) as error:
        raise ConfigError(
            f"{config.algorithm.name.upper()} cannot be built from these hyperparameters "
            f"({type(error).__name__}: {error}); fix them (--hp KEY=VALUE)"
        ) from None
    set_precision(model, dtype)
    return model


def run_algorithm_class(config: TrainConfig) -> type[BaseAlgorithm]:
    """The SB3 class that trains ``config``'s run: its algorithm's, or with
    ``world.overlap`` that class collecting its rollouts overlapped
    (:func:`~noisybolt.agents.pipeline.overlapped_class`; it saves and loads as the plain
    class does).

    Raises:
        ConfigError: ``world.overlap`` with an algorithm that is not on-policy.
    """
    cls = algorithm_class(config.algorithm.name)
    return overlapped_class(cls) if config.world_config.overlap else cls


def save_model(model: BaseAlgorithm, handle: Any, *, algo: str) -> None:
    """Saves ``model`` to an open binary file, its algorithm named in plain JSON."""
    setattr(model, ALGO_KEY, algo)
    model.save(handle, include=[ALGO_KEY])


def read_model_data(path: Path, content: bytes | None = None) -> dict[str, Any]:
    """The JSON ``data`` entry of a saved model, read without unpickling anything.
    ``content``: the file's bytes, where the caller has read them already.

    Raises:
        CorruptFileError: the file is not a readable SB3 model archive.
    """
    try:
        with zipfile.ZipFile(path if content is None else io.BytesIO(content)) as archive:
            data = json.loads(archive.read("data"))
    except (zipfile.BadZipFile, KeyError, ValueError, EOFError) as error:
        raise CorruptFileError(
            f"{path} is corrupt ({type(error).__name__}: {error}); restore it from a copy, or "
            "train the run again"
        ) from None
    if not isinstance(data, dict):
        raise CorruptFileError(f"{path} is corrupt: its data entry is not a JSON object")
    return data


def load_model(
    path: Path,
    config: TrainConfig,
    env: VecEnv,
    *,
    device: str | None = None,
    precision: str | None = None,
) -> BaseAlgorithm:
    """Loads a saved model of ``config``'s run onto ``env`` without unpickling anything,
    its network on ``device`` (default: the run's ``algorithm.device``; a model trained
    on a GPU loads on the CPU and the other way round), computing in ``precision``
    (default: the run's ``algorithm.precision``; the weights are float32 either way).

    Raises:
        UnsafeFileError: the model holds a serialized entry noisybolt does not rebuild.
        CorruptFileError: the file is damaged, or saved by another algorithm than
            ``config.algorithm.name``, or for other spaces.
    """
    data = read_model_data(path)
    algo = config.algorithm.name.lower()
    saved_algo = data.get(ALGO_KEY)
    trial = make_model(config, env, trial=True)
    serialized = sorted(k for k, v in data.items() if isinstance(v, dict) and ":serialized:" in v)
    unknown = [key for key in serialized if not hasattr(trial, key)]
    if unknown:
        raise UnsafeFileError(
            f"{path} holds pickled entries {unknown} that a {algo.upper()} model does not "
            "have; noisybolt never unpickles a model's entries (a pickle can run code), so "
            "it will not load this file: train the run again, or load it yourself with "
            "Stable-Baselines3 if you trust its author"
        )
    foreign = sorted(k for k in data if k != ALGO_KEY and not hasattr(trial, k))
    if (saved_algo is not None and saved_algo != algo) or foreign:
        raise CorruptFileError(
            f"{path} was saved by another algorithm ({saved_algo or 'unknown'}) than the run's "
            f"{algo}{f' (entries {foreign} are not {algo.upper()}’s)' if foreign else ''}: "
            "the run directory mixes two runs; start it over (--restart) or use another one"
        )
    custom_objects = {key: getattr(trial, key) for key in serialized}
    device = torch_device(device or config.algorithm.device)
    dtype = compute_dtype(precision or config.algorithm.precision, device)
    try:
        model = run_algorithm_class(config).load(
            path,
            env=env,
            device=device,
            custom_objects=custom_objects,
        )
    except (zipfile.BadZipFile, KeyError, ValueError, RuntimeError, EOFError) as error:
        raise CorruptFileError(
            f"{path} is corrupt or was saved for another world ({type(error).__name__}: "
            f"{str(error)[:300]}); restore it from a copy, or train the run again"
        ) from None
    set_precision(model, dtype)
    return model
