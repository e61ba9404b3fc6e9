"""The paper's specifications by name, and turning command-line text into :class:`Spec` s.

Rewards: the paper gives no numbers for its bolts' rewards. Ours are per step
(``every_step`` timing, the paper's Algorithm 1): +1 for each step the DFA is accepting,
and 0.5 for each low-confidence fluent on the edge taken. Both stay below the world's
step cost (1.5 in the gridworld), so complying never pays more than reaching the goal:
the bolt shapes *how* the agent reaches it.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from noisybolt.bolt import Spec
from noisybolt.errors import ConfigError

__all__ = ["DEFAULT_COST", "DEFAULT_REWARD", "PAPER_SPECS", "resolve_spec"]

DEFAULT_REWARD = 1.0
DEFAULT_COST = 0.5

_T, _B = "top_right_corner", "bottom_left_corner"

#: The paper's Table 1 specifications, by name.
PAPER_SPECS: dict[str, str] = {
    "edge": "G(on_edge)",
    "avoid_top_right": f"!F({_T})",
    "top_right_once": f"F({_T} & X(!F({_T})))",
    "one_corner_once": (f"(F({_T} & X(!F({_T}))) & !F({_B})) | (F({_B} & X(!F({_B}))) & !F({_T}))"),
    "clear_left_column": "F(brick_clear_left)",
}


def resolve_spec(item: str | Mapping[str, Any]) -> Spec:
    """A :class:`Spec` from a built-in name, a formula, or a mapping of Spec fields.

    Example:
        >>> resolve_spec("edge").formula
        'G(on_edge)'
        >>> resolve_spec({"formula": "F(a)", "terminal_reward": 5}).terminal_reward
        5.0
    """
    if isinstance(item, str):
        text = item.strip()
        if text in PAPER_SPECS:
            return Spec(
                PAPER_SPECS[text],
                terminal_reward=DEFAULT_REWARD,
                low_confidence_cost=DEFAULT_COST,
                name=text,
            )
        return Spec(text, terminal_reward=DEFAULT_REWARD, low_confidence_cost=DEFAULT_COST)
    if isinstance(item, Mapping):
        fields = dict(item)
        if "name" in fields and "formula" not in fields and fields["name"] in PAPER_SPECS:
            fields["formula"] = PAPER_SPECS[fields["name"]]
        if "formula" not in fields:
            raise ConfigError(f"a spec needs a formula or a built-in name: {dict(item)}")
        known = {"formula", "terminal_reward", "low_confidence_cost", "reward_timing", "name"}
        unknown = sorted(set(fields) - known)
        if unknown:
            raise ConfigError(f"unknown spec field(s) {unknown}; known: {sorted(known)}")
        fields.setdefault("terminal_reward", DEFAULT_REWARD)
        fields.setdefault("low_confidence_cost", DEFAULT_COST)
        formula = fields.pop("formula")
        return Spec(formula, **fields)
    raise ConfigError(f"cannot read a spec from {item!r}")
