"""Every bolt the library builds vets its specs, as the README says: an unsatisfiable spec
is refused (``UnsatisfiableSpecError``), a spec true of every trace gets one warning."""

from __future__ import annotations

import warnings
from typing import Any

import gymnasium as gym
import pytest

from noisybolt.bolt import Spec
from noisybolt.envs.labels import FluentLabels
from noisybolt.errors import UnsatisfiableSpecError
from noisybolt.logic import compile_ltlf
from noisybolt.wrappers import RestrainingBoltWrapper, make_bolted_vec_env

FLUENTS = {"at_goal": lambda lake: lake.s == 15, "top_row": lambda lake: lake.s < 4}
UNSATISFIABLE = "F(at_goal) & G(!at_goal)"
VACUOUS = "G(at_goal | !at_goal)"


def lake() -> FluentLabels:
    env = gym.make("FrozenLake-v1", render_mode="rgb_array", is_slippery=False)
    return FluentLabels(env, fluents=FLUENTS, success="at_goal")


def _single(specs: Any, **kwargs: Any) -> RestrainingBoltWrapper:
    return RestrainingBoltWrapper(lake(), specs, "oracle", **kwargs)


def _batched(specs: Any, **kwargs: Any) -> Any:
    return make_bolted_vec_env(lake, 2, specs, "oracle", seed=0, **kwargs)


@pytest.mark.parametrize("build", [_single, _batched], ids=["wrapper", "vec_env"])
@pytest.mark.parametrize("spec", [UNSATISFIABLE, Spec(UNSATISFIABLE, name="never")])
def test_an_unsatisfiable_spec_is_refused_at_construction(build: Any, spec: Any) -> None:
    with pytest.raises(UnsatisfiableSpecError, match=r"is unsatisfiable.*fix the formula") as error:
        build(["G(!top_row) | F(at_goal)", spec])
    assert error.value.formula == UNSATISFIABLE
    name = spec.name if isinstance(spec, Spec) else UNSATISFIABLE
    assert f"spec {name!r}" in str(error.value)


def test_an_unsatisfiable_dfa_given_to_the_wrapper_is_refused() -> None:
    dfa = compile_ltlf(UNSATISFIABLE, tuple(FLUENTS))
    with pytest.raises(UnsatisfiableSpecError):
        _single([UNSATISFIABLE], dfas=[dfa])


@pytest.mark.parametrize("build", [_single, _batched], ids=["wrapper", "vec_env"])
def test_a_spec_true_of_every_trace_is_warned_once(build: Any) -> None:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        env = build([VACUOUS, "F(at_goal)"])
        env.reset()
    said = [w for w in caught if "holds on every trace" in str(w.message)]
    assert [str(w.message) for w in said] == [
        f"spec {VACUOUS!r} holds on every trace ({VACUOUS!r}): the bolt asks for nothing"
    ]
    assert said[0].category is UserWarning


def test_a_spec_some_trace_violates_builds_silently() -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        _single(["G(!top_row) | F(at_goal)"]).reset(seed=0)
