"""The spec, not a per-step payment, decides the route the agent learns.

In the gridworld the shortest route to the goal (7 actions: along the top wall, through
the top-right corner) breaks ``!F(top_right_corner)``; the shortest compliant one (8:
down the left wall, through the bottom-left corner) is one step longer. Three bolts
watch the *same* experience (same seed, same exploratory actions, the oracle detector):

* ``spec``: ``!F(top_right_corner)`` pays the bolt's reward;
* ``payment``: ``F(facing_right)``, true from the first observation on every route, pays
  the same reward instead (the same per-step payment, on every route alike);
* ``none``: neither pays (the world's reward only).

Each bolt carries both DFAs, so the three agents see identical observations and differ
only in the rewards they were paid. A tabular agent learns from each bolt's rewards
(Q-iteration over the transitions it experienced) and its greedy route is read from the
world's grid. Only under ``spec`` does it detour; under the other two it takes
the shortcut. The end-to-end version with A2C through ``train`` is marked slow.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from noisybolt.bolt import Spec
from noisybolt.envs import SB3VecEnv
from noisybolt.envs.gridworld_vec import VectorGridworld
from noisybolt.perception.detectors import OracleDetector
from noisybolt.wrappers import BoltVecEnv

TOP_RIGHT = (4, 1)
AVOID, START = "!F(top_right_corner)", "F(facing_right)"


def _bolt(payer: str, *, timing: str, reward: float) -> list[Spec]:
    def spec(formula: str, name: str) -> Spec:
        paid = name == payer
        return Spec(
            formula,
            terminal_reward=reward if paid else 0.0,
            low_confidence_cost=0.5 if paid else 0.0,
            reward_timing=timing,  # type: ignore[arg-type]
            name=name,
        )

    return [spec(START, "payment"), spec(AVOID, "spec")]


def _env(specs: list[Spec], *, n: int, seed: int) -> BoltVecEnv:
    world = VectorGridworld(num_envs=n, seed=seed)
    return BoltVecEnv(SB3VecEnv(world), specs, OracleDetector(world.fluent_names))


def _states(obs: dict[str, np.ndarray]) -> np.ndarray:
    """int ``[n, 3 + n_specs]``: the agent's cell and heading (read off the symbolic
    grid, where object 10 is the agent and its third channel its heading), and the DFA
    states: everything the agent observes, as a table index."""
    image = obs["image"]
    n = len(image)
    cell = np.argmax(image[..., 0].reshape(n, -1) == 10, axis=1)
    x, y = np.unravel_index(cell, image.shape[1:3])
    return np.stack([x, y, image[np.arange(n), x, y, 2], *obs["dfa"].T], axis=1)


def _learn(specs: list[Spec], *, frames: int, seed: int, gamma: float = 0.99) -> np.ndarray:
    """Q-values ``[6, 6, 4, *dfa_states, 4]`` learned from the bolted env's rewards.

    The experience is uniformly random actions (so it is the same for every bolt); the
    values are then iterated to convergence over the transitions seen. Pairs never tried
    are never chosen.
    """
    n = 16
    env = _env(specs, n=n, seed=seed)
    rng = np.random.default_rng(seed)
    obs = env.reset()
    states = _states(obs)
    rows = []
    for _ in range(frames // n):
        actions = rng.integers(4, size=n)
        obs, rewards, dones, infos = env.step(actions)
        after = _states(obs)
        # A step cut short by the time limit is left out: the limit is outside the
        # task, and what an ``episode_end`` spec pays there depends on the step count,
        # which the table does not hold. A step into the goal ends the episode.
        keep = np.array([not info.get("TimeLimit.truncated", False) for info in infos])
        rows.append((states[keep], actions[keep], rewards[keep], after[keep], dones[keep]))
        states = after
    s, a, r, s2, end = (np.concatenate(column) for column in zip(*rows, strict=True))

    shape = (6, 6, 4, *env.observation_space["dfa"].nvec)
    pairs = np.ravel_multi_index(s.T, shape) * 4 + a
    seen, which = np.unique(pairs, return_inverse=True)
    reward = np.bincount(which, weights=r) / np.bincount(which)
    successor = np.zeros(len(seen), dtype=np.int64)
    successor[which] = np.ravel_multi_index(s2.T, shape)
    final = np.zeros(len(seen), dtype=bool)
    final[which] = end
    q = np.full(int(np.prod(shape)) * 4, -np.inf)
    q[seen] = 0.0
    for _ in range(500):
        value = q.reshape(-1, 4).max(axis=1)
        value[~np.isfinite(value)] = 0.0
        q[seen] = reward + gamma * value[successor] * ~final
    return q.reshape(*shape, 4)


def _greedy_route(q: np.ndarray, specs: list[Spec]) -> tuple[list[tuple[int, int]], bool]:
    """The cells the greedy agent stands on before the goal, and whether it reached the
    goal (within 30 steps)."""
    env = _env(specs, n=1, seed=0)
    obs = env.reset()
    cells: list[tuple[int, int]] = []
    for _ in range(30):
        state = _states(obs)[0]
        cells.append((int(state[0]), int(state[1])))
        obs, _, dones, infos = env.step(np.array([q[tuple(state)].argmax()]))
        if dones[0]:
            return cells, bool(infos[0]["is_success"])
    return cells, False


@pytest.mark.parametrize(
    ("timing", "reward"),
    [("every_step", 1.0), ("episode_end", 50.0)],
    ids=["paid-every-compliant-step", "paid-once-at-the-end"],
)
@pytest.mark.parametrize("seed", [0, 1])
def test_only_the_spec_makes_the_agent_detour(timing: str, reward: float, seed: int) -> None:
    routes = {}
    for payer in ("spec", "payment", "none"):
        specs = _bolt(payer, timing=timing, reward=reward)
        cells, goal = _greedy_route(_learn(specs, frames=8000, seed=seed), specs)
        assert goal, (payer, cells)
        routes[payer] = cells
    # The shortcut: 7 actions, 7 cells stood on before the goal, one the top-right corner.
    for control in ("payment", "none"):
        assert len(routes[control]) == 7 and TOP_RIGHT in routes[control], routes
    # The detour: one step longer, and never through the corner.
    assert len(routes["spec"]) == 8 and TOP_RIGHT not in routes["spec"], routes


@pytest.mark.slow
def test_a2c_detours_only_with_the_bolt(tmp_path: Path) -> None:
    # End to end through train(): the same config and seed with and without the bolt's
    # rewards (bolted=False keeps the DFA in the observation and tracks compliance).
    from noisybolt.runs import DetectorConfig, TrainConfig, train

    results = {}
    for bolted in (True, False):
        config = TrainConfig.create(
            specs=["avoid_top_right"],
            algo="a2c",
            detector=DetectorConfig(kind="oracle"),
            frames=40_000,
            eval_freq=0,
            eval_episodes=20,
            checkpoint_freq=0,
            progress_bar=False,
            reward="paper",
            bolted=bolted,
        )
        results[bolted] = train(config, tmp_path / str(bolted), log=lambda _: None).final
    for result in results.values():
        assert result.goal_rate >= 0.9
    assert results[True].compliance["avoid_top_right"] >= 0.9
    assert results[True].length_mean >= 8
    assert results[False].compliance["avoid_top_right"] <= 0.1
    assert results[False].length_mean < 8
