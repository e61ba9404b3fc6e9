"""Reward schemes in a run's config: scales, specs files, bad input refused before writing."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import pytest

from noisybolt.bolt import compliance_scale
from noisybolt.bolt.schemes import COMPLIANCE_MARGIN
from noisybolt.cli import main
from noisybolt.envs import make_world
from noisybolt.envs.bounds import world_return_bounds
from noisybolt.errors import (
    ConfigError,
    UnknownFluentError,
    UnknownNameError,
    UnnormalizedRewardWarning,
    UnsatisfiableSpecError,
)
from noisybolt.runs import DetectorConfig, TrainConfig, train
from noisybolt.runs.environments import build_bolted_env, prepare_bolt
from noisybolt.runs.presentation import warn_of_unnormalized_rewards
from noisybolt.runs.resolution import resolve
from noisybolt.runs.specs import load_specs_file

ORACLE = DetectorConfig(kind="oracle")


def _config(specs: list, **kwargs: object) -> TrainConfig:
    kwargs.setdefault("detector", ORACLE)
    return resolve(
        TrainConfig.create(
            specs=specs,
            frames=64,
            eval_freq=0,
            checkpoint_freq=0,
            eval_episodes=1,
            progress_bar=False,
            n_envs=2,
            **kwargs,
        )
    )


def _lake_module(folder: Path, monkeypatch: pytest.MonkeyPatch, name: str, labels: str = "") -> str:
    """A user's FrozenLake world, ``make`` in module ``name`` under ``folder`` (on the
    path); ``labels``: further ``FluentLabels`` arguments. Returns its factory path."""
    (folder / f"{name}.py").write_text(
        "import gymnasium as gym\n"
        "import noisybolt\n"
        "def make():\n"
        "    lake = gym.make('FrozenLake-v1', render_mode='rgb_array', is_slippery=False)\n"
        "    return noisybolt.FluentLabels(\n"
        f"        lake, fluents={{'at_goal': lambda e: e.s == 15}}, {labels}\n"
        "    )\n"
    )
    monkeypatch.syspath_prepend(str(folder))
    return f"{name}:make"


def test_the_default_scheme_is_constrained_for_ppo_and_a2c_and_compliance_for_dqn() -> None:
    built = {
        algo: TrainConfig.build({"bolt.specs": ["edge"], "algorithm.name": algo}).bolt.reward
        for algo in ("ppo", "a2c", "dqn")
    }
    assert built == {"ppo": "constrained", "a2c": "constrained", "dqn": "compliance"}
    assert TrainConfig.create(specs=["edge"]).bolt.reward == "constrained"
    # a scheme given is kept, whatever the learner
    given = TrainConfig.build({"bolt.specs": ["edge"], "bolt.reward": "compliance"})
    assert given.bolt.reward == "compliance"
    # a budget given without a scheme is the default's (PPO: constrained)
    budget = TrainConfig.build({"bolt.specs": ["edge"], "bolt.constraint.cost_limit": 0.1})
    assert budget.bolt.cost_limit.cost_limit == 0.1
    # a saved run keeps its scheme: the default changes no config that names one
    assert TrainConfig.from_dict(given.to_dict()).bolt.reward == "compliance"


def test_the_compliance_scale_is_exact_on_the_gridworlds_product() -> None:
    from noisybolt.runs.resolution import compliance_scale_choice

    config = _config(["avoid_top_right"], reward="compliance")
    bounds = world_return_bounds(make_world("gridworld"))
    assert bounds is not None and (bounds.low, bounds.high) == (-1.5 * 144, 98.5)
    # The bound from the world's returns caps it; the product gives far less.
    choice = compliance_scale_choice(config)
    assert choice.exact and choice.bound == compliance_scale(bounds)
    assert (
        config.bolt.reward == "compliance"
        and config.bolt.reward_scale == choice.scale < choice.bound
    )
    (spec,) = config.spec_objects()
    assert spec.terminal_reward == config.bolt.reward_scale and spec.reward_timing == "on_change"
    at_end = _config(["avoid_top_right"], reward="compliance", pay_on_change=False)
    assert at_end.spec_objects()[0].reward_timing == "episode_end"
    paper = _config(["avoid_top_right"], reward="paper", pay_on_change=True)
    assert paper.spec_objects()[0].terminal_reward == 1.0
    assert paper.spec_objects()[0].reward_timing == "every_step"
    assert not paper.pay_on_change  # recorded as what the paper scheme does
    # The config holds the resolved scale: reading it back gives the same run.
    assert TrainConfig.from_dict(config.to_dict()) == config


def test_a_learner_paid_clipped_rewards_is_scaled_from_the_clipped_return(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from noisybolt.envs.breakout import MAX_BRICKS, MAX_SCORE
    from noisybolt.errors import EstimatedBoundsWarning

    # Breakout's learner sees each brick's points clipped to 1 (clip_reward, from its
    # hyperparameters): compliance must outweigh 216 clipped points, not 864 points.
    for world in ("breakout", "breakout-ram"):
        config = _config(["left_row5"], world=world)
        assert config.world_config.clip_reward
        assert config.bolt.reward_scale == pytest.approx(COMPLIANCE_MARGIN * MAX_BRICKS)
        unclipped = _config(["left_row5"], world=world, overrides={"clip_reward": False})
        assert unclipped.reward_scale == pytest.approx(COMPLIANCE_MARGIN * MAX_SCORE)
    # A world that declares only its score's bounds: random play, clipped, with a warning.
    world = _lake_module(tmp_path, monkeypatch, "clipped_lake", "return_bounds=(0, 1)")
    lake = {"world": world, "specs": ["F(at_goal)"]}
    assert resolve(TrainConfig.create(**lake)).reward_scale == pytest.approx(1.1)
    with pytest.warns(EstimatedBoundsWarning, match=r"clipped to their sign.*--reward-scale"):
        clipped = resolve(TrainConfig.create(**lake, overrides={"clip_reward": True}))
    assert clipped.reward_scale == pytest.approx(1.65)  # as random play's 0 or 1 above


def test_per_spec_scales_and_the_unbolted_twin() -> None:
    config = _config(
        ["edge", {"formula": "F(top_right_corner)", "reward_scale": 7}], reward_scale=40.0
    )
    assert [s.terminal_reward for s in config.spec_objects()] == [40.0, 7.0]
    unbolted = _config(["edge"], bolted=False)
    assert unbolted.progress_gamma is None
    assert unbolted.spec_objects()[0].terminal_reward == 0.0


@pytest.mark.parametrize(
    "kwargs",
    [
        {"reward": "bonus"},
        {"reward_scale": -3.0},
        {"reward_scale": float("nan")},
        {"reward": "paper", "reward_scale": 10.0},
    ],
)
def test_bad_scheme_settings_are_refused(kwargs: dict) -> None:
    with pytest.raises((ConfigError, UnknownNameError)):
        _config(["edge"], **kwargs)


def test_paper_only_spec_settings_are_refused_under_compliance() -> None:
    with pytest.raises(ConfigError, match="reward_scale instead"):
        _config([{"formula": "F(top_right_corner)", "terminal_reward": 5}])
    assert _config([{"formula": "F(top_right_corner)", "terminal_reward": 5}], reward="paper")


def test_the_bolted_env_pays_the_scheme_and_plain_algorithm_1_under_paper() -> None:
    # !F(top_right_corner) with the oracle: 3 steps east reach the corner, a violation.
    # Compliance: accepting from the reset frame (the baseline: nothing paid), then the
    # violation takes the 50 back and charges 50.
    for reward, expected in (
        ("compliance", [0.0, 0.0, -100.0]),
        ("paper", [1.0 + 1.0, 1.0, 0.0]),
    ):
        config = _config(
            ["avoid_top_right"],
            reward=reward,
            **({"reward_scale": 50.0} if reward == "compliance" else {}),
        )
        setup = prepare_bolt(config, seed=0, log=lambda _: None)
        env = build_bolted_env(
            config, setup.detector, n_envs=1, seed=0, dfas=setup.dfas, letters=setup.letters
        )
        env.reset()
        bolt = []
        for _ in range(3):
            _, _, _, infos = env.step(np.array([2]))  # forward
            bolt.append(infos[0]["bolt_reward"])
        assert bolt == expected, reward


def test_unsatisfiable_and_foreign_specs_are_refused_before_anything_is_written(
    tmp_path: Path,
) -> None:
    run = tmp_path / "run"
    with pytest.raises(UnsatisfiableSpecError):
        train(_config(["F(top_right_corner) & G(!top_right_corner)"]), run, log=lambda _: None)
    with pytest.raises(UnknownFluentError):
        train(_config(["F(lava)"]), run, log=lambda _: None)
    assert not run.exists()
    warnings: list[str] = []
    prepare_bolt(_config(["top_right_corner | !top_right_corner"]), seed=0, log=warnings.append)
    assert any("holds on every trace" in w for w in warnings)


def test_specs_file(tmp_path: Path) -> None:
    good = tmp_path / "specs.yaml"
    good.write_text(
        "specs:\n  - edge\n  - formula: F(top_right_corner)\n    name: tr\n    reward_scale: 9\n"
    )
    specs = load_specs_file(good)
    assert specs == ["edge", {"formula": "F(top_right_corner)", "name": "tr", "reward_scale": 9}]
    assert [s.terminal_reward for s in _config(specs, reward_scale=20.0).spec_objects()] == [20, 9]
    for text, message in (
        ("- formula: F(a)\n  colour: red\n", "unknown key"),
        ("- reward_scale: 3\n", "give a formula"),
        ("specs: 3\n", "non-empty list"),
        ("[unclosed\n", "not valid YAML"),
    ):
        bad = tmp_path / "bad.yaml"
        bad.write_text(text)
        with pytest.raises(ConfigError, match=message):
            load_specs_file(bad)
    with pytest.raises(ConfigError, match="cannot read"):
        load_specs_file(tmp_path / "missing.yaml")


def test_a_run_saved_before_reward_schemes_resumes_as_the_paper_scheme(tmp_path: Path) -> None:
    config = _config(["edge"], reward="paper")
    run = tmp_path / "old"
    train(config, run, log=lambda _: None)
    saved = json.loads((run / "config.json").read_text())
    for key in ("reward", "reward_scale", "shaping"):
        saved["bolt"].pop(key)
    (run / "config.json").write_text(json.dumps(saved))
    assert TrainConfig.from_dict(saved).reward == "paper"
    bigger = TrainConfig.from_dict({**config.to_dict(), "frames": 128})
    train(bigger, run, resume=True, log=lambda _: None)  # no "config differs"
    changed = {"bolt.reward": "compliance", "bolt.reward_scale": 5.0, "frames": 256}
    with pytest.raises(ConfigError, match="reward"):
        train(config.override(changed), run, resume=True, log=lambda _: None)


def test_cli_reward_flags_and_spec_set(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    out = tmp_path / "cli"
    code = main(
        [
            "train",
            "--spec",
            "F(top_right_corner)",
            "--spec-set",
            "reward_scale=12",
            "--spec",
            "edge",
            "--detector",
            "oracle",
            "--frames",
            "64",
            "--eval-freq",
            "0",
            "--checkpoint-freq",
            "0",
            "--eval-episodes",
            "1",
            "--n-envs",
            "2",
            "--no-progress",
            "--out",
            str(out),
        ]
    )
    assert code == 0
    printed = capsys.readouterr().out
    assert "compliance scale computed on the gridworld's product" in printed
    saved = json.loads((out / "config.json").read_text())
    assert saved["bolt"]["reward"] == "constrained"  # PPO's default scheme
    assert saved["bolt"]["specs"][0]["reward_scale"] == 12
    assert main(["train", "--spec", "edge", "--reward", "bonus", "--out", str(tmp_path / "x")]) == 2
    assert (
        main(["train", "--spec", "edge", "--reward-scale", "-1", "--out", str(tmp_path / "y")]) == 2
    )
    assert not (tmp_path / "x").exists() and not (tmp_path / "y").exists()
    with pytest.raises(SystemExit):
        main(["train", "--spec-set", "reward_scale=3", "--spec", "edge"])


def test_check_command(capsys: pytest.CaptureFixture) -> None:
    assert main(["check", "--spec", "F(top_right_corner) & F(bottom_left_corner)"]) == 0
    out = capsys.readouterr().out
    assert "R^c_max 76 in 16 steps" in out and "complies and reaches the goal" in out
    assert main(["check", "--spec", "F(top_right_corner & bottom_left_corner)"]) == 1
    assert main(["check", "--spec", "F(top_right_corner) & G(!top_right_corner)"]) == 2
    # Another detector is built and matched to the world (a classifier is not trained here).
    assert main(["check", "--spec", "edge", "--detector", "synthetic"]) == 0
    assert "detector synthetic: built, matched to the world's fluents" in capsys.readouterr().out
    assert main(["check", "--spec", "edge", "--detector", "classifier"]) == 2
    assert "check builds no classifier" in capsys.readouterr().err


def test_check_on_worlds_with_and_without_return_bounds(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture
) -> None:
    _lake_module(tmp_path, monkeypatch, "unbounded_lake")
    assert main(["check", "--world", "unbounded_lake:make", "--spec", "F(at_goal)"]) == 0
    out = capsys.readouterr().out
    assert "declares no bounds" in out and "satisfiable" in out and "no route check" in out
    # FrozenLake without declared bounds: random play returns 0 or 1 (the goal is reached
    # in some of ~500 random episodes), raised by half that width: 1.1 x 1.5.
    assert "estimated from" in out and "compliance scale: 1.65" in out
    argv = ["check", "--world", "unbounded_lake:make", "--spec", "F(at_goal)"]
    assert main([*argv, "--reward-scale", "2"]) == 0
    assert "compliance scale: 2" in capsys.readouterr().out
    # The example declares FrozenLake's bounds (an episode returns 0 or 1): 1.1 x 1.
    assert main(["check", "--world", "examples.frozenlake:make_lake", "--spec", "F(at_goal)"]) == 0
    assert "compliance scale: 1.1" in capsys.readouterr().out


def test_fluent_labels_declare_return_bounds() -> None:
    import gymnasium as gym

    import noisybolt
    from noisybolt.bolt import ReturnBounds

    def lake(**kwargs: object) -> noisybolt.FluentLabels:
        env = gym.make("FrozenLake-v1", render_mode="rgb_array", is_slippery=False)
        return noisybolt.FluentLabels(env, fluents={"g": lambda e: e.s == 15}, **kwargs)

    assert world_return_bounds(make_world("examples.frozenlake:make_lake")) == ReturnBounds(0, 1)
    assert lake().episode_return_bounds is None
    assert lake(return_bounds=(-2, 3)).episode_return_bounds == ReturnBounds(-2.0, 3.0)
    for bad in ((1, 0), (0,), (0, float("inf")), "0-1"):
        with pytest.raises(ConfigError):
            lake(return_bounds=bad)


def test_a_world_without_bounds_trains_on_an_estimated_scale_with_a_warning(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from noisybolt.errors import EstimatedBoundsWarning
    from noisybolt.runs import DetectorConfig, TrainConfig

    _lake_module(tmp_path, monkeypatch, "bare_lake")
    common = {"world": "bare_lake:make", "specs": ["F(at_goal)"]}
    with pytest.warns(EstimatedBoundsWarning, match=r"declare the bounds.*--reward-scale"):
        config = resolve(TrainConfig.create(**common, detector=DetectorConfig(kind="oracle")))
    assert config.bolt.reward == "constrained" and config.bolt.reward_scale == pytest.approx(1.65)
    # An estimated scale is kept above the returns training sees; a given one is not.
    assert config.bolt.constraint["rescale"] == pytest.approx(1.1)
    # The estimate is seeded: the same scale again; a given scale is taken as it is.
    with pytest.warns(EstimatedBoundsWarning):
        again = resolve(TrainConfig.create(**common, detector=DetectorConfig(kind="oracle")))
    assert again.bolt.reward_scale == config.bolt.reward_scale
    given = resolve(
        TrainConfig.create(**common, reward_scale=3.0, detector=DetectorConfig(kind="oracle"))
    )
    assert given.reward_scale == 3.0
    assert given.bolt.cost_limit.rescale is None  # a multiplier given None: not raised


def test_check_says_what_a_spec_with_its_own_scale_is_paid(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    import re

    specs = tmp_path / "specs.yaml"
    specs.write_text("- edge\n- formula: F(top_right_corner)\n  name: tr\n  reward_scale: 50\n")
    assert main(["check", "--specs-file", str(specs)]) == 0
    out = capsys.readouterr().out
    scale = re.search(r"compliance scheme: scale (\S+) ", out)
    assert scale is not None
    assert f"note: training pays edge {scale[1]}, tr 50 " in out
    assert main(["check", "--spec", "edge"]) == 0  # one scale for every spec: no note
    assert "note: training pays" not in capsys.readouterr().out


@pytest.mark.parametrize(
    ("settings", "warned"),
    [
        ({"algo": "ppo", "hp": {"normalize_reward": False}}, True),
        ({"algo": "a2c", "hp": {"normalize_reward": False}}, True),
        ({"algo": "ppo", "hp": {"normalize_reward": True}}, False),
        ({"algo": "ppo", "hp": {"normalize_reward": False}, "reward_scale": 10.0}, False),
        ({"algo": "ppo", "hp": {"normalize_reward": False}, "reward": "paper"}, False),
        ({"algo": "ppo", "hp": {"normalize_reward": False}, "bolted": False}, False),
        ({"algo": "dqn", "hp": {"normalize_reward": False}}, False),
    ],
)
def test_a_learner_paid_large_unnormalised_rewards_is_warned(settings: dict, warned: bool) -> None:
    settings = dict(settings)
    overrides = settings.pop("hp")
    config = _config(["avoid_top_right"], overrides=overrides, **settings)
    assert config.algorithm.hyperparams["normalize_reward"] is overrides["normalize_reward"]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        warn_of_unnormalized_rewards(config)
    hits = [w for w in caught if issubclass(w.category, UnnormalizedRewardWarning)]
    assert len(hits) == warned
    if warned:
        assert "--hp normalize_reward=true" in str(hits[0].message)


def test_a_users_world_normalises_every_learners_rewards_by_default() -> None:
    from noisybolt.agents.hyperparams import load_hyperparams

    for algo in ("ppo", "a2c", "dqn"):
        params = load_hyperparams("examples.frozenlake:make_lake", algo, {})
        assert params["normalize_reward"] is True


def _constrained(specs: list, constraint: dict, world: str | None = None) -> TrainConfig:
    """A constrained run's config with ``constraint`` given, resolved."""
    settings: dict = {"bolt.specs": specs, "bolt.reward": "constrained"}
    if world is not None:
        settings["world.name"] = world
    return resolve(TrainConfig.build({**settings, "bolt.constraint": constraint}))


def test_the_constrained_price_is_linear_unless_a_span_is_given(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from noisybolt.bolt.constraint import LagrangeMultiplier

    # The gridworld's scale is exact on the product: the price is linear.
    exact = _config(["edge"], reward="constrained")
    assert exact.bolt.constraint["decades"] == 0.0
    assert exact.bolt.cost_limit.price(0.5) == 0.5
    # A world's declared bounds with a spec kept by doing nothing (G(!at_goal) accepts
    # the empty trace): the price is searched, and linear too.
    world = _lake_module(tmp_path, monkeypatch, "bounded_lake", "return_bounds=(0, 1)")
    bound = resolve(
        TrainConfig.create(world=world, specs=["F(at_goal)", "G(!at_goal)"], reward="constrained")
    )
    assert bound.bolt.constraint["decades"] == 0.0
    assert bound.bolt.constraint["kp"] == 0.0
    # A span given is kept, and priced over its decades; saved and read back, it stays.
    given = _constrained(["F(at_goal)"], {"decades": 3.0}, world)
    assert given.bolt.constraint["decades"] == 3.0
    assert given.bolt.cost_limit.price(0.5) == pytest.approx((10**1.5 - 1) / (10**3 - 1))
    assert TrainConfig.from_dict(given.to_dict()).bolt.constraint["decades"] == 3.0
    # 0 given (the linear price, no wait) is kept too, not read as "not given".
    linear = _constrained(["F(at_goal)"], {"decades": 0, "wait": 0}, world)
    assert linear.bolt.constraint["decades"] == 0.0 and linear.bolt.constraint["wait"] == 0.0
    assert linear.bolt.cost_limit.price(0.5) == 0.5
    assert not LagrangeMultiplier(linear.bolt.cost_limit).waiting
    # A scale given: nothing resolved, the price linear as a multiplier given None.
    scaled = resolve(
        TrainConfig.create(world=world, specs=["F(at_goal)"], reward="constrained", reward_scale=5)
    )
    assert "decades" not in scaled.bolt.constraint
    assert scaled.bolt.cost_limit.price(0.5) == 0.5


def test_on_an_exact_scale_the_budget_is_annealed_only_where_a_spec_is_kept_by_doing_nothing() -> (
    None
):
    from noisybolt.bolt.constraint import LagrangeMultiplier
    from noisybolt.bolt.constraint_choices import ANNEAL

    # G(!top_right_corner) accepts the empty trace: early breaks priced before the task
    # is found could teach standing still, so the budget falls over half the run ...
    safety = _config(["G(!top_right_corner)"], reward="constrained")
    assert safety.bolt.constraint["anneal"] == ANNEAL == 0.5
    assert safety.bolt.cost_limit.budget(0.25, first_cost=1.0) == pytest.approx(0.02 + 0.98 * 0.5)
    # ... and with an F spec beside it, still (standing still keeps the G spec).
    mixed = _config(["G(!top_right_corner)", "F(bottom_left_corner)"], reward="constrained")
    assert mixed.bolt.constraint["anneal"] == ANNEAL
    # Where every spec asks for something, the budget is the limit from the first rollout:
    # a cost of 1 is priced in full at once (kp = 1), before the direct route settles.
    detour = _config(["F(top_right_corner) & F(bottom_left_corner)"], reward="constrained")
    assert detour.bolt.constraint["anneal"] == 0.0
    assert detour.bolt.cost_limit.budget(0.0, first_cost=1.0) == 0.02
    lagrange = LagrangeMultiplier(detour.bolt.cost_limit)
    lagrange.update(1.0, progress=0.0)  # the first cost measured
    assert lagrange.update(1.0, progress=0.05) == 1.0
    # Saved and read back, it stays; one given is kept, 0.5 on a detour included.
    assert TrainConfig.from_dict(detour.to_dict()).bolt.constraint["anneal"] == 0.0
    given = _constrained(["F(top_right_corner)"], {"anneal": 0.5})
    assert given.bolt.constraint["anneal"] == 0.5
    # A run saved before the choice existed names its anneal (the section filled in the
    # default then), and a resolved config is resolved again unchanged.
    assert resolve(detour) is detour


def test_the_price_starts_in_full_only_on_an_exact_scale_where_no_spec_is_kept_by_doing_nothing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from noisybolt.bolt.constraint import LagrangeMultiplier

    # A scale from the world's return bounds is a worst case: asked in full at once it
    # would drown the world's reward, so the integral goes on from `initial` there.
    world = _lake_module(tmp_path, monkeypatch, "bounded_lake_start", "return_bounds=(0, 1)")
    bound = resolve(TrainConfig.create(world=world, specs=["F(at_goal)"], reward="constrained"))
    assert bound.bolt.constraint["start"] == 0.0
    # ... and its budget is annealed, whatever the specs ask.
    assert bound.bolt.constraint["anneal"] == 0.5
    # The gridworld's scale is exact; every spec asks for something: the integral starts
    # at 1 from the first cost.
    detour = _config(["F(top_right_corner) & F(bottom_left_corner)"], reward="constrained")
    assert detour.bolt.constraint["start"] == 1.0
    lagrange = LagrangeMultiplier(detour.bolt.cost_limit)
    assert lagrange.value == 0.0
    assert lagrange.update(0.5, frames=256, progress=0.0) == 1.0
    # A spec that standing still keeps: from `initial` (0), priced as the cost demands.
    safety = _config(["G(!top_right_corner)"], reward="constrained")
    assert safety.bolt.constraint["start"] == 0.0
    assert LagrangeMultiplier(safety.bolt.cost_limit).update(0.5, frames=256) < 0.5
    # One given is kept; a saved run without the key goes on from `initial`, as it did.
    given = _constrained(["F(top_right_corner)"], {"start": 0.3})
    assert given.bolt.constraint["start"] == 0.3
    saved = detour.to_dict()
    del saved["bolt"]["constraint"]["start"]
    assert "start" not in TrainConfig.from_dict(saved).bolt.constraint
    assert TrainConfig.from_dict(saved).bolt.cost_limit.start is None


def test_the_price_is_searched_only_where_it_could_teach_standing_still(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    searched = {"kp": 0.0, "lr": 0.02, "release": 1.0, "window": 1000.0}
    asserted = {"kp": 1.0, "lr": 0.1, "release": 0.0, "window": 0.0}
    world = _lake_module(tmp_path, monkeypatch, "bounded_lake_search", "return_bounds=(0, 1)")
    bound = resolve(TrainConfig.create(world=world, specs=["G(!at_goal)"], reward="constrained"))
    assert {k: bound.bolt.constraint[k] for k in searched} == searched
    # A spec that asks for something: standing still breaks it too; asserted, its costs
    # pooled over the window as on every scale from bounds.
    detour = resolve(TrainConfig.create(world=world, specs=["F(at_goal)"], reward="constrained"))
    assert {k: detour.bolt.constraint[k] for k in asserted} == {**asserted, "window": 1000.0}
    # The exact scale (the gridworld): asserted, learning every rollout.
    exact = _config(["G(!top_right_corner)"], reward="constrained")
    assert {k: exact.bolt.constraint[k] for k in asserted} == asserted
    # One given is kept.
    given = _constrained(["F(top_right_corner)"], {"kp": 0.5, "window": 300})
    assert (given.bolt.constraint["kp"], given.bolt.constraint["window"]) == (0.5, 300.0)
    # A run saved before the choice names its gains (the section filled in the defaults
    # then) and has no release or window: it learns every rollout, unreleased, as it did.
    saved = exact.to_dict()
    for key in ("release", "window"):
        del saved["bolt"]["constraint"][key]
    limit = TrainConfig.from_dict(saved).bolt.cost_limit
    assert (limit.kp, limit.lr, limit.release, limit.window) == (1.0, 0.1, None, None)
