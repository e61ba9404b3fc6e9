"""The compliance scheme's rewards, by hand, inside the bolt; its settings refused when bad."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from noisybolt.bolt import (
    ProgressShaping,
    RestrainingBolt,
    ReturnBounds,
    RewardScheme,
    Spec,
    compliance_scale,
)
from noisybolt.errors import ConfigError, UnknownNameError
from noisybolt.logic import compile_ltlf

FLUENTS = ["a", "b"]
ON, OFF = 0.99, 0.01


def _bolt(
    formula: str,
    *,
    scale: float = 30.0,
    shaping: bool = True,
    gamma: float = 1.0,
    pay_on_change: bool = True,
) -> RestrainingBolt:
    scheme = RewardScheme("compliance", scale=scale, shaping=shaping, pay_on_change=pay_on_change)
    spec = scheme.apply(Spec(formula, terminal_reward=1.0, low_confidence_cost=0.5))
    dfa = compile_ltlf(formula, FLUENTS)
    terms = ProgressShaping([dfa], scales=[scale], gamma=gamma, shaping=shaping)
    return RestrainingBolt([spec], FLUENTS, dfas=[dfa], shaping=terms)


def _episode(bolt: RestrainingBolt, letters: list[tuple[float, float]]) -> list[float]:
    """Bolt rewards of an episode whose observations are ``letters`` (reset included)."""
    bolt.reset(np.array([letters[0]]))
    rewards = []
    for i, probs in enumerate(letters[1:], start=1):
        rewards.append(float(bolt.step(np.array([probs]), done=i == len(letters) - 1).total[0]))
    return rewards


def test_a_detour_is_paid_as_it_progresses_and_acceptance_as_it_comes() -> None:
    # F(a) & F(b): 2 letters from acceptance (over letters with a and b apart), but the
    # DFA's own graph has the letter a & b: distance 1, d_max 1, so each step is 15.
    bolt = _bolt("F(a) & F(b)")
    rewards = _episode(bolt, [(OFF, OFF), (ON, OFF), (OFF, OFF), (OFF, ON), (OFF, OFF)])
    # reset: nothing; a seen: no progress by the DFA's distance (1 -> 1); b seen: +15
    # (1 -> 0) and +30 for accepting; the episode ends with nothing left to pay.
    assert rewards == [0.0, 0.0, 15.0 + 30.0, 0.0]
    # paid at the end instead (pay_on_change=False): the same sum, the 30 at the end
    bolt = _bolt("F(a) & F(b)", pay_on_change=False)
    rewards = _episode(bolt, [(OFF, OFF), (ON, OFF), (OFF, OFF), (OFF, ON), (OFF, OFF)])
    assert rewards == [0.0, 0.0, 15.0, 30.0]


def test_an_unfinished_episode_keeps_its_shortfall_and_a_violation_pays_at_once() -> None:
    unfinished = _bolt("F(a & X(F(b)))")  # d: 2 at the start, d_max 2: 10 a step
    assert _episode(unfinished, [(OFF, OFF), (ON, OFF), (OFF, OFF)]) == [10.0, 0.0]
    # G(!a): accepting from the reset frame (where the episode starts: not paid) until a,
    # then a rejecting sink: the 30 taken back and -30 for the violation, nothing after.
    safety = _bolt("G(!a)")
    assert _episode(safety, [(OFF, OFF), (OFF, OFF), (ON, OFF), (OFF, OFF), (OFF, OFF)]) == [
        0.0,
        -60.0,
        0.0,
        0.0,
    ]
    # Complying with G(!a) from the start pays nothing on change (no payment per accepting
    # step either); at the end, the scale. The two differ by what the start accepts, which
    # no action changes.
    assert _episode(_bolt("G(!a)"), [(OFF, OFF)] * 4) == [0.0, 0.0, 0.0]
    at_end = _bolt("G(!a)", pay_on_change=False)
    assert _episode(at_end, [(OFF, OFF)] * 4) == [0.0, 0.0, 30.0]


def test_on_change_pays_nothing_for_where_the_episode_starts() -> None:
    # F(a & X(F(b))): a on the reset frame already moves the DFA one letter closer (+10 of
    # shaping) and b then completes it. The first transition is read before any action:
    # under on_change neither its progress nor an acceptance on it is paid (the carried
    # reward is only Algorithm 1's cost, 0 here); paid at the end, its progress is.
    start_with_a = [(ON, OFF), (OFF, OFF), (OFF, ON), (OFF, OFF)]
    on_change = _bolt("F(a & X(F(b)))")
    assert on_change.reset(np.array([start_with_a[0]])).total.tolist() == [0.0]
    assert _episode(on_change, start_with_a) == [0.0, 10.0 + 30.0, 0.0]
    at_end = _bolt("F(a & X(F(b)))", pay_on_change=False)
    assert at_end.reset(np.array([start_with_a[0]])).total.tolist() == [10.0]
    assert _episode(at_end, start_with_a) == [10.0, 10.0, 30.0]
    # what an action changes is paid the same however the episode starts
    assert _episode(on_change, [(OFF, OFF), (ON, OFF), (OFF, ON), (OFF, OFF)]) == [10.0, 40.0, 0.0]


def test_without_shaping_the_outcome_is_paid_at_the_end() -> None:
    bolt = _bolt("F(a & X(F(b)))", shaping=False)
    assert _episode(bolt, [(OFF, OFF), (ON, OFF), (OFF, OFF)]) == [0.0, -10.0]
    assert _episode(bolt, [(OFF, OFF), (ON, OFF), (OFF, ON)]) == [0.0, 30.0]


def test_discounted_shaping_telescopes_to_the_same_value_for_every_route() -> None:
    # Whatever the route, sum_t gamma^t F_t = -Phi(q_0) when the end's potential is 0.
    gamma = 0.9
    dfa = compile_ltlf("F(a & X(F(b)))", FLUENTS)
    terms = ProgressShaping([dfa], scales=[30.0], gamma=gamma)
    rng = np.random.default_rng(0)
    q0 = dfa.initial_state
    for _ in range(20):
        states = [q0]
        for _ in range(int(rng.integers(1, 8))):
            letter = {"a": bool(rng.integers(2)), "b": bool(rng.integers(2))}
            states.append(dfa.step(states[-1], letter))
        total = 0.0
        for t, (q, q_next) in enumerate(itertools.pairwise(states)):
            done = t == len(states) - 2
            term = terms(np.array([[q]]), np.array([[q_next]]), done=np.array([done]))[0, 0]
            # Remove the graded end charge and the violation charge: the shaping alone.
            no_shaping = ProgressShaping([dfa], scales=[30.0], gamma=gamma, shaping=False)
            base = no_shaping(np.array([[q]]), np.array([[q_next]]), done=np.array([done]))
            total += gamma**t * (term - base[0, 0])
        assert math.isclose(total, -terms.potentials[0][q0], abs_tol=1e-9)


def test_compliance_scale_and_scheme_settings() -> None:
    assert compliance_scale(ReturnBounds(-216.0, 98.5)) == pytest.approx(1.1 * 314.5)
    assert compliance_scale(ReturnBounds(3.0, 3.0)) == 1.0
    paper = RewardScheme("paper")
    spec = Spec("F(a)", terminal_reward=2.0, low_confidence_cost=0.5)
    assert paper.apply(spec) is spec
    applied = RewardScheme("compliance", scale=7.0).apply(spec, scale=9.0)
    assert (applied.terminal_reward, applied.reward_timing) == (9.0, "on_change")


@pytest.mark.parametrize(
    ("kwargs", "error"),
    [
        ({"name": "bonus", "scale": 1.0}, UnknownNameError),
        ({"name": "compliance", "scale": None}, ConfigError),
        ({"name": "compliance", "scale": -1.0}, ConfigError),
        ({"name": "compliance", "scale": 0.0}, ConfigError),
        ({"name": "compliance", "scale": float("inf")}, ConfigError),
        ({"name": "compliance", "scale": float("nan")}, ConfigError),
        ({"name": "paper", "scale": 5.0}, ConfigError),
    ],
)
def test_bad_schemes_are_refused(kwargs: dict, error: type[Exception]) -> None:
    with pytest.raises(error):
        RewardScheme(**kwargs)


def test_bad_bounds_and_shaping_are_refused() -> None:
    with pytest.raises(ConfigError):
        ReturnBounds(1.0, 0.0)
    with pytest.raises(ConfigError):
        ReturnBounds(float("-inf"), 0.0)
    dfa = compile_ltlf("F(a)", FLUENTS)
    with pytest.raises(ConfigError):
        ProgressShaping([dfa], scales=[1.0], gamma=0.0)
    with pytest.raises(ConfigError):
        ProgressShaping([dfa], scales=[1.0, 2.0], gamma=1.0)
    with pytest.raises(ConfigError):  # shaping over DFAs that are not the bolt's
        RestrainingBolt(
            [Spec("F(a)", terminal_reward=1.0, low_confidence_cost=0.5)],
            FLUENTS,
            dfas=[dfa],
            shaping=ProgressShaping([compile_ltlf("F(b)", FLUENTS)], scales=[1.0], gamma=1.0),
        )


@pytest.mark.parametrize("pay_on_change", [False, True])
def test_a_time_limit_cut_pays_no_outcome_when_the_learner_bootstraps_there(
    pay_on_change: bool,
) -> None:
    scale = 30.0
    dfa = compile_ltlf("F(a & X(F(b)))", FLUENTS)
    spec = RewardScheme("compliance", scale=scale, pay_on_change=pay_on_change).apply(
        Spec("F(a & X(F(b)))", terminal_reward=1.0, low_confidence_cost=0.5)
    )

    def last_reward(pay_at_truncation: bool, truncated: bool, b: float) -> float:
        terms = ProgressShaping([dfa], scales=[scale], gamma=1.0)
        bolt = RestrainingBolt(
            [spec], FLUENTS, dfas=[dfa], shaping=terms, pay_at_truncation=pay_at_truncation
        )
        bolt.reset(np.array([[ON, OFF]]))  # a seen: 10 of progress, paid with step 1
        out = bolt.step(np.array([[OFF, b]]), done=True, truncated=truncated)
        return float(out.total[0] - out.carried[0])

    # Accepted on the last step (b): progress 10 and 30 for accepting, which at the
    # episode's end is paid only if the episode is paid as ended; paid on change, the
    # acceptance has happened and is paid (the learner's bootstrapped value holds only
    # what may change after it).
    assert last_reward(True, True, ON) == 40.0
    assert last_reward(False, False, ON) == 40.0  # terminated: paid
    # cut by the time limit: progress only, unless acceptance is paid as it comes
    assert last_reward(False, True, ON) == (40.0 if pay_on_change else 10.0)
    # Short of acceptance: with gamma 1 the end charge (-10) and the shaping's end (+10)
    # net to what an unended step pays, so a cut changes nothing there.
    assert last_reward(True, True, OFF) == last_reward(False, True, OFF) == 0.0
