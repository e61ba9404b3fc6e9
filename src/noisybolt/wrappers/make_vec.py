"""The batched bolt over any labelled env, in one call (as SB3's ``make_vec_env``)."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import gymnasium as gym
from stable_baselines3.common.vec_env import VecMonitor

from noisybolt.bolt import (
    DEFAULT_THRESHOLDS,
    BeliefSettings,
    BoltSettings,
    CostMode,
    Spec,
    Thresholds,
    Tracking,
)
from noisybolt.envs.labelled_vec import LabelledVectorEnv
from noisybolt.envs.labels import collect_labelled_samples
from noisybolt.envs.sb3 import SB3VecEnv
from noisybolt.errors import ConfigError
from noisybolt.logic.dfa import DFA
from noisybolt.perception.protocols import FluentDetector
from noisybolt.wrappers._inputs import DetectorName, coerce_specs, resolve_detector
from noisybolt.wrappers.bolt_vec_env import BoltVecEnv

__all__ = ["make_bolted_vec_env"]


def make_bolted_vec_env(
    env_fn: Callable[[], gym.Env],
    n_envs: int,
    specs: Spec | str | Sequence[Spec | str],
    detector: FluentDetector | DetectorName = "oracle",
    *,
    seed: int | None = None,
    monitor: bool = True,
    dfas: Sequence[DFA] | None = None,
    settings: BoltSettings | None = None,
    classifier_samples: int = 2000,
    thresholds: Thresholds = DEFAULT_THRESHOLDS,
    cost_mode: CostMode = "count",
    tracking: Tracking = "threshold",
    belief: BeliefSettings | None = None,
) -> BoltVecEnv:
    """``n_envs`` copies of a labelled env, bolted, as an SB3 ``VecEnv`` ready to train on.

    The envs run in a :class:`~noisybolt.envs.labelled_vec.LabelledVectorEnv` (same-step
    autoreset: the bolt reads each ended episode's last view from ``final_info`` before the
    next episode starts), with SB3's ``VecMonitor`` below the bolt so that logged returns
    are the environment's, and :class:`BoltVecEnv` on top. Its rewards and observations
    are those of ``n_envs`` separate :class:`~noisybolt.wrappers.RestrainingBoltWrapper` s.

    Args:
        env_fn: returns a labelled env (e.g. wrapped in :class:`noisybolt.FluentLabels`).
        n_envs: number of envs.
        specs: :class:`Spec` s or LTLf formulas (text gets the paper's rewards).
        detector: a :class:`FluentDetector`, or ``"oracle"``, ``"synthetic"`` or
            ``"classifier"`` (trained on ``classifier_samples`` images from one more env).
        seed: seeds the first reset (env ``i`` with ``seed + i``) and a detector built by
            name (with ``seed``, or 0).
        monitor: put a ``VecMonitor`` below the bolt (episode returns, lengths and
            ``is_success`` in the logs).
        dfas, settings: as in :class:`BoltVecEnv` (a
            :class:`~noisybolt.bolt.BoltSettings`; with ``tracking="belief"``, ``"dfa"``
            holds each spec's beliefs over its states).
        thresholds, cost_mode, tracking, belief: the settings as keywords, for code
            written before ``settings`` (giving both is refused).
        classifier_samples: images to train a ``"classifier"`` detector on.

    Raises:
        ConfigError: ``n_envs`` < 1.
        UnlabelledEnvError: ``env_fn`` returns an env that is not labelled.
        UnknownFluentError: a spec reads a fluent the env does not have.

    Example:
        >>> import gymnasium as gym
        >>> from noisybolt import FluentLabels
        >>> def lake():
        ...     env = gym.make("FrozenLake-v1", render_mode="rgb_array", is_slippery=False)
        ...     return FluentLabels(env, fluents={"top_row": lambda lake: lake.s < 4})
        >>> venv = make_bolted_vec_env(lake, 4, ["G(top_row)"], seed=0)
        >>> obs = venv.reset()
        >>> obs["image"].shape, obs["dfa"].tolist()
        ((4,), [[0], [0], [0], [0]])
    """
    if isinstance(n_envs, bool) or not isinstance(n_envs, int) or n_envs < 1:
        raise ConfigError(f"n_envs must be an integer >= 1, got {n_envs!r}")
    if not callable(env_fn):
        raise ConfigError(f"env_fn must be a function returning a labelled env, got {env_fn!r}")
    specs = coerce_specs(specs)
    world = LabelledVectorEnv([env_fn] * n_envs)
    detector_seed = 0 if seed is None else seed
    detector = resolve_detector(
        detector,
        world.fluent_names,
        seed=detector_seed,
        samples=lambda: collect_labelled_samples(
            env_fn(), num_samples=classifier_samples, seed=detector_seed
        ),
        specs=specs,
    )
    venv = SB3VecEnv(world)
    bolted = BoltVecEnv(
        VecMonitor(venv) if monitor else venv,
        specs,
        detector,
        world=world,
        dfas=dfas,
        settings=settings,
        thresholds=thresholds,
        cost_mode=cost_mode,
        tracking=tracking,
        belief=belief,
    )
    if seed is not None:
        bolted.seed(seed)
    return bolted
