"""Worlds by name: ``make_world("gridworld", num_envs=8, seed=0, noise="regional")``.

A world is named in a config by a registered name or by a *factory path*
``"package.module:factory"``: ``factory()`` returns one labelled Gymnasium env (see
:class:`~noisybolt.envs.labels.FluentLabels`), and :func:`make_world` steps
``num_envs`` of them as a :class:`~noisybolt.envs.labelled_vec.LabelledVectorEnv`. Any
process (a resumed run, ``evaluate``, a spawned worker) rebuilds it from the path; a
module not on ``sys.path`` is looked for in the current directory too.

A factory path is imported only where a world is built (:func:`make_world`), never where
a config naming it is read (:func:`check_world` checks its form alone): a config read from
a shared run directory is data. While a saved run is loaded (:func:`refusing_code`), a
factory path the user did not vouch for is refused with
:class:`~noisybolt.errors.UntrustedCodeError` before anything is imported, and the
current directory is not searched for it.

A registered world factory returns a vectorised world: a Gymnasium
:class:`~gymnasium.vector.VectorEnv` with same-step autoreset that puts the bolt's labels
into its batched ``info`` (the contract of :mod:`noisybolt.perception.protocols`) and
meets :class:`~noisybolt.perception.protocols.BoltObservable` for sample collection.
Factories are registered as ``"module:attribute"`` paths and imported only when asked
for, so a world whose module or dependencies are missing breaks only itself. Every
factory takes the keywords ``num_envs``, ``seed``, ``noise`` and ``obs_mode`` plus its own.

Example:
    >>> world = make_world("gridworld", num_envs=2, seed=0, obs_mode="view")
    >>> world.num_envs, world.fluent_names[0], world.camera_spec.shape
    (2, 'on_edge', (48, 48, 3))
    >>> "breakout" in known_worlds()
    True
"""

from __future__ import annotations

import contextlib
import contextvars
import importlib
import inspect
import os
import sys
import warnings
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from typing import Any

import gymnasium as gym

from noisybolt.errors import (
    BackendUnavailableError,
    ConfigError,
    UnboundedEpisodesWarning,
    UnknownNameError,
    UnlabelledEnvError,
    UntrustedCodeError,
    WorldFactoryError,
)
from noisybolt.perception.noise import NoiseSpec
from noisybolt.perception.protocols import BoltObservable

__all__ = [
    "DEFAULT_WORLD",
    "WorldDisplay",
    "check_world",
    "factory_settings",
    "is_factory_path",
    "known_worlds",
    "make_single_world",
    "make_world",
    "refusing_code",
    "register_world",
    "resolve_factory",
    "world_display",
    "world_fingerprint",
]

WorldFactory = Callable[..., BoltObservable]

#: The paper's 6x6 gridworld: the world of a run that names none, and of the paper's
#: experiments (Table 1, case 4). World names live here, in ``envs``, and nowhere else.
DEFAULT_WORLD = "gridworld"

_WORLDS: dict[str, str | WorldFactory] = {
    "gridworld": "noisybolt.envs.gridworld_vec:VectorGridworld",
    # Written separately (envs/breakout.py); the factory takes the same keywords.
    "breakout": "noisybolt.envs.breakout:make_breakout_world",
    # The same game and bolt; the agent reads the console's RAM (its own hyperparameters).
    "breakout-ram": "noisybolt.envs.breakout:make_breakout_ram_world",
    # MinAtar's Breakout (the optional minatar package: pip install "noisybolt[minatar]").
    "minatar-breakout": "noisybolt.envs.minatar:make_minatar_breakout_world",
}


# One labelled (non-vectorised) env of each registered world, for recordings (GIFs).
_SINGLE: dict[str, str] = {
    "gridworld": "noisybolt.envs.gridworld:GridworldEnv",
    "breakout": "noisybolt.envs.breakout:BreakoutEnv",
    "breakout-ram": "noisybolt.envs.breakout:make_breakout_ram_env",
    "minatar-breakout": "noisybolt.envs.minatar:MinAtarBreakoutEnv",
}


@dataclass(frozen=True)
class WorldDisplay:
    """How recordings show a world.

    Attributes:
        gif_steps: steps recorded per episode (None: the whole episode).
        gif_fps: GIF frame rate.
        action_names: names drawn for the actions, in the world's action order (None:
            their numbers).
    """

    gif_steps: int | None = 1000
    gif_fps: float = 4.0
    action_names: tuple[str, ...] | None = None


_DISPLAY: dict[str, WorldDisplay] = {
    "gridworld": WorldDisplay(
        gif_steps=None,
        gif_fps=4.0,
        action_names=("left", "right", "forward", "no-op"),
    ),
    # A Breakout game can last thousands of steps.
    "breakout": WorldDisplay(
        gif_steps=600,
        gif_fps=15.0,
        action_names=("no-op", "fire", "right", "left"),
    ),
}
_DISPLAY["breakout-ram"] = _DISPLAY["breakout"]
_DISPLAY["minatar-breakout"] = WorldDisplay(
    gif_steps=600, gif_fps=10.0, action_names=("no-op", "left", "right")
)


def world_display(name: str) -> WorldDisplay:
    """How recordings show the world ``name`` (defaults for a factory-path world)."""
    return _DISPLAY.get(name, WorldDisplay())


def is_factory_path(name: str) -> bool:
    """Whether ``name`` is a factory path ``"package.module:factory"`` (not a registered name)."""
    return isinstance(name, str) and name not in _WORLDS and ":" in name


#: The factory paths a saved run being loaded may follow (None: no run is being loaded,
#: every path is followed: a new run's author gave them). Set by :func:`refusing_code`.
_TRUSTED_CODE: contextvars.ContextVar[frozenset[str] | None] = contextvars.ContextVar(
    "noisybolt_trusted_code", default=None
)


@contextlib.contextmanager
def refusing_code(trusted: Iterable[str] = ()) -> Iterator[None]:
    """While the block runs, :func:`resolve_factory` refuses every factory path outside
    ``trusted`` (the ones the user gave) with :class:`~noisybolt.errors.UntrustedCodeError`
    before importing anything: what loads a saved run (``evaluate``, ``--resume``,
    ``report``) runs inside it, so that a reference it missed is refused all the same.

    Example:
        >>> with refusing_code(trusted=["mymod:make"]):
        ...     resolve_factory("os:system", what="detector")  # doctest: +ELLIPSIS
        Traceback (most recent call last):
        ...
        noisybolt.errors.UntrustedCodeError: detector 'os:system' is named by a saved run...
    """
    token = _TRUSTED_CODE.set(frozenset(trusted))
    try:
        yield
    finally:
        _TRUSTED_CODE.reset(token)


def _factory_parts(path: str, *, what: str, error: type[WorldFactoryError]) -> tuple[str, str]:
    """``(module, function)`` of a factory path, refused unless of the form
    ``package.module:function`` (nothing imported)."""
    module_name, sep, attribute = path.partition(":")
    modules = module_name.split(".")
    if not sep or not all(part.isidentifier() for part in modules) or not attribute.isidentifier():
        raise error(f"a {what} factory path is 'package.module:factory', got {path!r}", path=path)
    return module_name, attribute


def resolve_factory(
    path: str, *, what: str = "world", error: type[WorldFactoryError] = WorldFactoryError
) -> Callable[..., Any]:
    """The function a factory path names (imported; the current directory is searched too).

    ``what`` names the thing made in messages (a world, a detector), and ``error`` is the
    error raised (a :class:`~noisybolt.errors.WorldFactoryError` or a subclass).

    Raises:
        WorldFactoryError: the path is malformed, its module does not import, or it names
            nothing callable.
        UntrustedCodeError: inside :func:`refusing_code`, a path the user did not give.
    """
    module_name, attribute = _factory_parts(path, what=what, error=error)
    trusted = _TRUSTED_CODE.get()
    if trusted is not None and path not in trusted:
        raise UntrustedCodeError(
            f"{what} {path!r} is named by a saved run, not by you: noisybolt imports no "
            "code a run directory names without your word. If you trust whoever wrote the "
            "run, pass --trust-code (Python: trust_code=True), or give the reference "
            f"yourself (--{what} {path})",
            references=(f"{what} = {path!r}",),
        )
    try:
        module = _import_here_too(module_name)
    except Exception as exc:
        raise error(
            f"{what} {path!r}: importing {module_name} failed ({type(exc).__name__}: {exc}); "
            "is the module on PYTHONPATH or in the current directory?",
            path=path,
        ) from exc
    factory = getattr(module, attribute, None)
    if not callable(factory):
        raise error(f"{what} {path!r}: {module_name} has no function {attribute!r}", path=path)
    return factory


def _import_here_too(module_name: str) -> Any:
    try:
        return importlib.import_module(module_name)
    except ModuleNotFoundError as exc:
        # A console script does not put the current directory on sys.path (python -m does).
        top = module_name.partition(".")[0]
        here = os.getcwd()
        if exc.name != top or here in sys.path or "" in sys.path:
            raise
        sys.path.insert(0, here)
        return importlib.import_module(module_name)


#: Steps at which the episodes of a factory world's env without a time limit of its own
#: are cut (truncated), with an :class:`~noisybolt.errors.UnboundedEpisodesWarning`.
DEFAULT_MAX_EPISODE_STEPS = 10_000


def _has_time_limit(env: gym.Env) -> bool:
    """A ``TimeLimit`` among its wrappers, or an env that cuts its own episodes after a
    ``max_steps`` it states (MiniGrid's levels, registered without ``max_episode_steps``)."""
    layer: Any = env
    while isinstance(layer, gym.Wrapper):
        if isinstance(layer, gym.wrappers.TimeLimit):
            return True
        layer = layer.env
    own = getattr(env.unwrapped, "max_steps", None)
    return isinstance(own, int) and not isinstance(own, bool) and own > 0


#: Factory paths already warned of having no time limit in this process (the world is
#: built several times a run: its probe, training, evaluation).
_UNBOUNDED_WARNED: set[str] = set()


def _labelled_env(
    path: str, factory: Callable[..., gym.Env], settings: dict[str, Any] | None = None
) -> gym.Env:
    """``factory(**settings)``, checked to be one labelled Gymnasium env; one without a
    time limit (``gym.make`` of an env registered without ``max_episode_steps``, or an env
    made directly) gets one of :data:`DEFAULT_MAX_EPISODE_STEPS` steps, said once."""
    from noisybolt.envs.labels import fluent_names_of

    try:
        env = factory(**(settings or {}))
    except Exception as exc:
        # The user's own code: say which factory failed and how, not a traceback.
        raise WorldFactoryError(
            f"world {path!r}: the factory raised {type(exc).__name__}: {exc}",
            path=path,
        ) from exc
    if not isinstance(env, gym.Env):
        raise WorldFactoryError(
            f"world {path!r}: the factory must return one Gymnasium env (gym.Env), got "
            f"{type(env).__name__}",
            path=path,
        )
    try:
        fluent_names_of(env)
    except UnlabelledEnvError:
        raise WorldFactoryError(
            f"world {path!r}: the factory returned an env without labels; return "
            "noisybolt.FluentLabels(env, fluents={name: fn(env) -> bool}, ...)",
            path=path,
        ) from None
    if not _has_time_limit(env):
        if path in _UNBOUNDED_WARNED:
            return gym.wrappers.TimeLimit(env, max_episode_steps=DEFAULT_MAX_EPISODE_STEPS)
        _UNBOUNDED_WARNED.add(path)
        warnings.warn(
            f"world {path!r}: its env has no time limit, so an episode its policy never "
            f"ends would stall every evaluation; its episodes are cut at "
            f"{DEFAULT_MAX_EPISODE_STEPS:,} steps (wrap the env in "
            "gymnasium.wrappers.TimeLimit to choose)",
            UnboundedEpisodesWarning,
            stacklevel=2,
        )
        env = gym.wrappers.TimeLimit(env, max_episode_steps=DEFAULT_MAX_EPISODE_STEPS)
    return env


def check_world(name: str) -> None:
    """Checks that ``name`` is a registered world or a factory path
    ``package.module:factory``.

    A factory path is not imported here: a config naming it may have been read from a
    shared run directory, and importing a module runs its code. :func:`make_world` imports
    it (and says if it does not import).

    Raises:
        UnknownNameError: neither (the message lists the registered worlds).
        WorldFactoryError: a factory path of the wrong form.
    """
    if is_factory_path(name):
        _factory_parts(name, what="world", error=WorldFactoryError)
    elif name not in _WORLDS:
        raise UnknownNameError(
            f"unknown world {name!r}; known worlds: {list(known_worlds())}, or a factory "
            "path 'package.module:factory' returning a labelled env",
            name=str(name),
            known=known_worlds(),
        )


def make_single_world(name: str, **settings: Any) -> gym.Env:
    """One labelled (non-vectorised) env of a world, e.g. to record an episode.

    Args:
        name: a registered world or a factory path.
        **settings: the world's settings (a factory path's: keywords of its factory).

    Raises:
        ConfigError: a setting the world (or the factory) does not take.
        UnknownNameError, WorldFactoryError: as :func:`check_world`.
    """
    check_world(name)
    if is_factory_path(name):
        factory = resolve_factory(name)
        return _labelled_env(name, factory, factory_settings(name, factory, settings))
    module_name, _, attribute = _SINGLE[name].partition(":")
    env: gym.Env = getattr(importlib.import_module(module_name), attribute)(**settings)
    return env


def factory_settings(
    name: str, factory: Callable[..., Any], settings: dict[str, Any]
) -> dict[str, Any]:
    """The settings a factory-path world is built with: those given (``world.kwargs``,
    ``--noise``, ``--obs-mode``; unset ones, None or noise ``"none"``, are left to the
    factory's own defaults), each one the factory takes as a keyword.

    Raises:
        ConfigError: a setting the factory does not take, naming the ones it does.

    Example:
        >>> def make(size=4, noise="none"): ...
        >>> factory_settings("m:make", make, {"noise": "none", "obs_mode": None, "size": 8})
        {'size': 8}
    """
    import inspect

    given = {
        k: v for k, v in settings.items() if v is not None and not (k == "noise" and v == "none")
    }
    if not given:
        return {}
    try:
        parameters = inspect.signature(factory).parameters
    except (TypeError, ValueError):
        return given  # no signature to check against: the call will say
    if any(p.kind is inspect.Parameter.VAR_KEYWORD for p in parameters.values()):
        return given
    takes = [
        p.name
        for p in parameters.values()
        if p.kind in (inspect.Parameter.POSITIONAL_OR_KEYWORD, inspect.Parameter.KEYWORD_ONLY)
    ]
    unknown = sorted(set(given) - set(takes))
    if unknown:
        noise = "noise" in unknown
        where = (
            " (give the factory a noise parameter and pass it to FluentLabels(..., noise=))"
            if noise
            else ""
        )
        raise ConfigError(
            f"world {name!r}: its factory takes no setting {', '.join(map(repr, unknown))}"
            f"{where}; it takes {takes or 'none'} (world.kwargs are passed to the factory "
            "as keywords)"
        )
    return given


def world_fingerprint(
    name: str,
    world_kwargs: dict[str, Any] | None = None,
    *,
    samples: int = 64,
    seed: int = 0,
    final_views: bool = False,
) -> str:
    """What a world's fluents *mean*: a digest of labelled bolt images it shows.

    A classifier cached under a world's name and camera stays right only while the
    fluents keep their definitions; a user's world (a factory path) can change one
    without changing its name. The digest is over ``samples`` labelled images collected
    from the world with ``seed`` (images and labels), so a changed fluent, camera or
    noise gives another digest. ``final_views`` collects the ended episodes' last states
    too (:func:`~noisybolt.perception.dataset.collect_samples`), so that a fluent true only
    as an episode ends counts as well; False gives the digest of before they were
    collected, which the classifiers cached then are named by.

    Example:
        >>> len(world_fingerprint("gridworld", {"obs_mode": "grid"}))
        16
    """
    import hashlib

    from noisybolt.perception.dataset import collect_samples

    world = make_world(name, num_envs=4, seed=seed, **(world_kwargs or {}))
    try:
        data = collect_samples(world, num_samples=samples, seed=seed, final_views=final_views)
    finally:
        if isinstance(world, gym.vector.VectorEnv):
            world.close()
    digest = hashlib.sha256(data.labels.tobytes())
    digest.update(str(data.labels.shape).encode())
    digest.update(data.images.tobytes())
    return digest.hexdigest()[:16]


def known_worlds() -> tuple[str, ...]:
    """Registered world names, sorted."""
    return tuple(sorted(_WORLDS))


def register_world(name: str, factory: str | WorldFactory, *, overwrite: bool = False) -> None:
    """Register a world factory (a callable, or a lazy ``"module:attribute"`` path).

    Raises:
        ConfigError: if ``name`` is taken and ``overwrite`` is False, or a path is malformed.
    """
    if name in _WORLDS and not overwrite:
        raise ConfigError(f"world {name!r} is already registered; pass overwrite=True")
    if isinstance(factory, str) and factory.count(":") != 1:
        raise ConfigError(f"a world factory path is 'module:attribute', got {factory!r}")
    _WORLDS[name] = factory


def _resolve(name: str) -> WorldFactory:
    entry = _WORLDS[name]
    if not isinstance(entry, str):
        return entry
    module_name, _, attribute = entry.partition(":")
    try:
        module = importlib.import_module(module_name)
    except ModuleNotFoundError as exc:
        raise BackendUnavailableError(
            f"world {name!r} cannot be built here: importing {module_name} failed ({exc}); "
            f"install its dependencies or pick another of {', '.join(known_worlds())}"
        ) from exc
    try:
        factory: WorldFactory = getattr(module, attribute)
    except AttributeError:
        raise BackendUnavailableError(
            f"world {name!r}: {module_name} has no factory {attribute!r}"
        ) from None
    return factory


def make_world(
    name: str,
    *,
    num_envs: int = 1,
    seed: int | None = None,
    noise: NoiseSpec = "none",
    obs_mode: str | None = None,
    **kwargs: Any,
) -> BoltObservable:
    """Build a vectorised world by name.

    Args:
        name: one of :func:`known_worlds`, or a factory path (see the module docs).
        num_envs: number of environments in the batch.
        seed: seeds the world's randomness (the bolt camera's noise included).
        noise: the bolt camera's noise spec (see
            :func:`noisybolt.perception.noise.make_noise`).
        obs_mode: the agent's observation; None for the world's default.
        **kwargs: the world's own parameters (e.g. ``size`` for the gridworld).

    Raises:
        UnknownNameError: for a name outside :func:`known_worlds` (listing them).
        ConfigError: for a parameter the world does not take, or a bad value.
        BackendUnavailableError: if the world's module cannot be imported here.
        WorldFactoryError: a factory path that does not import or returns an env without
            labels.
    """
    if is_factory_path(name):
        from noisybolt.envs.labelled_vec import LabelledVectorEnv

        env_fn = resolve_factory(name)
        given = factory_settings(name, env_fn, {"noise": noise, "obs_mode": obs_mode, **kwargs})
        first = _labelled_env(name, env_fn, given)
        fns = [lambda: first] + [lambda: _labelled_env(name, env_fn, given)] * (num_envs - 1)
        return LabelledVectorEnv(fns, seed=seed)
    if name not in _WORLDS:
        raise UnknownNameError(
            f"unknown world {name!r}; known: {', '.join(known_worlds())}, or a factory path "
            "'package.module:factory' returning a labelled env",
            name=str(name),
            known=known_worlds(),
        )
    factory = _resolve(name)
    arguments: dict[str, Any] = {"num_envs": num_envs, "seed": seed, "noise": noise, **kwargs}
    if obs_mode is not None:
        arguments["obs_mode"] = obs_mode
    _check_arguments(name, factory, arguments)
    return factory(**arguments)


def _check_arguments(name: str, factory: WorldFactory, arguments: dict[str, Any]) -> None:
    try:
        parameters = inspect.signature(factory).parameters
    except (TypeError, ValueError):  # pragma: no cover - builtins without a signature
        return
    if any(p.kind is inspect.Parameter.VAR_KEYWORD for p in parameters.values()):
        return
    unknown = sorted(set(arguments) - set(parameters))
    if unknown:
        raise ConfigError(
            f"world {name!r} takes no parameter(s) {', '.join(unknown)}; it takes: "
            f"{', '.join(p for p in parameters if p != 'self')}"
        )
