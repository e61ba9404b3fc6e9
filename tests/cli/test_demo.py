"""``noisybolt demo``: the bolt changes where the agent goes, judged from ground truth."""

from __future__ import annotations

import doctest
import json
import re
import warnings
from pathlib import Path

import imageio.v3 as iio
import pytest

import noisybolt.experiments.comparison as comparison_module
from noisybolt.cli import main
from noisybolt.cli.demo import DEMO_ALGO, DEMO_NOISE, DEMO_SPEC
from noisybolt.errors import ConfigError
from noisybolt.experiments.comparison import (
    BoltComparison,
    compare_bolted_unbolted,
    format_comparison,
)

TOP_RIGHT = (4, 1)


@pytest.fixture(scope="module")
def comparison(tmp_path_factory: pytest.TempPathFactory) -> BoltComparison:
    # The demo's spec and learner with fast settings: the oracle detector instead of the
    # classifier (no classifier to train, cheaper steps), the demo's own 40k frames.
    return compare_bolted_unbolted(
        spec=DEMO_SPEC,
        algo=DEMO_ALGO,
        frames=40_000,
        detector="oracle",
        noise=DEMO_NOISE,
        episodes=20,
        seed=0,
        out=tmp_path_factory.mktemp("demo"),
        progress=False,
        log=lambda _: None,
    )


def test_the_bolted_agent_complies_and_the_unbolted_one_does_not(
    comparison: BoltComparison,
) -> None:
    unbolted, bolted = comparison.unbolted.evaluation, comparison.bolted.evaluation
    assert comparison.spec_name == "avoid_top_right"
    assert unbolted.goal_rate >= 0.9 and bolted.goal_rate >= 0.9
    # Ground truth: the true trace's DFA state at the end of each episode.
    assert unbolted.compliance["avoid_top_right"] <= 0.1
    assert bolted.compliance["avoid_top_right"] >= 0.9
    # The unbolted agent takes the 7-step route through the corner, the bolted one the
    # 8-step route around it: the bolt costs the world's return a step.
    assert unbolted.length_mean < bolted.length_mean
    assert unbolted.env_return_mean > bolted.env_return_mean
    assert bolted.bolt_return_mean > unbolted.bolt_return_mean
    through_corner = [TOP_RIGHT in episode for episode in comparison.unbolted.positions]
    assert sum(through_corner) >= 0.9 * len(through_corner)
    assert not any(TOP_RIGHT in episode for episode in comparison.bolted.positions)


def test_the_demo_writes_its_picture_gif_and_numbers(comparison: BoltComparison) -> None:
    picture = iio.imread(comparison.files["picture"])
    assert picture.ndim == 3 and picture.shape[1] > 1.5 * picture.shape[0]  # two rooms
    assert iio.imread(comparison.files["gif"], index=None).shape[0] >= 8  # >= 7 steps + reset
    summary = json.loads(Path(comparison.files["summary"]).read_text())
    assert summary["spec"] == {"name": "avoid_top_right", "formula": "!F(top_right_corner)"}
    assert summary["bolted"]["evaluation"]["compliance"]["avoid_top_right"] >= 0.9
    for agent in (comparison.unbolted, comparison.bolted):
        assert (agent.run_dir / "model.zip").exists()
        assert agent.frames == 40_000


def test_the_table_puts_the_two_agents_side_by_side(comparison: BoltComparison) -> None:
    lines = format_comparison(comparison).splitlines()
    assert lines[0].split() == ["unbolted", "bolted"]
    rows = dict(re.split(r"\s{2,}", line, maxsplit=1) for line in lines[1:])
    rows = {name: cells.split() for name, cells in rows.items()}
    assert rows["complies with avoid_top_right (ground truth)"][0] in ("0%", "5%", "10%")
    assert set(rows) >= {"route length (steps)", "goal rate", "env return R_pi", "bolt return"}


def test_demo_spec_runs_the_comparison_for_another_spec(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "edge"
    args = ["demo", "--spec", "edge", "--detector", "oracle", "--frames", "80"]
    assert main([*args, "--episodes", "1", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "edge = G(on_edge)" in printed
    assert "complies with edge (ground truth)" in printed
    for name in ("comparison.png", "bolted.gif", "comparison.json"):
        assert str(out / name) in printed and (out / name).exists()


def test_demo_names_its_rewards_and_warns_of_a_vacuous_spec_once(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    args = ["demo", "--spec", "G(on_edge | !on_edge)", "--detector", "oracle", "--frames", "80"]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert main([*args, "--episodes", "1", "--out", str(tmp_path / "v")]) == 0
    printed = capsys.readouterr()
    assert "pays the paper's rewards: +1 on each step its spec accepts, -0.5" in printed.out
    said = (printed.out + printed.err).count("holds on every trace")
    said += sum("holds on every trace" in str(w.message) for w in caught)
    assert said == 1  # set up three times (the bolt, each training): said once


def test_bad_input_is_refused_before_anything_is_trained(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "bad"
    args = ["demo", "--detector", "oracle", "--out", str(out)]
    assert main([*args, "--spec", "F(no_such_fluent)"]) == 2
    printed = capsys.readouterr()
    assert "no_such_fluent" in printed.err and "that the gridworld does not have" in printed.err
    assert printed.out == ""  # refused before the demo's introduction
    assert not (out / "unbolted").exists()
    with pytest.raises(ConfigError, match="episodes"):
        compare_bolted_unbolted(spec=DEMO_SPEC, algo=DEMO_ALGO, frames=8, episodes=0, out=out)
    with pytest.raises(ConfigError, match="one spec"):
        compare_bolted_unbolted(spec="left_column_milestones", algo="a2c", frames=8, out=out)
    (out / "unbolted").mkdir(parents=True)
    with pytest.raises(ConfigError, match="already holds a demo"):
        compare_bolted_unbolted(spec=DEMO_SPEC, algo=DEMO_ALGO, frames=8, out=out)


def test_the_walkthrough_still_walks_the_scripted_episode(
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert main(["demo", "--walkthrough"]) == 0
    printed = capsys.readouterr().out
    assert "== One scripted episode through Algorithm 1 ==" in printed
    assert "ground truth: edge: complied, avoid_top_right: complied" in printed
    # --spec walks that spec alone; the training options, which it would ignore, are refused
    assert main(["demo", "--walkthrough", "--spec", "F(top_right_corner)"]) == 0
    printed = capsys.readouterr().out
    assert "== The spec, compiled to a DFA ==" in printed and "[edge]" not in printed
    # the script walks down the west wall, never by the top-right corner
    assert printed.rstrip().endswith("ground truth: F(top_right_corner): violated")
    assert main(["demo", "--walkthrough", "--frames", "2k", "--episodes", "3"]) == 2
    assert "--walkthrough trains nothing, so --frames, --episodes" in capsys.readouterr().err


def test_docstring_examples() -> None:
    result = doctest.testmod(comparison_module, optionflags=doctest.NORMALIZE_WHITESPACE)
    assert result.failed == 0 and result.attempted > 0
