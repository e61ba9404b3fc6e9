"""The constrained scheme in training: episode costs, the multiplier's callback, resume,
bad input refused before anything is written."""

from __future__ import annotations

import json
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from stable_baselines3 import PPO

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


def test_the_callback_hands_the_multiplier_each_episode_s_world_return() -> None:
    """What the wait reads: each ended episode's world return, the bolt's payments left out,
    as the Monitor below the bolt measured it."""
    from stable_baselines3.common.monitor import Monitor

    seen: list[float] = []

    class Recording(LagrangianCallback):
        def _on_rollout_end(self) -> None:
            seen.extend(self._returns)
            super()._on_rollout_end()

    monitored: list[Monitor] = []

    def lake_monitored() -> FluentLabels:
        env = Monitor(gym.make("FrozenLake-v1", is_slippery=False, render_mode="rgb_array"))
        monitored.append(env)
        return FluentLabels(
            env,
            fluents={"at_goal": lambda e: e.s == 15, "right_col": lambda e: e.s % 4 == 3},
            camera=lambda e: np.zeros((4, 4, 3), dtype=np.uint8),
        )

    env = make_bolted_vec_env(lake_monitored, 2, ["G(!right_col)"], "oracle", seed=3)
    model = PPO("MultiInputPolicy", env, n_steps=256, batch_size=64, seed=0, device="cpu")
    callback = Recording(CostLimit(cost_limit=0.0, kp=1.0, anneal=0.0, wait=1.0), frames=1024)
    model.learn(total_timesteps=1024, callback=callback)
    truth = sorted(r for m in monitored for r in m.get_episode_rewards())
    assert len(seen) > 10 and sorted(seen) == truth
    assert callback.multiplier.updates == 2  # 1,024 frames: two rollouts of 2 x 256
    env.close()


def test_the_callback_pools_the_episodes_of_a_window_into_one_measured_cost() -> None:
    """A 128-frame rollout, a 300-frame window: the multiplier learns every third rollout,
    from the mean cost of every episode ended over those 384 frames."""
    ended: list[tuple[int, float]] = []  # (frames trained at the step, the episode's cost)
    measured: list[tuple[int, float, int]] = []  # (frames trained, cost, frames pooled)

    class Recording(LagrangianCallback):
        def _on_step(self) -> bool:
            for info in self.locals["infos"]:
                if info.get(EPISODE_COST_KEY) is not None:
                    ended.append((int(self.model.num_timesteps), info[EPISODE_COST_KEY]))
            return super()._on_step()

    env = make_bolted_vec_env(_lake, 4, ["G(!right_col)"], "oracle", seed=0)
    model = PPO("MultiInputPolicy", env, n_steps=32, batch_size=64, seed=0, device="cpu")
    callback = Recording(CostLimit(cost_limit=0.0, anneal=0.0, window=300), frames=768)
    update = callback.multiplier.update

    def recorded(cost: float, *, frames: int, **kwargs: object) -> float:
        measured.append((int(model.num_timesteps), cost, frames))
        return update(cost, frames=frames, **kwargs)  # type: ignore[arg-type]

    callback.multiplier.update = recorded  # type: ignore[method-assign]
    model.learn(total_timesteps=768, callback=callback)
    assert [(at, pooled) for at, _, pooled in measured] == [(384, 384), (768, 384)]
    for (at, cost, _), since in zip(measured, (0, 384), strict=True):
        window = [c for t, c in ended if since < t <= at]
        assert len(window) > 3 and cost == pytest.approx(np.mean(window))
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
        "decades": 0.0, "wait": 0.5, "start": 0.0, "release": 0.0, "window": 0.0,
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
