"""``noisybolt reproduce case4``: which corner does the agent detour through, and why?

The paper's case 4: under the exclusive spec (visit the top-right corner once or the
bottom-left corner once, not both), its classifier saw ``bottom_left_corner`` only with
low confidence (p <= 0.87), and the agent "chose to detour via the top-right corner",
which the paper reads as the agent avoiding what the bolt sees poorly. This measures it
against a control:

* ``regional``: the bolt's camera has the regional noise over the bottom-left corner
  (the paper's setting), with a classifier trained on that camera;
* ``control``: the same agent and spec with a clean camera (``noise: none``), where both
  corners are seen clearly.

Both train A2C (the paper's algorithm for this row) over several seeds through the sweep
machinery. Each finished seed is then evaluated on ``episodes`` episodes, and every
episode is classified from **ground truth** (the world's true fluents at every state the
episode reached, the last one included) as having visited the top-right corner only, the
bottom-left corner only, both, or neither; goal and compliance come from ground truth
too. Outputs, in the output directory (also the sweep directory): ``case4.json``,
``case4.md``, ``case4.png`` (the four shares per condition, every seed shown) and one
trajectory heat-map per condition (``heatmap_<condition>.png``, every episode of every
seed). Whatever the shares show is reported: the paper's claim is a hypothesis here, and
with equal rewards for either corner a preference can also come from the start heading
(the agent starts facing east, toward the top-right corner) rather than from the noise,
which is what the control separates.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from noisybolt.errors import ConfigError
from noisybolt.experiments.plotting import plot_shares
from noisybolt.experiments.report import ReportSection, register_section
from noisybolt.experiments.reporting import (
    Block,
    Heading,
    Image,
    Table,
    Text,
    percent,
    render_markdown,
)
from noisybolt.io import read_json

__all__ = [
    "CONDITIONS",
    "CornerVisits",
    "case4_sweep",
    "case4_table",
    "measure_corners",
    "reproduce_case4",
]

#: Condition name -> the bolt camera's noise.
CONDITIONS: dict[str, str] = {"regional": "regional", "control": "none"}
_TOP_RIGHT, _BOTTOM_LEFT = "top_right_corner", "bottom_left_corner"
_CATEGORIES = ("top_right_only", "bottom_left_only", "both", "neither")
#: (visited the top-right corner, visited the bottom-left one) -> the episode's category.
_CATEGORY = {
    (True, False): "top_right_only",
    (False, True): "bottom_left_only",
    (True, True): "both",
    (False, False): "neither",
}


@dataclass(frozen=True)
class CornerVisits:
    """Which corners the evaluation episodes of one run went through (ground truth).

    Attributes:
        episodes: episodes evaluated.
        top_right_only: episodes that visited the top-right corner and not the bottom-left.
        bottom_left_only: the reverse.
        both: episodes that visited both corners.
        neither: episodes that visited neither.
        goal: episodes that reached the goal.
        compliant: episodes whose trace satisfies every spec.
        positions: per episode, the agent's ``(x, y)`` cells (for the heat-map; the cell
            of a truncated episode's very last step is not recorded).
    """

    episodes: int
    top_right_only: int
    bottom_left_only: int
    both: int
    neither: int
    goal: int
    compliant: int
    positions: tuple[tuple[tuple[int, int], ...], ...] = ()

    def shares(self) -> dict[str, float]:
        """Each category's share of the episodes."""
        return {name: getattr(self, name) / self.episodes for name in _CATEGORIES}

    def to_dict(self) -> dict[str, Any]:
        """JSON-able form without the positions."""
        data = asdict(self)
        data.pop("positions")
        data["shares"] = self.shares()
        return data


def measure_corners(
    run_dir: str | os.PathLike[str],
    *,
    episodes: int = 100,
    seed: int = 12345,
    n_envs: int = 8,
    deterministic: bool | None = None,
) -> CornerVisits:
    """Evaluates a saved gridworld run and counts its episodes' corner visits.

    Args:
        run_dir: a run directory (``train`` output).
        episodes: episodes to evaluate.
        seed: seeds the evaluation world (its camera noise).
        n_envs: environments stepped together.
        deterministic: greedy actions; None uses the run's ``eval_deterministic``.

    Raises:
        ConfigError: the run's world has no corner fluents or agent positions.
    """
    import torch

    from noisybolt.runs.config import TrainConfig
    from noisybolt.runs.environments import make_env, prepare_bolt
    from noisybolt.runs.evaluation import EpisodeRecord, evaluate_bolted_policy
    from noisybolt.runs.run_evaluation import load_run_model
    from noisybolt.runs.rundir import RunDirectory

    if episodes < 1:
        raise ConfigError(f"episodes must be >= 1, got {episodes}")
    torch.set_num_threads(1)
    run = RunDirectory(run_dir)
    config = TrainConfig.from_dict(run.read_config())
    if deterministic is None:
        deterministic = config.evaluation.deterministic
    setup = prepare_bolt(config, seed=seed)
    fluents = setup.fluents
    if _TOP_RIGHT not in fluents or _BOTTOM_LEFT not in fluents:
        raise ConfigError(
            f"{config.world_config.name} has no {_TOP_RIGHT}/{_BOTTOM_LEFT} fluents: case 4 is "
            "measured "
            "in the gridworld"
        )
    tr, bl = fluents.index(_TOP_RIGHT), fluents.index(_BOTTOM_LEFT)
    dfas, detector = setup.dfas, setup.detector
    model = load_run_model(run, config)
    n_envs = max(1, min(n_envs, episodes))
    env = make_env(
        config,
        detector,
        training=False,
        n_envs=n_envs,
        seed=seed,
        dfas=dfas,
        letters=setup.letters,
        belief=setup.belief,
    )
    world: Any = env.world
    if not hasattr(world, "agent_state"):
        raise ConfigError(
            f"{config.world_config.name} does not report agent positions (agent_state)"
        )
    size = int(config.world_config.kwargs.get("size", 6))
    visited = np.zeros((n_envs, 2), dtype=bool)  # [n_envs, (top-right, bottom-left)]
    paths: list[list[tuple[int, int]]] = [[] for _ in range(n_envs)]
    ended: dict[int, tuple[str, list[tuple[int, int]]]] = {}
    recorded: list[tuple[str, tuple[tuple[int, int], ...]]] = []

    def on_step(_: Any, dones: np.ndarray) -> None:
        # Every state an episode reached counts, its last one too (read before the
        # reset); the first call comes right after the reset, before any step.
        reached = world.final_true_fluents() if paths[0] else world.true_fluents()
        visited[:] |= reached[:, [tr, bl]].astype(bool)
        x, y, _heading = world.agent_state
        now = world.true_fluents()
        for i in range(n_envs):
            if dones[i]:
                ended[i] = (_CATEGORY[bool(visited[i, 0]), bool(visited[i, 1])], paths[i])
                visited[i] = now[i, [tr, bl]].astype(bool)
                paths[i] = []
            paths[i].append((int(x[i]), int(y[i])))

    def on_episode(i: int, record: EpisodeRecord) -> None:
        category, path = ended[i]
        recorded.append((category, (*path, *([(size - 2, size - 2)] if record.goal else []))))

    result = evaluate_bolted_policy(
        lambda obs: model.predict(obs, deterministic=deterministic)[0],
        env,
        n_episodes=episodes,
        spec_names=[s.name for s in config.spec_objects()],
        on_step=on_step,
        on_episode=on_episode,
    )
    env.close()
    tally = {name: sum(c == name for c, _ in recorded) for name in _CATEGORIES}
    return CornerVisits(
        episodes=result.n_episodes,
        goal=sum(bool(e.goal) for e in result.episodes),
        compliant=sum(all(e.compliant) for e in result.episodes),
        positions=tuple(p for _, p in recorded),
        **tally,
    )


def _world_kwargs(noise: str, start_heading: str) -> dict[str, Any]:
    # The paper's heading is left out of the trials' configs, so runs made before the
    # option existed still resume.
    kwargs: dict[str, Any] = {"noise": noise}
    if start_heading != "east":
        kwargs["start_heading"] = start_heading
    return kwargs


def case4_sweep(
    *,
    seeds: int | Sequence[int] = 3,
    frames: int = 60_000,
    algo: str = "a2c",
    detector: str = "classifier",
    eval_freq: int | None = None,
    eval_episodes: int = 20,
    retries: int = 1,
    start_heading: str = "east",
    low_confidence_cost: float | None = None,
) -> Any:
    """The two-condition sweep (a :class:`~noisybolt.experiments.sweeps.SweepConfig`).

    Rows ``regional`` and ``control`` train the exclusive corner spec
    (``one_corner_once``) with ``algo`` under each camera. Evaluations come every
    ``eval_freq`` frames (default ``frames / 30``, at most 10k: every 2k for 60k frames,
    as Table 1's row). ``start_heading``: the agent's heading at the start; facing
    ``"east"`` (the paper's) the route by the clearly seen top-right corner is one turn
    shorter, so preferring it says nothing about perception; facing ``"south"`` the
    smudged bottom-left corner is on the shorter route. ``low_confidence_cost``: the
    spec's charge for a low-confidence fluent on the edge taken (None: the built-in 0.5).
    """
    from noisybolt.envs.registry import DEFAULT_WORLD
    from noisybolt.experiments.sweeps import SweepConfig

    every = eval_freq if eval_freq is not None else max(1, min(10_000, frames // 30))
    return SweepConfig.from_dict(
        {
            "name": "case4",
            # paths of the run config schema; each row overrides the base's world
            "base": {
                "world.name": DEFAULT_WORLD,  # the paper's gridworld
                "bolt.reward": "paper",  # Algorithm 1 as the paper pays it
                "bolt.specs": [
                    "one_corner_once"
                    if low_confidence_cost is None
                    else {"name": "one_corner_once", "low_confidence_cost": low_confidence_cost}
                ],
                "algorithm.name": algo,
                "detector.kind": detector,
                "frames": frames,
                "evaluation.freq": every,
                "evaluation.episodes": eval_episodes,
                "checkpoint_freq": max(every, frames // 5),
            },
            "rows": [
                {"name": name, "world.kwargs": _world_kwargs(noise, start_heading)}
                for name, noise in CONDITIONS.items()
            ],
            "seeds": seeds if isinstance(seeds, int) else list(seeds),
            "retries": retries,
        }
    )


def _plot(per_seed: dict[str, dict[int, CornerVisits]], path: Path) -> Path:
    shares = {
        condition: [{**v.shares(), "weight": v.episodes} for v in runs.values()]
        for condition, runs in per_seed.items()
    }
    labels = ("top-right only", "bottom-left only", "both", "neither")
    return plot_shares(
        shares,
        dict(zip(_CATEGORIES, labels, strict=True)),
        path,
        title="Case 4: corner the trajectory went through (bars: all seeds; dots: each seed)",
        legend="bolt camera",
    )


def reproduce_case4(
    out_dir: str | os.PathLike[str],
    *,
    seeds: int | Sequence[int] = 3,
    frames: int = 60_000,
    eval_freq: int | None = None,
    eval_episodes: int = 20,
    episodes: int = 100,
    algo: str = "a2c",
    detector: str = "classifier",
    backend: str = "local",
    workers: int | None = None,
    address: str | None = None,
    argv: Sequence[str] | None = None,
    log: Callable[[str], None] = print,
    start_heading: str = "east",
    low_confidence_cost: float | None = None,
) -> dict[str, Any]:
    """Trains both conditions over seeds (or resumes), measures corner visits, writes files.

    Arguments are those of :func:`case4_sweep` and
    :func:`~noisybolt.experiments.sweeps.run_sweep`; ``episodes`` per finished seed are
    evaluated by :func:`measure_corners`.

    Returns:
        What ``case4.json`` holds: per condition and seed the counts and shares, the
        pooled shares per condition, and the files written.
    """
    from noisybolt.experiments.sweeps import run_sweep
    from noisybolt.io import atomic_write_json, atomic_write_text
    from noisybolt.viz import trajectory_heatmap

    sweep = case4_sweep(
        seeds=seeds,
        frames=frames,
        algo=algo,
        detector=detector,
        eval_freq=eval_freq,
        eval_episodes=eval_episodes,
        start_heading=start_heading,
        low_confidence_cost=low_confidence_cost,
    )
    result = run_sweep(
        sweep, out_dir, backend=backend, workers=workers, address=address, argv=argv, log=log
    )
    root = Path(out_dir)
    per_seed: dict[str, dict[int, CornerVisits]] = {name: {} for name in CONDITIONS}
    for record in result.records:
        if record.status != "done":
            continue
        per_seed[record.row][record.seed] = measure_corners(record.run_dir, episodes=episodes)
    files: dict[str, str] = {}
    for condition, runs in per_seed.items():
        paths = [p for v in runs.values() for p in v.positions]
        if paths:
            heatmap = trajectory_heatmap(
                [list(p) for p in paths],
                size=6,
                path=root / f"heatmap_{condition}.png",
                title=f"case 4, {condition} bolt camera",
            )
            files[f"heatmap_{condition}"] = heatmap.name
    if any(per_seed.values()):
        files["plot"] = _plot(per_seed, root / "case4.png").name
    pooled = {}
    for condition, runs in per_seed.items():
        total = sum(v.episodes for v in runs.values())
        pooled[condition] = {
            "seeds": sorted(runs),
            "episodes": total,
            "shares": {
                name: (sum(getattr(v, name) for v in runs.values()) / total if total else None)
                for name in (*_CATEGORIES, "goal", "compliant")
            },
        }
    data = {
        "command": (root / "command.txt").read_text().strip(),
        "spec": "one_corner_once",
        "algo": algo,
        "detector": detector,
        "frames": frames,
        "start_heading": start_heading,
        "low_confidence_cost": low_confidence_cost,
        "episodes_per_seed": episodes,
        "conditions": dict(CONDITIONS),
        "pooled": pooled,
        "per_seed": {
            condition: {str(s): v.to_dict() for s, v in runs.items()}
            for condition, runs in per_seed.items()
        },
        "failed_trials": [r.trial_id for r in result.records if r.status == "failed"],
        "files": files,
    }
    atomic_write_json(root / "case4.json", data)
    atomic_write_text(root / "case4.md", _markdown(data))
    return data


def case4_table(data: Mapping[str, Any]) -> Table:
    """The corner shares per condition, pooled over seeds (from ``case4.json``'s data)."""
    header = (
        "bolt camera", "seeds", "episodes", "top-right only", "bottom-left only", "both",
        "neither", "goal", "compliant",
    )  # fmt: skip
    rows = tuple(
        (
            f"{condition} (noise `{data['conditions'][condition]}`)",
            str(len(pooled["seeds"])),
            str(pooled["episodes"]),
            *[percent(pooled["shares"][k]) for k in (*_CATEGORIES, "goal", "compliant")],
        )
        for condition, pooled in data["pooled"].items()
    )
    return Table(header, rows)


#: What the start heading does to the two routes (the others: see the heat-maps).
_SHORTER_ROUTE = {
    "east": "the route by the top-right corner is one turn shorter.",
    "south": "the route by the bottom-left corner is one turn shorter.",
}


def _markdown(data: dict[str, Any]) -> str:
    from noisybolt.runs.specs import DEFAULT_COST

    cost = data.get("low_confidence_cost")
    cost = DEFAULT_COST if cost is None else cost
    heading = data.get("start_heading", "east")
    per_seed = [
        f"- {condition}, seed {seed}: " + " / ".join(percent(v["shares"][k]) for k in _CATEGORIES)
        for condition, runs in data["per_seed"].items()
        for seed, v in runs.items()
    ]
    blocks: list[Block] = [
        Heading("Case 4: which corner does the agent detour through?"),
        Text(f"Command: `{data['command']}`"),
        Text(
            f"Spec `one_corner_once` (low-confidence cost {cost}), {data['algo'].upper()}, "
            f"detector `{data['detector']}`, {data['frames']:,} frames per seed, "
            f"{data['episodes_per_seed']} evaluation episodes per seed; corners, goal and "
            "compliance from ground truth. The agent starts top-left facing "
            f"{heading}: {_SHORTER_ROUTE.get(heading, 'see the heat-maps for the routes.')}"
        ),
        case4_table(data),
        Text("Per seed (top-right only / bottom-left only / both / neither):"),
        Text("\n".join(per_seed)),
    ]
    if data["failed_trials"]:
        blocks.append(Text(f"Failed trials: {', '.join(data['failed_trials'])}"))
    blocks.append(Image("case4.png", "corner shares"))
    blocks += [Image(v, k) for k, v in data["files"].items() if k.startswith("heatmap")]
    return render_markdown(blocks)


def _report_section(root: Path) -> tuple[list[Block], dict[str, float | None]]:
    """The case-4 section of a sweep report."""
    data = read_json(root / "case4.json", kind=dict)
    blocks: list[Block] = [
        Heading("Case 4: corner preference, regional noise vs control", 2),
        Text(
            "Share of evaluation episodes whose trajectory went through each corner (ground "
            "truth), pooled over seeds; `case4.md`, `case4.json`."
        ),
        case4_table(data),
    ]
    blocks += [
        Image(name, name) for name in data.get("files", {}).values() if (root / name).exists()
    ]
    return blocks, {}


register_section(ReportSection("case4", "case4.json", _report_section))
