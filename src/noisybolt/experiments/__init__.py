"""Experiments: what the paper measured, computed and run reproducibly.

* :mod:`noisybolt.experiments.optimal`: exact R^c_max (and R_max) by planning on the
  product of the gridworld's true dynamics and the specs' DFAs
  (``python -m noisybolt.experiments.optimal`` prints it for the paper's specs).

Names are loaded on first use (PEP 562), so importing the package stays cheap and
``python -m noisybolt.experiments.<module>`` runs a module that was not imported yet.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from noisybolt.experiments.optimal import (
        PAPER_TABLE1_RC_MAX,
        OptimalResult,
        SpecLike,
        SpecOptimum,
        format_optima_table,
        optimal_constrained_return,
        optimal_unconstrained_return,
        paper_spec_optima,
    )

#: The module that defines each public name.
_SOURCES: dict[str, str] = {
    "PAPER_TABLE1_RC_MAX": "optimal",
    "OptimalResult": "optimal",
    "SpecLike": "optimal",
    "SpecOptimum": "optimal",
    "format_optima_table": "optimal",
    "optimal_constrained_return": "optimal",
    "optimal_unconstrained_return": "optimal",
    "paper_spec_optima": "optimal",
}

__all__ = [
    "PAPER_TABLE1_RC_MAX",
    "OptimalResult",
    "SpecLike",
    "SpecOptimum",
    "format_optima_table",
    "optimal_constrained_return",
    "optimal_unconstrained_return",
    "paper_spec_optima",
]


def __getattr__(name: str) -> Any:
    if name in _SOURCES:
        module = importlib.import_module(f"{__name__}.{_SOURCES[name]}")
        return getattr(module, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted([*globals(), *__all__])
