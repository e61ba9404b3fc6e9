"""Reading the configs of runs saved by older versions: the flat ``config.json`` of
schema 1, and what a config saved before a setting existed meant by it.

:func:`nested_config` turns any saved config into today's nested form (nothing is
validated here: :meth:`~noisybolt.runs.config.TrainConfig.from_dict` does that), so old
runs resume and evaluate as they were started.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from typing import Any

from noisybolt.agents.hyperparams import WORLD_KEYS
from noisybolt.errors import ConfigError
from noisybolt.runs.schema import set_path

__all__ = ["FLAT_PATHS", "LEGACY_DEFAULTS", "SCHEMA_VERSION", "nested_config"]

#: The version of the nested schema that ``config.json`` holds under ``"schema"`` (a
#: config without it is the flat form of the runs saved before: version 1).
SCHEMA_VERSION = 2
#: What a config saved before a setting existed meant by it, by schema path (read by
#: :func:`nested_config`: a saved config that lacks the path gets this value).
LEGACY_DEFAULTS: dict[str, Any] = {
    "bolt.reward": "paper",
    "bolt.reward_scale": None,
    "bolt.shaping": False,
    # before bolt.pay_on_change existed the compliance scheme paid at the episode's end
    "bolt.pay_on_change": False,
    "evaluation.stop_after": 0,
    # before keep_best existed a run's final model was its last
    "evaluation.keep_best": False,
    # before the constrained scheme existed no run had a cost budget
    "bolt.constraint": {},
    # before belief tracking existed every bolt tracked by threshold (Algorithm 1)
    "bolt.tracking": "threshold",
    "bolt.confidence": 0.9,
    # before bolt.min_dwell existed belief tracking assumed two steps
    "bolt.min_dwell": 2,
    # before world.workers existed every world ran in the training process
    "world.workers": 0,
    # before world.overlap existed every rollout stepped all games at once
    "world.overlap": False,
    # before world.train_kwargs existed the learner's games were the evaluation's
    "world.train_kwargs": {},
    # before algorithm.device existed every agent trained on the CPU
    "algorithm.device": "cpu",
    # before algorithm.precision existed every agent computed in float32
    "algorithm.precision": "float32",
    # before algorithm.init_from existed every agent started from random weights
    "algorithm.init_from": None,
    # before algorithm.counterfactual existed every transition was stored as gathered
    "algorithm.counterfactual": False,
    "algorithm.counterfactual_samples": 16,
    # before detector.restarts existed one classifier was trained, from detector.seed
    "detector.restarts": 1,
    # before detector.final_views existed collection never kept an episode's last state
    "detector.final_views": False,
    # before detector.kwargs existed no detector took further arguments
    "detector.kwargs": {},
}

#: The flat name of each setting held in a section (``tracking`` -> ``bolt.tracking``):
#: the keys of the flat ``config.json`` of older runs, :meth:`TrainConfig.create`'s
#: keywords and the read-only attributes of :class:`~noisybolt.runs.config.TrainConfig`
#: that read them (a test holds the two lists equal).
FLAT_PATHS: dict[str, str] = {
    "world": "world.name",
    "world_kwargs": "world.kwargs",
    "n_envs": "world.n_envs",
    "specs": "bolt.specs",
    "reward": "bolt.reward",
    "reward_scale": "bolt.reward_scale",
    "shaping": "bolt.shaping",
    "pay_on_change": "bolt.pay_on_change",
    "tracking": "bolt.tracking",
    "confidence": "bolt.confidence",
    "min_dwell": "bolt.min_dwell",
    "thresholds": "bolt.thresholds",
    "cost_mode": "bolt.cost_mode",
    "bolted": "bolt.bolted",
    "algo": "algorithm.name",
    "hyperparams": "algorithm.hyperparams",
    "device": "algorithm.device",
    "eval_freq": "evaluation.freq",
    "eval_episodes": "evaluation.episodes",
    "eval_envs": "evaluation.envs",
    "eval_deterministic": "evaluation.deterministic",
    "success_threshold": "evaluation.success_threshold",
    "stop_after": "evaluation.stop_after",
    "keep_best": "evaluation.keep_best",
}


def nested_config(data: Mapping[str, Any]) -> dict[str, Any]:
    """A saved config's data in today's nested form, with its schema version: the flat
    ``config.json`` of a run saved before the schema was nested converted (its keys are
    :data:`FLAT_PATHS`; world settings among its hyperparameters moved to ``world``), and
    every path of
    :data:`LEGACY_DEFAULTS` it lacks filled in. Nothing is validated here.

    Raises:
        ConfigError: not a mapping, or a schema version this noisybolt does not read.

    Example:
        >>> nested = nested_config({"algo": "dqn", "eval_freq": 500, "hyperparams": {"n_envs": 2}})
        >>> nested["algorithm"], nested["evaluation"]["freq"], nested["world"]["n_envs"]
        ({'name': 'dqn', 'hyperparams': {}, 'device': 'cpu', 'precision': 'float32', \
'init_from': None, 'counterfactual': False, 'counterfactual_samples': 16}, 500, 2)
        >>> nested["bolt"]["tracking"]  # runs saved before belief tracking tracked by threshold
        'threshold'
    """
    if not isinstance(data, Mapping):
        raise ConfigError(f"a training config is a mapping, got {type(data).__name__}")
    raw: dict[str, Any] = json.loads(json.dumps(dict(data)))
    version = raw.pop("schema", None)
    nested_form = version is not None or any(
        isinstance(raw.get(k), Mapping) for k in ("world", "bolt", "algorithm", "evaluation")
    )
    if version is not None and version != SCHEMA_VERSION:
        raise ConfigError(
            f"config schema {version!r}: this noisybolt reads schema {SCHEMA_VERSION} (and the "
            "flat configs of older runs); use the noisybolt version that wrote it"
        )
    out: dict[str, Any] = raw if nested_form else {}
    if not nested_form:
        for key, value in raw.items():
            if key == "hyperparams" and isinstance(value, Mapping):
                value = dict(value)
                for name in sorted(WORLD_KEYS & set(value)):
                    setting = value.pop(name)
                    if setting is not None:
                        set_path(out, f"world.{name}", setting)
            set_path(out, FLAT_PATHS.get(key, key), value)
    for path, value in LEGACY_DEFAULTS.items():
        section, key = path.split(".")
        if not isinstance(out.get(section), dict):
            out.setdefault(section, {})  # a section of the wrong type is refused by loading
        if isinstance(out[section], dict) and key not in out[section]:
            out[section][key] = value
    return {"schema": SCHEMA_VERSION, **out}
