"""``reproduce table1``: the rows and their budgets, a small reproduction, the decision rules."""

from __future__ import annotations

import csv
import doctest
import json
from pathlib import Path

import pytest

from noisybolt.cli import main
from noisybolt.errors import ConfigError, UnknownNameError
from noisybolt.experiments import table1 as table1_module
from noisybolt.experiments.reporting import Stat
from noisybolt.experiments.sweeps import SweepResult, TrialRecord
from noisybolt.experiments.table1 import (
    TABLE1_ROWS,
    build_table1,
    select_rows,
    table1_sweep,
)


def _small_table_argv(out: Path) -> list[str]:
    """Two rows, one seed, 1k frames, oracle detector, into ``out``."""
    return [
        "reproduce",
        "table1",
        "--rows",
        "edge-ppo,avoid_top_right-a2c",
        "--seeds",
        "1",
        "--frames",
        "1024",
        "--detector",
        "oracle",
        "--eval-freq",
        "512",
        "--eval-episodes",
        "4",
        "--final-episodes",
        "8",
        "--out",
        str(out),
    ]


@pytest.fixture(scope="module")
def small_table(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Two rows, one seed, 1k frames, oracle detector: the pipeline end to end via the CLI."""
    out = tmp_path_factory.mktemp("table1") / "out"
    code = main(_small_table_argv(out))
    assert code == 0
    return out


def test_the_paper_rows_in_its_order_with_its_numbers() -> None:
    assert [(r.spec, r.algo) for r in TABLE1_ROWS] == [
        ("edge", "ppo"),
        ("edge", "a2c"),
        ("edge", "dqn"),
        ("avoid_top_right", "a2c"),
        ("avoid_top_right", "dqn"),
        ("top_right_once", "ppo"),
        ("top_right_once", "a2c"),
        ("one_corner_once", "a2c"),
    ]
    paper = {r.name: r.paper for r in TABLE1_ROWS}
    assert (paper["edge-ppo"].rc_max, paper["edge-ppo"].r_pi, paper["edge-ppo"].n_frames) == (
        94,
        79.48,
        25_000,
    )
    assert paper["edge-dqn"].rc_max == 92  # as printed, unlike the other G(e) rows
    assert paper["top_right_once-a2c"].n_steps == 104.2
    assert all(p.followed for p in paper.values())


def test_default_budget_is_twice_the_papers_frames_with_a_30k_floor_and_the_exploration() -> None:
    frames = {r.name: r.frames() for r in TABLE1_ROWS}
    assert frames == {
        "edge-ppo": 50_000,
        "edge-a2c": 160_000,
        "edge-dqn": 30_000,
        "avoid_top_right-a2c": 100_000,
        "avoid_top_right-dqn": 30_000,
        "top_right_once-ppo": 266_000,
        "top_right_once-a2c": 330_000,
        # twice the paper's 20k ends before A2C's entropy bonus (50k): 1.2 x 50k
        "one_corner_once-a2c": 60_000,
    }
    every = {r.name: r.eval_freq() for r in TABLE1_ROWS}
    assert every["edge-dqn"] == 1_000 and every["edge-a2c"] == 8_000
    assert every["edge-ppo"] == 2_000 and every["top_right_once-a2c"] == 10_000
    half = {r.name: r.frames(0.5) for r in TABLE1_ROWS}
    assert half["edge-ppo"] == 25_000


def test_the_default_sweep_is_eight_rows_by_three_seeds_with_the_noisy_classifier() -> None:
    sweep = table1_sweep()
    assert len(sweep.trials) == 24 and sweep.seeds == (0, 1, 2)
    assert sweep.final_eval_episodes == 100
    for trial in sweep.trials:
        assert trial.config.detector.kind == "classifier"
        assert trial.config.world_config.kwargs == {"noise": "regional"}
        row = next(r for r in TABLE1_ROWS if r.name == trial.row)
        assert trial.config.algorithm.name == row.algo and trial.config.frames == row.frames()
        assert trial.config.bolt.specs[0]["name"] == row.spec
        # Each seed keeps its best shaped-return model; DQN is evaluated greedily.
        assert trial.config.evaluation.keep_best
        # Algorithm 1 as the paper pays it: +1 every accepting step, 0.5 per low reading.
        assert trial.config.bolt.reward == "paper" and trial.config.progress_gamma is None
        (spec,) = trial.config.spec_objects()
        assert (spec.terminal_reward, spec.reward_timing) == (1.0, "every_step")
        assert trial.config.evaluation.deterministic == (row.algo == "dqn")


def test_n_frames_does_not_depend_on_the_budget() -> None:
    # Stop when solved, and every schedule that decides when a policy first acts surely
    # fixed in frames: the same for any budget (frames_scale 1 or 3).
    for scale in (1.0, 3.0):
        for trial in table1_sweep(frames_scale=scale).trials:
            config = trial.config
            assert config.evaluation.stop_after == 3 and config.evaluation.success_threshold == 0.95
            if config.algorithm.name == "a2c":
                assert config.algorithm.hyperparams["ent_coef_frames"] == 50_000
            if config.algorithm.name == "dqn":
                assert config.algorithm.hyperparams["exploration_frames"] == 3_000
                assert "exploration_fraction" not in config.algorithm.hyperparams
    assert {t.config.evaluation.stop_after for t in table1_sweep(stop_after=0).trials} == {0}


def test_the_command_line_sets_the_stopping_rule(small_table: Path) -> None:
    data = json.loads((small_table / "table1.json").read_text())
    assert "--stop-after 3" in data["command"] and data["settings"]["stop_after"] == 3
    config = json.loads(
        (small_table / "trials" / "edge-ppo" / "seed-0" / "config.json").read_text()
    )
    assert config["evaluation"]["stop_after"] == 3


def test_tracking_belief_changes_only_the_bolts_tracking(tmp_path: Path) -> None:
    threshold, belief = table1_sweep(), table1_sweep(tracking="belief")
    assert (threshold.name, belief.name) == ("table1", "table1-belief")
    assert "bolt.tracking" not in threshold.source["base"]  # its sweep file as before
    for a, b in zip(threshold.trials, belief.trials, strict=True):
        assert (a.config.bolt.tracking, b.config.bolt.tracking) == ("threshold", "belief")
        assert b.config.override({"bolt.tracking": "threshold"}) == a.config
    with pytest.raises(UnknownNameError, match="unknown tracking mode 'beleif'"):
        table1_sweep(tracking="beleif")
    # Through the command line: recorded in the trials, table1.json and the table's text.
    out = tmp_path / "out"
    argv = ["reproduce", "table1", "--rows", "edge-dqn", "--seeds", "1", "--frames", "256",
            "--detector", "oracle", "--eval-freq", "128", "--eval-episodes", "2",
            "--final-episodes", "2", "--tracking", "belief", "--out", str(out)]  # fmt: skip
    assert main(argv) == 0
    data = json.loads((out / "table1.json").read_text())
    assert data["settings"]["tracking"] == "belief" and "--tracking belief" in data["command"]
    config = json.loads((out / "trials" / "edge-dqn" / "seed-0" / "config.json").read_text())
    assert config["bolt"]["tracking"] == "belief"
    assert "bolt DFA tracking: `belief`" in (out / "table1.md").read_text()


def test_rows_are_chosen_by_row_or_spec_name() -> None:
    assert [r.name for r in select_rows(["edge"])] == ["edge-ppo", "edge-a2c", "edge-dqn"]
    assert select_rows(None) == TABLE1_ROWS
    with pytest.raises(ConfigError, match="unknown Table 1 row"):
        select_rows(["edge-sac"])


def test_bad_options_exit_2_before_anything_runs(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "out"
    assert main(["reproduce", "table1", "--rows", "edge-sac", "--out", str(out)]) == 2
    assert "unknown Table 1 row" in capsys.readouterr().err
    assert main(["reproduce", "table1", "--noise", "fog", "--out", str(out)]) == 2
    assert not out.exists()
    with pytest.raises(SystemExit):
        main(["reproduce", "table1", "--frames-scale", "0"])


def test_small_reproduction_writes_the_table_beside_the_papers(small_table: Path) -> None:
    data = json.loads((small_table / "table1.json").read_text())
    assert data["command"].startswith("noisybolt reproduce table1 --seeds 1 ")
    assert "--frames 1024 --rows edge-ppo,avoid_top_right-a2c" in data["command"]
    rows = {r["row"]: r for r in data["rows"]}
    assert list(rows) == ["edge-ppo", "avoid_top_right-a2c"]
    edge, avoid = rows["edge-ppo"], rows["avoid_top_right-a2c"]
    # Exact R^c_max from the planner, and the paper's numbers as printed.
    assert edge["rc_max"] == 89.5 and avoid["rc_max"] == 88.0
    assert edge["paper"] == {
        "rc_max": 94,
        "r_pi": 79.48,
        "n_steps": 90,
        "n_frames": 25_000,
        "followed": True,
    }
    assert edge["n_done"] == 1 and edge["frames"] == 1024
    evaluation = json.loads(
        (small_table / "trials" / "edge-ppo" / "seed-0" / "evaluation.json").read_text()
    )
    assert evaluation["episodes"] == 8
    assert edge["r_pi"]["mean"] == pytest.approx(evaluation["env_return_mean"])
    assert edge["compliance"]["mean"] == pytest.approx(evaluation["compliance"]["edge"])
    assert edge["followed"] is (evaluation["compliance"]["edge"] >= 0.95)

    markdown = (small_table / "table1.md").read_text()
    assert "| `G(on_edge)` | PPO | 89.5 | 94 |" in markdown
    assert "| `!F(top_right_corner)` | A2C | 88 | 82 |" in markdown
    assert "79.48" in markdown and "25.0k" in markdown
    with open(small_table / "table1.csv", newline="") as handle:
        table = list(csv.DictReader(handle))
    assert [r["row"] for r in table] == ["edge-ppo", "avoid_top_right-a2c"]
    assert table[1]["paper_r_pi"] == "80.71" and table[1]["rc_max"] == "88"
    for row in ("edge-ppo", "avoid_top_right-a2c"):
        png = small_table / "curves" / f"{row}.png"
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_the_table_records_its_wall_time_and_workers(small_table: Path) -> None:
    settings = json.loads((small_table / "table1.json").read_text())["settings"]
    assert settings["workers"] == 1  # the CLI's default: one trial after the other
    assert settings["cpus"] >= 1 and settings["load_average_at_start"] >= 0
    assert 0 < settings["wall_seconds"] < 600
    minutes = f"Wall time {settings['wall_seconds'] / 60:.1f} min with 1 worker(s)"
    assert minutes in (small_table / "table1.md").read_text()


def test_running_again_reuses_the_trials(small_table: Path) -> None:
    stamps = {p: p.stat().st_mtime_ns for p in (small_table / "trials").rglob("*") if p.is_file()}
    code = main(_small_table_argv(small_table))
    assert code == 0
    assert {p: p.stat().st_mtime_ns for p in stamps} == stamps


def _record(seed: int, compliance: float | None) -> TrialRecord:
    final = None
    if compliance is not None:
        final = {
            "env_return_mean": 80.0 + seed,
            "length_mean": 9.0,
            "goal_rate": 1.0,
            "success_rate": compliance,
            "compliance": {"edge": compliance},
        }
    return TrialRecord(
        trial_id=f"edge-ppo/seed-{seed}",
        group="edge-ppo",
        row="edge-ppo",
        seed=seed,
        settings={},
        run_dir=Path("/nonexistent"),
        status="done" if final else "failed",
        algo="ppo",
        spec_names=("edge",),
        final=final,
        frames=60_000,
        frames_to_comply=12_000 if compliance and compliance >= 0.95 else None,
    )


@pytest.mark.parametrize(
    ("rates", "followed"),
    [
        ((1.0, 0.95, 0.97), True),
        ((1.0, 0.9, 1.0), False),
        ((1.0, None, 1.0), None),  # a seed failed: undecided unless another is below
        ((0.5, None, 1.0), False),
    ],
)
def test_followed_needs_95_percent_compliance_in_every_seed(
    rates: tuple[float | None, ...], followed: bool | None
) -> None:
    records = tuple(_record(seed, rate) for seed, rate in enumerate(rates))
    result = SweepResult.of(Path("/nonexistent"), "table1", records)
    (entry,) = build_table1(result)
    assert entry.followed is followed
    assert entry.rc_max == 89.5
    done = [r for r in rates if r is not None]
    assert entry.r_pi == Stat.of(80.0 + s for s, r in enumerate(rates) if r is not None)
    assert entry.n_done == len(done) and entry.n_failed == len(rates) - len(done)
    assert entry.n_reached == sum(r >= 0.95 for r in done)
    assert entry.compliance_min == min(done)


def test_module_doctests_pass() -> None:
    assert doctest.testmod(table1_module).failed == 0


def test_the_committed_table1_rows_read_back_to_the_same_json() -> None:
    from noisybolt.experiments.table1 import Table1Entry

    committed = Path(__file__).resolve().parents[2] / "results" / "table1" / "table1.json"
    rows = json.loads(committed.read_text())["rows"]
    assert [Table1Entry.from_dict(row).to_dict() for row in rows] == rows
    assert isinstance(Table1Entry.from_dict(rows[0]).r_pi, Stat)
