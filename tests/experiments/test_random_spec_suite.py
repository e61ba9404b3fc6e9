"""The random-spec suite (benchmarks/cartpole_specs.py) draws over any labelled world."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from types import ModuleType

from noisybolt.logic import compile_ltlf

ROOT = Path(__file__).resolve().parents[2]


def test_specs_are_drawn_over_the_worlds_own_fluents(
    load_script: Callable[..., ModuleType],
) -> None:
    bench = load_script("benchmarks/cartpole_specs.py")
    fluents = bench.world_fluents("examples.acrobot:make_acrobot")
    assert fluents == ("tip_high", "fast", "left", "right")
    specs = bench.draw_specs(6, 0, fluents=fluents)
    assert len({s["formula"] for s in specs}) == 6
    for spec in specs:
        dfa = compile_ltlf(spec["formula"], list(fluents))  # over these fluents only
        # Drawn again where the DFA accepts from the start for good or never can.
        assert not dfa.accepting_sinks[dfa.initial_state]
    # The same seed draws the same suite; CartPole's stays what it was.
    assert bench.draw_specs(6, 0, fluents=fluents) == specs
    kept = json.loads((ROOT / "results/cartpole_specs/two_seeds/suite.json").read_text())
    assert bench.draw_specs(12, 0) == kept  # the suite the results were measured on
