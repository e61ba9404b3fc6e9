"""A vectorised world whose games run in worker processes, one shard of games each.

A training run is one process: the world (emulation, frame preprocessing, the bolt's
camera and its noise) and the learner (the bolt's classifier, the bolt, the agent) take
turns on one core. :class:`WorkerWorld` moves the world into ``workers`` processes, each
stepping its own shard of the games, while the calling process keeps the detector, the
bolt and the agent: the shards step in parallel, on the other cores.

It is a Gymnasium vector env with same-step autoreset, like the world it splits, and
hands the bolt the same batched ``info`` (the world–bolt contract of
:mod:`noisybolt.perception.protocols`: ``bolt_image`` and ``true_fluents`` with their
masks, ``final_info`` and ``final_obs`` for the games that ended), the shards' infos
joined along the game axis. Two differences:

* **the camera renders every step**, in the worker (a deferred value could only be
  computed in the process that holds the emulator, and a training run's bolt reads it
  every step anyway);
* given a ``detector`` (the run's classifier), **each worker runs it on its own images**
  and puts the probabilities beside them (``info["bolt_probs"]``, and in ``final_info``
  for the games that ended), in the world's fluent order; the bolt reads them instead of
  calling its detector (:class:`~noisybolt.wrappers.BoltVecEnv`, when the world's
  ``detector`` is its own). Perception then runs where the camera is, in parallel, and
  the caller keeps only the bolt and the agent. Only a detector whose output is a
  function of the images alone may go there (a classifier: same images, same
  probabilities, whatever the batch; tested against the detector in process): a
  detector that draws noise or reads the truth stays with the bolt. With
  ``images=False`` the images then stay in the workers (a learner's bolt reads only the
  probabilities; 85 kB of pixels a step for four 84x84 games less to pickle, pipe and
  join): ``info["bolt_image"]`` keeps its shape and dtype but reading it raises
  :class:`~noisybolt.errors.ConfigError`;
* a world splits only if its factory takes ``shard=(first, total)``, meaning "these
  ``num_envs`` games are games ``first`` .. of a world of ``total`` games with this seed,
  playing exactly as they do there" (:class:`~noisybolt.envs.breakout.BreakoutWorld`
  does). So a ``WorkerWorld`` plays the same games as the in-process world of the same
  seed, observation for observation and camera image for camera image (tested).

:meth:`WorkerWorld.step_async` and :meth:`WorkerWorld.step_wait` split a step in two, as
Gymnasium's ``AsyncVectorEnv`` does: the caller works while the shards step (the
overlapped rollouts of :mod:`noisybolt.agents.pipeline` step one group of games while the
learner works on the other). ``shard=(first, total)`` makes a ``WorkerWorld`` itself a
part of a larger world, as ``BreakoutWorld(shard=...)`` is.

Workers are forked from a fork server that has imported the worlds (no fork of a process
that holds torch's threads; :func:`_context`), compute on one thread each, and end with
:meth:`WorkerWorld.close` (also on garbage collection and at interpreter exit); a worker
whose parent is gone exits by itself. A worker that dies or raises makes the next call
raise :class:`~noisybolt.errors.WorldWorkerError`, naming it and the cause, after the
other workers are closed.

Example:
    >>> world = WorkerWorld("breakout-ram", num_envs=4, workers=2, seed=0)
    >>> obs, info = world.reset(seed=0)
    >>> obs.shape, info["bolt_image"].shape, world.shards
    ((4, 128), (4, 84, 84, 3), ((0, 2), (2, 2)))
    >>> world.close()
"""

from __future__ import annotations

import contextlib
import itertools
import multiprocessing
import pickle
import traceback
import weakref
from collections.abc import Mapping, Sequence
from multiprocessing.connection import Connection, wait
from multiprocessing.process import BaseProcess
from typing import TYPE_CHECKING, Any, NoReturn

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode

from noisybolt.envs.deferred import DeferredArray
from noisybolt.errors import ConfigError, WorldWorkerError
from noisybolt.perception.protocols import (
    BOLT_IMAGE_KEY,
    BOLT_PROBS_KEY,
    FINAL_INFO_KEY,
    CameraSpec,
    FluentDetector,
    goal_declared,
)

if TYPE_CHECKING:  # torch stays out of the fork server (see _context)
    from noisybolt.perception.classifier import ClassifierDetector

__all__ = ["WorkerWorld"]

#: Seconds a worker may take to import the world's modules and build its shard.
START_TIMEOUT_S = 300.0
#: Seconds a worker may take to close its shard before it is terminated.
CLOSE_TIMEOUT_S = 10.0


class WorkerWorld(gym.vector.VectorEnv):
    """``num_envs`` games of a registered world, split over ``workers`` processes.

    Args:
        name: a registered world whose factory takes ``shard`` (e.g. ``"breakout"``,
            ``"breakout-ram"``).
        num_envs: games in all.
        workers: worker processes, 1 .. ``num_envs``; the games are split into that many
            contiguous shards as evenly as possible.
        seed: the whole world's seed (None: drawn once here, shared by the shards).
        shard: ``(first, total)``: these ``num_envs`` games are games ``first`` .. of a
            world of ``total`` games with this seed (None: the whole world,
            ``(0, num_envs)``); each worker's shard is placed in that world.
        detector: a :class:`~noisybolt.perception.classifier.ClassifierDetector` each
            worker runs on its images (``info["bolt_probs"]``, module text); None: the
            images alone are sent.
        images: False (with a ``detector``): the camera's images stay in the workers,
            only their probabilities come back (module text).
        **settings: the world's other settings (``noise``, ``obs_mode``, ...), as
            :func:`~noisybolt.envs.registry.make_world` takes them.

    Raises:
        ConfigError: ``workers`` out of range, ``images=False`` without a detector, or the
            world cannot be built in shards (its factory takes no ``shard``, or a setting
            is bad: the worker's message says which).
        WorldWorkerError: a worker died while starting.
    """

    def __init__(
        self,
        name: str,
        *,
        num_envs: int,
        workers: int,
        seed: int | None = None,
        shard: tuple[int, int] | None = None,
        detector: ClassifierDetector | None = None,
        images: bool = True,
        **settings: Any,
    ) -> None:
        if not images and detector is None:
            raise ConfigError(
                "WorkerWorld(images=False) keeps the camera's images in the workers, where "
                "the detector reads them: give the detector, or keep images=True"
            )
        if detector is not None and not _is_classifier(detector):
            raise ConfigError(
                f"a WorkerWorld runs only a classifier in its workers (same images, same "
                f"probabilities), not a {type(detector).__name__}: leave detector out and let "
                "the bolt call it"
            )
        if not 1 <= workers <= num_envs:
            raise ConfigError(
                f"workers must be in 1..num_envs ({num_envs}) for world {name!r}, got {workers}"
            )
        offset, total = (0, num_envs) if shard is None else (int(v) for v in shard)
        if not (offset >= 0 and offset + num_envs <= total):
            raise ConfigError(
                f"shard (first game, games in all) must hold the {num_envs} games of world "
                f"{name!r}, got {shard}"
            )
        if seed is None:  # one seed for every shard: they are parts of one world
            seed = int(np.random.SeedSequence().generate_state(1)[0])
        self.name = name
        self.num_envs = num_envs
        bounds = np.linspace(0, num_envs, workers + 1).round().astype(int)
        #: ``(first game, games)`` of each worker's shard.
        self.shards: tuple[tuple[int, int], ...] = tuple(
            (int(a), int(b - a)) for a, b in itertools.pairwise(bounds)
        )
        self._seed = seed
        #: The detector the workers run (None: none); the bolt reads its probabilities
        #: from ``info`` when it is the bolt's own.
        self.detector = detector
        #: Whether the camera's images come back from the workers (else their shape only).
        self.images = bool(images)
        # Pickled once for every worker, by value (standard pickle, not the torch
        # reductions of multiprocessing's pickler, which would share its tensors' memory).
        detector_bytes = None if detector is None else pickle.dumps(detector)
        self._stepping = False  # a step sent by step_async, not yet received
        context = _context()
        self._conns: list[Connection] = []
        self._processes: list[BaseProcess] = []
        # Closes the workers however this object goes (close, garbage, interpreter exit).
        self._finalizer = weakref.finalize(self, _shut_down, self._processes, self._conns)
        for first, count in self.shards:
            parent, child = context.Pipe()
            process = context.Process(
                target=_work,
                args=(
                    child,
                    name,
                    offset + first,
                    count,
                    total,
                    seed,
                    dict(settings),
                    detector_bytes,
                    self.images,
                ),
                name=f"noisybolt-world-{name}-{first}",
                daemon=True,
            )
            process.start()
            child.close()
            self._conns.append(parent)
            self._processes.append(process)
        described = [self._receive(k, starting=True) for k in range(workers)]
        world = described[0]
        self.single_observation_space = world["single_observation_space"]
        self.single_action_space = world["single_action_space"]
        self.observation_space = gym.vector.utils.batch_space(
            self.single_observation_space, num_envs
        )
        self.action_space = gym.vector.utils.batch_space(self.single_action_space, num_envs)
        self.metadata = {"autoreset_mode": AutoresetMode.SAME_STEP}
        self.autoreset_mode = AutoresetMode.SAME_STEP
        if world["autoreset_mode"] != AutoresetMode.SAME_STEP:
            self.close()
            raise ConfigError(
                f"world {name!r} does not reset in the same step; WorkerWorld needs one that does"
            )
        self.termination_is_success: bool = world["termination_is_success"]
        self.declares_goal: bool = world["declares_goal"]
        self._fluent_names: tuple[str, ...] = world["fluent_names"]
        self._camera_spec: CameraSpec = world["camera_spec"]
        self._return_bounds = world["return_bounds"]
        self._clipped_return_bounds = world["clipped_return_bounds"]
        self._lives: np.ndarray | None = None

    # -- what the world declares ------------------------------------------------------------
    @property
    def fluent_names(self) -> tuple[str, ...]:
        """The world's fluents, in the column order of ``info["true_fluents"]``."""
        return self._fluent_names

    @property
    def camera_spec(self) -> CameraSpec:
        """The world's bolt camera."""
        return self._camera_spec

    def return_bounds(self) -> Any:
        """The world's declared bounds on an episode's return (None: it declares none)."""
        return self._return_bounds

    def clipped_return_bounds(self) -> Any:
        """Its declared bounds on the return of its rewards clipped to their sign (None:
        it declares none; see :mod:`noisybolt.envs.bounds`)."""
        return self._clipped_return_bounds

    def lives(self) -> np.ndarray:
        """Lives left in each game, from the last reset or step's ``info["lives"]``.

        Raises:
            ConfigError: the world's info has no ``lives``.
        """
        if self._lives is None:
            raise ConfigError(
                f"world {self.name!r} reports no lives in its info (or has not been reset)"
            )
        return self._lives.copy()

    @property
    def pids(self) -> tuple[int | None, ...]:
        """The worker processes' ids, one per shard."""
        return tuple(process.pid for process in self._processes)

    # -- the vector env -------------------------------------------------------------------
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Resets every game (re-seeding the whole world when ``seed`` is given).

        Options: ``reset_mask`` (bool ``[num_envs]``) resets only those games.
        """
        self._check_idle("reset")
        if seed is not None and not isinstance(seed, int | np.integer):
            raise ConfigError(
                f"WorkerWorld.reset takes one int seed for the whole world, got {seed!r}"
            )
        mask = None
        if options and "reset_mask" in options:
            mask = np.asarray(options["reset_mask"], dtype=bool)
            if mask.shape != (self.num_envs,):
                raise ValueError(f"reset_mask must be bool [{self.num_envs}], got {mask.shape}")
        for k, (first, count) in enumerate(self.shards):
            shard_options = dict(options or {})
            if mask is not None:
                shard_options["reset_mask"] = mask[first : first + count]
            self._send(k, "reset", {"seed": seed, "options": shard_options or None})
        parts = [self._receive(k) for k in range(len(self.shards))]
        obs = np.concatenate([part[0] for part in parts])
        info = _merge_infos([part[1] for part in parts], self._counts())
        self._remember(info)
        return obs, info

    def step(
        self, actions: Any
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """Steps every game: each worker its shard, in parallel."""
        self.step_async(actions)
        return self.step_wait()

    def step_async(self, actions: Any) -> None:
        """Sends every shard its actions and returns at once: the workers step while the
        caller goes on; :meth:`step_wait` collects the step.

        Raises:
            RuntimeError: a step is already under way.
        """
        self._check_idle("step_async")
        actions = np.asarray(actions)
        if actions.shape[:1] != (self.num_envs,):
            raise ValueError(f"actions must be [{self.num_envs}, ...], got {actions.shape}")
        for k, (first, count) in enumerate(self.shards):
            self._send(k, "step", actions[first : first + count])
        self._stepping = True

    def step_wait(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """The step :meth:`step_async` started, once every worker has made it (as
        :meth:`step` returns it).

        Raises:
            RuntimeError: no step is under way.
        """
        if not self._stepping:
            raise RuntimeError(f"world {self.name!r}: step_wait without a step_async before it")
        self._stepping = False
        parts = [self._receive(k) for k in range(len(self.shards))]
        obs, rewards, terminated, truncated = (
            np.concatenate([part[j] for part in parts]) for j in range(4)
        )
        info = _merge_infos([part[4] for part in parts], self._counts())
        self._remember(info)
        return obs, rewards, terminated, truncated, info

    def render(self) -> tuple[np.ndarray, ...] | None:
        """Every game's frame (the worlds' ``render()``, joined), or None."""
        self._check_idle("render")
        for k in range(len(self.shards)):
            self._send(k, "render", None)
        parts = [self._receive(k) for k in range(len(self.shards))]
        if any(part is None for part in parts):
            return None
        return tuple(frame for part in parts for frame in part)

    def close_extras(self, **kwargs: Any) -> None:
        """Closes every worker (asking first, then terminating one that does not stop)."""
        self._finalizer()

    # -- talking to the workers -------------------------------------------------------------
    def _check_idle(self, what: str) -> None:
        if self._stepping:
            raise RuntimeError(
                f"world {self.name!r}: {what} while a step is under way; call step_wait first"
            )

    def _counts(self) -> list[int]:
        return [count for _, count in self.shards]

    def _remember(self, info: Mapping[str, Any]) -> None:
        lives = info.get("lives")
        self._lives = None if lives is None else np.asarray(lives)

    def _send(self, k: int, command: str, payload: Any) -> None:
        if not self._finalizer.alive:
            raise WorldWorkerError(f"world {self.name!r}: its workers are closed")
        try:
            self._conns[k].send((command, payload))
        except (BrokenPipeError, ConnectionResetError, OSError):
            self._fail_gone(k, "its pipe is broken")

    def _receive(self, k: int, *, starting: bool = False) -> Any:
        conn, process = self._conns[k], self._processes[k]
        ready = wait([conn, process.sentinel], timeout=START_TIMEOUT_S if starting else None)
        if not ready:
            self._fail(k, f"it did not start within {START_TIMEOUT_S:.0f} s")
        message: tuple[str, Any] | None = None
        if conn in ready or conn.poll():
            try:
                message = conn.recv()
            except (EOFError, OSError):
                message = None
        if message is None:
            self._fail_gone(k, "its pipe closed without an answer")
        status, payload = message
        if status == "ok":
            return payload
        if starting and status == "config":
            self.close()
            raise ConfigError(f"world {self.name!r} cannot run in worker processes: {payload}")
        self._fail(k, f"it raised:\n{payload}")

    def _fail_gone(self, k: int, otherwise: str) -> NoReturn:
        """Worker ``k``'s pipe failed: most often the worker died, and its end of the pipe
        closed as it exited, so whether a send or a receive notices first is a race. Says
        it exited (with its exit code) when it did, whichever noticed; else ``otherwise``."""
        process = self._processes[k]
        process.join(CLOSE_TIMEOUT_S)
        if process.exitcode is not None:
            self._fail(k, f"it exited (exit code {process.exitcode})")
        self._fail(k, otherwise)

    def _fail(self, k: int, cause: str) -> NoReturn:
        first, count = self.shards[k]
        self._finalizer()
        raise WorldWorkerError(
            f"worker {k} (pid {self._processes[k].pid}) of world {self.name!r}, running games "
            f"{first}..{first + count - 1}, failed: {cause}. The other workers are closed; "
            "build the world again to go on"
        )


def _context() -> Any:  # a ForkServerContext (POSIX) or a SpawnContext
    """Where workers come from: a fork server, a fresh process that has imported the
    worlds (not torch's threads: forking a process that has run torch can hang), so a
    worker does not import torch, SB3 and the ALE again (seconds each); ``spawn`` where
    there is no fork server (not on POSIX)."""
    if "forkserver" not in multiprocessing.get_all_start_methods():  # pragma: no cover
        return multiprocessing.get_context("spawn")
    context = multiprocessing.get_context("forkserver")
    context.set_forkserver_preload(["noisybolt.envs.registry", "noisybolt.envs.breakout"])
    return context


def _shut_down(processes: Sequence[BaseProcess], conns: Sequence[Connection]) -> None:
    """Asks every worker to close, then kills those still alive (they ignore SIGTERM)."""
    for conn in conns:
        with contextlib.suppress(BrokenPipeError, ConnectionResetError, OSError):
            conn.send(("close", None))
    for process in processes:
        process.join(CLOSE_TIMEOUT_S)
        if process.is_alive():  # a worker stuck in a step: it ignores SIGTERM (_work)
            process.kill()
            process.join()
    for conn in conns:
        conn.close()


def _materialised(value: Any) -> Any:
    """``value`` with every :class:`DeferredArray` computed (dicts walked): what a worker
    sends back is computed in the worker, where the emulator is."""
    if isinstance(value, DeferredArray):
        return np.asarray(value)
    if isinstance(value, dict):
        return {key: _materialised(item) for key, item in value.items()}
    if isinstance(value, tuple):
        return tuple(_materialised(item) for item in value)
    return value


def _merge_infos(
    parts: Sequence[Mapping[str, Any]],
    counts: Sequence[int],
    fallbacks: Sequence[Mapping[str, Any]] | None = None,
) -> dict[str, Any]:
    """The shards' batched infos as one, joined along the game axis.

    A key some shards lack is filled for their games: a ``_key`` mask with False, a value
    with the shard's ``fallbacks`` value of that key if it has one (for ``final_info``:
    the shard's current info, as a world that ended no game in it shows there), else
    zeros (None for object arrays).
    """
    keys = list(dict.fromkeys(key for part in parts for key in part))
    out: dict[str, Any] = {}
    for key in keys:
        if key == FINAL_INFO_KEY:
            out[key] = _merge_infos(
                [part.get(key, {}) for part in parts], counts, fallbacks=list(parts)
            )
            continue
        first = next(part[key] for part in parts if key in part)
        if isinstance(first, _Withheld):
            out[key] = first.joined(sum(counts))
            continue
        template = np.asarray(first)
        pieces = []
        for j, (part, count) in enumerate(zip(parts, counts, strict=True)):
            if key in part:
                pieces.append(np.asarray(part[key]))
            elif key.startswith("_"):
                pieces.append(np.zeros(count, dtype=bool))
            elif fallbacks is not None and key in fallbacks[j]:
                pieces.append(np.asarray(fallbacks[j][key]))
            elif template.dtype == object:
                pieces.append(np.full(count, None, dtype=object))
            else:
                pieces.append(np.zeros((count, *template.shape[1:]), dtype=template.dtype))
        out[key] = np.concatenate(pieces)
    return out


class _Withheld:
    """What a worker sends for the images that stay with it (``images=False``): their
    shape and dtype. Joined, it is a deferred array that refuses to be read."""

    __slots__ = ("dtype", "shape")

    def __init__(self, shape: tuple[int, ...], dtype: Any) -> None:
        self.shape = tuple(shape)
        self.dtype = np.dtype(dtype)

    def __reduce__(self) -> tuple[Any, ...]:
        return (_Withheld, (self.shape, self.dtype.str))

    def joined(self, games: int) -> DeferredArray:
        """The images of ``games`` games, which no one can read."""
        return DeferredArray(_refuse_images, shape=(games, *self.shape[1:]), dtype=self.dtype)


def _refuse_images() -> np.ndarray:
    raise ConfigError(
        f"info[{BOLT_IMAGE_KEY!r}] stayed in the world's worker processes "
        "(WorkerWorld(images=False): only the detector's probabilities come back); build the "
        "world with images=True to read the camera's images here"
    )


def _is_classifier(detector: Any) -> bool:
    from noisybolt.perception.classifier import ClassifierDetector

    return isinstance(detector, ClassifierDetector)


def _with_probs(
    info: dict[str, Any], detector: FluentDetector, images: bool = True
) -> dict[str, Any]:
    """``info`` (materialised) with the detector's probabilities beside its images: of
    this step's images, and in ``final_info`` of the ended games' last views (the other
    rows there are this step's, as the world's own ``final_info`` images are). Not
    ``images``: the images replaced by their shape (:class:`_Withheld`)."""
    if BOLT_IMAGE_KEY not in info:
        return info
    probs = np.asarray(detector.predict(info[BOLT_IMAGE_KEY]), dtype=np.float32)
    info[BOLT_PROBS_KEY] = probs
    info[f"_{BOLT_PROBS_KEY}"] = np.asarray(info[f"_{BOLT_IMAGE_KEY}"], dtype=bool)
    final = info.get(FINAL_INFO_KEY)
    if final and BOLT_IMAGE_KEY in final:
        ended = np.asarray(final[f"_{BOLT_IMAGE_KEY}"], dtype=bool)
        last = probs.copy()
        if ended.any():
            last[ended] = detector.predict(np.asarray(final[BOLT_IMAGE_KEY])[ended])
        final[BOLT_PROBS_KEY] = last
        final[f"_{BOLT_PROBS_KEY}"] = ended
    if not images:
        for where in (info, final or {}):
            if BOLT_IMAGE_KEY in where:
                value = where[BOLT_IMAGE_KEY]
                where[BOLT_IMAGE_KEY] = _Withheld(value.shape, value.dtype)
    return info


def _work(
    conn: Connection,
    name: str,
    first: int,
    count: int,
    total: int,
    seed: int,
    settings: dict[str, Any],
    detector_bytes: bytes | None = None,
    images: bool = True,
) -> None:
    """A worker: builds its shard of the world, then serves commands until told to close
    or until its parent is gone."""
    import signal

    # Ctrl-C reaches the whole process group, and so does a SIGTERM sent to it (`timeout`,
    # `kill -TERM -PGID`, a batch scheduler's notice): the parent decides (a training saves
    # its checkpoint, which may still need the workers) and closes them; a worker whose
    # parent is gone ends on its closed pipe.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    try:
        import cv2

        cv2.setNumThreads(1)  # the workers are the parallelism
    except ImportError:  # pragma: no cover - cv2 is a dependency
        pass
    try:
        from noisybolt.envs.registry import make_world

        world: Any = make_world(name, num_envs=count, seed=seed, shard=(first, total), **settings)
        detector = None
        if detector_bytes is not None:
            import torch

            from noisybolt.perception.detectors import match_fluents

            torch.set_num_threads(1)  # the workers are the parallelism
            # its columns in the world's fluent order, as the bolt reads them
            detector = match_fluents(pickle.loads(detector_bytes), tuple(world.fluent_names))
    except Exception as error:
        conn.send(("config", f"{type(error).__name__}: {error}"))
        conn.close()
        return
    bounds = world.return_bounds() if callable(getattr(world, "return_bounds", None)) else None
    clipped = getattr(world, "clipped_return_bounds", None)
    conn.send(
        (
            "ok",
            {
                "single_observation_space": world.single_observation_space,
                "single_action_space": world.single_action_space,
                "autoreset_mode": world.metadata.get("autoreset_mode"),
                "termination_is_success": bool(getattr(world, "termination_is_success", False)),
                "declares_goal": goal_declared(world),
                "fluent_names": tuple(world.fluent_names),
                "camera_spec": world.camera_spec,
                "return_bounds": bounds,
                "clipped_return_bounds": clipped() if callable(clipped) else None,
            },
        )
    )
    try:
        while True:
            try:
                command, payload = conn.recv()
            except (EOFError, OSError):  # the parent is gone
                return
            if command == "close":
                return
            try:
                if command == "step":
                    result: Any = _materialised(world.step(payload))
                    if detector is not None:
                        result = (*result[:4], _with_probs(result[4], detector, images))
                elif command == "reset":
                    result = _materialised(world.reset(**payload))
                    if detector is not None:
                        result = (result[0], _with_probs(result[1], detector, images))
                elif command == "render":
                    result = world.render()
                else:  # pragma: no cover - only WorkerWorld sends commands
                    raise ValueError(f"unknown command {command!r}")
                conn.send(("ok", result))  # pickled whole before a byte is sent
            except Exception:
                conn.send(("error", traceback.format_exc()))
    finally:
        world.close()
        conn.close()
