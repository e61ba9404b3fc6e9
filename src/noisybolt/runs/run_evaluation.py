"""``noisybolt evaluate RUN_DIR``: a saved run's policy, evaluated from ground truth.

Loads the run's resolved config and final model (or its latest checkpoint), rebuilds the
same bolted world and detector, runs K episodes, and writes ``evaluation.json`` beside the
run's results. Optionally saves one episode as a GIF (the world, the bolt's noisy view,
the DFA states and fluent probabilities per step) and a trajectory heat-map.

A run directory is data: code its config names (a world or detector factory path) is
imported only with the user's word (:mod:`noisybolt.runs.trust`).
"""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
import torch
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.vec_env import VecEnv

from noisybolt.envs.layout import GridLayout
from noisybolt.envs.registry import make_single_world, world_display
from noisybolt.errors import ConfigError
from noisybolt.io import atomic_write_json
from noisybolt.runs.compliance import ComplianceReport
from noisybolt.runs.config import TrainConfig
from noisybolt.runs.environments import BoltSetup, make_env, prepare_bolt
from noisybolt.runs.evaluation import EvalResult, evaluate_bolted_policy
from noisybolt.runs.rundir import RunDirectory

__all__ = ["RunEvaluation", "evaluate_run", "load_run_model"]


@dataclass(frozen=True)
class RunEvaluation:
    """The evaluation of a run and the files it wrote (label → path).

    ``compliance`` is the compliance estimated from the bolt's evidence (None when not
    asked for); ``ground_truth`` says whether the truth was read: without it,
    ``result``'s compliance, success and false acceptances are not reported.
    """

    result: EvalResult
    files: dict[str, Path] = field(default_factory=dict)
    compliance: ComplianceReport | None = None
    ground_truth: bool = True

    def summary(self) -> dict[str, Any]:
        """What ``evaluation.json`` holds of the result: without ground truth, nothing
        judged from it (compliance, goal and success, false acceptances)."""
        data = self.result.to_dict()
        if not self.ground_truth:
            for key in ("compliance", "false_acceptance", "success_rate", "goal_rate"):
                data.pop(key, None)
        if self.compliance is not None:
            data["compliance_estimate"] = self.compliance.to_dict()
        return data


def load_run_model(
    run: RunDirectory, config: TrainConfig, env: VecEnv | None = None
) -> BaseAlgorithm:
    """The run's final model, or its latest checkpoint when it did not finish.

    Loaded without unpickling anything (:func:`noisybolt.runs.models.load_model`), from
    inside the run directory only. ``env``: envs of the run's world to load onto (default:
    one built here, with the oracle detector: only its spaces matter). Its network goes
    on the run's ``algorithm.device``, or on the CPU where this machine lacks that GPU.

    Raises:
        ConfigError: the run holds neither a model nor a checkpoint.
        CorruptFileError: a file is damaged, or a pointer or link leads outside the run.
        UnsafeFileError: the model holds a serialized entry noisybolt does not rebuild.
    """
    from noisybolt.runs.checkpoints import latest_checkpoint
    from noisybolt.runs.models import load_model, native_bfloat16, torch_device

    path = run.file("model.zip")
    if path.exists() or path.is_symlink():
        path = run.inside("model.zip")
    elif (run.file("checkpoints") / "latest.json").exists():
        path = latest_checkpoint(run).model
    else:
        raise ConfigError(f"{run.path} holds neither model.zip nor a checkpoint")
    if env is None:
        from noisybolt.envs import make_world
        from noisybolt.logic import compile_ltlf
        from noisybolt.perception.detectors import OracleDetector

        probe: Any = make_world(
            config.world_config.name, num_envs=1, seed=0, **config.world_settings
        )
        names = tuple(probe.fluent_names)
        probe.close()
        detector = OracleDetector(names)
        # Only its spaces matter; DFAs compiled here (cached), so that a spec every trace
        # satisfies is not warned of again by an env that only loads the model.
        dfas = [compile_ltlf(spec.formula, names) for spec in config.spec_objects()]
        # Belief tracking's base rates do not change the spaces: any will do here.
        settings = config.belief_settings
        belief = None if settings is None else replace(settings, base_rates=0.5)
        env = make_env(
            config,
            detector,
            training=False,
            n_envs=config.world_config.n_envs,
            dfas=dfas,
            belief=belief,
        )
    # A run trained on a GPU evaluates on the CPU of a machine without one.
    try:
        device = torch_device(config.algorithm.device)
    except ConfigError:
        device = "cpu"
    # ... and in float32 where this machine lacks the run's bfloat16 (same weights).
    precision = config.algorithm.precision if native_bfloat16(device) else "float32"
    return load_model(path, config, env, device=device, precision=precision)


def _single_env(config: TrainConfig) -> Any:
    """One (non-vectorised) labelled environment of the run's world, for recordings."""
    return make_single_world(config.world_config.name, **config.world_settings)


def _grid_layout(config: TrainConfig) -> GridLayout:
    """The world's declared grid (its single env's ``grid_layout``), for heat-maps.

    Raises:
        ConfigError: the world declares none (say how a world declares one).
    """
    env = _single_env(config)
    try:
        layout = env.get_wrapper_attr("grid_layout")
    except AttributeError:
        layout = None
    finally:
        env.close()
    if not isinstance(layout, GridLayout):
        raise ConfigError(
            f"world {config.world_config.name!r} declares no grid, so no heat-map can be drawn: a "
            "world on "
            "a grid of cells declares one with FluentLabels(..., grid=noisybolt.GridLayout("
            "width=, height=, position=fn(env) -> (x, y)))"
        )
    return layout


def _recordings(
    config: TrainConfig,
    setup: BoltSetup,
    model: BaseAlgorithm,
    *,
    episodes: int,
    seed: int,
    deterministic: bool,
) -> list[Any]:
    from noisybolt.viz import policy_from_model, record_episode
    from noisybolt.wrappers import RestrainingBoltWrapper

    # The run's own bolt (its tracking, beliefs and bands), so that the policy sees what
    # it was trained on: under belief tracking the "dfa" entry is the beliefs.
    env = RestrainingBoltWrapper(
        _single_env(config),
        config.spec_objects(),
        setup.detector,
        dfas=setup.dfas,
        settings=replace(config.bolt.settings, belief=setup.belief),
        world_letters=setup.letters,
    )
    policy = policy_from_model(model, deterministic=deterministic)
    limit = world_display(config.world_config.name).gif_steps
    return [record_episode(env, policy, seed=seed + i, max_steps=limit) for i in range(episodes)]


def evaluate_run(
    run_dir: str | os.PathLike[str],
    *,
    episodes: int = 50,
    seed: int = 12345,
    deterministic: bool | None = None,
    gif: str | os.PathLike[str] | None = None,
    heatmap: str | os.PathLike[str] | None = None,
    heatmap_episodes: int = 30,
    overrides: Mapping[str, Any] | None = None,
    trust_code: bool = False,
    estimate: bool = True,
    ground_truth: bool = True,
    labelled: str | os.PathLike[str] | None = None,
    reliability: str | os.PathLike[str] | None = None,
) -> RunEvaluation:
    """Evaluates a saved run (see the module docstring).

    Args:
        run_dir: the run directory written by :func:`noisybolt.runs.training.train`.
        episodes: evaluation episodes K.
        seed: seeds the evaluation world.
        deterministic: greedy actions; None uses the run's ``eval_deterministic``.
        gif: where to save one recorded episode (any world that renders), or None.
        heatmap: where to save the trajectory heat-map (worlds with grid positions: the
            gridworld), or None.
        heatmap_episodes: episodes drawn in the heat-map.
        overrides: settings (schema paths) to change for this evaluation only (e.g.
            ``{"world.kwargs.noise": "regional"}`` to test the policy under other noise).
            A code reference given here (``{"world.name": "mymod:make"}``, the run's own)
            is the user's: it is followed.
        trust_code: follow every code reference the run's config names (a world or
            detector factory path): only for a run whose author you trust.
        estimate: estimate each spec's compliance from the bolt's evidence
            (:mod:`noisybolt.runs.compliance`).
        ground_truth: read the truth: False reports no compliance, goal or success
            judged from it, only the estimate (which it forces on).
        labelled: a labelled dataset file to measure the detector's error model on
            (default: the one its classifier recorded, else images from the world).
        reliability: where to draw the estimate's reliability diagram (PNG), with ground
            truth; None: ``compliance-reliability.png`` in the run directory.

    Raises:
        UntrustedCodeError: the run names code neither ``trust_code`` nor ``overrides``
            vouch for; nothing is imported or written.
    """
    from noisybolt.runs.config import override_paths
    from noisybolt.runs.trust import code_references, loading_run

    run = RunDirectory(run_dir)
    saved = run.read_config()
    given = override_paths(overrides or {})
    # A reference given again as the run has it vouches for it and changes nothing (the
    # evaluation is the run's own, evaluation.json).
    own = {r.path: r.value for r in code_references(saved)}
    overrides = {k: v for k, v in (overrides or {}).items() if not (k in own and own[k] == v)}
    with loading_run(saved, trust_code=trust_code, given=given, source=f"run {run.path}"):
        return _evaluate(
            run,
            saved,
            episodes=episodes,
            seed=seed,
            deterministic=deterministic,
            gif=gif,
            heatmap=heatmap,
            heatmap_episodes=heatmap_episodes,
            overrides=overrides,
            estimate=estimate or not ground_truth,
            ground_truth=ground_truth,
            labelled=labelled,
            reliability=reliability,
        )


def _evaluate(
    run: RunDirectory,
    saved: Mapping[str, Any],
    *,
    episodes: int,
    seed: int,
    deterministic: bool | None,
    gif: str | os.PathLike[str] | None,
    heatmap: str | os.PathLike[str] | None,
    heatmap_episodes: int,
    overrides: Mapping[str, Any] | None,
    estimate: bool = True,
    ground_truth: bool = True,
    labelled: str | os.PathLike[str] | None = None,
    reliability: str | os.PathLike[str] | None = None,
) -> RunEvaluation:
    torch.set_num_threads(1)
    config = TrainConfig.from_dict(saved).override(overrides or {})
    if deterministic is None:
        deterministic = config.evaluation.deterministic
    display = world_display(config.world_config.name)
    layout = None
    if heatmap is not None:
        layout = _grid_layout(config)
    setup = prepare_bolt(config, seed=seed)
    dfas, detector = setup.dfas, setup.detector
    # Loaded onto envs of its own: loading seeds the model's env with the run's seed, which
    # must not touch the evaluation's.
    model = load_run_model(run, config)
    env = make_env(
        config,
        detector,
        training=False,
        n_envs=min(8, episodes),
        seed=seed,
        dfas=dfas,
        letters=setup.letters,
        belief=setup.belief,
    )
    spec_names = [s.name for s in config.spec_objects()]
    traces: list[Any] | None = [] if estimate else None
    result = evaluate_bolted_policy(
        lambda obs: model.predict(obs, deterministic=deterministic)[0],
        env,
        n_episodes=episodes,
        spec_names=spec_names,
        traces=traces,
    )
    files: dict[str, Path] = {}
    record: dict[str, Any] = {"episodes": episodes, "seed": seed, "deterministic": deterministic}
    suffix = ""
    if overrides:
        # Another camera (or other settings) than the run's own: kept beside, not over,
        # the run's evaluation, and named by what changed.
        record["overrides"] = dict(overrides)
        digest = hashlib.sha256(json.dumps(record["overrides"], sort_keys=True).encode())
        suffix = f"-{digest.hexdigest()[:8]}"
    if not ground_truth:
        suffix += "-no-ground-truth"
    compliance = None
    if traces is not None:
        compliance = _estimate(
            config, setup, traces, result, spec_names, seed, labelled, ground_truth
        )
        if ground_truth:
            path = (
                reliability
                if reliability is not None
                else run.file(f"compliance-reliability{suffix}.png")
            )
            files["reliability"] = _draw_reliability(compliance, path, config)
    evaluation = RunEvaluation(
        result=result, compliance=compliance, ground_truth=ground_truth, files=files
    )
    out = run.file(f"evaluation{suffix}.json")
    atomic_write_json(out, {**record, **evaluation.summary()})
    files["evaluation"] = out
    if gif is not None or heatmap is not None:
        from noisybolt.viz import save_episode_gif, trajectory_heatmap

        count = max(1, heatmap_episodes if heatmap is not None else 1)
        recordings = _recordings(
            config, setup, model, episodes=count, seed=seed, deterministic=deterministic
        )
        if gif is not None:
            files["gif"] = save_episode_gif(
                recordings[0],
                gif,
                fps=display.gif_fps,
                action_names=display.action_names,
            )
        if heatmap is not None:
            names = [s.name for s in config.spec_objects()]
            files["heatmap"] = trajectory_heatmap(
                [r.positions.tolist() for r in recordings if r.positions is not None],
                layout=layout,
                path=heatmap,
                title=f"{config.algorithm.name.upper()} under {', '.join(names)}",
            )
    return evaluation


def _estimate(
    config: TrainConfig,
    setup: BoltSetup,
    traces: list[Any],
    result: EvalResult,
    spec_names: list[str],
    seed: int,
    labelled: str | os.PathLike[str] | None,
    ground_truth: bool,
) -> ComplianceReport:
    from noisybolt.runs.compliance import compliance_report, run_error_model

    model, source = run_error_model(config, setup.detector, seed=seed + 1, labelled=labelled)
    truth = None
    if ground_truth:
        truth = np.array([e.compliant for e in result.episodes], dtype=bool)
    return compliance_report(
        dict(zip(spec_names, setup.dfas, strict=True)),
        setup.fluents,
        traces,
        model,
        source=source,
        truth=truth,
        seed=seed,
    )


def _draw_reliability(
    report: ComplianceReport, path: str | os.PathLike[str], config: TrainConfig
) -> Path:
    from noisybolt.viz.calibration import reliability_diagram

    groups = {
        name: (report.estimates[name].per_episode, outcomes)
        for name, outcomes in report.outcomes.items()
    }
    return reliability_diagram(
        groups,
        path,
        title=f"compliance estimates, {config.world_config.name}: per-episode reliability",
    )
