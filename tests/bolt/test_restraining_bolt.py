"""RestrainingBolt: reset, the carried first reward, reward timing and auto-reset."""

from __future__ import annotations

import numpy as np
import pytest
from bolt_helpers import F_E_AND_T, always, eventually_all, last_is, prob_matrices, random_dfas
from hypothesis import given
from hypothesis import strategies as st

import noisybolt.bolt.restraining_bolt as restraining_bolt
from noisybolt.bolt import REWARD_TIMINGS, RestrainingBolt, Spec
from noisybolt.errors import ConfigError, SpecSyntaxError, UnknownFluentError
from noisybolt.logic import DFA

T, C = 10.0, 2.0
LOW, HIGH, ABSENT = 0.7, 0.95, 0.1


def f_e_and_t_bolt(n_envs: int = 1, **kwargs: object) -> RestrainingBolt:
    spec = Spec("F(e & t)", terminal_reward=T, low_confidence_cost=C, **kwargs)  # type: ignore[arg-type]
    return RestrainingBolt([spec], ["e", "t"], dfas=[F_E_AND_T], n_envs=n_envs)


def p(*rows: tuple[float, ...]) -> np.ndarray:
    return np.array(rows, dtype=np.float64)


def run_last_is(timing: str, trace: list[float], cost: float = 0.0) -> list[float]:
    """Totals of reset + steps for 'the last letter has e' (1 on acceptance), done at the end."""
    spec = Spec("last e", terminal_reward=1.0, low_confidence_cost=cost, reward_timing=timing)  # type: ignore[arg-type]
    bolt = RestrainingBolt([spec], ["e"], dfas=[last_is("e")])
    totals = [float(bolt.reset(p((trace[0],))).total[0])]
    for i, prob in enumerate(trace[1:], start=2):
        done = np.array([i == len(trace)])
        totals.append(float(bolt.step(p((prob,)), done=done).total[0]))
    return totals


# ---------------------------------------------------------------- reset and carried reward
def test_reset_takes_the_first_transition_and_carries_its_reward() -> None:
    bolt = f_e_and_t_bolt()
    first = bolt.reset(p((LOW, HIGH)))
    assert first.next_states.tolist() == [[1]]
    assert first.total.tolist() == [T - C]
    assert bolt.states.tolist() == [[1]] and bolt.pending.tolist() == [T - C]
    out = bolt.step(p((ABSENT, ABSENT)))
    assert out.carried.tolist() == [T - C]
    assert out.total.tolist() == [T + T - C]  # accepting sink pays T, plus the carried reward
    assert bolt.pending.tolist() == [0.0]
    assert bolt.step(p((ABSENT, ABSENT))).total.tolist() == [T]


def test_reset_on_a_plain_observation_carries_nothing() -> None:
    bolt = f_e_and_t_bolt()
    assert bolt.reset(p((ABSENT, ABSENT))).total.tolist() == [0.0]
    out = bolt.step(p((0.6, HIGH)))
    assert (out.next_states.tolist(), out.total.tolist()) == ([[1]], [T - C])


def test_a_second_reset_abandons_the_pending_reward() -> None:
    bolt = f_e_and_t_bolt()
    bolt.reset(p((HIGH, HIGH)))
    assert bolt.pending.tolist() == [T]
    bolt.reset(p((ABSENT, ABSENT)))
    assert bolt.pending.tolist() == [0.0] and bolt.states.tolist() == [[0]]


# ---------------------------------------------------------------- reward timing
def test_reward_timing_hand_totals() -> None:
    # p(e) read by: reset, step 1, ..., step 5 (done). Step 1 adds the reward carried from
    # reset. every_step pays whenever e was last seen; on_entry when e returns after !e.
    trace = [HIGH, ABSENT, HIGH, HIGH, ABSENT, HIGH]
    assert run_last_is("every_step", trace) == [1.0, 0.0 + 1.0, 1.0, 1.0, 0.0, 1.0]
    assert run_last_is("on_entry", trace) == [1.0, 0.0 + 1.0, 1.0, 0.0, 0.0, 1.0]
    assert run_last_is("episode_end", trace) == [0.0, 0.0, 0.0, 0.0, 0.0, 1.0]
    # on_change pays each entry after the first frame and takes it back on each exit; the
    # first frame's acceptance is the baseline (nothing carried): the sum is episode_end's
    # less what the start already accepted, 1 - 1
    assert run_last_is("on_change", trace) == [0.0, -1.0 + 0.0, 1.0, 0.0, -1.0, 1.0]
    # episode ending while not accepting pays nothing
    assert run_last_is("episode_end", [HIGH, HIGH, ABSENT]) == [0.0, 0.0, 0.0]
    assert run_last_is("on_change", [HIGH, HIGH, ABSENT]) == [0.0, 0.0, -1.0]
    assert run_last_is("on_change", [ABSENT, HIGH, ABSENT]) == [0.0, 1.0, -1.0]


def on_change_and_end_totals(trace: list[tuple[float, float]]) -> dict[str, list[float]]:
    """Totals of reset + steps of F(e & t) (its acceptance is a sink), done at the end."""
    totals = {}
    for timing in ("on_change", "episode_end"):
        bolt = f_e_and_t_bolt(reward_timing=timing)  # no low-band frames: no cost
        out = [float(bolt.reset(p(trace[0])).total[0])]
        for i, probs in enumerate(trace[1:], start=2):
            out.append(float(bolt.step(p(probs), done=i == len(trace)).total[0]))
        totals[timing] = out
    return totals


def test_on_change_pays_an_acceptance_when_it_comes_and_nothing_at_the_end() -> None:
    seen, none = (HIGH, HIGH), (ABSENT, ABSENT)
    totals = on_change_and_end_totals([none, none, seen, none, none])
    assert totals["on_change"] == [0.0, 0.0, T, 0.0, 0.0]
    assert totals["episode_end"] == [0.0, 0.0, 0.0, 0.0, T]
    # accepting on the reset frame: the episode starts there, no action earned it, and
    # on_change pays nothing for it (episode_end still pays the accepted episode)
    totals = on_change_and_end_totals([seen, none, none])
    assert totals["on_change"] == [0.0, 0.0, 0.0]
    assert totals["episode_end"] == [0.0, 0.0, T]
    # never accepting: neither pays
    assert on_change_and_end_totals([none, none, none]) == {
        "on_change": [0.0, 0.0, 0.0],
        "episode_end": [0.0, 0.0, 0.0],
    }


def test_on_change_takes_back_an_acceptance_that_is_lost() -> None:
    # F(e) & G(!t): accepting once e is seen, until t is (for good).
    dfa = DFA.from_function(
        ["e", "t"],
        n_states=3,
        initial_state=0,
        accepting=[False, True, False],
        delta=lambda q, m: 2 if (q == 2 or m & 2) else (1 if (q == 1 or m & 1) else 0),
    )
    spec = Spec("F(e) & G(!t)", terminal_reward=T, low_confidence_cost=0, reward_timing="on_change")
    bolt = RestrainingBolt([spec], ["e", "t"], dfas=[dfa])
    bolt.reset(p((ABSENT, ABSENT)))
    assert bolt.step(p((HIGH, ABSENT))).total.tolist() == [T]
    assert bolt.step(p((ABSENT, ABSENT))).total.tolist() == [0.0]
    assert bolt.step(p((ABSENT, HIGH)), done=True).total.tolist() == [-T]


@given(st.data())
def test_on_change_and_episode_end_pay_the_same_sum_and_nothing_is_left_at_the_end(
    data: st.DataObject,
) -> None:
    fluents = ["f0", "f1"]
    dfa = data.draw(random_dfas(fluents=fluents, max_states=4))
    n_steps = data.draw(st.integers(1, 8))
    probs = [data.draw(prob_matrices(1, 2)) for _ in range(n_steps + 1)]
    truncated = data.draw(st.booleans())
    paid, accepting = {}, {}
    for timing in ("on_change", "episode_end"):
        spec = Spec("s", terminal_reward=3.0, low_confidence_cost=0.0, reward_timing=timing)  # type: ignore[arg-type]
        bolt = RestrainingBolt([spec], fluents, dfas=[dfa], pay_at_truncation=False)
        outs = [bolt.reset(probs[0])]
        for i in range(1, n_steps + 1):
            end = i == n_steps
            outs.append(bolt.step(probs[i], done=end, truncated=end and truncated))
        paid[timing] = np.array([o.terminal[0, 0] for o in outs])
        accepting[timing] = [bool(o.accepting[0, 0]) for o in outs]
    changes, at_end = paid["on_change"], paid["episode_end"]
    # what is held after each step is what the DFA accepts then, less what it accepted on
    # the first frame (the baseline, never paid): paid as it is gained
    start = accepting["on_change"][0]
    assert np.cumsum(changes).tolist() == [3.0 * (a - start) for a in accepting["on_change"]]
    if not truncated:  # (a cut episode's end is not paid at all under episode_end)
        assert changes.sum() == at_end.sum() - 3.0 * start


@pytest.mark.parametrize("timing", REWARD_TIMINGS)
def test_the_low_confidence_cost_is_charged_on_every_transition_under_every_timing(
    timing: str,
) -> None:
    totals = run_last_is(timing, [LOW, LOW, LOW], cost=0.25)
    paid = {
        "every_step": [1, 1, 1],
        "on_entry": [1, 0, 0],
        "episode_end": [0, 0, 1],
        "on_change": [0, 0, 0],  # accepting from the first frame: the baseline
    }[timing]
    expected = [paid[0] - 0.25, paid[1] - 0.25 + paid[0] - 0.25, paid[2] - 0.25]
    assert totals == pytest.approx(expected)


def test_on_entry_pays_a_first_observation_that_satisfies_an_initially_accepting_spec() -> None:
    spec = Spec("G(e)", terminal_reward=1.0, low_confidence_cost=0.0, reward_timing="on_entry")
    bolt = RestrainingBolt([spec], ["e"], dfas=[always("e")])
    assert bolt.reset(p((HIGH,))).total.tolist() == [1.0]
    assert bolt.step(p((HIGH,))).total.tolist() == [1.0]  # carried only
    assert bolt.step(p((HIGH,))).total.tolist() == [0.0]


def test_several_specs_add_up_and_expose_their_states() -> None:
    specs = [
        Spec("F(e & t)", terminal_reward=T, low_confidence_cost=C),
        Spec("G(e)", terminal_reward=1.0, low_confidence_cost=0.5, reward_timing="on_entry"),
    ]
    bolt = RestrainingBolt(specs, ["e", "t"], dfas=[F_E_AND_T, always("e", ["e", "t"])])
    assert bolt.n_states == (2, 2) and bolt.n_specs == 2
    first = bolt.reset(p((LOW, HIGH)))
    assert first.reward.tolist() == [[T - C, 1.0 - 0.5]]
    out = bolt.step(p((HIGH, ABSENT)))
    assert out.reward.tolist() == [[T, 0.0]]
    assert out.total.tolist() == [T + (T - C) + 0.5]
    assert bolt.states.tolist() == [[1, 0]]


def test_states_and_pending_are_copies() -> None:
    bolt = f_e_and_t_bolt()
    bolt.reset(p((HIGH, HIGH)))
    bolt.states[0, 0] = 0
    bolt.pending[0] = 99.0
    assert bolt.states.tolist() == [[1]] and bolt.pending.tolist() == [T]


# ---------------------------------------------------------------- violation
def make_violation_bolt(end_on_violation: bool) -> RestrainingBolt:
    specs = [
        Spec("G(e)", terminal_reward=1.0, low_confidence_cost=0.0),
        Spec("F(t)", terminal_reward=5.0, low_confidence_cost=0.0, reward_timing="episode_end"),
    ]
    return RestrainingBolt(
        specs,
        ["e", "t"],
        dfas=[always("e", ["e", "t"]), eventually_all(["t"])],
        end_on_violation=end_on_violation,
    )


def test_violation_is_reported_but_does_not_end_the_episode_by_default() -> None:
    bolt = make_violation_bolt(end_on_violation=False)
    bolt.reset(p((HIGH, HIGH)))
    out = bolt.step(p((ABSENT, HIGH)))
    assert out.violated.tolist() == [[True, False]]
    assert out.terminate.tolist() == [False]
    assert out.total.tolist() == [0.0 + 0.0 + 1.0]  # only the carried G(e) reward
    assert bolt.needs_reset.tolist() == [False]
    bolt.step(p((HIGH, HIGH)))  # the episode goes on, G(e) stays violated


def test_end_on_violation_terminates_and_pays_episode_end_specs() -> None:
    bolt = make_violation_bolt(end_on_violation=True)
    assert bolt.end_on_violation
    bolt.reset(p((HIGH, HIGH)))
    out = bolt.step(p((ABSENT, HIGH)))
    assert out.terminate.tolist() == [True]
    assert out.total.tolist() == [0.0 + 5.0 + 1.0]
    assert bolt.needs_reset.tolist() == [True]
    with pytest.raises(RuntimeError, match="reset"):
        bolt.step(p((HIGH, HIGH)))


def test_a_violation_at_reset_terminates_at_the_first_step() -> None:
    bolt = make_violation_bolt(end_on_violation=True)
    first = bolt.reset(p((ABSENT, ABSENT)))
    assert first.violated.tolist() == [[True, False]] and first.terminate.tolist() == [False]
    assert bolt.step(p((ABSENT, ABSENT))).terminate.tolist() == [True]


# ---------------------------------------------------------------- auto-reset
def test_same_step_auto_reset_as_in_sb3_vec_envs() -> None:
    bolt = f_e_and_t_bolt(n_envs=2)
    bolt.reset(p((ABSENT, ABSENT), (ABSENT, ABSENT)))
    out = bolt.step(p((LOW, HIGH), (ABSENT, ABSENT)))
    assert out.total.tolist() == [T - C, 0.0]
    # Env 0's episode ends: the step reads its *final* observation ...
    dones = np.array([True, False])
    out = bolt.step(p((HIGH, HIGH), (ABSENT, ABSENT)), done=dones)
    assert out.total.tolist() == [T, 0.0]
    assert out.next_states.tolist() == [[1], [0]]  # for the terminal observation
    assert bolt.needs_reset.tolist() == [True, False]
    # ... then its DFA restarts on the new episode's first observation (row 1 is ignored).
    first = bolt.reset(p((0.6, HIGH), (0.0, 0.0)), env_mask=dones)
    assert first.total.tolist() == [T - C, 0.0]
    assert first.next_states.tolist() == [[1], [0]]
    assert bolt.states.tolist() == [[1], [0]]  # what the returned observation carries
    assert bolt.pending.tolist() == [T - C, 0.0]
    out = bolt.step(p((ABSENT, ABSENT), (ABSENT, ABSENT)))
    assert out.carried.tolist() == [T - C, 0.0]
    assert out.total.tolist() == [T + T - C, 0.0]


def test_next_step_auto_reset_as_in_gymnasium_vector_envs() -> None:
    bolt = f_e_and_t_bolt(n_envs=2)
    bolt.reset(p((ABSENT, ABSENT), (ABSENT, ABSENT)))
    out = bolt.step(p((HIGH, HIGH), (ABSENT, ABSENT)), done=np.array([True, False]))
    assert out.total.tolist() == [T, 0.0]
    # Next call: env 0 is reset by the vector env (its observation is its new first one).
    autoreset = np.array([True, False])
    probs = p((LOW, HIGH), (HIGH, HIGH))
    bolt.reset(probs, env_mask=autoreset)
    out = bolt.step(probs, done=np.zeros(2, dtype=bool), env_mask=~autoreset)
    assert out.total.tolist() == [0.0, T]
    assert out.next_states.tolist() == [[1], [1]]
    out = bolt.step(p((ABSENT, ABSENT), (ABSENT, ABSENT)))
    assert out.total.tolist() == [T + T - C, T]


@given(st.data())
def test_a_batch_equals_independent_single_environment_bolts(data: st.DataObject) -> None:
    n_envs, fluents = 3, ["a", "b", "c"]
    dfas = [data.draw(random_dfas(fluents=fluents, max_states=4)) for _ in range(2)]
    specs = [
        Spec(
            f"s{i}",
            terminal_reward=data.draw(st.sampled_from([1.0, -2.0])),
            low_confidence_cost=data.draw(st.sampled_from([0.0, 0.5])),
            reward_timing=data.draw(st.sampled_from(REWARD_TIMINGS)),
        )
        for i in range(2)
    ]
    options = {
        "cost_mode": data.draw(st.sampled_from(["count", "proportional"])),
        "end_on_violation": data.draw(st.booleans()),
    }
    batch = RestrainingBolt(specs, fluents, dfas=dfas, n_envs=n_envs, **options)  # type: ignore[arg-type]
    singles = [RestrainingBolt(specs, fluents, dfas=dfas, **options) for _ in range(n_envs)]  # type: ignore[arg-type]
    probs = data.draw(prob_matrices(n_envs, 3))
    batch.reset(probs)
    for i, single in enumerate(singles):
        single.reset(probs[i : i + 1])
    for _ in range(data.draw(st.integers(1, 6))):
        final = data.draw(prob_matrices(n_envs, 3))
        done = np.array(data.draw(st.lists(st.booleans(), min_size=n_envs, max_size=n_envs)))
        out = batch.step(final, done=done)
        restart = batch.needs_reset
        new = data.draw(prob_matrices(n_envs, 3))
        if restart.any():
            batch.reset(new, env_mask=restart)
        for i, single in enumerate(singles):
            one = single.step(final[i : i + 1], done=done[i : i + 1])
            for name, x, y in zip(out._fields, out, one, strict=True):
                np.testing.assert_allclose(x[i], y[0], err_msg=name)
            if single.needs_reset[0]:
                single.reset(new[i : i + 1])
            np.testing.assert_array_equal(batch.states[i], single.states[0])
            np.testing.assert_allclose(batch.pending[i], single.pending[0])


# ---------------------------------------------------------------- misuse and bad input
def test_stepping_before_reset_raises() -> None:
    with pytest.raises(RuntimeError, match=r"environments \[0, 1\].*reset"):
        f_e_and_t_bolt(n_envs=2).step(p((HIGH, HIGH), (HIGH, HIGH)))


def test_stepping_an_ended_episode_raises_until_it_is_reset() -> None:
    bolt = f_e_and_t_bolt(n_envs=2)
    bolt.reset(p((ABSENT, ABSENT), (ABSENT, ABSENT)))
    bolt.step(p((ABSENT, ABSENT), (ABSENT, ABSENT)), done=np.array([False, True]))
    with pytest.raises(RuntimeError, match=r"environments \[1\]"):
        bolt.step(p((ABSENT, ABSENT), (ABSENT, ABSENT)))
    bolt.step(p((ABSENT, ABSENT), (ABSENT, ABSENT)), env_mask=np.array([True, False]))


def test_done_outside_env_mask_raises() -> None:
    bolt = f_e_and_t_bolt(n_envs=2)
    bolt.reset(p((ABSENT, ABSENT), (ABSENT, ABSENT)))
    with pytest.raises(ValueError, match=r"done is set for environments \[1\]"):
        bolt.step(
            p((ABSENT, ABSENT), (ABSENT, ABSENT)),
            done=np.array([False, True]),
            env_mask=np.array([True, False]),
        )


@pytest.mark.parametrize(
    ("mask", "message"), [(np.array([1, 0]), "bool"), (np.array([True]), "shape")]
)
def test_bad_env_mask_raises(mask: np.ndarray, message: str) -> None:
    bolt = f_e_and_t_bolt(n_envs=2)
    with pytest.raises(ValueError, match=message):
        bolt.reset(p((ABSENT, ABSENT), (ABSENT, ABSENT)), env_mask=mask)


def test_bad_probs_raise_in_reset_and_step() -> None:
    bolt = f_e_and_t_bolt(n_envs=2)
    with pytest.raises(ValueError, match=r"probs\[1, 0\] \(fluent 'e'\) is nan"):
        bolt.reset(p((ABSENT, ABSENT), (np.nan, ABSENT)))
    bolt.reset(p((ABSENT, ABSENT), (ABSENT, ABSENT)))
    with pytest.raises(ValueError, match=r"probs\[0, 1\] \(fluent 't'\) is -0.5"):
        bolt.step(p((ABSENT, -0.5), (ABSENT, ABSENT)))
    with pytest.raises(ValueError, match="expected n_envs=2"):
        bolt.step(p((ABSENT, ABSENT)))
    with pytest.raises(ValueError, match="floating-point"):
        bolt.step(np.zeros((2, 2), dtype=np.int64))


@pytest.mark.parametrize("n_envs", [0, -1, 1.5, True, "2"])
def test_bad_n_envs_raises(n_envs: object) -> None:
    with pytest.raises(ConfigError, match="n_envs"):
        f_e_and_t_bolt(n_envs=n_envs)  # type: ignore[arg-type]


def test_specs_over_unknown_fluents_raise() -> None:
    spec = Spec("F(e & x)", terminal_reward=T, low_confidence_cost=C)
    with pytest.raises(UnknownFluentError) as info:
        RestrainingBolt([spec], ["e", "t"], dfas=[eventually_all(["e", "x"])])
    assert info.value.unknown == ("x",)


# ---------------------------------------------------------------- compiling specs
def test_specs_without_dfas_are_compiled_over_the_bolts_whole_vocabulary(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    calls: list[tuple[str, tuple[str, ...]]] = []

    def fake_compile(formula: str, fluents: tuple[str, ...]) -> DFA:
        calls.append((formula, tuple(fluents)))
        return eventually_all(list(fluents))

    monkeypatch.setattr(restraining_bolt, "compile_ltlf", fake_compile)
    specs = [
        Spec("F(e & t & u)", terminal_reward=T, low_confidence_cost=C),
        Spec("F(t)", terminal_reward=1.0, low_confidence_cost=0.0, name="reach_t"),
    ]
    bolt = RestrainingBolt(specs, ["e", "t", "u"])
    assert calls == [("F(e & t & u)", ("e", "t", "u")), ("F(t)", ("e", "t", "u"))]
    assert [spec.name for spec in bolt.specs] == ["F(e & t & u)", "reach_t"]
    assert bolt.dfas[0].fluents == ("e", "t", "u")


def test_non_spec_objects_are_rejected_before_compiling() -> None:
    with pytest.raises(ConfigError, match="Spec objects"):
        RestrainingBolt(["F(e)"], ["e"])  # type: ignore[list-item]


@pytest.fixture
def compile_ltlf(monkeypatch: pytest.MonkeyPatch, tmp_path: object) -> None:
    """Real compilation, with the DFA cache in a temporary directory."""
    monkeypatch.setenv("NOISYBOLT_CACHE_DIR", str(tmp_path))


@pytest.mark.usefixtures("compile_ltlf")
def test_compiled_specs_give_the_hand_computed_rewards() -> None:
    spec = Spec("F(e & t)", terminal_reward=T, low_confidence_cost=C)
    bolt = RestrainingBolt([spec], ["e", "t", "u"], n_envs=3)
    assert bolt.dfas[0].fluents == ("e", "t", "u")
    bolt.reset(p((ABSENT, ABSENT, LOW), (ABSENT, ABSENT, LOW), (ABSENT, ABSENT, LOW)))
    out = bolt.step(p((LOW, HIGH, LOW), (0.4, HIGH, LOW), (0.9000001, 0.9, LOW)))
    # u is a don't-care of F(e & t): its low confidence costs nothing.
    assert out.total.tolist() == [T - C, 0.0, T - C]
    assert out.accepting[:, 0].tolist() == [True, False, True]


@pytest.mark.usefixtures("compile_ltlf")
def test_compiled_specs_over_unknown_fluents_raise_unknown_fluent_error() -> None:
    spec = Spec("F(e & x)", terminal_reward=T, low_confidence_cost=C)
    with pytest.raises(UnknownFluentError) as info:
        RestrainingBolt([spec], ["e", "t"])
    assert "x" in info.value.unknown


@pytest.mark.usefixtures("compile_ltlf")
def test_compiled_specs_with_syntax_errors_raise_spec_syntax_error() -> None:
    with pytest.raises(SpecSyntaxError):
        RestrainingBolt([Spec("F(e &", terminal_reward=T, low_confidence_cost=C)], ["e"])


@pytest.mark.usefixtures("compile_ltlf")
def test_compact_dfas_over_a_large_vocabulary_step_like_dense_ones() -> None:
    fluents = [f"f{i}" for i in range(24)]  # 2 states x 2^24 letters: too large for tables
    spec = Spec("F(f3 & f17)", terminal_reward=T, low_confidence_cost=C)
    bolt = RestrainingBolt([spec], fluents, n_envs=4)
    assert bolt.engine._flat_next is None  # stepped through DFA.step_batch
    bolt.reset(np.full((4, 24), ABSENT))
    probs = np.full((4, 24), ABSENT)
    probs[0, [3, 17]] = [LOW, HIGH]
    probs[1, [3, 17]] = [HIGH, HIGH]
    probs[2, [3, 5]] = [LOW, LOW]  # f5 is a don't-care
    probs[3, [3, 17]] = [0.4, HIGH]
    out = bolt.step(probs)
    assert out.next_states[:, 0].tolist() == [1, 1, 0, 0]
    assert out.total.tolist() == [T - C, T, -C, 0.0]
