"""Datasets: collection and balance, file round trip, corruption and mismatch errors."""

from __future__ import annotations

import zipfile

import numpy as np
import pytest

from noisybolt.errors import ConfigError, CorruptFileError, IncompatibleError
from noisybolt.perception.dataset import (
    FluentDataset,
    balanced_subset,
    collect_samples,
    load_dataset,
    save_dataset,
)
from noisybolt.perception.protocols import CameraSpec


def _dataset(n: int = 20) -> FluentDataset:
    rng = np.random.default_rng(0)
    return FluentDataset(
        images=rng.integers(0, 256, (n, 6, 5, 3), dtype=np.uint8),
        labels=rng.random((n, 2)) < 0.5,
        fluent_names=("a", "b"),
        camera_spec=CameraSpec("toy", 6, 5, noise={"name": "gaussian", "sigma": (1, 2)}),
        seed=3,
        metadata={"note": "test"},
    )


def test_round_trip(tmp_path):
    data = _dataset()
    path = tmp_path / "d.npz"
    save_dataset(data, path)
    again = load_dataset(path)
    np.testing.assert_array_equal(again.images, data.images)
    np.testing.assert_array_equal(again.labels, data.labels)
    assert again.fluent_names == data.fluent_names
    assert again.seed == 3 and again.metadata == {"note": "test"}
    assert again.camera_spec.noise == {"name": "gaussian", "sigma": [1, 2]}
    # a tuple in the spec and a list after JSON must not count as a mismatch
    load_dataset(path, fluent_names=("a", "b"), camera_spec=data.camera_spec)
    assert not list(tmp_path.glob(".*tmp"))  # no temp file left behind


@pytest.mark.parametrize("cut", [0.1, 0.5, 0.9, 0.999])
def test_truncated_file_is_a_clear_error(tmp_path, cut):
    path = tmp_path / "d.npz"
    save_dataset(_dataset(), path)
    raw = path.read_bytes()
    path.write_bytes(raw[: int(len(raw) * cut)])
    with pytest.raises(CorruptFileError, match="truncated or corrupt"):
        load_dataset(path)


def test_flipped_bytes_are_a_clear_error(tmp_path):
    path = tmp_path / "d.npz"
    save_dataset(_dataset(200), path)
    raw = bytearray(path.read_bytes())
    raw[len(raw) // 3] ^= 0xFF  # inside the compressed images: zip CRC or inflate fails
    path.write_bytes(bytes(raw))
    with pytest.raises(CorruptFileError):
        load_dataset(path)


def test_foreign_files_are_refused(tmp_path):
    garbage = tmp_path / "g.npz"
    garbage.write_bytes(b"not a zip at all")
    with pytest.raises(CorruptFileError):
        load_dataset(garbage)
    other = tmp_path / "o.npz"
    np.savez(other, x=np.zeros(3))
    with pytest.raises(CorruptFileError, match="unexpected members"):
        load_dataset(other)
    # right members, wrong header
    data = _dataset()
    fake = tmp_path / "f.npz"
    with zipfile.ZipFile(fake, "w"):
        pass
    np.savez(
        fake,
        images=data.images,
        labels=data.labels,
        header=np.frombuffer(b'{"format": "x"}', np.uint8),
    )
    with pytest.raises(CorruptFileError, match="not a noisybolt"):
        load_dataset(fake)
    with pytest.raises(FileNotFoundError):
        load_dataset(tmp_path / "missing.npz")


def test_mismatch_with_the_world_is_named(tmp_path):
    data = _dataset()
    path = tmp_path / "d.npz"
    save_dataset(data, path)
    with pytest.raises(IncompatibleError, match=r"missing \['c'\]"):
        load_dataset(path, fluent_names=("a", "b", "c"), camera_spec=data.camera_spec)
    with pytest.raises(IncompatibleError, match="order"):
        load_dataset(path, fluent_names=("b", "a"), camera_spec=data.camera_spec)
    with pytest.raises(IncompatibleError, match="camera height"):
        load_dataset(
            path,
            fluent_names=("a", "b"),
            camera_spec=CameraSpec("toy", 7, 5, noise=data.camera_spec.noise),
        )
    with pytest.raises(IncompatibleError, match="camera noise"):
        load_dataset(path, fluent_names=("a", "b"), camera_spec=CameraSpec("toy", 6, 5))


def test_invalid_datasets_are_refused():
    data = _dataset()
    with pytest.raises(ValueError, match="uint8"):
        FluentDataset(data.images.astype(np.float32), data.labels, ("a", "b"), data.camera_spec)
    with pytest.raises(ValueError, match="camera spec"):
        FluentDataset(data.images, data.labels, ("a", "b"), CameraSpec("toy", 5, 5))
    with pytest.raises(ValueError, match="columns"):
        FluentDataset(data.images, data.labels, ("a",), data.camera_spec)
    with pytest.raises(ValueError, match="repeat"):
        FluentDataset(data.images, data.labels, ("a", "a"), data.camera_spec)


def test_split_is_seeded_and_disjoint():
    data = _dataset(50)
    train, val = data.split(0.2, seed=1)
    assert (len(train), len(val)) == (40, 10)
    again = data.split(0.2, seed=1)
    np.testing.assert_array_equal(again.validation.images, val.images)
    rows = {r.tobytes() for r in train.images} | {r.tobytes() for r in val.images}
    assert len(rows) == 50
    with pytest.raises(ConfigError):
        data.split(1.0, seed=0)
    with pytest.raises(ConfigError, match="empty"):
        _dataset(2).split(0.1, seed=0)


def test_balanced_subset_prefers_rare_values():
    rng = np.random.default_rng(0)
    m = 4000
    labels = np.zeros((m, 3), dtype=bool)
    labels[:, 0] = rng.random(m) < 0.05  # rare positive
    labels[:, 1] = rng.random(m) < 0.95  # rare negative
    labels[:, 2] = rng.random(m) < 0.5
    picked = balanced_subset(labels, 1000, np.random.default_rng(1))
    assert len(np.unique(picked)) == 1000
    chosen = labels[picked]
    assert chosen[:, 0].sum() == labels[:, 0].sum()  # every rare positive taken
    assert (~chosen[:, 1]).sum() == (~labels[:, 1]).sum()  # every rare negative taken
    assert 0.35 < chosen[:, 2].mean() < 0.65
    with pytest.raises(ValueError):
        balanced_subset(labels, m + 1, rng)


def test_collect_balances_a_rare_fluent(make_line_world):
    world = make_line_world(
        num_envs=8, scripted=False
    )  # a random walk from cell 3: the ends are rare
    data = collect_samples(world, num_samples=200, seed=0, oversample=4)
    pool = data.metadata["pool_positives"]
    assert data.metadata["scripted_rounds"] == 0
    assert len(data) == 200
    for name in ("at_left", "at_right"):
        share_in_pool = pool[name] / data.metadata["pool_size"]
        assert data.positives[name] / 200 > min(0.4, 2 * share_in_pool)
    np.testing.assert_array_equal(  # labels are the truth of the images
        data.labels[:, 0], data.images[:, 0, 0, 0] == 255
    )


def test_collect_uses_scripted_states_and_is_seeded(make_line_world):
    a = collect_samples(make_line_world(), num_samples=64, seed=1, scripted_fraction=1.0)
    b = collect_samples(make_line_world(), num_samples=64, seed=1, scripted_fraction=1.0)
    assert a.metadata["scripted_rounds"] == a.metadata["rounds"]
    np.testing.assert_array_equal(a.images, b.images)
    np.testing.assert_array_equal(a.labels, b.labels)
    assert a.seed == 1 and a.camera_spec == CameraSpec("line", 8, 8)


def test_collect_settings_are_checked(line_world):
    with pytest.raises(ConfigError, match="num_samples"):
        collect_samples(line_world, num_samples=0, seed=0)
    with pytest.raises(ConfigError, match="oversample"):
        collect_samples(line_world, num_samples=5, seed=0, oversample=0.5)
    with pytest.raises(ConfigError, match="scripted_fraction"):
        collect_samples(line_world, num_samples=5, seed=0, scripted_fraction=2)
