"""The bolt wrappers' rewards against Algorithm 1 evaluated by hand, beside an unbolted twin.

Nothing here reads the bolt's reward, DFA states or probabilities back from the wrapper
under test. Each run steps a wrapped world and an unbolted twin from the same seed with
the same actions; the expected bolt reward of every step is recomputed from the twin's
ground truth by :class:`PaperBolt`, a direct, one-environment-at-a-time reading of the
paper's Algorithm 1 written for this file:

* the fluents' probabilities come from :class:`TableDetector`, a pure function of the
  true fluents (so the reference can call it on the twin's truth), full of low-band
  values, values on the band boundaries, false positives and misses;
* a fluent is true iff ``p >= 0.5``; the DFA takes the edge that truth selects;
* the edge's support (the fluents its guard depends on) is found by brute force over
  every letter, from the DFA's transitions alone;
* acceptance comes from the independent LTLf evaluator on the bolt's own trace, not
  from the DFA's accepting set;
* costs, reward timings, the reset transition's carried reward and several specs adding
  up follow DESIGN.md's "Semantics fixed here".

The wrapped reward must equal the twin's reward plus that bolt reward, and everything
else (images, terminations, SB3's infos) must be the twin's.
"""

from __future__ import annotations

from collections.abc import Sequence
from functools import cache
from typing import Any

import numpy as np
import pytest

from noisybolt.bolt import Spec, Thresholds
from noisybolt.envs import SB3VecEnv
from noisybolt.envs.gridworld import GRIDWORLD_FLUENTS, GridworldEnv, gridworld_fluents
from noisybolt.envs.gridworld_vec import VectorGridworld
from noisybolt.logic import DFA, compile_ltlf, holds
from noisybolt.logic.syntax import parse_ltlf
from noisybolt.wrappers import BoltVecEnv, RestrainingBoltWrapper

TRUTH, HIGH = 0.5, 0.9
FLUENTS = GRIDWORLD_FLUENTS

# Values a true fluent is seen with: mostly the low band, both of its boundaries (0.5 and
# exactly 0.9 are low), just above it (high), sure, and a miss.
SEEN_TRUE = (0.5, 0.55, 0.62, 0.75, 0.84, 0.9, 0.9 + 1e-9, 0.95, 1.0, 0.3)
SEEN_TRUE_WEIGHTS = (2, 1, 2, 2, 1, 2, 1, 1, 1, 1)
# Values a false fluent is seen with: absent, just below the truth threshold, and false
# positives in the low and in the high band.
SEEN_FALSE = (0.0, 0.1, 0.4999, 0.5, 0.8, 0.97)
SEEN_FALSE_WEIGHTS = (4, 3, 2, 1, 1, 1)

T, B = "top_right_corner", "bottom_left_corner"
# Several specs per bolt, each with its own reward and cost so that a cost charged to the
# wrong spec shows; edges whose guards read one, two or three fluents.
SPEC_SETS: dict[str, tuple[tuple[str, float, float], ...]] = {
    "paper": (
        ("G(on_edge)", 1.0, 0.5),
        (f"(F({T} & X(!F({T}))) & !F({B})) | (F({B} & X(!F({B}))) & !F({T}))", 2.5, 0.75),
    ),
    "two_fluent_edges": (
        (f"!F({T})", 1.0, 0.5),
        ("F(on_edge & facing_down)", 3.0, 1.25),
        ("G(facing_up -> on_edge)", 0.5, 0.25),
    ),
    "until": (
        (f"(!{B}) U ({T} | facing_left)", 2.0, 0.5),
        (f"F({T} & X(!F({T})))", 1.5, 1.0),
    ),
}
TIMINGS = ("every_step", "on_entry", "episode_end", "on_change")


def _specs(name: str, timing: str) -> list[Spec]:
    specs = []
    for k, (formula, reward, cost) in enumerate(SPEC_SETS[name]):
        when = TIMINGS[k % len(TIMINGS)] if timing == "mixed" else timing
        specs.append(
            Spec(
                formula,
                terminal_reward=reward,
                low_confidence_cost=cost,
                reward_timing=when,  # type: ignore[arg-type]
                name=f"s{k}",
            )
        )
    return specs


class TableDetector:
    """Probabilities as a seeded pure function of the true fluents (a row at a time).

    Each distinct truth row gets its own probabilities, drawn once from ``SEEN_TRUE`` and
    ``SEEN_FALSE``; the same row always gets the same ones, so the reference can ask for
    the probabilities of its twin's truth without knowing how the wrapper batches calls.
    """

    needs_truth = True

    def __init__(self, fluent_names: Sequence[str], *, seed: int) -> None:
        self.fluent_names = tuple(fluent_names)
        self._seed = seed

    def row(self, truth: np.ndarray) -> np.ndarray:
        return _table_row(self._seed, tuple(bool(v) for v in truth)).copy()

    def predict(self, images: np.ndarray, *, truth: np.ndarray | None = None) -> np.ndarray:
        assert truth is not None and len(truth) == len(images)
        return np.stack([self.row(t) for t in np.asarray(truth, dtype=bool)])


@cache
def _table_row(seed: int, truth: tuple[bool, ...]) -> np.ndarray:
    key = sum(1 << i for i, v in enumerate(truth) if v)
    rng = np.random.default_rng([seed, key])
    p_true = np.array(SEEN_TRUE_WEIGHTS) / sum(SEEN_TRUE_WEIGHTS)
    p_false = np.array(SEEN_FALSE_WEIGHTS) / sum(SEEN_FALSE_WEIGHTS)
    return np.array(
        [
            rng.choice(SEEN_TRUE, p=p_true) if v else rng.choice(SEEN_FALSE, p=p_false)
            for v in truth
        ],
        dtype=np.float64,
    )


# ---------------------------------------------------------------------- the reference
@cache
def _dfa(formula: str) -> DFA:
    return compile_ltlf(formula, FLUENTS)


@cache
def _parsed(formula: str) -> Any:
    return parse_ltlf(formula)


def _letter(dfa: DFA, mask: int) -> dict[str, bool]:
    return {f: bool(mask >> i & 1) for i, f in enumerate(dfa.fluents)}


@cache
def _successors(formula: str, q: int) -> tuple[int, ...]:
    """The state reached from ``q`` on every letter (bit i = the DFA's i-th fluent)."""
    dfa = _dfa(formula)
    return tuple(dfa.step(q, _letter(dfa, m)) for m in range(1 << len(dfa.fluents)))


@cache
def _edge_support(formula: str, q: int, target: int) -> frozenset[str]:
    """The fluents the guard of ``q -> target`` depends on: flipping one of them changes,
    for some letter, whether the edge is taken."""
    dfa = _dfa(formula)
    guard = [s == target for s in _successors(formula, q)]
    return frozenset(
        f
        for i, f in enumerate(dfa.fluents)
        if any(guard[m] != guard[m ^ (1 << i)] for m in range(len(guard)))
    )


@cache
def _reachable(formula: str, q: int) -> frozenset[int]:
    """The states some trace leads to from ``q`` (``q`` included)."""
    seen, todo = {q}, [q]
    while todo:
        for nxt in _successors(formula, todo.pop()):
            if nxt not in seen:
                seen.add(nxt)
                todo.append(nxt)
    return frozenset(seen)


def _can_accept(formula: str, q: int) -> bool:
    """Whether some accepting state is reachable from ``q`` (else ``q`` is a violation)."""
    return any(_dfa(formula).accepting[s] for s in _reachable(formula, q))


class PaperBolt:
    """Algorithm 1 for one environment, in plain Python, with the episode timing."""

    def __init__(
        self, specs: Sequence[Spec], *, cost_mode: str, truth: float = TRUTH, high: float = HIGH
    ) -> None:
        self.specs = list(specs)
        self.cost_mode = cost_mode
        self.truth, self.high = truth, high
        self.states: list[int] = []
        self.carried = 0.0
        self.terminate = False
        self._trace: list[dict[str, bool]] = []
        self._accepting: list[bool] = []

    def reset(self, probs: np.ndarray) -> None:
        self._trace = []
        self.states = [_dfa(s.formula).initial_state for s in self.specs]
        self._accepting = [False] * len(self.specs)
        self.carried = self._transition(probs, first=True, done=False)

    def step(self, probs: np.ndarray, *, done: bool, end_on_violation: bool = False) -> float:
        reward = self._transition(probs, first=False, done=done, end_on_violation=end_on_violation)
        reward += self.carried
        self.carried = 0.0
        return reward

    def _transition(
        self, probs: np.ndarray, *, first: bool, done: bool, end_on_violation: bool = False
    ) -> float:
        p = dict(zip(FLUENTS, (float(v) for v in probs), strict=True))
        self._trace.append({f: p[f] >= self.truth for f in FLUENTS})
        moves = []
        for spec, q in zip(self.specs, self.states, strict=True):
            dfa = _dfa(spec.formula)
            target = _successors(spec.formula, q)[dfa.mask(self._trace[-1])]
            moves.append((q, target))
        violated = [
            not _can_accept(s.formula, t) for s, (_, t) in zip(self.specs, moves, strict=True)
        ]
        self.terminate = end_on_violation and any(violated)
        ended = done or self.terminate
        total = 0.0
        for k, (spec, (q, target)) in enumerate(zip(self.specs, moves, strict=True)):
            truth, high = self.truth, self.high
            low = [f for f in _edge_support(spec.formula, q, target) if truth <= p[f] <= high]
            if self.cost_mode == "count":
                total -= spec.low_confidence_cost * len(low)
            else:  # weight 1 at the truth threshold, falling linearly to 0 at the high one
                total -= spec.low_confidence_cost * sum((high - p[f]) / (high - truth) for f in low)
            accepting = holds(_parsed(spec.formula), self._trace)
            entered = accepting and (first or not self._accepting[k])
            paid = accepting and (
                spec.reward_timing == "every_step"
                or (spec.reward_timing == "on_entry" and entered)
                or (spec.reward_timing == "episode_end" and ended)
                or (spec.reward_timing == "on_change" and entered and not first)
            )
            # on_change pays changes after the episode's first transition (where the episode
            # starts is its baseline, not paid) and takes the reward back on leaving acceptance
            lost = spec.reward_timing == "on_change" and self._accepting[k] and not accepting
            total -= spec.terminal_reward * (lost and not first)
            total += spec.terminal_reward * paid
            self._accepting[k] = accepting
            self.states[k] = target
        return total


def _truth(env: GridworldEnv) -> np.ndarray:
    """The unbolted twin's true fluents, from where its agent stands."""
    x, y = env.unwrapped.agent_pos
    return gridworld_fluents(
        np.array([x]), np.array([y]), np.array([env.unwrapped.agent_dir]), size=6
    )[0]


class Walker:
    """Actions for one room: each episode either heads for the goal (the bottom-right
    cell) with some detours, or wanders, so runs cross both kinds of episode end and
    pass over edges and corners."""

    def __init__(self, rng: np.random.Generator) -> None:
        self._rng = rng
        self.new_episode()

    def new_episode(self) -> None:
        self._wander = 0.95 if self._rng.random() < 0.5 else 0.35

    def action(self, env: GridworldEnv) -> int:
        if self._rng.random() < self._wander:
            return int(self._rng.integers(4))
        (x, y), heading = env.unwrapped.agent_pos, env.unwrapped.agent_dir
        wanted = [d for d, far in ((0, x < 4), (1, y < 4)) if far]  # east, south
        if not wanted or heading in wanted:
            return 2  # forward
        return 1 if heading in (3, 0) else 0  # turn right from north or east, else left


# ---------------------------------------------------------------------- the tests
def test_the_reference_detector_is_mostly_low_band_and_on_the_boundaries() -> None:
    # Over the seeds the tests below use, every (cell, heading) of the room.
    rows = np.array(
        [_truth_row(x, y, d) for x in range(1, 5) for y in range(1, 5) for d in range(4)]
    )
    images = np.zeros((len(rows), 1, 1, 3), np.uint8)
    probs = np.stack(
        [TableDetector(FLUENTS, seed=s).predict(images, truth=rows) for s in range(40)]
    )
    seen_true, seen_false = probs[:, rows], probs[:, ~rows]
    assert ((seen_true >= TRUTH) & (seen_true <= HIGH)).mean() > 0.5
    assert (seen_true == 0.5).any() and (seen_true == 0.9).any()  # both boundaries are low
    assert (seen_true < TRUTH).any()  # misses
    assert ((seen_false >= TRUTH) & (seen_false <= HIGH)).any()  # low-band false positives
    assert (seen_false > HIGH).any()  # sure false positives


def _truth_row(x: int, y: int, d: int) -> np.ndarray:
    return gridworld_fluents(np.array([x]), np.array([y]), np.array([d]), size=6)[0]


@pytest.mark.parametrize("cost_mode", ["count", "proportional"])
@pytest.mark.parametrize("timing", [*TIMINGS, "mixed"])
@pytest.mark.parametrize("spec_set", list(SPEC_SETS))
def test_wrapper_reward_is_the_twins_plus_algorithm_1_by_hand(
    spec_set: str, timing: str, cost_mode: str
) -> None:
    seed = list(SPEC_SETS).index(spec_set) * 10 + [*TIMINGS, "mixed"].index(timing)
    _check_single_wrapper(_specs(spec_set, timing), cost_mode=cost_mode, seed=seed)


@pytest.mark.parametrize("cost_mode", ["count", "proportional"])
def test_the_band_thresholds_are_settings_the_wrapper_obeys(cost_mode: str) -> None:
    # With truth 0.6 and high 0.8: 0.5 and 0.55 are no longer true, 0.84 and 0.9 are high.
    thresholds = Thresholds(truth=0.6, high=0.8)
    _check_single_wrapper(
        _specs("two_fluent_edges", "mixed"), cost_mode=cost_mode, seed=41, thresholds=thresholds
    )


def _check_single_wrapper(
    specs: list[Spec], *, cost_mode: str, seed: int, thresholds: Thresholds | None = None
) -> None:
    thresholds = thresholds or Thresholds()
    detector = TableDetector(FLUENTS, seed=seed)
    twin, bolted = GridworldEnv(max_steps=25), GridworldEnv(max_steps=25)
    wrapped = RestrainingBoltWrapper(
        bolted,
        specs,
        detector,
        cost_mode=cost_mode,  # type: ignore[arg-type]
        thresholds=thresholds,
    )
    reference = PaperBolt(specs, cost_mode=cost_mode, truth=thresholds.truth, high=thresholds.high)
    walker = Walker(np.random.default_rng(seed))

    twin.reset(seed=seed)
    obs, _ = wrapped.reset(seed=seed)
    reference.reset(detector.row(_truth(twin)))
    ends = {"terminated": 0, "truncated": 0}
    low_steps = 0
    for _ in range(250):
        assert obs["dfa"].tolist() == reference.states
        action = walker.action(twin)
        tobs, treward, tterm, ttrunc, _ = twin.step(action)
        obs, reward, term, trunc, _ = wrapped.step(action)
        probs = detector.row(_truth(twin))
        low_steps += bool(((probs >= thresholds.truth) & (probs <= thresholds.high)).any())
        expected = reference.step(probs, done=tterm or ttrunc)
        np.testing.assert_array_equal(obs["image"], tobs)
        assert (term, trunc) == (tterm, ttrunc)
        assert reward == pytest.approx(float(treward) + expected, abs=1e-9)
        if term or trunc:
            assert obs["dfa"].tolist() == reference.states
            ends["terminated" if term else "truncated"] += 1
            twin.reset()
            obs, _ = wrapped.reset()
            reference.reset(detector.row(_truth(twin)))
            walker.new_episode()
    # The run crossed both kinds of episode end, and the detector was unsure most steps.
    assert ends["terminated"] >= 2 and ends["truncated"] >= 2, ends
    assert low_steps > 150


def test_end_on_violation_ends_where_the_reference_sees_a_violation() -> None:
    specs = _specs("two_fluent_edges", "mixed")
    detector = TableDetector(FLUENTS, seed=3)
    twin, bolted = GridworldEnv(max_steps=25), GridworldEnv(max_steps=25)
    wrapped = RestrainingBoltWrapper(bolted, specs, detector, end_on_violation=True)
    reference = PaperBolt(specs, cost_mode="count")
    walker = Walker(np.random.default_rng(3))
    twin.reset(seed=3)
    wrapped.reset(seed=3)
    reference.reset(detector.row(_truth(twin)))
    cut_short = 0
    for _ in range(300):
        action = walker.action(twin)
        _, treward, tterm, ttrunc, _ = twin.step(action)
        _, reward, term, trunc, _ = wrapped.step(action)
        expected = reference.step(
            detector.row(_truth(twin)), done=tterm or ttrunc, end_on_violation=True
        )
        assert term == (tterm or reference.terminate) and trunc == ttrunc
        assert reward == pytest.approx(float(treward) + expected, abs=1e-9)
        if term or trunc:
            cut_short += reference.terminate and not (tterm or ttrunc)
            twin.reset()
            wrapped.reset()
            reference.reset(detector.row(_truth(twin)))
            walker.new_episode()
    assert cut_short >= 3


@pytest.mark.parametrize(
    ("spec_set", "timing"),
    [
        ("paper", "mixed"),
        ("two_fluent_edges", "on_entry"),
        ("until", "episode_end"),
        ("until", "on_change"),
    ],
)
@pytest.mark.parametrize("cost_mode", ["count", "proportional"])
def test_batched_bolt_is_the_unbolted_vector_env_plus_algorithm_1_by_hand(
    spec_set: str, timing: str, cost_mode: str
) -> None:
    n, seed = 4, 11
    specs = _specs(spec_set, timing)
    detector = TableDetector(FLUENTS, seed=seed)
    plain = SB3VecEnv(VectorGridworld(num_envs=n, max_steps=20, seed=seed))
    bolted = BoltVecEnv(
        SB3VecEnv(VectorGridworld(num_envs=n, max_steps=20, seed=seed)),
        specs,
        detector,
        cost_mode=cost_mode,  # type: ignore[arg-type]
    )
    # The reference's ground truth: one MiniGrid room per environment, in lockstep (the
    # vectorised world is tested identical to these elsewhere); they show the state an
    # episode ended in, before the vector env's same-step reset.
    rooms = [GridworldEnv(max_steps=20) for _ in range(n)]
    references = [PaperBolt(specs, cost_mode=cost_mode) for _ in range(n)]
    for room, reference in zip(rooms, references, strict=True):
        room.reset(seed=seed)
        reference.reset(detector.row(_truth(room)))
    plain_obs, obs = plain.reset(), bolted.reset()
    walkers = [Walker(np.random.default_rng([seed, i])) for i in range(n)]
    ends = 0
    for _ in range(100):
        np.testing.assert_array_equal(obs["image"], plain_obs)
        assert obs["dfa"].tolist() == [r.states for r in references]
        actions = np.array([w.action(room) for w, room in zip(walkers, rooms, strict=True)])
        plain_obs, plain_rewards, plain_dones, plain_infos = plain.step(actions)
        obs, rewards, dones, infos = bolted.step(actions)
        np.testing.assert_array_equal(dones, plain_dones)
        for i, (room, reference) in enumerate(zip(rooms, references, strict=True)):
            _, _, term, trunc, _ = room.step(int(actions[i]))
            assert bool(dones[i]) == (term or trunc)
            expected = reference.step(detector.row(_truth(room)), done=bool(dones[i]))
            assert rewards[i] == pytest.approx(plain_rewards[i] + expected, abs=1e-4)
            for key in ("TimeLimit.truncated", "is_success"):
                assert infos[i].get(key) == plain_infos[i].get(key)
            if dones[i]:
                ends += 1
                final = infos[i]["terminal_observation"]
                np.testing.assert_array_equal(
                    final["image"], plain_infos[i]["terminal_observation"]
                )
                assert final["dfa"].tolist() == reference.states
                room.reset()
                reference.reset(detector.row(_truth(room)))
                walkers[i].new_episode()
    assert ends >= 2 * n
