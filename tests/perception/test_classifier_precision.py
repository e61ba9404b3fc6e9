"""The classifier's bfloat16 inference: the same network to bfloat16 rounding, chosen by CPU."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from noisybolt.errors import ConfigError
from noisybolt.perception import classifier as classifier_module
from noisybolt.perception.classifier import (
    ClassifierConfig,
    ClassifierDetector,
    FluentNet,
    fast_inference_dtype,
    images_to_tensor,
)
from noisybolt.perception.protocols import CameraSpec

GRID = ClassifierConfig(channels=(32, 32), patch=8)  # the gridworld's on-the-fly trunk
SPEC = CameraSpec("toy", 48, 48)


def _net() -> FluentNet:
    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(3)
        return FluentNet(in_channels=3, n_fluents=5, config=GRID).eval()


def _images(n: int) -> np.ndarray:
    return np.random.default_rng(4).integers(0, 256, (n, 48, 48, 3), dtype=np.uint8)


def test_bfloat16_inference_is_the_network_to_bfloat16_rounding() -> None:
    net, images = _net(), _images(16)
    with torch.inference_mode():
        want = net(images_to_tensor(images))
        full = net.infer(torch.from_numpy(images))
        half = net.infer(torch.from_numpy(images), dtype=torch.bfloat16)
    assert half.dtype == torch.float32  # the head runs in float32
    torch.testing.assert_close(full, want, rtol=1e-5, atol=1e-5)
    # 8 significant bits per operand, float32 accumulation: ~1 % of the logits' scale.
    scale = float(want.abs().max())
    assert float((half - want).abs().max()) <= 0.02 * scale
    assert not torch.equal(half, full)  # it really ran in bfloat16


def test_the_detector_runs_the_precision_it_is_given() -> None:
    net, images = _net(), _images(8)
    names = ("a", "b", "c", "d", "e")
    full = ClassifierDetector(model=net, fluent_names=names, camera_spec=SPEC, config=GRID,
                              precision="float32")  # fmt: skip
    half = ClassifierDetector(model=net, fluent_names=names, camera_spec=SPEC, config=GRID,
                              precision="bfloat16")  # fmt: skip
    with torch.inference_mode():
        want = torch.sigmoid(net(images_to_tensor(images))).numpy()
    np.testing.assert_allclose(full.predict(images), want, rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(half.predict(images), want, atol=0.01)
    assert not np.array_equal(half.predict(images), full.predict(images))


def test_an_unknown_precision_is_refused() -> None:
    with pytest.raises(ConfigError, match="precision must be one of"):
        ClassifierDetector(model=_net(), fluent_names=("a",) * 1, camera_spec=SPEC,
                           precision="fp8")  # fmt: skip


@pytest.mark.parametrize(
    ("amx", "avx512_bf16", "expected"),
    [
        (True, False, torch.bfloat16),
        (False, True, torch.bfloat16),
        (False, False, torch.float32),
    ],
)
def test_auto_precision_is_bfloat16_only_on_a_cpu_that_multiplies_it_natively(
    monkeypatch: pytest.MonkeyPatch, amx: bool, avx512_bf16: bool, expected: torch.dtype
) -> None:
    monkeypatch.setattr(torch.cpu, "_is_amx_tile_supported", lambda: amx, raising=False)
    monkeypatch.setattr(torch.cpu, "_is_avx512_bf16_supported", lambda: avx512_bf16, raising=False)
    assert fast_inference_dtype() == expected
    detector = ClassifierDetector(
        model=_net(), fluent_names=("a", "b", "c", "d", "e"), camera_spec=SPEC, config=GRID
    )
    assert detector._dtype == expected
    assert classifier_module.PRECISIONS[0] == "auto" == detector.precision


def test_auto_runs_small_calls_in_float32_and_large_ones_in_bfloat16(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(classifier_module, "fast_inference_dtype", lambda: torch.bfloat16)
    net, names = _net(), ("a", "b", "c", "d", "e")
    auto = ClassifierDetector(model=net, fluent_names=names, camera_spec=SPEC, config=GRID)
    full = ClassifierDetector(model=net, fluent_names=names, camera_spec=SPEC, config=GRID,
                              precision="float32")  # fmt: skip
    half = ClassifierDetector(model=net, fluent_names=names, camera_spec=SPEC, config=GRID,
                              precision="bfloat16")  # fmt: skip
    small = _images(classifier_module.BFLOAT16_MIN_BATCH - 1)
    large = _images(classifier_module.BFLOAT16_MIN_BATCH)
    np.testing.assert_array_equal(auto.predict(small), full.predict(small))
    np.testing.assert_array_equal(auto.predict(large), half.predict(large))
    assert not np.array_equal(auto.predict(large), full.predict(large))
