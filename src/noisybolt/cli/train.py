"""``noisybolt train`` and ``noisybolt evaluate``: bolted agents with Stable-Baselines3."""

from __future__ import annotations

import argparse
import re
import sys
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

from noisybolt.errors import ConfigError

__all__ = [
    "FLAG_PATHS",
    "config_assignments",
    "format_eval_table",
    "parse_frames",
    "register",
    "train_overrides",
    "whole_number",
]

_SUFFIX = {"": 1, "k": 1_000, "m": 1_000_000}


def parse_frames(text: str) -> int:
    """Reads frame counts such as ``100000``, ``100k``, ``1.5m``.

    Example:
        >>> parse_frames("100k"), parse_frames("1.5M"), parse_frames("2500")
        (100000, 1500000, 2500)
    """
    match = re.fullmatch(r"\s*(\d+(?:\.\d+)?)\s*([kKmM]?)\s*", text)
    if not match:
        raise argparse.ArgumentTypeError(f"not a frame count: {text!r} (e.g. 100k, 1.5m, 2500)")
    value = float(match.group(1)) * _SUFFIX[match.group(2).lower()]
    if value < 1:
        raise argparse.ArgumentTypeError(f"frame count must be >= 1, got {text!r}")
    return int(value)


def parse_interval(text: str) -> int:
    """A frame interval; 0 turns the periodic action off (``0``, ``10k``)."""
    return 0 if text.strip() == "0" else parse_frames(text)


#: Each ``noisybolt train`` flag as the schema path it overrides
#: (:mod:`noisybolt.runs.config`). A flag given is an override of its path, a flag left
#: out leaves the schema's default; ``--set PATH=VALUE`` reaches every other path.
FLAG_PATHS: dict[str, str] = {
    "--world": "world.name",
    "--noise": "world.kwargs.noise",
    "--obs-mode": "world.kwargs.obs_mode",
    "--n-envs": "world.n_envs",
    "--spec": "bolt.specs",
    "--reward": "bolt.reward",
    "--reward-scale": "bolt.reward_scale",
    "--cost-limit": "bolt.constraint.cost_limit",
    "--no-shaping": "bolt.shaping",
    "--tracking": "bolt.tracking",
    "--confidence": "bolt.confidence",
    "--min-dwell": "bolt.min_dwell",
    "--cost-mode": "bolt.cost_mode",
    "--unbolted": "bolt.bolted",
    "--detector": "detector.kind",
    "--classifier": "detector.path",
    "--low-confidence": "detector.low_confidence",
    "--algo": "algorithm.name",
    "--hp": "algorithm.hyperparams",
    "--init-from": "algorithm.init_from",
    "--counterfactual": "algorithm.counterfactual",
    "--frames": "frames",
    "--seed": "seed",
    "--eval-freq": "evaluation.freq",
    "--eval-episodes": "evaluation.episodes",
    "--checkpoint-freq": "checkpoint_freq",
    "--keep-best": "evaluation.keep_best",
    "--last-model": "evaluation.keep_best",
    "--no-progress": "progress_bar",
}


def register(subparsers: Any) -> None:
    """Adds ``noisybolt train`` and ``noisybolt evaluate``."""
    train = subparsers.add_parser(
        "train",
        help="train an agent under a restraining bolt",
        description="Train PPO, A2C or DQN on a world under the bolt's LTLf specs. Every "
        "option that describes the run overrides one path of the run's config schema "
        "(config.json); --set PATH=VALUE overrides any path.",
    )

    def flag(name: str, **kwargs: Any) -> None:
        # dest is the schema path; a flag not given is absent (the schema's default)
        train.add_argument(name, dest=FLAG_PATHS[name], default=argparse.SUPPRESS, **kwargs)

    flag(
        "--world",
        help="a world name (default: the gridworld) or a factory path PACKAGE.MODULE:FACTORY whose "
        "FACTORY() returns a labelled env (noisybolt.FluentLabels); recorded in config.json",
    )
    flag(
        "--spec",
        action="append",
        metavar="NAME|FORMULA",
        help="a built-in spec name (edge, avoid_top_right, top_right_once, one_corner_once, "
        "clear_left_column, left_row0..left_row5), a group of them (left_column_milestones: "
        "clear_left_column and one spec per brick of Breakout's left column) or an LTLf "
        "formula over the world's fluents; repeat for several",
    )
    train.add_argument(
        "--spec-set",
        action=_SpecSetAction,
        dest=FLAG_PATHS["--spec"],
        metavar="KEY=VALUE",
        help="a setting of the --spec before it: reward_scale, low_confidence_cost, name "
        "(and, with --reward paper, terminal_reward, reward_timing); repeat for several",
    )
    train.add_argument(
        "--specs-file",
        type=Path,
        default=None,
        help="a YAML file of specs (names, formulas, or mappings with per-spec settings)",
    )
    flag(
        "--reward",
        help="reward scheme: constrained (the default for PPO and A2C: the world's return "
        "subject to a cost budget, --cost-limit: the specs paid as under compliance at a "
        "learned multiplier from 0 to 1 that rises only while episodes leave specs "
        "unsatisfied); compliance (DQN's default: complying is worth more than any gap "
        "between two episodes' returns, paid as the spec comes to accept and taken back if "
        "it stops, with progress shaping; --set bolt.pay_on_change=false pays at the "
        "episode's end) "
        "or paper (each spec's terminal_reward every accepting step: Algorithm 1 as "
        "reproduced)",
    )
    flag(
        "--cost-limit",
        type=float,
        help="constrained scheme: how many specs an episode may leave unsatisfied, on "
        "average, as the bolt sees them (default 0.02: comply in 98%% of episodes); "
        "--set bolt.constraint.lr=... (and kp, kd, initial, release, window) tune the "
        "multiplier",
    )
    flag(
        "--reward-scale",
        type=float,
        help="compliance scheme: what complying with a spec is worth (default: from the "
        "world's declared return bounds)",
    )
    flag(
        "--no-shaping",
        action="store_false",
        help="compliance scheme: no progress shaping over the DFAs",
    )
    flag("--algo", help="ppo, a2c or dqn (default ppo)")
    flag(
        "--counterfactual",
        action="store_true",
        help="DQN: counterfactual experience, every transition also stored replayed from the "
        "other DFA states (at most algorithm.counterfactual_samples copies; --set to change)",
    )
    flag(
        "--detector",
        help="classifier (trained CNN, default), oracle (ground truth), synthetic, or your "
        "own as package.module:function (called with those of fluent_names, camera_spec "
        "and seed it names; returns a FluentDetector)",
    )
    flag("--classifier", help="classifier file (default: cached or trained)")
    train.add_argument(
        "--retrain-classifier",
        action="store_true",
        help="train the cached classifier for this world and camera again (e.g. after "
        "changing what a fluent means); not with --resume",
    )
    flag(
        "--low-confidence",
        action="append",
        metavar="FLUENT",
        help="fluents the synthetic detector sees with low confidence",
    )
    flag("--noise", help="the bolt camera's noise (world default if unset)")
    flag(
        "--obs-mode",
        help="the agent's observation (gridworld: grid, view, rgb; breakout: stack, ram, ram_bits)",
    )
    flag("--frames", type=parse_frames, help="e.g. 100k (default)")
    flag("--seed", type=int, help="seeds the run and its detector (detector.seed); default 0")
    flag("--n-envs", type=int, help="training environments")
    train.add_argument(
        "--hp",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="hyperparameter override, e.g. --hp learning_rate=3e-4 "
        "(= --set algorithm.hyperparams.learning_rate=3e-4)",
    )
    flag(
        "--init-from",
        metavar="PATH",
        help="start the agent's network from a saved agent (a run directory, a checkpoint "
        "folder or a model.zip of the same world, bolted or not; a run directory of other "
        "specs starts this run's DFA states at zero weight) instead of random weights: a "
        "bolt put on an agent that already plays; the run keeps a copy",
    )
    train.add_argument(
        "--hp-file",
        type=Path,
        default=None,
        help="hyperparameters from this YAML file (one entry per algorithm, as in "
        "noisybolt/configs/hyperparams/gridworld.yaml) instead of the world's built-in "
        "ones; a world without built-in ones gets the documented _default.yaml",
    )
    flag(
        "--eval-freq",
        type=parse_interval,
        help="frames between evaluations (0: only at the end; default 10k)",
    )
    flag("--eval-episodes", type=int, help="episodes per evaluation (default 20)")
    flag(
        "--checkpoint-freq",
        type=parse_interval,
        help="frames between checkpoints (0: only at the end; default 20k)",
    )
    flag("--cost-mode", help="count (paper) or proportional")
    flag(
        "--tracking",
        help="threshold (Algorithm 1: one frame decides) or belief (a distribution over "
        "each spec's DFA states, paid at --confidence)",
    )
    flag(
        "--confidence",
        type=float,
        help="belief tracking: the probability at which a spec counts as accepted and is paid",
    )
    flag(
        "--min-dwell",
        type=int,
        help="belief tracking: the fewest steps a fluent, once true, is believed to stay true "
        "(default 2: rides out one-frame glitches; 1 credits a condition met in one step)",
    )
    flag(
        "--unbolted",
        action="store_false",
        help="train without the bolt's rewards (compliance still measured)",
    )
    flag(
        "--keep-best",
        action="store_true",
        help="keep the model of the evaluation with the best shaped (env + bolt) return, "
        "not the last one (best/ holds it; ground truth never chooses): the default",
    )
    flag(
        "--last-model",
        action="store_false",
        help="keep the last model, not the best evaluated one (--keep-best, the default)",
    )
    train.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="PATH=VALUE",
        help="override any setting of the config schema by its path, e.g. --set "
        "evaluation.envs=8, --set bolt.thresholds.high=0.95 (the value read as YAML; "
        "applied after the other options)",
    )
    train.add_argument("--out", type=Path, default=None, help="run directory (default runs/...)")
    train.add_argument(
        "--resume",
        action="store_true",
        help="continue the run in --out from its latest checkpoint (refused without one)",
    )
    train.add_argument(
        "--restart",
        action="store_true",
        help="start the run in --out over: its earlier results and checkpoints are removed",
    )
    train.add_argument(
        "--trust-code",
        action="store_true",
        help="with --resume: follow the code the run's config.json names (a world or detector "
        "factory path), which is otherwise refused unless given again (--world, --detector); "
        "only for a run whose author you trust",
    )
    flag("--no-progress", action="store_false", help="no progress bar")
    train.set_defaults(func=_train)

    evaluate = subparsers.add_parser(
        "evaluate",
        help="evaluate a trained run: returns, goal rate, compliance from ground truth",
    )
    evaluate.add_argument("run_dir", type=Path)
    evaluate.add_argument(
        "--episodes",
        type=whole_number(1),
        default=50,
        help="episodes to run (and draw in --heatmap)",
    )
    evaluate.add_argument("--seed", type=int, default=12345)
    evaluate.add_argument("--stochastic", action="store_true", help="sample actions")
    evaluate.add_argument("--gif", type=Path, default=None, help="save one episode as a GIF")
    evaluate.add_argument("--heatmap", type=Path, default=None, help="save a trajectory heat-map")
    evaluate.add_argument(
        "--noise",
        default=None,
        help="evaluate under another bolt camera noise (its classifier: cached or trained "
        "on the fly); written to evaluation-<hash>.json beside the run's own",
    )
    evaluate.add_argument(
        "--tracking",
        choices=("threshold", "belief"),
        default=None,
        help="evaluate with another bolt tracking (what its DFAs accept, and so the false "
        "acceptances; the agent sees those DFA states); written beside the run's own too",
    )
    evaluate.add_argument(
        "--world",
        default=None,
        metavar="MODULE:FACTORY",
        help="the run's world factory path, given again: you vouch for the code it names",
    )
    evaluate.add_argument(
        "--detector",
        default=None,
        metavar="MODULE:FUNCTION",
        help="the run's detector factory path, given again: you vouch for the code it names",
    )
    evaluate.add_argument(
        "--trust-code",
        action="store_true",
        help="follow every code reference the run's config.json names (a world or detector "
        "factory path); only for a run whose author you trust. Without it such a run is "
        "refused before anything is imported",
    )
    evaluate.add_argument(
        "--no-ground-truth",
        action="store_true",
        help="read no ground truth: report each spec's compliance estimated from the bolt's "
        "own evidence (its detector's outputs and measured error rates) with a 90%% "
        "interval, and nothing judged from the truth",
    )
    evaluate.add_argument(
        "--no-estimate",
        action="store_true",
        help="skip the compliance estimate (with ground truth it is printed beside the truth)",
    )
    evaluate.add_argument(
        "--labelled",
        type=Path,
        default=None,
        metavar="DATASET",
        help="labelled images (a dataset file of `noisybolt classifiers collect`) to measure "
        "the detector's error rates on; default: those its classifier recorded, else "
        "images collected from the world",
    )
    evaluate.add_argument(
        "--reliability",
        type=Path,
        default=None,
        help="where to draw the estimate's reliability diagram (PNG; with ground truth); "
        "default: compliance-reliability.png in the run directory",
    )
    evaluate.set_defaults(func=_evaluate)


def whole_number(minimum: int) -> Callable[[str], int]:
    """An argparse type: a whole number of at least ``minimum`` (counts of episodes,
    retries, workers), refused by name otherwise."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"not a whole number: {text!r}") from None
        if value < minimum:
            raise argparse.ArgumentTypeError(f"must be at least {minimum}, got {text!r}")
        return value

    parse.__name__ = f"whole number >= {minimum}"  # argparse names the type in errors
    return parse


class _SpecSetAction(argparse.Action):
    """``--spec-set KEY=VALUE``: a setting of the ``--spec`` given just before it."""

    def __call__(
        self,
        parser: argparse.ArgumentParser,
        namespace: argparse.Namespace,
        values: Any,
        option_string: str | None = None,
    ) -> None:
        import yaml

        from noisybolt.runs.specs import BUILTIN_SPECS, SPEC_FILE_KEYS

        specs = list(getattr(namespace, self.dest, None) or [])
        if not specs:
            parser.error("--spec-set sets a setting of the --spec before it: give a --spec first")
        key, sep, text = str(values).partition("=")
        key = key.strip()
        if not sep or key not in SPEC_FILE_KEYS or key == "formula":
            known = [k for k in SPEC_FILE_KEYS if k != "formula"]
            parser.error(f"--spec-set takes KEY=VALUE with KEY one of {known}, got {values!r}")
        last = specs[-1]
        if isinstance(last, str):
            text_spec = last.strip()
            last = {"name": text_spec} if text_spec in BUILTIN_SPECS else {"formula": text_spec}
        try:
            value = yaml.safe_load(text)
        except yaml.YAMLError:
            value = text
        specs[-1] = {**last, key: value}
        setattr(namespace, self.dest, specs)


def train_overrides(args: argparse.Namespace) -> dict[str, Any]:
    """The config overrides ``noisybolt train``'s options stand for: each flag given at its
    schema path (:data:`FLAG_PATHS`), ``--hp K=V`` at ``algorithm.hyperparams.K``, specs
    of ``--specs-file`` after those of ``--spec``, then every ``--set PATH=VALUE``.

    Raises:
        ConfigError: an unknown path, or a ``--hp``/``--set`` not of the form KEY=VALUE.
    """
    from noisybolt.runs.specs import load_specs_file

    paths = set(FLAG_PATHS.values())
    overrides = {k: v for k, v in vars(args).items() if k in paths}
    specs = list(overrides.pop("bolt.specs", None) or [])
    if args.specs_file is not None:
        specs += load_specs_file(args.specs_file)
    if specs:
        overrides["bolt.specs"] = specs
    if "seed" in overrides:  # the detector's seed follows the run's
        overrides["detector.seed"] = overrides["seed"]
    assignments = [("--hp", f"algorithm.hyperparams.{item}") for item in args.hp]
    assignments += [("--set", item) for item in args.set]
    overrides.update(config_assignments(assignments))
    return overrides


def config_assignments(assignments: Iterable[tuple[str, str]]) -> dict[str, Any]:
    """``{schema path: value}`` of ``(option, "PATH=VALUE")`` pairs, each value read as
    the path's setting (:func:`~noisybolt.runs.config.value_from_text`), later pairs
    winning; ``option`` names the flag in errors.

    Raises:
        ConfigError: an item not of the form KEY=VALUE, or a value the path refuses.
    """
    from noisybolt.runs.config import value_from_text

    out: dict[str, Any] = {}
    for option, item in assignments:
        path, sep, text = item.partition("=")
        if not sep or not path.strip():
            raise ConfigError(f"{option} {item!r} is not of the form KEY=VALUE")
        out[path.strip()] = value_from_text(path.strip(), text)
    return out


def _default_out(overrides: dict[str, Any]) -> Path:
    """``runs/<world>-<algo>-seed<seed>``, from the options given or the schema's
    defaults (a factory path's ``:`` made a ``.``: it names no folder well)."""
    from noisybolt.runs.config import TrainConfig
    from noisybolt.runs.schema import defaults

    default = defaults(TrainConfig)
    world = str(overrides.get("world.name", default["world"]["name"]))
    algo = overrides.get("algorithm.name", default["algorithm"]["name"])
    seed = overrides.get("seed", default["seed"])
    return Path("runs") / f"{world.replace(':', '.')}-{algo}-seed{seed}"


def _train(args: argparse.Namespace) -> int:
    from noisybolt.runs.config import TrainConfig
    from noisybolt.runs.resolution import resolve
    from noisybolt.runs.rundir import RunDirectory
    from noisybolt.runs.training import train

    overrides = train_overrides(args)
    if args.resume:  # the saved run's settings, with the ones given again on top
        out = args.out or _default_out(overrides)
        if not (out / "config.json").exists():
            raise ConfigError(f"--resume: {out} holds no run to continue")
        saved = RunDirectory(out).read_config()
        config = TrainConfig.resumed(
            saved, overrides, hp_file=args.hp_file, trust_code=args.trust_code
        )
    else:
        if not overrides.get("bolt.specs"):
            raise ConfigError(
                "give at least one --spec (a built-in name or an LTLf formula) or a --specs-file"
            )
        # Resolved as every door resolves a config (the scale, exact on a tabular product).
        config = resolve(TrainConfig.build(overrides, hp_file=args.hp_file), log=print)
        out = args.out or _default_out(overrides)
        if out.exists() and not out.is_dir():
            raise ConfigError(f"--out {out} is a file, not a run directory; give a directory")
        if args.trust_code:
            raise ConfigError(
                "--trust-code vouches for the code a saved run names, with --resume; a new "
                "run's code is the one you give (--world, --detector): leave it out"
            )
    from noisybolt.experiments.checks import goal_feasibility

    best = goal_feasibility(config)
    if best is not None and best.value is None:
        print(
            "warning: no episode of this world reaches the goal while complying with every "
            "spec (noisybolt check says more): the agent must trade the goal for the bolt"
        )
    started = out.exists() and (out / "config.json").exists()
    try:  # SIGTERM too (the CLI's main): train() saves a checkpoint, says how to resume
        result = train(
            config,
            out,
            resume=args.resume,
            restart=args.restart,
            retrain_classifier=args.retrain_classifier,
            argv=getattr(args, "command_line", None),
        )
    except KeyboardInterrupt:
        if not started and not (out / "config.json").exists():
            # Before the run was set up (a classifier training on the fly): nothing kept.
            print(
                "noisybolt train: interrupted before training began; nothing was saved",
                file=sys.stderr,
            )
        return 130
    print(
        format_eval_table(
            result.final.to_dict(),
            frames=result.frames,
            frames_to_comply=result.frames_to_comply,
            greedy=config.evaluation.deterministic,
        )
    )
    print(f"\nrun directory: {result.run_dir}")
    return 0


def format_eval_table(
    final: dict[str, Any],
    *,
    frames: int | None = None,
    frames_to_comply: int | None = None,
    greedy: bool | None = None,
) -> str:
    """A plain-text table of an evaluation (the one ``train`` and ``evaluate`` print): the
    run report's evaluation table, rendered as text."""
    from noisybolt.experiments.report import evaluation_table
    from noisybolt.experiments.reporting import render_text

    table = evaluation_table(final, frames=frames, frames_to_comply=frames_to_comply, greedy=greedy)
    return render_text([table])


def _evaluate(args: argparse.Namespace) -> int:
    from noisybolt.runs.run_evaluation import evaluate_run

    overrides: dict[str, Any] = {}
    if args.noise is not None:
        overrides["world.kwargs.noise"] = args.noise
    if args.tracking is not None:
        overrides["bolt.tracking"] = args.tracking
    if args.world is not None:
        overrides["world.name"] = args.world
    if args.detector is not None:
        overrides["detector.kind"] = args.detector
    report = evaluate_run(
        args.run_dir,
        episodes=args.episodes,
        seed=args.seed,
        deterministic=not args.stochastic,
        gif=args.gif,
        heatmap=args.heatmap,
        heatmap_episodes=args.episodes,
        overrides=overrides or None,
        trust_code=args.trust_code,
        estimate=not args.no_estimate,
        ground_truth=not args.no_ground_truth,
        labelled=args.labelled,
        reliability=args.reliability,
    )
    print(format_eval_table(report.summary(), greedy=not args.stochastic))
    if report.compliance is not None:
        title = "compliance estimated from the bolt's evidence"
        if report.ground_truth:
            title += ", beside the truth"
        print(f"\n{title}:\n{report.compliance.format_table()}")
    for label, path in report.files.items():
        print(f"{label}: {path}")
    return 0
