"""Overlapped rollouts: one group of games steps in its workers while the learner works
on the other (``world.overlap``).

SB3's on-policy collector steps every game at once: the learner computes the policy for
all games, waits while the world steps them, then runs the bolt's classifier and the bolt
on all of them, while the world waits. With the world in worker processes
(:class:`~noisybolt.envs.worker_world.WorkerWorld`) the two could run side by side on two
cores, but never do. Here the training games are split into groups
(:class:`GroupedVecEnv`: each group a whole bolted stack over its own share of the world's
games and workers), and :class:`OverlappedRollouts` collects a rollout in turns::

    learner:  policy(B, t)  send B  | receive A, bolt(A, t) | policy(A, t+1)  send A | ...
    workers:  A steps t ........................................ | B steps t ...........

so one group's world steps while the learner runs the policy, the classifier and the bolt
of the other.

A reward normaliser (``normalize_reward``: SB3's ``VecNormalize`` or
:class:`~noisybolt.wrappers.SplitRewardNormalize`) sits on top of the groups, as it sits on
top of the world in process, and sees the same steps: the collector joins the groups' steps
of one time step and hands them to the :class:`GroupedVecEnv` below the normaliser
(:meth:`GroupedVecEnv.hand_over`), whose next ``step_wait`` returns them, so the normaliser
updates its running returns on all games at once, in the games' order, as it would on the
world stepped whole. Normalised *observations* it cannot see in time (the next action of a
group is chosen before the other group's step is in), so a normaliser of observations is
refused.

What stays as SB3's collector has it: every action comes from the current policy (the
rollout's, never an older one: no game is sent a step of the next rollout before the
update), the games are the same ones (each group plays its games of the whole world, as
:class:`~noisybolt.envs.breakout.BreakoutWorld`'s ``shard`` does), and the rollout buffer
gets the same transitions in the same layout (games in their world order), with SB3's
bootstrapping of truncated episodes and its callbacks once per step of all games. What
changes for the same seed: the policy samples each group's actions in its own call, so
the random draws of a sampled action differ (a deterministic policy gives the very same
rollouts, tested), and the bolt's classifier sees half batches (the same probabilities up
to float rounding).

Example (the setting; a run uses it through ``noisybolt train --set world.workers=2
--set world.overlap=true``):

    >>> from noisybolt.runs.config import TrainConfig
    >>> TrainConfig.build({"world.name": "breakout-ram", "world.workers": 2,
    ...                    "world.overlap": True}).world_config.overlap
    True
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from functools import cache
from typing import Any

import gymnasium as gym
import numpy as np
import torch as th
from gymnasium import spaces
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.buffers import RolloutBuffer
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.on_policy_algorithm import OnPolicyAlgorithm
from stable_baselines3.common.utils import obs_as_tensor
from stable_baselines3.common.vec_env import VecEnv, VecNormalize
from stable_baselines3.common.vec_env.base_vec_env import VecEnvObs, VecEnvStepReturn

from noisybolt.errors import ConfigError

__all__ = [
    "GroupedVecEnv",
    "OverlappedRollouts",
    "group_bounds",
    "grouped_below",
    "overlapped_class",
]


def group_bounds(num_envs: int, groups: int) -> tuple[tuple[int, int], ...]:
    """``(first game, games)`` of each of ``groups`` contiguous groups of ``num_envs``
    games, as even as possible.

    >>> group_bounds(8, 2), group_bounds(5, 2)
    (((0, 4), (4, 4)), ((0, 2), (2, 3)))
    """
    if not 1 <= groups <= num_envs:
        raise ConfigError(f"{num_envs} games cannot be split into {groups} groups")
    edges = np.linspace(0, num_envs, groups + 1).round().astype(int)
    return tuple((int(a), int(b - a)) for a, b in itertools.pairwise(edges))


class GroupedVecEnv(VecEnv):
    """Several ``VecEnv`` side by side as one: group ``g``'s games are games
    ``slices[g]`` of the whole.

    Stepped as one (``step_async`` sends every group its actions, ``step_wait`` joins
    their steps), it is the whole world; :class:`OverlappedRollouts` steps the groups in
    turns instead. ``seed(s)`` gives every group the whole world's seed ``s``: each group
    is built as its share of that world (``shard``), so it must be seeded as the world.

    Args:
        groups: the groups, with equal observation and action spaces.

    Raises:
        ConfigError: no group, or the groups' spaces differ.
    """

    def __init__(self, groups: Sequence[VecEnv]) -> None:
        if not groups:
            raise ConfigError("GroupedVecEnv needs at least one group of environments")
        first = groups[0]
        for group in groups[1:]:
            if (
                group.observation_space != first.observation_space
                or group.action_space != first.action_space
            ):
                raise ConfigError(
                    "the groups of a GroupedVecEnv must have the same observation and action "
                    f"spaces, got {first.observation_space}, {first.action_space} and "
                    f"{group.observation_space}, {group.action_space}"
                )
        self.groups: tuple[VecEnv, ...] = tuple(groups)
        self._handed: VecEnvStepReturn | None = None
        edges = np.cumsum([0, *(group.num_envs for group in groups)])
        #: Group ``g``'s games in the whole.
        self.slices: tuple[slice, ...] = tuple(
            slice(int(a), int(b)) for a, b in itertools.pairwise(edges)
        )
        super().__init__(
            num_envs=int(edges[-1]),
            observation_space=first.observation_space,
            action_space=first.action_space,
        )

    def reset(self) -> VecEnvObs:
        """Resets every group; their observations joined."""
        obs = [group.reset() for group in self.groups]
        self.reset_infos = [info for group in self.groups for info in group.reset_infos]
        return join_obs(obs)

    def step_async(self, actions: np.ndarray) -> None:
        """Sends every group its games' actions."""
        for group, rows in zip(self.groups, self.slices, strict=True):
            group.step_async(actions[rows])

    def step_wait(self) -> VecEnvStepReturn:
        """Every group's step, joined in the games' order (or the step handed over)."""
        if self._handed is not None:
            step, self._handed = self._handed, None
            return step
        return join_steps([group.step_wait() for group in self.groups])

    def hand_over(self, step: VecEnvStepReturn) -> None:
        """The groups' steps of one time step, joined, collected by whoever stepped the
        groups one by one (:class:`OverlappedRollouts`): the next :meth:`step_wait`
        returns them, so that the wrappers on top (a reward normaliser) see them as a step
        of the whole."""
        self._handed = step

    def seed(self, seed: int | None = None) -> Sequence[int | None]:
        """Seeds every group with the whole world's ``seed`` (see the class docstring)."""
        for group in self.groups:
            group.seed(seed)
        return [None if seed is None else seed + i for i in range(self.num_envs)]

    def set_options(self, options: list[dict[str, Any]] | dict[str, Any] | None = None) -> None:
        """Options for the next reset: one dict for all, or a list in the games' order."""
        for group, rows in zip(self.groups, self.slices, strict=True):
            group.set_options(options[rows] if isinstance(options, list) else options)

    def close(self) -> None:
        """Closes every group."""
        for group in self.groups:
            group.close()

    def get_attr(self, attr_name: str, indices: Any = None) -> list[Any]:
        """The attribute of each game asked about, from its group."""
        return [self.groups[g].get_attr(attr_name, i)[0] for g, i in self._located(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: Any = None) -> None:
        """Sets the attribute of each game asked about, in its group."""
        for g, i in self._located(indices):
            self.groups[g].set_attr(attr_name, value, i)

    def env_method(
        self, method_name: str, *method_args: Any, indices: Any = None, **method_kwargs: Any
    ) -> list[Any]:
        """Calls the method of each game asked about, in its group."""
        return [
            self.groups[g].env_method(method_name, *method_args, indices=i, **method_kwargs)[0]
            for g, i in self._located(indices)
        ]

    def env_is_wrapped(self, wrapper_class: type[gym.Wrapper], indices: Any = None) -> list[bool]:
        """Whether each game asked about is wrapped, from its group."""
        return [
            self.groups[g].env_is_wrapped(wrapper_class, i)[0] for g, i in self._located(indices)
        ]

    def get_images(self) -> Sequence[np.ndarray | None]:
        """Every group's frames, joined."""
        return [frame for group in self.groups for frame in group.get_images()]

    def _located(self, indices: Any) -> list[tuple[int, int]]:
        """``(group, index in the group)`` of each game index asked about."""
        if indices is None:
            indices = range(self.num_envs)
        elif isinstance(indices, int | np.integer):
            indices = [indices]
        located = []
        for index in indices:
            g = next(g for g, rows in enumerate(self.slices) if rows.start <= index < rows.stop)
            located.append((g, int(index) - self.slices[g].start))
        return located


def join_obs(parts: Sequence[Any]) -> Any:
    """Observations of consecutive games joined (a dict observation key by key)."""
    if isinstance(parts[0], dict):
        return {key: np.concatenate([part[key] for part in parts]) for key in parts[0]}
    return np.concatenate(parts)


def rows_of(obs: Any, rows: slice) -> Any:
    """The observations of games ``rows`` (a dict observation key by key)."""
    if isinstance(obs, dict):
        return {key: value[rows] for key, value in obs.items()}
    return obs[rows]


def join_steps(parts: Sequence[VecEnvStepReturn]) -> VecEnvStepReturn:
    """The steps of consecutive games joined."""
    obs, rewards, dones, infos = zip(*parts, strict=True)
    return (
        join_obs(obs),
        np.concatenate(rewards),
        np.concatenate(dones),
        [info for part in infos for info in part],
    )


class OverlappedRollouts(OnPolicyAlgorithm):
    """An on-policy algorithm (PPO, A2C) whose rollouts on a :class:`GroupedVecEnv` are
    collected overlapped (see the module docstring), also through reward normalisers on
    top of it (:func:`grouped_below`); on any other env, as SB3 collects them. Mixed in
    before the algorithm by :func:`overlapped_class`."""

    def collect_rollouts(
        self,
        env: VecEnv,
        callback: BaseCallback,
        rollout_buffer: RolloutBuffer,
        n_rollout_steps: int,
    ) -> bool:
        """Fills ``rollout_buffer`` with ``n_rollout_steps`` steps of every game, as SB3's
        ``OnPolicyAlgorithm.collect_rollouts`` does (same buffer, callbacks and
        bootstrapping), the groups stepped in turns."""
        grouped = grouped_below(env)
        if grouped is None:
            return super().collect_rollouts(env, callback, rollout_buffer, n_rollout_steps)
        if self.use_sde:
            raise ConfigError("world.overlap does not support gSDE (use_sde); turn one off")
        assert self._last_obs is not None, "No previous observation was provided"
        self.policy.set_training_mode(False)
        rollout_buffer.reset()
        callback.on_rollout_start()
        groups, slices = grouped.groups, grouped.slices
        # What the policy sees of each group now, and what it chose at this step.
        seen = [rows_of(self._last_obs, rows) for rows in slices]
        chosen: list[tuple[np.ndarray, th.Tensor, th.Tensor]] = [self._send(groups[0], seen[0])]
        steps: list[VecEnvStepReturn] = []
        for n_steps in range(n_rollout_steps):
            ahead: tuple[np.ndarray, th.Tensor, th.Tensor] | None = None
            steps = []
            for g, group in enumerate(groups):
                if g + 1 < len(groups):  # the next group's step, while this one's runs
                    chosen.append(self._send(groups[g + 1], seen[g + 1]))
                steps.append(group.step_wait())
                seen[g] = steps[g][0]
                if g == 0 and n_steps + 1 < n_rollout_steps and len(groups) > 1:
                    # Group 0 is done with this step: its next step runs while the other
                    # groups finish this one (the policy is the same until the update).
                    ahead = self._send(groups[0], seen[0])
            if len(groups) == 1 and n_steps + 1 < n_rollout_steps:
                ahead = self._send(groups[0], seen[0])
            grouped.hand_over(join_steps(steps))
            new_obs, rewards, dones, infos = env.step_wait()  # through the normaliser, if any
            actions = np.concatenate([c[0] for c in chosen])
            values = th.cat([c[1] for c in chosen])
            log_probs = th.cat([c[2] for c in chosen])

            self.num_timesteps += env.num_envs
            callback.update_locals(locals())
            if not callback.on_step():
                if ahead is not None:  # a step of group 0 under way; its game moves on
                    groups[0].step_wait()
                return False
            self._update_info_buffer(infos, dones)

            if isinstance(self.action_space, spaces.Discrete):
                actions = actions.reshape(-1, 1)
            # As SB3: a truncated episode is bootstrapped with the value of its last state.
            for idx, done in enumerate(dones):
                if (
                    done
                    and infos[idx].get("terminal_observation") is not None
                    and infos[idx].get("TimeLimit.truncated", False)
                ):
                    terminal_obs = self.policy.obs_to_tensor(infos[idx]["terminal_observation"])[0]
                    with th.no_grad():
                        terminal_value = self.policy.predict_values(terminal_obs)[0]
                    rewards[idx] += self.gamma * terminal_value

            rollout_buffer.add(
                self._last_obs,  # type: ignore[arg-type]
                actions,
                rewards,
                self._last_episode_starts,  # type: ignore[arg-type]
                values,
                log_probs,
            )
            self._last_obs = new_obs  # type: ignore[assignment]
            self._last_episode_starts = dones
            chosen = [] if ahead is None else [ahead]

        with th.no_grad():
            values = self.policy.predict_values(obs_as_tensor(new_obs, self.device))  # type: ignore[arg-type]
        rollout_buffer.compute_returns_and_advantage(last_values=values, dones=dones)
        callback.update_locals(locals())
        callback.on_rollout_end()
        return True

    def _send(self, group: VecEnv, obs: Any) -> tuple[np.ndarray, th.Tensor, th.Tensor]:
        """The policy's actions for ``group``'s games (with their values and
        log-probabilities), sent to its world, which steps while the caller goes on."""
        with th.no_grad():
            actions, values, log_probs = self.policy(obs_as_tensor(obs, self.device))
        chosen = actions.cpu().numpy()
        sent = chosen
        if isinstance(self.action_space, spaces.Box):  # as SB3 does before stepping
            if self.policy.squash_output:
                sent = self.policy.unscale_action(sent)
            else:
                sent = np.clip(sent, self.action_space.low, self.action_space.high)
        group.step_async(sent)
        return chosen, values, log_probs


def grouped_below(env: VecEnv) -> GroupedVecEnv | None:
    """The :class:`GroupedVecEnv` that ``env`` is, or that reward normalisers
    (``VecNormalize``) on top of it wrap; None for any other env.

    Raises:
        ConfigError: a normaliser of observations over the groups (the collector chooses a
            group's next action before the normaliser has seen the other group's step).
    """
    normalisers = []
    while isinstance(env, VecNormalize):
        normalisers.append(env)
        env = env.venv
    if not isinstance(env, GroupedVecEnv):
        return None
    if any(normaliser.norm_obs for normaliser in normalisers):
        raise ConfigError(
            "world.overlap cannot normalise observations (VecNormalize norm_obs): a group's "
            "next action is chosen before the other group's step is in; drop world.overlap "
            "or norm_obs"
        )
    return env


@cache
def overlapped_class(algorithm: type[BaseAlgorithm]) -> type[BaseAlgorithm]:
    """``algorithm`` (an SB3 on-policy class) with :class:`OverlappedRollouts` mixed in.

    Raises:
        ConfigError: ``algorithm`` is not on-policy (DQN learns from a replay buffer while
            it steps, which this collector does not overlap).
    """
    if not issubclass(algorithm, OnPolicyAlgorithm):
        raise ConfigError(
            f"world.overlap collects on-policy rollouts (ppo, a2c); {algorithm.__name__} is "
            "not on-policy: drop world.overlap (world.workers alone runs its world in workers)"
        )
    return type(f"Overlapped{algorithm.__name__}", (OverlappedRollouts, algorithm), {})
