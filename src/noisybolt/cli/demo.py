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
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from noisybolt.agents.evaluation import EpisodeRecord, EvalResult, summarise
from noisybolt.agents.specs import PAPER_SPECS, resolve_spec
from noisybolt.bolt import Band, Thresholds, confidence_bands
from noisybolt.cli.train import parse_frames
from noisybolt.envs.gridworld import GridAction, GridworldEnv
from noisybolt.errors import ConfigError
from noisybolt.io import atomic_write_json
from noisybolt.logic import compile_ltlf
from noisybolt.perception.detectors import BetaNoise, SyntheticDetector
from noisybolt.wrappers import RestrainingBoltWrapper

__all__ = [
    "DEMO_ALGO",
    "DEMO_FRAMES",
    "DEMO_SPEC",
    "AgentOutcome",
    "DemoComparison",
    "compare_bolted_unbolted",
    "format_comparison",
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
#: Seeds the evaluation episodes (apart from the training seeds).
EVAL_SEED = 12_345

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
        default=DEMO_SPEC,
        help=f"the bolt's spec: a built-in name or an LTLf formula over the gridworld's "
        f"fluents (default {DEMO_SPEC})",
    )
    parser.add_argument(
        "--algo",
        default=DEMO_ALGO,
        choices=("ppo", "a2c", "dqn"),
        help=f"the learner (default {DEMO_ALGO})",
    )
    parser.add_argument(
        "--frames",
        type=parse_frames,
        default=DEMO_FRAMES,
        help=f"training frames of each agent, e.g. 60k (default {DEMO_FRAMES // 1000}k)",
    )
    parser.add_argument(
        "--detector",
        default="classifier",
        choices=("classifier", "oracle", "synthetic"),
        help="the bolt's fluent detector (default: a CNN on its noisy camera)",
    )
    parser.add_argument(
        "--episodes",
        type=int,
        default=DEMO_EPISODES,
        help=f"evaluation episodes of each agent (default {DEMO_EPISODES})",
    )
    parser.add_argument("--out", type=Path, default=None, help="output directory")
    parser.set_defaults(func=_run)


def _run(args: argparse.Namespace) -> int:
    if args.walkthrough:
        return run_walkthrough(seed=args.seed)
    return run_training_demo(
        spec=args.spec,
        algo=args.algo,
        frames=args.frames,
        detector=args.detector,
        episodes=args.episodes,
        seed=args.seed,
        out=args.out,
    )


@dataclass(frozen=True)
class AgentOutcome:
    """One of the demo's two agents: where it was trained and how it did.

    Attributes:
        bolted: whether it learnt from the bolt's rewards.
        run_dir: its run directory (see :mod:`noisybolt.agents.training`).
        frames: frames it trained for.
        seconds: wall time of its training (an on-the-fly classifier is trained before).
        evaluation: its evaluation episodes, compliance from ground truth; the bolt
            return is what the bolt pays (or would have paid, for the unbolted agent).
        positions: per evaluation episode, the ``(x, y)`` cell at every step.
    """

    bolted: bool
    run_dir: Path
    frames: int
    seconds: float
    evaluation: EvalResult
    positions: tuple[tuple[tuple[int, int], ...], ...] = field(repr=False)


@dataclass(frozen=True)
class DemoComparison:
    """What :func:`compare_bolted_unbolted` found and wrote.

    Attributes:
        spec_name: the spec's name.
        formula: its LTLf formula.
        algo: the learner.
        detector: the bolt's fluent detector kind.
        unbolted: the agent trained on the world's reward alone.
        bolted: the same agent trained with the bolt.
        files: label → path of what was written (``picture``, ``gif``, ``summary``).
    """

    spec_name: str
    formula: str
    algo: str
    detector: str
    unbolted: AgentOutcome
    bolted: AgentOutcome
    files: dict[str, Path]

    def to_dict(self) -> dict[str, Any]:
        """JSON-able form (``comparison.json``)."""
        return {
            "spec": {"name": self.spec_name, "formula": self.formula},
            "algo": self.algo,
            "detector": self.detector,
            **{
                label: {
                    "run_dir": str(agent.run_dir),
                    "frames": agent.frames,
                    "seconds": round(agent.seconds, 1),
                    "evaluation": agent.evaluation.to_dict(),
                }
                for label, agent in (("unbolted", self.unbolted), ("bolted", self.bolted))
            },
            "files": {label: str(path) for label, path in self.files.items()},
        }


def compare_bolted_unbolted(
    *,
    spec: str = DEMO_SPEC,
    algo: str = DEMO_ALGO,
    frames: int = DEMO_FRAMES,
    detector: str = "classifier",
    noise: str = DEMO_NOISE,
    episodes: int = DEMO_EPISODES,
    seed: int = 0,
    out: str | Path,
    progress: bool = True,
    log: Callable[[str], None] = print,
) -> DemoComparison:
    """Trains the same agent without and with the bolt, evaluates both, draws them.

    Both agents see the same observations (their image and the DFA states the bolt
    tracks) and train for the same frames from the same seed; only the bolted one is
    paid the bolt's rewards. Both are then evaluated in the bolted world: ``episodes``
    episodes each, from the same seeds, compliance from the world's true fluents, bolt
    return as the bolt pays it. Writes ``OUT/unbolted/`` and ``OUT/bolted/`` (run
    directories), ``OUT/comparison.png`` (the two heat-maps), ``OUT/bolted.gif`` (the
    bolted agent's first evaluation episode) and ``OUT/comparison.json``.

    Args:
        spec: a built-in spec name or an LTLf formula over the gridworld's fluents.
        algo: ``ppo``, ``a2c`` or ``dqn``, with the gridworld's default hyperparameters.
        frames: training frames of each agent.
        detector: the bolt's fluent detector (``classifier``, ``oracle``, ``synthetic``).
        noise: the bolt camera's noise.
        episodes: evaluation episodes of each agent.
        seed: seeds both trainings (and the on-the-fly classifier).
        out: the output directory (it must not hold a demo yet).
        progress: show progress bars while training.
        log: where progress messages go.

    Raises:
        ConfigError: ``out`` already holds a demo, fewer than one episode, or a bad
            setting of the training config (checked before anything is written).
        UnknownFluentError: the spec names a fluent the gridworld does not have.
    """
    import torch

    from noisybolt.agents.run_evaluation import load_run_model
    from noisybolt.agents.training import DetectorConfig, TrainConfig, prepare_bolt, train
    from noisybolt.agents.visualize import compare_heatmaps, save_episode_gif
    from noisybolt.rundir import RunDirectory

    # One thread, as train() sets it: on a small machine torch's default (every core)
    # made the on-the-fly classifier several times slower (FACTS.md).
    torch.set_num_threads(1)
    out = Path(out)
    if isinstance(episodes, bool) or not isinstance(episodes, int) or episodes < 1:
        raise ConfigError(f"episodes must be an integer >= 1, got {episodes!r}")
    taken = [
        out / name for name in ("unbolted", "bolted", "comparison.json") if (out / name).exists()
    ]
    if taken:
        raise ConfigError(f"{out} already holds a demo ({taken[0].name}); choose another --out")
    configs = {
        bolted: TrainConfig.create(
            specs=[spec],
            algo=algo,
            world_kwargs={"noise": noise},
            detector=DetectorConfig(kind=detector, seed=seed),
            frames=frames,
            seed=seed,
            eval_freq=0,
            checkpoint_freq=0,
            progress_bar=progress,
            bolted=bolted,
            # The paper's scheme (+1 per accepting step, 0.5 per low-confidence fluent),
            # whose learning times Table 1 measured; the wrapper that records the
            # evaluation episodes pays the same rewards.
            reward="paper",
        )
        for bolted in (False, True)
    }
    bolted_config = configs[True]
    (spec_obj,) = bolted_config.spec_objects()
    # The detector first (a classifier is trained on the fly and cached the first time),
    # so that the two trainings load the same one and their times compare.
    setup = prepare_bolt(bolted_config, seed=seed, progress=progress, log=log)
    trained: dict[bool, tuple[Any, float]] = {}
    for step, bolted in enumerate((False, True), start=1):
        what = "with the bolt's rewards" if bolted else "on the world's reward alone"
        log(f"[{step}/2] {algo.upper()} {what}, {frames:,} frames")
        started = time.monotonic()
        result = train(configs[bolted], out / _label(bolted), log=log)
        trained[bolted] = (result, time.monotonic() - started)

    # Both agents are evaluated in the bolted world, so that the unbolted one's bolt
    # return is what the bolt would have paid it.
    outcomes: dict[bool, AgentOutcome] = {}
    recordings: dict[bool, list[Any]] = {}
    for bolted in (False, True):
        result, seconds = trained[bolted]
        model = load_run_model(RunDirectory(result.run_dir), configs[bolted])
        torch.manual_seed(seed)  # sampled actions come from torch's global generator
        recordings[bolted] = _record(
            model,
            bolted_config,
            setup,
            episodes=episodes,
            deterministic=bolted_config.eval_deterministic,
        )
        outcomes[bolted] = AgentOutcome(
            bolted=bolted,
            run_dir=result.run_dir,
            frames=result.frames,
            seconds=seconds,
            evaluation=_summarise(recordings[bolted], spec_obj.name),
            positions=tuple(
                tuple((int(x), int(y)) for x, y in rec.positions) for rec in recordings[bolted]
            ),
        )

    files: dict[str, Path] = {}
    files["picture"] = compare_heatmaps(
        {
            _panel_title(outcomes[False], spec_obj.name, detector): list(outcomes[False].positions),
            _panel_title(outcomes[True], spec_obj.name, detector): list(outcomes[True].positions),
        },
        size=int(bolted_config.world_kwargs.get("size", 6)),
        path=out / "comparison.png",
        title=f"{algo.upper()} on the gridworld, without and with a restraining bolt\n"
        + _wrap(f"spec {_spec_text(spec_obj.name, spec_obj.formula)}", 90),
    )
    files["gif"] = save_episode_gif(
        recordings[True][0], out / "bolted.gif", action_names=[a.name.lower() for a in GridAction]
    )
    comparison = DemoComparison(
        spec_name=spec_obj.name,
        formula=spec_obj.formula,
        algo=algo,
        detector=detector,
        unbolted=outcomes[False],
        bolted=outcomes[True],
        files={**files, "summary": out / "comparison.json"},
    )
    atomic_write_json(out / "comparison.json", comparison.to_dict())
    return comparison


def _label(bolted: bool) -> str:
    return "bolted" if bolted else "unbolted"


def _record(
    model: Any, config: Any, setup: Any, *, episodes: int, deterministic: bool
) -> list[Any]:
    """``episodes`` recorded episodes of ``model`` in the bolted gridworld."""
    from noisybolt.agents.visualize import policy_from_model, record_episode

    env = RestrainingBoltWrapper(
        GridworldEnv(**config.world_settings),
        config.spec_objects(),
        setup.detector,
        dfas=setup.dfas,
        thresholds=Thresholds(**config.thresholds),
        cost_mode=config.cost_mode,
    )
    policy = policy_from_model(model, deterministic=deterministic)
    return [record_episode(env, policy, seed=EVAL_SEED + i) for i in range(episodes)]


def _summarise(recordings: Sequence[Any], spec_name: str) -> EvalResult:
    """The evaluation measures of recorded episodes (goal: the task ended, not a limit)."""
    records = [
        EpisodeRecord(
            env_return=rec.env_return,
            bolt_return=rec.bolt_return,
            length=rec.n_steps,
            goal=rec.terminated,
            compliant=tuple(bool(a) for a in rec.true_accepting[-1]),
            bolt_accepting=tuple(bool(a) for a in rec.bolt_accepting[-1]),
        )
        for rec in recordings
    ]
    return summarise(records, [spec_name])


#: How the bolted panel names the bolt's eyes, per detector.
_EYES = {
    "classifier": "noisy camera, CNN classifier",
    "oracle": "oracle detector",
    "synthetic": "synthetic noisy detector",
}


def _panel_title(agent: AgentOutcome, spec_name: str, detector: str) -> str:
    who = f"with the bolt ({_EYES[detector]})" if agent.bolted else "without the bolt"
    ev = agent.evaluation
    return (
        f"{who}\nroute {ev.length_mean:.1f} steps, goal {ev.goal_rate:.0%}, "
        f"complies {ev.compliance[spec_name]:.0%}"
    )


def _spec_text(name: str, formula: str) -> str:
    return formula if name == formula else f"{name} = {formula}"


def _wrap(text: str, width: int) -> str:
    """``text`` cut into lines of at most ``width`` characters at spaces."""
    lines: list[str] = []
    for word in text.split(" "):
        if lines and len(lines[-1]) + 1 + len(word) <= width:
            lines[-1] += " " + word
        else:
            lines.append(word)
    return "\n".join(lines)


def format_comparison(comparison: DemoComparison) -> str:
    """The side-by-side table the demo prints.

    Example:
        >>> from noisybolt.agents.evaluation import EpisodeRecord, summarise
        >>> def agent(bolted, length, complied, bolt_return):
        ...     record = EpisodeRecord(101.5 - 1.5 * length, bolt_return, length, True,
        ...                            (complied,))
        ...     return AgentOutcome(bolted=bolted, run_dir=Path("."), frames=40_000,
        ...                         seconds=20.0, evaluation=summarise([record], ["avoid"]),
        ...                         positions=())
        >>> print(format_comparison(DemoComparison(
        ...     spec_name="avoid", formula="!F(top_right_corner)", algo="a2c",
        ...     detector="classifier", unbolted=agent(False, 7, False, 3.0),
        ...     bolted=agent(True, 8, True, 9.0), files={})))
                                                 unbolted    bolted
        route length (steps)                          7.0       8.0
        goal rate                                    100%      100%
        complies with avoid (ground truth)             0%      100%
        env return R_pi                             91.00     89.50
        bolt return                                  3.00      9.00
        frames trained                             40,000    40,000
        training time                                20 s      20 s
    """
    rows: list[tuple[str, Callable[[AgentOutcome], str]]] = [
        ("route length (steps)", lambda a: f"{a.evaluation.length_mean:.1f}"),
        ("goal rate", lambda a: f"{a.evaluation.goal_rate:.0%}"),
        (
            f"complies with {comparison.spec_name} (ground truth)",
            lambda a: f"{a.evaluation.compliance[comparison.spec_name]:.0%}",
        ),
        ("env return R_pi", lambda a: f"{a.evaluation.env_return_mean:.2f}"),
        ("bolt return", lambda a: f"{a.evaluation.bolt_return_mean:.2f}"),
        ("frames trained", lambda a: f"{a.frames:,}"),
        ("training time", lambda a: f"{a.seconds:.0f} s"),
    ]
    width = max(40, *(len(name) for name, _ in rows))
    lines = [f"{'':<{width}} {'unbolted':>9} {'bolted':>9}"]
    for name, cell in rows:
        lines.append(f"{name:<{width}} {cell(comparison.unbolted):>9} {cell(comparison.bolted):>9}")
    return "\n".join(lines)


def _verdict(comparison: DemoComparison) -> str:
    name = comparison.spec_name
    before = comparison.unbolted.evaluation.compliance[name]
    after = comparison.bolted.evaluation.compliance[name]
    if before >= 0.95:
        return (
            f"Without the bolt {before:.0%} of the episodes already comply with {name}: the "
            "world's own best route satisfies it, so the bolt has nothing to restrain."
        )
    if after >= 0.95:
        return (
            f"The bolt restrains the agent: {before:.0%} of its episodes comply with {name} "
            f"without the bolt, {after:.0%} with it."
        )
    return (
        f"Compliance with {name}: {before:.0%} without the bolt, {after:.0%} with it; "
        "the bolted agent has not learnt the spec yet (try more --frames)."
    )


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
    """Runs :func:`compare_bolted_unbolted` and prints the comparison; returns 0."""
    out = out or Path("runs") / time.strftime("demo-%Y%m%d-%H%M%S")
    resolved = resolve_spec(spec)
    eyes = {
        "classifier": "a CNN classifier on its own noisy camera (smudged over the "
        "bottom-left corner)",
        "oracle": "the ground truth (oracle detector)",
        "synthetic": "the ground truth through seeded noise (synthetic detector)",
    }[detector]
    print(
        f"noisybolt demo: {algo.upper()} learns the 6x6 gridworld (reach the goal, -1.5 a "
        "step) twice,\nwithout and with a restraining bolt whose spec is "
        f"{_spec_text(resolved.name, resolved.formula)}.\n"
        f"The bolt sees the fluents through {eyes}.\n"
    )
    started = time.monotonic()
    comparison = compare_bolted_unbolted(
        spec=spec,
        algo=algo,
        frames=frames,
        detector=detector,
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
    print(f"\n{textwrap.fill(_verdict(comparison), 88)}\n")
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
