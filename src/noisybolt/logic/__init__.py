"""LTLf formulas to DFAs over an ordered fluent vocabulary."""

from __future__ import annotations

from noisybolt.logic.dfa import DFA, Edge, assignment_to_mask, masks_from_bool_matrix

__all__ = ["DFA", "Edge", "assignment_to_mask", "masks_from_bool_matrix"]
