"""``noisybolt demo``: the same agent trained without and with a restraining bolt.

By default A2C learns the 6x6 gridworld twice, under the bolt's spec ``avoid_top_right``
= ``!F(top_right_corner)``. The world's shortest route (7 steps, along the top wall)
runs through the top-right corner; the compliant one (8 steps, down the west wall) does
not. The first agent learns from the world's reward alone; the second also from the
bolt's, which watches the room through its own noisy camera (the paper's case-4 smudge
over the bottom-left corner) with a CNN fluent classifier, trained on the fly the first
time and cached. Both are then evaluated in the bolted world, compliance judged from
the world's ground truth, and printed side by side; one picture shows where each goes
(two heat-maps) and a GIF shows one episode of the bolted agent.
``--spec`` runs the same comparison for another spec.

``--walkthrough`` instead prints every DFA (states, accepting states, edges with their
guards and supports), then walks one scripted episode of the gridworld — down the left
wall through the bottom-left corner, whose fluent the bolt sees only with low confidence
(the paper's case 4), then east to the goal — through Algorithm 1, printing per step the
fluent probabilities, their confidence bands, every DFA's state and the reward terms.
"""

from __future__ import annotations

import argparse
import textwrap
import time
from pathlib import Path
from typing import Any

import numpy as np

from noisybolt.bolt import Band, confidence_bands
from noisybolt.cli.train import parse_frames, whole_number
from noisybolt.envs.gridworld import GridAction, GridworldEnv
from noisybolt.errors import ConfigError, UnknownFluentError
from noisybolt.experiments.comparison import (
    compare_bolted_unbolted,
    format_comparison,
    spec_text,
    verdict,
)
from noisybolt.logic import compile_ltlf
from noisybolt.perception.detectors import BetaNoise, SyntheticDetector
from noisybolt.runs.specs import PAPER_SPECS, resolve_spec
from noisybolt.wrappers import DETECTOR_NAMES, RestrainingBoltWrapper

__all__ = [
    "DEMO_ALGO",
    "DEMO_EPISODES",
    "DEMO_FRAMES",
    "DEMO_NOISE",
    "DEMO_SPEC",
    "register",
    "run_training_demo",
    "run_walkthrough",
]

#: The demo's spec: its compliant route (8 steps) is not the world's shortest (7 steps).
DEMO_SPEC = "avoid_top_right"
#: A2C with the gridworld's default hyperparameters learns it with the classifier bolt
#: within 30k frames (README, Table 1); 40k leaves a margin (measured on seeds 0-3).
DEMO_ALGO = "a2c"
DEMO_FRAMES = 40_000
DEMO_EPISODES = 50
#: The demo's bolt camera: the paper's case-4 smudge over the bottom-left corner.
DEMO_NOISE = "regional"

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
        help="train one agent without and one with a noisy restraining bolt, and compare them",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--seed", type=int, default=0, help="seed (default 0)")
    parser.add_argument(
        "--walkthrough",
        action="store_true",
        help="only compile the specs and walk one scripted noisy episode through Algorithm 1",
    )
    parser.add_argument(
        "--spec",
        default=None,
        help=f"the bolt's spec: a built-in name or an LTLf formula over the gridworld's "
        f"fluents (default {DEMO_SPEC})",
    )
    parser.add_argument(
        "--algo",
        default=None,
        choices=("ppo", "a2c", "dqn"),
        help=f"the learner (default {DEMO_ALGO})",
    )
    parser.add_argument(
        "--frames",
        type=parse_frames,
        default=None,
        help=f"training frames of each agent, e.g. 60k (default {DEMO_FRAMES // 1000}k)",
    )
    parser.add_argument(
        "--detector",
        default=None,
        choices=DETECTOR_NAMES,
        help="the bolt's fluent detector (default: a CNN on its noisy camera)",
    )
    parser.add_argument(
        "--episodes",
        type=whole_number(1),
        default=None,
        help=f"evaluation episodes of each agent (default {DEMO_EPISODES})",
    )
    parser.add_argument("--out", type=Path, default=None, help="output directory")
    parser.set_defaults(func=_run)


#: The options of the training demo (its defaults), which the walkthrough trains without.
_TRAINING_OPTIONS: dict[str, Any] = {
    "algo": DEMO_ALGO,
    "frames": DEMO_FRAMES,
    "detector": "classifier",
    "episodes": DEMO_EPISODES,
    "out": None,
}


def _run(args: argparse.Namespace) -> int:
    if args.walkthrough:
        given = [f"--{k}" for k in _TRAINING_OPTIONS if getattr(args, k) is not None]
        if given:
            raise ConfigError(
                f"--walkthrough trains nothing, so {', '.join(given)} would be ignored: "
                "leave them out, or leave out --walkthrough to train"
            )
        return run_walkthrough(seed=args.seed, spec=args.spec)
    options = {k: default if getattr(args, k) is None else getattr(args, k)
               for k, default in _TRAINING_OPTIONS.items()}  # fmt: skip
    return run_training_demo(spec=args.spec or DEMO_SPEC, seed=args.seed, **options)


def run_training_demo(
    *,
    spec: str = DEMO_SPEC,
    algo: str = DEMO_ALGO,
    frames: int = DEMO_FRAMES,
    detector: str = "classifier",
    episodes: int = DEMO_EPISODES,
    seed: int = 0,
    out: Path | None = None,
) -> int:
    """Runs :func:`~noisybolt.experiments.comparison.compare_bolted_unbolted` with the demo's
    camera and prints the comparison; returns 0."""
    out = out or Path("runs") / time.strftime("demo-%Y%m%d-%H%M%S")
    resolved = resolve_spec(spec)
    try:  # a spec over fluents the gridworld lacks is refused before the intro
        compile_ltlf(resolved.formula, GridworldEnv(obs_mode="grid").fluent_names)
    except UnknownFluentError as error:
        raise UnknownFluentError(
            f"spec {resolved.name!r} uses fluent(s) {list(error.unknown)} that the "
            f"gridworld does not have; its fluents are {list(error.known)}",
            unknown=error.unknown,
            known=error.known,
        ) from None
    eyes = {
        "classifier": "a CNN classifier on its own noisy camera (smudged over the "
        "bottom-left corner)",
        "oracle": "the ground truth (oracle detector)",
        "synthetic": "the ground truth through seeded noise (synthetic detector)",
    }[detector]
    print(
        f"noisybolt demo: {algo.upper()} learns the 6x6 gridworld (reach the goal, -1.5 a "
        "step) twice,\nwithout and with a restraining bolt whose spec is "
        f"{spec_text(resolved.name, resolved.formula)}.\n"
        f"The bolt sees the fluents through {eyes}.\n"
        f"It pays the paper's rewards: +{resolved.terminal_reward:g} on each step its spec "
        f"accepts, -{resolved.low_confidence_cost:g} for\neach fluent it reads with low "
        "confidence.\n"
    )
    started = time.monotonic()
    comparison = compare_bolted_unbolted(
        spec=spec,
        algo=algo,
        frames=frames,
        detector=detector,
        noise=DEMO_NOISE,
        episodes=episodes,
        seed=seed,
        out=out,
    )
    n = comparison.bolted.evaluation.n_episodes
    print(
        f"\n{n} evaluation episodes of each agent in the bolted world (sampled actions).\n"
        "Compliance is judged from the world's true fluents; the unbolted agent's bolt\n"
        "return is what the bolt would have paid it.\n"
    )
    print(format_comparison(comparison))
    print(f"\n{textwrap.fill(verdict(comparison), 88)}\n")
    print(f"heat-maps (unbolted | bolted): {comparison.files['picture']}")
    print(f"one episode of the bolted agent: {comparison.files['gif']}")
    print(f"numbers: {comparison.files['summary']}")
    print(f"run directories: {comparison.unbolted.run_dir}  {comparison.bolted.run_dir}")
    print(f"total time: {time.monotonic() - started:.0f} s")
    return 0


def _fmt_probs(probs: np.ndarray, bands: np.ndarray, names: tuple[str, ...]) -> str:
    return " ".join(
        f"{SHORT.get(n, n)}={p:.2f}{BAND_MARK[Band(int(b))]}"
        for n, p, b in zip(names, probs, bands, strict=True)
    )


def run_walkthrough(*, seed: int = 0, spec: str | None = None) -> int:
    """Prints the DFAs and the scripted noisy episode (of the paper's four gridworld specs,
    or of ``spec`` alone); returns 0."""
    env = GridworldEnv(obs_mode="grid")
    fluents = env.fluent_names
    specs = [resolve_spec(name) for name in ((spec,) if spec else GRIDWORLD_SPECS)]
    print(
        "== The paper's gridworld specifications, compiled to DFAs ==\n"
        if spec is None
        else "== The spec, compiled to a DFA ==\n"
    )
    dfas = []
    for one in specs:
        dfa = compile_ltlf(one.formula, fluents)
        dfas.append(dfa)
        if spec is None:  # the paper's own words beside each (the DFA names its formula)
            print(f"[{one.name}] {PAPER_SPECS[one.name]}")
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
