"""Compliance estimated from the bolt's evidence alone, checked against the ground truth.

For each world and bolt camera, scripted policies of several compliance levels play
episodes; every frame's detector probabilities and true fluents are recorded once. Each
spec's compliance rate is then estimated from the probabilities alone
(:func:`noisybolt.bolt.compliance.estimate_compliance`: the detector's error model, the
fluents' chains learnt from the same unlabelled episodes, with memory of whether a fluent
has been on, an exact forward pass over each DFA) and set beside the true rate of the
same episodes. A *case* is one (world,
camera, policy, spec).

- **within 3 points**: ``|estimated - true| <= 0.03``;
- **coverage**: the 90 % interval for the policy's rate (error-model draws and a
  Bayesian bootstrap over episodes) holds the true rate of the episodes; ``cov. these``
  is the same for the narrower interval over these episodes only (no bootstrap);
- **ECE**: the per-episode expected calibration error (10 bins) of ``P(complied)``
  against each episode's truth, pooled over the cases' episodes.

Worlds and cameras: the gridworld under the clean camera (``none``), the smudged corner
(``regional``, the paper's case 4: ``bottom_left_corner`` blurred and dimmed), Gaussian
noise (``gaussian:sigma=60``) and two occluding patches (``occlusion:count=2,size=0.3``),
each with the classifier ``noisybolt train --noise ...`` would use (cached or trained on
the fly); FrozenLake 8x8 (``benchmarks/unseen_worlds.py:lake8``) under its clean
camera (its render, one pixel in eight), with its classifier. Breakout is not included.

The error model is measured on 2,000 fresh labelled images collected from the world
(another seed than the classifier's), as ``noisybolt evaluate`` measures a classifier
that recorded none.

Policies (scripted, not trained: each episode follows one of a few routes, chosen by a
mixture, taking a uniformly random action instead with probability ``eps``):

- gridworld: ``top-right`` (along the top row, then down), ``bottom-left`` (down the
  left column, then along the bottom) and ``interior`` (a staircase through the middle),
  mixed as ``mostly-tr`` (0.8/0/0.2, eps 0.1), ``mixed`` (0.35/0.35/0.3, eps 0.2),
  ``mostly-bl`` (0/0.7/0.3, eps 0.1), and ``random`` (uniformly random actions).
- FrozenLake: ``right`` (along the top row and down the right column), ``detour`` (down
  to the bottom-left cell, back up and round the holes) and ``interior``, mixed as
  ``mostly-right`` (0.8/0/0.2), ``mixed`` (0.3/0.3/0.4) and ``mostly-detour``
  (0/0.7/0.3), eps 0.1.

Specs: the gridworld's spec suite (``generate_spec_suite(n_specs=8, seed=0)``: Dwyer's
patterns under three scopes) plus ``F(bottom_left_corner)`` and
``G(!bottom_left_corner)``; FrozenLake's ``G(!right_col | at_goal)``, ``F(bottom_left)``,
``G(bottom_left -> F(at_goal))`` and ``!at_goal U bottom_left``.

    .venv/bin/python benchmarks/compliance_estimates.py [--episodes 200] \\
        [--camera none --camera regional ...] [--no-lake] [--figure PATH] [--cases]

The last line reads ``calibration: K/N cases within 3 points; coverage C%; ECE E``.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from noisybolt.bolt.compliance import ComplianceEstimate, ErrorModel, estimate_compliance
from noisybolt.logic import compile_ltlf
from noisybolt.perception.metrics import expected_calibration_error

HERE = Path(__file__).resolve().parent
#: Labelled episodes of random play the successive frames' confusion is counted on.
LABELLED_EPISODES = 200

GRID_CAMERAS = ("none", "regional", "gaussian:sigma=60", "occlusion:count=2,size=0.3")
# Gridworld headings in the order of its facing_* fluents' directions: E, S, W, N.
_STEPS = {0: (1, 0), 1: (0, 1), 2: (-1, 0), 3: (0, -1)}
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


@dataclass(frozen=True)
class Episode:
    """One recorded episode: the detector's probabilities and the truth, per frame."""

    probs: np.ndarray  # float64 [T, n_fluents]
    truth: np.ndarray  # bool [T, n_fluents]


class RoutePolicy:
    """Per episode, a route drawn from a mixture; greedy moves to its next waypoint, or a
    uniformly random action with probability ``eps`` (seeded)."""

    def __init__(
        self,
        routes: Mapping[str, list[tuple[int, int]]],
        mixture: Mapping[str, float],
        eps: float,
        *,
        n_envs: int,
        n_actions: int,
        turning: bool,
        seed: int,
    ) -> None:
        self._names = list(mixture)
        self._weights = np.array([mixture[n] for n in self._names], dtype=np.float64)
        self._weights /= self._weights.sum()
        self._routes = routes
        self._eps = eps
        self._n_actions = n_actions
        self._turning = turning
        self._rng = np.random.default_rng(seed)
        self._route: list[list[tuple[int, int]]] = [[] for _ in range(n_envs)]
        self._next = np.zeros(n_envs, dtype=int)
        for i in range(n_envs):
            self.restart(i)

    def restart(self, i: int) -> None:
        """A new episode in env ``i``: a new route."""
        self._route[i] = self._routes[self._rng.choice(self._names, p=self._weights)]
        self._next[i] = 0

    def act(self, positions: np.ndarray, headings: np.ndarray | None) -> np.ndarray:
        """Actions for the envs at ``positions`` (int ``[n, 2]``, ``(x, y)``)."""
        actions = np.zeros(len(positions), dtype=np.int64)
        for i, (x, y) in enumerate(positions.tolist()):
            route = self._route[i]
            while self._next[i] < len(route) - 1 and route[self._next[i]] == (x, y):
                self._next[i] += 1
            if self._rng.random() < self._eps:
                actions[i] = self._rng.integers(self._n_actions)
                continue
            tx, ty = route[self._next[i]]
            # E, S, W, N as the gridworld's headings
            want = (0 if tx > x else 2) if tx != x else (1 if ty > y else 3)
            if self._turning:
                assert headings is not None
                turn = (want - int(headings[i])) % 4
                actions[i] = 2 if turn == 0 else (1 if turn == 1 else 0)
            else:  # FrozenLake: 0 left, 1 down, 2 right, 3 up
                actions[i] = {0: 2, 1: 1, 2: 0, 3: 3}[want]
        return actions


def _headings(truth: np.ndarray, fluents: Sequence[str]) -> np.ndarray:
    cols = [fluents.index(f) for f in ("facing_right", "facing_down", "facing_left", "facing_up")]
    return np.argmax(truth[:, cols], axis=1)


def record(
    world: Any,
    detector: Any,
    policy: RoutePolicy,
    episodes: int,
    seed: int,
    turning: bool,
    *,
    views: list[tuple[np.ndarray, np.ndarray]] | None = None,
) -> list[Episode]:
    """Plays until ``episodes`` episodes ended; every frame's probabilities and truths
    (and, given ``views``, every frame's image and truth appended to it)."""
    fluents = list(world.fluent_names)
    n = world.num_envs

    def look(images: np.ndarray, truth: np.ndarray) -> np.ndarray:
        if views is not None:
            views.extend(zip(images, truth, strict=True))
        out = detector.predict(images, truth=truth if detector.needs_truth else None)
        return np.asarray(out, dtype=np.float64)

    _, info = world.reset(seed=seed)
    truth = np.asarray(info["true_fluents"], dtype=bool)
    positions = np.asarray(info["grid_position"])
    probs = look(np.asarray(info["bolt_image"]), truth)
    current = [[(probs[i], truth[i])] for i in range(n)]
    done: list[Episode] = []
    while len(done) < episodes:
        headings = _headings(truth, fluents) if turning else None
        _, _, terminated, truncated, info = world.step(policy.act(positions, headings))
        ended = np.flatnonzero(np.asarray(terminated) | np.asarray(truncated))
        images = np.asarray(info["bolt_image"])
        truth = np.asarray(info["true_fluents"], dtype=bool)
        positions = np.asarray(info["grid_position"])
        last_truth = truth.copy()
        batch = images
        if ended.size:
            final = info["final_info"]
            last_truth[ended] = np.asarray(final["true_fluents"], dtype=bool)[ended]
            batch = np.concatenate([images, np.asarray(final["bolt_image"])[ended]])
        seen = look(batch, np.concatenate([truth, last_truth[ended]]))
        probs, last_probs = seen[:n].copy(), seen[:n].copy()
        last_probs[ended] = seen[n:]
        for i in range(n):
            if i in ended:
                current[i].append((last_probs[i], last_truth[i]))
                steps = current[i]
                done.append(
                    Episode(np.stack([p for p, _ in steps]), np.stack([t for _, t in steps]))
                )
                current[i] = [(probs[i], truth[i])]
                policy.restart(i)
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
            return record(world, detector, policy, episodes, at, False, views=views)
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
    camera: str | None,
    policies: Mapping[str, tuple[dict[str, float], float]],
    routes: Mapping[str, list[tuple[int, int]]],
    specs: Mapping[str, tuple[str, str]],
    *,
    episodes: int,
    seed: int,
    n_envs: int,
    turning: bool,
    n_actions: int,
) -> list[Case]:
    """Every (policy, spec) case of one world and camera."""
    from noisybolt.envs import make_world

    kwargs = {} if camera is None else {"noise": camera}
    if world_name.endswith(":lake8"):
        detector, model = lake_detector_and_error_model(world_name, routes, seed)
    else:
        detector, model = detector_and_error_model(world_name, kwargs, seed)
    # The same model without successive frames' confusion: frames independent given the truth.
    independent = ErrorModel(
        fluent_names=model.fluent_names, edges=model.edges, counts=model.counts
    )
    cases = []
    for p, (policy_name, (mixture, eps)) in enumerate(policies.items()):
        world = make_world(world_name, num_envs=n_envs, seed=seed + p, **kwargs)
        fluents = tuple(world.fluent_names)
        policy = RoutePolicy(
            routes, mixture, eps, n_envs=n_envs, n_actions=n_actions, turning=turning, seed=seed + p
        )
        start = time.perf_counter()
        recorded = record(world, detector, policy, episodes, seed + p, turning)
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
                    world=world_name.split(":")[-1],
                    camera=camera or "clean",
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
            f"  {world_name} {camera or 'clean'} {policy_name}: {len(recorded)} episodes, "
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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=200)
    parser.add_argument("--n-envs", type=int, default=16)
    parser.add_argument("--seed", type=int, default=50)
    parser.add_argument("--camera", action="append", help="gridworld cameras (repeatable)")
    parser.add_argument("--no-lake", action="store_true", help="leave FrozenLake out")
    parser.add_argument("--no-grid", action="store_true", help="leave the gridworld out")
    parser.add_argument("--figure", type=Path, default=None, help="reliability diagram (PNG)")
    parser.add_argument("--cases", action="store_true", help="print every case's row too")
    args = parser.parse_args()
    import torch

    torch.set_num_threads(1)
    sys.path.insert(0, str(HERE))  # unseen_worlds, for the FrozenLake factory
    from noisybolt.experiments.spec_families import generate_spec_suite

    suite = generate_spec_suite(n_specs=8, seed=0)
    grid_specs = {s.name: (s.formula, s.family) for s in suite}
    grid_specs.update(
        {
            "ever-bl": (GRID_EXTRA_SPECS[0], "existence"),
            "never-bl": (GRID_EXTRA_SPECS[1], "absence"),
        }
    )
    cases: list[Case] = []
    for camera in () if args.no_grid else args.camera or GRID_CAMERAS:
        cases += measure_world(
            "gridworld",
            camera,
            GRID_POLICIES,
            GRID_ROUTES,
            grid_specs,
            episodes=args.episodes,
            seed=args.seed,
            n_envs=args.n_envs,
            turning=True,
            n_actions=3,
        )
    if not args.no_lake:
        lake_specs = {
            "keep-right-clear": (LAKE_SPECS[0], "absence/before"),
            "visit-bl": (LAKE_SPECS[1], "existence"),
            "bl-then-goal": (LAKE_SPECS[2], "response"),
            "bl-before-goal": (LAKE_SPECS[3], "precedence"),
        }
        cases += measure_world(
            "unseen_worlds:lake8",
            None,
            LAKE_POLICIES,
            LAKE_ROUTES,
            lake_specs,
            episodes=args.episodes,
            seed=args.seed,
            n_envs=args.n_envs,
            turning=False,
            n_actions=4,
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
