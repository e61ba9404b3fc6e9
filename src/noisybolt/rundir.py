"""Run directories: every run keeps its resolved config and exact command beside its results.

Layout of a run directory::

    config.json     the resolved configuration (what actually ran, defaults included)
    command.txt     the exact command line, shell-quoted
    metrics.json    a list of records (rewritten atomically, never appended in place)
    ...             whatever the run produces (checkpoints/, model.zip, plots)

All files are written atomically (:mod:`noisybolt.io`).
"""

from __future__ import annotations

import json
import os
import shlex
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from noisybolt.errors import ConfigError, CorruptFileError
from noisybolt.io import atomic_write_json, atomic_write_text

__all__ = ["RunDirectory", "config_differences"]


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

    def exists(self) -> bool:
        """Whether a run was started here (it has a config)."""
        return self.config_path.exists()

    def write_config(self, config: Mapping[str, Any]) -> None:
        """Saves the resolved config."""
        atomic_write_json(self.config_path, dict(config))

    def read_config(self) -> dict[str, Any]:
        """Loads the resolved config, with a clear error if it is missing or corrupt."""
        try:
            data = json.loads(self.config_path.read_text())
        except FileNotFoundError:
            raise ConfigError(f"{self.path} holds no run (no config.json)") from None
        except (json.JSONDecodeError, UnicodeDecodeError) as error:
            raise CorruptFileError(f"{self.config_path} is corrupt: {error}") from None
        if not isinstance(data, dict):
            raise CorruptFileError(f"{self.config_path} does not hold a JSON object")
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
        argv = list(sys.argv if argv is None else argv)
        if argv and Path(argv[0]).name in ("noisybolt", "__main__.py"):
            argv[0] = "noisybolt"
        text = shlex.join(argv) + "\n"
        atomic_write_text(self.file("command.txt"), text)

    def write_metrics(self, records: Sequence[Mapping[str, Any]]) -> None:
        """Rewrites ``metrics.json`` with all records (atomic, so never half-written)."""
        atomic_write_json(self.file("metrics.json"), [dict(r) for r in records])

    def read_metrics(self) -> list[dict[str, Any]]:
        """Loads ``metrics.json`` (empty list when absent)."""
        path = self.file("metrics.json")
        if not path.exists():
            return []
        try:
            data = json.loads(path.read_text())
        except json.JSONDecodeError as error:
            raise CorruptFileError(f"{path} is corrupt: {error}") from None
        return list(data)
