"""Counterfactual experience (CRM) for DQN: relabelled copies pay what the bolt would pay."""

from __future__ import annotations

import copy
import sys
from collections import deque
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from stable_baselines3 import DQN
from stable_baselines3.common.buffers import DictReplayBuffer

from noisybolt.agents.counterfactual import (
    BoltReplay,
    CounterfactualReplayBuffer,
    CounterfactualStates,
    bolted_env,
)
from noisybolt.bolt import REWARD_TIMINGS, ProgressShaping, RestrainingBolt, Spec
from noisybolt.errors import ConfigError
from noisybolt.logic import DFA
from noisybolt.runs import DetectorConfig, train
from noisybolt.runs.config import TrainConfig
from noisybolt.runs.environments import make_env, prepare_bolt
from noisybolt.runs.models import make_model
from noisybolt.runs.resolution import resolve

# The bolt tests' DFAs and strategies (tests/bolt is on the path only for its own tests).
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "bolt"))
from bolt_helpers import eventually_all, last_is, prob_matrices, random_dfas

TWO_CORNERS = "F(top_right_corner) & F(bottom_left_corner)"


# ---------------------------------------------------------------------- the replay
def _bolt(dfas: list[DFA], fluents: list[str], specs: list[Spec], **kwargs: Any) -> RestrainingBolt:
    return RestrainingBolt(specs, fluents, dfas=dfas, **kwargs)


def _crisp(letter: int, n_fluents: int) -> np.ndarray:
    """float ``[1, n_fluents]``: probabilities 0/1 spelling ``letter`` (no low band)."""
    return np.array([[float(letter >> i & 1) for i in range(n_fluents)]])


def _paths(bolt: RestrainingBolt) -> dict[tuple[int, ...], list[int]]:
    """Every joint state a fresh episode can reach, with the letters that reach it (the
    first is read at reset)."""
    n = bolt.n_specs
    paths: dict[tuple[int, ...], list[int]] = {}
    start = bolt.engine.initial_states(1)
    queue: deque[tuple[np.ndarray, list[int]]] = deque()
    for letter in range(1 << len(bolt.fluents)):
        out = bolt.engine.step(start, _crisp(letter, len(bolt.fluents)), first=True)
        queue.append((out.next_states, [letter]))
    while queue:
        states, path = queue.popleft()
        key = tuple(int(q) for q in states[0, :n])
        if key in paths:
            continue
        paths[key] = path
        for letter in range(1 << len(bolt.fluents)):
            out = bolt.engine.step(states, _crisp(letter, len(bolt.fluents)))
            queue.append((out.next_states, [*path, letter]))
    return paths


def _bolt_in(bolt: RestrainingBolt, path: list[int]) -> RestrainingBolt:
    """``bolt`` (fresh, one env) driven along ``path`` to the state it reaches."""
    k = len(bolt.fluents)
    bolt.reset(_crisp(path[0], k))
    for letter in path[1:]:
        bolt.step(_crisp(letter, k))
    return bolt


@st.composite
def _setups(draw: st.DrawFn) -> dict[str, Any]:
    fluents = ["f0", "f1", "f2"][: draw(st.integers(1, 3))]
    n_specs = draw(st.integers(1, 2))
    dfas = [draw(random_dfas(fluents=fluents, max_states=4)) for _ in range(n_specs)]
    specs = [
        Spec(
            f"spec{i}",
            name=f"s{i}",
            terminal_reward=draw(st.sampled_from([1.0, 10.0, 31.5])),
            low_confidence_cost=draw(st.sampled_from([0.0, 0.5, 2.0])),
            reward_timing=draw(st.sampled_from(REWARD_TIMINGS)),
        )
        for i in range(n_specs)
    ]
    shaping = None
    if draw(st.booleans()):
        shaping = ProgressShaping(
            dfas, scales=[s.terminal_reward for s in specs], gamma=1.0, shaping=draw(st.booleans())
        )
    return {
        "fluents": fluents,
        "dfas": dfas,
        "specs": specs,
        "shaping": shaping,
        "pay_at_truncation": draw(st.booleans()),
        "probs": draw(prob_matrices(1, len(fluents))),
        "done": draw(st.booleans()),
        "truncated": draw(st.booleans()),
        "pick": draw(st.integers(0, 10**6)),
    }


@settings(max_examples=60, deadline=None)
@given(_setups())
def test_a_replay_from_any_reachable_state_pays_what_the_bolt_pays_from_there(
    setup: dict[str, Any],
) -> None:
    def new_bolt() -> RestrainingBolt:
        return _bolt(
            setup["dfas"],
            setup["fluents"],
            setup["specs"],
            shaping=setup["shaping"],
            pay_at_truncation=setup["pay_at_truncation"],
        )

    paths = _paths(new_bolt())
    states = sorted(paths)
    state = states[setup["pick"] % len(states)]
    bolt = _bolt_in(new_bolt(), paths[state])
    assert tuple(bolt.states[0]) == state
    done, truncated = setup["done"], setup["done"] and setup["truncated"]
    truth = bolt.step(setup["probs"], done=np.array([done]), truncated=np.array([truncated]))

    replay = BoltReplay(new_bolt(), pay_at_truncation=setup["pay_at_truncation"])
    out = replay.step(
        np.array([state]), setup["probs"], done=np.array([done]), truncated=np.array([truncated])
    )
    assert out.next_states.tolist() == truth.next_states.tolist()
    assert out.total[0] == pytest.approx(truth.total[0] - truth.carried[0], abs=1e-12)
    assert out.carried.tolist() == [0.0]


def test_replayed_rewards_by_hand_on_change_entry_and_take_back() -> None:
    # last_is(t): accepting iff the last letter has t; on_change pays 10 on entering, takes
    # it back on leaving; t seen at 0.7 is low confidence (cost 2 per fluent on the edge).
    spec = Spec(
        "F(t & last)", terminal_reward=10.0, low_confidence_cost=2.0, reward_timing="on_change"
    )
    replay = BoltReplay(_bolt([last_is("t")], ["t"], [spec]))
    states = np.array([[0], [1], [0], [1]])
    probs = np.array([[0.7], [0.7], [0.1], [0.1]])
    out = replay.step(states, probs, done=np.zeros(4, dtype=bool))
    assert out.next_states.tolist() == [[1], [1], [0], [0]]
    # enter (+10 - 2), stay (-2), stay out (0), leave (-10)
    assert out.total.tolist() == [8.0, -2.0, 0.0, -10.0]


def test_replayed_episode_end_is_paid_at_done_and_at_a_cut_as_the_bolt_says() -> None:
    spec = Spec(
        "F(e & t)", terminal_reward=5.0, low_confidence_cost=0.0, reward_timing="episode_end"
    )
    states, probs = np.array([[1], [1], [1]]), np.array([[1.0, 1.0]] * 3)
    done, cut = np.array([False, True, True]), np.array([False, False, True])
    for pay_at_cut, expected in ((True, [0.0, 5.0, 5.0]), (False, [0.0, 5.0, 0.0])):
        bolt = _bolt([eventually_all(["e", "t"])], ["e", "t"], [spec])
        out = BoltReplay(bolt, pay_at_truncation=pay_at_cut).step(
            states, probs, done=done, truncated=cut
        )
        assert out.total.tolist() == expected


def test_a_belief_bolt_is_not_replayed() -> None:
    bolt = _bolt([eventually_all(["e"])], ["e"], [Spec("F(e)")], tracking="belief")
    with pytest.raises(ConfigError, match="belief"):
        BoltReplay(bolt)


# ---------------------------------------------------------------------- which states
def test_every_other_joint_state_when_few() -> None:
    chooser = CounterfactualStates((2, 2), samples=3)
    chosen = chooser.choose(np.array([[0, 0], [1, 0]]))
    assert chooser.exhaustive and chosen.shape == (3, 2, 2)
    assert sorted(map(tuple, chosen[:, 0].tolist())) == [(0, 1), (1, 0), (1, 1)]
    assert sorted(map(tuple, chosen[:, 1].tolist())) == [(0, 0), (0, 1), (1, 1)]


def test_a_seeded_sample_never_the_visited_state_when_many() -> None:
    visited = np.array([[3, 4, 0], [0, 0, 0]])
    first = CounterfactualStates((5, 6, 2), samples=4, seed=7)
    assert not first.exhaustive and first.copies == 4
    draws = np.concatenate([first.choose(visited) for _ in range(200)])
    assert not (draws == visited[None]).all(axis=2).any()
    assert (draws >= 0).all() and (draws < np.array([5, 6, 2])).all()
    assert len({tuple(s) for s in draws[:, 0].tolist()}) > 30  # spread over the 60 states
    again = CounterfactualStates((5, 6, 2), samples=4, seed=7)
    assert np.array_equal(np.concatenate([again.choose(visited) for _ in range(200)]), draws)


def test_samples_below_one_are_refused() -> None:
    with pytest.raises(ConfigError, match="samples"):
        CounterfactualStates((2,), samples=0)


# ---------------------------------------------------------------------- the buffer
def _config(**overrides: Any) -> TrainConfig:
    config = resolve(
        TrainConfig.create(
            specs=[TWO_CORNERS],
            algo="dqn",
            detector=DetectorConfig(kind="oracle"),
            frames=400,
            eval_freq=200,
            eval_episodes=2,
            checkpoint_freq=200,
            progress_bar=False,
            overrides={"learning_starts": 100},
        )
    )
    return config.override({"algorithm.counterfactual": True, **overrides})


def test_visited_transitions_are_stored_unchanged_and_copies_as_the_bolt_pays() -> None:
    # No training; episodes cut at 20 steps, so some steps end one (truncated).
    config = _config(
        **{"algorithm.hyperparams.learning_starts": 10_000, "world.kwargs": {"max_steps": 20}}
    )
    setup = prepare_bolt(config, seed=config.seed)
    env = make_env(config, setup.detector, training=True, dfas=setup.dfas)
    model = make_model(config, env)
    assert isinstance(model, DQN)
    buffer = model.replay_buffer
    assert isinstance(buffer, CounterfactualReplayBuffer)
    calls: list[tuple[Any, ...]] = []
    original = buffer.add

    def record(*args: Any) -> None:
        calls.append(copy.deepcopy(args))
        original(*args)

    buffer.add = record  # type: ignore[method-assign,assignment]
    model.learn(240)
    env.close()
    copies = buffer.states.copies
    assert copies == 3  # F(a) & F(b): 4 joint states, the visited one stored as gathered

    plain = DictReplayBuffer(
        buffer.buffer_size * buffer.n_envs, buffer.observation_space, buffer.action_space,
        n_envs=buffer.n_envs,
    )  # fmt: skip
    for args in copy.deepcopy(calls):
        plain.add(*args)
    rows = np.arange(len(calls)) * (1 + copies)
    for key in plain.observations:
        assert np.array_equal(buffer.observations[key][rows], plain.observations[key][: len(calls)])
        assert np.array_equal(
            buffer.next_observations[key][rows], plain.next_observations[key][: len(calls)]
        )
    for name in ("actions", "rewards", "dones", "timeouts"):
        assert np.array_equal(getattr(buffer, name)[rows], getattr(plain, name)[: len(calls)])

    # Each copy: the bolt's own engine and shaping from the copy's state, on the step's probs.
    replay = BoltReplay(bolted_env(env).bolt)
    ended_seen = False
    for step, (obs, _next, _action, _reward, done, infos) in enumerate(calls):
        probs = np.stack([info["fluent_probs"] for info in infos])
        env_reward = np.array([info["env_reward"] for info in infos])
        ended_seen |= bool(np.any(done))
        for j in range(copies):
            row = step * (1 + copies) + 1 + j
            q = buffer.observations["dfa"][row]
            assert not (q == obs["dfa"]).all(axis=1).any()
            out = replay.step(q, probs, done=np.asarray(done, dtype=bool))
            assert np.array_equal(buffer.next_observations["dfa"][row], out.next_states)
            np.testing.assert_allclose(
                buffer.rewards[row], (env_reward + out.total).astype(np.float32)
            )
            for key in ("image",):
                assert np.array_equal(buffer.observations[key][row], obs[key])
    assert ended_seen  # steps that ended an episode were among them (final views replayed)


def test_a_step_without_the_bolts_records_is_refused_by_name() -> None:
    config = _config()
    setup = prepare_bolt(config, seed=config.seed)
    env = make_env(config, setup.detector, training=True, dfas=setup.dfas)
    model = make_model(config, env, trial=True)
    env.close()
    assert isinstance(model, DQN) and isinstance(model.replay_buffer, CounterfactualReplayBuffer)
    buffer, n = model.replay_buffer, model.replay_buffer.n_envs
    obs = {k: np.zeros((n, *shape), dtype=buffer.observations[k].dtype)
           for k, shape in buffer.obs_shape.items()}  # fmt: skip
    with pytest.raises(RuntimeError, match="transition_records"):
        buffer.add(obs, obs, np.zeros(n), np.zeros(n), np.zeros(n), [{"env_reward": 0.0}] * n)


def test_a_tiny_dqn_run_trains_checkpoints_and_resumes_with_its_copies(tmp_path: Path) -> None:
    from noisybolt.runs.checkpoints import latest_checkpoint
    from noisybolt.runs.run_evaluation import load_run_model
    from noisybolt.runs.rundir import RunDirectory

    config = _config()
    result = train(config, tmp_path / "run", log=lambda _: None)
    assert result.frames == 400
    folder = latest_checkpoint(RunDirectory(tmp_path / "run")).folder
    with np.load(folder / "replay_buffer.npz") as saved:
        # 100 steps of 4 games, each stored with its 3 copies
        assert int(saved["pos"]) == 100 * 4
        dfa = saved["observations/dfa"][:400, 0, :]
    assert sorted({tuple(q) for q in dfa[:4].tolist()}) == [(0,), (1,), (2,), (3,)]
    resumed = train(
        config.override({"frames": 600}), tmp_path / "run", resume=True, log=lambda _: None
    )
    assert resumed.frames == 600
    folder = latest_checkpoint(RunDirectory(tmp_path / "run")).folder
    with np.load(folder / "replay_buffer.npz") as saved:
        assert int(saved["pos"]) == 150 * 4
        assert np.array_equal(saved["observations/dfa"][:400, 0, :], dfa)  # kept over the resume
    # The final model loads for evaluation (its buffer settings rebuilt, nothing unpickled).
    model = load_run_model(RunDirectory(tmp_path / "run"), config)
    assert isinstance(model, DQN) and isinstance(model.replay_buffer, CounterfactualReplayBuffer)


# ---------------------------------------------------------------------- bad input
@pytest.mark.parametrize(
    ("changes", "match"),
    [
        ({"algorithm.name": "ppo", "algorithm.hyperparams": {}}, "on-policy"),
        ({"algorithm.name": "a2c", "algorithm.hyperparams": {}}, "on-policy"),
        ({"bolt.tracking": "belief"}, "belief"),
        ({"bolt.bolted": False}, "unbolted"),
        ({"algorithm.counterfactual_samples": 0}, "counterfactual_samples"),
        ({"algorithm.hyperparams.optimize_memory_usage": True}, "optimize_memory_usage"),
    ],
)
def test_bad_counterfactual_settings_are_refused_by_name(
    changes: dict[str, Any], match: str
) -> None:
    with pytest.raises(ConfigError, match=match):
        _config(**changes)


def test_the_command_line_sets_it_by_flag_and_by_path() -> None:
    from noisybolt.cli import build_parser
    from noisybolt.cli.train import train_overrides

    def config(*argv: str) -> TrainConfig:
        base = ["train", "--spec", "edge", "--detector", "oracle", "--algo", "dqn"]
        args = build_parser().parse_args([*base, *argv])
        return resolve(TrainConfig.build(train_overrides(args), hp_file=args.hp_file))

    assert config().algorithm.counterfactual is False
    assert config("--counterfactual").algorithm.counterfactual is True
    chosen = config(
        "--set", "algorithm.counterfactual=true", "--set", "algorithm.counterfactual_samples=4"
    )
    assert (chosen.algorithm.counterfactual, chosen.algorithm.counterfactual_samples) == (True, 4)
    with pytest.raises(ConfigError, match="on-policy"):
        config("--counterfactual", "--algo", "ppo")
