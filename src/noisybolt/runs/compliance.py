"""A run's compliance estimated from the bolt's evidence, and checked against the truth.

``noisybolt evaluate`` records every episode's detector outputs and hands them, with the
run's DFAs and its detector's error model, to
:func:`~noisybolt.bolt.compliance.estimate_compliance`. Where ground truth is at hand
(a simulated world) the estimate is set beside it with its calibration: the per-episode
expected calibration error and a reliability diagram. With ``--no-ground-truth`` the
estimate is all that is reported: it is never presented as the truth.

The detector's error model comes from, in order: labelled images the caller gives (a
dataset saved by ``noisybolt classifiers collect``), the measurements a classifier
recorded on its held-out images when it was trained, or fresh labelled images collected
from the world (as the classifier's own were), which is how a classifier file saved
before error models were recorded, or a user's detector, gets one. How successive
frames' bands follow each other (a smudge that reads "maybe" keeps reading it while the
agent stays under it, whatever the truth) is counted on labelled episodes of the world's
seeded random play: the simulator labels them as it labelled the classifier's images;
the evaluation's own episodes are never read for it.

Example:
    >>> from noisybolt.bolt.compliance import ErrorModel
    >>> from noisybolt.logic import DFA
    >>> f_x = DFA.from_function(["x"], n_states=2, initial_state=0,
    ...     accepting=[False, True], delta=lambda q, m: 1 if q == 1 or m & 1 else 0)
    >>> perfect = ErrorModel(fluent_names=("x",), edges=(0.5,),
    ...                      counts=np.array([[[500.0, 0.0], [0.0, 500.0]]]))
    >>> traces = [np.array([[0.0], [1.0], [1.0]]), np.array([[0.0], [0.0], [0.0]])]
    >>> report = compliance_report({"ever_x": f_x}, ("x",), traces, perfect,
    ...                            source="by hand", truth=np.array([[True], [False]]))
    >>> print(report.format_table())  # doctest: +NORMALIZE_WHITESPACE
    spec                 estimated   90% interval (policy)   (these episodes)    true
    ever_x                   50.0%   [5.4%, 94.9%]           [50.0%, 50.0%]     50.0%
    per-episode ECE 0.000 over 2 episodes
    error model: by hand
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from noisybolt.bolt.compliance import ComplianceEstimate, ErrorModel, estimate_compliance
from noisybolt.logic.dfa import DFA
from noisybolt.perception.metrics import expected_calibration_error

__all__ = [
    "LABELLED_EPISODES",
    "LABELLED_SAMPLES",
    "ComplianceReport",
    "compliance_report",
    "run_error_model",
]

#: Labelled images collected from the world to measure a detector that recorded no error
#: model (as many as a classifier's held-out check uses).
LABELLED_SAMPLES = 2000
#: Labelled episodes of random play that successive frames' confusion is counted on.
LABELLED_EPISODES = 100


@dataclass(frozen=True)
class ComplianceReport:
    """Each spec's estimated compliance; beside it, where known, the truth.

    Attributes:
        estimates: spec name -> its :class:`~noisybolt.bolt.compliance.ComplianceEstimate`.
        source: where the detector's error model came from.
        truth: spec name -> the share of the same episodes that truly complied; empty
            without ground truth.
        outcomes: spec name -> bool ``[n_episodes]``, each episode's true compliance;
            empty without ground truth.
    """

    estimates: dict[str, ComplianceEstimate]
    source: str
    truth: dict[str, float] = field(default_factory=dict)
    outcomes: dict[str, np.ndarray] = field(default_factory=dict, repr=False)

    @property
    def ece(self) -> float | None:
        """The per-episode expected calibration error over every spec's episodes (10
        bins); None without ground truth."""
        if not self.outcomes:
            return None
        probs = np.concatenate([self.estimates[n].per_episode for n in self.outcomes])
        truth = np.concatenate(list(self.outcomes.values()))
        return expected_calibration_error(probs, truth)

    def to_dict(self) -> dict[str, Any]:
        """A JSON-able dict (what ``evaluation.json`` keeps under ``compliance_estimate``)."""
        out: dict[str, Any] = {
            "error_model": self.source,
            "specs": {name: e.to_dict() for name, e in self.estimates.items()},
        }
        if self.truth:
            out["truth"] = dict(self.truth)
            out["per_episode_ece"] = self.ece
        return out

    def format_table(self) -> str:
        """A fixed-width text table: per spec, the estimate, its intervals and the truth."""
        head = (
            f"{'spec':<20} {'estimated':>9}   {'90% interval (policy)':<22}  "
            f"{'(these episodes)':<16}"
        )
        if self.truth:
            head += f"  {'true':>6}"
        lines = [head]
        for name, e in self.estimates.items():
            row = (
                f"{name:<20} {e.rate:>9.1%}   {f'[{e.low:.1%}, {e.high:.1%}]':<22}  "
                f"{f'[{e.episodes_low:.1%}, {e.episodes_high:.1%}]':<16}"
            )
            if self.truth:
                row += f"  {self.truth[name]:>6.1%}"
            lines.append(row)
        n = next(iter(self.estimates.values())).n_episodes if self.estimates else 0
        if self.truth:
            lines.append(f"per-episode ECE {self.ece:.3f} over {n} episodes")
        else:
            lines.append(
                f"estimated from the bolt's evidence over {n} episodes (no ground truth read)"
            )
        lines.append(f"error model: {self.source}")
        return "\n".join(lines)


def compliance_report(
    dfas: Mapping[str, DFA],
    fluents: Sequence[str],
    traces: Sequence[np.ndarray],
    error_model: ErrorModel,
    *,
    source: str,
    truth: np.ndarray | None = None,
    seed: int = 0,
) -> ComplianceReport:
    """Estimates every spec's compliance over ``traces`` and, given ``truth`` (bool
    ``[n_episodes, n_specs]``, specs in the order of ``dfas``), sets the truth beside it.

    Raises:
        UnknownFluentError: a spec's fluent the detector or its error model lacks.
    """
    estimates = estimate_compliance(dfas, fluents, traces, error_model, seed=seed)
    if truth is None:
        return ComplianceReport(estimates=estimates, source=source)
    truth = np.asarray(truth, dtype=bool).reshape(len(traces), len(dfas))
    outcomes = {name: truth[:, i] for i, name in enumerate(dfas)}
    return ComplianceReport(
        estimates=estimates,
        source=source,
        truth={name: float(o.mean()) for name, o in outcomes.items()},
        outcomes=outcomes,
    )


def run_error_model(
    config: Any,
    detector: Any,
    *,
    seed: int,
    labelled: str | os.PathLike[str] | None = None,
    samples: int = LABELLED_SAMPLES,
    episodes: int = LABELLED_EPISODES,
) -> tuple[ErrorModel, str]:
    """The run's detector's error model and a line on where it came from (see the
    module docstring).

    Besides the confusion of single frames (from ``labelled``, else recorded with the
    classifier, else ``samples`` images collected from the world), how successive frames'
    bands follow each other is counted on ``episodes`` labelled episodes of the world's
    seeded random play (none: frames are taken as independent given the truth, which
    over-counts a detector's repeated errors).

    Args:
        config: the run's resolved :class:`~noisybolt.runs.config.TrainConfig`.
        detector: the run's detector.
        seed: seeds the collection of labelled images and episodes.
        labelled: a labelled dataset file to measure the detector on.
        samples: labelled images to collect where needed.
        episodes: labelled episodes of random play to count successive frames on.

    Raises:
        UnknownFluentError: the dataset lacks labels of some of the detector's fluents.
        IncompatibleError: the dataset comes from another camera.
    """
    from noisybolt.envs import make_world
    from noisybolt.perception.dataset import collect_samples, load_dataset
    from noisybolt.perception.error_model import (
        error_model_of,
        record_labelled_play,
        recorded_error_model,
    )

    def world() -> Any:
        return make_world(config.world_config.name, num_envs=16, seed=seed, **config.world_settings)

    sequences: list[Any] = []
    if episodes > 0:
        player = world()
        try:
            sequences = record_labelled_play(
                player, detector, episodes=episodes, seed=seed, max_frames=100 * episodes
            )
        finally:
            _close(player)
    plays = f"; successive frames from {len(sequences)} labelled episodes of random play"
    if labelled is not None:
        data: Any = load_dataset(Path(labelled))
        source = f"measured on {len(data.labels):,} labelled images from {labelled}"
    elif recorded_error_model(detector) is not None:
        data = None
        total = int(recorded_error_model(detector).counts[0].sum())  # type: ignore[union-attr]
        source = f"recorded with the classifier ({total:,} held-out images)"
    else:
        collector = world()
        try:
            data = collect_samples(collector, num_samples=samples, seed=seed, progress=False)
        finally:
            _close(collector)
        source = (
            f"measured on {len(data.labels):,} labelled images collected from the world "
            f"(seed {seed}; the detector recorded none)"
        )
    model = error_model_of(detector, labelled=data, sequences=sequences)
    return model, source + (plays if sequences else "")


def _close(world: Any) -> None:
    close = getattr(world, "close", None)
    if callable(close):
        close()
