"""Breakout runs across sessions: keep them in results/breakout, restore them, summarise them.

A long Breakout run outlives a session, and ``runs/`` and the classifier cache
(``~/.cache/noisybolt``) may be gone on the next machine. What a resume needs is small:
the run's ``config.json`` and ``command.txt``, its latest checkpoint (``model.zip`` with
the optimiser, ``state.json`` with the evaluation history) and the bolt's classifier (the
one trained on the fly, ~200 kB). ``keep`` copies exactly that into
``results/breakout/<run>/`` and ``results/breakout/classifiers/`` (commit them);
``restore`` puts them back under ``runs/`` and the classifier cache, after which the
command in ``command.txt`` with ``--resume`` (``restore`` prints it) continues the run. ``summary``
writes ``results/breakout/summary.json`` from every kept run's evaluations.

    .venv/bin/python scripts/breakout_runs.py keep runs/breakout-ram-ppo-bolted-seed0 ...
    .venv/bin/python scripts/breakout_runs.py restore breakout-ram-ppo-bolted-seed0 ...
    .venv/bin/python scripts/breakout_runs.py summary
    .venv/bin/python scripts/breakout_runs.py resume breakout-ram-ppo-bolted-seed0 ... \
        [--tree /tmp/wt] [--set world.workers=2 --set world.overlap=true]
                                           # restore where needed, resume at nice 19
    .venv/bin/python scripts/breakout_runs.py start [--tree /tmp/wt] NEW-RUN -- \
        --world breakout ... --init-from runs/<player>   # a new run, in the background
    .venv/bin/python scripts/breakout_runs.py stop     # SIGTERM them: each saves, exits

``summary.json`` is a list, one entry per run (sorted by agent, algo, bolted, seed):
``run``, ``agent`` (``image``, ``ram`` or ``ram_bits``), ``algo``, ``seed``, ``bolted``,
``frames`` (of its last evaluation), ``column_cleared_share`` (share of that
evaluation's episodes that cleared the left column, ground truth), ``left_bricks_gone``
(mean bricks of the left
column gone at an episode's end; null for a run without the per-brick specs), ``score``
(mean game score), ``bolt_false_acceptance`` (largest share of episodes over the specs whose
DFA, run on what the bolt perceived, ended
accepting while the true trace did not; null where not recorded), ``episodes`` and
``reward`` (the reward scheme), ``camera`` (the bolt camera's noise, as given to
``--noise``; ``none`` for a clean camera), ``tracking`` (``threshold``, Algorithm 1, or
``belief``), ``normalize_reward`` (``true``, ``false`` or ``split``: how the learner's
rewards were normalised) and ``bolt_weight`` (under ``split``, the bolt's stream's weight;
1 where not set).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

from noisybolt.io import atomic_write_bytes, atomic_write_json

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "results" / "breakout"
CLASSIFIERS = RESULTS / "classifiers"
RUN_FILES = ("config.json", "command.txt", "metrics.json", "summary.json", "init_model.zip")


def _copy(source: Path, target: Path) -> None:
    target.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_bytes(target, source.read_bytes())


def classifier_file(config: dict[str, Any]) -> Path | None:
    """The cached on-the-fly classifier a run's config uses (None: oracle, synthetic or a
    classifier file named in the config, which is kept wherever it is)."""
    from noisybolt.envs import make_world
    from noisybolt.runs import TrainConfig
    from noisybolt.runs.detectors import classifier_architecture, default_classifier_path

    detector = config.get("detector") or {}
    if detector.get("kind", "classifier") != "classifier" or detector.get("path"):
        return None
    train = TrainConfig.from_dict(config)
    world = make_world(train.world, num_envs=1, seed=0, **train.world_settings)
    camera = world.camera_spec
    return default_classifier_path(
        train.world,
        train.detector,
        camera,
        classifier_architecture(camera),
        world_kwargs=train.world_kwargs,
    )


def keep(run: Path) -> None:
    """Copies what a resume of ``run`` needs into ``results/breakout/<run name>/``."""
    target = RESULTS / run.name
    for name in RUN_FILES:
        if (run / name).exists():
            _copy(run / name, target / name)
    # A training that is still going replaces its checkpoint folder every checkpoint:
    # read the pointer, copy the folder, and try again if it went meanwhile.
    for _ in range(5):
        pointer = run / "checkpoints" / "latest.json"
        if not pointer.exists():
            print(f"{run}: no checkpoint yet")
            break
        latest = json.loads(pointer.read_text())
        folder = run / "checkpoints" / latest["folder"]
        try:
            files = {p.name: p.read_bytes() for p in folder.iterdir() if p.is_file()}
        except FileNotFoundError:
            continue
        kept = target / "checkpoints"
        for name, data in files.items():
            atomic_write_bytes(kept / latest["folder"] / name, data)
        atomic_write_json(kept / "latest.json", latest)
        for old in kept.glob("step_*"):
            if old.name != latest["folder"]:
                shutil.rmtree(old)
        print(f"{run} -> {target}: checkpoint at {latest['frames']:,} frames")
        break
    classifier = classifier_file(json.loads((run / "config.json").read_text()))
    if classifier is not None:
        if classifier.exists():
            _copy(classifier, CLASSIFIERS / classifier.name)
        else:
            print(f"{run}: its classifier {classifier} is not in the cache", file=sys.stderr)


def restore(name: str, runs: Path) -> None:
    """Puts a kept run back into ``runs/<name>`` and its classifier into the cache."""
    source = RESULTS / name
    target = runs / name
    if (target / "checkpoints" / "latest.json").exists():
        here = json.loads((target / "checkpoints" / "latest.json").read_text())["frames"]
        kept = json.loads((source / "checkpoints" / "latest.json").read_text())["frames"]
        if here >= kept:
            print(f"{target} already holds {here:,} frames (kept: {kept:,}); left alone")
            return
    for path in sorted(source.rglob("*")):
        if path.is_file():
            _copy(path, target / path.relative_to(source))
    classifier = classifier_file(json.loads((source / "config.json").read_text()))
    if classifier is not None and not classifier.exists():
        _copy(CLASSIFIERS / classifier.name, classifier)
    # A resume takes every setting from the run's config.json (TrainConfig.resumed).
    print(f"{source} -> {target}; continue with: noisybolt train --out {target} --resume")


def resume(
    name: str,
    runs: Path,
    pids: Path,
    *,
    tree: Path | None = None,
    settings: tuple[str, ...] = (),
) -> int:
    """Restores a kept ``name`` where ``runs/`` lacks it (or holds an older checkpoint) and
    resumes it in the background at nice 19, in a session of its own (so a stopped
    terminal does not stop it), its output appended to ``runs/bk-<name>.log``; its pid is
    appended to ``pids``. ``tree``: a checkout (a git worktree) whose ``src/`` the run
    imports, so that editing this one does not change a run under way. ``settings``:
    ``KEY=VALUE`` given to the resume as ``--set`` (those a resume may change, e.g.
    ``world.workers=2`` and ``world.overlap=true`` for a run alone on the machine, or
    ``frames``; the resume refuses any other). Returns the pid."""
    if (RESULTS / name).exists():
        restore(name, runs)
    elif not (runs / name / "config.json").exists():
        raise SystemExit(f"{name}: neither kept in {RESULTS} nor a run in {runs}")
    arguments = ["--out", str(runs / name), "--resume", "--no-progress"]
    for setting in settings:
        arguments += ["--set", setting]
    pid = _launch(name, arguments, runs, pids, tree)
    print(f"{name}: resumed, pid {pid}, log {runs / f'bk-{name}.log'}")
    return pid


def start(
    name: str,
    train_args: list[str],
    runs: Path,
    pids: Path,
    *,
    tree: Path | None = None,
) -> int:
    """Starts a new run ``runs/<name>`` in the background as ``resume`` continues one (nice
    19, a session of its own, ``runs/bk-<name>.log``, its pid appended to ``pids``):
    ``noisybolt train`` with ``train_args``, which name everything but the output folder
    (e.g. a bolted branch of a kept player: ``--init-from runs/<player>`` with the player's
    command and a learning-rate schedule). Refuses a name that is already a run or kept,
    and ``--out``/``--resume`` among the arguments (``resume`` continues a run).
    Returns the pid."""
    if (runs / name).exists() or (RESULTS / name).exists():
        raise SystemExit(
            f"{name}: already a run in {runs} or kept in {RESULTS}; "
            "continue it with `resume`, or start it under another name"
        )
    for flag in ("--out", "--resume"):
        if any(arg == flag or arg.startswith(flag + "=") for arg in train_args):
            raise SystemExit(f"start names the run's folder itself: leave {flag} out")
    pid = _launch(name, [*train_args, "--out", str(runs / name), "--no-progress"], runs, pids, tree)
    print(f"{name}: started, pid {pid}, log {runs / f'bk-{name}.log'}")
    return pid


#: The background runs' priority (nice value, and their session's autogroup's): the
#: lowest, so that they never slow what a person runs meanwhile.
NICE = 19


def _launch(name: str, train_args: list[str], runs: Path, pids: Path, tree: Path | None) -> int:
    """``noisybolt train train_args`` at nice 19 in a session of its own, its output
    appended to ``runs/bk-<name>.log`` and its pid to ``pids``; ``tree``: a checkout whose
    ``src/`` the run imports."""
    env = dict(os.environ)
    if tree is not None:
        env["PYTHONPATH"] = str(tree.resolve() / "src")
    command = ["nice", "-n", str(NICE), sys.executable, "-m", "noisybolt", "train", *train_args]
    runs.mkdir(parents=True, exist_ok=True)
    with open(runs / f"bk-{name}.log", "a") as log:
        process = subprocess.Popen(
            command, stdout=log, stderr=subprocess.STDOUT, env=env, start_new_session=True
        )
    _lower_autogroup(process.pid)
    with open(pids, "a") as out:
        out.write(f"{process.pid} {name}\n")
    return process.pid


def _lower_autogroup(pid: int) -> None:
    """Gives the run's session the scheduler's lowest share. Linux's autogroup scheduling
    (``kernel.sched_autogroup_enabled``) shares the CPU between *sessions* first, and a
    process's nice value counts only within its own: a run started in a session of its
    own at nice 19 takes as much CPU as a test suite at nice 0 (seen here: four such runs
    held the suite to a fifth of the cores). The session's nice is its autogroup's."""
    with contextlib.suppress(OSError):  # no autogroup scheduling: plain nice applies
        Path(f"/proc/{pid}/autogroup").write_text(str(NICE))


def stop(pids: Path, *, wait_s: float = 600.0) -> list[int]:
    """SIGTERMs every run ``start`` or ``resume`` recorded in ``pids`` that is still going
    (each saves a checkpoint, then exits), waits for them (at most ``wait_s``), and empties
    the file. Returns the pids that were still going."""
    going = []
    for line in pids.read_text().splitlines() if pids.exists() else []:
        pid = int(line.split()[0])
        try:
            os.kill(pid, signal.SIGTERM)
        except ProcessLookupError:
            continue
        going.append(pid)
    deadline = time.monotonic() + wait_s
    for pid in going:
        while time.monotonic() < deadline:
            try:
                os.kill(pid, 0)
            except ProcessLookupError:
                break
            time.sleep(1.0)
        else:
            print(f"pid {pid} is still going after {wait_s:.0f} s", file=sys.stderr)
    atomic_write_bytes(pids, b"")
    return going


def _agent(config: dict[str, Any]) -> str:
    from noisybolt.runs.legacy import nested_config

    config = nested_config(config)  # the flat configs of older runs too
    world = str(config["world"].get("name", ""))
    obs_mode = (config["world"].get("kwargs") or {}).get("obs_mode")
    if obs_mode is None:
        return "ram" if world.endswith("-ram") else "image"
    return {"ram": "ram", "ram_bits": "ram_bits"}.get(obs_mode, "image")


def summary_entry(run: Path) -> dict[str, Any] | None:
    """One run's entry of ``summary.json`` (None for a run with no evaluation yet)."""
    from noisybolt.runs.legacy import nested_config

    config = nested_config(json.loads((run / "config.json").read_text()))  # flat ones too
    metrics = (
        json.loads((run / "metrics.json").read_text()) if (run / "metrics.json").exists() else []
    )
    if not metrics:
        return None
    last = max(metrics, key=lambda record: int(record["frames"]))
    rates = last.get("compliance", {})
    false = last.get("false_acceptance")
    rows = {k: v for k, v in rates.items() if k.startswith("left_row")}  # one spec per brick
    hyperparams = config["algorithm"].get("hyperparams") or {}
    return {
        "run": run.name,
        "agent": _agent(config),
        "algo": config["algorithm"]["name"],
        "seed": int(config["seed"]),
        "bolted": bool(config["bolt"].get("bolted", True)),
        "frames": int(last["frames"]),
        "column_cleared_share": float(rates.get("clear_left_column", 0.0)),
        "left_bricks_gone": float(sum(rows.values())) if rows else None,
        "score": float(last["env_return_mean"]),
        "bolt_false_acceptance": max(false.values()) if false else None,
        "episodes": int(last["n_episodes"]),
        "reward": config["bolt"]["reward"],
        "camera": _camera(config),
        "tracking": str(config["bolt"].get("tracking", "threshold")),
        "normalize_reward": hyperparams.get("normalize_reward", False),
        "bolt_weight": float(hyperparams.get("bolt_weight") or 1.0),
        "frames_before": _frames_before(run),
    }


def _frames_before(run: Path) -> int:
    """Frames the run's network had trained before the run (``--init-from``: its source's,
    read from the copy ``init_model.zip``; 0 for a run from random weights)."""
    from noisybolt.runs.models import read_model_data

    init = run / "init_model.zip"
    return int(read_model_data(init).get("num_timesteps", 0)) if init.exists() else 0


def _camera(config: dict[str, Any]) -> str:
    """The bolt camera's noise as the run was given it (``none``: a clean camera)."""
    noise = (config["world"].get("kwargs") or {}).get("noise")
    if noise is None:
        return "none"
    return noise if isinstance(noise, str) else json.dumps(noise, sort_keys=True)


def summary(results: Path) -> list[dict[str, Any]]:
    """Every kept run's entry, written to ``results/summary.json``."""
    entries = [
        entry
        for run in sorted(results.iterdir())
        if (run / "config.json").exists() and (entry := summary_entry(run)) is not None
    ]
    entries.sort(key=lambda e: (e["agent"], e["algo"], not e["bolted"], e["seed"], e["run"]))
    atomic_write_json(results / "summary.json", entries)
    return entries


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    keep_parser = sub.add_parser("keep", help="copy runs' resume files into results/breakout")
    keep_parser.add_argument("runs", nargs="+", type=Path)
    restore_parser = sub.add_parser("restore", help="put kept runs back under runs/")
    restore_parser.add_argument("names", nargs="+")
    restore_parser.add_argument("--runs", type=Path, default=Path("runs"))
    sub.add_parser("summary", help="write results/breakout/summary.json")
    resume_parser = sub.add_parser(
        "resume", help="restore kept runs where needed and resume them in the background"
    )
    resume_parser.add_argument("names", nargs="+")
    resume_parser.add_argument("--runs", type=Path, default=Path("runs"))
    resume_parser.add_argument("--pids", type=Path, default=Path("runs/breakout.pids"))
    resume_parser.add_argument("--tree", type=Path, help="a checkout whose src/ the runs import")
    resume_parser.add_argument(
        "--set",
        dest="settings",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help=(
            "a setting a resume may change (world.workers, world.overlap, frames, "
            "algorithm.device, algorithm.precision), each run"
        ),
    )
    start_parser = sub.add_parser(
        "start", help="start a new run in the background (noisybolt train's arguments after --)"
    )
    start_parser.add_argument("name")
    start_parser.add_argument("train_args", nargs=argparse.REMAINDER)
    start_parser.add_argument("--runs", type=Path, default=Path("runs"))
    start_parser.add_argument("--pids", type=Path, default=Path("runs/breakout.pids"))
    start_parser.add_argument("--tree", type=Path, help="a checkout whose src/ the run imports")
    stop_parser = sub.add_parser("stop", help="SIGTERM the started and resumed runs")
    stop_parser.add_argument("--pids", type=Path, default=Path("runs/breakout.pids"))
    args = parser.parse_args(argv)
    if args.command == "keep":
        for run in args.runs:
            keep(run)
        summary(RESULTS)
    elif args.command == "restore":
        for name in args.names:
            restore(name, args.runs)
    elif args.command == "resume":
        for name in args.names:
            resume(name, args.runs, args.pids, tree=args.tree, settings=tuple(args.settings))
    elif args.command == "start":
        train_args = args.train_args[1:] if args.train_args[:1] == ["--"] else args.train_args
        start(args.name, train_args, args.runs, args.pids, tree=args.tree)
    elif args.command == "stop":
        print(f"stopped {len(stop(args.pids))} runs (each saved a checkpoint)")
    else:
        for entry in summary(RESULTS):
            print(json.dumps(entry))


if __name__ == "__main__":
    main()
