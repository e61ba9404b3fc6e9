"""Training a bolted agent with Stable-Baselines3: the run directory, resume and restart.

A run directory holds::

    config.json            the resolved :class:`TrainConfig`, nested (schema 2)
    command.txt            the exact command
    .lock                  held by the training writing the run (names its pid, command)
    metrics.json           one record per evaluation (returns, compliance, success, frames)
    checkpoints/latest.json  points to the newest complete checkpoint folder
    checkpoints/step_N/    model.zip, state.json (+ vecnormalize.npz, replay_buffer.npz)
    best/step_N/           with ``keep_best``: the model of the best periodic evaluation
    model.zip              the final model (+ vecnormalize.npz): the last one, or with
                           ``keep_best`` the best one
    tensorboard/           TensorBoard logs
    summary.json           the final evaluation and the first frame count of compliance
    init_model.zip         with ``algorithm.init_from``: a copy of the saved agent the run's
                           network started from (:mod:`~noisybolt.runs.warm_start`)

:func:`train` validates the whole run (config, detector, environments, the model on their
spaces) before it writes anything, then holds the directory's lock for the training's
life. Every file is written atomically, and a checkpoint counts only once ``latest.json``
names it: a run killed at any moment loses at most the work since its last checkpoint.
``resume=True`` continues from there (after checking the saved config equals the new
one, except the frame budget) and refuses a run without a usable checkpoint;
``restart=True`` starts a run over in its directory. Nothing loaded from a run directory
can run code (:mod:`noisybolt.runs.models`, :mod:`noisybolt.runs.checkpoints`).

The pieces live in their own modules (import each from its home): the config
(:mod:`~noisybolt.runs.config`), the detector (:mod:`~noisybolt.runs.detectors`),
the wrapper stack (:mod:`~noisybolt.runs.environments`), the model
(:mod:`~noisybolt.runs.models`), checkpoints (:mod:`~noisybolt.runs.checkpoints`) and
callbacks (:mod:`~noisybolt.runs.callbacks`).
"""

from __future__ import annotations

import contextlib
import os
import shutil
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import torch
from stable_baselines3.common.callbacks import BaseCallback, CallbackList
from stable_baselines3.common.on_policy_algorithm import OnPolicyAlgorithm
from stable_baselines3.common.utils import configure_logger
from stable_baselines3.common.vec_env import VecNormalize

from noisybolt.agents.constraint import LagrangianCallback
from noisybolt.agents.hyperparams import exploration_ends
from noisybolt.errors import ConfigError, CorruptFileError, NoCheckpointError, UntrustedCodeError
from noisybolt.io import atomic_write_bytes, atomic_write_json
from noisybolt.runs.callbacks import (
    CheckpointCallback,
    EvaluationCallback,
    SaveBestModel,
    UpdateThreads,
    linear_schedules,
)
from noisybolt.runs.checkpoints import (
    BEST_DIR,
    NORMALISER,
    REPLAY_BUFFER,
    best_folder,
    copy_model_files,
    latest_checkpoint,
    load_normaliser,
    load_replay_buffer,
    refuse_pickles,
    save_model_files,
)
from noisybolt.runs.config import (
    RESUMABLE_KEYS,
    TrainConfig,
)
from noisybolt.runs.environments import make_env, prepare_bolt
from noisybolt.runs.evaluation import EvalResult
from noisybolt.runs.models import load_model
from noisybolt.runs.models import make_model as _make_model
from noisybolt.runs.presentation import describe_scheme, warn_of_unnormalized_rewards
from noisybolt.runs.resolution import resolve
from noisybolt.runs.rundir import RunDirectory, config_differences
from noisybolt.runs.stopping import StopWhenSolved, trailing_streak
from noisybolt.runs.warm_start import (
    INIT_MODEL,
    apply_initial_weights,
    read_initial_weights,
)

__all__ = ["RUN_OUTPUTS", "TrainResult", "check_frames_left", "check_same_config", "train"]

#: What :func:`train` writes in a run directory (``restart`` removes them first).
RUN_OUTPUTS: tuple[str, ...] = (
    "config.json",
    "command.txt",
    "metrics.json",
    "summary.json",
    "model.zip",
    NORMALISER,
    "vecnormalize.pkl",
    "checkpoints",
    BEST_DIR,
    "tensorboard",
    INIT_MODEL,
)


@dataclass(frozen=True)
class TrainResult:
    """What a finished run reports.

    Attributes:
        run_dir: the run directory.
        frames: environment steps trained (all environments together).
        final: the final evaluation.
        frames_to_comply: N_frames, the frames after which an evaluation first had at
            least ``success_threshold`` of its episodes reach the goal while complying
            with every spec (None if it never did).
        history: every evaluation's record.
    """

    run_dir: Path
    frames: int
    final: EvalResult
    frames_to_comply: int | None
    history: tuple[dict[str, Any], ...]


def train(
    config: TrainConfig,
    run_dir: str | os.PathLike[str],
    *,
    resume: bool = False,
    restart: bool = False,
    argv: Sequence[str] | None = None,
    log: Callable[[str], None] = print,
    retrain_classifier: bool = False,
) -> TrainResult:
    """Trains (or resumes, or restarts) a bolted agent; see the module docstring.

    Raises:
        ConfigError: bad settings (before anything is written); ``resume`` on a directory
            whose config differs (the message names the differing keys); a fresh run into
            a directory that already holds one; ``run_dir`` is a file.
        NoCheckpointError: ``resume`` of a run without a usable checkpoint.
        RunLockedError: another process is writing the run directory.
        CorruptFileError: a file of the run (pointer, state, model, statistics, buffer) is
            damaged, leads outside the directory, or belongs to another run.
        UnknownFluentError: a spec names a fluent the world does not have.
        IncompatibleError: the detector's fluents or camera differ from the world's.
    """
    torch.set_num_threads(1)
    run = RunDirectory(run_dir)
    if resume and restart:
        raise ConfigError(
            "--resume (resume=True) continues a run and --restart (restart=True) starts it "
            "over: give one"
        )
    if resume and retrain_classifier:
        raise ConfigError(
            "--retrain-classifier with --resume would change the bolt's eyes halfway through "
            "a run; retrain for a new run"
        )
    if run.path.exists() and not run.path.is_dir():
        raise ConfigError(
            f"{run.path} is a file, not a run directory; give --out a directory (new or "
            "holding a run)"
        )
    if resume and not run.exists():
        raise NoCheckpointError(f"--resume: {run.path} holds no run to continue")
    if not resume:  # a budget a new run cannot keep is refused (a saved run keeps its own)
        config.check_budget()
    if not (resume or restart) and run.exists():
        raise ConfigError(
            f"{run.path} already holds a run; pass --resume to continue it (resume=True from "
            "Python), --restart to start it over (restart=True), or choose another directory"
        )
    # What the world decides (the compliance scale, exact on a tabular product), as every
    # door decides it: a no-op on a config already resolved (a resumed run's config.json
    # is). A resumed run keeps what its config.json holds: check_same_config refuses
    # anything else.
    config = resolve(config, log=log)
    if resume:  # before the costly checks: a resume with other settings fails at once
        check_same_config(run, config)
        check_frames_left(run, config)

    # The saved agent a new run starts from is read first: a checkpoint can be rotated
    # away by its run while the checks below take their minutes.
    initial = None
    if not resume and config.algorithm.init_from is not None:
        initial = read_initial_weights(config)
    # Everything that can be checked is checked before anything is written: the specs
    # against the world, the detector, the environments, and the model on their spaces.
    setup = prepare_bolt(
        config,
        seed=config.seed,
        progress=config.progress_bar,
        log=log,
        retrain_classifier=retrain_classifier,
    )
    env, eval_env = (
        make_env(
            config,
            setup.detector,
            training=training,
            dfas=setup.dfas,
            letters=setup.letters,
            belief=setup.belief,
        )
        for training in (True, False)
    )
    tensorboard = str(run.file("tensorboard"))
    fresh = _make_model(config, env, tensorboard_log=tensorboard) if not resume else None
    if fresh is not None and initial is not None:
        apply_initial_weights(fresh, initial, setup.fluents)
    log(describe_scheme(config))  # once every check has passed
    if initial is not None:
        log(initial.describe())
    warn_of_unnormalized_rewards(config)

    with run.lock(argv):
        run.remove_partial_files()  # of a writer killed mid-write: no one writes now
        history: list[dict[str, Any]] = []
        frames_to_comply: int | None = None
        best: dict[str, Any] | None = None
        multiplier: dict[str, Any] | None = None
        if resume:
            # Read under the lock: no other writer can be midway through these files.
            check_same_config(run, config)
            model, state = _load_checkpoint(config, run, env)
            model.tensorboard_log = tensorboard  # never the path the saved model names
            history = list(state.get("history", []))
            frames_to_comply = state.get("frames_to_comply")
            best = state.get("best")
            multiplier = state.get("multiplier")
            log(f"resuming {run.path} from {model.num_timesteps} frames")
        else:
            if run.exists() and not restart:  # written by another process meanwhile
                raise ConfigError(
                    f"{run.path} already holds a run; pass --resume (resume=True) to continue it"
                )
            if restart:
                _clear_run(run)
            assert fresh is not None
            model = fresh
        run.write_config(config.to_dict())
        if initial is not None:  # the run stays reproducible when its source changes
            atomic_write_bytes(run.file(INIT_MODEL), initial.content)
        if not resume or not run.file("command.txt").exists():
            run.write_command(argv)  # a resume keeps the command that set the run up
        run.record_versions(frames=model.num_timesteps, argv=argv)
        return _learn(
            config,
            run,
            model,
            env,
            eval_env,
            history=history,
            frames_to_comply=frames_to_comply,
            best=best,
            multiplier=multiplier,
            fresh=not resume,
            log=log,
        )


def check_frames_left(run: RunDirectory, config: TrainConfig) -> None:
    """Refuses to resume ``run`` to ``config.frames`` when that is a new, lower target
    than its latest checkpoint has trained: the resume would train nothing, yet write the
    smaller target into its ``config.json``. The run's own saved target always resumes,
    even below the frames trained: PPO and A2C end a run at the rollout past it, so a run
    interrupted after that rollout has trained more than it asked for, and its resume
    writes the final model and evaluation it lacks (a sweep's trials resume this way).

    Raises:
        ConfigError: naming the frames trained and what to do.
        NoCheckpointError, CorruptFileError: as :func:`latest_checkpoint`.
    """
    from noisybolt.runs.checkpoints import latest_checkpoint

    trained = latest_checkpoint(run).frames
    if config.frames >= trained:
        return
    saved = run.read_config().get("frames") if run.config_path.exists() else None
    if config.frames != saved:
        raise ConfigError(
            f"cannot resume {run.path} to {config.frames:,} frames: it has trained "
            f"{trained:,} already; give --frames above that to train on, or evaluate it "
            f"with noisybolt evaluate {run.path}"
        )


def check_same_config(run: RunDirectory, config: TrainConfig) -> None:
    """Refuses to resume ``run`` with settings other than its saved ones
    (:data:`RESUMABLE_KEYS` aside), naming every differing schema path. The saved config is
    read as :meth:`TrainConfig.from_dict` reads it: a flat ``config.json`` of an older run
    through :data:`LEGACY_DEFAULTS`.

    Raises:
        ConfigError: the configs differ, or the saved one does not load.
    """
    from noisybolt.runs.trust import code_references, loading_run

    try:
        data = run.read_config()
        # The code ``config`` names is the user's; other code the saved run names is not
        # imported to compare (issue 46): it differs, and is refused as such.
        given = {r.path: r.value for r in code_references(config.to_dict())}
        with loading_run(data, given=given, source=f"{run.path} (resumed)"):
            saved = TrainConfig.from_dict(data).to_dict()
    except UntrustedCodeError:
        raise
    except ConfigError as error:
        raise ConfigError(
            f"cannot resume {run.path}: its config.json does not load: {error}"
        ) from None
    diffs = config_differences(saved, config.to_dict(), ignore=RESUMABLE_KEYS)
    if diffs:
        lines = "; ".join(f"{k}: saved {a!r}, now {b!r}" for k, (a, b) in diffs.items())
        raise ConfigError(
            f"cannot resume {run.path}: the config differs in {sorted(diffs)} ({lines}); "
            "use the saved settings or start a new run directory"
        )


def _load_checkpoint(
    config: TrainConfig, run: RunDirectory, env: Any
) -> tuple[Any, dict[str, Any]]:
    """The latest checkpoint's model (onto ``env``, whose normaliser and replay buffer it
    restores) and bookkeeping, read without unpickling anything."""
    checkpoint = latest_checkpoint(run)
    refuse_pickles(checkpoint.folder)
    saved_algo = checkpoint.state.get("algo")
    if saved_algo is not None and saved_algo != config.algorithm.name:
        raise CorruptFileError(
            f"{checkpoint.folder / 'state.json'} is a checkpoint of a {saved_algo} run, and "
            f"{run.config_path} describes a {config.algorithm.name} run: the directory mixes two "
            "runs; "
            "start it over (--restart) or use another directory"
        )
    if isinstance(env, VecNormalize):
        load_normaliser(env, checkpoint.folder / NORMALISER)
    model = load_model(checkpoint.model, config, env)
    if getattr(model, "replay_buffer", None) is not None:
        load_replay_buffer(model, checkpoint.folder / REPLAY_BUFFER)
    state = checkpoint.state
    history = state.get("history", [])
    if not isinstance(history, list) or not all(
        isinstance(r, dict) and isinstance(r.get("frames"), int) for r in history
    ):
        raise CorruptFileError(
            f"{checkpoint.folder / 'state.json'} is corrupt: its history must be a list of "
            "evaluation records; start the run over with --restart"
        )
    return model, state


def _clear_run(run: RunDirectory) -> None:
    """Removes what an earlier training wrote (``restart``), leaving other files alone."""
    for name in RUN_OUTPUTS:
        path = run.file(name)
        if path.is_dir() and not path.is_symlink():
            shutil.rmtree(path)
        elif path.exists() or path.is_symlink():
            path.unlink()
    for path in run.path.glob("evaluation*.json"):
        path.unlink()


@contextlib.contextmanager
def _unchecked_distributions() -> Iterator[None]:
    """torch's distributions without their argument checks, for the length of a
    ``learn()``.

    SB3 builds a ``Categorical`` (or ``Normal``) from the policy's own outputs at every
    step and every minibatch, and by default torch checks each one's parameters and each
    sampled action against its support: a fifth of a 4-game policy call on Breakout's
    RAM network (0.53 -> 0.43 ms measured). What it checks is what SB3 itself produced,
    so nothing a user gives goes unchecked. The previous default comes back afterwards
    (``train()`` is also a library call).
    """
    distribution = torch.distributions.Distribution
    before = distribution._validate_args
    distribution.set_default_validate_args(False)
    try:
        yield
    finally:
        distribution.set_default_validate_args(before)


def _learn(
    config: TrainConfig,
    run: RunDirectory,
    model: Any,
    env: Any,
    eval_env: Any,
    *,
    history: list[dict[str, Any]],
    frames_to_comply: int | None,
    best: dict[str, Any] | None,
    multiplier: dict[str, Any] | None = None,
    fresh: bool,
    log: Callable[[str], None],
) -> TrainResult:
    spec_names = [s.name for s in config.spec_objects()]
    stop = None
    if config.evaluation.stop_after:
        # A resumed run continues the streak its saved evaluations ended on.
        streak = trailing_streak(
            [r["success_rate"] for r in history], config.evaluation.success_threshold
        )
        stop = StopWhenSolved(
            threshold=config.evaluation.success_threshold,
            consecutive=config.evaluation.stop_after,
            score=lambda parent: parent.success_rate,
            streak=streak,
            # Not while an exploration schedule still runs: the policy judged solved
            # would not be the one the schedule ends with.
            not_before=exploration_ends(
                config.algorithm.hyperparams, algo=config.algorithm.name, frames=config.frames
            ),
        )
    evaluation = EvaluationCallback(
        config=config,
        run=run,
        eval_env=eval_env,
        spec_names=spec_names,
        history=history,
        frames_to_comply=frames_to_comply,
        best=best,
        callback_on_new_best=SaveBestModel(run, algo=config.algorithm.name)
        if config.evaluation.keep_best
        else None,
        callback_after_eval=stop,
    )
    # The constrained scheme's multiplier moves the training bolts' price between
    # rollouts; evaluation's bolts keep price 1 (the compliance scheme's payments), so the
    # shaped returns that choose the kept model are measured on one scale.
    constraint = (
        LagrangianCallback(
            config.bolt.cost_limit,
            frames=config.frames,
            state=multiplier,
            scale=config.bolt.reward_scale,
        )
        if config.bolt.bolted and config.bolt.reward == "constrained"
        else None
    )
    # The kept model is judged at the price's scale, raised as the multiplier's is.
    evaluation.constraint = constraint
    checkpoints = CheckpointCallback(
        config=config, run=run, evaluation=evaluation, constraint=constraint
    )
    callbacks: list[BaseCallback] = [evaluation, checkpoints]
    if constraint is not None:
        callbacks.insert(0, constraint)
    callbacks += linear_schedules(
        config.algorithm.hyperparams, algo=config.algorithm.name, frames=config.frames
    )
    if config.world_config.workers and isinstance(model, OnPolicyAlgorithm):
        callbacks.append(UpdateThreads.for_this_machine())
    remaining = config.frames - model.num_timesteps
    if remaining > 0 and not (stop is not None and stop.solved):
        try:
            with _unchecked_distributions():
                model.learn(
                    total_timesteps=remaining,
                    callback=CallbackList(callbacks),
                    reset_num_timesteps=fresh,
                    progress_bar=config.progress_bar,
                    tb_log_name="run",
                )
        except KeyboardInterrupt:
            # Ctrl-C (or the CLI's SIGTERM): keep every frame trained so far, not only
            # those up to the last periodic checkpoint. Mid-rollout is fine: the model,
            # normaliser and replay buffer are consistent between steps, and a resume
            # starts a fresh rollout, as it does from any checkpoint.
            evaluation.init_callback(model)  # in case learn() had not got that far
            checkpoints.init_callback(model)
            checkpoints.checkpoint()
            log(
                f"interrupted at {model.num_timesteps:,} frames: checkpoint saved; continue "
                f"with --resume --out {run.path}"
            )
            raise
    elif not hasattr(model, "_logger"):
        # learn() sets up the logger evaluations record to; a resume with no frames left
        # (a run interrupted after its last rollout) evaluates without it.
        model.set_logger(
            configure_logger(model.verbose, model.tensorboard_log, "run", reset_num_timesteps=False)
        )
    evaluation.init_callback(model)
    checkpoints.init_callback(model)
    try:
        final = (
            evaluation.evaluate()
            if not history or history[-1]["frames"] != model.num_timesteps
            else None
        )
    except KeyboardInterrupt:
        # Every frame is trained: keep them (a resume evaluates and finishes the run).
        checkpoints.checkpoint()
        log(
            f"interrupted in the final evaluation, {model.num_timesteps:,} frames trained: "
            f"checkpoint saved; finish with --resume --out {run.path}"
        )
        raise
    if final is None:
        final = EvalResult.from_record(history[-1])
    checkpoints.checkpoint()
    kept: dict[str, Any] = {"frames": int(model.num_timesteps), "chosen_by": "last"}
    if config.evaluation.keep_best and evaluation.best is not None:
        best_frames = evaluation.best["frames"]
        record = next(r for r in reversed(history) if r["frames"] == best_frames)
        final = EvalResult.from_record(record)
        constrained = config.bolt.bolted and config.bolt.reward == "constrained"
        chosen_by = "best shaped return"
        if constrained and "score" in evaluation.best:
            chosen_by = "best return within the cost budget"
        kept = {"frames": best_frames, "chosen_by": chosen_by, **evaluation.best}
        copy_model_files(best_folder(run, best_frames), run.path)
    else:
        save_model_files(model, env, run.path, algo=config.algorithm.name)
    summary = {
        "frames": int(model.num_timesteps),
        "frames_to_comply": evaluation.frames_to_comply,
        # Where stop-when-solved ended the run (None: it trained its budget, or no rule).
        "stopped_at": None if stop is None or not stop.solved else int(model.num_timesteps),
        "kept_model": kept,
        "final": final.to_dict(),
    }
    atomic_write_json(run.file("summary.json"), summary)
    return TrainResult(
        run_dir=run.path,
        frames=int(model.num_timesteps),
        final=final,
        frames_to_comply=evaluation.frames_to_comply,
        history=tuple(history),
    )
