"""Counterfactual experience for DQN: every transition replayed from other DFA states (CRM).

Toro Icarte et al., "Reward Machines: Exploiting Reward Function Structure in
Reinforcement Learning" (JAIR 2022), *counterfactual reasoning for reward machines*: the
world's transition ``(s, a, s')`` does not depend on the bolt's DFA states, and the bolt's
reward and next state depend on them only through Algorithm 1, which is known. So a
transition gathered in DFA state ``q`` teaches every other state ``q~`` too:
``((s, q~), a, r~, (s', q~'))`` with ``q~' = δ(q~, detector output of s')`` and ``r~`` the
world's reward plus what the bolt pays from ``q~`` on that same detector output. An agent
that violated a spec early in an episode still learns, from the rest of that episode, what
the compliant states are worth.

Exactly what is replayed (DESIGN.md, "Counterfactual experience"):

* The bolt's transition is :meth:`~noisybolt.bolt.BoltEngine.step` from ``q~`` on the
  probabilities the step's transition read (for an episode's last step: its final view),
  with the episode's end where the bolt's episode ended (``episode_end`` specs paid there;
  a time limit's cut as the bolt's ``pay_at_truncation`` says), never as an episode's
  first transition (those are read at reset and are no step of the buffer), then the
  bolt's progress terms (:class:`~noisybolt.bolt.ProgressShaping`) on ``q~ -> q~'``: what
  :meth:`~noisybolt.bolt.RestrainingBolt.step` pays from ``q~``. ``on_change`` pays on
  entering acceptance and takes it back on leaving, low-confidence fluents on the taken
  edge are charged, all as the engine says.
* The reward of the reset transition, which the bolt pays with an episode's first step
  (``carried``), is not part of a replayed copy: it is what starting the episode paid, not
  anything done from ``q~``.
* The world's share of the reward is the one the bolt reported (``info["env_reward"]``),
  the same unnormalised units SB3's off-policy learners store
  (``OffPolicyAlgorithm._store_transition`` stores ``VecNormalize``'s original reward
  and normalises at sampling: the copies are normalised alike).
* ``done`` and the time limit's flag are the step's own: the batched bolt never ends an
  episode the world did not end.
* States: with several specs, the joint states are the product of the DFAs' states. If
  there are at most ``samples`` others than the visited one, every one is replayed;
  otherwise ``samples`` of them are drawn per environment and step (uniformly per spec,
  with replacement, never the visited one) from a seeded generator.

Each step the replay of the *visited* state is checked against what the bolt actually
paid and moved to (a bolt whose reward depends on more than its states and the
detector's output, which the replay cannot see, is refused by name rather than replayed
wrong).

:class:`CounterfactualReplayBuffer` stores the step as SB3 does, then each relabelled copy
as one more row of the same buffer (the buffer's size counts copies: with ``k`` copies a
buffer holds ``1 / (1 + k)`` as many of the world's steps). Nothing beside SB3's own arrays
is stored, so a checkpoint's buffer (:mod:`noisybolt.runs.checkpoints`) resumes with
its copies. Its environment is a :class:`~noisybolt.wrappers.BoltVecEnv` built with
``transition_records=True`` (``noisybolt train`` does so for ``algorithm.counterfactual``).

Measured on the gridworld spec suite's detour specs, it made DQN *slower* to comply and
reach the goal (N_frames ≥ 2.2× without, one seed; ``benchmarks/README.md``,
"Counterfactual experience for DQN"): ``algorithm.counterfactual`` is off by default.

Example:
    >>> from noisybolt.bolt import RestrainingBolt, Spec
    >>> from noisybolt.logic import DFA
    >>> f_t = DFA.from_function(["t"], n_states=2, initial_state=0, accepting=[False, True],
    ...     delta=lambda q, m: 1 if q == 1 or m == 1 else 0)
    >>> bolt = RestrainingBolt([Spec("F(t)", terminal_reward=10.0, low_confidence_cost=2.0)],
    ...     ["t"], dfas=[f_t])
    >>> replay = BoltReplay(bolt)
    >>> out = replay.step(np.array([[0], [1]]), np.array([[0.7], [0.7]]),
    ...     done=np.array([False, False]))
    >>> out.next_states.tolist(), out.total.tolist()
    ([[1], [1]], [8.0, 10.0])

    From state 0 the edge taken reads ``t``, seen with low confidence (cost 2); from the
    accepting sink the edge reads nothing, so nothing is charged.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from gymnasium import spaces
from stable_baselines3.common.buffers import DictReplayBuffer
from stable_baselines3.common.vec_env import VecEnv, VecEnvWrapper

from noisybolt.bolt import BoltEngine, BoltStep, ProgressShaping, RestrainingBolt
from noisybolt.errors import ConfigError
from noisybolt.wrappers import BOLT_REWARD_KEY, ENV_REWARD_KEY, BoltVecEnv
from noisybolt.wrappers.bolt_vec_env import BOLT_CARRIED_KEY, BOLT_DONE_KEY, FLUENT_PROBS_KEY

__all__ = [
    "BoltReplay",
    "CounterfactualReplayBuffer",
    "CounterfactualStates",
    "bolted_env",
    "replay_buffer_settings",
]

#: How closely the replay of the visited state must give what the bolt paid.
_TOLERANCE = 1e-6


class BoltReplay:
    """The bolt's transition replayed from any DFA states: stateless, what
    :meth:`RestrainingBolt.step <noisybolt.bolt.RestrainingBolt.step>` pays from them
    (without the reward carried from a reset; see the module docstring).

    Args:
        bolt: the bolt whose transitions are replayed; its engine and progress shaping
            are used, its states never read or changed. Threshold tracking only.
        pay_at_truncation: the bolt's setting (a time limit's cut paid as an end).

    Raises:
        ConfigError: a bolt under belief tracking (its reward depends on a belief, not on
            one DFA state to relabel from).
    """

    def __init__(self, bolt: RestrainingBolt, *, pay_at_truncation: bool = True) -> None:
        if bolt.tracking != "threshold":
            raise ConfigError(
                f"counterfactual experience replays Algorithm 1 from other DFA states; a bolt "
                f"under {bolt.tracking!r} tracking pays on a belief, not on one state: use "
                "bolt.tracking=threshold, or turn algorithm.counterfactual off"
            )
        self._engine: BoltEngine = bolt.engine
        self._shaping: ProgressShaping | None = bolt.shaping
        self._pay_at_truncation = bool(pay_at_truncation)

    @property
    def n_states(self) -> tuple[int, ...]:
        """DFA states per spec."""
        return self._engine.n_states

    @property
    def n_fluents(self) -> int:
        """The bolt's fluents: the columns of ``probs``."""
        return self._engine.n_fluents

    def step(
        self,
        states: np.ndarray,
        probs: np.ndarray,
        *,
        done: np.ndarray,
        truncated: np.ndarray | None = None,
    ) -> BoltStep:
        """The transition from ``states`` (int ``[n, n_specs]``) on ``probs``
        (float ``[n, n_fluents]``), ``done``/``truncated`` (bool ``[n]``) as the bolt's
        ``step`` takes them; ``carried`` is 0."""
        done = np.asarray(done, dtype=bool)
        if not self._pay_at_truncation and truncated is not None:
            done = done & ~np.asarray(truncated, dtype=bool)
        out = self._engine.step(states, probs, done=done, first=False)
        if self._shaping is None:
            return out
        progress = self._shaping(np.asarray(states, dtype=np.int64), out.next_states, done=done)
        reward = out.reward + progress
        return out._replace(progress=progress, reward=reward, total=reward.sum(axis=1))


class CounterfactualStates:
    """Which joint DFA states a transition is replayed from (see the module docstring).

    Args:
        n_states: DFA states per spec.
        samples: the most copies per transition (>= 1).
        seed: seeds the draws where not every joint state is replayed.

    Example:
        >>> chooser = CounterfactualStates((2, 3), samples=8)
        >>> chooser.copies, chooser.exhaustive
        (5, True)
        >>> chooser.choose(np.array([[1, 2]]))[:, 0].tolist()  # all but the visited (1, 2)
        [[0, 0], [0, 1], [0, 2], [1, 0], [1, 1]]
    """

    def __init__(self, n_states: tuple[int, ...], *, samples: int, seed: int | None = None) -> None:
        if isinstance(samples, bool) or not isinstance(samples, int) or samples < 1:
            raise ConfigError(f"counterfactual samples must be an integer >= 1, got {samples!r}")
        self._n_states = np.array(n_states, dtype=np.int64)
        others = math.prod(n_states) - 1
        self.exhaustive = others <= samples
        #: Relabelled copies per transition.
        self.copies = others if self.exhaustive else samples
        self._rng = np.random.default_rng(seed)
        if self.exhaustive:
            grids = np.meshgrid(*(np.arange(n) for n in n_states), indexing="ij")
            self._joint = np.stack([g.ravel() for g in grids], axis=1)  # [n_joint, n_specs]

    def choose(self, visited: np.ndarray) -> np.ndarray:
        """int64 ``[copies, n_envs, n_specs]``: the states to replay from, for the
        ``visited`` states ``[n_envs, n_specs]``."""
        visited = np.asarray(visited, dtype=np.int64)
        if self.exhaustive:
            index = np.ravel_multi_index(tuple(visited.T), tuple(self._n_states))  # [n_envs]
            others = np.arange(self.copies)[:, None]  # skip the visited joint state
            return self._joint[others + (others >= index[None, :])]
        shape = (self.copies, *visited.shape)
        chosen = self._rng.integers(0, self._n_states, size=shape)
        while (same := (chosen == visited).all(axis=2)).any():
            chosen[same] = self._rng.integers(0, self._n_states, size=(int(same.sum()), shape[2]))
        return chosen


class CounterfactualReplayBuffer(DictReplayBuffer):
    """SB3's ``DictReplayBuffer`` that also stores each transition replayed from other DFA
    states (see the module docstring); DQN takes it as ``replay_buffer_class``.

    Args:
        buffer_size, observation_space, action_space, device, n_envs,
            optimize_memory_usage, handle_timeout_termination: SB3's (the size counts
            the relabelled copies).
        replay: the bolt's transitions, replayed (:class:`BoltReplay`).
        samples: the most copies per transition (:class:`CounterfactualStates`;
            ``algorithm.counterfactual_samples``).
        seed: seeds the drawn states.

    Raises:
        ConfigError: ``optimize_memory_usage`` (SB3's dict buffers have none), or an
            observation without the bolt's ``"dfa"`` states.
    """

    def __init__(
        self,
        buffer_size: int,
        observation_space: spaces.Dict,
        action_space: spaces.Space,
        device: Any = "auto",
        n_envs: int = 1,
        optimize_memory_usage: bool = False,
        handle_timeout_termination: bool = True,
        *,
        replay: BoltReplay,
        samples: int,
        seed: int | None = None,
    ) -> None:
        if optimize_memory_usage:
            raise ConfigError(
                "counterfactual experience stores its copies in a dict replay buffer, which "
                "has no optimize_memory_usage: drop the hyperparameter"
            )
        dfa = (
            observation_space.spaces.get("dfa")
            if isinstance(observation_space, spaces.Dict)
            else None
        )
        if not isinstance(dfa, spaces.MultiDiscrete) or tuple(dfa.nvec) != replay.n_states:
            raise ConfigError(
                f"counterfactual experience relabels the 'dfa' entry of the observation, "
                f"the bolt's DFA states {replay.n_states}; this observation space has "
                f"{dfa!r} there"
            )
        super().__init__(
            buffer_size,
            observation_space,
            action_space,
            device=device,
            n_envs=n_envs,
            handle_timeout_termination=handle_timeout_termination,
        )
        self.replay = replay
        self.states = CounterfactualStates(replay.n_states, samples=samples, seed=seed)

    def add(  # type: ignore[override]
        self,
        obs: dict[str, np.ndarray],
        next_obs: dict[str, np.ndarray],
        action: np.ndarray,
        reward: np.ndarray,
        done: np.ndarray,
        infos: list[dict[str, Any]],
    ) -> None:
        """Stores the transition unchanged, then one relabelled copy per chosen state."""
        super().add(obs, next_obs, action, reward, done, infos)
        visited = np.asarray(obs["dfa"], dtype=np.int64).reshape(self.n_envs, -1)
        probs, env_reward, bolt_done, truncated = self._records(infos)
        chosen = self.states.choose(visited)  # [copies, n_envs, n_specs]
        n, copies = self.n_envs, self.states.copies
        # One replay for the visited states and every copy: rows [0, n) are the visited.
        states = np.concatenate([visited, chosen.reshape(copies * n, -1)])
        out = self.replay.step(
            states,
            np.tile(probs, (copies + 1, 1)),
            done=np.tile(bolt_done, copies + 1),
            truncated=np.tile(truncated, copies + 1),
        )
        self._check_visited(out, next_obs, infos)
        next_states = out.next_states[n:].reshape(copies, n, -1)
        rewards = env_reward[None, :] + out.total[n:].reshape(copies, n)
        for j in range(copies):
            super().add(
                {**obs, "dfa": chosen[j]},
                {**next_obs, "dfa": next_states[j]},
                action,
                rewards[j],
                done,
                infos,
            )

    def _records(
        self, infos: list[dict[str, Any]]
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(probs, env_reward, bolt_done, truncated)`` of the step, from its infos."""
        try:
            probs = np.stack(
                [np.asarray(info[FLUENT_PROBS_KEY], dtype=np.float64) for info in infos]
            )
            env_reward = np.array([info[ENV_REWARD_KEY] for info in infos], dtype=np.float64)
            bolt_done = np.array([info[BOLT_DONE_KEY] for info in infos], dtype=bool)
        except KeyError as missing:
            raise RuntimeError(
                f"a step's info lacks {missing}: counterfactual experience replays the bolt's "
                "transition from what it read, which BoltVecEnv(transition_records=True) puts "
                "in each step's info"
            ) from None
        truncated = np.array([bool(info.get("TimeLimit.truncated")) for info in infos])
        return probs, env_reward, bolt_done, truncated

    def _check_visited(
        self, out: BoltStep, next_obs: dict[str, np.ndarray], infos: list[dict[str, Any]]
    ) -> None:
        """Raises RuntimeError where the replay of the visited states is not what the bolt
        did (then the copies would be wrong too)."""
        n = self.n_envs
        paid = np.array(
            [info[BOLT_REWARD_KEY] - info[BOLT_CARRIED_KEY] for info in infos], dtype=np.float64
        )
        moved = np.asarray(next_obs["dfa"], dtype=np.int64).reshape(n, -1)
        if not np.allclose(out.total[:n], paid, rtol=0.0, atol=_TOLERANCE) or not np.array_equal(
            out.next_states[:n], moved
        ):
            raise RuntimeError(
                f"replaying the bolt's step from the visited DFA states gives rewards "
                f"{out.total[:n].tolist()} and states {out.next_states[:n].tolist()}, but the "
                f"bolt paid {paid.tolist()} and moved to {moved.tolist()}: its reward depends "
                "on something a replay does not see (a multiplier, a belief), so relabelled "
                "copies would be wrong; train without algorithm.counterfactual"
            )


def bolted_env(env: VecEnv) -> BoltVecEnv:
    """The :class:`~noisybolt.wrappers.BoltVecEnv` in ``env``'s stack of wrappers.

    Raises:
        ConfigError: there is none (an unbolted run has no DFA states to relabel).
    """
    layer: VecEnv = env
    while not isinstance(layer, BoltVecEnv):
        if not isinstance(layer, VecEnvWrapper):
            raise ConfigError(
                "counterfactual experience relabels the bolt's DFA states, and this "
                "environment has no bolt (BoltVecEnv) in its stack"
            )
        layer = layer.venv
    return layer


def replay_buffer_settings(env: VecEnv, *, samples: int, seed: int | None) -> dict[str, Any]:
    """DQN's ``replay_buffer_class`` and ``replay_buffer_kwargs`` for counterfactual
    experience on ``env`` (a stack with a :class:`~noisybolt.wrappers.BoltVecEnv`)."""
    bolted = bolted_env(env)
    replay = BoltReplay(bolted.bolt, pay_at_truncation=bolted.pay_at_truncation)
    return {
        "replay_buffer_class": CounterfactualReplayBuffer,
        "replay_buffer_kwargs": {"replay": replay, "samples": samples, "seed": seed},
    }
