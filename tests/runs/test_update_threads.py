"""What a run sets in torch for the length of its training, and gives back.

With the world in worker processes an on-policy update gets the idle cores' threads
(:class:`~noisybolt.runs.callbacks.UpdateThreads`) and the rollouts one thread; torch's
distribution checks are off inside ``learn()`` and back as they were after it.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
import torch
from stable_baselines3 import PPO
from stable_baselines3.common.policies import ActorCriticPolicy

from noisybolt.errors import ConfigError
from noisybolt.runs import TrainConfig, train
from noisybolt.runs.callbacks import UpdateThreads


def _config(*, workers: int, algo: str = "ppo") -> TrainConfig:
    return TrainConfig.build(
        {
            "world.name": "breakout-ram",
            "world.workers": workers,
            "world.n_envs": 2,
            "bolt.specs": ["left_column_milestones"],
            "bolt.reward": "paper",
            "detector.kind": "oracle",
            "algorithm.name": algo,
            "algorithm.hyperparams.n_steps": 32,
            "algorithm.hyperparams.batch_size": 32,
            "algorithm.hyperparams.n_epochs": 1,
            "frames": 128,
            "evaluation.freq": 128,
            "evaluation.episodes": 1,
            "evaluation.envs": 1,
            "world.kwargs": {"max_episode_frames": 200},
            "progress_bar": False,
            "seed": 0,
        }
    )


def _record_threads(monkeypatch: pytest.MonkeyPatch) -> dict[str, list[Any]]:
    """Patches PPO's update and its policy's rollout steps (``forward``; the update calls
    ``evaluate_actions``) to note torch's threads and distribution checks."""
    seen: dict[str, list[Any]] = {"update": [], "rollout": [], "validate": []}
    update, forward = PPO.train, ActorCriticPolicy.forward

    def train_(self: Any) -> None:
        seen["update"].append(torch.get_num_threads())
        update(self)

    def forward_(self: Any, *args: Any, **kwargs: Any) -> Any:
        seen["rollout"].append(torch.get_num_threads())
        seen["validate"].append(torch.distributions.Distribution._validate_args)
        return forward(self, *args, **kwargs)

    monkeypatch.setattr(PPO, "train", train_)
    monkeypatch.setattr(ActorCriticPolicy, "forward", forward_)
    return seen


def test_with_workers_the_update_gets_the_cores_and_the_rollouts_one(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(UpdateThreads, "for_this_machine", staticmethod(lambda: UpdateThreads(3)))
    seen = _record_threads(monkeypatch)
    before = torch.distributions.Distribution._validate_args
    train(_config(workers=1), tmp_path / "run", log=lambda _: None)
    assert seen["update"] == [3, 3]  # 128 frames: two rollouts of 2 games x 32 steps
    assert set(seen["rollout"]) == {1} and len(seen["rollout"]) >= 64
    assert set(seen["validate"]) == {False}
    assert torch.get_num_threads() == 1
    assert torch.distributions.Distribution._validate_args is before


def test_without_workers_the_update_keeps_one_thread(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # The world shares the process: a second thread would fight the emulator.
    seen = _record_threads(monkeypatch)
    train(_config(workers=0), tmp_path / "run", log=lambda _: None)
    assert seen["update"] == [1, 1]
    assert set(seen["validate"]) == {False}


def test_distribution_checks_come_back_after_a_failed_run(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    def fail(self: Any, *args: Any, **kwargs: Any) -> bool:
        raise RuntimeError("the world broke")

    monkeypatch.setattr(PPO, "collect_rollouts", fail)
    torch.distributions.Distribution.set_default_validate_args(True)
    with pytest.raises(RuntimeError, match="the world broke"):
        train(_config(workers=0), tmp_path / "run", log=lambda _: None)
    assert torch.distributions.Distribution._validate_args is True


def test_the_callback_sets_and_takes_back_threads() -> None:
    callback = UpdateThreads(2)
    callback._on_rollout_end()
    assert torch.get_num_threads() == 2
    callback._on_rollout_start()
    assert torch.get_num_threads() == 1
    callback._on_rollout_end()
    callback._on_training_end()
    assert torch.get_num_threads() == 1
    assert 1 <= UpdateThreads.for_this_machine().threads <= 4
    with pytest.raises(ConfigError, match=">= 1"):
        UpdateThreads(0)
