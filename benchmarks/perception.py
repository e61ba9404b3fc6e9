"""The perception benchmark of the worlds issue, in one command: the bolt's camera and the
vectorised worlds (``perception_world.py``), then the fluent classifiers
(``perception_classifiers.py``). Each part prints its own table; see benchmarks/README.md.

    .venv/bin/python benchmarks/perception.py
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import perception_classifiers
import perception_world


def main() -> int:
    """Runs both parts with their default settings."""
    code = perception_world.main([])
    return code or perception_classifiers.main([])


if __name__ == "__main__":
    raise SystemExit(main())
