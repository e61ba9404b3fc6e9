"""The kept model under the constrained scheme: the world's return within the cost budget,
the cost as the bolt saw it (never ground truth)."""

from __future__ import annotations

from typing import Any

import pytest

from noisybolt.runs import DetectorConfig, TrainConfig
from noisybolt.runs.callbacks import EvaluationCallback, budget_score, shaped_return
from noisybolt.runs.evaluation import EpisodeRecord, summarise
from noisybolt.runs.resolution import resolve


def _episodes(n: int, *, violating: int, bolt_missed: int, ret: float) -> list[EpisodeRecord]:
    """``n`` episodes of return ``ret``: ``violating`` of them break the spec (truth and the
    bolt alike), and the bolt misses ``bolt_missed`` further true breaks (it saw them
    comply)."""
    out = []
    for i in range(n):
        truth = i >= violating + bolt_missed
        bolt = i >= violating
        out.append(EpisodeRecord(ret, 0.0, 10, True, (truth,), bolt_accepting=(bolt,)))
    return out


def test_the_bolt_s_cost_is_the_mean_count_of_specs_its_dfas_leave_unsatisfied() -> None:
    # 10 episodes, 2 broken as the bolt saw them, 1 more broken that it missed.
    result = summarise(_episodes(10, violating=2, bolt_missed=1, ret=1.0), ["s"])
    assert result.bolt_cost_mean == pytest.approx(0.2)  # the bolt's view, not truth's 0.3
    assert result.compliance == {"s": pytest.approx(0.7)}
    two = [EpisodeRecord(0.0, 0.0, 5, None, (True, False), bolt_accepting=(False, False))]
    assert summarise(two, ["a", "b"]).bolt_cost_mean == 2.0
    unrecorded = [EpisodeRecord(0.0, 0.0, 5, None, (True,))]
    assert summarise(unrecorded, ["a"]).bolt_cost_mean is None


def _callback(**kwargs: Any) -> EvaluationCallback:
    settings: dict[str, Any] = {
        "specs": ["edge"],
        "detector": DetectorConfig(kind="oracle"),
        "frames": 2048,
        "progress_bar": False,
    }
    settings.update(kwargs)
    config = resolve(TrainConfig.create(**settings))
    return EvaluationCallback(
        config=config,
        run=None,
        eval_env=None,
        spec_names=["edge"],
        history=[],  # type: ignore[arg-type]
    )


def test_under_a_budget_the_kept_model_spends_it_where_the_shaped_return_would_not() -> None:
    """d = 0.1, scale 1.1: one model violates in 10 % of episodes and returns 0.5, one
    complies always and returns 0.45, one violates in 30 % and returns 0.6."""
    spends = summarise(_episodes(20, violating=2, bolt_missed=0, ret=0.5), ["edge"])
    complies = summarise(_episodes(20, violating=0, bolt_missed=0, ret=0.45), ["edge"])
    over = summarise(_episodes(20, violating=6, bolt_missed=0, ret=0.6), ["edge"])
    callback = _callback(
        reward="constrained", reward_scale=1.1, **{"bolt.constraint.cost_limit": 0.1}
    )
    assert callback.score(spends) == pytest.approx(0.5)  # within the budget: its return
    assert callback.score(complies) == pytest.approx(0.45)
    assert callback.score(over) == pytest.approx(0.6 - 1.1 * 0.2)  # 0.2 over the budget
    assert callback.score(spends) > max(callback.score(complies), callback.score(over))
    # The same results judged by the shaped return at the full price pay acceptance
    # (scale 1.1 per complying episode) and would keep the one that complies most:
    # 0.45 + 1.1 against 0.5 + 0.9 * 1.1 and 0.6 + 0.7 * 1.1.
    paid = [
        summarise(
            [
                EpisodeRecord(e.env_return, 1.1 * e.bolt_accepting[0], 10, True, e.compliant,
                              bolt_accepting=e.bolt_accepting)
                for e in r.episodes
            ],
            ["edge"],
        )
        for r in (spends, complies, over)
    ]  # fmt: skip
    assert max(paid, key=shaped_return) is paid[1]
    assert max(paid, key=callback.score) is paid[0]


def test_the_other_schemes_keep_the_best_shaped_return() -> None:
    result = summarise(_episodes(20, violating=2, bolt_missed=0, ret=0.5), ["edge"])
    assert _callback(reward="compliance", reward_scale=1.1).score(result) == shaped_return(result)
    assert _callback(bolted=False).score(result) == shaped_return(result)


def test_a_spec_s_own_scale_prices_its_excess() -> None:
    result = summarise(_episodes(10, violating=5, bolt_missed=0, ret=1.0), ["edge"])
    callback = _callback(
        specs=[{"formula": "G(on_edge)", "name": "edge", "reward_scale": 4.0}],
        reward="constrained",
        reward_scale=1.1,
    )
    assert callback.score(result) == pytest.approx(1.0 - 4.0 * (0.5 - 0.02))
    assert budget_score(result, scale=4.0, cost_limit=0.02) == callback.score(result)


def test_the_kept_model_is_judged_at_the_price_s_raised_scale() -> None:
    """Where the world's returns outran an estimated scale, an excess over the budget
    costs the raised scale: a spec broken in every episode to win a return of 1 loses
    to complying without it (at the estimate's 1.0 it would have won, 1 - 0.98 > 0)."""
    from noisybolt.agents.constraint import LagrangianCallback
    from noisybolt.bolt import CostLimit

    breaks = summarise(_episodes(20, violating=20, bolt_missed=0, ret=1.0), ["edge"])
    complies = summarise(_episodes(20, violating=0, bolt_missed=0, ret=0.0), ["edge"])
    callback = _callback(reward="constrained", reward_scale=1.0)
    assert callback.score(breaks) > callback.score(complies)
    constraint = LagrangianCallback(CostLimit(rescale=1.1, anneal=0.0), frames=1000, scale=1.0)
    constraint.multiplier.update(1.0, returns=[0.0, 1.0])
    callback.constraint = constraint
    assert callback.score(breaks) == pytest.approx(1.0 - 1.1 * 0.98)
    assert callback.score(complies) == 0.0 > callback.score(breaks)


def test_a_best_saved_without_a_score_is_scored_again_from_its_record() -> None:
    """A run resumed from a checkpoint written before scores were kept: its best
    evaluation is judged as the new ones are, not by its shaped return."""
    spends = summarise(_episodes(20, violating=2, bolt_missed=0, ret=0.5), ["edge"])
    callback = _callback(
        reward="constrained", reward_scale=1.1, **{"bolt.constraint.cost_limit": 0.02}
    )
    callback.history.append({"frames": 4096, **spends.to_dict()})
    old_best = {"frames": 4096, "shaped_return": 123.0}
    assert callback._best_score(old_best) == pytest.approx(0.5 - 1.1 * 0.08)
    assert callback._best_score({"frames": 1, "shaped_return": 7.0}) == 7.0  # no record
