"""``noisybolt classifiers collect|train|report``: the bolt's fluent classifiers end to end.

All three work in one run directory (``--out``)::

    config.json             resolved settings of each stage run so far ({"collect": ...})
    command.txt             the exact commands, one line per stage, in stage order
    dataset.npz             collect: labelled bolt images (noisybolt.perception.dataset)
    classifier.safetensors  train: the classifier (noisybolt.perception.classifier)
    metrics.json            train: one record per epoch
    validation_report.json  train: per-fluent quality on the held-out split
    report.json / .txt      report: per-fluent quality on a fresh test set

Example::

    noisybolt classifiers collect --world gridworld --noise regional --samples 4000 --out runs/c
    noisybolt classifiers train --out runs/c --epochs 30
    noisybolt classifiers report --out runs/c
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys
from dataclasses import asdict
from pathlib import Path
from typing import Any

from noisybolt.errors import ConfigError
from noisybolt.io import atomic_write_json, atomic_write_text
from noisybolt.perception.classifier import ClassifierConfig, load_classifier
from noisybolt.perception.compat import camera_spec_to_dict
from noisybolt.perception.dataset import collect_samples, load_dataset, save_dataset
from noisybolt.perception.metrics import build_report
from noisybolt.perception.training import TrainingConfig, train_classifier
from noisybolt.runs.rundir import CLASSIFIER_STAGES, RunDirectory

__all__ = ["register"]

STAGES = CLASSIFIER_STAGES
DATASET_FILE = "dataset.npz"
CLASSIFIER_FILE = "classifier.safetensors"


def _world_arg(text: str) -> tuple[str, Any]:
    key, sep, value = text.partition("=")
    if not sep or not key.isidentifier():
        raise argparse.ArgumentTypeError(f"expected KEY=VALUE, got {text!r}")
    try:
        return key, json.loads(value)
    except json.JSONDecodeError:
        return key, value


def register(subparsers: Any) -> None:
    """Adds ``classifiers`` with its ``collect``, ``train`` and ``report`` subcommands."""
    parser = subparsers.add_parser(
        "classifiers",
        help="collect bolt images, train and report fluent classifiers",
        description="Collect labelled bolt images from a world, train the fluent classifiers "
        "and report their quality, all in one run directory (--out).",
    )
    actions = parser.add_subparsers(dest="action", metavar="ACTION", required=True)

    def common(p: argparse.ArgumentParser) -> None:
        p.add_argument("--out", required=True, type=Path, help="run directory")
        p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
        p.add_argument("--quiet", action="store_true", help="no progress bars")

    def world_options(p: argparse.ArgumentParser, *, required: bool) -> None:
        p.add_argument(
            "--world", required=required, help="world registry name (gridworld, breakout, ...)"
        )
        p.add_argument(
            "--noise",
            default=None,
            help="camera noise, e.g. none, regional, 'gaussian:sigma=12+blur' (default: the "
            "world's default)",
        )
        p.add_argument(
            "--world-arg",
            action="append",
            type=_world_arg,
            default=[],
            metavar="KEY=VALUE",
            help="extra world constructor argument (JSON value), repeatable",
        )
        p.add_argument("--num-envs", type=int, default=16, help="environments collected at once")

    collect = actions.add_parser("collect", help="collect a labelled dataset of bolt images")
    common(collect)
    world_options(collect, required=True)
    collect.add_argument("--samples", type=int, default=4000, help="dataset size")
    collect.add_argument("--oversample", type=float, default=2.0, help="pool / dataset size")
    collect.set_defaults(func=_collect)

    train = actions.add_parser("train", help="train the fluent classifier on the dataset")
    common(train)
    train.add_argument("--dataset", type=Path, help=f"default: RUN/{DATASET_FILE}")
    train.add_argument("--epochs", type=int, default=TrainingConfig.epochs)
    train.add_argument("--batch-size", type=int, default=TrainingConfig.batch_size)
    train.add_argument("--lr", type=float, default=TrainingConfig.learning_rate)
    train.add_argument(
        "--validation-fraction", type=float, default=TrainingConfig.validation_fraction
    )
    train.add_argument(
        "--target-accuracy",
        type=float,
        default=None,
        help="stop once every fluent's validation accuracy reaches this",
    )
    train.add_argument(
        "--channels",
        type=lambda s: tuple(int(c) for c in s.split(",")),
        default=ClassifierConfig.channels,
        help="conv channels, comma-separated (default 16,32,32)",
    )
    train.set_defaults(func=_train)

    report = actions.add_parser(
        "report", help="per-fluent accuracy, AUROC, ECE and confidence bands"
    )
    common(report)
    report.add_argument("--classifier", type=Path, help=f"default: RUN/{CLASSIFIER_FILE}")
    report.add_argument(
        "--dataset",
        type=Path,
        help="evaluate on this dataset instead of a fresh one collected from the world",
    )
    world_options(report, required=False)
    report.add_argument("--samples", type=int, default=None, help="fresh test-set size")
    report.add_argument(
        "--ignore-noise",
        action="store_true",
        help="allow a camera noise other than the classifier's (deliberate robustness test)",
    )
    report.add_argument(
        "--trust-code",
        action="store_true",
        help="follow the world factory path the run directory's collect stage names "
        "(otherwise refused unless given again with --world); only for a directory whose "
        "author you trust",
    )
    report.set_defaults(func=_report)


# -- run directory bookkeeping ----------------------------------------------------------------
def _command(args: argparse.Namespace) -> str:
    """A canonical command line that reproduces this stage with every setting explicit."""
    argv = ["noisybolt", "classifiers", args.action]
    for key, value in sorted(vars(args).items()):
        if key in ("func", "command", "action") or value is None or value is False:
            continue
        flag = "--" + key.replace("_", "-")
        if value is True:
            argv.append(flag)
        elif key == "world_arg":
            for k, v in value:
                argv += [flag, f"{k}={json.dumps(v)}"]
        elif key == "channels":
            argv += [flag, ",".join(map(str, value))]
        else:
            argv += [flag, str(value)]
    return shlex.join(argv)


def _record(
    run: RunDirectory, stage: str, args: argparse.Namespace, settings: dict[str, Any]
) -> None:
    config = run.read_config() if run.exists() else {}
    config[stage] = {
        **settings,
        "command": _command(args),
        "argv": [Path(sys.argv[0]).name, *sys.argv[1:]],
    }
    run.write_config(config)
    lines = [config[s]["command"] for s in STAGES if s in config]
    run.write_command_lines(lines)


def _make_world(
    name: str, *, num_envs: int, seed: int, noise: str | None, extra: dict[str, Any]
) -> Any:
    from noisybolt.envs import make_world  # the CLI is the top layer: it may know worlds

    kwargs = dict(extra)
    if noise is not None:
        kwargs["noise"] = noise
    return make_world(name, num_envs=num_envs, seed=seed, **kwargs)


def _positive(name: str, value: float | int) -> None:
    if value <= 0:
        raise ConfigError(f"--{name} must be positive, got {value}")


# -- stages -------------------------------------------------------------------------------------
def _collect(args: argparse.Namespace) -> int:
    _positive("samples", args.samples)
    _positive("num-envs", args.num_envs)
    run = RunDirectory(args.out)
    extra = dict(args.world_arg)
    world = _make_world(
        args.world, num_envs=args.num_envs, seed=args.seed, noise=args.noise, extra=extra
    )
    try:
        dataset = collect_samples(
            world,
            num_samples=args.samples,
            seed=args.seed,
            oversample=args.oversample,
            progress=not args.quiet,
        )
    finally:
        close = getattr(world, "close", None)
        if callable(close):
            close()
    dataset.metadata.update({"world": args.world, "noise": args.noise, "world_args": extra})
    path = run.file(DATASET_FILE)
    save_dataset(dataset, path)
    _record(
        run,
        "collect",
        args,
        {
            "world": args.world,
            "noise": args.noise,
            "world_args": extra,
            "num_envs": args.num_envs,
            "samples": args.samples,
            "oversample": args.oversample,
            "final_views": dataset.metadata["final_views"],
            "seed": args.seed,
            "camera_spec": camera_spec_to_dict(dataset.camera_spec),
            "fluent_names": list(dataset.fluent_names),
            "positives": dataset.positives,
            "dataset": str(path),
        },
    )
    print(f"collected {len(dataset)} samples into {path}")
    for name, count in dataset.positives.items():
        print(f"  {name:<20} {count:>6d} positive, {len(dataset) - count:>6d} negative")
    return 0


def _train(args: argparse.Namespace) -> int:
    run = RunDirectory(args.out)
    dataset_path = args.dataset or run.file(DATASET_FILE)
    if not Path(dataset_path).is_file():
        raise ConfigError(
            f"no dataset at {dataset_path}: collect one first (noisybolt classifiers collect "
            f"--world W --out {args.out}), or give --dataset FILE"
        )
    dataset = load_dataset(dataset_path)
    config = ClassifierConfig(channels=args.channels)
    training = TrainingConfig(
        epochs=args.epochs,
        batch_size=args.batch_size,
        learning_rate=args.lr,
        validation_fraction=args.validation_fraction,
        seed=args.seed,
        target_accuracy=args.target_accuracy,
    )
    result = train_classifier(dataset, config=config, training=training, progress=not args.quiet)
    path = run.file(CLASSIFIER_FILE)
    result.detector.save(path)
    run.write_metrics(
        [
            {
                "epoch": e.epoch,
                "train_loss": e.train_loss,
                "validation_loss": e.validation_loss,
                "validation_accuracy": dict(
                    zip(dataset.fluent_names, e.validation_accuracy, strict=True)
                ),
                "seconds": e.seconds,
            }
            for e in result.history
        ]
    )
    atomic_write_json(run.file("validation_report.json"), result.report.to_dict())
    _record(
        run,
        "train",
        args,
        {
            "dataset": str(dataset_path),
            "classifier": str(path),
            "architecture": asdict(config),
            "training": asdict(training),
            "epochs_run": len(result.history),
            "seconds": result.seconds,
            "reached_target": result.reached_target,
        },
    )
    print(f"trained in {result.seconds:.1f} s ({len(result.history)} epochs); saved {path}")
    print("validation:")
    print(result.report.format_table())
    return 0


def _report(args: argparse.Namespace) -> int:
    run = RunDirectory(args.out)
    classifier_path = args.classifier or run.file(CLASSIFIER_FILE)
    ignore = {"noise"} if args.ignore_noise else set()
    collected = run.read_config().get("collect", {}) if run.exists() else {}
    world = None
    if args.dataset is not None:
        data = load_dataset(args.dataset)
        names, spec = data.fluent_names, data.camera_spec
        source: dict[str, Any] = {"dataset": str(args.dataset)}
    else:
        world_name = args.world or collected.get("world")
        if world_name is None:
            raise ConfigError(
                "report needs --world (or --dataset), or a run directory made by collect"
            )
        if args.world is None:  # read from the directory: its code is not followed unasked
            from noisybolt.runs.trust import check_code_trusted

            check_code_trusted(
                {"world": {"name": world_name}},
                trust_code=args.trust_code,
                source=f"{run.path}'s collect stage (config.json)",
            )
        noise = args.noise if args.noise is not None else collected.get("noise")
        extra = dict(args.world_arg) if args.world_arg else collected.get("world_args", {})
        samples = args.samples or collected.get("samples", 2000)
        _positive("samples", samples)
        _positive("num-envs", args.num_envs)
        seed = args.seed + 1_000_003  # never the collection's seed: a fresh test set
        world = _make_world(world_name, num_envs=args.num_envs, seed=seed, noise=noise, extra=extra)
        names, spec = tuple(world.fluent_names), world.camera_spec
        source = {
            "world": world_name,
            "noise": noise,
            "world_args": extra,
            "samples": samples,
            "seed": seed,
        }
    try:
        # Refuse before any work a classifier made for other fluents or another camera.
        detector = load_classifier(
            classifier_path, fluent_names=names, camera_spec=spec, ignore=ignore
        )
        if world is not None:
            data = collect_samples(
                world,
                num_samples=source["samples"],
                seed=source["seed"],
                progress=not args.quiet,
            )
    finally:
        close = getattr(world, "close", None)
        if callable(close):
            close()
    probs = detector.predict(data.images)
    report = build_report(probs, data.labels, fluent_names=detector.fluent_names)
    atomic_write_json(run.file("report.json"), {"source": source, **report.to_dict()})
    table = report.format_table()
    atomic_write_text(run.file("report.txt"), table + "\n")
    _record(
        run,
        "report",
        args,
        {"classifier": str(classifier_path), "source": source, "ignore": sorted(ignore)},
    )
    print(table)
    return 0
