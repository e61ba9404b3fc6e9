"""``reproduce case4``: corner visits measured from ground truth, regional noise vs control."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from noisybolt.cli import main
from noisybolt.errors import ConfigError
from noisybolt.experiments.case4 import CONDITIONS, case4_sweep, measure_corners

TOP_RIGHT, BOTTOM_LEFT = (4, 1), (1, 4)


@pytest.fixture(scope="module")
def case4_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("case4") / "out"
    code = main(
        [
            "reproduce",
            "case4",
            "--seeds",
            "1",
            "--frames",
            "1024",
            "--eval-freq",
            "512",
            "--eval-episodes",
            "4",
            "--episodes",
            "24",
            "--detector",
            "oracle",
            "--out",
            str(out),
        ]
    )
    assert code == 0
    return out


def test_the_sweep_trains_the_exclusive_spec_under_both_cameras() -> None:
    sweep = case4_sweep(seeds=2, frames=60_000)
    assert [t.trial_id for t in sweep.trials] == [
        "regional/seed-0",
        "regional/seed-1",
        "control/seed-0",
        "control/seed-1",
    ]
    for trial in sweep.trials:
        assert trial.config.world_kwargs == {"noise": CONDITIONS[trial.row]}
        assert trial.config.specs[0]["name"] == "one_corner_once"
        assert trial.config.algo == "a2c" and trial.config.eval_freq == 2_000
    assert CONDITIONS == {"regional": "regional", "control": "none"}


def test_case4_reports_corner_shares_per_condition(case4_dir: Path) -> None:
    data = json.loads((case4_dir / "case4.json").read_text())
    assert data["command"].startswith("noisybolt reproduce case4 --seeds 1 --frames 1024")
    assert set(data["pooled"]) == {"regional", "control"}
    for condition, pooled in data["pooled"].items():
        assert pooled["episodes"] == 24 and pooled["seeds"] == [0]
        shares = pooled["shares"]
        categories = ("top_right_only", "bottom_left_only", "both", "neither")
        assert sum(shares[k] for k in categories) == pytest.approx(1.0)
        seed = data["per_seed"][condition]["0"]
        assert sum(seed[k] for k in categories) == seed["episodes"] == 24
    markdown = (case4_dir / "case4.md").read_text()
    assert "| regional (noise `regional`) | 1 | 24 |" in markdown
    assert "| control (noise `none`) | 1 | 24 |" in markdown
    for name in ("case4.png", "heatmap_regional.png", "heatmap_control.png"):
        assert (case4_dir / name).read_bytes()[:4] == b"\x89PNG"


def test_corner_visits_from_fluents_agree_with_the_positions(case4_dir: Path) -> None:
    # Two independent records of each episode: the true corner fluents at every state
    # reached, and the cells the agent stood on (all but a truncated episode's last one).
    visits = measure_corners(case4_dir / "trials" / "regional" / "seed-0", episodes=24)
    assert visits.episodes == len(visits.positions) == 24
    via_cells = {"top_right_only": 0, "bottom_left_only": 0, "both": 0, "neither": 0}
    for path in visits.positions:
        top, bottom = TOP_RIGHT in path, BOTTOM_LEFT in path
        key = (
            "both" if top and bottom else "top_right_only" if top else
            "bottom_left_only" if bottom else "neither"
        )  # fmt: skip
        via_cells[key] += 1
    counted = {k: getattr(visits, k) for k in via_cells}
    # A truncated episode may end on a corner that its positions miss: allow only that.
    truncated = visits.episodes - visits.goal
    assert sum(abs(counted[k] - via_cells[k]) for k in counted) <= 2 * truncated
    if truncated == 0:
        assert counted == via_cells


def test_measuring_needs_episodes(case4_dir: Path) -> None:
    with pytest.raises(ConfigError, match="episodes must be >= 1"):
        measure_corners(case4_dir / "trials" / "control" / "seed-0", episodes=0)


def test_case4_start_heading_reaches_both_conditions_and_east_stays_implicit() -> None:
    south = case4_sweep(seeds=1, frames=6_000, start_heading="south")
    assert {t.config.world_kwargs.get("start_heading") for t in south.trials} == {"south"}
    east = case4_sweep(seeds=1, frames=6_000)
    assert all("start_heading" not in t.config.world_kwargs for t in east.trials)


def test_case4_low_confidence_cost_reaches_the_spec() -> None:
    sweep = case4_sweep(seeds=1, frames=6_000, low_confidence_cost=3.0)
    specs = {json.dumps(t.config.specs, sort_keys=True) for t in sweep.trials}
    assert len(specs) == 1
    (spec,) = sweep.trials[0].config.specs
    assert spec["name"] == "one_corner_once" and spec["low_confidence_cost"] == 3.0


def test_case4_markdown_states_the_cost_and_the_shorter_route(case4_dir: Path) -> None:
    from noisybolt.experiments.case4 import _markdown

    markdown = (case4_dir / "case4.md").read_text()
    assert "(low-confidence cost 0.5)" in markdown
    assert "facing east: the route by the top-right corner is one turn shorter" in markdown
    data = json.loads((case4_dir / "case4.json").read_text())
    data.update(low_confidence_cost=0.0, start_heading="south")
    other = _markdown(data)
    assert "(low-confidence cost 0.0)" in other  # a zero charge is not the default's 0.5
    assert "facing south: the route by the bottom-left corner is one turn shorter" in other
