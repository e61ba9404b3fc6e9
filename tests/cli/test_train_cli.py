"""``noisybolt train`` and ``evaluate``: the table they print, stopping a training."""

from __future__ import annotations

import os
import re
import signal

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
    from noisybolt.cli.train import _sigterm_as_interrupt

    before = signal.getsignal(signal.SIGTERM)
    with pytest.raises(KeyboardInterrupt), _sigterm_as_interrupt():
        os.kill(os.getpid(), signal.SIGTERM)  # the handler runs before the next line
    assert signal.getsignal(signal.SIGTERM) == before
