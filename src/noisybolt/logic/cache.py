"""On-disk cache of compiled DFAs: one ``.npz`` file per automaton, no pickle.

An entry is keyed by a hash of (normalised formula, vocabulary, backend, backend version,
noisybolt version, format). It holds the DFA's arrays plus a JSON header (as a byte
array) that repeats the key's parts, so a hash collision or a stale entry is detected on
load. Entries are written to a temporary file in the cache directory and moved into
place with :func:`os.replace`, which is atomic: processes compiling at the same time
never read a half-written entry, and two writers of one key write the same bytes. An
entry that cannot be read or does not check out is ignored (and later overwritten).

The directory is ``$NOISYBOLT_CACHE_DIR`` if set, else ``~/.cache/noisybolt/dfa``.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import tempfile
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from noisybolt.logic.dfa import DFA, GuardDiagram

__all__ = ["cache_directory", "cache_key", "load", "store"]

#: Bumped whenever the layout of an entry changes.
FORMAT_VERSION = 1


def cache_directory(cache: bool | str | os.PathLike[str]) -> Path | None:
    """The directory ``compile_ltlf(cache=...)`` uses, or None when caching is off."""
    if cache is False or cache is None:
        return None
    if cache is True:
        configured = os.environ.get("NOISYBOLT_CACHE_DIR")
        if configured:
            return Path(configured).expanduser()
        return Path.home() / ".cache" / "noisybolt" / "dfa"
    return Path(cache).expanduser()


def _header(
    formula: str, fluents: tuple[str, ...], backend: str, backend_version: str
) -> dict[str, Any]:
    from noisybolt.version import __version__

    return {
        "format": FORMAT_VERSION,
        "formula": formula,
        "fluents": list(fluents),
        "backend": backend,
        "backend_version": backend_version,
        "noisybolt": __version__,
    }


def cache_key(formula: str, fluents: tuple[str, ...], backend: str, backend_version: str) -> str:
    """Hex digest naming the entry of a normalised formula over ``fluents``."""
    header = _header(formula, fluents, backend, backend_version)
    return hashlib.sha256(json.dumps(header, sort_keys=True).encode()).hexdigest()[:40]


def load(
    directory: Path,
    *,
    formula: str,
    fluents: tuple[str, ...],
    backend: str,
    backend_version: str,
    source: str,
) -> DFA | None:
    """The cached DFA, or None if absent, unreadable or not this key's.

    Args:
        directory: the cache directory.
        formula: normalised formula (part of the key).
        fluents: vocabulary (part of the key).
        backend: backend name (part of the key).
        backend_version: backend version (part of the key).
        source: the formula as the caller wrote it, kept as :attr:`DFA.formula`.
    """
    path = directory / f"{cache_key(formula, fluents, backend, backend_version)}.npz"
    try:
        with np.load(path, allow_pickle=False) as entry:
            header = json.loads(bytes(entry["header"]).decode())
            if header != _header(formula, fluents, backend, backend_version):
                return None
            return DFA(
                fluents=fluents,
                initial_state=int(entry["initial_state"]),
                accepting=entry["accepting"],
                diagram=GuardDiagram(
                    var=entry["var"],
                    lo=entry["lo"],
                    hi=entry["hi"],
                    root=entry["root"],
                    rank=entry["rank"],
                ),
                formula=source,
            )
    except FileNotFoundError:
        return None
    except Exception:  # corrupt, truncated or foreign: rebuild
        return None


def store(
    directory: Path,
    dfa: DFA,
    *,
    formula: str,
    backend: str,
    backend_version: str,
) -> None:
    """Writes ``dfa`` atomically; warns (does not raise) when the cache is not writable."""
    header = _header(formula, dfa.fluents, backend, backend_version)
    path = directory / f"{cache_key(formula, dfa.fluents, backend, backend_version)}.npz"
    temporary: str | None = None
    try:
        directory.mkdir(parents=True, exist_ok=True)
        handle, temporary = tempfile.mkstemp(dir=directory, prefix=".tmp-", suffix=".npz")
        with os.fdopen(handle, "wb") as file:
            np.savez(
                file,
                header=np.frombuffer(json.dumps(header).encode(), dtype=np.uint8),
                initial_state=np.int64(dfa.initial_state),
                accepting=dfa.accepting,
                **dfa.diagram._asdict(),
            )
        os.replace(temporary, path)
        temporary = None
    except OSError as error:
        warnings.warn(
            f"could not write the DFA cache in {directory} ({error}); compiling without it. "
            "Set NOISYBOLT_CACHE_DIR to a writable directory or pass cache=False.",
            RuntimeWarning,
            stacklevel=3,
        )
    finally:
        if temporary is not None:
            with contextlib.suppress(OSError):
                os.unlink(temporary)
