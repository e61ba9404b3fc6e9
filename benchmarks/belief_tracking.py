"""Threshold tracking (Algorithm 1) against belief tracking, side by side on the same frames.

A uniformly random agent plays a world under a noisy detector; every episode's detector
probabilities and true fluents are recorded once, then replayed through two bolts, one per
tracking mode, so both modes judge exactly the same frames. Per spec:

- **false acceptance**: the share of episodes whose bolt ended accepting (``info
  ["dfa_accepting"]`` at the last step) while the true trace did not;
- **recall**: of the episodes whose true trace ended accepting, the share the bolt
  accepted too.

Settings (``--setting``, repeatable; default: the two gridworld ones):

- ``grid-glitch``: the gridworld with a detector sure of the true fluents (p in [0.95, 1])
  and of the false ones (p in [0, 0.05]), except that on 3 % of frames one false fluent
  is reported in the low band (p in [0.5, 0.9]);
- ``grid-smudge``: the gridworld's regionally smudged camera and its classifier (the one
  ``noisybolt train --noise regional`` uses, cached or trained on the fly);
- ``breakout-occlusion`` and ``breakout-sigma50``: Breakout (FIRE after reset and lost
  lives) under the occluding and the sigma = 50 cameras, the ``left_column_milestones``
  specs, and the classifier ``noisybolt train --noise ...`` would use; the milestone
  fluents are monotone (a brick gone stays gone).

Columns: ``threshold`` (Algorithm 1), ``IBU`` (the same filter without persistence,
``switch_rate=1, min_dwell=1``: independent belief updating as Li et al. 2024),
``belief`` (the defaults: switch rate 0.5, min_dwell 2) and ``belief, s est.`` (switch
rates estimated too).
Belief tracking's base rates are estimated without ground truth (EM of Saerens et al.
2002 on the detector's outputs over separate calibration episodes of random play, floored
at 0.01: see :func:`~noisybolt.perception.base_rates.belief_settings_from_play`), and so
are the fluents' switch rates (from the lag-one autocorrelation of those outputs).

With ``--agent RUN_DIR`` (a Breakout setting), the recorded episodes are a trained run's
instead (its latest model, sampled actions, its DFA states read from the ground truth so
that it plays as with a bolt that never errs): longer games that reach states random play
does not, such as rows 0-3 of the left column gone. The base rates are still estimated on
random play.

Cost (``--cost``): microseconds per environment-step of ``RestrainingBolt.step`` at 64
environments for 1-16 fluents (one ``F(f_i)`` spec per fluent), both modes.

    .venv/bin/python benchmarks/belief_tracking.py [--setting grid-glitch ...] \
        [--episodes 200] [--cost] [--agent RUN_DIR]
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from noisybolt.bolt import BeliefSettings, RestrainingBolt, Spec, Tracking
from noisybolt.logic import compile_ltlf
from noisybolt.perception.base_rates import belief_settings_from_play

GRID_SPECS = (
    Spec("F(bottom_left_corner)", terminal_reward=1.0, low_confidence_cost=0.5, name="visit_bl"),
    Spec("F(top_right_corner)", terminal_reward=1.0, low_confidence_cost=0.5, name="visit_tr"),
    Spec(
        "F(top_right_corner) & F(bottom_left_corner)",
        terminal_reward=1.0,
        low_confidence_cost=0.5,
        name="both_corners",
    ),
    Spec("G(!bottom_left_corner)", terminal_reward=1.0, low_confidence_cost=0.5, name="avoid_bl"),
)


#: The Breakout settings' bolt cameras.
BREAKOUT_CAMERAS = {
    "breakout-occlusion": "gaussian:sigma=40+occlusion:count=2,size=0.25",
    "breakout-sigma50": "gaussian:sigma=50",
}


@dataclass(frozen=True)
class Episode:
    """One recorded episode: the detector's probabilities and the truth, per step.

    Row 0 is the first observation (read at reset), the last row the final one.
    """

    probs: np.ndarray  # float64 [T, n_fluents]
    truth: np.ndarray  # bool [T, n_fluents]


class GlitchDetector:
    """Sure of every fluent, except that on a share of frames one false fluent is
    reported in the low band (seeded)."""

    needs_truth = True

    def __init__(self, fluent_names: Sequence[str], *, rate: float, seed: int) -> None:
        self.fluent_names = tuple(fluent_names)
        self._rate = rate
        self._rng = np.random.default_rng(seed)

    def predict(self, images: np.ndarray, *, truth: np.ndarray | None = None) -> np.ndarray:
        assert truth is not None
        truth = np.asarray(truth, dtype=bool)
        n, k = truth.shape
        probs = np.where(
            truth, self._rng.uniform(0.95, 1.0, (n, k)), self._rng.uniform(0, 0.05, (n, k))
        )
        for i in np.flatnonzero(self._rng.random(n) < self._rate):
            false = np.flatnonzero(~truth[i])
            if false.size:
                probs[i, self._rng.choice(false)] = self._rng.uniform(0.5, 0.9)
        return probs.astype(np.float32)


def record(
    world: Any,
    detector: Any,
    episodes: int,
    seed: int,
    n_actions: int,
    *,
    agent: tuple[Any, Any] | None = None,
) -> list[Episode]:
    """Random play (or ``agent``'s); every finished episode's probabilities and truths.

    ``agent``: ``(venv, act)``, an SB3 ``VecEnv`` over ``world`` (already seeded) and
    ``act(observations) -> actions``; None: uniformly random actions on ``world``.
    """
    from noisybolt.envs import SB3VecEnv

    rng = np.random.default_rng(seed)
    n = world.num_envs
    if agent is None:
        venv = SB3VecEnv(world)
        venv.seed(seed)

        def act(_: Any) -> np.ndarray:
            return rng.integers(0, n_actions, size=n)

    else:
        venv, act = agent
    observations = venv.reset()

    def look(images: np.ndarray, truth: np.ndarray) -> np.ndarray:
        out = detector.predict(images, truth=truth if detector.needs_truth else None)
        return np.asarray(out, dtype=np.float64)

    truth = np.asarray(world.true_fluents(), dtype=bool)
    current: list[list[tuple[np.ndarray, np.ndarray]]] = [
        [(p, t)] for p, t in zip(look(world.bolt_images(), truth), truth, strict=True)
    ]
    done_episodes: list[Episode] = []
    while len(done_episodes) < episodes:
        venv.step_async(act(observations))
        observations, _, dones, _ = venv.step_wait()
        dones = np.asarray(dones, dtype=bool)
        images, truth = world.bolt_images(), np.asarray(world.true_fluents(), dtype=bool)
        if dones.any():
            final_truth = np.asarray(world.final_true_fluents(), dtype=bool)
            final = look(world.final_bolt_images(), final_truth)
        else:
            final_truth, final = truth, None
        probs = look(images, truth)
        for i in range(n):
            if dones[i]:
                assert final is not None
                current[i].append((final[i], final_truth[i]))
                steps = current[i]
                done_episodes.append(
                    Episode(np.stack([p for p, _ in steps]), np.stack([t for _, t in steps]))
                )
                current[i] = [(probs[i], truth[i])]
            else:
                current[i].append((probs[i], truth[i]))
    return done_episodes[:episodes]


def replay(
    episodes: Sequence[Episode],
    specs: Sequence[Spec],
    fluents: Sequence[str],
    *,
    tracking: str,
    belief: BeliefSettings | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """``(bolt accepting at the end, truth accepting at the end)``, bool ``[n_episodes,
    n_specs]``, every episode replayed through a bolt in its own row."""
    dfas = [compile_ltlf(spec.formula, fluents) for spec in specs]
    n = len(episodes)
    bolt = RestrainingBolt(
        specs,
        fluents,
        dfas=dfas,
        n_envs=n,
        tracking=tracking,  # type: ignore[arg-type]
        belief=belief,
    )
    lengths = np.array([len(e.probs) for e in episodes])
    width = len(fluents)

    def frame(t: int) -> np.ndarray:
        out = np.zeros((n, width))
        for i, e in enumerate(episodes):
            if t < len(e.probs):
                out[i] = e.probs[t]
        return out

    bolt_end = np.zeros((n, len(specs)), dtype=bool)
    out = bolt.reset(frame(0))
    bolt_end[lengths == 1] = out.accepting[lengths == 1]
    for t in range(1, int(lengths.max())):
        active = lengths > t
        last = lengths == t + 1
        out = bolt.step(frame(t), done=last, env_mask=active)
        bolt_end[last] = out.accepting[last]
    truth_end = np.zeros_like(bolt_end)
    for s, dfa in enumerate(dfas):
        for i, e in enumerate(episodes):
            trace = [dict(zip(fluents, map(bool, row), strict=True)) for row in e.truth]
            truth_end[i, s] = dfa.accepts(trace)
    return bolt_end, truth_end


def rates(bolt_end: np.ndarray, truth_end: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per spec: false acceptance (of all episodes), recall, and the true acceptances."""
    false = (bolt_end & ~truth_end).mean(axis=0)
    positives = truth_end.sum(axis=0)
    recall = np.where(
        positives > 0, (bolt_end & truth_end).sum(axis=0) / np.maximum(positives, 1), np.nan
    )
    return false, recall, positives


def setting_parts(
    name: str, seed: int, n_envs: int, breakout_world: str = "breakout-ram"
) -> tuple[Any, Any, tuple[Spec, ...], int, tuple[str, ...]]:
    """``(world, detector, specs, n_actions, monotone fluents)`` of a setting."""
    from noisybolt.envs import make_world
    from noisybolt.runs import DetectorConfig
    from noisybolt.runs.detectors import make_detector

    if name.startswith("grid"):
        noise = "regional" if name == "grid-smudge" else "none"
        world = make_world("gridworld", num_envs=n_envs, seed=seed, noise=noise)
        if name == "grid-glitch":
            detector: Any = GlitchDetector(world.fluent_names, rate=0.03, seed=seed)
        else:
            detector = make_detector(
                DetectorConfig(kind="classifier"),
                world="gridworld",
                world_kwargs={"noise": noise},
                fluent_names=world.fluent_names,
                camera_spec=world.camera_spec,
                progress=False,
                log=lambda _: None,
            )
        return world, detector, GRID_SPECS, 3, ()
    from noisybolt.runs.specs import expand_specs, resolve_spec

    noise = BREAKOUT_CAMERAS[name]
    kwargs: dict[str, Any] = {"noise": noise, "fire_on_reset": True}
    world = make_world(breakout_world, num_envs=n_envs, seed=seed, **kwargs)
    detector = make_detector(
        DetectorConfig(kind="classifier"),
        world=breakout_world,
        world_kwargs=kwargs,
        fluent_names=world.fluent_names,
        camera_spec=world.camera_spec,
        progress=False,
        log=lambda _: None,
    )
    specs = tuple(resolve_spec(n) for n in expand_specs(["left_column_milestones"]))
    return world, detector, specs, 4, tuple(world.fluent_names)


def agent_play(run_dir: str, noise: str, seed: int, n_envs: int) -> tuple[Any, tuple[Any, Any]]:
    """A trained run's policy playing its own world under the camera ``noise``:
    ``(world, (venv, act))`` for :func:`record`.

    The policy's DFA states come from a bolt on the ground truth (the oracle detector), so
    it plays as it would with a bolt that never errs; the camera under test only watches.
    Actions are sampled, as the runs' evaluations do.
    """
    from noisybolt.perception.detectors import OracleDetector
    from noisybolt.runs import TrainConfig
    from noisybolt.runs.environments import make_env
    from noisybolt.runs.run_evaluation import load_run_model
    from noisybolt.runs.rundir import RunDirectory

    run = RunDirectory(run_dir)
    config = TrainConfig.from_dict(run.read_config()).override({"world.kwargs.noise": noise})
    # Loaded onto envs of its own: loading seeds the env it is given with the run's seed.
    model = load_run_model(run, config)
    detector = OracleDetector(_world_fluents(config))
    venv = make_env(config, detector, training=False, n_envs=n_envs, seed=seed)
    return venv.world, (venv, lambda obs: model.predict(obs, deterministic=False)[0])


def _world_fluents(config: Any) -> tuple[str, ...]:
    from noisybolt.envs import make_world

    world = make_world(config.world_config.name, num_envs=1, seed=0, **config.world_settings)
    try:
        return tuple(world.fluent_names)
    finally:
        world.close()


def measure(
    name: str,
    episodes: int,
    n_envs: int,
    seed: int,
    belief_kwargs: dict[str, Any],
    breakout_world: str = "breakout-ram",
    agent_run: str | None = None,
) -> None:
    """Records a setting's episodes once and prints the side-by-side table (``agent_run``:
    the episodes are that trained run's, see :func:`agent_play`; the base rates still come
    from random play)."""
    world, detector, specs, n_actions, monotone = setting_parts(name, seed, n_envs, breakout_world)
    fluents = tuple(world.fluent_names)
    calibration = record(world, detector, max(episodes // 4, 8), seed + 1, n_actions)
    estimated = belief_settings_from_play(
        [e.probs for e in calibration], switch_rates=True, monotone=monotone
    )
    switch = np.asarray(estimated.switch_rate)
    player = "random-play"
    if agent_run is None:
        recorded = record(world, detector, episodes, seed, n_actions)
    else:
        if not name.startswith("breakout"):
            raise SystemExit("--agent plays a Breakout run: give a breakout-* --setting")
        noise = BREAKOUT_CAMERAS[name]
        agent_world, agent = agent_play(agent_run, noise, seed, n_envs)
        recorded = record(agent_world, detector, episodes, seed, n_actions, agent=agent)
        player = f"{agent_run}'s (sampled actions)"
    rates_used = np.asarray(estimated.base_rates)
    base = {"base_rates": tuple(rates_used), "monotone": monotone, **belief_kwargs}
    trackers: dict[str, BeliefSettings | None] = {
        "threshold": None,
        # With no persistence (s = 1, min_dwell = 1) the joint filter is independent
        # belief updating (IBU, Li et al. 2024) on base-rate-corrected frames.
        "IBU": BeliefSettings(**{**base, "switch_rate": 1.0, "min_dwell": 1}),
        "belief": BeliefSettings(**base),
        "belief, s est.": BeliefSettings(**{**base, "switch_rate": tuple(switch)}),
    }
    truth_rate = np.concatenate([e.truth for e in recorded]).mean(axis=0)
    n_frames = sum(len(e.probs) for e in recorded)
    print(
        f"\n### {name}: {len(recorded)} {player} episodes, {n_frames:,} frames "
        f"(seed {seed}){'; belief ' + str(belief_kwargs) if belief_kwargs else ''}"
    )
    print(
        "EM base rate (floored at 0.01) / switch rate, no labels, vs true frequency: "
        + ", ".join(
            f"{f} {r:.3f}/{sw:.2f} ({t:.3f})"
            for f, r, sw, t in zip(fluents, rates_used, switch, truth_rate, strict=True)
        )
    )
    results = {}
    for label, settings in trackers.items():
        mode = "threshold" if settings is None else "belief"
        results[label] = rates(*replay(recorded, specs, fluents, tracking=mode, belief=settings))
    labels = list(trackers)
    print(
        "| spec | true acc. | "
        + " | ".join(f"false acc. {label}" for label in labels)
        + " | "
        + " | ".join(f"recall {label}" for label in labels)
        + " |"
    )
    print("|---|---|" + "---|" * (2 * len(labels)))
    positives = results["threshold"][2]
    for s, spec in enumerate(specs):
        false = " | ".join(f"{results[label][0][s]:.1%}" for label in labels)
        recall = " | ".join(_pct(results[label][1][s]) for label in labels)
        print(f"| {spec.name} | {int(positives[s])} | {false} | {recall} |")


def _pct(value: float) -> str:
    return "n/a" if np.isnan(value) else f"{value:.1%}"


def cost(
    n_envs: int = 64, fluent_counts: Sequence[int] = (1, 2, 4, 8, 16), repeats: int = 200
) -> None:
    """µs per env-step of RestrainingBolt.step, both modes (one F(f_i) spec per fluent)."""
    from noisybolt.logic import DFA

    print(f"\n### cost per env-step, {n_envs} environments (median of {repeats} steps)")
    print("| fluents | threshold (µs) | belief (µs) |")
    print("|---|---|---|")
    rng = np.random.default_rng(0)
    for k in fluent_counts:
        fluents = [f"f{i}" for i in range(k)]
        dfas = [
            DFA.from_function(
                [f],
                n_states=2,
                initial_state=0,
                accepting=[False, True],
                delta=lambda q, m: 1 if q == 1 or m & 1 else 0,
            )
            for f in fluents
        ]
        specs = [Spec(f"F({f})", terminal_reward=1.0, low_confidence_cost=0.5) for f in fluents]
        row = []
        modes: tuple[Tracking, ...] = ("threshold", "belief")
        for tracking in modes:
            bolt = RestrainingBolt(specs, fluents, dfas=dfas, n_envs=n_envs, tracking=tracking)
            probs = rng.random((repeats + 1, n_envs, k))
            bolt.reset(probs[0])
            times = []
            for t in range(1, repeats + 1):
                start = time.perf_counter()
                bolt.step(probs[t])
                times.append(time.perf_counter() - start)
            row.append(float(np.median(times)) / n_envs * 1e6)
        print(f"| {k} | {row[0]:.2f} | {row[1]:.2f} |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--setting", action="append", help="repeatable; default: the gridworld two")
    parser.add_argument("--episodes", type=int, default=200)
    parser.add_argument("--n-envs", type=int, default=16)
    parser.add_argument("--seed", type=int, default=123)
    parser.add_argument("--cost", action="store_true", help="also time both modes")
    parser.add_argument(
        "--breakout-world",
        default="breakout-ram",
        help="breakout or breakout-ram: the same game and bolt camera, the agent's view "
        "differs (irrelevant to random play); each has its own cached classifiers",
    )
    parser.add_argument(
        "--agent",
        metavar="RUN_DIR",
        help="record a trained Breakout run's episodes (its latest model, sampled actions) "
        "instead of random play's; the camera under test only watches",
    )
    parser.add_argument("--switch-rate", type=float, default=None)
    parser.add_argument("--evidence-weight", type=float, default=None)
    args = parser.parse_args()
    import torch

    torch.set_num_threads(1)
    belief_kwargs: dict[str, Any] = {}
    if args.switch_rate is not None:
        belief_kwargs["switch_rate"] = args.switch_rate
    if args.evidence_weight is not None:
        belief_kwargs["evidence_weight"] = args.evidence_weight
    for name in args.setting or ("grid-glitch", "grid-smudge"):
        measure(
            name,
            args.episodes,
            args.n_envs,
            args.seed,
            belief_kwargs,
            args.breakout_world,
            agent_run=args.agent,
        )
    if args.cost:
        cost()


if __name__ == "__main__":
    main()
