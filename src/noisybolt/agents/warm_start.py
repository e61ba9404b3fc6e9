"""Starting a run's network from a saved agent (``algorithm.init_from``, ``--init-from``).

A restraining bolt is often put on an agent that already plays: the bolt then has to
*steer* a player, not to teach the game from nothing. A run with ``init_from`` builds its
model as any new run does (seeded, its own hyperparameters, a fresh optimiser and reward
normaliser), then replaces the policy's weights with the saved agent's; everything else
starts anew, its frame count included, so its schedules start over too (a DQN explores
from ``exploration_initial_eps`` again and fills its buffer for ``learning_starts`` frames:
lower them with ``--hp`` to keep more of a trained Q-network's play). A fresh optimiser
and reward normaliser cost some play at first: a Breakout RAM agent scoring 10 dropped to
5 in its first 100k frames and was back by 200k, bolted or not.

The source is a run directory (its final ``model.zip``, or its latest checkpoint's while
it trains), a checkpoint folder (``checkpoints/step_N``, ``best/step_N``) or a
``model.zip``. Its weights load as the run's own models do: the JSON entry and torch's
``weights_only`` state dict, nothing unpickled. They must fit the new network tensor for
tensor; where the source's run directory tells (its ``config.json``), its world and its
specs must also be the new run's, since the agent's observation holds the world's view and
the specs' DFA states: a network trained on other specs would read the states of these as
those of its own. PPO and A2C share their policy, so one may start the other; DQN's
Q-network starts DQN only.

The new run keeps a copy of the file it started from (``init_model.zip``), so the run
stays reproducible when the source run trains on or is deleted; a resume continues from
its own checkpoint and never reads the source again.
"""

from __future__ import annotations

import io
import pickle
import zipfile
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import torch
from stable_baselines3.common.base_class import BaseAlgorithm

from noisybolt.agents.checkpoints import MODEL, latest_checkpoint
from noisybolt.agents.config import TrainConfig
from noisybolt.agents.models import ALGO_KEY, read_model_data
from noisybolt.errors import ConfigError, CorruptFileError, IncompatibleError, NoCheckpointError
from noisybolt.io import read_json
from noisybolt.rundir import RunDirectory

__all__ = [
    "INIT_MODEL",
    "InitialWeights",
    "apply_initial_weights",
    "find_initial_model",
    "read_initial_weights",
]

#: The copy of the model a run started from, in its run directory.
INIT_MODEL = "init_model.zip"
#: The entry of an SB3 model archive that holds the policy's state dict.
_POLICY_ENTRY = "policy.pth"
#: Algorithms whose policies have the same parameters (SB3's actor-critic policy).
_ACTOR_CRITIC = frozenset({"ppo", "a2c"})


@dataclass(frozen=True)
class InitialWeights:
    """A saved agent's policy, read for a new run.

    Attributes:
        path: the model file read.
        algo: the algorithm that saved it (None if the file does not say).
        frames: the frames it had trained (None if the file does not say).
        state_dict: the policy's tensors, on the CPU.
        content: the file's bytes (what the new run keeps as :data:`INIT_MODEL`).
    """

    path: Path
    algo: str | None
    frames: int | None
    state_dict: Mapping[str, torch.Tensor]
    content: bytes

    def describe(self) -> str:
        """One line for the training's log."""
        trained = f" trained {self.frames:,} frames" if self.frames is not None else ""
        algo = f"{self.algo.upper()} agent" if self.algo else "agent"
        return f"the agent's network starts from {self.path} (a {algo}{trained})"


def find_initial_model(path: str | Path) -> Path:
    """The model file that ``path`` names: itself if a file; in a folder, its
    ``model.zip`` (a finished run, a checkpoint folder), else, in a run that is still
    training, its latest checkpoint's.

    Raises:
        ConfigError: ``path`` does not exist.
        NoCheckpointError: a folder holding no model and no checkpoint.
    """
    path = Path(path)
    if not path.exists():
        raise ConfigError(
            f"algorithm.init_from: {path} does not exist; give a run directory, a "
            "checkpoint folder or a model.zip of a saved agent"
        )
    if path.is_file():
        return path
    if (path / MODEL).is_file():
        return path / MODEL
    try:
        return latest_checkpoint(RunDirectory(path)).model
    except NoCheckpointError:
        raise NoCheckpointError(
            f"algorithm.init_from: {path} holds no {MODEL} and no checkpoint; give a run "
            "directory, a checkpoint folder or a model.zip of a saved agent"
        ) from None


def _source_config(model: Path) -> dict[str, Any] | None:
    """The ``config.json`` of the run ``model`` belongs to, if it is in one: beside it
    (a run's final model) or two folders up (``checkpoints/step_N``, ``best/step_N``)."""
    for folder in (model.parent, model.parent.parent.parent):
        config = folder / "config.json"
        if config.is_file():
            try:
                return TrainConfig.from_dict(read_json(config, kind=dict)).to_dict()
            except (ConfigError, CorruptFileError):
                return None  # an unreadable config tells nothing: the tensors still must fit
    return None


def read_initial_weights(config: TrainConfig) -> InitialWeights:
    """Reads the saved agent ``config.algorithm.init_from`` names, checked against the
    new run's algorithm, world and specs (where its run directory says them).

    Raises:
        ConfigError, NoCheckpointError: as :func:`find_initial_model`.
        CorruptFileError: the file is not an SB3 model archive with a policy.
        IncompatibleError: saved by an algorithm whose policy differs, or in a run of
            another world or other specs.
    """
    assert config.algorithm.init_from is not None
    path = find_initial_model(config.algorithm.init_from)
    content = path.read_bytes()
    try:
        data = read_model_data(path, content)
        with zipfile.ZipFile(io.BytesIO(content)) as archive:
            policy = archive.read(_POLICY_ENTRY)
        state_dict = torch.load(io.BytesIO(policy), map_location="cpu", weights_only=True)
    except (
        CorruptFileError,
        zipfile.BadZipFile,
        KeyError,
        ValueError,
        EOFError,
        RuntimeError,
        pickle.UnpicklingError,
    ) as error:
        raise CorruptFileError(
            f"algorithm.init_from: {path} is not a readable saved agent ({type(error).__name__}: "
            f"{str(error)[:200]}); give a model.zip that noisybolt or Stable-Baselines3 saved"
        ) from None
    if not isinstance(state_dict, dict):
        raise CorruptFileError(f"algorithm.init_from: {path} is not a saved agent")
    algo = data.get(ALGO_KEY)
    algo = algo if isinstance(algo, str) else None
    frames = data.get("num_timesteps")
    frames = frames if isinstance(frames, int) and not isinstance(frames, bool) else None
    new = config.algo.lower()
    if algo is not None and algo != new and not {algo, new} <= _ACTOR_CRITIC:
        raise IncompatibleError(
            f"algorithm.init_from: {path} is a {algo.upper()} agent and this run trains "
            f"{new.upper()}: their networks differ (PPO and A2C share theirs); start a "
            f"{algo.upper()} run from it, or give a {new.upper()} agent"
        )
    source = _source_config(path)
    if source is not None:
        _check_same_observation(path, source, config.to_dict())
    return InitialWeights(
        path=path, algo=algo, frames=frames, state_dict=state_dict, content=content
    )


def _check_same_observation(path: Path, source: Mapping[str, Any], new: Mapping[str, Any]) -> None:
    """Refuses a source run of another world or other specs (what the agent observes)."""
    if source["world"]["name"] != new["world"]["name"]:
        raise IncompatibleError(
            f"algorithm.init_from: {path} was trained on the world {source['world']['name']!r}, "
            f"this run plays {new['world']['name']!r}; start from an agent of this world"
        )

    def formulas(config: Mapping[str, Any]) -> list[str]:
        return [str(spec.get("formula")) for spec in config["bolt"]["specs"]]

    if formulas(source) != formulas(new):
        raise IncompatibleError(
            f"algorithm.init_from: {path} was trained with the specs {formulas(source)} and "
            f"this run has {formulas(new)}; the agent observes its specs' DFA states, so it "
            "must start from an agent of the same specs in the same order (bolted or not)"
        )


def apply_initial_weights(model: BaseAlgorithm, weights: InitialWeights) -> None:
    """Loads ``weights`` into ``model``'s policy, every tensor of the same name and shape.

    Raises:
        IncompatibleError: naming the tensors that are missing, extra or shaped otherwise
            (another network, observation or action space).
    """
    target = model.policy.state_dict()
    missing = sorted(set(target) - set(weights.state_dict))
    extra = sorted(set(weights.state_dict) - set(target))
    shapes = [
        f"{key} {tuple(weights.state_dict[key].shape)} vs {tuple(tensor.shape)}"
        for key, tensor in target.items()
        if key in weights.state_dict and weights.state_dict[key].shape != tensor.shape
    ]
    if missing or extra or shapes:
        detail = "; ".join(
            part
            for part in (
                f"missing {missing[:4]}" if missing else "",
                f"not in this network {extra[:4]}" if extra else "",
                f"shaped otherwise (saved vs new) {shapes[:4]}" if shapes else "",
            )
            if part
        )
        raise IncompatibleError(
            f"algorithm.init_from: the network saved in {weights.path} does not fit this "
            f"run's ({detail}); the world's observation, the specs (their DFA states), the "
            "actions and the network's hyperparameters (image_features, cnn, net_arch) must "
            "be the saved agent's"
        )
    model.policy.load_state_dict(dict(weights.state_dict))
