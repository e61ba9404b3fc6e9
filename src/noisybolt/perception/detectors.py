"""Fluent detectors that read the ground truth: the oracle and a synthetic noisy one.

Both set ``needs_truth`` and get the true fluents through ``predict(..., truth=...)``; the
images are only counted. They make experiments fast and controlled: the oracle is perfect
perception; the :class:`SyntheticDetector` passes the truth through a seeded noise model of
probabilities, one Beta distribution for positives and one for negatives per fluent, so a
fluent can be made mostly low-band (seen only dimly, like the paper's
``bottom_left_corner``) while the others stay crisp. It can also be *calibrated* to a
trained classifier by :meth:`SyntheticDetector.fit`, matching the mean and variance of the
classifier's probabilities on positives and on negatives.

The trained image classifier is :class:`noisybolt.perception.classifier.ClassifierDetector`.

Example:
    >>> import numpy as np
    >>> truth = np.array([[True, False], [False, True]])
    >>> OracleDetector(("t", "b")).predict(np.zeros((2, 1, 1, 3), np.uint8), truth=truth)
    array([[1., 0.],
           [0., 1.]], dtype=float32)
    >>> dim = SyntheticDetector(("t", "b"), seed=0,
    ...                         fluents={"b": BetaNoise.low_confidence()})
    >>> probs = dim.predict(np.zeros((2, 1, 1, 3), np.uint8), truth=truth)
    >>> probs.shape, probs.dtype
    ((2, 2), dtype('float32'))
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from noisybolt.errors import ConfigError, DetectorOutputError, IncompatibleError, UnknownFluentError

__all__ = [
    "TRUTH_DETECTORS",
    "BetaNoise",
    "FluentsByName",
    "OracleDetector",
    "SyntheticDetector",
    "match_fluents",
    "reads_images",
    "reseed_detector",
    "truth_detector",
]


def _check_truth(
    names: tuple[str, ...], images: np.ndarray | None, truth: np.ndarray | None
) -> np.ndarray:
    if truth is None:
        raise ValueError("this detector reads the ground truth: pass truth=world.true_fluents()")
    truth = np.asarray(truth)
    if truth.ndim != 2 or truth.shape[1] != len(names):
        raise ValueError(f"truth must be [n, {len(names)}] for fluents {names}, got {truth.shape}")
    if truth.dtype != np.bool_:
        if not np.isin(truth, (0, 1)).all():
            raise ValueError("truth must be booleans or 0/1")
        truth = truth.astype(bool)
    if images is not None and len(images) != truth.shape[0]:
        raise ValueError(f"{len(images)} images but {truth.shape[0]} rows of truth")
    return truth


def reads_images(detector: Any) -> bool:
    """Whether ``detector.predict`` reads its images' pixels: its ``reads_images``, True
    where it has none. A detector that says False (the oracle, the synthetic detector) is
    handed images that render only if read (:class:`~noisybolt.envs.deferred.DeferredArray`),
    so that a world's camera costs nothing under it."""
    return bool(getattr(detector, "reads_images", True))


def _check_names(fluent_names: Sequence[str]) -> tuple[str, ...]:
    names = tuple(fluent_names)
    if not names or len(set(names)) != len(names):
        raise ConfigError(f"fluent names must be non-empty and distinct: {names}")
    return names


class FluentsByName:
    """A detector's columns matched to a world's fluents by name (see :func:`match_fluents`).

    Its ``fluent_names`` are the world's; ``predict`` asks the detector (handing it the
    truth in the detector's own column order, if it reads the truth) and returns the
    world's columns, in the world's order. ``training_prior`` follows the detector's.
    """

    def __init__(self, detector: Any, fluent_names: Sequence[str]) -> None:
        self.detector = detector
        own = tuple(detector.fluent_names)
        self._own = own
        self._names = tuple(fluent_names)
        self._columns = np.array([own.index(f) for f in self._names], dtype=np.int64)
        # Where the detector's own fluents sit among the world's (reading the truth).
        self._truth_columns = np.array(
            [self._names.index(f) if f in self._names else -1 for f in own], dtype=np.int64
        )

    @property
    def fluent_names(self) -> tuple[str, ...]:
        """The world's fluents, in the world's column order."""
        return self._names

    @property
    def needs_truth(self) -> bool:
        """Whether the detector reads the truth."""
        return bool(self.detector.needs_truth)

    @property
    def reads_images(self) -> bool:
        """Whether the detector reads the images (:func:`reads_images`)."""
        return reads_images(self.detector)

    @property
    def training_prior(self) -> Any:
        """The detector's ``training_prior`` in the world's order (None if it has none)."""
        prior = getattr(self.detector, "training_prior", None)
        if prior is None or np.ndim(prior) == 0:
            return prior
        return np.asarray(prior, dtype=np.float64)[self._columns]

    def reseed(self, seed: int) -> None:
        """The detector's ``reseed``, if it has one (see :func:`reseed_detector`)."""
        reseed_detector(self.detector, seed)

    def predict(self, images: np.ndarray, *, truth: np.ndarray | None = None) -> np.ndarray:
        """The detector's probabilities of the world's fluents, ``[n, n_world_fluents]``."""
        if truth is not None:
            truth = np.asarray(truth)[:, self._truth_columns]
        probs = self.detector.predict(images, truth=truth)
        if hasattr(probs, "detach"):  # a torch tensor
            probs = probs.detach().cpu().numpy()
        try:
            probs = np.asarray(probs, dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise DetectorOutputError(
                f"detector {type(self.detector).__name__}.predict returned "
                f"{type(probs).__name__}, not numbers: {exc}"
            ) from None
        if probs.ndim != 2 or probs.shape[1] != len(self._own):
            raise DetectorOutputError(
                f"detector {type(self.detector).__name__}.predict returned shape "
                f"{probs.shape}; it must be [n_images, {len(self._own)}], one column per "
                f"fluent of its own {list(self._own)}"
            )
        return probs[:, self._columns]


def reseed_detector(detector: Any, seed: int | None) -> None:
    """Restarts a detector's randomness from ``seed`` where it has any: the bolts call
    this on ``reset(seed=)`` (and SB3's ``VecEnv.seed``), so that seeded episodes see the
    same noise again. A detector without a ``reseed(seed)`` method is left alone (a
    classifier is deterministic); a user's noisy detector may define one."""
    if seed is not None and callable(getattr(detector, "reseed", None)):
        detector.reseed(seed)


def _check_predict_takes_truth(detector: Any) -> None:
    """The bolts call ``predict(images, truth=...)``: refuse one that cannot take it."""
    import inspect

    try:
        parameters = inspect.signature(detector.predict).parameters
    except (TypeError, ValueError, AttributeError):
        return  # nothing to check against: the first call will say
    if "truth" in parameters or any(
        p.kind is inspect.Parameter.VAR_KEYWORD for p in parameters.values()
    ):
        return
    raise IncompatibleError(
        f"{type(detector).__name__}.predict takes no truth keyword; the bolt calls "
        "predict(images, truth=...) (None unless needs_truth): define it as "
        "predict(self, images, *, truth=None)"
    )


def match_fluents(detector: Any, fluent_names: Sequence[str]) -> Any:
    """``detector`` itself if it predicts ``fluent_names`` in that order; else, if it
    predicts every one of them (in another order, or more besides), a
    :class:`FluentsByName` that reads its columns by name.

    Raises:
        IncompatibleError: the detector lacks some of the fluents, names one twice, or
            reads the truth of fluents the world does not have.

    Example:
        >>> matched = match_fluents(OracleDetector(("b", "t", "extra_seen")), ("t", "b"))
        Traceback (most recent call last):
        ...
        noisybolt.errors.IncompatibleError: the detector reads the ground truth of ['extra_seen'], \
which the world does not have (its fluents are ['t', 'b'])
        >>> matched = match_fluents(OracleDetector(("b", "t")), ("t", "b"))
        >>> matched.fluent_names
        ('t', 'b')
        >>> matched.predict(np.zeros((1, 1, 1, 3), np.uint8), truth=np.array([[True, False]]))
        array([[1., 0.]])
    """
    if isinstance(detector.fluent_names, str):
        raise IncompatibleError(
            f"the detector's fluent_names is the string {detector.fluent_names!r}; it must "
            "be a sequence of names, e.g. ('right_edge',)"
        )
    _check_predict_takes_truth(detector)
    own, world = tuple(detector.fluent_names), tuple(fluent_names)
    if own == world:
        return detector
    if len(set(own)) != len(own):
        raise IncompatibleError(f"the detector names a fluent twice: {list(own)}")
    missing = [f for f in world if f not in own]
    if missing:
        raise IncompatibleError(
            f"the detector predicts {list(own)} but the world's fluents are {list(world)}: "
            f"it lacks {missing}; a detector must predict every fluent of the world (in any "
            "order; others besides are ignored)"
        )
    extra = [f for f in own if f not in world]
    if extra and detector.needs_truth:
        raise IncompatibleError(
            f"the detector reads the ground truth of {extra}, which the world does not have "
            f"(its fluents are {list(world)})"
        )
    return FluentsByName(detector, world)


class OracleDetector:
    """Perfect perception: the ground truth as probabilities 0 and 1.

    Args:
        fluent_names: the fluents, in the column order of the truth it will be given.
    """

    def __init__(self, fluent_names: Sequence[str]) -> None:
        self._names = _check_names(fluent_names)

    @property
    def fluent_names(self) -> tuple[str, ...]:
        """The fluents it predicts, in column order."""
        return self._names

    @property
    def needs_truth(self) -> bool:
        """Always True."""
        return True

    @property
    def reads_images(self) -> bool:
        """Always False: only their number is read (the camera need not render)."""
        return False

    def predict(self, images: np.ndarray, *, truth: np.ndarray | None = None) -> np.ndarray:
        """float32 ``[n, k]``: 1 where ``truth`` is true, else 0."""
        return _check_truth(self._names, images, truth).astype(np.float32)


@dataclass(frozen=True)
class BetaNoise:
    """Beta distributions of a detector's probability for one fluent.

    A probability for a true fluent is drawn from ``Beta(m c, (1 - m) c)`` with mean
    ``m = positive_mean`` and concentration ``c``; for a false one with
    ``m = negative_mean``. Larger concentration means less spread.

    Attributes:
        positive_mean: mean probability when the fluent is true, in (0, 1).
        negative_mean: mean probability when it is false, in (0, 1).
        positive_concentration: ``a + b`` of the positives' Beta, > 0.
        negative_concentration: ``a + b`` of the negatives' Beta, > 0.
    """

    positive_mean: float = 0.97
    negative_mean: float = 0.03
    positive_concentration: float = 60.0
    negative_concentration: float = 60.0

    def __post_init__(self) -> None:
        for name in ("positive_mean", "negative_mean"):
            value = getattr(self, name)
            if not 0.0 < value < 1.0:
                raise ConfigError(f"BetaNoise.{name} must be in (0, 1), got {value}")
        for name in ("positive_concentration", "negative_concentration"):
            value = getattr(self, name)
            if not value > 0.0 or not np.isfinite(value):
                raise ConfigError(f"BetaNoise.{name} must be positive and finite, got {value}")

    @classmethod
    def high_confidence(cls) -> BetaNoise:
        """Crisp: about 99% of positives above 0.9 and of negatives below 0.1."""
        return cls()

    @classmethod
    def low_confidence(cls, mean: float = 0.72) -> BetaNoise:
        """Dim: about 99% of positives in the low band [0.5, 0.9] with the default mean."""
        return cls(
            positive_mean=mean,
            negative_mean=0.1,
            positive_concentration=30.0,
            negative_concentration=30.0,
        )

    def beta_parameters(self) -> tuple[tuple[float, float], tuple[float, float]]:
        """``((a_pos, b_pos), (a_neg, b_neg))`` of the two Beta distributions."""
        pm, pc = self.positive_mean, self.positive_concentration
        nm, nc = self.negative_mean, self.negative_concentration
        return (pm * pc, (1.0 - pm) * pc), (nm * nc, (1.0 - nm) * nc)

    def to_dict(self) -> dict[str, float]:
        """JSON-able parameters."""
        return {
            "positive_mean": self.positive_mean,
            "negative_mean": self.negative_mean,
            "positive_concentration": self.positive_concentration,
            "negative_concentration": self.negative_concentration,
        }


def _moments(values: np.ndarray, fallback_mean: float) -> tuple[float, float]:
    """(mean, concentration) of a Beta matching the sample's first two moments."""
    eps = 1e-4
    if values.size < 2:
        return fallback_mean, 60.0
    mean = float(np.clip(values.mean(), eps, 1.0 - eps))
    var = float(values.var())
    ceiling = mean * (1.0 - mean)
    if var <= 0.0:
        return mean, 1e4
    concentration = ceiling / var - 1.0 if var < ceiling else eps
    return mean, float(np.clip(concentration, eps, 1e4))


class SyntheticDetector:
    """Ground truth turned into probabilities by seeded per-fluent Beta noise.

    Reproducible: two detectors with the same seed, given the same truths in the same
    order, return the same probabilities. Vectorised: one draw per call for the batch.

    Args:
        fluent_names: the fluents, in the column order of the truth it will be given.
        seed: seeds the detector's own generator.
        default: the noise of every fluent not named in ``fluents``.
        fluents: per-fluent noise, keyed by fluent name.

    Raises:
        UnknownFluentError: if ``fluents`` names a fluent not in ``fluent_names``.
    """

    def __init__(
        self,
        fluent_names: Sequence[str],
        *,
        seed: int,
        default: BetaNoise | None = None,
        fluents: Mapping[str, BetaNoise] | None = None,
    ) -> None:
        self._names = _check_names(fluent_names)
        fluents = dict(fluents or {})
        unknown = tuple(sorted(set(fluents) - set(self._names)))
        if unknown:
            raise UnknownFluentError(
                f"noise given for unknown fluent(s) {list(unknown)}; known: {list(self._names)}",
                unknown=unknown,
                known=self._names,
            )
        default = default or BetaNoise()
        self._noise = tuple(fluents.get(name, default) for name in self._names)
        params = np.array([n.beta_parameters() for n in self._noise])  # [k, 2 (pos,neg), 2]
        self._a_pos, self._b_pos = params[:, 0, 0], params[:, 0, 1]
        self._a_neg, self._b_neg = params[:, 1, 0], params[:, 1, 1]
        self._seed = seed
        self._rng = np.random.default_rng(seed)

    def reseed(self, seed: int) -> None:
        """Restarts the noise from ``seed`` (with the detector's own seed), as an env's
        ``reset(seed=)`` restarts its randomness: a bolted env reset with the same seed
        then sees the same probabilities again.

        Example:
            >>> d = SyntheticDetector(("x",), seed=0)
            >>> truth = np.ones((1, 1), bool)
            >>> d.reseed(5); a = d.predict(np.zeros((1, 1, 1, 3), np.uint8), truth=truth)
            >>> d.reseed(5); b = d.predict(np.zeros((1, 1, 1, 3), np.uint8), truth=truth)
            >>> bool((a == b).all())
            True
        """
        self._rng = np.random.default_rng([self._seed, int(seed)])

    @classmethod
    def fit(
        cls,
        probs: np.ndarray,
        truth: np.ndarray,
        *,
        fluent_names: Sequence[str],
        seed: int,
    ) -> SyntheticDetector:
        """A synthetic detector calibrated to another detector's outputs.

        Matches, per fluent, the mean and variance of ``probs`` on true positives and on
        true negatives (method of moments), so it reproduces that detector's band
        frequencies approximately, at no cost per image.

        Args:
            probs: float ``[n, k]`` probabilities of the detector to imitate.
            truth: bool ``[n, k]`` ground truth for the same samples.
            fluent_names: the ``k`` fluents.
            seed: seeds the new detector.
        """
        names = _check_names(fluent_names)
        probs = np.asarray(probs, dtype=np.float64)
        truth = _check_truth(names, None, truth)
        if probs.shape != truth.shape:
            raise ValueError(f"probs {probs.shape} and truth {truth.shape} differ")
        noise = {}
        for j, name in enumerate(names):
            pm, pc = _moments(probs[truth[:, j], j], 0.97)
            nm, nc = _moments(probs[~truth[:, j], j], 0.03)
            noise[name] = BetaNoise(pm, nm, pc, nc)
        return cls(names, seed=seed, fluents=noise)

    @property
    def fluent_names(self) -> tuple[str, ...]:
        """The fluents it predicts, in column order."""
        return self._names

    @property
    def needs_truth(self) -> bool:
        """Always True."""
        return True

    @property
    def reads_images(self) -> bool:
        """Always False: only their number is read (the camera need not render)."""
        return False

    @property
    def noise(self) -> dict[str, BetaNoise]:
        """The noise model of each fluent."""
        return dict(zip(self._names, self._noise, strict=True))

    def to_dict(self) -> dict[str, Any]:
        """JSON-able settings (fluents, seed, per-fluent Beta parameters)."""
        return {
            "fluent_names": list(self._names),
            "seed": self._seed,
            "noise": {name: n.to_dict() for name, n in self.noise.items()},
        }

    def reset(self, seed: int | None = None) -> None:
        """Restarts the random stream (from ``seed``, or the constructor's seed)."""
        self._seed = self._seed if seed is None else seed
        self._rng = np.random.default_rng(self._seed)

    def predict(self, images: np.ndarray, *, truth: np.ndarray | None = None) -> np.ndarray:
        """float32 ``[n, k]`` probabilities drawn around the ``truth``."""
        truth = _check_truth(self._names, images, truth)
        a = np.where(truth, self._a_pos, self._a_neg)
        b = np.where(truth, self._b_pos, self._b_neg)
        return self._rng.beta(a, b).astype(np.float32)


#: The detectors that read the world's truth, built by name (:func:`truth_detector`).
TRUTH_DETECTORS: tuple[str, ...] = ("oracle", "synthetic")


def truth_detector(
    kind: str,
    fluent_names: Sequence[str],
    *,
    seed: int = 0,
    low_confidence: Sequence[str] = (),
) -> OracleDetector | SyntheticDetector:
    """A detector that reads the truth, by name: the one factory of the wrappers and of a
    run's config (a classifier is trained or loaded by each, which differ in where its
    images come from).

    ``low_confidence``: fluents the synthetic detector reads with
    :meth:`BetaNoise.low_confidence` (mostly in the low band); the oracle takes none.

    Raises:
        ConfigError: a name not in :data:`TRUTH_DETECTORS`, or ``low_confidence`` for the
            oracle.

    Example:
        >>> truth_detector("oracle", ["a"]).predict(None, truth=np.array([[True]])).tolist()
        [[1.0]]
        >>> truth_detector("synthetic", ["a", "b"], seed=3, low_confidence=["b"]).fluent_names
        ('a', 'b')
    """
    if kind == "oracle":
        if low_confidence:
            raise ConfigError("the oracle detector reads every fluent with certainty")
        return OracleDetector(fluent_names)
    if kind == "synthetic":
        return SyntheticDetector(
            fluent_names,
            seed=seed,
            fluents={name: BetaNoise.low_confidence() for name in low_confidence},
        )
    raise ConfigError(f"{kind!r} is not a detector that reads the truth: {list(TRUTH_DETECTORS)}")
