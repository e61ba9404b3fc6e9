"""The constrained scheme in training: episode costs, the multiplier's callback, resume,
bad input refused before anything is written."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from stable_baselines3 import PPO
from stable_baselines3.common.monitor import Monitor

from noisybolt import FluentLabels, make_bolted_vec_env
from noisybolt.agents.constraint import LagrangianCallback, bolted_envs
from noisybolt.agents.pipeline import GroupedVecEnv
from noisybolt.bolt import CostLimit
from noisybolt.cli import main
from noisybolt.errors import ConfigError
from noisybolt.runs import DetectorConfig, TrainConfig, train
from noisybolt.wrappers import EPISODE_COST_KEY

# FrozenLake 4x4 (SFFF / FHFH / FFFH / HFFG); actions 0 left, 1 down, 2 right, 3 up.
TO_GOAL = [1, 1, 2, 2, 1, 2]
INTO_HOLE = [2, 1]  # (0, 1), then the hole at (1, 1)


def _lake() -> FluentLabels:
    env = gym.make("FrozenLake-v1", is_slippery=False, render_mode="rgb_array")
    return FluentLabels(
        env,
        fluents={"at_goal": lambda e: e.s == 15, "right_col": lambda e: e.s % 4 == 3},
        camera=lambda e: np.zeros((4, 4, 3), dtype=np.uint8),
    )


def _episode_cost(specs: list[str], actions: list[int]) -> tuple[float, ...]:
    env = make_bolted_vec_env(_lake, 1, specs, "oracle", seed=0)
    env.reset()
    costs = []
    for action in actions:
        _, _, dones, infos = env.step(np.array([action]))
        costs.append(infos[0].get(EPISODE_COST_KEY))
        if dones[0]:
            break
    env.close()
    assert costs[-1] is not None and all(c is None for c in costs[:-1])  # the last step only
    return costs[-1]


def test_an_episode_costs_the_specs_it_leaves_unsatisfied() -> None:
    # At the goal: F(at_goal) satisfied; G(!right_col) broken on entering the right column.
    assert _episode_cost(["F(at_goal)"], TO_GOAL) == 0.0
    assert _episode_cost(["F(at_goal)", "G(!right_col)"], TO_GOAL) == 1.0
    # Into the hole: F(at_goal) short of acceptance; G(!right_col) kept.
    assert _episode_cost(["F(at_goal)", "G(!right_col)"], INTO_HOLE) == 1.0
    assert _episode_cost(["F(at_goal)", "G(right_col)"], INTO_HOLE) == 2.0


def test_the_callback_prices_every_training_bolt_with_its_multiplier() -> None:
    env = make_bolted_vec_env(_lake, 4, ["F(at_goal)"], "oracle", seed=0)
    model = PPO("MultiInputPolicy", env, n_steps=32, batch_size=64, seed=0, device="cpu")
    callback = LagrangianCallback(CostLimit(cost_limit=0.0, lr=0.1, kp=0.0, anneal=0.0), frames=384)
    model.learn(total_timesteps=4 * 32 * 3, callback=callback)
    # A random walk on the lake seldom reaches the goal: every rollout's cost is near 1,
    # and the integral rises 0.1 a 1,000 frames at cost 1: at most 0.1 * 3 * 128 / 1000.
    assert callback.multiplier.updates == 3
    assert 0.02 < callback.multiplier.value <= 0.1 * 3 * 128 / 1000 + 1e-12
    assert env.price == callback.multiplier.value
    env.close()


def _ended_at(monitor: Monitor) -> list[tuple[int, float]]:
    """(the game's step at which each episode ended, its world return), from a Monitor."""
    lengths = np.cumsum(monitor.get_episode_lengths()).tolist()
    return list(zip(lengths, monitor.get_episode_rewards(), strict=True))


def _recording(callback: LagrangianCallback, model: PPO) -> list[tuple[int, float, int, list]]:
    """Each update the callback makes: (frames trained, cost, frames pooled, returns)."""
    calls: list[tuple[int, float, int, list]] = []
    update = callback.multiplier.update

    def recorded(cost: float, *, frames: int, returns: Any = None, **kwargs: Any) -> float:
        calls.append((int(model.num_timesteps), cost, frames, list(returns or [])))
        return update(cost, frames=frames, returns=returns, **kwargs)

    callback.multiplier.update = recorded  # type: ignore[method-assign]
    return calls


def _lake_monitored(monitored: list[Monitor], *, rewarded: bool = True) -> Any:
    def make() -> FluentLabels:
        lake: Any = gym.make("FrozenLake-v1", is_slippery=False, render_mode="rgb_array")
        if not rewarded:  # every episode returns 0: a goal never found
            lake = gym.wrappers.TransformReward(lake, lambda r: 0.0)
        env = Monitor(lake)
        monitored.append(env)
        return FluentLabels(
            env,
            fluents={"at_goal": lambda e: e.s == 15, "right_col": lambda e: e.s % 4 == 3},
            camera=lambda e: np.zeros((4, 4, 3), dtype=np.uint8),
        )

    return make


class CostsSeen(LagrangianCallback):
    """Records each game's ended episodes: (the game's step, the episode's cost), the
    step as :func:`_ended_at` counts it (the games step together)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.costs: list[list[tuple[int, float]]] = []

    def _on_step(self) -> bool:
        infos = self.locals["infos"]
        if not self.costs:
            self.costs.extend([] for _ in infos)
        for row, info in enumerate(infos):
            if info.get(EPISODE_COST_KEY) is not None:
                step = int(self.model.num_timesteps) // len(infos)
                self.costs[row].append((step, info[EPISODE_COST_KEY]))
        return super()._on_step()


def _begun_before(game: list[tuple[int, float]], frames: int, n_envs: int) -> list[int]:
    """The indices of a game's episodes begun before ``frames`` frames of ``n_envs`` games
    (the first begins at 0, each next one as the one before ends)."""
    starts = [0] + [step * n_envs for step, _ in game[:-1]]
    return [i for i, start in enumerate(starts) if start < frames]


def test_the_first_cost_pools_the_episodes_begun_in_the_window_then_windows_pool_the_rest() -> None:
    """The first measured cost pools every episode *begun* in the first 300 frames (each
    game's first among them), each waited for to its end, not the episodes a window
    happens to end first (the short ones); then every episode ended over a window of at
    least 300 frames, each with its world return (the bolt's payments left out, as the
    Monitor below the bolt measured it)."""
    monitored: list[Monitor] = []
    env = make_bolted_vec_env(_lake_monitored(monitored), 4, ["G(!right_col)"], "oracle", seed=0)
    model = PPO("MultiInputPolicy", env, n_steps=32, batch_size=64, seed=0, device="cpu")
    # A run of 100k frames (the first cost waits 5k past its window for the episodes it
    # counts), of which the first 768 are trained here.
    callback = CostsSeen(CostLimit(cost_limit=0.0, anneal=0.0, window=300), frames=100_000)
    costs = callback.costs
    calls = _recording(callback, model)
    model.learn(total_timesteps=768, callback=callback)
    ended = [_ended_at(m) for m in monitored]
    counted = [_begun_before(game, 300, 4) for game in costs]
    assert sum(map(len, counted)) > 4  # more than one episode a game
    last_end = max(costs[g][i][0] * 4 for g, indices in enumerate(counted) for i in indices)
    # Learnt at the first rollout's end (every 128 frames) past the window and past the
    # end of every counted episode, from their costs and returns.
    first_at, first_cost, first_frames, first_returns = calls[0]
    assert first_at == first_frames == max(384, -(-last_end // 128) * 128)
    cost_counted = [costs[g][i][1] for g, indices in enumerate(counted) for i in indices]
    assert first_cost == pytest.approx(np.mean(cost_counted))
    returns_counted = [ended[g][i][1] for g, indices in enumerate(counted) for i in indices]
    assert sorted(first_returns) == sorted(returns_counted)
    # Then windows of at least 300 frames: the episodes ended after the first update.
    assert [(at, pooled) for at, _, pooled, _ in calls[1:]] == [(first_at + 384, 384)]
    window = [c for game in costs for step, c in game if first_at < step * 4 <= first_at + 384]
    assert len(window) > 3 and calls[1][1] == pytest.approx(np.mean(window))
    returns = [r for game in ended for step, r in game if first_at < step * 4 <= first_at + 384]
    assert sorted(calls[1][3]) == sorted(returns)
    env.close()


def test_with_no_window_the_first_cost_is_each_game_s_first_episode() -> None:
    monitored: list[Monitor] = []
    env = make_bolted_vec_env(_lake_monitored(monitored), 4, ["G(!right_col)"], "oracle", seed=0)
    model = PPO("MultiInputPolicy", env, n_steps=32, batch_size=64, seed=0, device="cpu")
    callback = CostsSeen(CostLimit(cost_limit=0.0, anneal=0.0, window=0), frames=256)
    calls = _recording(callback, model)
    model.learn(total_timesteps=256, callback=callback)
    # Every game ended an episode within the first 32-step rollout (the lake is small),
    # most more than one: one episode a game, not the short ones a rollout ends first.
    assert all(game and game[0][0] <= 32 for game in callback.costs)
    assert sum(step <= 32 for game in callback.costs for step, _ in game) > 4
    assert calls[0][:3] == (128, pytest.approx(np.mean([g[0][1] for g in callback.costs])), 128)
    assert sorted(calls[0][3]) == sorted(game[0][1] for game in map(_ended_at, monitored))
    env.close()


def test_a_multiplier_woken_by_a_window_measures_its_first_cost_on_episodes_begun_after() -> None:
    """The window whose end wakes the multiplier teaches it nothing; the first cost is
    then of each game's next episode, begun after it woke."""
    monitored: list[Monitor] = []
    lake = _lake_monitored(monitored, rewarded=False)
    env = make_bolted_vec_env(lake, 2, ["G(!right_col)"], "oracle", seed=3)
    model = PPO("MultiInputPolicy", env, n_steps=256, batch_size=64, seed=0, device="cpu")
    # Every return 0: the wait ends at 0.3 of the run (the rollout ending at 1,024 frames).
    limit = CostLimit(cost_limit=0.0, kp=1.0, anneal=0.0, wait=0.3, window=0)
    callback = CostsSeen(limit, frames=2048)
    calls = _recording(callback, model)
    model.learn(total_timesteps=2048, callback=callback)
    multiplier = callback.multiplier
    assert multiplier.woke_at == 0.5
    assert [at for at, *_ in calls] == [512, 1024, 1536, 2048]
    # At 1,536 frames: each game's first episode begun at or after its step 512 (the
    # episode under way then is not counted).
    firsts = []
    for game in callback.costs:
        starts = [0] + [step for step, _ in game[:-1]]
        firsts.append(next(c for (_, c), began in zip(game, starts, strict=True) if began >= 512))
    assert calls[2][1] == pytest.approx(np.mean(firsts)) and len(calls[2][3]) == 2
    assert multiplier.first_cost == calls[2][1]
    # The window before (512-1,024) held other episodes, and taught nothing.
    assert calls[1][3] and multiplier.updates == 4
    env.close()


def test_the_price_s_scale_rises_with_the_world_returns_seen_where_it_was_estimated() -> None:
    """A scale of 0.25 (an estimate from random play that never reached the goal): once a
    goal is reached the returns seen span 0 to 1, and the bolts are priced at the
    multiplier times 1.1 / 0.25, the compliance scale over the gap they show."""
    env = make_bolted_vec_env(_lake, 4, ["G(!right_col)"], "oracle", seed=0)
    model = PPO("MultiInputPolicy", env, n_steps=256, batch_size=64, seed=0, device="cpu")
    limit = CostLimit(cost_limit=0.0, kp=1.0, anneal=0.0, rescale=1.1)
    callback = LagrangianCallback(limit, frames=4096, scale=0.25)
    model.learn(total_timesteps=4096, callback=callback)
    multiplier = callback.multiplier
    assert multiplier.returns_seen == (0.0, 1.0)  # random play found the goal by then
    assert callback.scale_factor == pytest.approx(4.4)
    assert env.price == pytest.approx(multiplier.value * 4.4) and multiplier.value > 0
    # Without rescale (bounds declared, or a scale given) the price is the multiplier.
    plain = LagrangianCallback(CostLimit(cost_limit=0.0, anneal=0.0), frames=4096, scale=0.25)
    plain.multiplier.update(1.0, returns=[0.0, 1.0])
    assert plain.scale_factor == 1.0
    env.close()


def test_bolted_envs_are_found_through_groups_and_wrappers() -> None:
    from stable_baselines3.common.vec_env import VecNormalize

    groups = [make_bolted_vec_env(_lake, 1, ["F(at_goal)"], "oracle", seed=s) for s in (0, 1)]
    found = bolted_envs(VecNormalize(GroupedVecEnv(groups), norm_obs=False))
    assert sorted(map(id, found)) == sorted(map(id, groups))
    with pytest.raises(ConfigError, match="no BoltVecEnv"):
        bolted_envs(groups[0].venv)


def _config(**kwargs: object) -> TrainConfig:
    settings: dict[str, object] = {
        "specs": ["edge"],
        "reward": "constrained",
        "detector": DetectorConfig(kind="oracle"),
        "frames": 2048,
        "eval_freq": 1024,
        "eval_episodes": 4,
        "checkpoint_freq": 1024,
        "progress_bar": False,
        "overrides": {"n_steps": 64},
    }
    settings.update(kwargs)
    return TrainConfig.create(**settings)  # type: ignore[arg-type]


def _multiplier(run: Path) -> dict:
    latest = json.loads((run / "checkpoints" / "latest.json").read_text())
    state = json.loads((run / "checkpoints" / latest["folder"] / "state.json").read_text())
    return state["multiplier"]


def test_the_multiplier_is_learned_checkpointed_and_resumed(tmp_path: Path) -> None:
    run = tmp_path / "run"
    train(_config(), run, log=lambda _: None)
    config = json.loads((run / "config.json").read_text())
    assert config["bolt"]["reward"] == "constrained"
    assert config["bolt"]["constraint"] == {
        "cost_limit": 0.02, "lr": 0.1, "kp": 1.0, "kd": 0.0, "initial": 0.0, "anneal": 0.5,
        "decades": 0.0, "wait": 0.5, "start": 0.0, "release": 0.0, "window": 0.0, "rescale": 0.0,
    }  # fmt: skip
    saved = _multiplier(run)
    # 8 games x 64 steps a rollout: 4 rollouts; G(on_edge) is broken by random play at once
    assert saved["updates"] == 4
    # the gridworld's returns differ from the first rollout on (its step costs): no wait
    assert saved["woke_at"] == 0.0
    assert saved["value"] > 0
    train(_config(frames=3072), run, resume=True, log=lambda _: None)
    resumed = _multiplier(run)
    assert resumed["updates"] == 6  # continued from the saved state, not started afresh


@pytest.mark.parametrize(
    ("settings", "message"),
    [
        ({"algo": "dqn", "overrides": {}}, "replay buffer"),
        ({"reward": "paper", "bolt.constraint.cost_limit": 0.1}, "needs --reward constrained"),
        ({"bolt.constraint.cost_limit": -0.1}, "cost_limit must be >= 0"),
        ({"bolt.constraint.cost_limit": float("nan")}, "cost_limit must be finite"),
        ({"bolt.constraint.lr": 0.0}, "learning rate"),
        ({"bolt.constraint.wait": 2.0}, "wait must be in"),
        ({"bolt.constraint.budget": 0.1}, "unknown config key"),
    ],
)
def test_bad_budgets_are_refused_before_anything_is_written(
    tmp_path: Path, settings: dict, message: str
) -> None:
    with pytest.raises(ConfigError, match=message):
        train(_config(**settings), tmp_path / "run", log=lambda _: None)
    assert not (tmp_path / "run").exists()


def test_the_cli_refuses_a_bad_budget_with_exit_2(tmp_path: Path, capsys) -> None:
    out = tmp_path / "run"
    code = main(
        ["train", "--spec", "edge", "--reward", "constrained", "--cost-limit", "-1",
         "--frames", "1024", "--out", str(out)]
    )  # fmt: skip
    assert code == 2
    assert "cost_limit must be >= 0" in capsys.readouterr().err
    assert not out.exists()
    # a budget under the compliance scheme (given, or DQN's default) is refused
    for scheme in (["--reward", "compliance"], ["--algo", "dqn"]):
        code = main(
            ["train", "--spec", "edge", *scheme, "--cost-limit", "0.1", "--frames", "1024",
             "--out", str(out)]
        )  # fmt: skip
        assert code == 2
        assert "needs --reward constrained" in capsys.readouterr().err
