"""benchmarks/training_throughput.py: its models build from the tuned settings, its timers."""

from __future__ import annotations

from collections.abc import Callable
from types import ModuleType

import pytest


@pytest.fixture(scope="module")
def bench(load_script: Callable[..., ModuleType]) -> ModuleType:
    return load_script("benchmarks/training_throughput.py")


@pytest.mark.parametrize("variant", ["bare", "oracle"])
def test_each_variant_trains_with_the_tuned_hyperparameters(bench: ModuleType, variant) -> None:
    # The tuned file holds world settings (n_envs) beside PPO's arguments: the benchmark
    # must hand PPO only the latter (it once stopped running when n_envs moved).
    model = bench.make_model(variant, seed=0, n_envs=2)
    assert model.n_envs == 2 and model.n_steps == 32
    model.learn(64)
    assert model.num_timesteps >= 64


def test_the_timers_count_cpu_time_while_installed_and_restore_the_functions(
    bench: ModuleType,
) -> None:
    from noisybolt.bolt.restraining_bolt import RestrainingBolt
    from noisybolt.wrappers import bolt_vec_env

    step, info = RestrainingBolt.__dict__["step"], bolt_vec_env.bolt_info
    timers = bench.Timers()
    timers.install()
    try:
        assert RestrainingBolt.__dict__["step"] is not step
        model = bench.make_model("oracle", seed=0, n_envs=2)
        model.learn(64)
    finally:
        timers.uninstall()
    assert RestrainingBolt.__dict__["step"] is step and bolt_vec_env.bolt_info is info
    seconds = timers.seconds
    assert seconds["RestrainingBolt.step"] > 0 and seconds["policy preprocess"] > 0
    # The learner's envs build no per-step records (as `noisybolt train` builds them).
    assert "info records" not in seconds and "truth tracking" not in seconds
    # Nested timers: the bolt's step_wait holds the bolt's step, training holds both.
    assert seconds["BoltVecEnv.step_wait"] > seconds["RestrainingBolt.step"]
    assert seconds["collect_rollouts"] > seconds["BoltVecEnv.step_wait"]
    assert "classifier" not in seconds  # the oracle variant runs no classifier


def test_the_old_bolt_variant_is_the_same_learner_built_the_old_way(bench: ModuleType) -> None:
    # (c0) and (c) must differ only in how they are built (SB3's policy and per-step
    # records against the bolt's policy without them), or their rates compare nothing.
    import torch

    from noisybolt.agents.policies import BoltActorCriticPolicy

    models = []
    for variant in (bench.OLD_BOLT, "classifier"):  # built and trained in turn: torch's
        models.append(bench.make_model(variant, seed=0, n_envs=2))  # global RNG samples
        models[-1].learn(128)
    old, new = models
    assert type(new.policy) is BoltActorCriticPolicy
    assert type(old.policy).__name__ == "MultiInputActorCriticPolicy"
    _, _, _, old_infos = old.get_env().step(torch.zeros(2, dtype=torch.long).numpy())
    _, _, _, new_infos = new.get_env().step(torch.zeros(2, dtype=torch.long).numpy())
    assert "fluent_probs" in old_infos[0] and "fluent_probs" not in new_infos[0]
    trained = old.policy.state_dict(), new.policy.state_dict()
    assert all(torch.equal(trained[0][k], trained[1][k]) for k in trained[0])
