"""noisybolt: restraining bolts with noisy perception for reinforcement learning.

Bolt any Gymnasium env in a few lines: label it with its fluents, then wrap it.

Example:
    >>> import gymnasium as gym
    >>> import noisybolt
    >>> lake = noisybolt.FluentLabels(
    ...     gym.make("FrozenLake-v1", render_mode="rgb_array", is_slippery=False),
    ...     fluents={"top_row": lambda lake: lake.s < 4},
    ... )
    >>> env = noisybolt.RestrainingBoltWrapper(lake, ["G(top_row)"], "oracle")
    >>> obs, info = env.reset(seed=0)
    >>> sorted(obs)
    ['dfa', 'image']

Layers, lowest first (a lower layer never imports a higher one):
``logic`` (LTLf → DFA), ``bolt`` (Algorithm 1 and reward timing), ``perception``
(cameras, noise, fluent classifiers), ``envs`` (worlds and their true fluents),
``wrappers``, ``viz`` (episode GIFs, heat-maps), ``agents`` (the learner), ``runs``
(config, training, checkpoints, evaluation), ``experiments``, ``cli``. The names below
are imported on first use, so ``import noisybolt.logic`` does not load Gymnasium or torch.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from noisybolt import _moved
from noisybolt.version import __version__

_moved.install()  # old module paths of moved names, for one release

# The public API: name -> module that defines it.
_EXPORTS: dict[str, str] = {
    "BoltVecEnv": "noisybolt.wrappers.bolt_vec_env",
    "FluentDetector": "noisybolt.perception.protocols",
    "FluentLabels": "noisybolt.envs.labels",
    "GridLayout": "noisybolt.envs.layout",
    "RestrainingBoltWrapper": "noisybolt.wrappers.bolt_wrapper",
    "Spec": "noisybolt.bolt.spec",
    "compile_ltlf": "noisybolt.logic.compiler",
    "make_bolted_vec_env": "noisybolt.wrappers.make_vec",
}

__all__ = ["__version__", *sorted(_EXPORTS)]

if TYPE_CHECKING:
    from noisybolt.bolt.spec import Spec as Spec
    from noisybolt.envs.labels import FluentLabels as FluentLabels
    from noisybolt.envs.layout import GridLayout as GridLayout
    from noisybolt.logic.compiler import compile_ltlf as compile_ltlf
    from noisybolt.perception.protocols import FluentDetector as FluentDetector
    from noisybolt.wrappers.bolt_vec_env import BoltVecEnv as BoltVecEnv
    from noisybolt.wrappers.bolt_wrapper import RestrainingBoltWrapper as RestrainingBoltWrapper
    from noisybolt.wrappers.make_vec import make_bolted_vec_env as make_bolted_vec_env


def __getattr__(name: str) -> Any:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'noisybolt' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_EXPORTS))
