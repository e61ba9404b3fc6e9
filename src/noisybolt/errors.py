"""Named exceptions shared by every layer of noisybolt.

Each message says what went wrong and what to do about it. They subclass the built-in
exception a caller would naturally catch (``ValueError``, ``RuntimeError``) so generic
handlers keep working.
"""

from __future__ import annotations

__all__ = [
    "BackendFallbackWarning",
    "BackendUnavailableError",
    "BaseRateError",
    "BriefFluentWarning",
    "CameraError",
    "CompilationError",
    "ConfidenceLevelError",
    "ConfigError",
    "CorruptFileError",
    "DenseTableError",
    "DetectorFactoryError",
    "DetectorOutputError",
    "EstimatedBoundsWarning",
    "FluentFunctionError",
    "IncompatibleError",
    "LargeCameraWarning",
    "MissingDependencyError",
    "MissingErrorModelError",
    "NoCheckpointError",
    "NoEvaluationWarning",
    "NoisyboltError",
    "ObservationSpaceError",
    "RareFluentWarning",
    "RunLockedError",
    "SmallIntegerImagesWarning",
    "SpecSyntaxError",
    "StaleInfoError",
    "UnboundedEpisodesWarning",
    "UnknownBaseRatesWarning",
    "UnknownFluentError",
    "UnknownNameError",
    "UnlabelledEnvError",
    "UnnormalizedRewardWarning",
    "UnsafeFileError",
    "UnsatisfiableSpecError",
    "UnseenFluentError",
    "UnseenFluentWarning",
    "UntrustedCodeError",
    "WorldFactoryError",
    "WorldWorkerError",
]


class NoisyboltError(Exception):
    """Base class of every error raised on purpose by noisybolt."""


class SpecSyntaxError(NoisyboltError, ValueError):
    """An LTLf formula could not be parsed.

    Attributes:
        formula: the text that was parsed.
        position: 0-based character offset of the problem, or None if unknown.
    """

    def __init__(self, message: str, *, formula: str, position: int | None = None) -> None:
        super().__init__(message)
        self.formula = formula
        self.position = position


class UnknownFluentError(NoisyboltError, ValueError):
    """A formula, detector or config names a fluent outside the known vocabulary."""

    def __init__(self, message: str, *, unknown: tuple[str, ...], known: tuple[str, ...]) -> None:
        super().__init__(message)
        self.unknown = unknown
        self.known = known


class UnknownNameError(NoisyboltError, ValueError):
    """A world, noise model, algorithm, spec or other registry name is not known."""

    def __init__(self, message: str, *, name: str, known: tuple[str, ...]) -> None:
        super().__init__(message)
        self.name = name
        self.known = known


class BackendUnavailableError(NoisyboltError, RuntimeError):
    """A compiler backend was requested but cannot run here (e.g. MONA is not installed)."""


class MissingDependencyError(BackendUnavailableError):
    """An optional package a world needs is not installed (e.g. ``minatar`` for
    ``minatar-breakout``); the message names the extra that installs it.

    Attributes:
        package: the missing package's import name.
        extra: the noisybolt extra that installs it (``pip install "noisybolt[<extra>]"``).
    """

    def __init__(self, message: str, *, package: str, extra: str) -> None:
        super().__init__(message)
        self.package = package
        self.extra = extra


class CompilationError(NoisyboltError, RuntimeError):
    """A backend failed to compile a formula (timeout, crash, unreadable output)."""

    def __init__(self, message: str, *, formula: str) -> None:
        super().__init__(message)
        self.formula = formula


class DenseTableError(NoisyboltError, ValueError):
    """A dense transition table was asked of a DFA held compactly (see ``DFA.is_compact``)."""


class ConfigError(NoisyboltError, ValueError):
    """A configuration value is missing, unknown or out of range."""


class IncompatibleError(NoisyboltError, ValueError):
    """Two parts that must agree do not (e.g. a classifier trained for another camera)."""


class CorruptFileError(NoisyboltError, ValueError):
    """A saved file (dataset, classifier, checkpoint, cache entry) is truncated or corrupt."""


class DetectorOutputError(ConfigError):
    """A fluent detector's ``predict`` returned what the bolt cannot read: not one row of
    probabilities in [0, 1] per image and one column per fluent, as floats."""


class FluentFunctionError(ConfigError):
    """A user's fluent function raised, or returned something other than a bool.

    Attributes:
        fluent: the fluent's name.
    """

    def __init__(self, message: str, *, fluent: str) -> None:
        super().__init__(message)
        self.fluent = fluent


class CameraError(ConfigError):
    """A bolt camera raised, or returned an image that is not uint8 ``[H, W, 3]`` of one shape."""


class ObservationSpaceError(ConfigError):
    """An env offered to the bolt observes a structured space (a ``Dict``, a ``Tuple``)
    that would be nested under the bolt's ``"image"`` entry, which SB3 cannot train on:
    reduce it to its image or flatten it in the env first."""


class UnlabelledEnvError(ConfigError):
    """An env offered to the bolt carries no labels (no ``fluent_names``, or no
    ``bolt_image``/``true_fluents`` in its ``info``): wrap it in ``noisybolt.FluentLabels``."""


class StaleInfoError(NoisyboltError, RuntimeError):
    """A deferred ``info`` value (e.g. a world's bolt camera images) was first read after
    the world had moved on (a later reset or step): read it before stepping again."""


class WorldFactoryError(ConfigError):
    """A world factory path (``package.module:factory``) does not import, is not callable,
    or its factory does not return a labelled env.

    Attributes:
        path: the factory path as given.
    """

    def __init__(self, message: str, *, path: str) -> None:
        super().__init__(message)
        self.path = path


class WorldWorkerError(NoisyboltError, RuntimeError):
    """A worker process of a world split across processes
    (:class:`~noisybolt.envs.worker_world.WorkerWorld`) died or raised; the message names
    the worker, its games and the cause (the worker's traceback, or its exit code). The
    world has closed its other workers: build a new one to go on."""


class UnsatisfiableSpecError(ConfigError):
    """No trace satisfies a spec (its DFA can never accept a non-empty trace): no agent
    can comply, so training under it would only teach the agent to ignore the bolt.

    Attributes:
        formula: the spec's formula.
    """

    def __init__(self, message: str, *, formula: str) -> None:
        super().__init__(message)
        self.formula = formula


class UnseenFluentError(ConfigError):
    """A fluent some spec uses is true in none (or in all) of the images a classifier
    learns from: it could never see the fluent (or its absence), so the bolt would never
    pay for a spec over it, or always would. The message names the fluents, the images and
    what to do (another detector, more images, a world whose collection shows the state).

    Attributes:
        fluents: the fluents never seen true or never seen false.
        images: how many images the classifier learns from.
    """

    def __init__(self, message: str, *, fluents: tuple[str, ...], images: int) -> None:
        super().__init__(message)
        self.fluents = fluents
        self.images = images


class ConfidenceLevelError(ConfigError):
    """A belief-tracking bolt's confidence level is outside (0.5, 1): at 0.5 or below a
    spec would count as accepted while its rejection is as likely; at 1 never."""


class BaseRateError(ConfigError):
    """A fluent's base rate (its frequency in play or in a detector's training set) is not
    a number in [0, 1]."""


class MissingErrorModelError(ConfigError):
    """A compliance estimate was asked of a detector whose error rates were never measured
    (no held-out measurements recorded with it) and no labelled images were given to
    measure them on."""


class RunLockedError(ConfigError):
    """Another process is writing the run directory (a training holds its lock).

    Attributes:
        holder: what the lock file says of its holder (pid and command), as text.
    """

    def __init__(self, message: str, *, holder: str) -> None:
        super().__init__(message)
        self.holder = holder


class NoCheckpointError(ConfigError):
    """``resume`` was asked of a run directory without a usable checkpoint to continue from."""


class UnsafeFileError(CorruptFileError):
    """A file in a run directory that noisybolt will not load because loading it could run
    code (a pickle, or a model entry it does not know); the message says what to do."""


class UntrustedCodeError(ConfigError):
    """A saved run (its ``config.json``, a sweep's trial) names code outside noisybolt: a
    world factory path (``world.name``), a detector factory path (``detector.kind``).
    Loading a run never imports or runs such code without the user's word: pass
    ``--trust-code`` (Python: ``trust_code=True``), or give the same reference yourself
    (``--world mymod:make``, ``--detector mydetectors:noisy``).

    Attributes:
        references: each reference as ``"path = 'module:function'"``.
    """

    def __init__(self, message: str, *, references: tuple[str, ...]) -> None:
        super().__init__(message)
        self.references = references


class DetectorFactoryError(WorldFactoryError):
    """A detector factory path (``package.module:function``, ``--detector``) does not
    import, is not callable, or its function does not return a fluent detector.

    Attributes:
        path: the factory path as given.
    """


class BackendFallbackWarning(UserWarning):
    """MONA is not installed, so ``backend="auto"`` compiles specs with the pure-Python BDD
    progression (the same DFAs, slower on large specs): install MONA with
    ``sudo apt-get install mona`` (``make mona`` in a checkout). Said once per process."""


class EstimatedBoundsWarning(UserWarning):
    """The world declares no bounds on its episodes' returns, so the ``compliance`` scale
    was set from bounds estimated by random play; declare them (``return_bounds=``) or give
    the scale to be sure compliance comes first."""


class NoEvaluationWarning(UserWarning):
    """A new run evaluates every ``evaluation.freq`` frames, more than its whole budget
    (``frames``): no periodic evaluation runs before the final one."""


class UnknownBaseRatesWarning(UserWarning):
    """Belief tracking was set up without the fluents' base rates in play, so it takes
    the detector's training prior (0.5) for them, which protects rare fluents poorly
    against faint, steady false readings: estimate them with
    :func:`noisybolt.perception.base_rates.belief_settings_from_play`."""


class UnseenFluentWarning(UserWarning):
    """A fluent some spec uses was never true (or never false) in a run's random play,
    with a detector that reads the truth: a spec needing it is met only if a trained
    agent makes it so, and never if the fluent's function is constant."""


class UnboundedEpisodesWarning(UserWarning):
    """A user's env has no time limit, so an episode its policy never ends (a loop by a
    wall) would stall training's episode statistics and every evaluation: its episodes are
    cut at :data:`noisybolt.envs.registry.DEFAULT_MAX_EPISODE_STEPS` steps; wrap the env in
    ``gymnasium.wrappers.TimeLimit`` to choose."""


class LargeCameraWarning(UserWarning):
    """A classifier is about to be trained on the fly on a large camera (a user's env's
    full render), which takes hours on a CPU: give the world a smaller camera."""


class RareFluentWarning(UserWarning):
    """A fluent some spec uses is true (or false) in only a few of the images a classifier
    learns from (fewer than :data:`noisybolt.runs.detectors.RARE_FLUENT_IMAGES`): its
    validation accuracy rests on a handful of them, and the bolt may read it poorly."""


class BriefFluentWarning(UserWarning):
    """Under belief tracking, a fluent some spec uses is true in the world's play for
    fewer frames in a row than the bolt needs to believe it, even from a perfect detector
    (:func:`noisybolt.bolt.belief.frames_to_believe`): a spec met only on such a visit is
    never credited. ``min_dwell=1`` or threshold tracking may be needed."""


class UnnormalizedRewardWarning(UserWarning):
    """PPO or A2C is paid the ``compliance`` scheme's large rewards without
    ``normalize_reward``: value targets in the hundreds or thousands can swamp the policy's
    share of each gradient step, and the policy barely moves."""


class SmallIntegerImagesWarning(UserWarning):
    """A user's world shows uint8 image observations holding small integers (a symbolic
    grid), so they reach the agent's network undivided (``normalize_images`` off)."""
