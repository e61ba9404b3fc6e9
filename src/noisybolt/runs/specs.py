"""The paper's specifications by name, and turning command-line text into :class:`Spec` s.

Rewards: the paper gives no numbers for its bolts' rewards. By default ours are per step
(``every_step`` timing, the paper's Algorithm 1): +1 for each step the DFA is accepting,
and 0.5 for each low-confidence fluent on the edge taken. Both stay below the world's
step cost (1.5 in the gridworld), so complying never pays more than reaching the goal:
the bolt shapes *how* the agent reaches it, and staying in an accepting state forever
earns -0.5 per step (no incentive to loiter).

Per-spec settings (:data:`SPEC_SETTINGS`) may replace those defaults for one spec; none
does at present, after measuring (``benchmarks/tuning_notes.md``):

- The world's shortest path (7 actions, along the top wall through the top-right corner)
  already complies with ``edge``, ``top_right_once`` and ``one_corner_once``: the +1 per
  accepting step only has to keep the agent on it (or, for the two ``F`` specs, off the
  interior routes that visit no corner).
- ``avoid_top_right`` costs one extra step (8 actions). With gamma 0.99 the compliant
  route is worth ~3.4 more than the shortcut (out of ~90), at 0.97 ~1.5, at 0.95 ~0;
  at gamma 0.9 the shortcut is worth ~2.2 more, and DQN at 0.9 learned it in every
  seed. ``episode_end`` timing with a terminal reward
  of 50 (no loitering incentive, wide margin at any gamma) made DQN at gamma 0.9 learn
  it in 2-6k frames, but A2C then converged on the shortcut in all three seeds within
  100k frames (the per-step reward reaches it in 20-30k): the dense per-step signal is
  what A2C needs. So every spec keeps the paper's per-step reward and DQN uses gamma
  0.97 instead. Per-step rewards above the 1.5 step cost are avoided: they would pay
  the agent for staying in an accepting state forever.

Breakout milestones (not the paper's): ``F(brick_clear_left)`` pays nothing until the
whole left column is gone, which random play never achieves, so a bolt with only that
spec adds no signal (measured: bolted and unbolted PPO runs were identical). The group
``left_column_milestones`` adds one spec per brick of that column, ``left_row{r}`` =
``F(left_gone_row{r})``, each paying :data:`MILESTONE_REWARD` once, on the step its brick
is seen gone (``on_entry``: a per-step reward would pay for the rest of a game that can
last thousands of steps). It is +1, what a brick is worth to a learner that sees the
game's score clipped to its sign (the Atari convention of ``breakout.yaml``), so a left
brick is worth twice any other. It was +5 (about a brick's unclipped 1 to 7 points)
until the reward clipping came: then each milestone was worth five bricks, and a bolted
PPO agent lagged the unbolted one in score and even in left bricks taken
(``results/breakout/README.md``).
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping, Sequence
from dataclasses import asdict
from pathlib import Path
from typing import Any

import yaml

from noisybolt.bolt import Spec
from noisybolt.bolt.spec import DEFAULT_COST, DEFAULT_REWARD
from noisybolt.errors import ConfigError, SpecSyntaxError

__all__ = [
    "BUILTIN_SPECS",
    "DEFAULT_COST",
    "DEFAULT_REWARD",
    "MILESTONE_REWARD",
    "PAPER_SPECS",
    "SPEC_FILE_KEYS",
    "SPEC_GROUPS",
    "SPEC_SETTINGS",
    "expand_specs",
    "load_specs_file",
    "parsed_spec",
    "resolve_spec",
    "spec_fields",
]

#: What each of Breakout's ``left_row{r}`` milestones pays, once (see the module text).
MILESTONE_REWARD = 1.0

_T, _B = "top_right_corner", "bottom_left_corner"

#: The paper's Table 1 specifications, by name.
PAPER_SPECS: dict[str, str] = {
    "edge": "G(on_edge)",
    "avoid_top_right": f"!F({_T})",
    "top_right_once": f"F({_T} & X(!F({_T})))",
    "one_corner_once": (f"(F({_T} & X(!F({_T}))) & !F({_B})) | (F({_B} & X(!F({_B}))) & !F({_T}))"),
    "clear_left_column": "F(brick_clear_left)",
}

_ROWS = range(6)

#: Every built-in spec by name: the paper's, and Breakout's per-brick milestones.
BUILTIN_SPECS: dict[str, str] = {
    **PAPER_SPECS,
    **{f"left_row{r}": f"F(left_gone_row{r})" for r in _ROWS},
}

#: Reward settings of built-in specs that differ from the defaults (see the module text);
#: they fill in whatever a mapping given to :func:`resolve_spec` leaves out.
SPEC_SETTINGS: dict[str, dict[str, Any]] = {
    f"left_row{r}": {"terminal_reward": MILESTONE_REWARD, "reward_timing": "on_entry"}
    for r in _ROWS
}

#: Names that stand for several built-in specs (see :func:`expand_specs`).
SPEC_GROUPS: dict[str, tuple[str, ...]] = {
    # Bottom row first: the order in which a ball from below reaches them.
    "left_column_milestones": (
        "clear_left_column",
        *(f"left_row{r}" for r in reversed(_ROWS)),
    ),
}


def _builtin_fields(name: str) -> dict[str, Any]:
    fields: dict[str, Any] = {
        "formula": BUILTIN_SPECS[name],
        "terminal_reward": DEFAULT_REWARD,
        "low_confidence_cost": DEFAULT_COST,
        "name": name,
    }
    fields.update(SPEC_SETTINGS.get(name, {}))
    return fields


def resolve_spec(item: str | Mapping[str, Any]) -> Spec:
    """A :class:`Spec` from a built-in name, a formula, or a mapping of Spec fields.

    Example:
        >>> resolve_spec("edge").formula
        'G(on_edge)'
        >>> resolve_spec({"formula": "F(a)", "terminal_reward": 5}).terminal_reward
        5.0
        >>> resolve_spec("avoid_top_right").reward_timing
        'every_step'
    """
    if isinstance(item, str):
        text = item.strip()
        if text in BUILTIN_SPECS:
            fields = _builtin_fields(text)
            return Spec(fields.pop("formula"), **fields)
        return Spec(text, terminal_reward=DEFAULT_REWARD, low_confidence_cost=DEFAULT_COST)
    if isinstance(item, Mapping):
        fields = dict(item)
        if "name" in fields and "formula" not in fields and fields["name"] in BUILTIN_SPECS:
            fields = {**_builtin_fields(fields["name"]), **fields}
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


#: The keys a spec may set in a specs file (or with ``--spec-set``): the
#: :class:`~noisybolt.bolt.Spec` fields, and ``reward_scale`` for the compliance scheme.
SPEC_FILE_KEYS: tuple[str, ...] = (
    "formula",
    "name",
    "low_confidence_cost",
    "reward_scale",
    "terminal_reward",
    "reward_timing",
)


def load_specs_file(path: str | os.PathLike[str]) -> list[str | dict[str, Any]]:
    """The specs of a YAML specs file: a list whose items are built-in names, formulas,
    or mappings of :data:`SPEC_FILE_KEYS` (a top-level mapping with a ``specs`` list too).

    Example file::

        specs:
          - edge                                  # a built-in spec
          - formula: F(top_right_corner) & F(bottom_left_corner)
            name: both_corners
            reward_scale: 500                     # compliance scheme: this spec's worth
          - formula: "!F(bottom_left_corner)"
            low_confidence_cost: 2.0

    Raises:
        ConfigError: the file is missing or not YAML, holds no list of specs, or an entry
            has an unknown key or no formula (the message names the entry).
    """
    file = Path(path)
    try:
        data = yaml.safe_load(file.read_text())
    except OSError as error:
        raise ConfigError(f"cannot read the specs file {file}: {error.strerror}") from None
    except yaml.YAMLError as error:
        raise ConfigError(f"the specs file {file} is not valid YAML: {error}") from None
    if isinstance(data, Mapping):
        unknown = sorted(set(data) - {"specs"})
        if unknown:
            raise ConfigError(f"{file}: unknown top-level key(s) {unknown}; expected 'specs'")
        data = data.get("specs")
    if not isinstance(data, list) or not data:
        raise ConfigError(f"{file} must hold a non-empty list of specs (or 'specs: [...]')")
    out: list[str | dict[str, Any]] = []
    for i, item in enumerate(data):
        where = f"{file}, spec {i + 1}"
        if isinstance(item, str):
            out.append(item)
            continue
        if not isinstance(item, Mapping):
            raise ConfigError(f"{where}: a spec is a name, a formula or a mapping, got {item!r}")
        unknown = sorted(map(str, set(item) - set(SPEC_FILE_KEYS)))  # YAML keys: any type
        if unknown:
            raise ConfigError(f"{where}: unknown key(s) {unknown}; known: {list(SPEC_FILE_KEYS)}")
        name = item.get("name")
        if "formula" not in item and not (isinstance(name, str) and name in BUILTIN_SPECS):
            raise ConfigError(f"{where}: give a formula (or the name of a built-in spec)")
        out.append(dict(item))
    return out


def expand_specs(items: Sequence[str | Mapping[str, Any]]) -> list[str | Mapping[str, Any]]:
    """``items`` with every group name of :data:`SPEC_GROUPS` replaced by its specs.

    Example:
        >>> expand_specs(["edge", "left_column_milestones"])[:3]
        ['edge', 'clear_left_column', 'left_row5']
    """
    out: list[str | Mapping[str, Any]] = []
    for item in items:
        if isinstance(item, str) and item.strip() in SPEC_GROUPS:
            out += SPEC_GROUPS[item.strip()]
        else:
            out.append(item)
    return out


def spec_fields(items: Sequence[Any], *, paper: bool) -> list[dict[str, Any]]:
    """Specs given by name, group, formula or mapping, as :class:`Spec` fields (plus a
    spec's own ``reward_scale``): what a run's config holds under ``bolt.specs``.

    Raises:
        ConfigError: a spec that sets what only the paper scheme pays (``terminal_reward``,
            ``reward_timing``) where ``paper`` is false; as :func:`parsed_spec`.
    """
    resolved = []
    for item in expand_specs(list(items)):
        scale = None
        if isinstance(item, Mapping):
            item = dict(item)
            scale = item.pop("reward_scale", None)
            paid_by_paper = sorted({"terminal_reward", "reward_timing"} & set(item))
            if paid_by_paper and not paper:
                raise ConfigError(
                    f"spec {item.get('name') or item.get('formula')!r} sets "
                    f"{paid_by_paper}, which only the paper reward scheme pays; under the "
                    "compliance scheme set reward_scale instead, or use --reward paper"
                )
        fields = asdict(parsed_spec(item))
        if scale is not None:
            fields["reward_scale"] = scale
        resolved.append(json.loads(json.dumps(fields)))
    return resolved


def parsed_spec(fields: str | Mapping[str, Any]) -> Spec:
    """:func:`resolve_spec`, with a formula nested beyond Python's recursion limit (which
    the parser recurses through) refused by name rather than by traceback."""
    try:
        return resolve_spec(fields)
    except RecursionError:
        formula = str(fields if isinstance(fields, str) else fields.get("formula", ""))
        raise SpecSyntaxError(
            f"formula {formula[:40]!r}... is nested too deeply to parse; write it with fewer "
            "nested operators (e.g. G(a & b) instead of G(a) & G(b) nested)",
            formula=formula,
        ) from None
