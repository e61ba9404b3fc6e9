"""Hyperparameters per world and algorithm (YAML, RL-Zoo style), with overrides.

The built-in files live in ``noisybolt/configs/hyperparams/<world>.yaml``, one entry per
algorithm. A world named by factory path (``package.module:factory``) without a file of
its own gets the documented fallbacks of ``_default.yaml`` there; a user's own file in the
same layout replaces either (``hp_file``, ``noisybolt train --hp-file``). Overrides come
from the command line as ``key=value`` strings (the value is read as YAML, so
``net_arch=[32,32]`` is a list) and may reach into nested mappings with dots
(``policy_kwargs.net_arch=[32,32]``). Unknown keys are refused with the known ones listed.
"""

from __future__ import annotations

import contextlib
import copy
import inspect
import os
from collections.abc import Iterable, Mapping
from importlib import resources
from pathlib import Path
from typing import Any

import yaml
from gymnasium import spaces
from stable_baselines3 import A2C, DQN, PPO
from stable_baselines3.common.base_class import BaseAlgorithm

from noisybolt.errors import ConfigError, UnknownNameError

__all__ = [
    "ACTION_SPACES",
    "ALGORITHMS",
    "DEFAULT_HYPERPARAMS",
    "META_KEYS",
    "SCHEDULED",
    "SPLIT",
    "WORLD_KEYS",
    "algorithm_class",
    "check_action_space",
    "check_budget",
    "check_hyperparameter_values",
    "constructor_defaults",
    "exploration_ends",
    "frame_schedules",
    "known_hyperparameters",
    "load_hyperparams",
    "parse_overrides",
    "zoo_schedules",
]

ALGORITHMS: dict[str, type[BaseAlgorithm]] = {"ppo": PPO, "a2c": A2C, "dqn": DQN}

#: The fallback file for a factory-path world with no file of its own (its comments say
#: where the values come from).
DEFAULT_HYPERPARAMS = "_default"

#: Hyperparameters a run may move linearly over its frames (callbacks.LinearSchedule):
#: ``<name>_final`` is the value reached, ``<name>_frames`` the frames it takes (the run's
#: budget without it). ``ent_coef``: PPO and A2C; ``clip_range``: PPO.
SCHEDULED: tuple[str, ...] = ("ent_coef", "learning_rate", "clip_range")

#: noisybolt's own settings of the agent, consumed before the rest reaches the SB3
#: constructor (a run's config holds them in ``algorithm.hyperparams``).
META_KEYS: frozenset[str] = frozenset(
    {
        *(f"{name}_final" for name in SCHEDULED),
        *(f"{name}_frames" for name in SCHEDULED),
        "normalize_reward",
        # normalize_reward split: the bolt's normalised stream is multiplied by this
        "bolt_weight",
        "image_features",
        # the agent's convolutions (extractor.conv_stack): auto, nature, atari2013, grid
        "cnn",
        # DQN: epsilon falls over this many frames, whatever the budget
        # (sets SB3's exploration_fraction; see frame_schedules)
        "exploration_frames",
    }
)

#: ``normalize_reward``'s third value (besides true and false): the world's rewards and the
#: bolt's normalised apart (:class:`~noisybolt.wrappers.SplitRewardNormalize`).
SPLIT = "split"

#: Settings of the world that the per-world files give beside the hyperparameters, as RL
#: Zoo's files give ``n_envs``: training environments and the Atari conventions
#: (noisybolt.wrappers.atari, BreakoutWorld.fire_on_reset). A run's config holds them in
#: its ``world`` section (:class:`~noisybolt.runs.config.WorldConfig`).
WORLD_KEYS: frozenset[str] = frozenset(
    {"n_envs", "fire_on_reset", "clip_reward", "life_loss_terminal"}
)

# Constructor arguments that noisybolt sets itself.
_RESERVED = frozenset(
    {"self", "policy", "env", "seed", "device", "verbose", "tensorboard_log", "_init_setup_model"}
)


def algorithm_class(algo: str) -> type[BaseAlgorithm]:
    """The SB3 class of ``algo`` (``ppo``, ``a2c``, ``dqn``)."""
    try:
        return ALGORITHMS[algo.lower()]
    except KeyError:
        raise UnknownNameError(
            f"unknown algorithm {algo!r}; known algorithms: {sorted(ALGORITHMS)}",
            name=algo,
            known=tuple(sorted(ALGORITHMS)),
        ) from None


def constructor_defaults(algo: str) -> dict[str, Any]:
    """The default of each argument of ``algo``'s SB3 constructor (``inspect.Parameter.
    empty`` where it has none), e.g. PPO's ``learning_rate`` 3e-4."""
    params = inspect.signature(algorithm_class(algo).__init__).parameters
    return {name: p.default for name, p in params.items()}


def known_hyperparameters(algo: str) -> frozenset[str]:
    """Keys accepted for ``algo`` in a hyperparameter file or override: its SB3
    constructor's arguments plus :data:`META_KEYS` and :data:`WORLD_KEYS`."""
    return frozenset(constructor_defaults(algo)) - _RESERVED | META_KEYS | WORLD_KEYS


def frame_schedules(params: Mapping[str, Any], *, frames: int) -> dict[str, Any]:
    """SB3 arguments for the schedules given in frames rather than fractions of the run.

    SB3 sets DQN's epsilon schedule as a fraction of the run (``exploration_fraction``), so
    when a policy first acts well would depend on the budget chosen; ``exploration_frames``
    fixes it in frames instead, and this turns it into the fraction of a ``frames`` run.

    Raises:
        ConfigError: both ``exploration_frames`` and ``exploration_fraction`` set, or a
            count below 1.

    Example:
        >>> frame_schedules({"exploration_frames": 3000}, frames=30_000)
        {'exploration_fraction': 0.1}
        >>> frame_schedules({"exploration_frames": 3000}, frames=1_000)
        {'exploration_fraction': 1.0}
    """
    out: dict[str, Any] = {}
    given = params.get("exploration_frames")
    if given is not None:
        if params.get("exploration_fraction") is not None:
            raise ConfigError(
                "exploration_frames and exploration_fraction both set; give one "
                "(exploration_frames=null to use a fraction of the run)"
            )
        if isinstance(given, bool) or not isinstance(given, int) or given < 1:
            raise ConfigError(f"exploration_frames must be an integer >= 1, got {given!r}")
        out["exploration_fraction"] = min(1.0, given / max(1, int(frames)))
    for name in SCHEDULED:
        span = params.get(f"{name}_frames")
        if span is None:
            continue
        if isinstance(span, bool) or not isinstance(span, int) or span < 1:
            raise ConfigError(f"{name}_frames must be an integer >= 1, got {span!r}")
        if params.get(f"{name}_final") is None:
            raise ConfigError(
                f"{name}_frames={span} without {name}_final: give the value {name} moves "
                f"to (e.g. {name}_final=0), or drop {name}_frames"
            )
    return out


def exploration_ends(params: Mapping[str, Any], *, algo: str, frames: int) -> int:
    """The frame at which a run's exploration schedules end: the entropy bonus's
    (``ent_coef_final`` given: over ``ent_coef_frames``, or the whole run) and DQN's epsilon
    (``exploration_frames``, or SB3's ``exploration_fraction`` of the run); 0 where none
    runs. Until then the policy is not yet the one the schedule ends with.

    Example:
        >>> exploration_ends({"ent_coef": 0.05, "ent_coef_final": 0.0,
        ...                   "ent_coef_frames": 50_000}, algo="a2c", frames=40_000)
        50000
        >>> exploration_ends({"ent_coef": 0.01}, algo="ppo", frames=40_000)
        0
        >>> exploration_ends({"exploration_frames": 3000}, algo="dqn", frames=30_000)
        3000
        >>> exploration_ends({}, algo="dqn", frames=30_000)  # SB3's fraction, 0.1
        3000
    """
    ends = 0
    if params.get("ent_coef_final") is not None:
        ends = int(params.get("ent_coef_frames") or frames)
    if algo == "dqn":
        given = params.get("exploration_frames")
        if given is not None:
            ends = max(ends, int(given))
        else:
            fraction = params.get("exploration_fraction")
            if fraction is None:
                fraction = constructor_defaults("dqn").get("exploration_fraction", 0.1)
            ends = max(ends, round(float(fraction) * int(frames)))
    return ends


def parse_overrides(items: Iterable[str]) -> dict[str, Any]:
    """Parses ``key=value`` strings; values are read as YAML.

    Example:
        >>> parse_overrides(["learning_rate=3e-4", "policy_kwargs.net_arch=[32, 32]"])
        {'learning_rate': 0.0003, 'policy_kwargs.net_arch': [32, 32]}
    """
    result: dict[str, Any] = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise ConfigError(f"hyperparameter override {item!r} is not of the form key=value")
        try:
            parsed = yaml.safe_load(value)
        except yaml.YAMLError as error:
            raise ConfigError(f"cannot read the value of {item!r}: {error}") from None
        # YAML 1.1 reads "3e-4" as a string; accept the float a user meant.
        if isinstance(parsed, str):
            with contextlib.suppress(ValueError):
                parsed = float(parsed)
        result[key.strip()] = parsed
    return result


def _builtin(world: str) -> dict[str, Any]:
    files = resources.files("noisybolt.configs").joinpath("hyperparams")
    known = sorted(
        p.name.removesuffix(".yaml")
        for p in files.iterdir()
        if p.name.endswith(".yaml") and not p.name.startswith("_")
    )
    if world not in known and ":" in world:  # a factory path: the documented fallbacks
        world = DEFAULT_HYPERPARAMS
    elif world not in known:
        raise UnknownNameError(
            f"unknown world {world!r}: the built-in worlds are {known}; a world of your own "
            "is named by its factory path, module:function (e.g. my_world:make_world)",
            name=world,
            known=tuple(known),
        )
    data = yaml.safe_load(files.joinpath(f"{world}.yaml").read_text())
    return data if isinstance(data, dict) else {}


def _user_file(path: str | os.PathLike[str], algo: str) -> dict[str, Any]:
    try:
        data = yaml.safe_load(Path(path).read_text())
    except OSError as exc:
        raise ConfigError(f"cannot read the hyperparameter file {path}: {exc}") from None
    except yaml.YAMLError as exc:
        raise ConfigError(f"the hyperparameter file {path} is not valid YAML: {exc}") from None
    if not isinstance(data, dict) or algo not in data:
        found = sorted(data) if isinstance(data, dict) else type(data).__name__
        raise ConfigError(
            f"the hyperparameter file {path} needs an entry {algo!r} (one mapping per "
            f"algorithm, as in noisybolt/configs/hyperparams/gridworld.yaml); found {found}"
        )
    return data


def load_hyperparams(
    world: str,
    algo: str,
    overrides: Mapping[str, Any] | None = None,
    *,
    hp_file: str | os.PathLike[str] | None = None,
) -> dict[str, Any]:
    """Resolved hyperparameters of ``algo`` on ``world``, with ``overrides`` applied.

    Args:
        world: a world with a built-in file, or a factory path (fallbacks:
            ``_default.yaml``).
        algo: ``ppo``, ``a2c`` or ``dqn``.
        overrides: ``{key: value}``, dotted keys reaching into mappings.
        hp_file: a YAML file of the built-in layout to read instead of the built-in one.

    Raises:
        UnknownNameError: unknown world (with no ``hp_file``) or algorithm.
        ConfigError: an override or file names a key the algorithm does not have, or
            ``hp_file`` is unreadable or has no entry for ``algo``.

    Example:
        >>> params = load_hyperparams("gridworld", "ppo", {"n_epochs": 2})
        >>> params["n_epochs"], params["n_envs"]
        (2, 8)
    """
    algo = algo.lower()
    algorithm_class(algo)
    table = _user_file(hp_file, algo) if hp_file is not None else _builtin(world)
    params = copy.deepcopy(table.get(algo) or {})
    known = known_hyperparameters(algo)
    for key, value in (overrides or {}).items():
        head, *rest = key.split(".")
        if head not in known:
            raise ConfigError(f"unknown hyperparameter {head!r} for {algo}; known: {sorted(known)}")
        if not rest:
            params[head] = value
            continue
        node = params.setdefault(head, {})
        for part in rest[:-1]:
            if not isinstance(node, dict):
                raise ConfigError(f"{key!r}: {part!r} is not inside a mapping")
            node = node.setdefault(part, {})
        if not isinstance(node, dict):
            raise ConfigError(f"{key!r}: cannot set a key inside a non-mapping value")
        node[rest[-1]] = value
    unknown = sorted(set(params) - known)
    if unknown:
        source = hp_file if hp_file is not None else f"built-in hyperparameters for {world}"
        raise ConfigError(f"{source}/{algo} has unknown keys {unknown}")
    return zoo_schedules(params)


#: The RL Zoo's spelling of a schedule: ``lin_<start>`` moves linearly to zero over the run.
_ZOO_LINEAR = "lin_"


def zoo_schedules(params: Mapping[str, Any]) -> dict[str, Any]:
    """``params`` with the RL Zoo's ``lin_<start>`` schedules written as noisybolt's:
    ``<name>: <start>`` and ``<name>_final: 0.0`` (over the run's budget, as the Zoo's over
    its ``n_timesteps``), so that a Zoo file reads the same here and the resolved config
    holds numbers.

    Raises:
        ConfigError: the start is not a number, the key is not one SB3 schedules
            (``learning_rate``, ``clip_range``), or ``<name>_final`` is given as well.

    Example:
        >>> zoo_schedules({"learning_rate": "lin_2.5e-4", "n_steps": 128})
        {'learning_rate': 0.00025, 'n_steps': 128, 'learning_rate_final': 0.0}
    """
    out = dict(params)
    for name, value in params.items():
        if not (isinstance(value, str) and value.startswith(_ZOO_LINEAR)):
            continue
        if name not in SCHEDULED or name == "ent_coef":
            raise ConfigError(
                f"{name}={value!r}: only learning_rate and clip_range take the RL Zoo's "
                f"lin_<start> schedules (ent_coef moves with ent_coef_final)"
            )
        try:
            start = float(value.removeprefix(_ZOO_LINEAR))
        except ValueError:
            raise ConfigError(
                f"{name}={value!r}: a linear schedule is lin_<start>, e.g. lin_2.5e-4"
            ) from None
        if out.get(f"{name}_final") is not None:
            raise ConfigError(
                f"{name}={value!r} and {name}_final both set: lin_ already moves {name} to 0; "
                f"give {name}=<start> with {name}_final, or lin_ alone"
            )
        out[name] = start
        out[f"{name}_final"] = 0.0
    return out


#: Ranges of the SB3 hyperparameters whose bad values would otherwise pass construction
#: and fail (or silently misbehave) mid-run: ``(low, high, low_open, high_open)``.
_RANGES: dict[str, tuple[float, float, bool, bool]] = {
    "gamma": (0.0, 1.0, True, False),
    "gae_lambda": (0.0, 1.0, False, False),
    "learning_rate": (0.0, float("inf"), True, True),
    "n_steps": (1, float("inf"), False, True),
    "batch_size": (1, float("inf"), False, True),
    "n_epochs": (1, float("inf"), False, True),
    "buffer_size": (1, float("inf"), False, True),
    "learning_starts": (0, float("inf"), False, True),
    "target_update_interval": (1, float("inf"), False, True),
    "gradient_steps": (-1, float("inf"), False, True),
    "tau": (0.0, 1.0, True, False),
    "ent_coef": (0.0, float("inf"), False, True),
    "ent_coef_final": (0.0, float("inf"), False, True),
    "bolt_weight": (0.0, float("inf"), True, True),
    "ent_coef_frames": (1, float("inf"), False, True),
    "learning_rate_final": (0.0, float("inf"), False, True),
    "learning_rate_frames": (1, float("inf"), False, True),
    "clip_range_final": (0.0, float("inf"), False, True),
    "clip_range_frames": (1, float("inf"), False, True),
    "exploration_frames": (1, float("inf"), False, True),
    "vf_coef": (0.0, float("inf"), False, True),
    "max_grad_norm": (0.0, float("inf"), True, True),
    "clip_range": (0.0, float("inf"), True, True),
    "exploration_fraction": (0.0, 1.0, False, False),
    "exploration_initial_eps": (0.0, 1.0, False, False),
    "exploration_final_eps": (0.0, 1.0, False, False),
    "n_envs": (1, float("inf"), False, True),
    "image_features": (1, float("inf"), False, True),
}
_INTEGERS = frozenset(
    {"n_envs", "image_features", "exploration_frames", *(f"{n}_frames" for n in SCHEDULED)}
)


def check_hyperparameter_values(algo: str, params: Mapping[str, Any]) -> None:
    """Refuses hyperparameter values of the wrong type or out of range.

    A number's type is the SB3 constructor default's (an int where SB3 counts, a float
    where it weighs); the ranges are those of ``_RANGES`` (``gamma`` in (0, 1], counts
    >= 1, ...). What only the model's construction can tell is left to it.

    Raises:
        ConfigError: naming the key, the value and what is expected.

    Example:
        >>> check_hyperparameter_values("ppo", {"gamma": 2})
        Traceback (most recent call last):
        ...
        noisybolt.errors.ConfigError: hyperparameter gamma=2 is out of range: it must be in (0, 1]
    """
    defaults = constructor_defaults(algo)
    for key, value in params.items():
        default = defaults.get(key, inspect.Parameter.empty)
        numeric_default = isinstance(default, (int, float)) and not isinstance(default, bool)
        if key == "train_freq" and isinstance(value, (list, tuple)):
            continue
        if value is None and key in META_KEYS:  # noisybolt's own settings: null is unset
            continue
        if key == "normalize_reward":
            _check_normalize_reward(algo, value)
            continue
        if key in _RANGES or numeric_default:
            wants_int = key in _INTEGERS or (isinstance(default, int) and numeric_default)
            number = isinstance(value, (int, float)) and not isinstance(value, bool)
            if not number or (wants_int and not isinstance(value, int)):
                kind = "an integer" if wants_int else "a number"
                hint = (
                    f" (a schedule here is {key}=<start> with {key}_final=<end>; the RL Zoo's "
                    "lin_<start> is read from --hp and hyperparameter files)"
                    if key in SCHEDULED and isinstance(value, str)
                    else ""
                )
                raise ConfigError(f"hyperparameter {key}={value!r} must be {kind}{hint}")
        elif isinstance(default, bool) and not isinstance(value, bool):
            raise ConfigError(f"hyperparameter {key}={value!r} must be true or false")
        if key in _RANGES:
            low, high, low_open, high_open = _RANGES[key]
            below = value <= low if low_open else value < low
            above = value >= high if high_open else value > high
            if below or above:
                top = "inf" if high == float("inf") else f"{high:g}"
                interval = f"{'(' if low_open else '['}{low:g}, {top}{')' if high_open else ']'}"
                raise ConfigError(
                    f"hyperparameter {key}={value!r} is out of range: it must be in {interval}"
                )


def _check_normalize_reward(algo: str, value: Any) -> None:
    if not isinstance(value, bool) and value != SPLIT:
        raise ConfigError(
            f"hyperparameter normalize_reward={value!r} must be true, false or {SPLIT!r} "
            "(the world's rewards and the bolt's normalised apart)"
        )
    if value == SPLIT and algo.lower() not in ("ppo", "a2c"):
        raise ConfigError(
            f"hyperparameter normalize_reward={SPLIT!r} needs an on-policy learner (ppo, a2c): "
            f"{algo}'s replay buffer keeps each step's summed reward and normalises it as it "
            "samples, which cannot tell the world's share from the bolt's; use "
            "normalize_reward=true"
        )


#: The action spaces of the algorithms that take only some (SB3 asserts them deep inside
#: the constructor, which reads as a hyperparameter problem; no hyperparameter fixes it).
ACTION_SPACES: dict[str, tuple[type[spaces.Space], ...]] = {"dqn": (spaces.Discrete,)}


def check_action_space(algo: str, action_space: spaces.Space, *, world: str) -> None:
    """Refuses an algorithm that cannot act in a world's action space (DQN on a
    continuous or multi-part one), naming those that can.

    Raises:
        ConfigError: naming the algorithm, the world's space and the alternatives.

    Example:
        >>> check_action_space("ppo", spaces.Box(-1, 1, (1,)), world="car")
        >>> check_action_space("dqn", spaces.Box(-1, 1, (1,)), world="car")  # doctest: +ELLIPSIS
        Traceback (most recent call last):
        ...
        noisybolt.errors.ConfigError: DQN takes only Discrete actions, and world 'car' acts in ...
    """
    allowed = ACTION_SPACES.get(algo)
    if allowed is not None and not isinstance(action_space, allowed):
        others = [name for name in ALGORITHMS if name not in ACTION_SPACES]
        raise ConfigError(
            f"{algo.upper()} takes only {' or '.join(a.__name__ for a in allowed)} actions, "
            f"and world {world!r} acts in {action_space}; train it with --algo "
            f"{' or '.join(others)}"
        )


def check_budget(algo: str, *, frames: int, n_envs: int, hyperparams: Mapping[str, Any]) -> None:
    """Refuses a budget an algorithm cannot keep: PPO's or A2C's first rollout (``n_envs``
    x ``n_steps`` frames) larger than ``frames`` (SB3 would train that rollout whole, past
    the budget), or DQN's ``learning_starts`` at or past ``frames`` (it would never learn).

    Raises:
        ConfigError: giving the arithmetic and what to change.

    Example:
        >>> check_budget("ppo", frames=1000, n_envs=64, hyperparams={"n_steps": 128})
        Traceback (most recent call last):
        ...
        noisybolt.errors.ConfigError: frames 1,000 is less than one PPO rollout: \
world.n_envs x algorithm.hyperparams.n_steps = 64 x 128 = 8,192 frames, which would be \
trained whole, past the budget; give --frames 8192 or more, or --hp n_steps=15 or less
    """
    params = {**constructor_defaults(algo), **hyperparams}
    if algo in ("ppo", "a2c"):  # one rollout of every env before an update
        steps = params["n_steps"]
        rollout = n_envs * steps
        if rollout > frames:
            fewer = (
                f"--hp n_steps={frames // n_envs} or less"
                if frames >= n_envs
                else f"--n-envs {frames} or less"
            )
            raise ConfigError(
                f"frames {frames:,} is less than one {algo.upper()} rollout: "
                f"world.n_envs x algorithm.hyperparams.n_steps = {n_envs} x {steps} "
                f"= {rollout:,} frames, which would be trained whole, past the budget; "
                f"give --frames {rollout} or more, or {fewer}"
            )
        return
    starts = params.get("learning_starts")
    if isinstance(starts, int) and starts >= frames:
        raise ConfigError(
            f"algorithm.hyperparams.learning_starts {starts:,} >= frames {frames:,}: "
            f"{algo.upper()} would never learn; give --frames above {starts} or --hp "
            f"learning_starts={frames // 10}"
        )
