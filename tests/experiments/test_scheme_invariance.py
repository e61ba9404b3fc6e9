"""Progress shaping never changes the optimal policy: value iteration on the gridworld's product."""

from __future__ import annotations

import numpy as np
import pytest

from noisybolt.experiments.optimal import (
    exact_compliance_scale,
    optimal_constrained_return,
    scheme_optimum,
    scheme_q_values,
)
from noisybolt.experiments.spec_families import generate_spec_suite

SPECS = [
    "F(top_right_corner) & F(bottom_left_corner)",
    "!F(top_right_corner)",
    "G(on_edge)",
    "G(top_right_corner -> F(bottom_left_corner))",
    "F(top_right_corner & X(!F(top_right_corner)))",
]


@pytest.mark.parametrize("formula", SPECS)
@pytest.mark.parametrize("gamma", [0.9, 0.99, 1.0])
def test_shaping_shifts_every_action_value_of_a_state_alike(formula: str, gamma: float) -> None:
    plain = scheme_q_values([formula], scale=50.0, gamma=gamma, shaping=False)
    shaped = scheme_q_values([formula], scale=50.0, gamma=gamma, shaping=True)
    shift = plain - shaped  # Ng et al.: Q_shaped(s, a) = Q(s, a) - Phi(s), the same for all a
    assert np.ptp(shift, axis=-1).max() < 1e-9
    # Hence the same optimal actions (up to ties within rounding).
    best_plain = plain >= plain.max(axis=-1, keepdims=True) - 1e-9
    best_shaped = shaped >= shaped.max(axis=-1, keepdims=True) - 1e-9
    assert np.array_equal(best_plain, best_shaped)


@pytest.mark.parametrize("formula", SPECS)
def test_paying_on_change_shifts_every_undiscounted_action_value_of_a_state_alike(
    formula: str,
) -> None:
    # Undiscounted, paying acceptance as it is gained (and taken back as it is lost) rather
    # than at the end moves no payment between episodes: Q_change(s, a) = Q_end(s, a) -
    # (what is held in s).
    at_end = scheme_q_values([formula], scale=50.0, gamma=1.0, shaping=True, pay_on_change=False)
    on_change = scheme_q_values([formula], scale=50.0, gamma=1.0, shaping=True)
    shift = at_end - on_change
    assert np.ptp(shift, axis=-1).max() < 1e-9
    assert set(np.round(np.unique(shift), 9)) == {0.0, 50.0}


def test_the_exact_scale_makes_the_discounted_optimum_comply_on_generated_specs() -> None:
    for spec in generate_spec_suite(n_specs=6, seed=3):
        scale = exact_compliance_scale([spec.formula], gamma=0.99, floor=31.45, cap=345.95)
        assert scale is not None
        optimum = scheme_optimum([spec.formula], scale=scale, gamma=0.99)
        assert optimum.complies and optimum.reaches_goal, spec.formula
        assert optimum.env_return == pytest.approx(spec.rc_max)


def test_a_scale_too_small_lets_the_shortcut_win() -> None:
    # The detour by both corners costs 9 steps (13.5): a spec worth 5 is not worth it.
    formula = "F(top_right_corner) & F(bottom_left_corner)"
    assert optimal_constrained_return([formula], require_goal=True).steps == 16
    assert not scheme_optimum([formula], scale=5.0, gamma=0.99).complies
    assert scheme_optimum([formula], scale=60.0, gamma=0.99).complies
