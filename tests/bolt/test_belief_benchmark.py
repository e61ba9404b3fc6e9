"""benchmarks/belief_tracking.py: its replay and rates on hand-made episodes, and a tiny run."""

from __future__ import annotations

from collections.abc import Callable
from types import ModuleType

import numpy as np
import pytest

from noisybolt.bolt import Spec


@pytest.fixture(scope="module")
def bench(load_script: Callable[..., ModuleType]) -> ModuleType:
    return load_script("benchmarks/belief_tracking.py")


def test_replay_counts_a_glitch_as_a_false_acceptance_only_under_threshold(
    bench: ModuleType,
) -> None:
    no, yes, glitch = 0.02, 0.99, 0.8
    episodes = [
        # x never true; one glitch frame: threshold accepts F(x), belief does not.
        bench.Episode(np.array([[no], [no], [glitch], [no], [no]]), np.zeros((5, 1), bool)),
        # x true for three frames: both accept.
        bench.Episode(
            np.array([[no], [yes], [yes], [yes], [no], [no]]),
            np.array([[0], [1], [1], [1], [0], [0]], dtype=bool),
        ),
        # nothing at all, a shorter episode.
        bench.Episode(np.array([[no], [no]]), np.zeros((2, 1), bool)),
    ]
    specs = [Spec("F(x)", terminal_reward=1.0, low_confidence_cost=0.5)]
    threshold = bench.replay(episodes, specs, ["x"], tracking="threshold")
    belief = bench.replay(
        episodes, specs, ["x"], tracking="belief", belief=bench.BeliefSettings(base_rates=0.1)
    )
    np.testing.assert_array_equal(threshold[1], [[False], [True], [False]])  # the truth
    np.testing.assert_array_equal(threshold[0], [[True], [True], [False]])
    np.testing.assert_array_equal(belief[0], [[False], [True], [False]])
    false, recall, positives = bench.rates(*threshold)
    assert false.tolist() == pytest.approx([1 / 3]) and recall.tolist() == [1.0]
    assert positives.tolist() == [1]
    false, recall, _ = bench.rates(*belief)
    assert false.tolist() == [0.0] and recall.tolist() == [1.0]


def test_glitch_detector_is_sure_except_on_its_share_of_frames(bench: ModuleType) -> None:
    detector = bench.GlitchDetector(["a", "b", "c"], rate=0.03, seed=0)
    truth = np.zeros((20_000, 3), dtype=bool)
    truth[:, 0] = True
    probs = detector.predict(np.zeros((20_000, 1, 1, 3), np.uint8), truth=truth)
    assert probs[:, 0].min() >= 0.95
    glitched = (probs[:, 1:] >= 0.5).any(axis=1)
    assert glitched.mean() == pytest.approx(0.03, abs=0.005)
    assert probs[:, 1:].max() <= 0.9


def test_cost_table_runs_on_tiny_sizes(
    bench: ModuleType, capsys: pytest.CaptureFixture[str]
) -> None:
    bench.cost(n_envs=4, fluent_counts=(1, 2), repeats=3)
    out = capsys.readouterr().out
    assert "| 1 |" in out and "| 2 |" in out


def test_record_plays_the_agent_it_is_given(bench: ModuleType) -> None:
    # An agent that only turns left never leaves its cell: every episode runs to the
    # truncation limit with the same position fluents on every frame (only the facing_*
    # ones change), and it sees the observations the env returned; random play on the
    # same world moves.
    from noisybolt.envs import SB3VecEnv, make_world
    from noisybolt.perception.detectors import OracleDetector

    world = make_world("gridworld", num_envs=2, seed=0, max_steps=9)
    venv = SB3VecEnv(world)
    venv.seed(0)
    seen: list[object] = []

    def turn_left(observations: object) -> np.ndarray:
        seen.append(observations)
        return np.zeros(2, dtype=np.int64)

    detector = OracleDetector(world.fluent_names)
    place = [i for i, name in enumerate(world.fluent_names) if not name.startswith("facing")]
    assert place

    def stays(episode: object) -> bool:
        truth = episode.truth[:, place]  # type: ignore[attr-defined]
        return len(truth) == 10 and bool((truth == truth[0]).all())

    episodes = bench.record(world, detector, 3, 0, 3, agent=(venv, turn_left))
    assert len(episodes) == 3
    for episode in episodes:
        assert stays(episode)  # the first observation and 9 steps, never moved
        np.testing.assert_array_equal(episode.probs, episode.truth)
    assert len(seen) >= 18
    assert not all(stays(e) for e in bench.record(world, detector, 6, 0, 3))
