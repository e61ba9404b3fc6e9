"""LTLf formulas to DFAs over an ordered fluent vocabulary.

``compile_ltlf`` reads ltlf2dfa's LTLf syntax and builds the minimal DFA with MONA or, with
no binary, with a pure-Python BDD backend; both give identical automata. ``holds`` is an
independent evaluator of the same logic on finite traces, used to test the compilers.
"""

from __future__ import annotations

from noisybolt.logic.analysis import distance_to_acceptance, is_satisfiable, is_valid
from noisybolt.logic.compiler import BACKENDS, compile_ltlf
from noisybolt.logic.dfa import (
    DENSE_TABLE_LIMIT,
    DFA,
    Edge,
    GuardDiagram,
    assignment_to_mask,
    masks_from_bool_matrix,
)
from noisybolt.logic.evaluator import holds

__all__ = [
    "BACKENDS",
    "DENSE_TABLE_LIMIT",
    "DFA",
    "Edge",
    "GuardDiagram",
    "assignment_to_mask",
    "compile_ltlf",
    "distance_to_acceptance",
    "holds",
    "is_satisfiable",
    "is_valid",
    "masks_from_bool_matrix",
]
