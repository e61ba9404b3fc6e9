"""``noisybolt sweep``, ``noisybolt reproduce table1|case4`` and ``noisybolt report``.

Exit codes: 0 when every trial finished, 1 when some failed (their errors are in the
table and in each trial's ``trial.json``; the others' results are kept), 2 for bad
input (found before anything runs).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from noisybolt.bolt.belief import TRACKING_MODES
from noisybolt.cli.train import parse_frames, whole_number
from noisybolt.wrappers import DETECTOR_NAMES

__all__ = ["register"]


def _positive_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not value > 0:
        raise argparse.ArgumentTypeError(f"must be > 0, got {text!r}")
    return value


def _seeds(text: str) -> int | list[int]:
    """``3`` (seeds 0, 1, 2) or ``0,4,7`` (those seeds)."""
    try:
        if "," in text:
            return [int(s) for s in text.split(",") if s.strip()]
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"seeds: a count (3) or a list (0,4,7), not {text!r}"
        ) from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"seeds must be >= 1, got {text!r}")
    return value


def _add_backend_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--backend",
        choices=("local", "ray"),
        default="local",
        help="local (default, no Ray) or ray (Ray Tune; local Ray unless --address)",
    )
    parser.add_argument("--address", default=None, help="Ray cluster address (with --backend ray)")
    parser.add_argument(
        "--workers",
        type=whole_number(0),
        default=None,
        help="trials at once: local, default 1 (one after the other in this process), more on "
        "a local Ray Tune; ray, default 0 (as the CPUs allow)",
    )


def _command(*words: Any, **options: Any) -> list[str]:
    """The command line as run, every option explicit (saved as ``command.txt``).

    Rebuilt from the parsed options rather than taken from ``sys.argv``, so that it is
    the same however noisybolt was started (console script, ``python -m``, a test).

    Example:
        >>> _command("sweep", "a.yaml", out="runs/x", address=None, report=True, seeds=[0, 2])
        ['noisybolt', 'sweep', 'a.yaml', '--out', 'runs/x', '--report', '--seeds', '0,2']
    """
    argv = ["noisybolt", *map(str, words)]
    for name, value in options.items():
        flag = "--" + name.replace("_", "-")
        if value is None or value is False:
            continue
        if value is True:
            argv.append(flag)
        elif isinstance(value, list | tuple):
            argv += [flag, ",".join(map(str, value))]
        else:
            argv += [flag, str(value)]
    return argv


def _workers(args: argparse.Namespace) -> int:
    if args.workers is not None:
        return int(args.workers)
    return 1 if args.backend == "local" else 0


def register(subparsers: Any) -> None:
    """Adds ``sweep``, ``reproduce`` (``table1``, ``case4``) and ``report``."""
    sweep = subparsers.add_parser(
        "sweep",
        help="run a grid of training runs (rows x settings x seeds) from a YAML file",
        description="Run a sweep config (see noisybolt.experiments.sweeps for its format). "
        "Running it again resumes: finished trials are reused, interrupted ones resume "
        "from their checkpoints, failed ones are retried.",
    )
    sweep.add_argument("config", type=Path, help="the sweep's YAML file")
    sweep.add_argument("--out", type=Path, default=None, help="default runs/sweeps/<name>")
    sweep.add_argument(
        "--retries", type=whole_number(0), default=None, help="override the config's retries"
    )
    sweep.add_argument("--report", action="store_true", help="also write report.md/html")
    _add_backend_options(sweep)
    sweep.set_defaults(func=_sweep)

    reproduce = subparsers.add_parser(
        "reproduce", help="reproduce the paper's experiments (table1, case4)"
    )
    which = reproduce.add_subparsers(dest="experiment", metavar="EXPERIMENT", required=True)
    table1 = which.add_parser(
        "table1",
        help="train the paper's gridworld Table 1 rows over seeds and write the table",
        description="Trains each gridworld row of the paper's Table 1 (spec x algorithm) "
        "over seeds under the noisy classifier bolt, then writes table1.md/csv/json and "
        "learning curves beside the paper's numbers. Resumes when run again.",
    )
    table1.add_argument("--seeds", type=_seeds, default=3, help="count or list (default 3)")
    table1.add_argument(
        "--frames-scale",
        type=_positive_float,
        default=1.0,
        help="scale every row's frames (default 1: max(60k, 2 x the paper's N_frames))",
    )
    table1.add_argument(
        "--frames", type=parse_frames, default=None, help="frames for every row instead"
    )
    table1.add_argument(
        "--rows",
        default=None,
        help="comma-separated rows (edge-ppo, ...) or specs (edge, avoid_top_right, "
        "top_right_once, one_corner_once); default all eight",
    )
    table1.add_argument(
        "--detector",
        default="classifier",
        choices=DETECTOR_NAMES,
        help="the bolt's fluent detector (default classifier: trained CNN, noisy camera)",
    )
    table1.add_argument("--noise", default="regional", help="bolt camera noise (regional)")
    table1.add_argument(
        "--eval-freq",
        type=parse_frames,
        default=None,
        help="frames between evaluations (N_frames resolution; default per row: "
        "clip(paper N_frames / 10, 2k, 10k))",
    )
    table1.add_argument(
        "--eval-episodes", type=whole_number(1), default=20, help="episodes per periodic evaluation"
    )
    table1.add_argument(
        "--final-episodes",
        type=whole_number(1),
        default=100,
        help="final evaluation episodes per seed",
    )
    table1.add_argument("--retries", type=whole_number(0), default=1)
    table1.add_argument(
        "--stop-after",
        type=whole_number(0),
        default=3,
        help="stop a seed once this many evaluations in a row have >= 95%% of episodes at "
        "the goal and complying (default 3; 0: every seed trains its whole budget)",
    )
    table1.add_argument(
        "--last-model",
        action="store_true",
        help="report each seed's last model, not the one of its evaluation with the best "
        "shaped (env + bolt) return",
    )
    table1.add_argument(
        "--tracking",
        default="threshold",
        choices=TRACKING_MODES,
        help="the bolt's DFA tracking: threshold (Algorithm 1, the paper's; default) or belief "
        "(a distribution over DFA states, base rates estimated in each run)",
    )
    table1.add_argument("--out", type=Path, default=Path("runs/table1"))
    _add_backend_options(table1)
    table1.set_defaults(func=_table1)

    case4 = which.add_parser(
        "case4",
        help="exclusive corner spec: regional noise vs a clean control, corner visits",
        description="Trains the exclusive one-visit corner spec under the regional noise "
        "and under a clean camera (control) over seeds, then reports the share of "
        "evaluation episodes detouring via the top-right vs the bottom-left corner "
        "(ground truth), with a plot and heat-maps.",
    )
    case4.add_argument("--seeds", type=_seeds, default=3)
    case4.add_argument("--frames", type=parse_frames, default=60_000, help="per seed (60k)")
    case4.add_argument(
        "--eval-freq",
        type=parse_frames,
        default=None,
        help="frames between periodic evaluations (default frames/30, at most 10k)",
    )
    case4.add_argument(
        "--eval-episodes", type=whole_number(1), default=20, help="episodes per periodic evaluation"
    )
    case4.add_argument(
        "--episodes",
        type=whole_number(1),
        default=100,
        help="episodes per seed whose corners are counted",
    )
    case4.add_argument("--algo", default="a2c", help="default a2c (the paper's)")
    case4.add_argument("--detector", default="classifier", choices=DETECTOR_NAMES)
    case4.add_argument(
        "--start-heading",
        default="east",
        help="the agent's heading at the start: east (the paper's; the top-right route is "
        "shorter) or south (the smudged bottom-left route is shorter), west, north",
    )
    case4.add_argument(
        "--low-confidence-cost",
        type=float,
        default=None,
        help="the spec's charge per low-confidence fluent on the edge taken (default: the "
        "built-in 0.5)",
    )
    case4.add_argument("--out", type=Path, default=Path("runs/case4"))
    _add_backend_options(case4)
    case4.set_defaults(func=_case4)

    report = subparsers.add_parser(
        "report",
        help="write report.md and report.html for a run or sweep directory",
        description="Markdown (pictures linked) and self-contained HTML (pictures "
        "embedded) of a run (config, command, final evaluation, curves, GIFs, heat-maps) "
        "or a sweep (tables, curves, every trial's report).",
    )
    report.add_argument("path", type=Path, help="a run or sweep directory")
    report.add_argument("--no-html", action="store_true", help="Markdown only")
    report.set_defaults(func=_report)


def _sweep(args: argparse.Namespace) -> int:
    from dataclasses import replace

    from noisybolt.experiments.report import sweep_report
    from noisybolt.experiments.sweeps import load_sweep, run_sweep

    config = load_sweep(args.config)
    if args.retries is not None:
        config = replace(config, retries=args.retries)
    out = args.out or Path("runs") / "sweeps" / config.name
    argv = _command(
        "sweep",
        args.config,
        out=out,
        backend=args.backend,
        address=args.address,
        workers=_workers(args),
        retries=args.retries,
    )
    try:
        result = run_sweep(
            config, out, backend=args.backend, workers=_workers(args), address=args.address,
            argv=argv,
        )  # fmt: skip
    except KeyboardInterrupt:  # Ctrl-C or SIGTERM (the CLI's main)
        print(
            f"sweep {config.name} interrupted: the running trial saved a checkpoint; run the "
            "same command to resume",
            file=sys.stderr,
        )
        return 130
    print(result.files["markdown"].read_text())
    unfinished = len(result.records) - result.n_done - result.n_failed
    if unfinished:
        print(f"{unfinished} trials unfinished (interrupted): run the same command to resume")
    if args.report:
        print(f"report: {sweep_report(out).html}")
    return 1 if result.n_failed or unfinished else 0


def _table1(args: argparse.Namespace) -> int:
    from noisybolt.experiments.table1 import reproduce_table1

    rows = [r for r in args.rows.split(",")] if args.rows else None
    argv = _command(
        "reproduce",
        "table1",
        seeds=args.seeds,
        frames_scale=args.frames_scale,
        frames=args.frames,
        rows=args.rows,
        detector=args.detector,
        noise=args.noise,
        eval_freq=args.eval_freq,
        eval_episodes=args.eval_episodes,
        final_episodes=args.final_episodes,
        retries=args.retries,
        stop_after=args.stop_after,
        last_model=args.last_model,
        tracking=args.tracking,
        out=args.out,
        backend=args.backend,
        address=args.address,
        workers=_workers(args),
    )
    result = reproduce_table1(
        args.out,
        rows=rows,
        seeds=args.seeds,
        frames_scale=args.frames_scale,
        frames=args.frames,
        detector=args.detector,
        noise=args.noise,
        eval_freq=args.eval_freq,
        eval_episodes=args.eval_episodes,
        final_eval_episodes=args.final_episodes,
        retries=args.retries,
        keep_best=not args.last_model,
        stop_after=args.stop_after,
        tracking=args.tracking,
        backend=args.backend,
        workers=_workers(args),
        address=args.address,
        argv=argv,
    )
    print(result.files["markdown"].read_text())
    return 1 if result.sweep.n_failed else 0


def _case4(args: argparse.Namespace) -> int:
    from noisybolt.experiments.case4 import reproduce_case4

    argv = _command(
        "reproduce",
        "case4",
        seeds=args.seeds,
        frames=args.frames,
        eval_freq=args.eval_freq,
        eval_episodes=args.eval_episodes,
        episodes=args.episodes,
        algo=args.algo,
        detector=args.detector,
        start_heading=args.start_heading,
        low_confidence_cost=args.low_confidence_cost,
        out=args.out,
        backend=args.backend,
        address=args.address,
        workers=_workers(args),
    )
    data = reproduce_case4(
        args.out,
        seeds=args.seeds,
        frames=args.frames,
        eval_freq=args.eval_freq,
        eval_episodes=args.eval_episodes,
        episodes=max(1, args.episodes),
        algo=args.algo,
        detector=args.detector,
        backend=args.backend,
        workers=_workers(args),
        address=args.address,
        argv=argv,
        start_heading=args.start_heading,
        low_confidence_cost=args.low_confidence_cost,
    )
    print((args.out / "case4.md").read_text())
    return 1 if data["failed_trials"] else 0


def _report(args: argparse.Namespace) -> int:
    # The experiments register their report sections when imported; report imports none.
    import noisybolt.experiments.case4
    import noisybolt.experiments.table1  # noqa: F401
    from noisybolt.envs.registry import refusing_code
    from noisybolt.experiments.report import write_report

    # A report reads JSON and pictures only: a code reference it would follow (a config
    # that needs its world built to load) is refused, never imported.
    with refusing_code():
        files = write_report(args.path, html_page=not args.no_html)
    print(f"markdown: {files.markdown}")
    if not args.no_html:
        print(f"html: {files.html}")
    return 0
