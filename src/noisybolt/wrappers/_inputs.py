"""What a user may hand the bolt wrappers: specs as text, detectors by name."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any, Literal, get_args

from noisybolt.bolt import Spec
from noisybolt.errors import ConfigError, UnknownNameError
from noisybolt.perception.protocols import FluentDetector

__all__ = [
    "DETECTOR_NAMES",
    "DetectorName",
    "coerce_specs",
    "resolve_detector",
]

#: Detectors by name: ``oracle`` reads the truth, ``synthetic`` the truth through seeded
#: Beta noise, ``classifier`` is trained on labelled samples of the env's bolt camera.
#: The detectors built by name, here and in a run's config (``detector.kind``).
DetectorName = Literal["classifier", "oracle", "synthetic"]
DETECTOR_NAMES: tuple[str, ...] = get_args(DetectorName)


def coerce_specs(specs: Spec | str | Sequence[Spec | str]) -> list[Spec]:
    """Specs from :class:`Spec` s or LTLf text (text gets :class:`Spec`'s defaults, the
    paper's rewards: +1 on every accepting step, 0.5 for each low-confidence fluent on the
    edge taken).

    Example:
        >>> [s.name for s in coerce_specs(["G(safe)", Spec("F(goal)", terminal_reward=5.0,
        ...     low_confidence_cost=0.0, name="reach")])]
        ['G(safe)', 'reach']
    """
    items = [specs] if isinstance(specs, (str, Spec)) else list(specs)
    if not items:
        raise ConfigError("the bolt needs at least one spec (an LTLf formula or a Spec)")
    out = []
    for item in items:
        if isinstance(item, Spec):
            out.append(item)
        elif isinstance(item, str):
            out.append(Spec(item))
        else:
            raise ConfigError(f"a spec is an LTLf formula (str) or a Spec, got {item!r}")
    return out


#: The advice of a refusal (or warning) of the images a classifier by name would learn
#: from, in the wrappers' keyword arguments.
_WHAT_TO_DO = (
    "Pass detector='synthetic' or 'oracle' (no classifier), collect more images "
    "(classifier_samples=N), or label a world whose random play shows the fluent both ways"
)
_IF_RARE = "collect more images (classifier_samples=N) or pass detector='synthetic' or 'oracle'"


def resolve_detector(
    detector: FluentDetector | str,
    fluent_names: Sequence[str],
    *,
    seed: int = 0,
    samples: Callable[[], Any] | None = None,
    specs: Sequence[Spec] = (),
) -> FluentDetector:
    """A detector object, or one built by name (see :data:`DetectorName`).

    Args:
        detector: a :class:`FluentDetector`, or ``"oracle"``, ``"synthetic"``,
            ``"classifier"``.
        fluent_names: the world's fluents.
        seed: seeds the synthetic detector's noise or the classifier's training.
        samples: for ``"classifier"``: returns a labelled
            :class:`~noisybolt.perception.dataset.FluentDataset` to train on.
        specs: the bolt's specs; a classifier by name must see each fluent they use both
            true and false in its samples.

    Raises:
        UnknownNameError: an unknown name (listing the known ones).
        ConfigError: an object that is not a detector.
        UnseenFluentError: the samples never show a fluent of ``specs`` true, or never
            false (the classifier could not learn it; no classifier is trained).

    Warns:
        RareFluentWarning: the samples show one such fluent true, or false, in fewer
            than :data:`~noisybolt.perception.dataset.RARE_FLUENT_IMAGES` images.
    """
    from noisybolt.perception.detectors import TRUTH_DETECTORS, truth_detector

    if isinstance(detector, str):
        if detector in TRUTH_DETECTORS:
            return truth_detector(detector, fluent_names, seed=seed)
        if detector == "classifier":
            if samples is None:
                raise ConfigError("a classifier by name needs labelled samples to train on")
            from noisybolt.logic.syntax import atoms, parse_ltlf
            from noisybolt.perception.dataset import LabelCounts, check_fluents_shown
            from noisybolt.perception.training import TrainingConfig, train_classifier

            data = samples()
            check_fluents_shown(
                LabelCounts.of(data),
                sorted({name for spec in specs for name in atoms(parse_ltlf(spec.formula))}),
                source=f"the {len(data):,} images collected from the env's random play (seed "
                f"{seed}) to train the bolt's classifier",
                what_to_do=_WHAT_TO_DO,
                if_rare=_IF_RARE,
            )
            result = train_classifier(data, training=TrainingConfig(seed=seed), progress=False)
            return result.detector
        raise UnknownNameError(
            f"unknown detector {detector!r}; known: {', '.join(DETECTOR_NAMES)}, or pass a "
            "FluentDetector object",
            name=detector,
            known=DETECTOR_NAMES,
        )
    if not isinstance(detector, FluentDetector):
        raise ConfigError(
            f"detector must be one of {list(DETECTOR_NAMES)} or a FluentDetector (fluent_names, "
            f"needs_truth, predict(images, truth=...)), got {detector!r}"
        )
    return detector
