"""The same agent trained without and with a restraining bolt, compared (``noisybolt demo``).

:func:`compare_bolted_unbolted` trains one agent on the world's reward alone and the same
agent (algorithm, hyperparameters, seed, frames, observations) with the bolt's rewards,
both through :func:`noisybolt.runs.training.train` (``bolted=False`` for the first).
Both are then evaluated in the *bolted* world, from the same episode seeds: compliance
from the world's true fluents, and the bolt return as the bolt pays it (for the unbolted
agent: what it would have paid). It draws where each goes, side by side
(:func:`~noisybolt.viz.compare_heatmaps`), and one episode of the bolted
agent as a GIF. Gridworld only: the heat-maps need grid positions.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

from noisybolt.bolt import CostMode, Thresholds, Tracking
from noisybolt.envs.gridworld import GridAction, GridworldEnv
from noisybolt.errors import ConfigError
from noisybolt.io import atomic_write_json
from noisybolt.runs.evaluation import EpisodeRecord, EvalResult, summarise
from noisybolt.wrappers import RestrainingBoltWrapper

if TYPE_CHECKING:  # training imports torch and Stable-Baselines3: loaded when first used
    from noisybolt.runs.config import TrainConfig
    from noisybolt.runs.environments import BoltSetup

__all__ = [
    "AgentOutcome",
    "BoltComparison",
    "compare_bolted_unbolted",
    "format_comparison",
    "spec_text",
    "verdict",
]

#: Seeds the evaluation episodes (apart from the training seeds).
EVAL_SEED = 12_345


@dataclass(frozen=True)
class AgentOutcome:
    """One of the two agents compared: where it was trained and how it did.

    Attributes:
        bolted: whether it learnt from the bolt's rewards.
        run_dir: its run directory (see :mod:`noisybolt.runs.training`).
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
class BoltComparison:
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
    spec: str,
    algo: str,
    frames: int,
    detector: str = "classifier",
    noise: str = "regional",
    episodes: int = 50,
    seed: int = 0,
    out: str | Path,
    progress: bool = True,
    log: Callable[[str], None] = print,
) -> BoltComparison:
    """Trains the same agent without and with the bolt, evaluates both, draws them.

    Both agents see the same observations (their image and the DFA states the bolt
    tracks) and train for the same frames from the same seed; only the bolted one is
    paid the bolt's rewards. Both are then evaluated in the bolted world: ``episodes``
    episodes each, from the same seeds, compliance from the world's true fluents, bolt
    return as the bolt pays it. Writes ``OUT/unbolted/`` and ``OUT/bolted/`` (run
    directories), ``OUT/comparison.png`` (the two heat-maps), ``OUT/bolted.gif`` (the
    bolted agent's first evaluation episode) and ``OUT/comparison.json``.

    Args:
        spec: a built-in spec name or an LTLf formula over the gridworld's fluents (one
            spec, not a group).
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
        ConfigError: ``out`` already holds a demo, fewer than one episode, a group of
            specs, or a bad setting of the training config (all checked before anything
            is written).
        UnknownFluentError: the spec names a fluent the gridworld does not have.
    """
    import torch

    from noisybolt.runs.config import DetectorConfig, TrainConfig
    from noisybolt.runs.environments import prepare_bolt
    from noisybolt.runs.run_evaluation import load_run_model
    from noisybolt.runs.rundir import RunDirectory
    from noisybolt.runs.training import train
    from noisybolt.viz import compare_heatmaps, save_episode_gif

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
    specs = bolted_config.spec_objects()
    if len(specs) != 1:
        raise ConfigError(
            f"{spec!r} names {len(specs)} specs; the comparison is drawn for one spec"
        )
    spec_obj = specs[0]
    # The detector first (a classifier is trained on the fly and cached the first time),
    # so that the two trainings load the same one and their times compare.
    log = _each_warning_once(log)  # the bolt is set up three times (here, each training)
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
            deterministic=bolted_config.evaluation.deterministic,
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
        size=int(bolted_config.world_config.kwargs.get("size", 6)),
        path=out / "comparison.png",
        title=f"{algo.upper()} on the gridworld, without and with a restraining bolt\n"
        + _wrap(f"spec {spec_text(spec_obj.name, spec_obj.formula)}", 90),
    )
    files["gif"] = save_episode_gif(
        recordings[True][0], out / "bolted.gif", action_names=[a.name.lower() for a in GridAction]
    )
    comparison = BoltComparison(
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
    model: Any, config: TrainConfig, setup: BoltSetup, *, episodes: int, deterministic: bool
) -> list[Any]:
    """``episodes`` recorded episodes of ``model`` in the bolted gridworld."""
    from noisybolt.viz import policy_from_model, record_episode

    env = RestrainingBoltWrapper(
        GridworldEnv(**config.world_settings),
        config.spec_objects(),
        setup.detector,
        dfas=setup.dfas,
        thresholds=Thresholds(**config.bolt.thresholds),
        cost_mode=cast(CostMode, config.bolt.cost_mode),  # checked by TrainConfig
        tracking=cast(Tracking, config.bolt.tracking),  # checked by TrainConfig
        belief=setup.belief,
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


def spec_text(name: str, formula: str) -> str:
    """``name = formula``, or the formula alone where it is its own name."""
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


def format_comparison(comparison: BoltComparison) -> str:
    """The two agents side by side, as ``noisybolt demo`` prints them.

    Example:
        >>> from noisybolt.runs.evaluation import EpisodeRecord, summarise
        >>> def agent(bolted, length, complied, bolt_return):
        ...     record = EpisodeRecord(101.5 - 1.5 * length, bolt_return, length, True,
        ...                            (complied,))
        ...     return AgentOutcome(bolted=bolted, run_dir=Path("."), frames=40_000,
        ...                         seconds=20.0, evaluation=summarise([record], ["avoid"]),
        ...                         positions=())
        >>> print(format_comparison(BoltComparison(
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


def verdict(comparison: BoltComparison) -> str:
    """One sentence on what the bolt changed (or why it changed nothing)."""
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
        "the bolted agent has not learnt the spec yet (train it for more frames)."
    )


def _each_warning_once(log: Callable[[str], None]) -> Callable[[str], None]:
    """``log``, passing each ``warning:`` line on the first time only."""
    seen: set[str] = set()

    def once(line: str) -> None:
        if line.startswith("warning:"):
            if line in seen:
                return
            seen.add(line)
        log(line)

    return once
