"""Compliance estimated from the bolt's evidence alone, checked against the ground truth.

For each world and bolt camera, policies of several compliance levels (scripted, and
trained with the library, bolted and not) play episodes; every frame's detector
probabilities and true fluents are recorded once (:func:`record`). Each spec's compliance
rate is then estimated from the probabilities alone
(:func:`noisybolt.bolt.compliance.estimate_compliance`: the detector's error model, the
fluents' chains learnt from the same unlabelled episodes, with memory of whether a fluent
has been on, an exact forward pass over each DFA) and set beside the true rate of the
same episodes. A *case* is one (world, camera, policy, spec).

- **within 3 points**: ``|estimated - true| <= 0.03``;
- **coverage**: the 90 % interval for the policy's rate (error-model draws and a
  Bayesian bootstrap over episodes) holds the true rate of the episodes; ``cov. these``
  is the same for the narrower interval over these episodes only (no bootstrap);
- **ECE**: the per-episode expected calibration error (10 bins) of ``P(complied)``
  against each episode's truth, pooled over the cases' episodes.

Worlds and cameras, each with the classifier ``noisybolt train --noise ...`` would use
(cached or trained on the fly) unless said:

- the gridworld under the clean camera (``none``), the smudged corner (``regional``, the
  paper's case 4: ``bottom_left_corner`` blurred and dimmed), Gaussian noise
  (``gaussian:sigma=60``) and two occluding patches (``occlusion:count=2,size=0.3``);
- FrozenLake 8x8 (``benchmarks/unseen_worlds.py:lake8``) under its clean camera (its
  render, one pixel in eight), with a classifier of its own (see
  :func:`lake_detector_and_error_model`);
- Breakout, the paper's (the ALE game, ``breakout-ram``: the agent reads the RAM, the
  bolt an 84x84 colour camera) under ``gaussian:sigma=50``, the camera its trained agents
  in ``results/breakout`` were watched through; games cut at 3,000 frames. The ALE game,
  its classifier (4,000 images, 30 epochs: under a minute) and its play (about 2,000
  steps a second) fit this benchmark on a CPU, so MinAtar's stand-in is not needed.

The error model is measured on 2,000 fresh labelled images collected from the world
(another seed than the classifier's), as ``noisybolt evaluate`` measures a classifier
that recorded none, with successive frames' confusion counted on 200 labelled episodes
of random play.

Policies (:mod:`compliance_policies`):

- gridworld, scripted: ``top-right`` (along the top row, then down), ``bottom-left``
  (down the left column, then along the bottom) and ``interior`` (a staircase through the
  middle), mixed per episode as ``mostly-tr`` (0.8/0/0.2, eps 0.1), ``mixed``
  (0.35/0.35/0.3, eps 0.2), ``mostly-bl`` (0/0.7/0.3, eps 0.1), and ``random``
  (uniformly random actions);
- gridworld, trained (``noisybolt.runs.train``, PPO, 40,000 frames, synthetic detector,
  seeded; trained once into ``--work``): ``ppo-bolted`` (bolted with
  ``F(bottom_left_corner)``: it passes the corner on its way to the goal), ``ppo-unbolted``
  (the world's reward alone: the other way round) and ``ppo-mix`` (per episode one of the
  two, even odds); actions sampled, their bolt's DFA states tracked on the benchmark
  camera's classifier, as deployed;
- FrozenLake, scripted: ``right`` (along the top row and down the right column),
  ``detour`` (down to the bottom-left cell, back up and round the holes) and
  ``interior``, mixed as ``mostly-right`` (0.8/0/0.2), ``mixed`` (0.3/0.3/0.4) and
  ``mostly-detour`` (0/0.7/0.3), eps 0.1;
- Breakout, scripted: ``random``; ``track`` (the paddle under the ball, eps 0.05),
  ``track-left`` (offset to send the ball left, towards the fluents' column, eps 0.2),
  ``mixed`` (per episode one of those offsets or one further left, eps 0.4).

Specs: the gridworld's spec suite (``generate_spec_suite(n_specs=8, seed=0)``: Dwyer's
patterns under three scopes) plus ``F(bottom_left_corner)`` and
``G(!bottom_left_corner)``; FrozenLake's ``G(!right_col | at_goal)``, ``F(bottom_left)``,
``G(bottom_left -> F(at_goal))`` and ``!at_goal U bottom_left``; Breakout's
:data:`BREAKOUT_SPECS` over the left column's bricks (existence, absence, response,
precedence).

    .venv/bin/python benchmarks/compliance_estimates.py [--episodes 200] \\
        [--camera none --camera regional ...] [--no-lake] [--no-breakout] [--no-trained] \\
        [--work runs/compliance_estimates] [--figure PATH] [--cases]

The last line reads ``calibration: K/N cases within 3 points; coverage C%; ECE E``.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from noisybolt.bolt.compliance import ComplianceEstimate, ErrorModel, estimate_compliance
from noisybolt.logic import compile_ltlf
from noisybolt.perception.metrics import expected_calibration_error

sys.path.insert(0, str(Path(__file__).resolve().parent))  # its siblings, when loaded by path
from compliance_policies import (  # the policies it plays
    PaddlePolicy,
    Policy,
    RoutePolicy,
    TrainedPolicy,
    trained_grid_runs,
)

#: ``(n_envs, seed, fluents) -> policy``: a policy for one world's envs.
PolicyMaker = Callable[[int, int, tuple[str, ...]], Policy]
#: Labelled episodes of random play the successive frames' confusion is counted on.
LABELLED_EPISODES = 200

GRID_CAMERAS = ("none", "regional", "gaussian:sigma=60", "occlusion:count=2,size=0.3")
GRID_ROUTES = {
    "top-right": [(4, 1), (4, 4)],
    "bottom-left": [(1, 4), (4, 4)],
    "interior": [(2, 1), (2, 2), (3, 2), (3, 3), (4, 3), (4, 4)],
}
GRID_POLICIES: dict[str, tuple[dict[str, float], float]] = {
    "mostly-tr": ({"top-right": 0.8, "interior": 0.2}, 0.1),
    "mixed": ({"top-right": 0.35, "bottom-left": 0.35, "interior": 0.3}, 0.2),
    "mostly-bl": ({"bottom-left": 0.7, "interior": 0.3}, 0.1),
    "random": ({"interior": 1.0}, 1.0),
}
GRID_EXTRA_SPECS = ("F(bottom_left_corner)", "G(!bottom_left_corner)")
LAKE_ROUTES = {
    "right": [(7, 0), (7, 7)],
    "detour": [(0, 7), (0, 1), (4, 1), (4, 5), (5, 5), (5, 7), (7, 7)],
    "interior": [(4, 0), (4, 5), (5, 5), (5, 7), (7, 7)],
}
LAKE_POLICIES: dict[str, tuple[dict[str, float], float]] = {
    "mostly-right": ({"right": 0.8, "interior": 0.2}, 0.1),
    "mixed": ({"right": 0.3, "detour": 0.3, "interior": 0.4}, 0.1),
    "mostly-detour": ({"detour": 0.7, "interior": 0.3}, 0.1),
}
LAKE_SPECS = (
    "G(!right_col | at_goal)",
    "F(bottom_left)",
    "G(bottom_left -> F(at_goal))",
    "!at_goal U bottom_left",
)
#: The gridworld's trained agents (:func:`compliance_policies.trained_grid_runs`), each
#: episode played by one of them drawn with these weights.
TRAINED_PREFIX = "ppo-"
TRAINED_MIXTURES: dict[str, dict[str, float]] = {
    "ppo-bolted": {"bolted": 1.0},
    "ppo-unbolted": {"unbolted": 1.0},
    "ppo-mix": {"bolted": 0.5, "unbolted": 0.5},
}
#: The paper's Breakout: the ALE game, the agent reading the RAM (which the scripted
#: paddle reads too), the bolt's 84x84 colour camera with the noise its trained agents were
#: watched through (results/breakout), FIRE after a reset and a lost life.
BREAKOUT_WORLD = "breakout-ram"
BREAKOUT_KWARGS: dict[str, Any] = {"noise": "gaussian:sigma=50", "fire_on_reset": True}
#: Games cut at 3,000 frames (750 steps): a tracking paddle rarely loses its five balls,
#: and uncut games would cost minutes each on a CPU.
BREAKOUT_PLAY: dict[str, Any] = {"max_episode_frames": 3000}
#: ``name: ({paddle offset: weight}, eps)`` (:class:`compliance_policies.PaddlePolicy`).
BREAKOUT_POLICIES: dict[str, tuple[dict[int, float], float]] = {
    "random": ({0: 1.0}, 1.0),
    "track": ({0: 1.0}, 0.05),
    "track-left": ({-6: 1.0}, 0.2),
    "mixed": ({0: 0.5, -10: 0.5}, 0.4),
}
BREAKOUT_SPECS: dict[str, tuple[str, str]] = {
    "left-row5": ("F(left_gone_row5)", "existence"),
    "left-row3": ("F(left_gone_row3)", "existence"),
    "keep-row4": ("G(!left_gone_row4)", "absence"),
    "row5-then-row3": ("G(left_gone_row5 -> F(left_gone_row3))", "response"),
    "row4-before-row3": ("G(!left_gone_row3) | (!left_gone_row3 U left_gone_row4)", "precedence"),
}
WORLD_LABELS = {"unseen_worlds:lake8": "lake8", BREAKOUT_WORLD: "breakout"}


@dataclass(frozen=True)
class Episode:
    """One recorded episode: the detector's probabilities and the truth, per frame."""

    probs: np.ndarray  # float64 [T, n_fluents]
    truth: np.ndarray  # bool [T, n_fluents]


def record(
    world: Any,
    detector: Any,
    policy: Policy,
    episodes: int,
    seed: int,
    *,
    views: list[tuple[np.ndarray, np.ndarray]] | None = None,
) -> list[Episode]:
    """Plays until ``episodes`` episodes ended; every frame's probabilities and truths
    (and, given ``views``, every frame's image and truth appended to it). The policy is
    told what the detector read after each step (:class:`compliance_policies.Policy`)."""
    n = world.num_envs

    def look(images: np.ndarray, truth: np.ndarray) -> np.ndarray:
        if views is not None:
            views.extend(zip(images, truth, strict=True))
        out = detector.predict(images, truth=truth if detector.needs_truth else None)
        return np.asarray(out, dtype=np.float64)

    obs, info = world.reset(seed=seed)
    truth = np.asarray(info["true_fluents"], dtype=bool)
    probs = look(np.asarray(info["bolt_image"]), truth)
    policy.start(probs)
    current = [[(probs[i], truth[i])] for i in range(n)]
    done: list[Episode] = []
    while len(done) < episodes:
        obs, _, terminated, truncated, info = world.step(policy.act(obs, info, truth))
        ended = np.flatnonzero(np.asarray(terminated) | np.asarray(truncated))
        images = np.asarray(info["bolt_image"])
        truth = np.asarray(info["true_fluents"], dtype=bool)
        last_truth = truth.copy()
        batch = images
        if ended.size:
            final = info["final_info"]
            last_truth[ended] = np.asarray(final["true_fluents"], dtype=bool)[ended]
            batch = np.concatenate([images, np.asarray(final["bolt_image"])[ended]])
        seen = look(batch, np.concatenate([truth, last_truth[ended]]))
        probs, last_probs = seen[:n].copy(), seen[:n].copy()
        last_probs[ended] = seen[n:]
        policy.seen(last_probs, probs[ended], ended)
        for i in range(n):
            if i in ended:
                current[i].append((last_probs[i], last_truth[i]))
                steps = current[i]
                done.append(
                    Episode(np.stack([p for p, _ in steps]), np.stack([t for _, t in steps]))
                )
                current[i] = [(probs[i], truth[i])]
            else:
                current[i].append((probs[i], truth[i]))
    return done[:episodes]


@dataclass(frozen=True)
class Case:
    """One (world, camera, policy, spec) and what was measured."""

    world: str
    camera: str
    policy: str
    spec: str
    family: str
    true: float
    estimate: ComplianceEstimate
    outcomes: np.ndarray  # bool [n_episodes]
    independent: ComplianceEstimate  # the same, frames taken as independent given the truth

    def frames_independent(self) -> Case:
        """This case as estimated with frames independent given the truth."""
        return replace(self, estimate=self.independent)

    @property
    def error(self) -> float:
        return self.estimate.rate - self.true

    @property
    def covered(self) -> bool:
        return self.estimate.low - 1e-9 <= self.true <= self.estimate.high + 1e-9

    @property
    def covered_these(self) -> bool:
        e = self.estimate
        return e.episodes_low - 1e-9 <= self.true <= e.episodes_high + 1e-9


def detector_and_error_model(
    world_name: str, world_kwargs: dict[str, Any], seed: int
) -> tuple[Any, Any]:
    """The classifier ``noisybolt train`` would use for this camera, and its error model
    measured on 2,000 fresh labelled images."""
    from noisybolt.envs import make_world
    from noisybolt.perception.dataset import collect_samples
    from noisybolt.perception.error_model import error_model_of, record_labelled_play
    from noisybolt.runs.detectors import make_detector
    from noisybolt.runs.sections import DetectorConfig

    probe = make_world(world_name, num_envs=16, seed=seed + 1000, **world_kwargs)
    detector = make_detector(
        DetectorConfig(kind="classifier"),
        world=world_name,
        world_kwargs=world_kwargs,
        fluent_names=probe.fluent_names,
        camera_spec=probe.camera_spec,
        progress=False,
        log=lambda line: print(
            f"  [{world_name} {world_kwargs}] {line.splitlines()[0]}", file=sys.stderr
        ),
    )
    labelled = collect_samples(probe, num_samples=2000, seed=seed + 1000, progress=False)
    probe.close()
    player = make_world(world_name, num_envs=16, seed=seed + 2000, **world_kwargs)
    sequences = record_labelled_play(
        player, detector, episodes=LABELLED_EPISODES, seed=seed + 2000, max_frames=40_000
    )
    player.close()
    return detector, error_model_of(detector, labelled=labelled, sequences=sequences)


def lake_detector_and_error_model(
    world_name: str, routes: Mapping[str, list[tuple[int, int]]], seed: int
) -> tuple[Any, Any]:
    """FrozenLake's: random play never reaches the goal and hardly the bottom-left cell, so
    the on-the-fly classifier never sees them true; this one learns from 4,000 labelled
    frames of the scripted routes' play (seeded apart from the evaluation), and its error
    model is measured on 200 further labelled episodes of it (another seed)."""
    from noisybolt.envs import make_world
    from noisybolt.perception.dataset import FluentDataset
    from noisybolt.perception.detectors import OracleDetector
    from noisybolt.perception.error_model import measure_error_model
    from noisybolt.perception.training import TrainingConfig, train_classifier
    from noisybolt.runs.detectors import classifier_architecture

    mixture = {name: 1.0 for name in routes}

    def play(detector: Any, episodes: int, at: int, views: Any = None) -> list[Episode]:
        world = make_world(world_name, num_envs=16, seed=at)
        policy = RoutePolicy(routes, mixture, 0.2, n_envs=16, n_actions=4, turning=False, seed=at)
        try:
            return record(world, detector, policy, episodes, at, views=views)
        finally:
            world.close()

    probe = make_world(world_name, num_envs=1, seed=seed)
    fluents, camera = tuple(probe.fluent_names), probe.camera_spec
    probe.close()
    views: list[tuple[np.ndarray, np.ndarray]] = []
    play(OracleDetector(fluents), 300, seed + 3000, views)
    picked = np.random.default_rng(seed).permutation(len(views))[:4000]
    data = FluentDataset(
        images=np.stack([views[i][0] for i in picked]),
        labels=np.stack([views[i][1] for i in picked]),
        fluent_names=fluents,
        camera_spec=camera,
    )
    detector = train_classifier(
        data,
        config=classifier_architecture(camera),
        training=TrainingConfig(epochs=30, seed=seed),
        progress=False,
    ).detector
    held_out = play(detector, 200, seed + 4000)
    sequences = [(e.probs, e.truth) for e in held_out]
    model = measure_error_model(
        np.concatenate([e.probs for e in held_out]),
        np.concatenate([e.truth for e in held_out]),
        fluent_names=fluents,
        sequences=sequences,
    )
    return detector, model


def measure_world(
    world_name: str,
    camera: str,
    detector: Any,
    model: ErrorModel,
    policies: Mapping[str, PolicyMaker],
    specs: Mapping[str, tuple[str, str]],
    *,
    episodes: int,
    seed: int,
    n_envs: int,
    world_kwargs: Mapping[str, Any],
) -> list[Case]:
    """Every (policy, spec) case of one world and camera: each policy plays ``episodes``
    episodes of ``make_world(world_name, **world_kwargs)`` (seeded by its place among
    ``policies``), read by ``detector``, estimated with ``model``."""
    from noisybolt.envs import make_world

    # The same model without successive frames' confusion: frames independent given the truth.
    independent = ErrorModel(
        fluent_names=model.fluent_names, edges=model.edges, counts=model.counts
    )
    cases = []
    for p, (policy_name, make_policy) in enumerate(policies.items()):
        world = make_world(world_name, num_envs=n_envs, seed=seed + p, **world_kwargs)
        fluents = tuple(world.fluent_names)
        policy = make_policy(n_envs, seed + p, fluents)
        start = time.perf_counter()
        recorded = record(world, detector, policy, episodes, seed + p)
        world.close()
        dfas = {name: compile_ltlf(formula, fluents) for name, (formula, _) in specs.items()}
        traces = [e.probs for e in recorded]
        estimates = estimate_compliance(dfas, fluents, traces, model, seed=seed + p)
        flat = estimate_compliance(dfas, fluents, traces, independent, seed=seed + p)
        for name, dfa in dfas.items():
            outcomes = np.array(
                [
                    dfa.accepts(
                        [dict(zip(fluents, map(bool, row), strict=True)) for row in e.truth]
                    )
                    for e in recorded
                ]
            )
            cases.append(
                Case(
                    world=WORLD_LABELS.get(world_name, world_name),
                    camera=camera,
                    policy=policy_name,
                    spec=name,
                    family=specs[name][1],
                    true=float(outcomes.mean()),
                    estimate=estimates[name],
                    outcomes=outcomes,
                    independent=flat[name],
                )
            )
        print(
            f"  {world_name} {camera} {policy_name}: {len(recorded)} episodes, "
            f"{sum(len(e.probs) for e in recorded):,} frames, {time.perf_counter() - start:.0f} s",
            file=sys.stderr,
        )
    return cases


def summary_row(label: str, cases: Sequence[Case]) -> str:
    """One markdown row: cases, within 3 points, coverage, ECE, mean and worst error, width."""
    probs = np.concatenate([c.estimate.per_episode for c in cases])
    truth = np.concatenate([c.outcomes for c in cases])
    errors = np.array([abs(c.error) for c in cases])
    widths = np.array([c.estimate.high - c.estimate.low for c in cases])
    within = int((errors <= 0.03 + 1e-9).sum())
    covered = sum(c.covered for c in cases)
    these = sum(c.covered_these for c in cases)
    return (
        f"| {label} | {len(cases)} | {within}/{len(cases)} | {covered / len(cases):.0%} | "
        f"{these / len(cases):.0%} | {expected_calibration_error(probs, truth):.3f} | "
        f"{errors.mean() * 100:.1f} | {errors.max() * 100:.1f} | {widths.mean() * 100:.1f} |"
    )


def route_policies(
    routes: Mapping[str, list[tuple[int, int]]],
    policies: Mapping[str, tuple[dict[str, float], float]],
    *,
    n_actions: int,
    turning: bool,
) -> dict[str, PolicyMaker]:
    """Each scripted route mixture ``name: (mixture, eps)`` as a policy maker."""

    def maker(mixture: dict[str, float], eps: float) -> PolicyMaker:
        return lambda n, seed, fluents: RoutePolicy(
            routes, mixture, eps, n_envs=n, n_actions=n_actions, turning=turning, seed=seed,
            fluents=fluents,
        )  # fmt: skip

    return {name: maker(mixture, eps) for name, (mixture, eps) in policies.items()}


def trained_policies(runs: Mapping[str, Path]) -> dict[str, PolicyMaker]:
    """The trained agents of :data:`TRAINED_MIXTURES` over ``runs`` (label -> run)."""

    def maker(weights: dict[str, float]) -> PolicyMaker:
        chosen = [label for label in runs if weights.get(label, 0) > 0]
        return lambda n, seed, fluents: TrainedPolicy.from_runs(
            [runs[label] for label in chosen], [weights[label] for label in chosen],
            fluents=fluents, n_envs=n, seed=seed,
        )  # fmt: skip

    return {name: maker(weights) for name, weights in TRAINED_MIXTURES.items()}


def breakout_policies() -> dict[str, PolicyMaker]:
    """:data:`BREAKOUT_POLICIES` as policy makers."""

    def maker(offsets: dict[int, float], eps: float) -> PolicyMaker:
        return lambda n, seed, fluents: PaddlePolicy(offsets, eps, n_envs=n, seed=seed)

    return {name: maker(offsets, eps) for name, (offsets, eps) in BREAKOUT_POLICIES.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=200)
    parser.add_argument("--n-envs", type=int, default=16)
    parser.add_argument("--seed", type=int, default=50)
    parser.add_argument("--camera", action="append", help="gridworld cameras (repeatable)")
    parser.add_argument("--no-lake", action="store_true", help="leave FrozenLake out")
    parser.add_argument("--no-grid", action="store_true", help="leave the gridworld out")
    parser.add_argument("--no-breakout", action="store_true", help="leave Breakout out")
    parser.add_argument(
        "--no-trained", action="store_true", help="leave the gridworld's trained agents out"
    )
    parser.add_argument(
        "--work",
        type=Path,
        default=Path("runs/compliance_estimates"),
        help="where the trained agents are trained once and kept (default: %(default)s)",
    )
    parser.add_argument("--figure", type=Path, default=None, help="reliability diagram (PNG)")
    parser.add_argument("--cases", action="store_true", help="print every case's row too")
    parser.add_argument("--save", type=Path, default=None, help="pickle every case here")
    args = parser.parse_args()
    import torch

    torch.set_num_threads(1)
    from noisybolt.experiments.spec_families import generate_spec_suite

    suite = generate_spec_suite(n_specs=8, seed=0)
    grid_specs = {s.name: (s.formula, s.family) for s in suite}
    grid_specs.update(
        {
            "ever-bl": (GRID_EXTRA_SPECS[0], "existence"),
            "never-bl": (GRID_EXTRA_SPECS[1], "absence"),
        }
    )
    common = {"episodes": args.episodes, "seed": args.seed, "n_envs": args.n_envs}
    grid = route_policies(GRID_ROUTES, GRID_POLICIES, n_actions=3, turning=True)
    if not args.no_trained and not args.no_grid:
        grid |= trained_policies(trained_grid_runs(args.work, args.seed))
    cases: list[Case] = []
    for camera in () if args.no_grid else args.camera or GRID_CAMERAS:
        kwargs = {"noise": camera}
        detector, model = detector_and_error_model("gridworld", kwargs, args.seed)
        cases += measure_world(
            "gridworld", camera, detector, model, grid, grid_specs, world_kwargs=kwargs, **common
        )
    if not args.no_lake:
        lake_specs = {
            "keep-right-clear": (LAKE_SPECS[0], "absence/before"),
            "visit-bl": (LAKE_SPECS[1], "existence"),
            "bl-then-goal": (LAKE_SPECS[2], "response"),
            "bl-before-goal": (LAKE_SPECS[3], "precedence"),
        }
        lake = "unseen_worlds:lake8"
        detector, model = lake_detector_and_error_model(lake, LAKE_ROUTES, args.seed)
        policies = route_policies(LAKE_ROUTES, LAKE_POLICIES, n_actions=4, turning=False)
        cases += measure_world(
            lake, "clean", detector, model, policies, lake_specs, world_kwargs={}, **common
        )
    if not args.no_breakout:
        kwargs = dict(BREAKOUT_KWARGS)
        detector, model = detector_and_error_model(BREAKOUT_WORLD, kwargs, args.seed)
        cases += measure_world(
            BREAKOUT_WORLD,
            BREAKOUT_KWARGS["noise"],
            detector,
            model,
            breakout_policies(),
            BREAKOUT_SPECS,
            world_kwargs=kwargs | BREAKOUT_PLAY,
            **common,
        )
    print(
        f"\n### compliance estimates: {args.episodes} episodes per (world, camera, policy), "
        f"seed {args.seed}"
    )
    if args.cases:
        print("| world | camera | policy | spec | true | estimated | 90% interval | these |")
        print("|---|---|---|---|---:|---:|---|---|")
        for c in cases:
            e = c.estimate
            print(
                f"| {c.world} | {c.camera} | {c.policy} | {c.spec} | {c.true:.1%} | "
                f"{e.rate:.1%} | [{e.low:.1%}, {e.high:.1%}] | "
                f"[{e.episodes_low:.1%}, {e.episodes_high:.1%}] |"
            )
        print()
    header = (
        "| world, camera | cases | within 3 pts | coverage | cov. these | per-episode ECE "
        "| mean abs. err (pts) | worst (pts) | mean 90% width (pts) |\n"
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|"
    )
    print(header)
    groups: dict[str, list[Case]] = {}
    for c in cases:
        groups.setdefault(f"{c.world}, {c.camera}", []).append(c)
    for label, group in groups.items():
        print(summary_row(label, group))
    print(summary_row("all", cases))
    kinds = {"scripted policies": False, "trained policies": True}
    for label, trained in kinds.items():
        group = [c for c in cases if c.policy.startswith(TRAINED_PREFIX) == trained]
        if group:
            print(summary_row(label, group))
    if args.save is not None:
        import pickle

        args.save.write_bytes(pickle.dumps(cases))
    print("\nthe same episodes, frames taken as independent given the truth (no successions):\n")
    print(header)
    for label, group in groups.items():
        print(summary_row(label, [c.frames_independent() for c in group]))
    print(summary_row("all", [c.frames_independent() for c in cases]))
    if args.figure is not None:
        from noisybolt.viz.calibration import reliability_diagram

        reliability_diagram(
            {
                label: (
                    np.concatenate([c.estimate.per_episode for c in group]),
                    np.concatenate([c.outcomes for c in group]),
                )
                for label, group in groups.items()
            },
            args.figure,
            title="P(complied) per episode, by world and camera",
        )
        print(f"reliability diagram: {args.figure}")
    probs = np.concatenate([c.estimate.per_episode for c in cases])
    truth = np.concatenate([c.outcomes for c in cases])
    within = sum(abs(c.error) <= 0.03 + 1e-9 for c in cases)
    coverage = sum(c.covered for c in cases) / len(cases)
    print(
        f"calibration: {within}/{len(cases)} cases within 3 points; coverage {coverage:.0%}; "
        f"ECE {expected_calibration_error(probs, truth):.3f}"
    )


if __name__ == "__main__":
    main()
