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
``weights_only`` state dict, nothing unpickled. Where the source's run directory tells (its
``config.json``), its world must be the new run's. PPO and A2C share their policy, so one
may start the other; DQN's Q-network starts DQN only.

The agent observes the world and its specs' DFA states (one-hot, or beliefs over them),
joined after the world's features. **Same specs** (same formulas in the same order): the
network is the source's, tensor for tensor. **Other specs** (a player trained unbolted or
under other wishes, restrained now by new ones; its run directory must say its specs): the
world's part of the network is the source's; the layers that read the joined features
(the first of each of the policy's and value's nets, or their heads where those nets are
empty; the Q-networks' first layers) keep their columns for the world's features, start
those for the new DFA states at zero, and take into their biases what the source's own
DFA states before any letter added to them. So the new run first plays exactly as the
source did at the start of its specs' episodes, whatever state the new specs are in, and
learns what their states mean: a network trained on other specs would otherwise read the
new states as those of its own. A bare ``model.zip`` (no run directory) tells no specs: it
must fit the new network tensor for tensor.

The new run keeps a copy of the file it started from (``init_model.zip``), so the run
stays reproducible when the source run trains on or is deleted; a resume continues from
its own checkpoint and never reads the source again.
"""

from __future__ import annotations

import io
import pickle
import zipfile
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import torch
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.policies import ActorCriticPolicy
from stable_baselines3.dqn.policies import DQNPolicy
from torch import nn

from noisybolt.envs.registry import refusing_code
from noisybolt.errors import (
    ConfigError,
    CorruptFileError,
    IncompatibleError,
    NoCheckpointError,
    NoisyboltError,
)
from noisybolt.io import read_json
from noisybolt.logic import compile_ltlf
from noisybolt.runs.checkpoints import MODEL, latest_checkpoint
from noisybolt.runs.config import TrainConfig
from noisybolt.runs.models import ALGO_KEY, read_model_data
from noisybolt.runs.rundir import RunDirectory

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
        source_specs: the source's spec formulas where they are not the new run's (None:
            the same specs, or a bare file that does not say).
    """

    path: Path
    algo: str | None
    frames: int | None
    state_dict: Mapping[str, torch.Tensor]
    content: bytes
    source_specs: tuple[str, ...] | None = None

    def describe(self) -> str:
        """One line for the training's log."""
        trained = f" trained {self.frames:,} frames" if self.frames is not None else ""
        algo = f"{self.algo.upper()} agent" if self.algo else "agent"
        line = f"the agent's network starts from {self.path} (a {algo}{trained})"
        if self.source_specs is not None:
            line += (
                f"; it was trained with the specs {list(self.source_specs)}: it plays as it "
                "did at their start, and this run's DFA states start with zero weight"
            )
        return line


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
                # Read as data: code the other run names is never imported (issue 46).
                with refusing_code():
                    return TrainConfig.from_dict(read_json(config, kind=dict)).to_dict()
            except (ConfigError, CorruptFileError):
                return None  # an unreadable config tells nothing: the tensors still must fit
    return None


def read_initial_weights(config: TrainConfig) -> InitialWeights:
    """Reads the saved agent ``config.algorithm.init_from`` names, checked against the
    new run's algorithm and world (where its run directory says it), with its specs where
    they differ from the new run's (:func:`apply_initial_weights` then needs the world's
    fluents).

    Raises:
        ConfigError, NoCheckpointError: as :func:`find_initial_model`.
        CorruptFileError: the file is not an SB3 model archive with a policy.
        IncompatibleError: saved by an algorithm whose policy differs, or in a run of
            another world.
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
    new = config.algorithm.name.lower()
    if algo is not None and algo != new and not {algo, new} <= _ACTOR_CRITIC:
        raise IncompatibleError(
            f"algorithm.init_from: {path} is a {algo.upper()} agent and this run trains "
            f"{new.upper()}: their networks differ (PPO and A2C share theirs); start a "
            f"{algo.upper()} run from it, or give a {new.upper()} agent"
        )
    source = _source_config(path)
    source_specs: tuple[str, ...] | None = None
    if source is not None:
        new_config = config.to_dict()
        if source["world"]["name"] != new_config["world"]["name"]:
            raise IncompatibleError(
                f"algorithm.init_from: {path} was trained on the world "
                f"{source['world']['name']!r}, this run plays {new_config['world']['name']!r}; "
                "start from an agent of this world"
            )
        if _formulas(source) != _formulas(new_config):
            source_specs = _formulas(source)
    return InitialWeights(
        path=path,
        algo=algo,
        frames=frames,
        state_dict=state_dict,
        content=content,
        source_specs=source_specs,
    )


def _formulas(config: Mapping[str, Any]) -> tuple[str, ...]:
    return tuple(str(spec.get("formula")) for spec in config["bolt"]["specs"])


def _dfa_starts(
    path: Path, source_specs: Sequence[str], fluents: Sequence[str] | None
) -> tuple[tuple[int, int], ...]:
    """``(states, state before any letter)`` of each of the source's specs' DFAs, compiled
    over the world's ``fluents`` as its run compiled them: where each one-hot block lies
    in the source's features, and which of its states starts an episode."""
    if fluents is None:
        raise IncompatibleError(
            f"algorithm.init_from: {path} was trained with the specs {list(source_specs)}, "
            "not this run's; to start from an agent of other specs give the world's fluents "
            "(apply_initial_weights(model, weights, fluents); train() does)"
        )
    starts = []
    for formula in source_specs:
        try:
            dfa = compile_ltlf(formula, tuple(fluents))
        except (NoisyboltError, RecursionError) as error:
            raise IncompatibleError(
                f"algorithm.init_from: {path} was trained with the spec {formula!r}, which "
                f"does not compile over this world's fluents {list(fluents)} "
                f"({type(error).__name__}: {str(error)[:200]}); start from an agent of this "
                "world"
            ) from None
        starts.append((int(dfa.n_states), int(dfa.initial_state)))
    return tuple(starts)


def _feature_readers(policy: nn.Module) -> list[tuple[str, Any]]:
    """The layers that read the policy's joined features (world's, then DFA states'),
    each with the extractor that makes its input: the first linear layer of the actor's
    and the critic's nets (their heads where the nets are empty); the first layer of the
    Q-network and of its target."""
    names = {id(module): name for name, module in policy.named_modules()}

    def first_linear(net: nn.Module, otherwise: nn.Module | None) -> str | None:
        layer = next((m for m in net.modules() if isinstance(m, nn.Linear)), otherwise)
        return None if layer is None else names[id(layer)]

    pairs: list[tuple[str | None, Any]]
    if isinstance(policy, ActorCriticPolicy):
        pairs = [
            (
                first_linear(policy.mlp_extractor.policy_net, policy.action_net),
                policy.pi_features_extractor,
            ),
            (
                first_linear(policy.mlp_extractor.value_net, policy.value_net),
                policy.vf_features_extractor,
            ),
        ]
    elif isinstance(policy, DQNPolicy):
        pairs = [
            (first_linear(q.q_net, None), q.features_extractor)
            for q in (policy.q_net, policy.q_net_target)
        ]
    else:
        pairs = [(None, policy)]
    if any(name is None or not hasattr(extractor, "n_dfa") for name, extractor in pairs):
        raise IncompatibleError(
            f"algorithm.init_from: a source of other specs starts SB3's actor-critic or DQN "
            f"policy on noisybolt's features extractor, not a {type(policy).__name__}; start "
            "from an agent of the same specs"
        )
    return [(name, extractor) for name, extractor in pairs if name is not None]


def _respecified(
    policy: nn.Module, weights: InitialWeights, fluents: Sequence[str] | None
) -> dict[str, torch.Tensor]:
    """The source's tensors for a network of other specs (see the module's text): each
    layer that reads the joined features keeps its world columns, starts its DFA columns
    at zero and folds the source's first DFA states into its bias.

    Raises:
        IncompatibleError: the source's layers are not as wide as its world's features
            and its specs' DFA states (a network of other hyperparameters).
    """
    assert weights.source_specs is not None
    starts = _dfa_starts(weights.path, weights.source_specs, fluents)
    state = dict(weights.state_dict)
    onehot = torch.zeros(sum(n for n, _ in starts))
    offset = 0
    for n_states, first in starts:
        onehot[offset + first] = 1.0
        offset += n_states
    for name, extractor in _feature_readers(policy):
        n_world = int(extractor.features_dim) - int(extractor.n_dfa)
        weight, bias = state.get(f"{name}.weight"), state.get(f"{name}.bias")
        if (
            weight is None
            or bias is None
            or weight.ndim != 2
            or weight.shape[1] != n_world + onehot.numel()
        ):
            shape = None if weight is None else tuple(weight.shape)
            raise IncompatibleError(
                f"algorithm.init_from: the network saved in {weights.path} does not fit this "
                f"run's: its {name}.weight is {shape}, where the world's {n_world} features "
                f"and its specs' {onehot.numel()} DFA states make {n_world + onehot.numel()} "
                "inputs; the world's observation and the network's hyperparameters "
                "(image_features, cnn, net_arch) must be the saved agent's"
            )
        dfa_columns = weight[:, n_world:].to(torch.float64)
        state[f"{name}.bias"] = (bias.to(torch.float64) + dfa_columns @ onehot.double()).to(
            bias.dtype
        )
        state[f"{name}.weight"] = torch.cat(
            [weight[:, :n_world], weight.new_zeros(weight.shape[0], int(extractor.n_dfa))], dim=1
        )
    return state


def apply_initial_weights(
    model: BaseAlgorithm, weights: InitialWeights, fluents: Sequence[str] | None = None
) -> None:
    """Loads ``weights`` into ``model``'s policy, every tensor of the same name and shape
    (for a source of other specs, the layers that read the DFA states as the module's text
    says: its specs are compiled over the world's ``fluents``).

    Raises:
        IncompatibleError: naming the tensors that are missing, extra or shaped otherwise
            (another network, observation or action space); a source of other specs
            without ``fluents``, or whose specs do not compile over them.
    """
    target = model.policy.state_dict()
    source = (
        weights.state_dict
        if weights.source_specs is None
        else _respecified(model.policy, weights, fluents)
    )
    missing = sorted(set(target) - set(source))
    extra = sorted(set(source) - set(target))
    shapes = [
        f"{key} {tuple(source[key].shape)} vs {tuple(tensor.shape)}"
        for key, tensor in target.items()
        if key in source and source[key].shape != tensor.shape
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
    model.policy.load_state_dict(dict(source))
