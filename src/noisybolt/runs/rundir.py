"""Run directories: every run keeps its resolved config and exact command beside its results.

Layout of a run directory::

    config.json     the resolved configuration (what actually ran, defaults included)
    command.txt     the exact command line, shell-quoted
    versions.json   per start or resume: its command, Python's, the platform's and the
                    main packages' versions (command.txt keeps the run's first command)
    metrics.json    a list of records (rewritten atomically, never appended in place)
    .lock           held (``flock``) by the one process writing the run; names its holder
    ...             whatever the run produces (checkpoints/, model.zip, plots)

All files are written atomically (:mod:`noisybolt.io`). The directory owns its files: a
writer holds :meth:`RunDirectory.lock` for its whole life, a second writer is refused
with :class:`~noisybolt.errors.RunLockedError` naming the first, and every path read
through :meth:`RunDirectory.inside` stays inside the directory.
"""

from __future__ import annotations

import contextlib
import fcntl
import json
import os
import shlex
import sys
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

from noisybolt.errors import ConfigError, CorruptFileError, RunLockedError
from noisybolt.io import atomic_write_json, atomic_write_text, read_json

__all__ = [
    "CLASSIFIER_STAGES",
    "RECORDED_PACKAGES",
    "RunDirectory",
    "config_differences",
    "software_versions",
]

#: The stages ``noisybolt classifiers`` runs in one directory, each keeping its settings
#: under its name in that directory's ``config.json`` (a run's holds its TrainConfig).
CLASSIFIER_STAGES = ("collect", "train", "report")


def _flatten(obj: Any, prefix: str = "") -> dict[str, Any]:
    if isinstance(obj, Mapping):
        items: dict[str, Any] = {}
        for key, value in obj.items():
            items.update(_flatten(value, f"{prefix}{key}."))
        return items if items or not prefix else {prefix[:-1]: {}}
    return {prefix[:-1]: obj}


def config_differences(
    old: Mapping[str, Any], new: Mapping[str, Any], *, ignore: Sequence[str] = ()
) -> dict[str, tuple[Any, Any]]:
    """Dotted keys whose values differ between two nested configs, as ``(old, new)``.

    Example:
        >>> config_differences({"a": 1, "b": {"c": 2}}, {"a": 1, "b": {"c": 3}})
        {'b.c': (2, 3)}
    """
    flat_old, flat_new = (
        _flatten(json.loads(json.dumps(old))),
        _flatten(json.loads(json.dumps(new))),
    )
    ignored = tuple(ignore)
    diffs = {}
    for key in sorted(set(flat_old) | set(flat_new)):
        if any(key == i or key.startswith(i + ".") for i in ignored):
            continue
        a, b = flat_old.get(key, "<absent>"), flat_new.get(key, "<absent>")
        if a != b:
            diffs[key] = (a, b)
    return diffs


class RunDirectory:
    """A folder holding one run's config, command and results.

    Example:
        >>> import tempfile
        >>> run = RunDirectory(tempfile.mkdtemp())
        >>> run.write_config({"seed": 0})
        >>> run.read_config()
        {'seed': 0}
    """

    def __init__(self, path: str | os.PathLike[str]) -> None:
        self.path = Path(path)

    def __repr__(self) -> str:
        return f"RunDirectory({str(self.path)!r})"

    def file(self, name: str) -> Path:
        """Path of ``name`` inside the run directory."""
        return self.path / name

    @property
    def config_path(self) -> Path:
        """Where the resolved config lives."""
        return self.file("config.json")

    def inside(self, relative: str | os.PathLike[str], *, named_in: Path | None = None) -> Path:
        """``relative`` under the run directory, refused if it leads outside it.

        A pointer file (``checkpoints/latest.json``) or a symbolic link could otherwise send
        a reader anywhere on the machine: a shared run directory must only ever be read
        from inside itself.

        Raises:
            CorruptFileError: the path (after ``..`` and links) lies outside the directory;
                ``named_in`` names the file that pointed there.

        Example:
            >>> run = RunDirectory("/tmp/run")
            >>> run.inside("checkpoints/step_1").name
            'step_1'
            >>> run.inside("../elsewhere")
            Traceback (most recent call last):
            ...
            noisybolt.errors.CorruptFileError: ../elsewhere lies outside the run directory ...
        """
        root = self.path.resolve()
        source = f" (named in {named_in})" if named_in is not None else ""
        try:
            target = (self.path / relative).resolve()
        except (ValueError, OSError) as error:  # a NUL byte, a loop of links, a long name
            raise CorruptFileError(
                f"{relative!r} names no file of the run directory {self.path}{source} "
                f"({error}); fix or remove the pointer"
            ) from None
        if target != root and root not in target.parents:
            raise CorruptFileError(
                f"{relative} lies outside the run directory {self.path}{source}: a run "
                "directory is only read from inside itself; fix or remove the pointer"
            )
        return target

    @contextlib.contextmanager
    def lock(self, argv: Sequence[str] | None = None) -> Iterator[None]:
        """Holds the run's exclusive writer lock while the block runs.

        An advisory ``flock`` on ``.lock``: the kernel releases it when its holder exits,
        however it exits (a SIGKILL included), so a stale lock never blocks a resume. The
        file names the holder (pid and command) for whoever is refused.

        Raises:
            RunLockedError: another process holds the lock (the message names it).
        """
        self.path.mkdir(parents=True, exist_ok=True)
        path = self.file(".lock")
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                holder = os.pread(fd, 4096, 0).decode("utf-8", "replace").strip() or "unknown"
                raise RunLockedError(
                    f"{self.path} is being written by another process ({holder}); wait for "
                    "it to finish or stop it, or choose another directory",
                    holder=holder,
                ) from None
            command = _command_text(sys.argv if argv is None else argv).strip()
            os.ftruncate(fd, 0)
            os.pwrite(fd, f"pid {os.getpid()}: {command}\n".encode(), 0)
            try:
                yield
            finally:
                os.ftruncate(fd, 0)
                fcntl.flock(fd, fcntl.LOCK_UN)
        finally:
            os.close(fd)

    def remove_partial_files(self) -> list[Path]:
        """Removes the temporary files of atomic writes that a killed writer left behind.

        Call it only while holding :meth:`lock`: then no write is in progress, and every
        ``.NAME.*.tmp`` (:func:`noisybolt.io.atomic_open`'s pattern) is a dead one.
        Returns what it removed.
        """
        removed = []
        for path in self.path.rglob(".*.tmp"):
            if path.is_file() and not path.is_symlink():
                path.unlink()
                removed.append(path)
        return removed

    def exists(self) -> bool:
        """Whether a run was started here (it has a config)."""
        return self.config_path.exists()

    def write_config(self, config: Mapping[str, Any]) -> None:
        """Saves the resolved config."""
        atomic_write_json(self.config_path, dict(config))

    def read_config(self) -> dict[str, Any]:
        """Loads the resolved config, with a clear error if it is missing or corrupt."""
        try:
            data: dict[str, Any] = read_json(self.config_path, kind=dict)
        except FileNotFoundError:
            raise ConfigError(f"{self.path} holds no run (no config.json)") from None
        return data

    def check_same_config(
        self,
        config: Mapping[str, Any],
        *,
        ignore: Sequence[str] = (),
        defaults: Mapping[str, Any] | None = None,
    ) -> None:
        """Raises ``ConfigError`` naming every key where ``config`` differs from the saved one.

        ``defaults``: values of top-level keys that a config saved before they existed
        lacks (what those runs did), filled in before comparing.
        """
        saved = {**(defaults or {}), **self.read_config()}
        diffs = config_differences(saved, config, ignore=ignore)
        if diffs:
            lines = "; ".join(
                f"{k}: saved {a!r}, now {b!r}" for k, a, b in ((k, *v) for k, v in diffs.items())
            )
            raise ConfigError(
                f"cannot resume {self.path}: the config differs in {sorted(diffs)} ({lines}); "
                "use the saved settings or start a new run directory"
            )

    def write_command(self, argv: Sequence[str] | None = None) -> None:
        """Saves the exact command line (default: this process's, as ``noisybolt ...``)."""
        self.write_command_lines([_command_text(sys.argv if argv is None else argv).rstrip("\n")])

    def write_command_lines(self, lines: Sequence[str]) -> None:
        """Saves ``command.txt`` as these command lines, one per line (a run made in
        stages, as ``noisybolt classifier``'s, keeps one per stage): the one writer of
        the file."""
        atomic_write_text(self.file("command.txt"), "".join(f"{line}\n" for line in lines))

    def record_versions(self, *, frames: int, argv: Sequence[str] | None = None) -> None:
        """Adds this process's software (:func:`software_versions`) to ``versions.json``:
        a list, one record per start or resume, with the frames it started from and its
        command line (``argv``, default this process's; ``command.txt`` keeps the first)."""
        path = self.file("versions.json")
        try:
            records = read_json(path, default=[], kind=list)
        except CorruptFileError:
            records = []  # a record of provenance, not results: start it again
        command = _command_text(sys.argv if argv is None else argv).strip()
        records.append({"frames": int(frames), "command": command, **software_versions()})
        atomic_write_json(path, records)

    def write_metrics(self, records: Sequence[Mapping[str, Any]]) -> None:
        """Rewrites ``metrics.json`` with all records (atomic, so never half-written)."""
        atomic_write_json(self.file("metrics.json"), [dict(r) for r in records])

    def read_metrics(self) -> list[dict[str, Any]]:
        """Loads ``metrics.json`` (empty list when absent).

        Raises:
            CorruptFileError: the file is not a JSON list of records each with an integer
                ``frames``, in increasing order.
        """
        path = self.file("metrics.json")
        data = read_json(path, default=[], kind=list)
        frames = [r.get("frames") if isinstance(r, dict) else None for r in data]
        counts = [f for f in frames if isinstance(f, int)]
        if len(counts) != len(frames) or counts != sorted(counts):
            raise CorruptFileError(
                f"{path} is corrupt: its records must be objects with increasing integer "
                "'frames'; restore it from a copy, or remove it and train again"
            )
        return [dict(r) for r in data]


#: The packages whose versions a run records (those installed).
RECORDED_PACKAGES = (
    "noisybolt",
    "stable-baselines3",
    "torch",
    "gymnasium",
    "numpy",
    "minigrid",
    "ale-py",
    "ltlf2dfa",
)


def software_versions() -> dict[str, Any]:
    """Python, the platform and :data:`RECORDED_PACKAGES`' versions (None: not installed).

    Example:
        >>> sorted(software_versions())[:3]
        ['packages', 'platform', 'python']
    """
    import platform
    from importlib import metadata

    packages: dict[str, str | None] = {}
    for name in RECORDED_PACKAGES:
        try:
            packages[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            packages[name] = None
    return {
        "python": platform.python_version(),
        "platform": platform.platform(),
        "packages": packages,
    }


def _command_text(argv: Sequence[str]) -> str:
    argv = list(argv)
    if argv and Path(argv[0]).name in ("noisybolt", "__main__.py"):
        argv[0] = "noisybolt"
    return shlex.join(argv) + "\n"
