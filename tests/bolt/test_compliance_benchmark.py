"""benchmarks/compliance_estimates.py's policies: what each is shown, and when it changes."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from types import ModuleType
from typing import Any

import numpy as np
import pytest

from noisybolt.bolt import RestrainingBolt, Spec
from noisybolt.envs import make_world
from noisybolt.perception.detectors import OracleDetector


@pytest.fixture(scope="module")
def bench(load_script: Callable[..., ModuleType]) -> ModuleType:
    return load_script("benchmarks/compliance_estimates.py")


class _Agent:
    """A stand-in model: uniformly random actions (seeded), and every ``dfa`` observation
    it was shown."""

    def __init__(self, seed: int) -> None:
        self.rng = np.random.default_rng(seed)
        self.shown: list[np.ndarray] = []

    def predict(self, obs: Mapping[str, Any], deterministic: bool = False) -> tuple[Any, None]:
        assert not deterministic  # the benchmark samples its agents' actions
        self.shown.append(obs["dfa"][:, 0].copy())
        return self.rng.integers(3, size=len(obs["dfa"])), None


class _Watch:
    """Wraps a policy: per step, the truth it acted on, who played and what ended."""

    def __init__(self, policy: Any) -> None:
        self.policy = policy
        self.truth: list[np.ndarray] = []
        self.playing: list[np.ndarray] = []
        self.ended: list[np.ndarray] = []

    def start(self, probs: np.ndarray) -> None:
        self.policy.start(probs)

    def act(self, obs: Any, info: Mapping[str, Any], truth: np.ndarray) -> np.ndarray:
        self.truth.append(truth.copy())
        self.playing.append(self.policy.playing.copy())
        return self.policy.act(obs, info, truth)

    def seen(self, last: np.ndarray, first: np.ndarray, ended: np.ndarray) -> None:
        self.policy.seen(last, first, ended)
        self.ended.append(ended.copy())


def test_trained_agents_see_their_bolts_states_and_are_drawn_once_per_episode(
    bench: ModuleType,
) -> None:
    world = make_world("gridworld", num_envs=4, seed=0)
    fluents = tuple(world.fluent_names)
    spec = [Spec(formula="F(bottom_left_corner)")]
    agents = [_Agent(1), _Agent(2)]
    bolts = [RestrainingBolt(spec, fluents, n_envs=4) for _ in agents]
    policy = bench.TrainedPolicy(list(zip(agents, bolts, strict=True)), [0.5, 0.5], seed=3)
    watch = _Watch(policy)
    episodes = bench.record(world, OracleDetector(fluents), watch, 24, 0)
    world.close()
    assert len(episodes) == 24
    corner = fluents.index("bottom_left_corner")
    # F(bottom_left_corner) as the bolt tracks it on the oracle's readings: the corner seen
    # on this episode's frames so far, the frame acted on included, the last one's forgotten
    # where an episode ended before it.
    visited = np.zeros(4, dtype=bool)
    expected = []
    for t, truth in enumerate(watch.truth):
        if t:
            visited[watch.ended[t - 1]] = False
        visited |= truth[:, corner]
        playing = watch.playing[t]
        expected.append((playing, visited.copy()))
        if t:  # the agent changes only where an episode ended
            changed = np.flatnonzero(playing != watch.playing[t - 1])
            assert set(changed.tolist()) <= set(watch.ended[t - 1].tolist())
    for k, agent in enumerate(agents):
        shown = [v[p == k] for p, v in expected if (p == k).any()]
        assert len(agent.shown) == len(shown)
        assert all((a == b).all() for a, b in zip(agent.shown, shown, strict=True))
    states = np.concatenate([np.concatenate(a.shown) for a in agents])
    assert states.any() and not states.all()  # both DFA states were shown
    # each agent played some episodes' first steps
    firsts = np.concatenate([watch.playing[0]] + [
        watch.playing[t + 1][e] for t, e in enumerate(watch.ended[:-1])
    ])  # fmt: skip
    assert set(firsts.tolist()) == {0, 1}


def test_the_paddle_follows_the_ball_with_its_offset_and_fires_without_one(
    bench: ModuleType,
) -> None:
    ram = np.zeros((4, 128))
    # paddle x, ball x, ball y per row
    for row, (paddle, ball_x, ball_y) in enumerate(
        [(40, 80, 100), (60, 50, 100), (42, 50, 100), (40, 60, 0)]
    ):
        ram[row, [72, 99, 101]] = paddle, ball_x, ball_y
    noop, fire, right, left = 0, 1, 2, 3  # the ALE's Breakout actions
    straight = bench.PaddlePolicy({0: 1.0}, 0.0, n_envs=4, seed=0)
    actions = straight.act(ram / 255, {}, np.zeros((4, 7), dtype=bool))
    assert actions.tolist() == [right, left, noop, fire]
    # an offset of -6 to the left: the paddle at 42 is now right of where it should be
    leftwards = bench.PaddlePolicy({-6: 1.0}, 0.0, n_envs=4, seed=0)
    assert leftwards.act(ram / 255, {}, np.zeros((4, 7), dtype=bool))[2] == left


def test_a_scripted_route_goes_where_it_says(bench: ModuleType) -> None:
    world = make_world("gridworld", num_envs=3, seed=1)
    fluents = tuple(world.fluent_names)
    policy = bench.RoutePolicy(
        bench.GRID_ROUTES, {"top-right": 1.0}, 0.0, n_envs=3, n_actions=3, turning=True,
        seed=1, fluents=fluents,
    )  # fmt: skip
    episodes = bench.record(world, OracleDetector(fluents), policy, 6, 1)
    world.close()
    top, bottom = fluents.index("top_right_corner"), fluents.index("bottom_left_corner")
    assert all(e.truth[:, top].any() and not e.truth[:, bottom].any() for e in episodes)
    # every frame recorded once: a route of 6 cells and its turns, the first frame included
    assert all(len(e.truth) == len(episodes[0].truth) for e in episodes)


def test_breakout_games_are_recorded_whole_and_their_bricks_stay_gone(bench: ModuleType) -> None:
    world = make_world(
        bench.BREAKOUT_WORLD, num_envs=4, seed=0, **bench.BREAKOUT_KWARGS, max_episode_frames=400
    )
    fluents = tuple(world.fluent_names)
    policy = bench.PaddlePolicy({0: 1.0, -6: 1.0}, 0.05, n_envs=4, seed=0)
    episodes = bench.record(world, OracleDetector(fluents), policy, 6, 0)
    world.close()
    for e in episodes:
        assert not e.truth[0].any()  # a fresh wall
        assert len(e.truth) <= 400 // 4 + 1  # 4 frames a step, the first frame besides
        assert (np.diff(e.truth.astype(int), axis=0) >= 0).all()  # bricks never come back
