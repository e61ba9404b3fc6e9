"""Public names and modules that moved in 0.2 (the ``agents`` / ``runs`` / ``viz`` split),
still importable from their old homes for one release with a ``DeprecationWarning`` that
names the new one (Gymnasium's habit for renamed wrappers).

Old *modules* (``noisybolt.agents.config``, ``noisybolt.rundir``, ...) are served by an
import finder placed last on ``sys.meta_path`` by ``import noisybolt``: it only answers
for the names in :data:`MOVED_MODULES`, which no file provides any more, and hands back
the new module itself (one module object under two names, so ``isinstance`` and
monkeypatching see one class). Old *package attributes* (``noisybolt.agents.TrainConfig``)
go through :func:`moved_attribute`. Nothing here imports a layer at import time: the new
homes are imported by name, on first use.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import sys
import warnings
from types import ModuleType
from typing import Any

_RUNS = [
    "callbacks",
    "checkpoints",
    "config",
    "detectors",
    "environments",
    "evaluation",
    "models",
    "resolution",
    "run_evaluation",
    "schema",
    "sections",
    "specs",
    "stopping",
    "training",
    "trust",
    "warm_start",
    "world_checks",
]

#: old module -> its new home.
MOVED_MODULES: dict[str, str] = {
    **{f"noisybolt.agents.{name}": f"noisybolt.runs.{name}" for name in _RUNS},
    "noisybolt.rundir": "noisybolt.runs.rundir",
    "noisybolt.agents.visualize": "noisybolt.viz",
    "noisybolt.agents.comparison": "noisybolt.experiments.comparison",
}

#: Old modules that re-exported names from several homes: the names each offered besides
#: its own, and where they live now (``noisybolt.agents.training`` re-exported the config,
#: the env stack, the detector and the callbacks).
REEXPORTED: dict[str, tuple[str, ...]] = {
    "noisybolt.agents.training": (
        "noisybolt.runs.config",
        "noisybolt.runs.environments",
        "noisybolt.runs.detectors",
        "noisybolt.runs.callbacks",
    ),
    "noisybolt.agents.config": (
        "noisybolt.runs.legacy",
        "noisybolt.runs.presentation",
        "noisybolt.runs.resolution",
    ),
}

#: (old package, name) -> the module that now defines it.
MOVED_ATTRIBUTES: dict[tuple[str, str], str] = {
    ("noisybolt.agents", name): "noisybolt.runs"
    for name in (
        "DetectorConfig",
        "EpisodeRecord",
        "EvalResult",
        "PAPER_SPECS",
        "TrainConfig",
        "TrainResult",
        "evaluate_bolted_policy",
        "resolve_spec",
        "train",
    )
}


def _warn(old: str, new: str) -> None:
    warnings.warn(
        f"{old} moved to {new}; the old name stops working in the next release",
        DeprecationWarning,
        stacklevel=3,
    )


def moved_attribute(package: str, name: str) -> Any:
    """The value of ``package.name`` from its new home, with a ``DeprecationWarning``.

    Raises:
        AttributeError: ``name`` never lived in ``package``.
    """
    home = MOVED_ATTRIBUTES.get((package, name))
    if home is None:
        raise AttributeError(f"module {package!r} has no attribute {name!r}")
    _warn(f"{package}.{name}", f"{home}.{name}")
    return getattr(importlib.import_module(home), name)


class _Alias(importlib.abc.Loader):
    """Loads an old module name as the new module object itself, or, for a module that
    re-exported names from elsewhere (:data:`REEXPORTED`), as a view that finds each name
    in its home."""

    def __init__(self, new: str) -> None:
        self.new = new

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> ModuleType:
        _warn(spec.name, self.new)
        module = importlib.import_module(self.new)
        homes = REEXPORTED.get(spec.name)
        return module if homes is None else _View(spec.name, module, homes)

    def exec_module(self, module: ModuleType) -> None:
        """Nothing to run: the new module already ran."""


class _View(ModuleType):
    """An old module's names: its new home's, then those it re-exported, each from its home."""

    def __init__(self, name: str, module: ModuleType, homes: tuple[str, ...]) -> None:
        super().__init__(name, module.__doc__)
        self._homes = (module.__name__, *homes)

    def __getattr__(self, attr: str) -> Any:
        for home in self._homes:
            module = importlib.import_module(home)
            if hasattr(module, attr):
                return getattr(module, attr)
        raise AttributeError(f"module {self.__name__!r} has no attribute {attr!r}")


class MovedModuleFinder(importlib.abc.MetaPathFinder):
    """Finds the old names of moved modules (:data:`MOVED_MODULES`) and nothing else."""

    def find_spec(self, fullname: str, path: Any = None, target: Any = None) -> Any:
        new = MOVED_MODULES.get(fullname)
        if new is None:
            return None
        return importlib.machinery.ModuleSpec(fullname, _Alias(new))


def install() -> None:
    """Places :class:`MovedModuleFinder` last on ``sys.meta_path`` (once)."""
    if not any(isinstance(f, MovedModuleFinder) for f in sys.meta_path):
        sys.meta_path.append(MovedModuleFinder())
