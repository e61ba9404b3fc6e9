"""Evaluating a bolted policy: returns, lengths, goal rate and compliance from ground truth.

Compliance is never judged by looking: an episode complies with a spec when the spec's
DFA, run on the *true* fluents of the episode (``info["true_accepting"]`` of the bolted
env, computed from the world's ground truth), ends in an accepting state.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
from stable_baselines3.common.vec_env import VecEnv

__all__ = [
    "EpisodeRecord",
    "EvalResult",
    "episode_targets",
    "evaluate_bolted_policy",
    "summarise",
]

Predict = Callable[[Any], np.ndarray]


@dataclass(frozen=True)
class EpisodeRecord:
    """One evaluation episode.

    Attributes:
        env_return: sum of the environment's rewards (R_π's summand).
        bolt_return: sum of the bolt's shaping rewards (reported apart).
        length: number of steps.
        goal: whether the episode reached the task's goal: ``info["is_success"]`` of its
            last step (SB3's convention; the gridworld's worlds set it on termination),
            else "terminated, not truncated"; None where the world declares no goal
            (:func:`~noisybolt.perception.protocols.goal_declared`: Breakout, a
            :class:`~noisybolt.FluentLabels` env without ``success``).
        compliant: per spec, whether the true trace is accepted by its DFA.
        bolt_accepting: per spec, whether the bolt's own DFA (run on what it *perceived*)
            ended the episode accepting; empty where not recorded.
    """

    env_return: float
    bolt_return: float
    length: int
    goal: bool | None
    compliant: tuple[bool, ...]
    bolt_accepting: tuple[bool, ...] = ()


@dataclass(frozen=True)
class EvalResult:
    """Summary over K episodes (means and standard deviations over episodes).

    ``success_rate`` is the share of episodes that reach the goal and comply with every
    spec; for a world without a goal (``goal_rate`` None), that comply with every spec.

    ``false_acceptance`` is, per spec, the fraction of episodes whose bolt DFA ended
    accepting while the true trace was not accepted: what the bolt paid for and never
    happened. With a noisy camera and an ``F(x)`` spec one false positive of ``x`` is
    enough (the DFA never leaves its accepting sink), so over long episodes this measures
    how far the bolt's rewards can be trusted. Empty where episodes did not record it.

    ``bolt_cost_mean`` is the mean over episodes of the specs the bolt's own DFAs left
    unsatisfied at the episode's end: the ``constrained`` scheme's episode cost as the bolt
    sees it (never ground truth), what the kept model's budget is judged by
    (:func:`~noisybolt.runs.callbacks.budget_score`). None where not recorded.
    """

    n_episodes: int
    env_return_mean: float
    env_return_std: float
    bolt_return_mean: float
    length_mean: float
    goal_rate: float | None
    compliance: dict[str, float]
    success_rate: float
    episodes: tuple[EpisodeRecord, ...] = field(repr=False, default=())
    false_acceptance: dict[str, float] = field(default_factory=dict)
    bolt_cost_mean: float | None = None

    @classmethod
    def from_record(cls, record: Mapping[str, Any]) -> EvalResult:
        """The result a ``metrics.json`` record holds (:meth:`to_dict`; its other keys,
        such as ``frames``, left out)."""
        return cls(**{k: v for k, v in record.items() if k in cls.__dataclass_fields__})

    def to_dict(self, *, with_episodes: bool = False) -> dict[str, Any]:
        """A JSON-able dict (episodes only when asked)."""
        data = asdict(self)
        if not with_episodes:
            data.pop("episodes")
        else:
            data["episodes"] = [asdict(e) for e in self.episodes]
        return data


def summarise(episodes: Sequence[EpisodeRecord], spec_names: Sequence[str]) -> EvalResult:
    """Aggregates episode records; ``success`` = reaches the goal and complies with all
    specs (with no goal declared: complies with all specs).

    Example:
        >>> eps = [EpisodeRecord(90.0, 5.0, 7, True, (True,)),
        ...        EpisodeRecord(-30.0, 0.0, 20, False, (False,))]
        >>> r = summarise(eps, ["edge"])
        >>> r.env_return_mean, r.goal_rate, r.compliance, r.success_rate
        (30.0, 0.5, {'edge': 0.5}, 0.5)
        >>> no_goal = [EpisodeRecord(1.0, 0.0, 9, None, (True,)),
        ...            EpisodeRecord(3.0, 0.0, 9, None, (True,))]
        >>> r = summarise(no_goal, ["edge"])
        >>> r.goal_rate, r.success_rate
        (None, 1.0)
    """
    if not episodes:
        raise ValueError("cannot summarise zero episodes")
    returns = np.array([e.env_return for e in episodes])
    compliant = np.array([e.compliant for e in episodes], dtype=bool).reshape(len(episodes), -1)
    declared = [e.goal is not None for e in episodes]
    if any(declared) and not all(declared):
        raise ValueError("some episodes record a goal and some do not: one world's episodes")
    goal = np.array([bool(e.goal) for e in episodes]) if all(declared) else None
    false_acceptance: dict[str, float] = {}
    bolt_cost: float | None = None
    if all(len(e.bolt_accepting) == compliant.shape[1] for e in episodes):
        bolt = np.array([e.bolt_accepting for e in episodes], dtype=bool).reshape(compliant.shape)
        false = bolt & ~compliant
        false_acceptance = {name: float(false[:, i].mean()) for i, name in enumerate(spec_names)}
        bolt_cost = float((~bolt).sum(axis=1).mean())
    return EvalResult(
        n_episodes=len(episodes),
        env_return_mean=float(returns.mean()),
        env_return_std=float(returns.std()),
        bolt_return_mean=float(np.mean([e.bolt_return for e in episodes])),
        length_mean=float(np.mean([e.length for e in episodes])),
        goal_rate=None if goal is None else float(goal.mean()),
        compliance={name: float(compliant[:, i].mean()) for i, name in enumerate(spec_names)},
        success_rate=float(
            (compliant.all(axis=1) if goal is None else goal & compliant.all(axis=1)).mean()
        ),
        episodes=tuple(episodes),
        false_acceptance=false_acceptance,
        bolt_cost_mean=bolt_cost,
    )


def describe_false_acceptance(summary: Mapping[str, Any]) -> str | None:
    """One line on an evaluation's ``false_acceptance`` (None where it was not recorded).

    Example:
        >>> describe_false_acceptance({"false_acceptance": {"a": 0.0, "b": 0.25}})
        'b 25%'
        >>> describe_false_acceptance({"false_acceptance": {"a": 0.0}})
        'none'
    """
    rates = summary.get("false_acceptance") or {}
    if not rates:
        return None
    falsely = [f"{name} {rate:.0%}" for name, rate in rates.items() if rate > 0]
    return ", ".join(falsely) if falsely else "none"


def episode_targets(n_episodes: int, n_envs: int) -> np.ndarray:
    """How many of ``n_episodes`` each of ``n_envs`` environments records, spread evenly
    (as SB3's ``evaluate_policy`` spreads them): the first ``n_episodes`` to end would
    over-represent short episodes.

    >>> episode_targets(10, 4).tolist()
    [2, 2, 3, 3]
    """
    return np.array([(n_episodes + i) // n_envs for i in range(n_envs)], dtype=int)


def _bolt_vec_env(env: VecEnv) -> Any:
    """The :class:`~noisybolt.wrappers.BoltVecEnv` under ``env``'s VecEnv wrappers (its
    ``reset_infos`` hold the episodes' first frames; a wrapper keeps its own)."""
    from noisybolt.wrappers import BoltVecEnv

    inner: Any = env
    while not isinstance(inner, BoltVecEnv):
        if not hasattr(inner, "venv"):
            raise TypeError(f"{type(env).__name__} wraps no BoltVecEnv: no detector outputs")
        inner = inner.venv
    return inner


def evaluate_bolted_policy(
    predict: Predict,
    env: VecEnv,
    *,
    n_episodes: int,
    spec_names: Sequence[str],
    on_step: Callable[[VecEnv, np.ndarray], None] | None = None,
    on_episode: Callable[[int, EpisodeRecord], None] | None = None,
    traces: list[np.ndarray] | None = None,
) -> EvalResult:
    """Runs ``n_episodes`` on a bolted ``VecEnv`` and summarises them.

    Episodes are spread evenly over the environments (as SB3's ``evaluate_policy`` does)
    so that short episodes are not over-represented.

    Args:
        predict: maps a batch of observations to actions (e.g.
            ``lambda obs: model.predict(obs, deterministic=True)[0]``).
        env: a :class:`~noisybolt.wrappers.BoltVecEnv` (possibly wrapped).
        n_episodes: how many episodes to record.
        spec_names: names of the bolt's specs, in order.
        on_step: called after the reset (``dones`` all False) and after every step with
            ``(env, dones)``: to follow what the episodes go through (e.g. positions).
        on_episode: called with ``(env_index, record)`` for every episode recorded, in
            the order of the result's ``episodes``.
        traces: a list to which every recorded episode's detector probabilities are
            appended (float64 ``[T, n_fluents]``, row 0 its first observation), in the
            order of the result's ``episodes``: what a compliance estimate reads
            (:mod:`noisybolt.runs.compliance`).
    """
    if n_episodes < 1:
        raise ValueError(f"n_episodes must be >= 1, got {n_episodes}")
    n_envs = env.num_envs
    # Through the VecEnv wrappers to SB3VecEnv; an env that does not say has a goal.
    has_goal = bool(getattr(env, "declares_goal", True))
    targets = episode_targets(n_episodes, n_envs)
    counts = np.zeros(n_envs, dtype=int)
    env_ret = np.zeros(n_envs)
    bolt_ret = np.zeros(n_envs)
    lengths = np.zeros(n_envs, dtype=int)
    episodes: list[EpisodeRecord] = []
    obs = env.reset()
    bolt_env = _bolt_vec_env(env) if traces is not None else None
    frames: list[list[np.ndarray]] = [[] for _ in range(n_envs)]
    if bolt_env is not None:
        frames = [[np.asarray(info["fluent_probs"])] for info in bolt_env.reset_infos]
    if on_step is not None:
        on_step(env, np.zeros(n_envs, dtype=bool))
    while (counts < targets).any():
        actions = predict(obs)
        obs, _, dones, infos = env.step(actions)
        if on_step is not None:
            on_step(env, dones)
        for i, info in enumerate(infos):
            env_ret[i] += info["env_reward"]
            bolt_ret[i] += info["bolt_reward"]
            lengths[i] += 1
            if bolt_env is not None:
                frames[i].append(np.asarray(info["fluent_probs"]))
            if not dones[i]:
                continue
            if counts[i] < targets[i]:
                truncated = bool(info.get("TimeLimit.truncated", False))
                goal = bool(info.get("is_success", not truncated)) if has_goal else None
                episodes.append(
                    EpisodeRecord(
                        env_return=float(env_ret[i]),
                        bolt_return=float(bolt_ret[i]),
                        length=int(lengths[i]),
                        goal=goal,
                        compliant=tuple(bool(a) for a in info["true_accepting"]),
                        bolt_accepting=tuple(bool(a) for a in info["dfa_accepting"]),
                    )
                )
                if on_episode is not None:
                    on_episode(i, episodes[-1])
                if traces is not None:
                    traces.append(np.stack(frames[i]).astype(np.float64))
                counts[i] += 1
            env_ret[i] = bolt_ret[i] = lengths[i] = 0
            if bolt_env is not None:
                frames[i] = [np.asarray(bolt_env.reset_infos[i]["fluent_probs"])]
    return summarise(episodes, spec_names)
