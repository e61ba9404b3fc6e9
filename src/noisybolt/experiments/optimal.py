"""Exact R^c_max: the best environment return an episode can earn while complying.

The paper's Table 1 reports, per specification, "the total possible reward with the
constraint" (R^c_max) without saying how it was found. Here it is computed, not guessed:
finite-horizon dynamic programming (backward induction over the steps left before
truncation) on the product of the gridworld's true, deterministic dynamics and every
spec's DFA, read on ground-truth fluents.

Semantics, as in the rest of noisybolt (see DESIGN.md):

- An episode starts at the world's start state; at reset every DFA reads the fluents of
  that first observation (the DFA's initial state is the empty trace).
- Each step pays the environment's reward; the DFAs then read the fluents of the state
  reached. The episode ends when the agent enters the goal (termination) or after the
  step limit (truncation), whichever comes first.
- An episode *complies* when every DFA is in an accepting state at its end (plain LTLf
  on the whole finite trace). Its return is the environment's return only: bolt rewards
  are not part of R^c_max.

R^c_max is the largest return over compliant episodes; None when no episode complies
(:attr:`OptimalResult.feasible` is False). With ``require_goal=True`` only episodes that
reach the goal count, which excludes complying by waiting out the clock.

The dynamics are not re-implemented: every ``(state, action)`` is stepped once in a real
:class:`~noisybolt.envs.gridworld.GridworldEnv` (placing the agent through MiniGrid's
public ``agent_pos`` / ``agent_dir``), and its rewards, terminations and ground-truth
fluents are what the planner uses. Cost: ``step_limit * n_agent_states * n_dfa_states``
cells per action (about 40 thousand for the paper's 6x6 room and specs).

Our rewards follow the paper's text (-1.5 per step, +100 on entering the goal), which
gives R_max = 100 - 7 * 1.5 = 89.5 in the 6x6 room; the paper's Table 1 reports 94, 82,
92 and 92 for its four gridworld specs, numbers these rules cannot produce (a goal
episode of k steps returns 100 - 1.5 k: 94 would need 4 steps where 7 is the least, and
92 no whole k), so the paper's accounting differed in a way it does not state. Run
``python -m noisybolt.experiments.optimal`` to print both side by side; with the
defaults it gives:

=================  ========  =====  =====
spec               R^c_max   steps  paper
=================  ========  =====  =====
edge               89.5      7      94
avoid_top_right    88.0      8      82
top_right_once     89.5      7      92
one_corner_once    89.5      7      92
=================  ========  =====  =====

Example:
    >>> result = optimal_constrained_return(["!F(top_right_corner)"])
    >>> result.value, result.steps
    (88.0, 8)
    >>> optimal_unconstrained_return().value
    89.5
    >>> optimal_constrained_return(["G(top_right_corner)"]).feasible
    False
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache
from typing import NamedTuple

import numpy as np

from noisybolt.bolt.shaping import progress_potential
from noisybolt.bolt.spec import Spec
from noisybolt.envs.gridworld import (
    GRIDWORLD_FLUENTS,
    GridAction,
    GridworldConfig,
    GridworldEnv,
    resolve_fluents,
)
from noisybolt.errors import ConfigError
from noisybolt.logic import DFA, compile_ltlf, distance_to_acceptance, masks_from_bool_matrix

__all__ = [
    "PAPER_TABLE1_RC_MAX",
    "OptimalResult",
    "SchemeOptimum",
    "SpecLike",
    "SpecOptimum",
    "exact_compliance_scale",
    "format_optima_table",
    "optimal_constrained_return",
    "optimal_unconstrained_return",
    "paper_spec_optima",
    "scheme_optimum",
    "scheme_q_values",
    "tabular_gridworld_settings",
]

#: What a spec may be given as: LTLf text over the gridworld fluents, a bolt
#: :class:`~noisybolt.bolt.Spec` (only its formula matters here), or a compiled DFA whose
#: vocabulary is a subset of :data:`~noisybolt.envs.gridworld.GRIDWORLD_FLUENTS`.
SpecLike = str | Spec | DFA

#: R^c_max as printed in the paper's Table 1, keyed by the names of
#: :data:`noisybolt.agents.specs.PAPER_SPECS`.
PAPER_TABLE1_RC_MAX: dict[str, float] = {
    "edge": 94.0,
    "avoid_top_right": 82.0,
    "top_right_once": 92.0,
    "one_corner_once": 92.0,
}

#: Largest number of policy cells (steps x agent states x joint DFA states) planned for.
_MAX_CELLS = 200_000_000


@dataclass(frozen=True)
class OptimalResult:
    """The best compliant episode (see the module docstring for what complying means).

    Attributes:
        value: R^c_max, the best environment return of a compliant episode; None when no
            episode complies.
        steps: length of one optimal episode (the shortest among optimal ones); None
            when infeasible.
        actions: one optimal action sequence (:class:`~noisybolt.envs.gridworld.GridAction`
            values); empty when infeasible.
        states: ``(x, y, heading)`` at reset and after every action (``steps + 1`` of
            them); empty when infeasible.
        path: the cells visited, in order, without repeating a cell the agent stays on
            (turns and no-ops); empty when infeasible.
        reaches_goal: whether the optimal episode ends by entering the goal (False: it
            is truncated at the step limit).
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


class SpecOptimum(NamedTuple):
    """One row of :func:`paper_spec_optima`.

    Attributes:
        name: the spec's name in :data:`noisybolt.agents.specs.PAPER_SPECS`.
        formula: its LTLf formula.
        result: what :func:`optimal_constrained_return` computes for it alone.
        paper_value: the paper's R^c_max for it (:data:`PAPER_TABLE1_RC_MAX`).
    """

    name: str
    formula: str
    result: OptimalResult
    paper_value: float


class _Model(NamedTuple):
    """The gridworld's deterministic dynamics over its agent states, as read from the env.

    ``states[i]`` is ``(x, y, heading)``; ``next_index``, ``reward`` and ``terminated``
    are ``[n_states, n_actions]``; ``fluents`` is bool ``[n_states, 7]`` (ground truth of
    each state, in :data:`GRIDWORLD_FLUENTS` order); ``start`` indexes the reset state.
    """

    states: tuple[tuple[int, int, int], ...]
    next_index: np.ndarray
    reward: np.ndarray
    terminated: np.ndarray
    fluents: np.ndarray
    start: int
    step_limit: int


@lru_cache(maxsize=16)
def _gridworld_model(
    size: int, max_steps: int | None, step_reward: float, goal_reward: float
) -> _Model:
    """Steps every (agent state, action) once in a real GridworldEnv and records it."""
    env = GridworldEnv(
        size=size, max_steps=max_steps, step_reward=step_reward, goal_reward=goal_reward
    )
    try:
        env.reset(seed=0)
        start = (int(env.agent_pos[0]), int(env.agent_pos[1]), int(env.agent_dir))
        # Every cell the agent may stand on, as the env's grid says (floor and goal).
        cells = [
            (x, y)
            for x in range(env.width)
            for y in range(env.height)
            if (obj := env.grid.get(x, y)) is None or obj.can_overlap()
        ]
        states = tuple((x, y, d) for x, y in cells for d in range(4))
        index = {s: i for i, s in enumerate(states)}
        n_actions = len(GridAction)
        next_index = np.empty((len(states), n_actions), dtype=np.intp)
        reward = np.empty((len(states), n_actions), dtype=np.float64)
        terminated = np.empty((len(states), n_actions), dtype=bool)
        fluents = np.empty((len(states), len(GRIDWORLD_FLUENTS)), dtype=bool)
        for i, (x, y, d) in enumerate(states):
            env.agent_pos, env.agent_dir = (x, y), d
            fluents[i] = env.true_fluents()
            for a in range(n_actions):
                env.reset()  # a fresh episode (step count 0), then the agent is placed
                env.agent_pos, env.agent_dir = (x, y), d
                _, r, term, _, _ = env.step(a)
                reached = (int(env.agent_pos[0]), int(env.agent_pos[1]), int(env.agent_dir))
                next_index[i, a] = index[reached]
                reward[i, a] = r
                terminated[i, a] = term
        model = _Model(
            states=states,
            next_index=next_index,
            reward=reward,
            terminated=terminated,
            fluents=fluents,
            start=index[start],
            step_limit=env.config.step_limit,
        )
    finally:
        env.close()
    for array in (next_index, reward, terminated, fluents):
        array.setflags(write=False)
    return model


def _as_dfa(spec: SpecLike) -> DFA:
    """Compiles a spec over the gridworld vocabulary (a DFA passes through)."""
    if isinstance(spec, DFA):
        resolve_fluents(spec.fluents)  # raises UnknownFluentError for a foreign vocabulary
        return spec
    if isinstance(spec, Spec):
        return compile_ltlf(spec.formula, GRIDWORLD_FLUENTS)
    if isinstance(spec, str):
        return compile_ltlf(spec, GRIDWORLD_FLUENTS)
    raise ConfigError(
        f"a spec must be LTLf text, a noisybolt.bolt.Spec or a compiled DFA, got {spec!r}"
    )


class _Product(NamedTuple):
    """The joint DFA state space of several specs, driven by the agent state reached.

    ``successor[s, j]`` is the joint state after the DFAs in joint state ``j`` read the
    fluents of agent state ``s``; ``accepting[j]`` says every DFA accepts; ``initial`` is
    the joint state after reading the reset state's fluents.
    """

    successor: np.ndarray
    accepting: np.ndarray
    initial: int


def _product(dfas: Sequence[DFA], model: _Model) -> _Product:
    n_agent = len(model.states)
    successor = np.zeros((n_agent, 1), dtype=np.intp)
    accepting = np.ones(1, dtype=bool)
    initial = 0
    for dfa in dfas:  # mixed radix: the joint index is sum_i q_i * stride_i
        _, columns = resolve_fluents(dfa.fluents)
        masks = masks_from_bool_matrix(model.fluents[:, columns])  # [n_agent]
        n = dfa.n_states
        q = np.repeat(np.arange(n), n_agent)
        step, _ = dfa.step_batch(q, np.tile(masks, n))
        step = step.reshape(n, n_agent).T  # [n_agent, n]: successor of q on entering s
        stride = successor.shape[1]
        # Joint j' = j + stride * q: digits below stride are the earlier DFAs.
        successor = (successor[:, None, :] + stride * step[:, :, None]).reshape(n_agent, -1)
        accepting = (accepting[None, :] & dfa.accepting[:, None]).reshape(-1)
        initial = initial + stride * int(step[model.start, dfa.initial_state])
    return _Product(successor=successor, accepting=accepting, initial=initial)


def optimal_constrained_return(
    specs: Sequence[SpecLike],
    *,
    size: int = 6,
    max_steps: int | None = None,
    step_reward: float = -1.5,
    goal_reward: float = 100.0,
    require_goal: bool = False,
) -> OptimalResult:
    """R^c_max: the best environment return of an episode that complies with every spec.

    Exact: backward induction over the steps left before truncation, on the product of
    the gridworld's dynamics (read from :class:`~noisybolt.envs.gridworld.GridworldEnv`)
    and the specs' DFAs on ground-truth fluents. Among optimal episodes the shortest is
    returned (then the one whose actions come first in :class:`GridAction` order).

    Args:
        specs: the bolt's specifications (LTLf text, :class:`~noisybolt.bolt.Spec` or a
            compiled :class:`~noisybolt.logic.DFA` over gridworld fluents); empty for R_max.
        size: room side in cells, walls included.
        max_steps: truncation limit; None for MiniGrid's ``4 * size**2``.
        step_reward: reward of every step.
        goal_reward: extra reward for entering the goal.
        require_goal: count only episodes that reach the goal (not those truncated).

    Returns:
        An :class:`OptimalResult`; its ``value`` is None when no episode complies.

    Raises:
        ConfigError: a bad world setting, a spec of the wrong type, or a product too
            large to plan over.
        SpecSyntaxError: a formula does not parse.
        UnknownFluentError: a formula or DFA uses a fluent the gridworld does not have.

    Example:
        >>> r = optimal_constrained_return(["G(on_edge)", "!F(top_right_corner)"])
        >>> r.value, r.path[:5], r.path[-1]
        (88.0, ((1, 1), (1, 2), (1, 3), (1, 4), (2, 4)), (4, 4))
    """
    if isinstance(specs, str | Spec | DFA):
        raise ConfigError(
            "specs must be a sequence of specs; wrap a single spec in a list, e.g. [spec]"
        )
    config = GridworldConfig(
        size=size, max_steps=max_steps, step_reward=step_reward, goal_reward=goal_reward
    )
    dfas = [_as_dfa(spec) for spec in specs]
    model = _gridworld_model(config.size, config.max_steps, config.step_reward, config.goal_reward)
    product = _product(dfas, model)
    horizon = model.step_limit
    n_agent, n_joint = product.successor.shape
    if horizon * n_agent * n_joint > _MAX_CELLS:
        raise ConfigError(
            f"planning needs {horizon} steps x {n_agent} agent states x {n_joint} joint DFA "
            f"states, over {_MAX_CELLS} cells: use fewer or smaller specs, a smaller room "
            "or a lower max_steps"
        )
    policy = _backward_induction(model, product, horizon=horizon, require_goal=require_goal)
    formulas = tuple(d.formula or repr(d) for d in dfas)
    if policy is None:
        return OptimalResult(None, None, (), (), (), False, horizon, formulas)
    return _rollout(model, product, policy, horizon, formulas)


def optimal_unconstrained_return(
    *,
    size: int = 6,
    max_steps: int | None = None,
    step_reward: float = -1.5,
    goal_reward: float = 100.0,
    require_goal: bool = False,
) -> OptimalResult:
    """R_max: :func:`optimal_constrained_return` with no specs.

    Example:
        >>> r = optimal_unconstrained_return()
        >>> r.value, r.steps, r.reaches_goal
        (89.5, 7, True)
    """
    return optimal_constrained_return(
        [],
        size=size,
        max_steps=max_steps,
        step_reward=step_reward,
        goal_reward=goal_reward,
        require_goal=require_goal,
    )


def _backward_induction(
    model: _Model, product: _Product, *, horizon: int, require_goal: bool
) -> np.ndarray | None:
    """The optimal policy ``[horizon, n_agent, n_joint]`` (int8), or None if infeasible.

    ``value[s, j]`` is the best return from agent state ``s`` and joint DFA state ``j``
    (both already read) with some steps left; ``length`` the steps an optimal episode
    from there takes, so ties in value go to the shorter episode.
    """
    n_agent, n_joint = product.successor.shape
    end_value = np.where(product.accepting, 0.0, -np.inf)  # [n_joint], on ending there
    # With no steps left the episode is truncated where it stands.
    value = np.broadcast_to(
        np.full(n_joint, -np.inf) if require_goal else end_value, (n_agent, n_joint)
    )
    length = np.zeros((n_agent, n_joint), dtype=np.int64)
    policy = np.empty((horizon, n_agent, n_joint), dtype=np.int8)
    n_actions = model.next_index.shape[1]
    for t in range(horizon - 1, -1, -1):
        values = np.empty((n_actions, n_agent, n_joint))
        lengths = np.empty((n_actions, n_agent, n_joint), dtype=np.int64)
        for a in range(n_actions):
            reached = model.next_index[:, a]  # [n_agent]
            joint = product.successor[reached]  # [n_agent, n_joint]
            ends = model.terminated[:, a, None]
            rows = reached[:, None]
            values[a] = model.reward[:, a, None] + np.where(
                ends, end_value[joint], value[rows, joint]
            )
            lengths[a] = 1 + np.where(ends, 0, length[rows, joint])
        best = values.max(axis=0)
        # Equal returns up to rounding: prefer the shorter episode, then the lower action.
        tolerance = 1e-9 * np.maximum(1.0, np.abs(np.where(np.isfinite(best), best, 0.0)))
        tied = values >= best - tolerance
        choice = np.argmin(np.where(tied, lengths, np.iinfo(np.int64).max), axis=0)
        policy[t] = choice
        value = np.take_along_axis(values, choice[None], axis=0)[0]
        length = np.take_along_axis(lengths, choice[None], axis=0)[0]
    if not np.isfinite(value[model.start, product.initial]):
        return None
    return policy


def _rollout(
    model: _Model,
    product: _Product,
    policy: np.ndarray,
    horizon: int,
    formulas: tuple[str, ...],
) -> OptimalResult:
    """Follows ``policy`` from the reset state and sums the rewards actually earned."""
    s, j = model.start, product.initial
    actions: list[int] = []
    states = [model.states[s]]
    total = 0.0
    reaches_goal = False
    for t in range(horizon):
        a = int(policy[t, s, j])
        actions.append(a)
        total += float(model.reward[s, a])
        reaches_goal = bool(model.terminated[s, a])
        s = int(model.next_index[s, a])
        j = int(product.successor[s, j])
        states.append(model.states[s])
        if reaches_goal:
            break
    path = [states[0][:2]]
    for x, y, _ in states[1:]:
        if (x, y) != path[-1]:
            path.append((x, y))
    return OptimalResult(
        value=total,
        steps=len(actions),
        actions=tuple(actions),
        states=tuple(states),
        path=tuple(path),
        reaches_goal=reaches_goal,
        step_limit=horizon,
        formulas=formulas,
    )


def paper_spec_optima(
    *,
    size: int = 6,
    max_steps: int | None = None,
    step_reward: float = -1.5,
    goal_reward: float = 100.0,
    require_goal: bool = False,
) -> tuple[SpecOptimum, ...]:
    """R^c_max of each of the paper's four gridworld specs, beside the paper's number.

    Arguments are those of :func:`optimal_constrained_return`.
    """
    # Imported here: noisybolt.agents pulls in torch, which planning does not need.
    from noisybolt.agents.specs import PAPER_SPECS

    rows = []
    for name, paper_value in PAPER_TABLE1_RC_MAX.items():
        formula = PAPER_SPECS[name]
        result = optimal_constrained_return(
            [formula],
            size=size,
            max_steps=max_steps,
            step_reward=step_reward,
            goal_reward=goal_reward,
            require_goal=require_goal,
        )
        rows.append(SpecOptimum(name, formula, result, paper_value))
    return tuple(rows)


def format_optima_table(rows: Sequence[SpecOptimum]) -> str:
    """A Markdown table of :func:`paper_spec_optima`'s rows (``|`` in formulas escaped)."""
    lines = [
        "| spec | formula | R^c_max (ours) | steps | R^c_max (paper) |",
        "|---|---|---:|---:|---:|",
    ]
    for row in rows:
        value = "infeasible" if row.result.value is None else f"{row.result.value:g}"
        steps = "-" if row.result.steps is None else str(row.result.steps)
        formula = row.formula.replace("|", "\\|")  # a bare | would end the cell
        lines.append(f"| {row.name} | `{formula}` | {value} | {steps} | {row.paper_value:g} |")
    return "\n".join(lines)


def tabular_gridworld_settings(world: object) -> dict[str, object] | None:
    """The planner's world settings (size, max_steps, step and goal rewards) of a
    vectorised gridworld, or None for a world the planner cannot explore."""
    from noisybolt.envs.gridworld_vec import VectorGridworld

    if not isinstance(world, VectorGridworld) or world.config.start_heading != "east":
        return None
    config = world.config
    return {
        "size": config.size,
        "max_steps": config.max_steps,
        "step_reward": config.step_reward,
        "goal_reward": config.goal_reward,
    }


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
    specs: Sequence[SpecLike],
    *,
    scale: float,
    gamma: float,
    shaping: bool,
    pay_on_change: bool = True,
    size: int = 6,
    max_steps: int | None = None,
    step_reward: float = -1.5,
    goal_reward: float = 100.0,
) -> np.ndarray:
    """Optimal Q-values ``[horizon, n_agent, n_joint, n_actions]`` of the compliance scheme.

    The learner's problem on the product of the gridworld and the specs' DFAs (on ground
    truth, no perception noise), discounted by ``gamma``: each step pays the world's
    reward and the progress terms of :class:`~noisybolt.bolt.ProgressShaping` (the
    violation charge; at the end, the graded outcome; with ``shaping``, the
    potential-based term), and an episode that ends (at the goal, or truncated at the
    step limit) pays ``scale`` per spec whose DFA accepts; with ``pay_on_change``, each
    spec's ``scale`` is paid as its DFA enters acceptance and taken back as it leaves
    instead (``on_change`` timing).
    Backward induction over the steps left.
    """
    dfas = [_as_dfa(spec) for spec in specs]
    model = _gridworld_model(size, max_steps, step_reward, goal_reward)
    product = _product(dfas, model)
    n_agent, n_joint = product.successor.shape
    # Per joint state, summed over specs: acceptance's worth, the potential, the
    # violation charge as a potential (-scale where a spec can no longer accept).
    accepted = np.zeros(n_joint)
    potential = np.zeros(n_joint)
    dead_cost = np.zeros(n_joint)
    rest = np.arange(n_joint)
    for dfa in dfas:  # the joint index's digits, first DFA lowest (as _product builds it)
        q = rest % dfa.n_states
        rest = rest // dfa.n_states
        accepted += scale * dfa.accepting[q]
        _, columns = resolve_fluents(dfa.fluents)
        letters = masks_from_bool_matrix(model.fluents[:, columns])  # the world's own
        potential += progress_potential(dfa, scale, letters)[q]
        dead_cost += scale * (distance_to_acceptance(dfa)[q] < 0)
    horizon = model.step_limit
    n_actions = model.next_index.shape[1]
    q_values = np.empty((horizon, n_agent, n_joint, n_actions))
    value = np.zeros((n_agent, n_joint))  # never read at the last step: every episode ends
    for t in range(horizon - 1, -1, -1):
        for a in range(n_actions):
            reached = model.next_index[:, a]
            joint = product.successor[reached]  # [n_agent, n_joint]
            ends = model.terminated[:, a, None] | (t == horizon - 1)
            reward = model.reward[:, a, None] + dead_cost[None, :] - dead_cost[joint]
            if pay_on_change:  # acceptance paid as it is gained, taken back as it is lost
                reward = reward + accepted[joint] - accepted[None, :]
                reward = reward + np.where(ends, potential[joint], 0.0)
            else:
                reward = reward + np.where(ends, accepted[joint] + potential[joint], 0.0)
            if shaping:
                reward = reward + np.where(ends, 0.0, gamma * potential[joint]) - potential
            q_values[t, :, :, a] = reward + np.where(
                ends, 0.0, gamma * value[reached[:, None], joint]
            )
        value = q_values[t].max(axis=-1)
    return q_values


def scheme_optimum(
    specs: Sequence[SpecLike],
    *,
    scale: float,
    gamma: float,
    shaping: bool = True,
    pay_on_change: bool = True,
    size: int = 6,
    max_steps: int | None = None,
    step_reward: float = -1.5,
    goal_reward: float = 100.0,
) -> SchemeOptimum:
    """What the optimal policy of :func:`scheme_q_values`'s problem does from the start.

    Example:
        >>> r = scheme_optimum(["F(top_right_corner) & F(bottom_left_corner)"],
        ...                    scale=346.0, gamma=0.99)
        >>> r.complies, r.reaches_goal, r.steps
        (True, True, 16)
    """
    q_values = scheme_q_values(
        specs,
        scale=scale,
        gamma=gamma,
        shaping=shaping,
        pay_on_change=pay_on_change,
        size=size,
        max_steps=max_steps,
        step_reward=step_reward,
        goal_reward=goal_reward,
    )
    dfas = [_as_dfa(spec) for spec in specs]
    model = _gridworld_model(size, max_steps, step_reward, goal_reward)
    product = _product(dfas, model)
    s, j, total = model.start, product.initial, 0.0
    reaches_goal, steps = False, 0
    for t in range(model.step_limit):
        a = int(np.argmax(q_values[t, s, j]))
        total += float(model.reward[s, a])
        steps += 1
        reaches_goal = bool(model.terminated[s, a])
        s = int(model.next_index[s, a])
        j = int(product.successor[s, j])
        if reaches_goal:
            break
    return SchemeOptimum(
        complies=bool(product.accepting[j]),
        reaches_goal=reaches_goal,
        steps=steps,
        env_return=total,
    )


def exact_compliance_scale(
    specs: Sequence[SpecLike],
    *,
    gamma: float,
    floor: float,
    cap: float,
    pay_on_change: bool = True,
    size: int = 6,
    max_steps: int | None = None,
    step_reward: float = -1.5,
    goal_reward: float = 100.0,
) -> float | None:
    """The compliance scheme's scale computed exactly on the gridworld's product.

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
    world = {
        "size": size,
        "max_steps": max_steps,
        "step_reward": step_reward,
        "goal_reward": goal_reward,
    }
    best = optimal_unconstrained_return(require_goal=True, **world)  # type: ignore[arg-type]
    compliant = optimal_constrained_return(specs, require_goal=True, **world)  # type: ignore[arg-type]
    if compliant.value is None or best.value is None:
        return None
    scale = min(cap, 2.0 * (best.value - compliant.value) + floor)

    def complies(scale: float) -> bool:
        optimum = scheme_optimum(
            specs,
            scale=scale,
            gamma=gamma,
            pay_on_change=pay_on_change,
            **world,  # type: ignore[arg-type]
        )
        return optimum.complies

    while scale < cap and not complies(scale):
        scale = min(cap, 2.0 * scale)
    return float(scale)


if __name__ == "__main__":  # pragma: no cover
    print(format_optima_table(paper_spec_optima()))
