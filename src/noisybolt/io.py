"""Atomic file writes and strict reads: results, checkpoints and caches are never left
half-written, and a damaged one is named, not half-read.

Every writer goes to a temporary file in the destination's folder, flushes and fsyncs it,
then ``os.replace``-s it over the destination, which is atomic on POSIX file systems. A run
killed at any moment leaves either the old file or the new one, never a mix.
"""

from __future__ import annotations

import contextlib
import json
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import IO, Any

from noisybolt.errors import CorruptFileError

__all__ = [
    "atomic_open",
    "atomic_write_bytes",
    "atomic_write_json",
    "atomic_write_text",
    "read_json",
]

_MISSING: Any = object()


@contextlib.contextmanager
def atomic_open(path: str | os.PathLike[str], mode: str = "wb") -> Iterator[IO[Any]]:
    """Opens a temporary file that replaces ``path`` only if the block exits cleanly.

    Example:
        >>> import tempfile, pathlib
        >>> target = pathlib.Path(tempfile.mkdtemp()) / "x.txt"
        >>> with atomic_open(target, "w") as f:
        ...     _ = f.write("hello")
        >>> target.read_text()
        'hello'
    """
    if mode not in ("w", "wb"):
        raise ValueError(f"atomic_open writes whole files: mode must be 'w' or 'wb', not {mode!r}")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, mode) as handle:
            yield handle
            handle.flush()
            # mkstemp makes the file private (0600); results are meant to be shared.
            os.fchmod(handle.fileno(), 0o644)
            os.fsync(handle.fileno())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise


def atomic_write_bytes(path: str | os.PathLike[str], data: bytes) -> None:
    """Writes ``data`` to ``path`` atomically."""
    with atomic_open(path, "wb") as handle:
        handle.write(data)


def atomic_write_text(path: str | os.PathLike[str], text: str) -> None:
    """Writes ``text`` (UTF-8) to ``path`` atomically."""
    atomic_write_bytes(path, text.encode("utf-8"))


def atomic_write_json(path: str | os.PathLike[str], obj: Any, *, indent: int = 2) -> None:
    """Writes ``obj`` as JSON to ``path`` atomically (keys sorted, trailing newline)."""
    atomic_write_text(path, json.dumps(obj, indent=indent, sort_keys=True) + "\n")


def read_json(path: str | os.PathLike[str], *, default: Any = _MISSING, kind: type = object) -> Any:
    """The JSON held in ``path``; ``default`` when the file is absent (if given).

    Raises:
        CorruptFileError: the file is not valid UTF-8 JSON, or its top level is not of
            type ``kind`` (e.g. ``dict``); the message names the file.
        FileNotFoundError: the file is absent and no ``default`` was given.

    Example:
        >>> import tempfile, pathlib
        >>> path = pathlib.Path(tempfile.mkdtemp()) / "x.json"
        >>> read_json(path, default=None) is None
        True
        >>> _ = path.write_text('{"a": ')
        >>> read_json(path)
        Traceback (most recent call last):
        ...
        noisybolt.errors.CorruptFileError: ... is corrupt (not JSON: ...); ...
    """
    path = Path(path)
    try:
        text = path.read_bytes().decode("utf-8")
    except FileNotFoundError:
        if default is _MISSING:
            raise
        return default
    except UnicodeDecodeError as error:
        raise CorruptFileError(f"{path} is corrupt (not UTF-8: {error}); {_REDO}") from None
    try:
        data = json.loads(text)
    except json.JSONDecodeError as error:
        raise CorruptFileError(f"{path} is corrupt (not JSON: {error}); {_REDO}") from None
    if not isinstance(data, kind):
        raise CorruptFileError(
            f"{path} is corrupt: it holds a JSON {type(data).__name__}, not a "
            f"{kind.__name__}; {_REDO}"
        )
    return data


_REDO = "restore it from a copy, or remove it and run what wrote it again"
