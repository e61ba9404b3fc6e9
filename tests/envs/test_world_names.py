"""World names live in ``noisybolt.envs`` only: no other module spells one out."""

from __future__ import annotations

import ast
from pathlib import Path

from noisybolt.envs import DEFAULT_WORLD, known_worlds

SOURCE = Path(__file__).resolve().parents[2] / "src" / "noisybolt"


def test_no_world_name_is_hard_coded_outside_envs() -> None:
    names = set(known_worlds())
    assert DEFAULT_WORLD in names
    found = []
    for path in sorted(SOURCE.rglob("*.py")):
        if path.relative_to(SOURCE).parts[0] == "envs":
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Constant) and node.value in names:
                found.append(f"{path.relative_to(SOURCE)}:{node.lineno} {node.value!r}")
    assert found == []
