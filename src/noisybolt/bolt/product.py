"""The product of a tabular world and the specs' DFAs: exact R^c_max and exact scales.

A *tabular world* (:class:`TabularWorld`) is a deterministic world over finitely many
states, given as arrays: where each action leads, what it pays, whether it ends the
episode, and each state's ground-truth fluents. A world that can be enumerated builds
one (the gridworld: :func:`noisybolt.envs.gridworld_tabular.gridworld_model`); this
module only plans over it, in numpy, by backward induction over the steps left before
truncation.

Semantics (as in DESIGN.md):

- An episode starts at the world's start state; at reset every DFA reads the fluents of
  that first observation (the DFA's initial state is the empty trace).
- Each step pays the world's reward; the DFAs then read the fluents of the state reached.
  The episode ends when a step terminates it or after ``step_limit`` steps (truncation).
- An episode *complies* when every DFA is in an accepting state at its end (plain LTLf on
  the whole finite trace). Its return is the world's return only.

What is computed:

- :func:`best_compliant_episode`: R^c_max, the largest return over compliant episodes
  (``require_goal=True``: over those that end by termination, the goal), and one such
  episode;
- :func:`scheme_q_values` / :func:`scheme_optimum`: the optimal policy of the problem the
  ``compliance`` reward scheme sets (discounted, with its progress terms);
- :func:`exact_compliance_scale`: the smallest-order scale under which that optimum
  complies, below the bound from the world's return range.

Example:
    >>> from noisybolt.logic import DFA
    >>> # A corridor 0 - 1 - 2; action 0 stays, action 1 moves right; state 2 ends it.
    >>> world = TabularWorld(
    ...     states=(0, 1, 2), next_index=np.array([[0, 1], [1, 2], [2, 2]]),
    ...     reward=np.array([[-1.0, -1.0], [-1.0, 10.0], [0.0, 0.0]]),
    ...     terminated=np.array([[False, False], [False, True], [True, True]]),
    ...     fluents=np.array([[False], [True], [False]]), fluent_names=("mid",),
    ...     start=0, step_limit=5)
    >>> eventually_mid = DFA.from_function(["mid"], n_states=2, initial_state=0,
    ...     accepting=[False, True], delta=lambda q, m: 1 if q or m & 1 else 0)
    >>> best = best_compliant_episode(world, [eventually_mid], require_goal=True)
    >>> best.value, best.actions
    (9.0, (1, 1))
"""

from __future__ import annotations

from collections.abc import Hashable, Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from noisybolt.bolt.shaping import progress_potential
from noisybolt.errors import ConfigError, UnknownFluentError
from noisybolt.logic.analysis import distance_to_acceptance
from noisybolt.logic.dfa import DFA, masks_from_bool_matrix

__all__ = [
    "MAX_CELLS",
    "OptimalResult",
    "Product",
    "SchemeOptimum",
    "TabularWorld",
    "best_compliant_episode",
    "exact_compliance_scale",
    "product",
    "scheme_optimum",
    "scheme_q_values",
]

#: Largest number of policy cells (steps x world states x joint DFA states) planned for.
MAX_CELLS = 200_000_000


class TabularWorld(NamedTuple):
    """A deterministic world over finitely many states, as the planner reads it.

    Attributes:
        states: a label per state (the gridworld's ``(x, y, heading)``).
        next_index: intp ``[n_states, n_actions]``: the state each action leads to.
        reward: float64 ``[n_states, n_actions]``: what each action pays.
        terminated: bool ``[n_states, n_actions]``: whether it ends the episode.
        fluents: bool ``[n_states, n_fluents]``: each state's ground truth.
        fluent_names: the names of ``fluents``' columns.
        start: the index of the reset state.
        step_limit: the truncation limit.
        positions: a label per state for :attr:`OptimalResult.path` (where the agent
            stands: the gridworld's ``(x, y)``); None: the states themselves.
    """

    states: tuple[Hashable, ...]
    next_index: np.ndarray
    reward: np.ndarray
    terminated: np.ndarray
    fluents: np.ndarray
    fluent_names: tuple[str, ...]
    start: int
    step_limit: int
    positions: tuple[Hashable, ...] | None = None

    def letters(self, dfa: DFA) -> np.ndarray:
        """intp ``[n_states]``: each state's letter over ``dfa``'s fluents (a bitmask).

        Raises:
            UnknownFluentError: ``dfa`` reads a fluent the world does not have.
        """
        unknown = tuple(f for f in dfa.fluents if f not in self.fluent_names)
        if unknown:
            raise UnknownFluentError(
                f"fluent(s) {', '.join(map(repr, unknown))} are not the tabular world's; "
                f"known: {', '.join(self.fluent_names)}",
                unknown=unknown,
                known=self.fluent_names,
            )
        columns = [self.fluent_names.index(f) for f in dfa.fluents]
        return masks_from_bool_matrix(self.fluents[:, columns])


class Product(NamedTuple):
    """The joint DFA state space of several specs, driven by the world state reached.

    ``successor[s, j]`` is the joint state after the DFAs in joint state ``j`` read the
    fluents of world state ``s``; ``accepting[j]`` says every DFA accepts; ``initial`` is
    the joint state after reading the reset state's fluents. The joint index is mixed
    radix, the first DFA's state its lowest digit.
    """

    successor: np.ndarray
    accepting: np.ndarray
    initial: int


def product(world: TabularWorld, dfas: Sequence[DFA]) -> Product:
    """The joint DFA states of ``dfas`` over ``world`` (see :class:`Product`).

    Raises:
        UnknownFluentError: a DFA reads a fluent the world does not have.
    """
    n_world = len(world.states)
    successor = np.zeros((n_world, 1), dtype=np.intp)
    accepting = np.ones(1, dtype=bool)
    initial = 0
    for dfa in dfas:  # mixed radix: the joint index is sum_i q_i * stride_i
        masks = world.letters(dfa)  # [n_world]
        n = dfa.n_states
        q = np.repeat(np.arange(n), n_world)
        step, _ = dfa.step_batch(q, np.tile(masks, n))
        step = step.reshape(n, n_world).T  # [n_world, n]: successor of q on entering s
        stride = successor.shape[1]
        # Joint j' = j + stride * q: digits below stride are the earlier DFAs.
        successor = (successor[:, None, :] + stride * step[:, :, None]).reshape(n_world, -1)
        accepting = (accepting[None, :] & dfa.accepting[:, None]).reshape(-1)
        initial = initial + stride * int(step[world.start, dfa.initial_state])
    return Product(successor=successor, accepting=accepting, initial=initial)


@dataclass(frozen=True)
class OptimalResult:
    """The best compliant episode (see the module docstring for what complying means).

    Attributes:
        value: R^c_max, the best return of a compliant episode; None when no episode
            complies.
        steps: length of one optimal episode (the shortest among optimal ones); None
            when infeasible.
        actions: one optimal action sequence; empty when infeasible.
        states: the state labels at reset and after every action (``steps + 1`` of them);
            empty when infeasible.
        path: the positions visited, in order, without repeating a position the agent
            stays at (turns and no-ops); empty when infeasible.
        reaches_goal: whether the optimal episode ends by termination (False: it is
            truncated at the step limit).
        step_limit: the truncation limit planned for.
        formulas: the specs' formulas, in the order given.
    """

    value: float | None
    steps: int | None
    actions: tuple[int, ...]
    states: tuple[tuple[int, int, int], ...]
    path: tuple[tuple[int, int], ...]
    reaches_goal: bool
    step_limit: int
    formulas: tuple[str, ...]

    @property
    def feasible(self) -> bool:
        """Whether some episode complies with every spec."""
        return self.value is not None


def best_compliant_episode(
    world: TabularWorld, dfas: Sequence[DFA], *, require_goal: bool = False
) -> OptimalResult:
    """R^c_max on ``world``: the best return of an episode that complies with every DFA.

    Exact: backward induction over the steps left before truncation on the product.
    Among optimal episodes the shortest is returned (then the one whose actions come
    first). With no DFAs this is R_max.

    Raises:
        ConfigError: a product too large to plan over (:data:`MAX_CELLS`).
        UnknownFluentError: a DFA reads a fluent the world does not have.
    """
    joint = product(world, dfas)
    horizon = world.step_limit
    n_world, n_joint = joint.successor.shape
    if horizon * n_world * n_joint > MAX_CELLS:
        raise ConfigError(
            f"planning needs {horizon} steps x {n_world} agent states x {n_joint} joint DFA "
            f"states, over {MAX_CELLS} cells: use fewer or smaller specs, a smaller room "
            "or a lower max_steps"
        )
    policy = _backward_induction(world, joint, horizon=horizon, require_goal=require_goal)
    formulas = tuple(d.formula or repr(d) for d in dfas)
    if policy is None:
        return OptimalResult(None, None, (), (), (), False, horizon, formulas)
    return _rollout(world, joint, policy, horizon, formulas)


def _backward_induction(
    world: TabularWorld, joint: Product, *, horizon: int, require_goal: bool
) -> np.ndarray | None:
    """The optimal policy ``[horizon, n_world, n_joint]`` (int8), or None if infeasible.

    ``value[s, j]`` is the best return from world state ``s`` and joint DFA state ``j``
    (both already read) with some steps left; ``length`` the steps an optimal episode
    from there takes, so ties in value go to the shorter episode.
    """
    n_world, n_joint = joint.successor.shape
    end_value = np.where(joint.accepting, 0.0, -np.inf)  # [n_joint], on ending there
    # With no steps left the episode is truncated where it stands.
    value = np.broadcast_to(
        np.full(n_joint, -np.inf) if require_goal else end_value, (n_world, n_joint)
    )
    length = np.zeros((n_world, n_joint), dtype=np.int64)
    policy = np.empty((horizon, n_world, n_joint), dtype=np.int8)
    n_actions = world.next_index.shape[1]
    for t in range(horizon - 1, -1, -1):
        values = np.empty((n_actions, n_world, n_joint))
        lengths = np.empty((n_actions, n_world, n_joint), dtype=np.int64)
        for a in range(n_actions):
            reached = world.next_index[:, a]  # [n_world]
            after = joint.successor[reached]  # [n_world, n_joint]
            ends = world.terminated[:, a, None]
            rows = reached[:, None]
            values[a] = world.reward[:, a, None] + np.where(
                ends, end_value[after], value[rows, after]
            )
            lengths[a] = 1 + np.where(ends, 0, length[rows, after])
        best = values.max(axis=0)
        # Equal returns up to rounding: prefer the shorter episode, then the lower action.
        tolerance = 1e-9 * np.maximum(1.0, np.abs(np.where(np.isfinite(best), best, 0.0)))
        tied = values >= best - tolerance
        choice = np.argmin(np.where(tied, lengths, np.iinfo(np.int64).max), axis=0)
        policy[t] = choice
        value = np.take_along_axis(values, choice[None], axis=0)[0]
        length = np.take_along_axis(lengths, choice[None], axis=0)[0]
    if not np.isfinite(value[world.start, joint.initial]):
        return None
    return policy


def _rollout(
    world: TabularWorld,
    joint: Product,
    policy: np.ndarray,
    horizon: int,
    formulas: tuple[str, ...],
) -> OptimalResult:
    """Follows ``policy`` from the reset state and sums the rewards actually earned."""
    s, j = world.start, joint.initial
    actions: list[int] = []
    visited = [s]
    total = 0.0
    reaches_goal = False
    for t in range(horizon):
        a = int(policy[t, s, j])
        actions.append(a)
        total += float(world.reward[s, a])
        reaches_goal = bool(world.terminated[s, a])
        s = int(world.next_index[s, a])
        j = int(joint.successor[s, j])
        visited.append(s)
        if reaches_goal:
            break
    positions = world.states if world.positions is None else world.positions
    path = [positions[visited[0]]]
    for index in visited[1:]:
        if positions[index] != path[-1]:
            path.append(positions[index])
    return OptimalResult(
        value=total,
        steps=len(actions),
        actions=tuple(actions),
        states=tuple(world.states[i] for i in visited),  # type: ignore[misc]
        path=tuple(path),  # type: ignore[arg-type]
        reaches_goal=reaches_goal,
        step_limit=horizon,
        formulas=formulas,
    )


@dataclass(frozen=True)
class SchemeOptimum:
    """The optimal policy of the problem the ``compliance`` reward scheme sets (discounted).

    Attributes:
        complies: whether its episode from the start complies with every spec.
        reaches_goal: whether that episode ends at the goal.
        steps: the episode's length.
        env_return: its (undiscounted) environment return.
    """

    complies: bool
    reaches_goal: bool
    steps: int
    env_return: float


def scheme_q_values(
    world: TabularWorld,
    dfas: Sequence[DFA],
    *,
    scale: float,
    gamma: float,
    shaping: bool,
    pay_on_change: bool = True,
) -> np.ndarray:
    """Optimal Q-values ``[horizon, n_world, n_joint, n_actions]`` of the compliance scheme.

    The learner's problem on the product of ``world`` and the DFAs (on ground truth, no
    perception noise), discounted by ``gamma``: each step pays the world's reward and the
    progress terms of :class:`~noisybolt.bolt.ProgressShaping` (the violation charge; at
    the end, the graded outcome; with ``shaping``, the potential-based term), and an
    episode that ends (by termination, or truncated at the step limit) pays ``scale`` per
    spec whose DFA accepts; with ``pay_on_change``, each spec's ``scale`` is paid as its
    DFA enters acceptance and taken back as it leaves instead (``on_change`` timing).
    Backward induction over the steps left.
    """
    joint = product(world, dfas)
    n_world, n_joint = joint.successor.shape
    # Per joint state, summed over specs: acceptance's worth, the potential, the
    # violation charge as a potential (-scale where a spec can no longer accept).
    accepted = np.zeros(n_joint)
    potential = np.zeros(n_joint)
    dead_cost = np.zeros(n_joint)
    rest = np.arange(n_joint)
    for dfa in dfas:  # the joint index's digits, first DFA lowest (as product builds it)
        q = rest % dfa.n_states
        rest = rest // dfa.n_states
        accepted += scale * dfa.accepting[q]
        potential += progress_potential(dfa, scale, world.letters(dfa))[q]
        dead_cost += scale * (distance_to_acceptance(dfa)[q] < 0)
    horizon = world.step_limit
    n_actions = world.next_index.shape[1]
    q_values = np.empty((horizon, n_world, n_joint, n_actions))
    value = np.zeros((n_world, n_joint))  # never read at the last step: every episode ends
    for t in range(horizon - 1, -1, -1):
        for a in range(n_actions):
            reached = world.next_index[:, a]
            after = joint.successor[reached]  # [n_world, n_joint]
            ends = world.terminated[:, a, None] | (t == horizon - 1)
            reward = world.reward[:, a, None] + dead_cost[None, :] - dead_cost[after]
            if pay_on_change:  # acceptance paid as it is gained, taken back as it is lost
                reward = reward + accepted[after] - accepted[None, :]
                reward = reward + np.where(ends, potential[after], 0.0)
            else:
                reward = reward + np.where(ends, accepted[after] + potential[after], 0.0)
            if shaping:
                reward = reward + np.where(ends, 0.0, gamma * potential[after]) - potential
            q_values[t, :, :, a] = reward + np.where(
                ends, 0.0, gamma * value[reached[:, None], after]
            )
        value = q_values[t].max(axis=-1)
    return q_values


def scheme_optimum(
    world: TabularWorld,
    dfas: Sequence[DFA],
    *,
    scale: float,
    gamma: float,
    shaping: bool = True,
    pay_on_change: bool = True,
) -> SchemeOptimum:
    """What the optimal policy of :func:`scheme_q_values`'s problem does from the start."""
    q_values = scheme_q_values(
        world, dfas, scale=scale, gamma=gamma, shaping=shaping, pay_on_change=pay_on_change
    )
    joint = product(world, dfas)
    s, j, total = world.start, joint.initial, 0.0
    reaches_goal, steps = False, 0
    for t in range(world.step_limit):
        a = int(np.argmax(q_values[t, s, j]))
        total += float(world.reward[s, a])
        steps += 1
        reaches_goal = bool(world.terminated[s, a])
        s = int(world.next_index[s, a])
        j = int(joint.successor[s, j])
        if reaches_goal:
            break
    return SchemeOptimum(
        complies=bool(joint.accepting[j]),
        reaches_goal=reaches_goal,
        steps=steps,
        env_return=total,
    )


def exact_compliance_scale(
    world: TabularWorld,
    dfas: Sequence[DFA],
    *,
    gamma: float,
    floor: float,
    cap: float,
    pay_on_change: bool = True,
) -> float | None:
    """The compliance scheme's scale computed exactly on ``world``'s product.

    Complying must be worth more than what it costs the world's return: twice the gap
    between the best goal-reaching episode and the best compliant one
    (``R_max - R^c_max``), plus ``floor`` so that a spec the shortest route already
    follows still pays for staying on it; doubled until the optimal policy of the
    discounted problem (:func:`scheme_optimum` with the learner's ``gamma``) complies,
    and never above ``cap`` (the bound from the world's return range). Far smaller than
    ``cap`` where complying costs a few steps, which keeps the learner's rewards in scale.

    Returns:
        The scale, or None when no goal-reaching episode complies (use ``cap``).
    """
    best = best_compliant_episode(world, [], require_goal=True)
    compliant = best_compliant_episode(world, dfas, require_goal=True)
    if compliant.value is None or best.value is None:
        return None
    scale = min(cap, 2.0 * (best.value - compliant.value) + floor)

    def complies(scale: float) -> bool:
        return scheme_optimum(
            world, dfas, scale=scale, gamma=gamma, pay_on_change=pay_on_change
        ).complies

    while scale < cap and not complies(scale):
        scale = min(cap, 2.0 * scale)
    return float(scale)
