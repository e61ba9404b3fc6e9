"""The constrained scheme's pieces: the cost budget, the Lagrange multiplier, the bolt's price."""

from __future__ import annotations

import math

import numpy as np
import pytest
from bolt_helpers import F_E_AND_T, always, last_is
from hypothesis import given, settings
from hypothesis import strategies as st

from noisybolt.bolt import (
    CostLimit,
    LagrangeMultiplier,
    ProgressShaping,
    RestrainingBolt,
    RewardScheme,
    Spec,
    episode_costs,
)
from noisybolt.errors import ConfigError

# ------------------------------------------------------------------ the budget


@pytest.mark.parametrize(
    ("settings_", "named"),
    [
        ({"cost_limit": -0.1}, "cost_limit"),
        ({"cost_limit": math.nan}, "cost_limit"),
        ({"cost_limit": math.inf}, "cost_limit"),
        ({"lr": 0.0}, "lr"),
        ({"lr": -1.0}, "lr"),
        ({"kp": -0.5}, "kp"),
        ({"kd": -0.5}, "kd"),
        ({"initial": 1.5}, "initial"),
        ({"anneal": -0.1}, "anneal"),
        ({"anneal": 2.0}, "anneal"),
        ({"wait": 1.5}, "wait"),
        ({"wait": -0.1}, "wait"),
        ({"wait": "half"}, "wait"),
        ({"start": 1.5}, "start"),
        ({"start": -0.5}, "start"),
        ({"start": math.nan}, "start"),
        ({"window": -1}, "window"),
        ({"window": math.inf}, "window"),
        ({"release": 1.5}, "release"),
        ({"release": -0.1}, "release"),
        ({"cost_limit": "0.1"}, "cost_limit"),
        ({"lr": True}, "lr"),
    ],
)
def test_bad_budgets_are_refused_by_name(settings_: dict, named: str) -> None:
    with pytest.raises(ConfigError, match=f"bolt.constraint.{named}"):
        CostLimit(**settings_)


def test_unknown_constraint_keys_are_named() -> None:
    with pytest.raises(ConfigError, match="budget"):
        CostLimit.from_mapping({"budget": 0.1})
    assert CostLimit.from_mapping({"cost_limit": 0.2}).cost_limit == 0.2


# ------------------------------------------------------------------ the price it starts from


def test_the_integral_starts_at_start_from_the_first_cost_measured_awake() -> None:
    # Linear price, no anneal, kp 1, lr 0.1 per 1,000 frames, the limit 0.02.
    limit = CostLimit(cost_limit=0.02, lr=0.1, kp=1.0, anneal=0.0, start=1.0)
    lagrange = LagrangeMultiplier(limit)
    assert lagrange.value == 0.0  # the first rollout is paid at `initial`
    # A cost of 0.6 measured over 1,000 frames: the integral starts at 1, then learns:
    # 1 + 0.1 * (0.6 - 0.02) clipped to 1; the price kp * 0.58 + 1, clipped to 1.
    assert lagrange.update(0.6, frames=1000, progress=0.0) == 1.0
    # Without `start` the same cost is priced by the proportional term and an integral
    # from 0: 0.58 + 0.1 * 0.58 = 0.638 (the price that falls as the agent complies).
    plain = LagrangeMultiplier(CostLimit(cost_limit=0.02, lr=0.1, kp=1.0, anneal=0.0))
    assert plain.update(0.6, frames=1000, progress=0.0) == pytest.approx(0.638)
    # Complying (cost 0, below the limit) eases the price from 1 by the integral's rate
    # and the proportional term: 1 - 0.1 * 0.02 * 10 - 0.02 = 0.96 after 10,000 frames.
    assert lagrange.update(0.0, frames=10_000, progress=0.5) == pytest.approx(0.96)
    # A waiting multiplier keeps `initial` and starts from `start` only once awake.
    waiting = LagrangeMultiplier(CostLimit(cost_limit=0.02, anneal=0.0, start=1.0, wait=0.5))
    assert waiting.update(1.0, progress=0.1, returns=[0.0, 0.0]) == 0.0
    assert waiting.waiting
    assert waiting.update(1.0, progress=0.2, returns=[0.0, 0.9]) == 0.0  # awake now
    assert waiting.update(1.0, progress=0.25, returns=[0.0]) == 1.0  # the first cost
    # A resumed multiplier goes on from its saved integral, not from `start` again.
    resumed = LagrangeMultiplier(limit, state=lagrange.state_dict())
    assert resumed.update(0.0, frames=10_000, progress=0.6) == pytest.approx(0.94)


# ------------------------------------------------------------------ the release


def test_released_the_integral_falls_as_fast_below_the_budget_as_it_rises_above() -> None:
    # Integral alone (kp 0), linear price, lr 0.02 per 1,000 frames, the limit 0.02.
    limit = CostLimit(cost_limit=0.02, lr=0.02, kp=0.0, anneal=0.0, release=1.0)
    lagrange = LagrangeMultiplier(limit)
    # A cost of 1 over 10,000 frames: 0.02 * 0.98 * 10 = 0.196.
    assert lagrange.update(1.0, frames=10_000) == pytest.approx(0.196)
    # Met at cost 0 over 5,000 frames: the error is -1 * (0.02 - 0) / 0.02 = -1, the
    # integral falls 0.02 * 5 = 0.1 (unreleased: 0.02 * 0.02 * 5 = 0.002).
    assert lagrange.update(0.0, frames=5_000) == pytest.approx(0.096)
    # Half the budget: -0.5; 0.096 - 0.02 * 0.5 * 5 = 0.046.
    assert lagrange.update(0.01, frames=5_000) == pytest.approx(0.046)
    # Above the budget the error is the plain one, released or not.
    assert lagrange.update(0.52, frames=1_000) == pytest.approx(0.046 + 0.02 * 0.5)
    plain = LagrangeMultiplier(CostLimit(cost_limit=0.02, lr=0.02, kp=0.0, anneal=0.0))
    plain.update(1.0, frames=10_000)
    assert plain.update(0.0, frames=5_000) == pytest.approx(0.194)


def test_a_multiplier_given_no_gains_learns_at_the_second_round_s() -> None:
    from noisybolt.bolt.constraint_choices import KP, LR

    assert (LR, KP) == (0.1, 1.0)
    given = LagrangeMultiplier(CostLimit(cost_limit=0.02, lr=0.1, kp=1.0, anneal=0.0))
    default = LagrangeMultiplier(CostLimit(cost_limit=0.02, anneal=0.0))
    for cost in (0.6, 0.3, 0.0, 1.0):
        assert default.update(cost, frames=800) == given.update(cost, frames=800)


# ------------------------------------------------------------------ the wait for the task


def test_a_waiting_multiplier_learns_nothing_until_the_world_returns_differ() -> None:
    limit = CostLimit(cost_limit=0.0, lr=0.1, kp=1.0, anneal=0.5, wait=0.9)
    lagrange = LagrangeMultiplier(limit)
    assert lagrange.waiting
    # Two rollouts whose episodes all returned 0 (a goal not found yet): no price, no
    # first cost, however high the cost.
    assert lagrange.update(0.8, frames=1000, progress=0.1, returns=[0.0, 0.0, 0.0]) == 0.0
    assert lagrange.update(0.9, frames=1000, progress=0.2, returns=[0.0]) == 0.0
    assert lagrange.waiting and lagrange.first_cost is None and lagrange.updates == 2
    # The third's returns differ (a goal found): it wakes, but learns nothing from this
    # window's cost (its episodes began before it woke: no first cost, no price).
    assert lagrange.update(0.1, frames=1000, progress=0.3, returns=[0.0, 1.0]) == 0.0
    assert not lagrange.waiting and lagrange.woke_at == 0.3 and lagrange.first_cost is None
    assert lagrange.updates == 3
    # The next cost is the first: the budget annealed from it (0.6 at progress 0.3) over
    # half of the run then left (0.35). e = 0.6 - 0.6 = 0: integral 0, u = 0
    value = lagrange.update(0.6, frames=1000, progress=0.3, returns=[0.0])
    assert lagrange.first_cost == 0.6 and value == 0.0
    # At progress 0.475, a quarter of the run after waking: the budget is half-way down
    # from 0.6 to 0 (0.3). e = 0.5 - 0.3 = 0.2: integral 0.1 * 0.2 = 0.02, u = 0.2 + 0.02
    assert lagrange.budget(0.475) == pytest.approx(0.3)
    assert lagrange.update(0.5, frames=1000, progress=0.475, returns=[0.0]) == pytest.approx(0.22)


def test_returns_that_differ_across_rollouts_end_the_wait() -> None:
    lagrange = LagrangeMultiplier(CostLimit(cost_limit=0.0, kp=1.0, anneal=0.0, wait=1.0))
    assert lagrange.update(1.0, progress=0.1, returns=[-5.0]) == 0.0
    assert lagrange.waiting
    # one episode a rollout, each the same as itself, but not as the first rollout's:
    # awake, priced from the next cost measured
    assert lagrange.update(1.0, progress=0.2, returns=[-7.0]) == 0.0
    assert lagrange.woke_at == 0.2
    assert lagrange.update(1.0, progress=0.25, returns=[-7.0]) == 1.0


def test_the_wait_ends_at_its_share_of_the_run_whatever_the_returns() -> None:
    lagrange = LagrangeMultiplier(CostLimit(cost_limit=0.0, kp=1.0, anneal=0.0, wait=0.5))
    assert lagrange.update(1.0, progress=0.49, returns=[0.0]) == 0.0
    assert lagrange.update(1.0, progress=0.5, returns=[0.0]) == 0.0
    assert lagrange.woke_at == 0.5
    assert lagrange.update(1.0, progress=0.51, returns=[0.0]) == 1.0


@settings(max_examples=40, deadline=None)
@given(
    costs=st.lists(st.floats(0.0, 3.0), min_size=1, max_size=12),
    wait=st.floats(0.01, 1.0),
)
def test_returns_that_differ_from_the_first_rollout_mean_no_wait(
    costs: list[float], wait: float
) -> None:
    """A world whose returns differ from the start (the gridworld's, CliffWalking's) is
    priced exactly as without the wait: the same values, the same annealed budget."""
    base = dict(cost_limit=0.1, lr=0.3, kp=1.0, kd=0.5, anneal=0.5, decades=0.0)
    waiting = LagrangeMultiplier(CostLimit(**base, wait=wait))
    plain = LagrangeMultiplier(CostLimit(**base))
    for i, cost in enumerate(costs):
        progress = (i + 1) / len(costs)
        assert waiting.update(cost, progress=progress, returns=[0.0, 1.0]) == plain.update(
            cost, progress=progress
        )
    assert waiting.woke_at == 0.0


def test_a_waiting_multiplier_resumes_where_it_stood() -> None:
    limit = CostLimit(cost_limit=0.0, kp=1.0, anneal=0.0, wait=1.0)
    first = LagrangeMultiplier(limit)
    first.update(1.0, progress=0.1, returns=[2.0])
    state = first.state_dict()
    assert state["woke_at"] is None and state["returns_seen"] == [2.0, 2.0]
    resumed = LagrangeMultiplier(limit, state=state)
    assert resumed.waiting
    assert resumed.update(1.0, progress=0.2, returns=[3.0]) == 0.0  # 3 differs from 2: awake
    assert not resumed.waiting and resumed.update(1.0, progress=0.3, returns=[3.0]) == 1.0


def test_a_state_saved_before_the_wait_existed_loads_awake() -> None:
    old = {"value": 0.3, "integral": 0.2, "last_cost": 0.5, "first_cost": 0.9, "updates": 4}
    lagrange = LagrangeMultiplier(CostLimit(wait=0.5), state=old)
    assert not lagrange.waiting and lagrange.woke_at == 0.0 and lagrange.value == 0.3


@pytest.mark.parametrize(
    "extra",
    [{"woke_at": 1.5}, {"woke_at": "0"}, {"returns_seen": [2.0, 1.0]}, {"returns_seen": [1.0]}],
)
def test_bad_wait_states_are_refused(extra: dict) -> None:
    state = {"value": 0.3, "integral": 0.2, "last_cost": None, "first_cost": None, "updates": 1}
    with pytest.raises(ConfigError, match="multiplier state"):
        LagrangeMultiplier(CostLimit(), state={**state, **extra})


# ------------------------------------------------------------------ the multiplier


def test_the_multiplier_follows_the_pid_rule_by_hand() -> None:
    limit = CostLimit(cost_limit=0.2, lr=0.1, kp=0.5, kd=1.0, anneal=0.0)
    lagrange = LagrangeMultiplier(limit)
    # e = 0.8: I = 0.08; lambda = 0.5 * 0.8 + 0.08 + 1.0 * 0 (no previous cost) = 0.48
    assert lagrange.update(1.0) == pytest.approx(0.48)
    # e = 0.4: I = 0.12; rise 0 (the cost fell): 0.2 + 0.12 = 0.32
    assert lagrange.update(0.6) == pytest.approx(0.32)
    # e = 0.6: I = 0.18; rise 0.2: 0.3 + 0.18 + 0.2 = 0.68
    assert lagrange.update(0.8) == pytest.approx(0.68)
    # e = -0.2: I = 0.16; kp term negative: -0.1 + 0.16 = 0.06
    assert lagrange.update(0.0) == pytest.approx(0.06)
    assert lagrange.updates == 4


def test_the_proportional_term_prices_a_cost_above_the_annealed_budget_at_once() -> None:
    # A run of 10,000 frames, the budget annealed over its first half from the first cost.
    limit = CostLimit(cost_limit=0.0, lr=0.1, kp=2.0, anneal=0.5)
    lagrange = LagrangeMultiplier(limit)
    assert lagrange.update(0.5, progress=0.0) == 0.0  # budget 0.5: no error at all
    # progress 0.25: budget 0.25; e = 0.15: I = 0.015; 2 * 0.15 + 0.015 = 0.315
    assert lagrange.update(0.4, progress=0.25) == pytest.approx(0.315)
    # the cost falls with the budget: e = 0, I stays, the proportional term goes
    assert lagrange.update(0.25, progress=0.25) == pytest.approx(0.015)
    # the anneal over: budget 0; cost 0.1: I = 0.025, 2 * 0.1 + 0.025 = 0.225
    assert lagrange.update(0.1, progress=0.9) == pytest.approx(0.225)


def test_the_integral_rises_by_the_frames_trained_not_by_the_updates() -> None:
    limit = CostLimit(cost_limit=0.0, lr=0.1, kp=0.0, anneal=0.0)
    once, twice = LagrangeMultiplier(limit), LagrangeMultiplier(limit)
    once.update(0.5, frames=4000)  # 0.1 * 0.5 * 4
    twice.update(0.5, frames=2000)
    twice.update(0.5, frames=2000)
    assert once.value == pytest.approx(twice.value) == pytest.approx(0.2)
    for frames in (0, -5, 1.5, True):
        with pytest.raises(ConfigError, match="frames"):
            once.update(0.5, frames=frames)  # type: ignore[arg-type]


@given(costs=st.lists(st.floats(0.0, 3.0), min_size=1, max_size=40))
@settings(max_examples=200, deadline=None)
def test_the_integral_rises_only_while_the_cost_exceeds_the_budget(costs: list[float]) -> None:
    limit = CostLimit(cost_limit=0.3, lr=0.2, kp=0.0, anneal=0.0)
    lagrange = LagrangeMultiplier(limit)
    before = lagrange.value
    for cost in costs:
        after = lagrange.update(cost)
        assert 0.0 <= after <= 1.0
        if cost > 0.3:
            assert after >= before
        elif cost < 0.3:
            assert after <= before
        before = after


def test_the_budget_falls_from_the_first_cost_to_the_limit_over_the_anneal_share() -> None:
    limit = CostLimit(cost_limit=0.1, lr=1.0, anneal=0.5)
    assert limit.budget(0.0, first_cost=None) == 0.1  # nothing measured yet
    assert limit.budget(0.0, first_cost=0.9) == pytest.approx(0.9)
    assert limit.budget(0.25, first_cost=0.9) == pytest.approx(0.5)
    assert limit.budget(0.5, first_cost=0.9) == pytest.approx(0.1)
    assert limit.budget(0.9, first_cost=0.9) == pytest.approx(0.1)
    assert limit.budget(0.1, first_cost=0.05) == 0.1  # a first cost within the limit
    assert CostLimit(cost_limit=0.1, anneal=0.0).budget(0.0, first_cost=0.9) == 0.1


def test_a_cost_that_falls_as_fast_as_the_annealed_budget_is_never_priced() -> None:
    lagrange = LagrangeMultiplier(CostLimit(cost_limit=0.0, lr=1.0, kp=0.0, anneal=0.5))
    for step in range(11):  # the cost falls 1 -> 0 over the first half, as the budget does
        progress = step / 20
        assert lagrange.update(max(0.0, 1.0 - 2 * progress), progress=progress) == 0.0
    # a cost that stays at 0.3 once the budget is 0 is priced: 1.0 * 0.3 a 1,000 frames
    assert lagrange.update(0.3, progress=0.6) == pytest.approx(0.3)
    assert lagrange.first_cost == 1.0


def test_a_budget_met_from_the_start_never_prices_compliance() -> None:
    lagrange = LagrangeMultiplier(CostLimit(cost_limit=0.1))
    for _ in range(50):
        assert lagrange.update(0.05) == 0.0


@given(costs=st.lists(st.floats(0.0, 2.0), min_size=2, max_size=20), cut=st.integers(1, 19))
@settings(max_examples=100, deadline=None)
def test_a_restored_multiplier_continues_as_the_original(costs: list[float], cut: int) -> None:
    limit = CostLimit(cost_limit=0.1, lr=0.3, kp=0.4, kd=0.2)
    whole = LagrangeMultiplier(limit)
    cut = min(cut, len(costs) - 1)
    first = LagrangeMultiplier(limit)
    for cost in costs[:cut]:
        whole.update(cost)
        first.update(cost)
    resumed = LagrangeMultiplier(limit, state=first.state_dict())
    assert resumed.state_dict() == first.state_dict()
    for cost in costs[cut:]:
        assert resumed.update(cost) == whole.update(cost)


@pytest.mark.parametrize(
    "state",
    [
        {},
        {"value": 0.5, "integral": 0.5, "last_cost": None, "first_cost": None},
        {"value": 2.0, "integral": 0.5, "last_cost": None, "first_cost": None, "updates": 1},
        {"value": 0.5, "integral": "x", "last_cost": None, "first_cost": None, "updates": 1},
        {"value": 0.5, "integral": 0.5, "last_cost": -1.0, "first_cost": None, "updates": 1},
        {"value": 0.5, "integral": 0.5, "last_cost": None, "first_cost": "1", "updates": 1},
        {"value": 0.5, "integral": 0.5, "last_cost": None, "first_cost": None, "updates": -1},
        {
            "value": 0.5,
            "integral": 0.5,
            "last_cost": None,
            "first_cost": None,
            "updates": 1,
            "extra": 0,
        },
        [0.5],
    ],
)
def test_a_damaged_saved_multiplier_is_refused(state: object) -> None:
    with pytest.raises(ConfigError, match="multiplier"):
        LagrangeMultiplier(CostLimit(), state=state)  # type: ignore[arg-type]


@pytest.mark.parametrize("cost", [-0.1, math.nan, math.inf])
def test_a_bad_measured_cost_is_refused(cost: float) -> None:
    with pytest.raises(ConfigError, match="episode cost"):
        LagrangeMultiplier(CostLimit()).update(cost)


def test_episode_costs_count_the_unsatisfied_specs_of_ended_episodes() -> None:
    accepting = np.array([[True, True], [False, True], [False, False], [False, False]])
    ended = np.array([True, True, True, False])
    assert episode_costs(accepting, ended).tolist() == [0.0, 1.0, 2.0, 0.0]


# ------------------------------------------------------------------ the bolt's price


def _bolt(scale: float, *, n_envs: int, tracking: str = "threshold") -> RestrainingBolt:
    """Two specs under the compliance scheme at ``scale``: a safety spec and one that can
    enter and leave acceptance, with progress shaping and low-confidence costs."""
    dfas = [always("e", ["e", "t"]), last_is("t"), F_E_AND_T]
    scheme = RewardScheme("compliance", scale=scale)
    specs = [
        scheme.apply(Spec(d.formula, name=f"s{i}", low_confidence_cost=0.5))
        for i, d in enumerate(dfas)
    ]
    shaping = ProgressShaping(dfas, scales=[scale] * len(dfas), gamma=1.0)
    return RestrainingBolt(
        specs, ["e", "t"], dfas=dfas, n_envs=n_envs, shaping=shaping, tracking=tracking
    )


probs_rows = st.lists(
    st.lists(st.sampled_from([0.0, 0.3, 0.5, 0.7, 0.95, 1.0]), min_size=2, max_size=2),
    min_size=2,
    max_size=2,
)


@given(
    trace=st.lists(
        st.tuples(probs_rows, st.lists(st.booleans(), min_size=2, max_size=2)),
        min_size=1,
        max_size=12,
    ),
    price=st.floats(0.0, 1.0),
    tracking=st.sampled_from(["threshold", "belief"]),
)
@settings(max_examples=120, deadline=None)
def test_a_bolt_at_price_p_pays_what_a_bolt_of_scale_p_times_s_pays(
    trace: list, price: float, tracking: str
) -> None:
    """Every term the price scales is linear in the scale: a bolt of scale 10 at price p
    pays exactly what a bolt of scale 10 p pays (states, acceptance, low-confidence
    charges and totals alike), over random traces with resets."""
    priced, scaled = (
        _bolt(10.0, n_envs=2, tracking=tracking),
        _bolt(max(10.0 * price, 1e-12), n_envs=2, tracking=tracking),
    )
    priced.price = price
    start = np.array([[0.95, 0.2], [0.3, 0.7]])
    a, b = priced.reset(start), scaled.reset(start)
    np.testing.assert_allclose(a.total, b.total, atol=1e-9)
    for probs, done in trace:
        probs, done = np.array(probs), np.array(done)
        a, b = priced.step(probs, done=done), scaled.step(probs, done=done)
        np.testing.assert_array_equal(a.next_states, b.next_states)
        np.testing.assert_allclose(a.low_confidence, b.low_confidence)
        np.testing.assert_allclose(a.total, b.total, atol=1e-9)
        if done.any():
            priced.reset(probs, env_mask=done)
            scaled.reset(probs, env_mask=done)


def test_price_zero_leaves_only_the_low_confidence_charges() -> None:
    bolt = _bolt(10.0, n_envs=1)
    bolt.price = 0.0
    bolt.reset(np.array([[0.95, 0.2]]))
    out = bolt.step(np.array([[0.7, 0.7]]), done=np.array([False]))  # e, t both low: entry
    assert out.total.tolist() == [out.low_confidence.sum()]
    assert out.low_confidence.sum() < 0
    out = bolt.step(np.array([[0.0, 0.0]]), done=np.array([True]))  # G(e) violated
    assert out.total.tolist() == [0.0]


def test_the_default_price_changes_nothing() -> None:
    bolt = _bolt(10.0, n_envs=1)
    assert bolt.price == 1.0
    bolt.reset(np.array([[0.95, 0.2]]))
    out = bolt.step(np.array([[0.95, 0.95]]), done=np.array([False]))
    # s1 (last t) enters acceptance: +10; s2 F(e & t) accepts: +10; s0 G(e) holds: 0
    assert out.terminal.tolist() == [[0.0, 10.0, 10.0]]


@pytest.mark.parametrize("price", [-0.5, math.nan, math.inf, "1", True])
def test_a_bad_price_is_refused(price: object) -> None:
    bolt = _bolt(10.0, n_envs=1)
    with pytest.raises(ConfigError, match="price"):
        bolt.price = price  # type: ignore[assignment]
    assert bolt.price == 1.0


def test_a_price_over_decades_spans_them_geometrically_from_the_pid_output() -> None:
    limit = CostLimit(decades=3)
    # by hand: (10 ** (3u) - 1) / 999; none at u = 0, the whole scale at u = 1
    assert limit.price(0.0) == 0.0
    assert limit.price(1.0) == 1.0
    assert limit.price(2 / 3) == pytest.approx(99 / 999)
    assert limit.price(1 / 3) == pytest.approx(9 / 999)
    # a cost just above the budget is priced just above 0 (continuous at 0)
    assert 0 < limit.price(1e-6) < 1e-7
    # the multiplier applies it to what its PID gives: a cost 0.5 above a fixed budget
    lagrange = LagrangeMultiplier(CostLimit(cost_limit=0.0, lr=0.5, kp=0.0, anneal=0.0, decades=3))
    assert lagrange.update(0.5) == pytest.approx((10**0.75 - 1) / 999)
    # the linear price (decades 0) is the PID's output itself, and few decades are near it
    assert CostLimit().price(0.4) == 0.4
    assert CostLimit(decades=0.01).price(0.4) == pytest.approx(0.4, abs=0.01)


@settings(max_examples=60, deadline=None)
@given(st.floats(0.0, 6.0), st.floats(0.0, 1.0), st.floats(0.0, 1.0))
def test_the_price_rises_with_the_pid_output_from_0_to_the_scale(
    decades: float, u: float, v: float
) -> None:
    limit = CostLimit(decades=decades)
    lo, hi = sorted((u, v))
    assert 0.0 <= limit.price(lo) <= limit.price(hi) <= 1.0 + 1e-12
    assert limit.price(0.0) == 0.0 and limit.price(1.0) == pytest.approx(1.0)


def test_negative_decades_are_refused_by_name() -> None:
    with pytest.raises(ConfigError, match=r"bolt\.constraint\.decades must be >= 0"):
        CostLimit(decades=-1)
