"""Checkpoints of a run: written atomically, read strictly, nothing in them executable.

A checkpoint folder ``checkpoints/step_N/`` holds::

    model.zip            the SB3 model (loaded by :func:`noisybolt.runs.models.load_model`)
    vecnormalize.npz     the reward normaliser's statistics (numpy arrays, no pickle)
    replay_buffer.npz    an off-policy learner's replay buffer (numpy arrays, no pickle)
    state.json           the run's bookkeeping (evaluations so far, N_frames, best model)

It counts only once ``checkpoints/latest.json`` names it, which happens after all its files
are complete. Every read names the file it found damaged (``CorruptFileError``), and the
pointer may only name a ``step_N`` folder inside the run directory.
"""

from __future__ import annotations

import re
import shutil
import zipfile
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.vec_env import VecEnv, VecNormalize

from noisybolt.errors import CorruptFileError, NoCheckpointError, UnsafeFileError
from noisybolt.io import atomic_open, atomic_write_json, read_json
from noisybolt.runs.models import save_model
from noisybolt.runs.rundir import RunDirectory
from noisybolt.wrappers import SplitRewardNormalize

__all__ = [
    "BEST_DIR",
    "Checkpoint",
    "best_folder",
    "convert_pickled_run",
    "copy_model_files",
    "latest_checkpoint",
    "load_normaliser",
    "load_replay_buffer",
    "save_checkpoint",
    "save_model_files",
    "save_normaliser",
    "save_replay_buffer",
]

BEST_DIR = "best"
CHECKPOINTS = "checkpoints"
MODEL = "model.zip"
NORMALISER = "vecnormalize.npz"
REPLAY_BUFFER = "replay_buffer.npz"
STATE = "state.json"
LATEST = "latest.json"
#: Files of runs saved before statistics and buffers stopped being pickles.
LEGACY_PICKLES = ("vecnormalize.pkl", "replay_buffer.pkl")
_FOLDER = re.compile(r"step_\d{12}")


@dataclass(frozen=True)
class Checkpoint:
    """A complete checkpoint folder and its bookkeeping (``state.json``)."""

    folder: Path
    frames: int
    state: dict[str, Any]

    @property
    def model(self) -> Path:
        """Its model file."""
        return self.folder / MODEL


# ---------------------------------------------------------------------- writing
def save_model_files(model: BaseAlgorithm, env: VecEnv, folder: Path, *, algo: str) -> None:
    """The model (and the reward normaliser's statistics) into ``folder``, atomically."""
    folder.mkdir(parents=True, exist_ok=True)
    with atomic_open(folder / MODEL, "wb") as handle:
        save_model(model, handle, algo=algo)
    if isinstance(env, VecNormalize):
        save_normaliser(env, folder / NORMALISER)


def copy_model_files(source: Path, folder: Path) -> None:
    """Copies a saved model (and its normaliser) into ``folder``, each file atomically."""
    for name in (MODEL, NORMALISER):
        if (source / name).exists():
            with atomic_open(folder / name, "wb") as handle:
                handle.write((source / name).read_bytes())


def best_folder(run: RunDirectory, frames: int) -> Path:
    """Where the model of the evaluation at ``frames`` is kept (``keep_best``)."""
    return run.file(BEST_DIR) / f"step_{frames:012d}"


def save_checkpoint(
    model: BaseAlgorithm, env: VecEnv, run: RunDirectory, state: Mapping[str, Any], *, algo: str
) -> Path:
    """Writes a complete checkpoint folder, then points ``latest.json`` at it; returns it."""
    root = run.file(CHECKPOINTS)
    folder = root / f"step_{model.num_timesteps:012d}"
    save_model_files(model, env, folder, algo=algo)
    if getattr(model, "replay_buffer", None) is not None:
        save_replay_buffer(model, folder / REPLAY_BUFFER)
    atomic_write_json(folder / STATE, {**state, "algo": algo})
    atomic_write_json(root / LATEST, {"folder": folder.name, "frames": model.num_timesteps})
    for old in root.glob("step_*"):
        if old.is_dir() and old.name != folder.name:
            shutil.rmtree(old, ignore_errors=True)
    return folder


def _running_stats(env: VecNormalize) -> list[tuple[Any, tuple[str, str, str]]]:
    """Every running mean and variance of the normaliser ``env``, each with the names of
    its mean, variance and count in the file."""
    found: list[tuple[Any, tuple[str, str, str]]] = [
        (env.ret_rms, ("ret_mean", "ret_var", "ret_count"))
    ]
    if isinstance(env, SplitRewardNormalize):
        found.append((env.bolt_ret_rms, ("bolt_ret_mean", "bolt_ret_var", "bolt_ret_count")))
    if env.norm_obs:
        rms = env.obs_rms if isinstance(env.obs_rms, dict) else {"": env.obs_rms}
        found += [
            (stats, (f"obs_mean/{key}", f"obs_var/{key}", f"obs_count/{key}"))
            for key, stats in rms.items()
        ]
    return found


def _running_returns(env: VecNormalize) -> tuple[str, ...]:
    """The attributes of ``env`` holding its games' running returns (named so in the file)."""
    return ("returns", "bolt_returns") if isinstance(env, SplitRewardNormalize) else ("returns",)


def save_normaliser(env: VecNormalize, path: Path) -> None:
    """The reward normaliser's running statistics as npz (what a resume needs)."""
    arrays: dict[str, np.ndarray] = {}
    for stats, (mean, var, count) in _running_stats(env):
        arrays[mean] = np.asarray(stats.mean, dtype=np.float64)
        arrays[var] = np.asarray(stats.var, dtype=np.float64)
        arrays[count] = np.asarray(stats.count, dtype=np.float64)
    for name in _running_returns(env):
        arrays[name] = np.asarray(getattr(env, name), dtype=np.float64)
    with atomic_open(path, "wb") as handle:
        np.savez(handle, **arrays)  # type: ignore[arg-type]


def save_replay_buffer(model: BaseAlgorithm, path: Path) -> None:
    """An off-policy model's replay buffer as npz: its arrays, position and fullness."""
    with atomic_open(path, "wb") as handle:
        np.savez(handle, **_buffer_arrays(model.replay_buffer))  # type: ignore[attr-defined,arg-type]


def _buffer_arrays(buffer: Any) -> dict[str, np.ndarray]:
    arrays: dict[str, np.ndarray] = {
        "pos": np.asarray(buffer.pos),
        "full": np.asarray(buffer.full),
    }
    for name in ("observations", "next_observations", "actions", "rewards", "dones", "timeouts"):
        value = getattr(buffer, name, None)
        if isinstance(value, dict):
            for key, array in value.items():
                arrays[f"{name}/{key}"] = array
        elif value is not None:
            arrays[name] = value
    return arrays


# ---------------------------------------------------------------------- reading
def latest_checkpoint(run: RunDirectory) -> Checkpoint:
    """The checkpoint ``latest.json`` names, checked complete.

    Raises:
        NoCheckpointError: the run has no checkpoint (no ``latest.json``), or the folder
            or model it names is missing.
        CorruptFileError: ``latest.json`` or ``state.json`` is damaged, or the pointer
            leads outside the run directory.
    """
    pointer = run.file(CHECKPOINTS) / LATEST
    data = read_json(pointer, default=None, kind=dict)
    if data is None:
        raise NoCheckpointError(
            f"{run.path} holds no checkpoint ({pointer} is missing): nothing to resume; "
            "start it over with --restart"
        )
    name = data.get("folder")
    if not isinstance(name, str) or not isinstance(data.get("frames"), int):
        raise CorruptFileError(
            f"{pointer} is corrupt: it must name a 'folder' and its 'frames'; remove it and "
            "start the run over with --restart"
        )
    folder = run.inside(Path(CHECKPOINTS) / name, named_in=pointer)
    if not _FOLDER.fullmatch(name):
        raise CorruptFileError(
            f"{pointer} names {name!r}, not a checkpoint folder (step_N); remove it and start "
            "the run over with --restart"
        )
    model = folder / MODEL
    if not model.is_file():
        raise NoCheckpointError(
            f"{pointer} names {model}, which is missing: the run cannot be resumed; start "
            "it over with --restart"
        )
    run.inside(model.relative_to(run.path.resolve()), named_in=pointer)  # not a link out
    state = read_json(folder / STATE, kind=dict)
    return Checkpoint(folder=folder, frames=int(data["frames"]), state=state)


def refuse_pickles(folder: Path) -> None:
    """Refuses a checkpoint saved as pickles (before noisybolt stored npz).

    Raises:
        UnsafeFileError: naming the file and what to do.
    """
    for name in LEGACY_PICKLES:
        if (folder / name).exists():
            raise UnsafeFileError(
                f"{folder / name} is a pickle (saved by an older noisybolt), and loading a "
                "pickle can run any code, so noisybolt does not load it. If you trust whoever "
                "wrote this run, convert it once with `python -m noisybolt.runs.checkpoints "
                "--trust-pickles RUN_DIR`; otherwise start the run over with --restart (its "
                "final model.zip still evaluates)"
            )


def load_normaliser(env: VecNormalize, path: Path) -> None:
    """Restores the statistics :func:`save_normaliser` wrote onto ``env`` (built alike).

    Raises:
        CorruptFileError: the file is damaged or does not fit ``env``.
    """
    arrays = _load_npz(path)
    try:
        for stats, (mean, var, count) in _running_stats(env):
            stats.mean = _fit(arrays, mean, np.shape(stats.mean), path)
            stats.var = _fit(arrays, var, np.shape(stats.var), path)
            stats.count = float(_fit(arrays, count, (), path))
        for name in _running_returns(env):
            setattr(env, name, _fit(arrays, name, np.shape(getattr(env, name)), path))
    except KeyError as error:
        raise CorruptFileError(f"{path} is corrupt: it lacks {error}") from None


def load_replay_buffer(model: BaseAlgorithm, path: Path) -> None:
    """Fills ``model``'s replay buffer (built by the model) from :func:`save_replay_buffer`.

    Raises:
        CorruptFileError: the file is damaged or its arrays do not fit the buffer.
    """
    buffer = model.replay_buffer  # type: ignore[attr-defined]
    arrays = _load_npz(path)
    expected = _buffer_arrays(buffer)
    if set(arrays) != set(expected):
        raise CorruptFileError(
            f"{path} does not fit this run's replay buffer (it holds {sorted(arrays)}, the "
            f"buffer {sorted(expected)}); start the run over with --restart"
        )
    for key, target in expected.items():
        if key in ("pos", "full"):
            continue
        target[...] = _fit(arrays, key, target.shape, path)
    pos, full = int(arrays["pos"]), bool(arrays["full"])
    if not 0 <= pos < buffer.buffer_size:
        raise CorruptFileError(f"{path} is corrupt: position {pos} outside the buffer")
    buffer.pos, buffer.full = pos, full


def _load_npz(path: Path) -> dict[str, np.ndarray]:
    try:
        with np.load(path, allow_pickle=False) as archive:
            return {key: archive[key] for key in archive.files}
    except FileNotFoundError:
        raise CorruptFileError(f"{path} is missing from its checkpoint") from None
    except (ValueError, OSError, EOFError, KeyError, zipfile.BadZipFile) as error:
        # allow_pickle=False raises ValueError on an object array: refused, never unpickled
        raise CorruptFileError(
            f"{path} is corrupt ({type(error).__name__}: {error}); start the run over with "
            "--restart"
        ) from None


def _fit(arrays: Mapping[str, np.ndarray], key: str, shape: tuple[int, ...], path: Path) -> Any:
    array = arrays[key]
    if array.shape != tuple(shape):
        raise CorruptFileError(
            f"{path}: {key} has shape {array.shape}, this run needs {tuple(shape)}; start the "
            "run over with --restart"
        )
    return array.copy()


# ---------------------------------------------------------------------- old runs
def convert_pickled_run(run_dir: str | Path) -> list[Path]:
    """Converts a run saved by an older noisybolt: its pickled normaliser statistics and
    replay buffers become the npz files this version reads, and the pickles are removed.

    This *unpickles* them, which runs whatever code they hold: call it only on a run you
    trust (one you trained yourself). Returns the files converted.
    """
    import pickle

    from stable_baselines3.common.save_util import load_from_pkl

    run = RunDirectory(run_dir)
    folders = [
        run.path,
        *run.path.glob(f"{CHECKPOINTS}/step_*"),
        *run.path.glob(f"{BEST_DIR}/step_*"),
    ]
    converted = []
    for folder in folders:
        old = folder / "vecnormalize.pkl"
        if old.is_file():
            with old.open("rb") as handle:
                normaliser = pickle.load(handle)  # the caller trusts it (see above)
            if "returns" not in vars(normaliser):
                # VecNormalize pickles without its running returns; SB3's own loader
                # restarts them at zero, as a resume from the pickle did.
                normaliser.returns = np.zeros(normaliser.num_envs)
            save_normaliser(normaliser, folder / NORMALISER)
            old.unlink()
            converted.append(old)
        old = folder / "replay_buffer.pkl"
        if old.is_file():
            buffer = load_from_pkl(old)
            with atomic_open(folder / REPLAY_BUFFER, "wb") as handle:
                np.savez(handle, **_buffer_arrays(buffer))  # type: ignore[arg-type]
            old.unlink()
            converted.append(old)
    return converted


def _main(argv: list[str] | None = None) -> int:
    import argparse

    parser = argparse.ArgumentParser(
        prog="python -m noisybolt.runs.checkpoints",
        description="Convert a run saved by an older noisybolt (pickled statistics and "
        "replay buffers) to npz. Unpickling runs code: only for runs you trust.",
    )
    parser.add_argument("run_dir", type=Path)
    parser.add_argument(
        "--trust-pickles",
        action="store_true",
        required=True,
        help="confirm that you trust whoever wrote this run (its pickles are unpickled)",
    )
    args = parser.parse_args(argv)
    for path in convert_pickled_run(args.run_dir):
        print(f"converted {path}")
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(_main())
