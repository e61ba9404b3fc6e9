"""Experiments: what the paper measured, computed and run reproducibly.

* :mod:`noisybolt.experiments.optimal`: exact R^c_max (and R_max) by planning on the
  product of the gridworld's true dynamics and the specs' DFAs
  (``python -m noisybolt.experiments.optimal`` prints it for the paper's specs).
* :mod:`noisybolt.experiments.spec_families`: specs nobody tuned for, generated from
  Dwyer et al.'s specification patterns (the spec-family suite).
* :mod:`noisybolt.experiments.sweeps`: grids of training runs from YAML (rows x settings x
  seeds: overrides of the run's ``TrainConfig``), resumable, one after the other or in
  parallel on Ray Tune (which then owns retries, resume and results); mean ± std tables.
* :mod:`noisybolt.experiments.table1`: the paper's gridworld Table 1, reproduced over
  seeds through a sweep, beside the paper's numbers.
* :mod:`noisybolt.experiments.case4`: the paper's case 4 (corner preference under the
  regional noise) against a clean-camera control, from ground truth.
* :mod:`noisybolt.experiments.report`: Markdown and self-contained HTML reports of runs
  and sweeps; experiments register their sections with it. Below it,
  :mod:`noisybolt.experiments.reporting` (blocks and renderers: Markdown, HTML, CSV,
  text) and :mod:`noisybolt.experiments.plotting` (every figure).

Names are loaded on first use (PEP 562), so importing the package stays cheap and
``python -m noisybolt.experiments.<module>`` runs a module that was not imported yet.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from noisybolt.experiments.case4 import (
        CornerVisits,
        case4_sweep,
        measure_corners,
        reproduce_case4,
    )
    from noisybolt.experiments.optimal import (
        PAPER_TABLE1_RC_MAX,
        OptimalResult,
        SchemeOptimum,
        SpecLike,
        SpecOptimum,
        exact_compliance_scale,
        format_optima_table,
        optimal_constrained_return,
        optimal_unconstrained_return,
        paper_spec_optima,
        scheme_optimum,
        scheme_q_values,
        tabular_gridworld_settings,
    )
    from noisybolt.experiments.plotting import plot_learning_curves
    from noisybolt.experiments.report import run_report, sweep_report, write_report
    from noisybolt.experiments.reporting import Stat
    from noisybolt.experiments.spec_families import GeneratedSpec, generate_spec_suite
    from noisybolt.experiments.sweeps import (
        GroupSummary,
        SweepConfig,
        SweepResult,
        Trial,
        TrialRecord,
        builtin_sweeps,
        collect_sweep,
        load_sweep,
        run_sweep,
    )
    from noisybolt.experiments.table1 import (
        TABLE1_ROWS,
        PaperNumbers,
        Table1Entry,
        Table1Result,
        Table1Row,
        reproduce_table1,
        table1_sweep,
        write_table1,
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
    "SchemeOptimum": "optimal",
    "exact_compliance_scale": "optimal",
    "scheme_optimum": "optimal",
    "scheme_q_values": "optimal",
    "tabular_gridworld_settings": "optimal",
    "GeneratedSpec": "spec_families",
    "generate_spec_suite": "spec_families",
    "CornerVisits": "case4",
    "case4_sweep": "case4",
    "measure_corners": "case4",
    "reproduce_case4": "case4",
    "plot_learning_curves": "plotting",
    "run_report": "report",
    "sweep_report": "report",
    "write_report": "report",
    "GroupSummary": "sweeps",
    "Stat": "reporting",
    "SweepConfig": "sweeps",
    "SweepResult": "sweeps",
    "Trial": "sweeps",
    "TrialRecord": "sweeps",
    "builtin_sweeps": "sweeps",
    "collect_sweep": "sweeps",
    "load_sweep": "sweeps",
    "run_sweep": "sweeps",
    "TABLE1_ROWS": "table1",
    "PaperNumbers": "table1",
    "Table1Entry": "table1",
    "Table1Result": "table1",
    "Table1Row": "table1",
    "reproduce_table1": "table1",
    "table1_sweep": "table1",
    "write_table1": "table1",
}

__all__ = [
    "PAPER_TABLE1_RC_MAX",
    "TABLE1_ROWS",
    "CornerVisits",
    "GeneratedSpec",
    "GroupSummary",
    "OptimalResult",
    "PaperNumbers",
    "SchemeOptimum",
    "SpecLike",
    "SpecOptimum",
    "Stat",
    "SweepConfig",
    "SweepResult",
    "Table1Entry",
    "Table1Result",
    "Table1Row",
    "Trial",
    "TrialRecord",
    "builtin_sweeps",
    "case4_sweep",
    "collect_sweep",
    "exact_compliance_scale",
    "format_optima_table",
    "generate_spec_suite",
    "load_sweep",
    "measure_corners",
    "optimal_constrained_return",
    "optimal_unconstrained_return",
    "paper_spec_optima",
    "plot_learning_curves",
    "reproduce_case4",
    "reproduce_table1",
    "run_report",
    "run_sweep",
    "scheme_optimum",
    "scheme_q_values",
    "sweep_report",
    "table1_sweep",
    "tabular_gridworld_settings",
    "write_report",
    "write_table1",
]


def __getattr__(name: str) -> Any:
    if name in _SOURCES:
        module = importlib.import_module(f"{__name__}.{_SOURCES[name]}")
        return getattr(module, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted([*globals(), *__all__])
