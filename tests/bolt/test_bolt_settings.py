"""The bolt's settings as one object: what each layer that builds a bolt is handed whole,
and the same bolt whether it is given the object or the keywords of old."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from noisybolt.bolt import (
    BeliefSettings,
    BoltSettings,
    RestrainingBolt,
    RewardScheme,
    Spec,
    Thresholds,
)
from noisybolt.bolt.settings import settings_from_keywords
from noisybolt.errors import ConfigError, UnknownNameError

FLUENTS = ("a", "b")


def test_a_scheme_pays_each_spec_at_its_scale_or_its_own() -> None:
    scheme = RewardScheme("compliance", scale=40.0)
    paid = BoltSettings(scheme=scheme, spec_scales=(None, 7.0)).paid(
        [Spec("F(a)"), Spec("G(!b)", reward_timing="episode_end")]
    )
    assert [(s.terminal_reward, s.reward_timing) for s in paid] == [
        (40.0, "on_change"),
        (7.0, "on_change"),
    ]
    # the low-confidence cost is the spec's own under every scheme
    assert paid[0].low_confidence_cost == Spec("F(a)").low_confidence_cost


def test_the_paper_scheme_pays_a_spec_as_it_says_and_adds_no_progress_terms() -> None:
    spec = Spec("F(a)", terminal_reward=3.0, reward_timing="episode_end")
    assert BoltSettings().paid([spec]) == [spec]
    assert BoltSettings().progress_terms([], []) is None


@pytest.mark.parametrize(
    ("fields", "named"),
    [
        ({"cost_mode": "sum"}, "cost_mode"),
        ({"thresholds": (0.5, 0.9)}, "thresholds"),
        ({"scheme": "compliance"}, "scheme"),
        (
            {"spec_scales": (1.0, -2.0), "scheme": RewardScheme("compliance", scale=1.0)},
            "spec_scales[1]",
        ),
        ({"spec_scales": (2.0,)}, "terminal_reward"),  # a scale under the paper scheme
        ({"progress_gamma": 0.0}, "progress_gamma"),
        ({"belief": BeliefSettings()}, "tracking='belief'"),
        ({"tracking": "belief", "cost_mode": "proportional"}, "proportional"),
        ({"end_on_violation": 1}, "end_on_violation"),
    ],
)
def test_a_bad_setting_is_refused_by_name(fields: dict, named: str) -> None:
    with pytest.raises(ConfigError, match=named.replace("[", r"\[").replace("]", r"\]")):
        BoltSettings(**fields)


def test_an_unknown_tracking_mode_is_refused_by_name() -> None:
    with pytest.raises(UnknownNameError, match="tracking"):
        BoltSettings(tracking="guess")  # type: ignore[arg-type]


def test_settings_and_keywords_together_are_refused() -> None:
    with pytest.raises(ConfigError, match=r"cost_mode=\.\.\. was given beside settings="):
        RestrainingBolt([Spec("F(a)")], FLUENTS, settings=BoltSettings(), cost_mode="proportional")
    # a keyword left at its default is no conflict
    bolt = RestrainingBolt([Spec("F(a)")], FLUENTS, settings=BoltSettings(), cost_mode="count")
    assert bolt.settings == BoltSettings()


def test_progress_gamma_as_a_keyword_is_the_compliance_scheme_at_each_specs_reward() -> None:
    specs = [Spec("F(a)", terminal_reward=5.0, reward_timing="on_change"), Spec("F(b)")]
    specs[1] = Spec("F(b)", terminal_reward=2.0, reward_timing="on_change")
    made = settings_from_keywords(
        None, {"progress_gamma": 1.0, "shaping": False}, owner="f", specs=specs
    )
    assert made.scheme.name == "compliance" and not made.scheme.shaping
    assert made.spec_scales == (5.0, 2.0)
    with pytest.raises(ConfigError, match="progress_gamma adds"):
        settings_from_keywords(None, {"progress_gamma": 1.0}, owner="f", specs=[Spec("F(a)")])


def _run(bolt: RestrainingBolt, probs: np.ndarray, dones: np.ndarray) -> list[float]:
    """Rewards of a run whose ended episodes restart on the next frame."""
    bolt.reset(probs[0])
    rewards = []
    for i in range(1, len(probs)):
        rewards.extend(bolt.step(probs[i], done=dones[i]).reward.tolist())
        if dones[i].any() and i + 1 < len(probs):
            bolt.reset(probs[i], env_mask=dones[i])
    return rewards


@settings(max_examples=25, deadline=None)
@given(
    seed=st.integers(0, 2**16),
    scheme=st.sampled_from(["paper", "compliance"]),
    high=st.floats(0.6, 0.95),
)
def test_a_bolt_given_settings_pays_as_one_given_the_same_keywords(
    seed: int, scheme: str, high: float
) -> None:
    rng = np.random.default_rng(seed)
    probs = rng.uniform(size=(12, 2, 2))
    dones = rng.uniform(size=(12, 2)) < 0.2
    thresholds = Thresholds(truth=0.5, high=high)
    specs = [Spec("F(a) & G(!b)"), Spec("G(a -> F(b))")]
    chosen = BoltSettings(
        thresholds=thresholds,
        scheme=RewardScheme(scheme, scale=None if scheme == "paper" else 10.0),
        cost_mode="proportional",
    )
    whole = RestrainingBolt(specs, FLUENTS, settings=chosen, n_envs=2)
    if scheme == "paper":
        by_keywords = RestrainingBolt(
            specs, FLUENTS, thresholds=thresholds, cost_mode="proportional", n_envs=2
        )
    else:  # the scheme by hand: specs paid at the scale, the same progress terms
        paid = chosen.paid(specs)
        plain = RestrainingBolt(paid, FLUENTS, n_envs=2)
        by_keywords = RestrainingBolt(
            paid,
            FLUENTS,
            dfas=plain.dfas,
            thresholds=thresholds,
            cost_mode="proportional",
            n_envs=2,
            shaping=chosen.progress_terms(plain.dfas, paid),
        )
    np.testing.assert_allclose(_run(whole, probs, dones), _run(by_keywords, probs, dones))
