"""Belief tracking: bad input, hand-computed beliefs, payments, and that beliefs stay
distributions."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from noisybolt.bolt import BeliefSettings, ProgressShaping, RestrainingBolt, Spec
from noisybolt.errors import BaseRateError, ConfidenceLevelError, ConfigError, UnknownNameError
from noisybolt.logic import DFA, compile_ltlf


def eventually(name: str = "x") -> DFA:
    """``F(x)``: state 0 until x, then the accepting sink 1."""
    return DFA.from_function(
        [name],
        n_states=2,
        initial_state=0,
        accepting=[False, True],
        delta=lambda q, m: 1 if q == 1 or m & 1 else 0,
    )


def always(name: str = "e") -> DFA:
    """``G(e)``: accepting state 0 while e, else the rejecting sink 1."""
    return DFA.from_function(
        [name],
        n_states=2,
        initial_state=0,
        accepting=[True, False],
        delta=lambda q, m: 0 if q == 0 and m & 1 else 1,
    )


def spec(formula: str, timing: str = "every_step", cost: float = 0.5) -> Spec:
    return Spec(formula, terminal_reward=1.0, low_confidence_cost=cost, reward_timing=timing)  # type: ignore[arg-type]


def belief_bolt(dfa: DFA, formula: str, n_envs: int = 1, **settings: object) -> RestrainingBolt:
    return RestrainingBolt(
        [spec(formula)],
        dfa.fluents,
        dfas=[dfa],
        n_envs=n_envs,
        tracking="belief",
        belief=BeliefSettings(**settings),  # type: ignore[arg-type]
    )


# ---------------------------------------------------------------------- bad input
def test_unknown_tracking_mode_is_a_named_error() -> None:
    with pytest.raises(UnknownNameError, match="'threshold', 'belief'"):
        RestrainingBolt([spec("F(x)")], ["x"], dfas=[eventually()], tracking="bayes")  # type: ignore[arg-type]


def test_min_dwell_must_be_a_positive_integer() -> None:
    for bad in (0, 1.5, True):
        with pytest.raises(ConfigError, match="min_dwell"):
            BeliefSettings(min_dwell=bad)  # type: ignore[arg-type]


@pytest.mark.parametrize("level", [0.5, 1.0, 0.3, 1.2, math.nan, True])
def test_confidence_level_outside_half_to_one_is_refused(level: float) -> None:
    with pytest.raises(ConfidenceLevelError, match=r"outside \(0.5, 1\)"):
        BeliefSettings(confidence=level)


@pytest.mark.parametrize("rates", [-0.1, 1.5, math.nan, (0.2, 1.01), {"x": -1.0}, "high"])
def test_base_rates_outside_zero_one_are_refused(rates: object) -> None:
    with pytest.raises(BaseRateError, match=r"\[0, 1\]"):
        BeliefSettings(base_rates=rates)  # type: ignore[arg-type]
    with pytest.raises(BaseRateError):
        BeliefSettings(training_prior=rates)  # type: ignore[arg-type]


def test_base_rates_zero_and_one_are_legal() -> None:
    bolt = belief_bolt(eventually(), "F(x)", base_rates=(0.0,))
    bolt.reset(np.array([[0.99]]))
    assert np.isfinite(bolt.beliefs).all()
    belief_bolt(eventually(), "F(x)", base_rates=1.0).reset(np.array([[0.01]]))


def test_belief_settings_need_belief_tracking() -> None:
    with pytest.raises(ConfigError, match="tracking is not 'belief'"):
        RestrainingBolt([spec("F(x)")], ["x"], dfas=[eventually()], belief=BeliefSettings())


def test_per_fluent_settings_must_match_the_vocabulary() -> None:
    with pytest.raises(ConfigError, match="one value per fluent"):
        belief_bolt(eventually(), "F(x)", base_rates=(0.1, 0.2))
    with pytest.raises(ConfigError, match="unknown fluent"):
        belief_bolt(eventually(), "F(x)", monotone=("y",))


def test_proportional_cost_is_refused_under_belief_tracking() -> None:
    with pytest.raises(ConfigError, match="proportional"):
        RestrainingBolt(
            [spec("F(x)")],
            ["x"],
            dfas=[eventually()],
            tracking="belief",
            cost_mode="proportional",
        )


# ---------------------------------------------------------------------- hand-computed
def test_first_frame_posterior_is_the_base_rate_corrected_detector() -> None:
    # Training prior 0.5, play base rate 0.2: odds(x | frame) = 4 (p = 0.8) * 0.25 = 1.
    bolt = belief_bolt(eventually(), "F(x)", base_rates=(0.2,))
    bolt.reset(np.array([[0.8]]))
    assert bolt.beliefs[0].tolist() == pytest.approx([0.5, 0.5])
    # With the base rate equal to the training prior the detector is taken as it is.
    bolt = belief_bolt(eventually(), "F(x)")
    bolt.reset(np.array([[0.8]]))
    assert bolt.beliefs[0].tolist() == pytest.approx([0.2, 0.8])


def test_one_step_hand_computed_with_persistence() -> None:
    # pi = 0.5, s = 0.3: P(on | off) = 0.15. Frame 1 p = 0.5 (no evidence): x1 off, or
    # just on (0.5 each), accepting 0.5. min_dwell 2: x just on stays on at frame 2.
    # Frame 2 p = 0.8 (ratio 4): before the evidence, x2 on with q = 1 always, from x1 on
    # (0.5) or from off (0.5 * 0.15); x2 off only from x1 off (0.5 * 0.85), q = 0.
    # Unnormalised: on (0.5 + 0.075) * 4 = 2.3; off: 0.425.
    bolt = belief_bolt(eventually(), "F(x)", switch_rate=0.3)
    bolt.reset(np.array([[0.5]]))
    bolt.step(np.array([[0.8]]))
    total = 2.3 + 0.425
    assert bolt.beliefs[0].tolist() == pytest.approx([0.425 / total, 2.3 / total])


def test_doubtful_frame_is_taken_back_by_clear_frames_after_it() -> None:
    # IBU would keep the mass one doubtful frame moved into F(x)'s sink for good.
    bolt = belief_bolt(eventually(), "F(x)", base_rates=(0.1,))
    bolt.reset(np.array([[0.02]]))
    bolt.step(np.array([[0.7]]))
    after_doubt = bolt.beliefs[0, 1]
    for _ in range(5):
        bolt.step(np.array([[0.02]]))
    assert after_doubt > 0.1
    assert bolt.beliefs[0, 1] < after_doubt / 5


def test_frames_without_evidence_leave_the_prior_of_the_truth_chain() -> None:
    # p = the training prior says nothing: P(F(x) by step t) = 1 - (1 - pi)(1 - s pi)^t.
    bolt = belief_bolt(eventually(), "F(x)", base_rates=(0.05,), switch_rate=0.15)
    bolt.reset(np.array([[0.5]]))
    for t in range(1, 61):
        bolt.step(np.array([[0.5]]))
        assert bolt.beliefs[0, 1] == pytest.approx(1 - 0.95 * (1 - 0.15 * 0.05) ** t)


def test_weak_evidence_below_the_bound_does_not_accumulate_as_ibu_does() -> None:
    # Ratio 0.52 / 0.48 = 1.08 per frame, below (1 - s pi) / (1 - s (1 - pi)) = 1.157:
    # "x stayed on" never gains on "x stayed off". IBU moves P(x | frame) of the
    # remaining mass into F(x)'s sink on every frame.
    bolt = belief_bolt(eventually(), "F(x)", base_rates=(0.05,), switch_rate=0.15)
    p = 0.52
    out = bolt.reset(np.array([[p]]))
    for _ in range(60):
        out = bolt.step(np.array([[p]]))
    odds = 0.05 / 0.95 * p / (1 - p)
    ibu = 1 - (1 - odds / (1 + odds)) ** 61
    assert ibu > 0.95
    assert bolt.beliefs[0, 1] < 0.65
    assert not out.accepting[0, 0]


def test_min_dwell_two_keeps_unseen_one_frame_blips_from_adding_up() -> None:
    # G(!x) over 150 frames that all say "no" (p = 0.05): with a one-frame blip allowed,
    # each frame leaves s * pi * 0.05 / 0.95 for "x was true unseen"; with two frames
    # needed, that chance is squared.
    kept = {}
    for dwell in (1, 2):
        bolt = RestrainingBolt(
            [spec("G(!x)")],
            ["x"],
            dfas=[compile_ltlf("G(!x)", ["x"])],
            tracking="belief",
            belief=BeliefSettings(base_rates=(0.08,), switch_rate=0.5, min_dwell=dwell),
        )
        out = bolt.reset(np.array([[0.05]]))
        for _ in range(150):
            out = bolt.step(np.array([[0.05]]))
        kept[dwell] = (bolt.beliefs[0, bolt.dfas[0].initial_state], bool(out.accepting[0, 0]))
    assert kept[1][0] < 0.85 and not kept[1][1]
    assert kept[2][0] > 0.97 and kept[2][1]


def test_min_dwell_two_refutes_a_single_glitch_frame() -> None:
    # Without persistence (s = 1) and one-frame truths allowed, this is IBU: the mass the
    # glitch moved into F(x)'s sink stays. Needing two frames, the next frame refutes it.
    accepting = {}
    for dwell in (1, 2):
        bolt = belief_bolt(
            eventually(), "F(x)", base_rates=(0.08,), switch_rate=1.0, min_dwell=dwell
        )
        bolt.reset(np.array([[0.02]]))
        bolt.step(np.array([[0.88]]))
        bolt.step(np.array([[0.02]]))
        accepting[dwell] = bolt.beliefs[0, 1]
    assert accepting[1] > 0.3
    assert accepting[2] < 0.05


def test_a_glitch_on_the_reset_frame_is_refuted_as_one_on_any_other_frame() -> None:
    # The same confident false frame, first on the reset frame, then on a later one,
    # followed by clear frames: with two frames needed, both are taken back. (A fluent
    # on at reset used to be "held", so the reset-frame glitch latched F(x): 0.92.)
    after = {}
    for at in (0, 3):
        bolt = belief_bolt(eventually(), "F(x)", base_rates=(0.1,))
        frames = np.full((10, 1, 1), 0.02)
        frames[at] = 0.97
        bolt.reset(frames[0])
        for frame in frames[1:]:
            bolt.step(frame)
        after[at] = bolt.beliefs[0, 1]
    assert after[0] < 0.05 and after[3] < 0.05
    # While a fluent truly on at reset is believed from its second frame on.
    bolt = belief_bolt(eventually(), "F(x)", base_rates=(0.1,))
    bolt.reset(np.array([[0.97]]))
    bolt.step(np.array([[0.97]]))
    assert bolt.beliefs[0, 1] > 0.9


def test_monotone_fluent_is_refuted_by_the_frames_after_a_false_positive() -> None:
    # A brick that is gone stays gone: one confident false frame, then clear frames.
    bolt = belief_bolt(eventually(), "F(x)", base_rates=(0.05,), monotone=("x",))
    bolt.reset(np.array([[0.02]]))
    bolt.step(np.array([[0.95]]))
    spike = bolt.beliefs[0, 1]
    for _ in range(3):
        bolt.step(np.array([[0.02]]))
    assert spike > 0.2
    assert bolt.beliefs[0, 1] < 0.01


def test_clear_frames_are_believed() -> None:
    bolt = belief_bolt(eventually(), "F(x)", base_rates=(0.05,))
    bolt.reset(np.array([[0.01]]))
    out = bolt.step(np.array([[0.999]]))
    out = bolt.step(np.array([[0.999]]))
    assert out.accepting[0, 0] and out.next_states[0, 0] == 1
    for _ in range(20):
        out = bolt.step(np.array([[0.01]]))
    assert out.accepting[0, 0]  # the visit happened; x being over does not undo it


# ---------------------------------------------------------------------- payments
def test_low_confidence_charge_as_algorithm_1_on_a_sure_state() -> None:
    # G(e) from its initial state: e on the edge, read in the low band: one charge.
    bolt = RestrainingBolt([spec("G(e)")], ["e"], dfas=[always()], tracking="belief")
    out = bolt.reset(np.array([[0.8]]))
    assert out.low_confidence.tolist() == [[-0.5]]
    assert out.n_low.tolist() == [[1]]
    # P(accepting) = 0.8 < 0.9: not paid, and not accepting for info["dfa_accepting"].
    assert out.terminal.tolist() == [[0.0]]
    assert not out.accepting[0, 0]
    assert out.total.tolist() == [-0.5]


def test_on_entry_is_paid_once_per_confident_entry() -> None:
    dfa = eventually()
    bolt = RestrainingBolt(
        [spec("F(x)", "on_entry", cost=0.0)], ["x"], dfas=[dfa], tracking="belief"
    )
    bolt.reset(np.array([[0.01]]))
    paid = [bolt.step(np.array([[p]])).terminal[0, 0] for p in [0.999] * 6 + [0.01] * 6]
    assert sum(paid) == 1.0


def test_every_step_is_paid_on_each_confident_step_episode_end_and_on_change_once() -> None:
    probs = [0.999] * 4 + [0.01] * 3
    for timing in ("every_step", "episode_end", "on_change"):
        bolt = RestrainingBolt(
            [spec("F(x)", timing, cost=0.0)], ["x"], dfas=[eventually()], tracking="belief"
        )
        bolt.reset(np.array([[0.01]]))
        outs = [bolt.step(np.array([[p]]), done=i == len(probs) - 1) for i, p in enumerate(probs)]
        paid = np.array([o.terminal[0, 0] for o in outs])
        accepting = np.array([o.accepting[0, 0] for o in outs])
        if timing == "every_step":
            np.testing.assert_array_equal(paid, accepting.astype(float))
        elif timing == "episode_end":
            assert paid.tolist() == [0.0] * (len(probs) - 1) + [1.0]
        else:  # once, when the bolt is first confident of F(x)
            first = int(np.argmax(accepting))
            assert accepting.any() and first < len(probs) - 1
            assert paid.tolist() == [1.0 if i == first else 0.0 for i in range(len(probs))]


def test_on_change_pays_no_acceptance_the_belief_starts_with() -> None:
    # G(e) on a clear first frame: the bolt is confident of acceptance from the start.
    # on_entry pays that landing; on_change takes it as the episode's baseline.
    first = {}
    for timing in ("on_entry", "on_change"):
        bolt = RestrainingBolt(
            [spec("G(e)", timing, cost=0.0)], ["e"], dfas=[always("e")], tracking="belief"
        )
        out = bolt.reset(np.array([[0.999]]))
        assert out.accepting.tolist() == [[True]]
        first[timing] = out.total.tolist()
    assert first == {"on_entry": [1.0], "on_change": [0.0]}


def test_on_change_takes_back_what_the_belief_doubts_and_pays_it_again() -> None:
    # Two fairly confident frames of x make the bolt believe F(x) (paid); clear frames
    # then pull the belief back (min_dwell allows a glitch: taken back), and confident
    # ones push it up again (paid again): the sum is what episode_end pays.
    paid = {}
    probs = [0.98, 0.98] + [0.001] * 12 + [0.999] * 4
    for timing in ("on_change", "episode_end"):
        bolt = RestrainingBolt(
            [spec("F(x)", timing, cost=0.0)],
            ["x"],
            dfas=[eventually()],
            tracking="belief",
            belief=BeliefSettings(base_rates=0.01),
        )
        bolt.reset(np.array([[0.01]]))
        outs = [bolt.step(np.array([[p]]), done=i == len(probs) - 1) for i, p in enumerate(probs)]
        believed = "".join(str(int(o.accepting[0, 0])) for o in outs)
        assert believed == "01" + "0" * 12 + "1111"  # confident, doubted, confident again
        paid[timing] = [o.terminal[0, 0] for o in outs]
    assert paid["on_change"] == [0.0, 1.0, -1.0] + [0.0] * 11 + [1.0, 0.0, 0.0, 0.0]
    assert sum(paid["on_change"]) == sum(paid["episode_end"]) == 1.0


def test_decisive_frames_give_threshold_tracking_states_and_rewards() -> None:
    # With frames far beyond any doubt the belief is one-hot on Algorithm 1's state
    # (min_dwell=1: these random traces have one-frame truths).
    fluents = ["a", "b"]
    formulas = ["F(a & X(F(b)))", "G(a -> F(b))"]
    dfas = [compile_ltlf(f, fluents) for f in formulas]
    specs = [spec(f, cost=0.0) for f in formulas]
    rng = np.random.default_rng(1)
    frames = rng.random((60, 8, 2)) < 0.4
    probs = np.where(frames, 1.0, 0.0)
    bolts = {
        mode: RestrainingBolt(
            specs,
            fluents,
            dfas=dfas,
            n_envs=8,
            tracking=mode,
            belief=BeliefSettings(max_log_ratio=40.0, base_rates=0.5, min_dwell=1)
            if mode == "belief"
            else None,
        )
        for mode in ("threshold", "belief")
    }
    outs = {mode: bolt.reset(probs[0]) for mode, bolt in bolts.items()}
    for t in range(1, len(probs)):
        np.testing.assert_array_equal(outs["belief"].next_states, outs["threshold"].next_states)
        np.testing.assert_array_equal(outs["belief"].accepting, outs["threshold"].accepting)
        np.testing.assert_allclose(outs["belief"].total, outs["threshold"].total)
        outs = {mode: bolt.step(probs[t]) for mode, bolt in bolts.items()}


def test_progress_shaping_in_expectation_equals_shaping_of_sure_states() -> None:
    fluents = ["a", "b"]
    dfas = [compile_ltlf("F(a & X(F(b)))", fluents)]
    specs = [
        Spec(
            "F(a & X(F(b)))",
            terminal_reward=10.0,
            low_confidence_cost=0.0,
            reward_timing="episode_end",
        )
    ]
    rng = np.random.default_rng(2)
    probs = np.where(rng.random((30, 4, 2)) < 0.3, 1.0, 0.0)
    outs = {}
    for mode in ("threshold", "belief"):
        shaping = ProgressShaping(dfas, scales=[10.0], gamma=1.0)
        bolt = RestrainingBolt(
            specs,
            fluents,
            dfas=dfas,
            n_envs=4,
            shaping=shaping,
            tracking=mode,
            belief=BeliefSettings(max_log_ratio=40.0, base_rates=0.5, min_dwell=1)
            if mode == "belief"
            else None,
        )
        rows = [bolt.reset(probs[0]).progress]
        rows += [bolt.step(probs[t], done=t == 29).progress for t in range(1, 30)]
        outs[mode] = np.array(rows)
    np.testing.assert_allclose(outs["belief"], outs["threshold"], atol=1e-6)


# ---------------------------------------------------------------------- distributions
def test_beliefs_stay_distributions_over_1e5_random_steps() -> None:
    fluents = ["a", "b", "c"]
    formulas = ["F(a & X(F(b)))", "G(!c)", "a U b", "G(a -> X(b))"]
    dfas = [compile_ltlf(f, fluents) for f in formulas]
    n_envs, steps = 100, 1000  # 10^5 environment-steps
    bolt = RestrainingBolt(
        [spec(f) for f in formulas],
        fluents,
        dfas=dfas,
        n_envs=n_envs,
        tracking="belief",
        belief=BeliefSettings(monotone=("c",), base_rates=(0.01, 0.5, 0.999)),
    )
    rng = np.random.default_rng(0)

    def frame() -> np.ndarray:
        # Extremes included: exact 0 and 1, and values a hair from them.
        raw = rng.random((n_envs, len(fluents)))
        pick = rng.random(raw.shape)
        return np.where(pick < 0.1, 0.0, np.where(pick > 0.9, 1.0, raw))

    offsets = np.cumsum((0, *bolt.n_states))
    bolt.reset(frame())
    for _ in range(steps):
        done = rng.random(n_envs) < 0.02
        bolt.step(frame(), done=done)
        if done.any():
            bolt.reset(frame(), env_mask=done)
        beliefs = bolt.beliefs
        assert beliefs.min() >= 0.0
        sums = np.add.reduceat(beliefs, offsets[:-1], axis=1)
        assert np.abs(sums - 1.0).max() <= 1e-6


@settings(max_examples=40, deadline=None)
@given(
    probs=st.lists(st.lists(st.floats(0.0, 1.0), min_size=2, max_size=2), min_size=1, max_size=40),
    switch=st.floats(0.01, 1.0),
    rate=st.floats(0.0, 1.0),
)
def test_beliefs_are_distributions_for_any_frames(
    probs: list[list[float]], switch: float, rate: float
) -> None:
    fluents = ["a", "b"]
    dfa = compile_ltlf("F(a) & G(a -> X(!b))", fluents)
    bolt = RestrainingBolt(
        [spec("F(a) & G(a -> X(!b))")],
        fluents,
        dfas=[dfa],
        tracking="belief",
        belief=BeliefSettings(switch_rate=switch, base_rates=rate),
    )
    array = np.array(probs)
    bolt.reset(array[:1])
    for row in array[1:]:
        bolt.step(row[None])
        beliefs = bolt.beliefs[0]
        assert beliefs.min() >= 0.0
        assert beliefs.sum() == pytest.approx(1.0, abs=1e-6)
        assert bolt.states[0, 0] == int(np.argmax(beliefs))


def test_env_mask_moves_only_the_masked_rows() -> None:
    bolt = belief_bolt(eventually(), "F(x)", n_envs=3)
    bolt.reset(np.array([[0.01], [0.01], [0.01]]))
    before = bolt.beliefs.copy()
    out = bolt.step(np.array([[0.999], [0.999], [0.999]]), env_mask=np.array([True, False, True]))
    np.testing.assert_array_equal(bolt.beliefs[1], before[1])
    assert out.total[1] == 0.0
    assert bolt.beliefs[0, 1] > 0.8 and bolt.beliefs[2, 1] > 0.8


def test_a_spec_too_large_to_track_is_refused_with_what_to_do() -> None:
    fluents = [f"a{i}" for i in range(7)]
    formula = f"F({' & '.join(fluents)})"  # 2 states * 3**7 cells at min_dwell 2
    with pytest.raises(ConfigError, match="split the spec"):
        RestrainingBolt(
            [spec(formula)], fluents, dfas=[compile_ltlf(formula, fluents)], tracking="belief"
        )


def test_a_rare_monotone_event_is_believed_after_a_few_clear_frames() -> None:
    # A brick random play never reached (base rate floored at 0.01) that an agent clears.
    bolt = belief_bolt(eventually(), "F(x)", base_rates=(0.01,), monotone=("x",))
    out = bolt.reset(np.array([[0.01]]))
    accepted = []
    for _ in range(4):
        out = bolt.step(np.array([[0.99]]))
        accepted.append(bool(out.accepting[0, 0]))
    assert accepted == [False, True, True, True]
