"""``noisybolt train`` and ``evaluate``: the table they print, stopping a training."""

from __future__ import annotations

import os
import re
import signal
from pathlib import Path
from typing import Any

import pytest

from noisybolt.cli.train import format_eval_table

_FINAL = {
    "n_episodes": 4,
    "env_return_mean": 3.5,
    "env_return_std": 1.25,
    "bolt_return_mean": 2.0,
    "length_mean": 812.0,
    "goal_rate": 0.0,
    "compliance": {"clear_left_column": 0.0, "left_row5": 0.75},
    "success_rate": 0.0,
}


def _rows(table: str) -> dict[str, str]:
    # "key<padding>  value": keys are padded to the longest, then two spaces
    return dict(re.split(r"\s{2,}", line.strip(), maxsplit=1) for line in table.splitlines())


def test_false_acceptances_are_named_per_spec_where_recorded() -> None:
    final = _FINAL | {"false_acceptance": {"clear_left_column": 0.5, "left_row5": 0.0}}
    rows = _rows(format_eval_table(final))
    assert rows["bolt falsely accepting (episodes)"] == "clear_left_column 50%"
    assert rows["compliance [left_row5]"] == "75%"
    clean = _FINAL | {"false_acceptance": {"clear_left_column": 0.0, "left_row5": 0.0}}
    assert _rows(format_eval_table(clean))["bolt falsely accepting (episodes)"] == "none"


def test_runs_recorded_before_the_bolts_view_was_kept_have_no_such_row() -> None:
    assert "falsely" not in format_eval_table(_FINAL)


def test_sigterm_interrupts_a_training_like_ctrl_c_and_only_meanwhile() -> None:
    from noisybolt.cli import sigterm_as_interrupt

    before = signal.getsignal(signal.SIGTERM)
    with pytest.raises(KeyboardInterrupt), sigterm_as_interrupt():
        os.kill(os.getpid(), signal.SIGTERM)  # the handler runs before the next line
    assert signal.getsignal(signal.SIGTERM) == before


def test_the_table_says_whether_the_actions_were_greedy_or_sampled() -> None:
    # the same policy can comply greedily (standing still) and not when sampled: a train
    # table (sampled, the evaluation default) and an evaluate table (greedy) must say so
    assert _rows(format_eval_table(_FINAL))["episodes"] == "4"
    assert _rows(format_eval_table(_FINAL, greedy=True))["episodes"] == "4 (greedy actions)"
    assert _rows(format_eval_table(_FINAL, greedy=False))["episodes"] == "4 (sampled actions)"


def test_evaluate_takes_at_least_one_episode_and_draws_as_many_in_its_heatmap(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    from noisybolt.cli import main
    from noisybolt.runs import run_evaluation
    from noisybolt.runs.evaluation import EpisodeRecord, summarise

    for bad in ("0", "-3", "many"):
        with pytest.raises(SystemExit) as exit_info:
            main(["evaluate", str(tmp_path), "--episodes", bad])
        assert exit_info.value.code == 2
        assert "--episodes" in capsys.readouterr().err
    calls: list[dict[str, Any]] = []

    def fake(run_dir: Any, **kwargs: Any) -> Any:
        calls.append(kwargs)
        episode = EpisodeRecord(1.0, 0.0, 5, True, (True,))
        return run_evaluation.RunEvaluation(result=summarise([episode], ["edge"]))

    monkeypatch.setattr(run_evaluation, "evaluate_run", fake)
    assert main(["evaluate", str(tmp_path), "--episodes", "7", "--heatmap", "h.png"]) == 0
    assert calls[0]["episodes"] == 7 and calls[0]["heatmap_episodes"] == 7
    assert _rows(capsys.readouterr().out.split("\n\n")[0].strip())["episodes"].endswith(
        "(greedy actions)"
    )


def test_the_commands_print_noisybolts_warnings_as_a_sentence_and_others_as_python_does() -> None:
    import warnings

    from noisybolt.cli import _plain_warnings
    from noisybolt.errors import EstimatedBoundsWarning

    original = warnings.formatwarning
    with _plain_warnings("noisybolt train"):
        ours = warnings.formatwarning(
            EstimatedBoundsWarning("declare the bounds"), EstimatedBoundsWarning, "x.py", 3
        )
        theirs = warnings.formatwarning(UserWarning("w"), UserWarning, "lib.py", 7)
    assert ours == "noisybolt train: warning: declare the bounds\n"
    assert theirs.startswith("lib.py:7: UserWarning: w")
    assert warnings.formatwarning is original


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["reproduce", "table1", "--final-episodes", "0"], "must be at least 1, got '0'"),
        (["reproduce", "table1", "--eval-episodes", "0"], "must be at least 1, got '0'"),
        (["reproduce", "case4", "--episodes", "0"], "must be at least 1, got '0'"),
        (["reproduce", "table1", "--retries", "-1"], "must be at least 0, got '-1'"),
        (["reproduce", "table1", "--stop-after", "two"], "not a whole number: 'two'"),
    ],
)
def test_counts_of_episodes_are_at_least_one_and_other_counts_not_negative(
    argv: list[str], message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    from noisybolt.cli import main

    with pytest.raises(SystemExit) as exit_info:
        main(argv)
    assert exit_info.value.code == 2
    assert message in capsys.readouterr().err


def test_an_interrupt_before_the_run_is_set_up_says_nothing_was_saved(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    # A classifier training on the fly is interrupted: no run directory, and one line.
    from noisybolt.cli import main
    from noisybolt.runs import training

    def interrupted(*args: Any, **kwargs: Any) -> Any:
        raise KeyboardInterrupt

    monkeypatch.setattr(training, "train", interrupted)
    argv = ["train", "--spec", "edge", "--detector", "oracle", "--out", str(tmp_path / "r")]
    assert main(argv) == 130
    assert "interrupted before training began; nothing was saved" in capsys.readouterr().err
