"""What seeded random play of a run's world tells its bolt before training: the base
rates belief tracking reads (:func:`belief_from_play`), fluents the world shows for too
few frames (:func:`warn_of_brief_runs`) or never (:func:`warn_of_unseen_fluents`), all
from one seeded :func:`random_play` of the world as the run configures it."""

from __future__ import annotations

import warnings
from collections.abc import Iterator, Sequence
from dataclasses import replace
from typing import Any

import numpy as np

from noisybolt.bolt import BeliefSettings
from noisybolt.bolt.belief import frames_to_believe
from noisybolt.envs import make_world
from noisybolt.errors import BriefFluentWarning, UnseenFluentWarning
from noisybolt.perception.protocols import (
    BOLT_IMAGE_KEY,
    FINAL_INFO_KEY,
    TRUE_FLUENTS_KEY,
    FluentDetector,
)
from noisybolt.runs.config import TrainConfig

__all__ = [
    "BASE_RATE_PLAY",
    "RANDOM_PLAY",
    "belief_from_play",
    "random_play",
    "random_play_letters",
    "true_runs",
    "warn_of_brief_runs",
    "warn_of_unseen_fluents",
]


#: Random play that the base-rate estimate reads: envs x steps frames.
BASE_RATE_PLAY = (16, 128)


def belief_from_play(
    config: TrainConfig,
    detector: FluentDetector,
    *,
    n_envs: int = BASE_RATE_PLAY[0],
    steps: int = BASE_RATE_PLAY[1],
    monotone: Sequence[str] = (),
    spec_fluents: Sequence[str] = (),
) -> BeliefSettings:
    """``config.belief_settings`` with base rates estimated from seeded random play, and
    the fluents the world declares ``monotone`` (its ``monotone_fluents``: true once, true
    for the rest of the episode, as Breakout's bricks gone).

    The detector's probabilities on ``n_envs * steps`` frames of the bolt's camera in
    random play (seeded by the run's seed: training and evaluation estimate the same) go
    through the EM of Saerens et al. (:func:`~noisybolt.perception.base_rates.
    belief_settings_from_play`): no ground truth is read unless the detector itself reads
    it (the oracle and the synthetic detector). A trained classifier's probabilities carry
    the label frequencies of its training images (:attr:`ClassifierDetector.
    training_prior`); the other detectors' are taken as balanced (0.5).

    Random play is not the trained agent's play: a fluent random play rarely shows (a
    far corner) gets a small rate, floored at ``min_base_rate`` (0.01) so that the bolt
    still believes a trained agent that shows it clearly.

    Warns (:class:`~noisybolt.errors.BriefFluentWarning`) where one of ``spec_fluents`` is
    true in random play for fewer frames in a row than the resulting settings need to
    believe it even from a perfect detector (:func:`~noisybolt.bolt.belief.
    frames_to_believe`): a check of the world against the model, reading the world's
    labels as the classifier checks do; the estimate itself reads none.
    """
    from noisybolt.perception.base_rates import belief_settings_from_play

    settings = config.belief_settings
    assert settings is not None, "belief_from_play is for belief tracking"
    frames = []
    # Per env, its frames in time order (each ended episode's last view included) and
    # whether each is an episode's last.
    sequences: list[list[np.ndarray]] = [[] for _ in range(n_envs)]
    last: list[list[bool]] = [[] for _ in range(n_envs)]
    for info, ended in random_play(config, seed=config.seed + 1, n_envs=n_envs, steps=steps):
        rows, views = _final_views(info, ended, (BOLT_IMAGE_KEY, TRUE_FLUENTS_KEY))
        viewed = set(rows.tolist())
        if views:  # the states the ended episodes reached
            final_images, final_truth = views[BOLT_IMAGE_KEY], views[TRUE_FLUENTS_KEY]
            seen = final_truth if detector.needs_truth else None
            frames.append(detector.predict(final_images, truth=seen))
            for row, row_truth in zip(rows, final_truth, strict=True):
                sequences[row].append(row_truth)
                last[row].append(True)
        truth = np.asarray(info[TRUE_FLUENTS_KEY], dtype=bool)
        seen_truth = truth if detector.needs_truth else None
        frames.append(detector.predict(np.asarray(info[BOLT_IMAGE_KEY]), truth=seen_truth))
        for row in range(n_envs):
            if ended[row] and row not in viewed:  # no last view given: it ended here
                last[row][-1] = True
            sequences[row].append(truth[row])
            last[row].append(False)
    # A trained classifier's label frequencies; a user's detector may state its own.
    prior = getattr(detector, "training_prior", None)
    estimated = belief_settings_from_play(
        [np.concatenate(frames)],
        training_prior=0.5 if prior is None else prior,
        confidence=settings.confidence,
        min_dwell=settings.min_dwell,
        monotone=tuple(settings.monotone) or tuple(monotone),
    )
    fluents = tuple(detector.fluent_names)
    for fluent in spec_fluents:
        column = fluents.index(fluent)
        lengths, at_end = [], []
        for sequence, ends in zip(sequences, last, strict=True):
            run_lengths, run_ends = true_runs(
                np.array([t[column] for t in sequence], dtype=bool), np.array(ends, dtype=bool)
            )
            lengths += run_lengths.tolist()
            at_end += run_ends.tolist()
        warn_of_brief_runs(
            estimated, fluents, fluent, np.array(lengths, dtype=np.int64), np.array(at_end)
        )
    return estimated


def _final_views(
    info: dict[str, Any], ended: np.ndarray, keys: tuple[str, ...]
) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """The rows that ended whose last views ``info["final_info"]`` gives under every one
    of ``keys``, and those views (true fluents as bool); no rows and ``{}`` where no
    episode ended or the world gives none (the step's own view is then its last)."""
    final = info.get(FINAL_INFO_KEY)
    if not ended.any() or not isinstance(final, dict) or any(k not in final for k in keys):
        return np.zeros(0, dtype=np.intp), {}
    rows = ended.copy()
    for key in keys:
        mask = final.get(f"_{key}")
        if mask is not None:
            rows &= np.asarray(mask, dtype=bool)
    index = np.flatnonzero(rows)
    if index.size == 0:
        return index, {}
    views = {key: np.asarray(final[key])[index] for key in keys}
    if TRUE_FLUENTS_KEY in views:
        views[TRUE_FLUENTS_KEY] = views[TRUE_FLUENTS_KEY].astype(bool)
    return index, views


def true_runs(truth: np.ndarray, last: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The runs of True in one env's frames ``truth`` (bool ``[frames]``, in time order;
    ``last`` marks each episode's last frame, after which the next episode starts).

    A run is counted when it is whole within the frames: it begins at an episode's first
    frame or after a False one, and ends before a False frame or at an episode's end (a
    run still going when the frames stop is not counted).

    Returns:
        ``(lengths, at_end)``: int64 ``[n_runs]`` lengths, and bool ``[n_runs]`` whether
        each run lasted to its episode's last frame.

    Example:
        >>> true_runs(np.array([1, 0, 1, 1, 0, 1, 1], dtype=bool),
        ...           np.array([0, 0, 0, 1, 0, 0, 0], dtype=bool))
        (array([1, 2]), array([False,  True]))
    """
    truth = np.asarray(truth, dtype=bool)
    last = np.zeros(len(truth), dtype=bool) if last is None else np.asarray(last, dtype=bool)
    lengths: list[int] = []
    at_end: list[bool] = []
    run = 0
    for t, on in enumerate(truth):
        if on:
            run += 1
            if last[t]:
                lengths.append(run)
                at_end.append(True)
                run = 0
        else:
            if run:
                lengths.append(run)
                at_end.append(False)
            run = 0
    return np.array(lengths, dtype=np.int64), np.array(at_end, dtype=bool)


def warn_of_brief_runs(
    settings: BeliefSettings,
    fluents: Sequence[str],
    fluent: str,
    runs: np.ndarray,
    at_end: np.ndarray | None = None,
) -> None:
    """Warns (:class:`BriefFluentWarning`) if some of ``runs`` (lengths of ``fluent``'s
    true runs in play; ``at_end``: whether each lasted to its episode's end, where no
    later frame can refute it) are shorter than belief tracking under ``settings`` needs."""
    if len(runs) == 0:
        return
    at_end = np.zeros(len(runs), dtype=bool) if at_end is None else np.asarray(at_end, bool)
    needed, single = frames_to_believe(settings, fluents, fluent)
    needed_at_end, _ = frames_to_believe(settings, fluents, fluent, after=0)

    def short(need: int | None, where: np.ndarray) -> np.ndarray:
        return where & (runs < need) if need is not None else where

    brief_mask = short(needed, ~at_end) | short(needed_at_end, at_end)
    brief = runs[brief_mask]
    if len(brief) == 0:
        return
    if needed is None:
        need = f"does not believe {fluent} within 8 frames in a row"
    else:
        need = f"believes {fluent} only after {needed} frames of it in a row"
    ending = int((brief_mask & at_end).sum())
    ends = f", {ending} of them as the episode ended" if ending else ""
    shortest = int(brief.min())
    fix_with_one, _ = frames_to_believe(replace(settings, min_dwell=1), fluents, fluent)
    if settings.min_dwell > 1 and fix_with_one is not None and fix_with_one <= shortest:
        advice = (
            "with --min-dwell 1 (BeliefSettings(min_dwell=1)) a perfect detector's "
            f"{fix_with_one} frame(s) would be, a noisy detector's may still not be; "
            "threshold tracking (--tracking threshold) believes a single frame"
        )
    else:
        advice = (
            "threshold tracking (--tracking threshold) credits them; belief tracking "
            "needs the world to show it longer"
        )
    warnings.warn(
        BriefFluentWarning(
            f"belief tracking: in random play, {fluent} was true for fewer frames in a row "
            f"than the bolt needs in {len(brief)} of its {len(runs)} visits (the shortest "
            f"{shortest}{ends}); under these settings (base rate "
            f"{_rate_of(settings, fluents, fluent)}, min_dwell {settings.min_dwell}, "
            f"confidence {settings.confidence:g}) the bolt {need}, even from a perfect "
            f"detector (one frame: P = {single:g}), so a spec met only on such a visit is "
            f"never credited; {advice}"
        ),
        stacklevel=2,
    )


def _rate_of(settings: BeliefSettings, fluents: Sequence[str], fluent: str) -> str:
    return f"{settings.resolve(fluents).rates[list(fluents).index(fluent)]:.3f}"


#: Random play that the letters a world shows are read from: envs x steps frames.
RANDOM_PLAY = (16, 128)


def warn_of_unseen_fluents(
    letters: np.ndarray,
    fluents: Sequence[str],
    spec_fluents: Sequence[str],
    *,
    play: tuple[int, int],
) -> None:
    """Warns (:class:`~noisybolt.errors.UnseenFluentWarning`) of each fluent of
    ``spec_fluents`` that is true in none, or in all, of ``letters`` (bool ``[n,
    n_fluents]``, the assignments random play showed: ``play`` = (games, steps each), so
    only the first steps of a long episode): a fluent function that never holds (a typo,
    a state never reached) leaves a spec the bolt can never credit, which training would
    only show as 0 % compliance; one that holds only late in an episode is reported too,
    and the message says how far the play went.

    Example:
        >>> import warnings
        >>> seen = np.array([[True, False], [True, False]])
        >>> with warnings.catch_warnings(record=True) as caught:
        ...     warnings.simplefilter("always")
        ...     warn_of_unseen_fluents(seen, ["a", "won"], ["won"], play=(16, 128))
        >>> print(caught[0].message)  # doctest: +ELLIPSIS
        the specs' fluent won was never true in 16 games of random play, in the first 128 ...
    """
    games, steps = play
    never: dict[str, list[str]] = {"true": [], "false": []}
    for fluent in spec_fluents:
        column = letters[:, list(fluents).index(fluent)]
        if column.all() == column.any():
            never["false" if column.any() else "true"].append(fluent)
    for value, names in never.items():
        if not names:
            continue
        other = "false" if value == "true" else "true"
        warnings.warn(
            UnseenFluentWarning(
                f"the specs' fluent{'s' if len(names) > 1 else ''} {', '.join(names)} "
                f"{'were' if len(names) > 1 else 'was'} never {value} in {games} games of "
                f"random play, in the first {steps} steps of each ({games * steps:,} "
                f"steps): a spec that needs {'them' if len(names) > 1 else 'it'} {value} "
                f"is met only if a trained agent makes it so (or only later in an episode), "
                f"and can never be if a fluent's function is always {other} (check it in "
                "the world's definition)"
            ),
            stacklevel=2,
        )


def random_play_letters(
    config: TrainConfig, *, n_envs: int = RANDOM_PLAY[0], steps: int = RANDOM_PLAY[1]
) -> np.ndarray:
    """The distinct true-fluent assignments a world shows in ``n_envs * steps`` random
    steps (seeded by the run's seed, so training and evaluation see the same), the states
    ended episodes reached included (a goal true only as its episode ends)."""
    seen = []
    for info, ended in random_play(config, seed=config.seed, n_envs=n_envs, steps=steps):
        seen.append(np.asarray(info[TRUE_FLUENTS_KEY], dtype=bool))
        _, views = _final_views(info, ended, (TRUE_FLUENTS_KEY,))
        if views:
            seen.append(views[TRUE_FLUENTS_KEY])
    return np.unique(np.concatenate(seen), axis=0)


def random_play(
    config: TrainConfig, *, seed: int, n_envs: int, steps: int
) -> Iterator[tuple[dict[str, Any], np.ndarray]]:
    """The batched ``info`` of the world's reset and of ``steps`` seeded random steps,
    each with the rows whose episodes the step ended (bool ``[n_envs]``), each to be read
    before the next is asked for (a deferred camera value is valid only until the world
    moves on); the world is closed afterwards."""
    world: Any = make_world(
        config.world_config.name, num_envs=n_envs, seed=seed, **config.world_settings
    )
    try:
        yield world.reset(seed=seed)[1], np.zeros(n_envs, dtype=bool)
        world.action_space.seed(seed)
        for _ in range(steps):
            _, _, terminated, truncated, info = world.step(world.action_space.sample())
            yield info, np.logical_or(np.asarray(terminated), np.asarray(truncated))
    finally:
        world.close()
