"""``noisybolt demo``: a bolt-restrained agent on the paper's gridworld, end to end.

By default: PPO learns the gridworld under ``G(on_edge)`` while the bolt watches through
its own noisy camera (the paper's case-4 smudge over the bottom-left corner) with a CNN
fluent classifier, trained on the fly the first time and cached. Then the policy is
evaluated from ground truth and a GIF and a trajectory heat-map are saved.

``--walkthrough`` instead prints every DFA (states, accepting states, edges with their
guards and supports), then walks one scripted episode of the gridworld — down the left
wall through the bottom-left corner, whose fluent the bolt sees only with low confidence
(the paper's case 4), then east to the goal — through Algorithm 1, printing per step the
fluent probabilities, their confidence bands, every DFA's state and the reward terms.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import Any

import numpy as np

from noisybolt.agents.specs import PAPER_SPECS, resolve_spec
from noisybolt.bolt import Band, confidence_bands
from noisybolt.envs.gridworld import GridAction, GridworldEnv
from noisybolt.logic import compile_ltlf
from noisybolt.perception.detectors import BetaNoise, SyntheticDetector
from noisybolt.wrappers import RestrainingBoltWrapper

__all__ = ["register", "run_training_demo", "run_walkthrough"]

GRIDWORLD_SPECS = ("edge", "avoid_top_right", "top_right_once", "one_corner_once")
SHORT = {
    "on_edge": "edge",
    "top_right_corner": "tr",
    "bottom_left_corner": "bl",
    "facing_up": "up",
    "facing_down": "down",
    "facing_left": "left",
    "facing_right": "right",
}
# Down the west wall to the bottom-left corner, east along the south wall to the goal.
SCRIPT = (
    [GridAction.RIGHT] + [GridAction.FORWARD] * 3 + [GridAction.LEFT] + [GridAction.FORWARD] * 3
)
BAND_MARK = {Band.ABSENT: " ", Band.LOW: "~", Band.HIGH: "*"}


def register(subparsers: Any) -> None:
    """Adds ``noisybolt demo``."""
    parser = subparsers.add_parser(
        "demo",
        help="compile the paper's gridworld specs and walk a noisy episode through Algorithm 1",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--seed", type=int, default=0, help="seed (default 0)")
    parser.add_argument(
        "--walkthrough",
        action="store_true",
        help="only compile the specs and walk one scripted noisy episode through Algorithm 1",
    )
    parser.add_argument("--frames", type=int, default=60_000, help="training frames")
    parser.add_argument("--out", type=Path, default=None, help="run directory")
    parser.set_defaults(func=_run)


def _run(args: argparse.Namespace) -> int:
    if args.walkthrough:
        return run_walkthrough(seed=args.seed)
    return run_training_demo(seed=args.seed, frames=args.frames, out=args.out)


def run_training_demo(*, seed: int = 0, frames: int = 60_000, out: Path | None = None) -> int:
    """Trains PPO under ``G(on_edge)`` with the noisy classifier bolt and evaluates it."""
    from noisybolt.agents.run_evaluation import evaluate_run
    from noisybolt.agents.training import DetectorConfig, TrainConfig, train
    from noisybolt.cli.train import format_eval_table

    out = out or Path("runs") / time.strftime("demo-%Y%m%d-%H%M%S")
    config = TrainConfig.create(
        specs=["edge"],
        algo="ppo",
        world_kwargs={"noise": "regional"},
        detector=DetectorConfig(kind="classifier", seed=seed),
        frames=frames,
        eval_freq=10_000,
        eval_episodes=20,
        seed=seed,
    )
    print(
        "noisybolt demo: PPO on the 6x6 gridworld under the bolt's spec G(on_edge).\n"
        "The bolt sees the room through its own camera, smudged over the bottom-left corner,\n"
        "and a CNN turns each picture into fluent probabilities (Algorithm 1 charges for\n"
        "fluents seen with low confidence). Compliance is checked from ground truth.\n"
    )
    started = time.monotonic()
    result = train(config, out)
    print(f"\ntrained {result.frames:,} frames in {time.monotonic() - started:.0f} s\n")
    report = evaluate_run(out, episodes=50, gif=out / "episode.gif", heatmap=out / "heatmap.png")
    print("Evaluation of the trained policy (50 episodes, ground-truth compliance):")
    print(
        format_eval_table(
            report.result.to_dict(), frames=result.frames, frames_to_comply=result.frames_to_comply
        )
    )
    print(f"\nrun directory: {out}  (config.json, command.txt, metrics.json, model.zip)")
    for label, path in report.files.items():
        print(f"{label}: {path}")
    print(f"TensorBoard: tensorboard --logdir {out / 'tensorboard'}")
    return 0


def _fmt_probs(probs: np.ndarray, bands: np.ndarray, names: tuple[str, ...]) -> str:
    return " ".join(
        f"{SHORT.get(n, n)}={p:.2f}{BAND_MARK[Band(int(b))]}"
        for n, p, b in zip(names, probs, bands, strict=True)
    )


def run_walkthrough(*, seed: int = 0) -> int:
    """Prints the DFAs and the scripted noisy episode; returns 0."""
    env = GridworldEnv(obs_mode="grid")
    fluents = env.fluent_names
    specs = [resolve_spec(name) for name in GRIDWORLD_SPECS]
    print("== The paper's gridworld specifications, compiled to DFAs ==\n")
    dfas = []
    for spec in specs:
        dfa = compile_ltlf(spec.formula, fluents)
        dfas.append(dfa)
        print(f"[{spec.name}] {PAPER_SPECS[spec.name]}")
        print(dfa.describe())
        print()

    detector = SyntheticDetector(
        fluents, seed=seed, fluents={"bottom_left_corner": BetaNoise.low_confidence()}
    )
    bolted = RestrainingBoltWrapper(env, specs, detector, dfas=dfas)
    print("== One scripted episode through Algorithm 1 ==")
    print(
        "Synthetic noisy detector: every fluent crisp except bottom_left_corner, seen with "
        "low confidence.\nBands: * high (p > 0.9), ~ low (0.5 <= p <= 0.9), blank absent "
        "(p < 0.5). Rewards: +1 per step a DFA accepts, -0.5 per low-confidence fluent on "
        "the edge taken.\n"
    )
    names = [s.name for s in specs]
    print("spec order:", ", ".join(names), "\n")
    obs, info = bolted.reset(seed=seed)
    print(
        f"reset   pos={_pos(env)}  probs: "
        f"{_fmt_probs(info['fluent_probs'], confidence_bands(info['fluent_probs']), fluents)}"
    )
    print(
        f"        dfa={obs['dfa'].tolist()} (reward of this first transition is paid with step 1)"
    )
    env_total = bolt_total = 0.0
    for t, action in enumerate(SCRIPT, start=1):
        obs, reward, terminated, truncated, info = bolted.step(int(action))
        env_total += info["env_reward"]
        bolt_total += info["bolt_reward"]
        print(
            f"step {t:>2} {action.name:<7} pos={_pos(env)}  probs: "
            f"{_fmt_probs(info['fluent_probs'], info['confidence_bands'], fluents)}"
        )
        print(
            f"        dfa={info['dfa_states'].tolist()} true dfa={info['true_dfa_states'].tolist()}"
            f"  terminal={info['bolt_terminal'].tolist()}"
            f" low-conf={info['bolt_low_confidence'].tolist()}"
            f"  carried={info['bolt_carried']:+.1f}  env={info['env_reward']:+.1f}"
            f"  total={float(reward):+.2f}"
        )
        if terminated or truncated:
            break
    print(f"\nepisode: env return {env_total:+.1f}, bolt return {bolt_total:+.2f}")
    compliance = ", ".join(
        f"{n}: {'complied' if ok else 'violated'}"
        for n, ok in zip(names, info["true_accepting"], strict=True)
    )
    print(f"ground truth: {compliance}")
    return 0


def _pos(env: GridworldEnv) -> tuple[int, int]:
    x, y = env.agent_pos
    return int(x), int(y)
