"""A Spec's rewards default to the paper's, the same a formula given as text gets."""

from __future__ import annotations

from noisybolt.bolt import Spec
from noisybolt.bolt.spec import DEFAULT_COST, DEFAULT_REWARD
from noisybolt.runs import specs as agent_specs
from noisybolt.wrappers._inputs import coerce_specs


def test_a_spec_of_a_formula_alone_gets_the_papers_rewards() -> None:
    spec = Spec("G(x)")
    assert (spec.terminal_reward, spec.low_confidence_cost) == (1.0, 0.5)
    assert (spec.reward_timing, spec.name) == ("every_step", "G(x)")
    assert (DEFAULT_REWARD, DEFAULT_COST) == (1.0, 0.5)


def test_the_defaults_are_one_pair_of_constants_seen_everywhere() -> None:
    assert agent_specs.DEFAULT_REWARD is DEFAULT_REWARD
    assert agent_specs.DEFAULT_COST is DEFAULT_COST
    assert agent_specs.resolve_spec("G(x)") == Spec("G(x)")
    assert coerce_specs("G(x)") == [Spec("G(x)")]


def test_one_default_may_be_replaced_alone() -> None:
    spec = Spec("G(x)", low_confidence_cost=0.0)
    assert (spec.terminal_reward, spec.low_confidence_cost) == (1.0, 0.0)
