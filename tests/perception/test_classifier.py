"""The trained classifier: learning, determinism, speed budget, persistence and bad files."""

from __future__ import annotations

import json
import struct

import numpy as np
import pytest
import torch

from noisybolt.errors import ConfigError, CorruptFileError, IncompatibleError
from noisybolt.perception.classifier import (
    ClassifierConfig,
    ClassifierDetector,
    load_classifier,
)
from noisybolt.perception.dataset import collect_samples
from noisybolt.perception.protocols import CameraSpec, FluentDetector
from noisybolt.perception.training import TrainingConfig, train_classifier

SPEC = CameraSpec("toy", 12, 10, noise={"name": "regional", "strength": 0.5})


@pytest.fixture
def detector() -> ClassifierDetector:
    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(0)
        return ClassifierDetector.untrained(
            fluent_names=("a", "b"), camera_spec=SPEC, config=ClassifierConfig(channels=(4, 8))
        )


def _images(n: int, seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).integers(0, 256, (n, *SPEC.shape), dtype=np.uint8)


def test_learns_a_separable_dataset(make_line_world):
    data = collect_samples(make_line_world(num_envs=8), num_samples=320, seed=0)
    result = train_classifier(
        data,
        config=ClassifierConfig(channels=(8, 16), pool=2, hidden=32),
        training=TrainingConfig(epochs=60, seed=0, target_accuracy=1.0),
        progress=False,
    )
    assert result.reached_target
    assert result.report.min_accuracy == 1.0
    for fluent in result.report.fluents:
        assert fluent.auroc == 1.0
    assert len(result.history) < 60
    assert result.detector.training["epochs_run"] == len(result.history)
    probs = result.detector.predict(data.images)
    assert ((probs >= 0.5) == data.labels).mean() > 0.99


def test_training_is_deterministic(make_line_world):
    data = collect_samples(make_line_world(num_envs=4), num_samples=64, seed=0)
    settings = {
        "config": ClassifierConfig(channels=(4,), pool=2, hidden=8),
        "training": TrainingConfig(epochs=2, seed=3),
        "progress": False,
    }
    state = torch.random.get_rng_state()
    first = train_classifier(data, **settings)
    assert torch.equal(state, torch.random.get_rng_state())  # global RNG untouched
    second = train_classifier(data, **settings)
    for (name, a), b in zip(
        first.detector.model.state_dict().items(),
        second.detector.model.state_dict().values(),
        strict=True,
    ):
        assert torch.equal(a, b), name


def test_training_does_not_depend_on_the_callers_thread_count(make_line_world):
    # With two torch threads the convolutions' gradient sums are split differently and the
    # weights came out different (by ~1e-8 after 3 epochs on this data) before training
    # fixed its own thread count; a cached classifier then depended on its process.
    data = collect_samples(make_line_world(num_envs=8), num_samples=1024, seed=0)
    settings = {
        "config": ClassifierConfig(channels=(16, 32), pool=2, hidden=32),
        "training": TrainingConfig(epochs=3, seed=0, batch_size=128),
        "progress": False,
    }
    before = torch.get_num_threads()
    weights = []
    try:
        for threads in (1, 2):
            torch.set_num_threads(threads)
            weights.append(train_classifier(data, **settings).detector.model.state_dict())
            assert torch.get_num_threads() == threads  # the caller's setting restored
    finally:
        torch.set_num_threads(before)
    for name, a in weights[0].items():
        assert torch.equal(a, weights[1][name]), name


def test_predict_contract(detector):
    assert isinstance(detector, FluentDetector) and not detector.needs_truth
    probs = detector.predict(_images(5))
    assert probs.shape == (5, 2) and probs.dtype == np.float32
    assert ((probs > 0) & (probs < 1)).all()
    detector.batch_size = 2  # batching must not change the answer
    np.testing.assert_allclose(detector.predict(_images(5)), probs, rtol=1e-6, atol=1e-7)
    with pytest.raises(ValueError, match="camera"):
        detector.predict(_images(2)[:, :10])
    with pytest.raises(ValueError, match="uint8"):
        detector.predict(_images(2).astype(np.float32))


def test_save_load_round_trip_gives_identical_predictions(detector, tmp_path):
    detector.training = {"note": "hello"}
    path = tmp_path / "c.safetensors"
    detector.save(path)
    again = load_classifier(path, fluent_names=("a", "b"), camera_spec=SPEC)
    np.testing.assert_array_equal(again.predict(_images(7)), detector.predict(_images(7)))
    assert again.config == detector.config
    assert again.camera_spec == SPEC and again.fluent_names == ("a", "b")
    assert again.training == {"note": "hello"}
    # The file is a plain safetensors file: the weights load without noisybolt or pickle.
    from safetensors.torch import load_file

    assert set(load_file(path)) == set(detector.model.state_dict())


def test_mismatched_world_is_refused_at_load(detector, tmp_path):
    path = tmp_path / "c.safetensors"
    detector.save(path)
    with pytest.raises(IncompatibleError, match=r"missing \['c'\]"):
        load_classifier(path, fluent_names=("a", "b", "c"), camera_spec=SPEC)
    with pytest.raises(IncompatibleError, match="fluent order"):
        load_classifier(path, fluent_names=("b", "a"), camera_spec=SPEC)
    other = CameraSpec("toy", 12, 10, noise={"name": "none"})
    with pytest.raises(IncompatibleError, match="camera noise differs"):
        load_classifier(path, fluent_names=("a", "b"), camera_spec=other)
    with pytest.raises(IncompatibleError, match="camera world differs") as info:
        load_classifier(
            path,
            fluent_names=("a", "b"),
            camera_spec=CameraSpec("breakout", 84, 84, noise=SPEC.noise),
        )
    assert "camera height differs" in str(info.value)  # every difference is named
    # deliberately evaluating under another noise
    load_classifier(path, fluent_names=("a", "b"), camera_spec=other, ignore={"noise"})


@pytest.mark.parametrize("cut", [4, 100, 0.5, -3])
def test_truncated_file_is_a_clear_error(detector, tmp_path, cut):
    path = tmp_path / "c.safetensors"
    detector.save(path)
    raw = path.read_bytes()
    keep = int(len(raw) * cut) if isinstance(cut, float) else cut
    path.write_bytes(raw[:keep])
    with pytest.raises(CorruptFileError, match="truncated or corrupt"):
        load_classifier(path)


def test_flipped_weight_byte_is_caught(detector, tmp_path):
    path = tmp_path / "c.safetensors"
    detector.save(path)
    raw = bytearray(path.read_bytes())
    raw[-5] ^= 0x01  # inside the last tensor's data
    path.write_bytes(bytes(raw))
    with pytest.raises(CorruptFileError, match="SHA-256"):
        load_classifier(path)


def test_foreign_and_tampered_headers_are_refused(detector, tmp_path):
    from safetensors.torch import save_file

    plain = tmp_path / "plain.safetensors"
    save_file({"w": torch.zeros(2)}, plain)
    with pytest.raises(CorruptFileError, match="without a noisybolt header"):
        load_classifier(plain)
    path = tmp_path / "c.safetensors"
    detector.save(path)
    raw = path.read_bytes()
    (length,) = struct.unpack("<Q", raw[:8])
    header = json.loads(raw[8 : 8 + length])
    ours = json.loads(header["__metadata__"]["noisybolt"])
    ours["config"]["hidden"] = 7  # architecture no longer fits the weights
    header["__metadata__"]["noisybolt"] = json.dumps(ours)
    text = json.dumps(header).encode()
    text += b" " * (-len(text) % 8)
    path.write_bytes(struct.pack("<Q", len(text)) + text + raw[8 + length :])
    with pytest.raises(CorruptFileError):
        load_classifier(path)
    with pytest.raises(FileNotFoundError):
        load_classifier(tmp_path / "missing.safetensors")


def test_bad_configs_are_refused():
    with pytest.raises(ConfigError, match="channels"):
        ClassifierConfig(channels=())
    with pytest.raises(ConfigError, match="epochs"):
        TrainingConfig(epochs=0)
    with pytest.raises(ConfigError, match="target_accuracy"):
        TrainingConfig(target_accuracy=1.5)
    with pytest.raises(ConfigError, match="distinct"):
        ClassifierDetector.untrained(fluent_names=("a", "a"), camera_spec=SPEC)
    with pytest.raises(ConfigError, match="patch"):
        ClassifierConfig(patch=0)


def test_tile_reading_trunk_sees_one_tile_per_first_layer_output(tmp_path):
    from noisybolt.perception.classifier import FluentNet

    config = ClassifierConfig(channels=(4, 8), patch=2)
    net = FluentNet(in_channels=3, n_fluents=2, config=config)
    first = net.trunk[0]
    assert first.kernel_size == (2, 2) and first.stride == (2, 2)
    # 12x10 image of 2-pixel tiles: a 6x5 grid of cells, kept at that size afterwards.
    assert net.trunk[:4](torch.zeros(1, 3, 12, 10)).shape == (1, 8, 6, 5)
    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(0)
        det = ClassifierDetector.untrained(fluent_names=("a", "b"), camera_spec=SPEC, config=config)
    det.save(tmp_path / "c.safetensors")
    loaded = load_classifier(tmp_path / "c.safetensors")
    assert loaded.config == config
    np.testing.assert_array_equal(loaded.predict(_images(4)), det.predict(_images(4)))


def test_configs_saved_before_patch_existed_still_load():
    old = {"channels": [16, 32, 32], "pool": 4, "hidden": 64}
    assert ClassifierConfig.from_dict(old) == ClassifierConfig()


@pytest.mark.parametrize(
    ("config", "height", "width"),
    [
        (ClassifierConfig(channels=(32, 32), patch=8), 48, 48),  # the gridworld's
        (ClassifierConfig(), 84, 84),  # Breakout's: stride-2 3x3 convolutions
        (ClassifierConfig(channels=(4, 8), patch=8), 84, 90),  # tiles that do not divide
        (ClassifierConfig(channels=(4, 8, 8), pool=3), 7, 9),  # odd sizes, pool 3
    ],
)
def test_fast_inference_is_the_network(config, height, width):
    from noisybolt.perception.classifier import FluentNet, images_to_tensor

    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(1)
        net = FluentNet(in_channels=3, n_fluents=5, config=config).eval()
    images = np.random.default_rng(2).integers(0, 256, (6, height, width, 3), dtype=np.uint8)
    with torch.inference_mode():
        want = net(images_to_tensor(images))
        got = net.infer(torch.from_numpy(images))
    torch.testing.assert_close(got, want, rtol=1e-5, atol=1e-5)


def test_fast_inference_follows_weight_updates(detector):
    # The derived matrices are cached: an optimiser step, a state-dict load and a
    # replaced parameter must each be seen by the next prediction.
    images = _images(4)
    before = detector.predict(images)
    net = detector.model
    optimiser = torch.optim.SGD(net.parameters(), lr=0.5)
    net.train()
    loss = net(torch.rand(4, 3, *SPEC.shape[:2])).sum()
    loss.backward()
    optimiser.step()
    stepped = detector.predict(images)
    assert not np.allclose(stepped, before)
    with torch.inference_mode():
        want = torch.sigmoid(net(torch.from_numpy(images).permute(0, 3, 1, 2).float() / 255))
    np.testing.assert_allclose(stepped, want.numpy(), rtol=1e-5, atol=1e-6)
    saved = {k: v.clone() for k, v in net.state_dict().items()}
    with torch.no_grad():
        net.head[2].bias.add_(3.0)
    assert not np.allclose(detector.predict(images), stepped)
    net.load_state_dict(saved)
    np.testing.assert_allclose(detector.predict(images), stepped, rtol=1e-6)
    net.head[2].bias = torch.nn.Parameter(net.head[2].bias.detach() - 3.0)
    assert (detector.predict(images) < stepped).all()
