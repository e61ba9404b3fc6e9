"""Atari training conventions: FIRE after resets and lost lives, clipped game rewards,
and lost lives as the learner's ``done`` while the game and the bolt's DFAs go on."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from playback import PlaybackVecEnv

from noisybolt.envs import SB3VecEnv
from noisybolt.envs.breakout import BreakoutWorld
from noisybolt.perception.detectors import OracleDetector
from noisybolt.runs.specs import resolve_spec
from noisybolt.wrappers import BoltVecEnv, ClipGameReward, LifeLossTerminal

NOOP = 0


class Scripted(PlaybackVecEnv):
    """Plays back rewards, dones and lives given per step (one env per column)."""

    def __init__(self, rewards: list[list[float]], dones: list[list[bool]], lives: list[list[int]]):
        self.rewards = np.asarray(rewards, dtype=np.float32)
        self.dones = np.asarray(dones, dtype=bool)
        self.life_table = np.asarray(lives, dtype=np.int64)  # row 0: after reset
        n = self.rewards.shape[1]
        super().__init__(n)
        self.t = 0

    def lives(self) -> np.ndarray:
        return self.life_table[self.t]

    def reset(self) -> Any:
        self.t = 0
        return np.zeros((self.num_envs, 1), np.float32)

    def step_wait(self) -> Any:
        self.t += 1
        obs = np.full((self.num_envs, 1), self.t, np.float32)
        infos: list[dict[str, Any]] = [{} for _ in range(self.num_envs)]
        return obs, self.rewards[self.t - 1], self.dones[self.t - 1], infos


def test_clip_game_reward_keeps_the_sign_and_reports_the_score():
    venv = ClipGameReward(Scripted([[0, 4, -2, 7]], [[False] * 4], [[5] * 4, [5] * 4]))
    venv.reset()
    _, rewards, _, infos = venv.step(np.zeros(4, dtype=np.int64))
    assert rewards.tolist() == [0.0, 1.0, -1.0, 1.0]
    assert [i["unclipped_reward"] for i in infos] == [0.0, 4.0, -2.0, 7.0]


def test_lost_life_is_done_for_the_learner_only():
    # env 0 loses a life at step 2 and again at step 3; env 1 loses its last life at
    # step 2, which ends its game (done already; its new game has 5 lives).
    lives = [[2, 1], [2, 1], [1, 5], [0, 5], [0, 5]]
    dones = [[False, False], [False, True], [False, False], [True, False]]
    inner = Scripted([[0, 0]] * 4, dones, lives)
    venv = LifeLossTerminal(inner, inner.lives)
    venv.reset()
    got, lost = [], []
    for _ in range(4):
        obs, _, done, infos = venv.step(np.zeros(2, dtype=np.int64))
        got.append(done.tolist())
        lost.append([bool(i.get("life_lost")) for i in infos])
        assert obs[:, 0].tolist() == [inner.t, inner.t]  # the real next observation
    assert got == [[False, False], [True, True], [True, False], [True, False]]
    assert lost == [[False, False], [True, False], [True, False], [False, False]]


def test_lives_of_the_wrong_shape_are_refused():
    inner = Scripted([[0, 0]], [[False, False]], [[5, 5], [5, 5]])
    venv = LifeLossTerminal(inner, lambda: np.array([5, 5, 5]))
    with pytest.raises(ValueError, match=r"lives\(\) must return \[2\]"):
        venv.reset()


def _lives_lost_in(world: BreakoutWorld, steps: int) -> int:
    world.reset(seed=3)
    lost = 0
    before = world.lives()
    for _ in range(steps):
        _, _, terminated, truncated, _ = world.step(np.full(world.num_envs, NOOP))
        now = world.lives()
        lost += int(((now < before) & ~(terminated | truncated)).sum())
        before = now
    return lost


def test_fire_on_reset_serves_the_ball_to_an_agent_that_never_fires():
    # Without FIRE the ball is never served, so a NOOP-only agent never loses a life; with
    # fire_on_reset the ball is served at the start and after every lost life, so it
    # loses them (the paddle stays in the middle and misses most balls).
    assert _lives_lost_in(BreakoutWorld(num_envs=1, seed=3, fluents=["brick_clear_left"]), 400) == 0
    fired = BreakoutWorld(num_envs=1, seed=3, fluents=["brick_clear_left"], fire_on_reset=True)
    assert _lives_lost_in(fired, 400) >= 2


def test_life_loss_terminal_over_the_bolt_keeps_the_game_and_the_dfas_going():
    def bolted(seed: int) -> tuple[BoltVecEnv, BreakoutWorld]:
        world = BreakoutWorld(num_envs=2, seed=seed, fire_on_reset=True, noop_max=0)
        spec = resolve_spec("left_row5")
        detector = OracleDetector(world.fluent_names)
        return BoltVecEnv(SB3VecEnv(world), [spec], detector, world=world), world

    plain, _ = bolted(5)
    inner, world = bolted(5)
    wrapped = LifeLossTerminal(inner, world.lives)
    obs_a, obs_b = plain.reset(), wrapped.reset()
    rng = np.random.default_rng(0)
    extra_dones = 0
    for _ in range(300):
        actions = rng.integers(0, 4, size=2)
        obs_a, rew_a, done_a, _ = plain.step(actions)
        obs_b, rew_b, done_b, infos = wrapped.step(actions)
        np.testing.assert_array_equal(obs_a["image"], obs_b["image"])
        np.testing.assert_array_equal(obs_a["dfa"], obs_b["dfa"])  # DFAs not restarted
        np.testing.assert_array_equal(rew_a, rew_b)
        lost = np.array([bool(i.get("life_lost")) for i in infos])
        np.testing.assert_array_equal(done_b, done_a | lost)
        assert not (lost & done_a).any()
        extra_dones += int(lost.sum())
    assert extra_dones >= 2
