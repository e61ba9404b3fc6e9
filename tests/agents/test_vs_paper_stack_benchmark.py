"""benchmarks/vs_paper_stack.py: its install hint, its model of rl-starter-files, its clock."""

from __future__ import annotations

import importlib.util
import time
from collections.abc import Callable
from types import ModuleType

import numpy as np
import pytest
import torch


@pytest.fixture(scope="module")
def bench(load_script: Callable[..., ModuleType]) -> ModuleType:
    return load_script("benchmarks/vs_paper_stack.py")


def test_without_torch_ac_it_says_how_to_install_it(
    bench: ModuleType, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    real = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util, "find_spec", lambda name, *a: None if name == "torch_ac" else real(name)
    )
    assert bench.main(["--rounds", "1"]) == 2
    err = capsys.readouterr().err
    assert "pip install 'noisybolt[bench]'" in err and "torch-ac==1.4.0" in err


def test_the_starter_model_reads_the_7x7_view_into_64_features(bench: ModuleType) -> None:
    from noisybolt.envs.gridworld import GridworldEnv

    env = GridworldEnv(obs_mode="view", bolt_labels=False)
    obs, _ = env.reset(seed=0)
    assert obs.shape == (7, 7, 3)
    model = bench.StarterACModel(obs.shape, int(env.action_space.n))
    assert model.actor[0].in_features == 64  # ((7-1)//2-2)^2 * 64, as rl-starter-files
    # rl-starter-files' initialisation: every dense layer's rows have unit norm.
    for layer in (model.actor[0], model.actor[2], model.critic[0], model.critic[2]):
        torch.testing.assert_close(layer.weight.norm(dim=1), torch.ones(layer.out_features))
        assert not layer.bias.any()

    class Obs:
        image = torch.tensor(np.stack([obs, obs]), dtype=torch.float)

    dist, value = model(Obs())
    assert dist.probs.shape == (2, env.action_space.n) and value.shape == (2,)


def test_the_stopwatch_leaves_out_the_time_it_is_stopped(bench: ModuleType) -> None:
    clock = bench.Stopwatch()
    clock.start()
    time.sleep(0.02)
    clock.stop()
    time.sleep(0.05)  # an evaluation: not counted
    clock.start()
    time.sleep(0.02)
    clock.stop()
    assert 0.04 <= clock.total < 0.09


@pytest.mark.parametrize("n_envs", [None, 2])
def test_noisybolt_learns_with_the_tuned_hyperparameters_on_any_env_count(
    bench: ModuleType, n_envs
) -> None:
    # The tuned file holds world settings (n_envs) beside PPO's arguments; a budget below
    # the first evaluation: one update, never solved.
    outcome = bench.run_noisybolt(False, seed=0, budget=64, n_envs=n_envs)
    assert outcome.frames >= 64 and outcome.solved_frames is None
    assert outcome.seconds > 0 and outcome.cpu_seconds > 0
