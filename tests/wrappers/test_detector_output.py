"""A user's detector may return a list or a torch tensor: the bolt reads it and ``info``
keeps it as a float array; what it cannot read (ints, the wrong shape, a value outside
[0, 1]) is refused by name, naming the detector, before any reward is paid."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
import pytest
import torch

from noisybolt.envs.labels import FluentLabels
from noisybolt.errors import DetectorOutputError
from noisybolt.wrappers import RestrainingBoltWrapper, make_bolted_vec_env

FLUENTS = {"top": lambda lake: lake.s < 4, "left": lambda lake: lake.s % 4 == 0}


def _lake() -> FluentLabels:
    env = gym.make("FrozenLake-v1", render_mode="rgb_array", is_slippery=False)
    return FluentLabels(env, fluents=FLUENTS)


class _Returns:
    """Reads the truth surely (0.95 / 0.05), handing it back as ``kind`` says."""

    needs_truth = True
    fluent_names = tuple(FLUENTS)

    def __init__(self, kind: str) -> None:
        self.kind = kind

    def predict(self, images: np.ndarray, *, truth: np.ndarray | None = None) -> Any:
        assert truth is not None
        probs = np.where(truth, 0.95, 0.05)
        if self.kind == "list":
            return probs.tolist()
        if self.kind == "tensor":
            return torch.tensor(probs, dtype=torch.float32, requires_grad=True)
        if self.kind == "ints":
            return truth.astype(int)
        if self.kind == "one column":
            return probs[:, :1]
        if self.kind == "percent":
            return probs * 100
        raise AssertionError(self.kind)


@pytest.mark.parametrize("kind", ["list", "tensor"])
def test_lists_and_tensors_are_read_and_kept_as_arrays(kind: str) -> None:
    reference = RestrainingBoltWrapper(_lake(), ["G(top)"], _Returns("list"))
    _, expected = reference.reset(seed=0)
    bolted = RestrainingBoltWrapper(_lake(), ["G(top)"], _Returns(kind))
    _, info = bolted.reset(seed=0)
    assert isinstance(info["fluent_probs"], np.ndarray)
    np.testing.assert_allclose(info["fluent_probs"], [0.95, 0.95], rtol=1e-6)  # cell 0: both
    np.testing.assert_allclose(info["fluent_probs"], expected["fluent_probs"], rtol=1e-6)
    venv = make_bolted_vec_env(_lake, 2, ["G(top)"], _Returns(kind), seed=0)
    venv.reset()
    _, rewards, _, infos = venv.step(np.array([2, 1]))  # right along the top; down
    assert isinstance(infos[0]["fluent_probs"], np.ndarray)
    assert rewards.tolist() == [2.0, 1.0]  # +1 carried from the reset; +1 if still on top


@pytest.mark.parametrize(
    ("kind", "said"),
    [
        ("ints", "floating-point array, got dtype int"),
        ("one column", "1 columns, expected n_fluents=2"),
        ("percent", "is 95.0; probabilities must be numbers in [0, 1]"),
    ],
)
def test_what_the_bolt_cannot_read_is_refused_by_name(kind: str, said: str) -> None:
    for build in (
        lambda: RestrainingBoltWrapper(_lake(), ["G(top)"], _Returns(kind)).reset(seed=0),
        lambda: make_bolted_vec_env(_lake, 2, ["G(top)"], _Returns(kind), seed=0).reset(),
    ):
        with pytest.raises(DetectorOutputError) as caught:
            build()
        message = str(caught.value)
        assert message.startswith("_Returns.predict gave what the bolt cannot read")
        assert said in message and "['top', 'left']" in message
