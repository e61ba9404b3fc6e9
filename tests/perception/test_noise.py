"""Noise models: what each does, seeded determinism, specs, and bad input."""

from __future__ import annotations

import doctest
import json

import numpy as np
import pytest

import noisybolt.perception.noise as noise
import noisybolt.perception.noise_base as noise_base
from noisybolt.envs.gridworld import GridworldCamera
from noisybolt.errors import ConfigError, UnknownNameError
from noisybolt.perception.noise import (
    Blur,
    Compose,
    GaussianNoise,
    NoNoise,
    OcclusionPatches,
    RegionalDegradation,
    SaltPepperNoise,
    known_noises,
    make_noise,
    parse_noise,
)

GREY = np.full((16, 24, 24, 3), 128, dtype=np.uint8)
ALL_MODELS = [
    NoNoise(),
    GaussianNoise(sigma=10),
    SaltPepperNoise(amount=0.1),
    Blur(sigma=1.5),
    OcclusionPatches(count=2, size=0.3),
    RegionalDegradation(),
    Compose(models=(Blur(sigma=0.5), GaussianNoise(sigma=5))),
]


def checker_images(n: int = 8) -> np.ndarray:
    board = (np.indices((24, 24)).sum(axis=0) % 2 * 255).astype(np.uint8)
    return np.repeat(np.repeat(board[None, :, :, None], 3, axis=3), n, axis=0)


@pytest.mark.parametrize("model", ALL_MODELS, ids=lambda m: m.name)
def test_every_model_is_seeded_shape_preserving_and_leaves_its_input(model) -> None:
    images = checker_images()
    before = images.copy()
    a = model.apply(images, np.random.default_rng(7))
    b = model.apply(images, np.random.default_rng(7))
    assert a.shape == images.shape and a.dtype == np.uint8
    assert np.array_equal(a, b)
    assert np.array_equal(images, before)


@pytest.mark.parametrize("model", ALL_MODELS, ids=lambda m: m.name)
def test_each_image_with_its_own_generator_is_each_applied_alone(model) -> None:
    images = np.random.default_rng(3).integers(0, 256, (5, 24, 24, 3), dtype=np.uint8)
    alone = [model.apply(images[i : i + 1], np.random.default_rng(i)) for i in range(5)]
    each = model.apply_each(images, [np.random.default_rng(i) for i in range(5)])
    assert np.array_equal(each, np.concatenate(alone))
    assert model.apply_each(images[:0], []).shape == (0, 24, 24, 3)
    with pytest.raises(ValueError, match="5 images need as many generators, got 4"):
        model.apply_each(images, [np.random.default_rng(i) for i in range(4)])


@pytest.mark.parametrize(
    "model",
    [m for m in ALL_MODELS if not isinstance(m, NoNoise | Blur)],
    ids=lambda m: m.name,
)
def test_different_seeds_give_different_noise(model) -> None:
    images = checker_images()
    a = model.apply(images, np.random.default_rng(1))
    b = model.apply(images, np.random.default_rng(2))
    assert not np.array_equal(a, b)


@pytest.mark.parametrize("model", ALL_MODELS, ids=lambda m: m.name)
def test_describe_round_trips_through_json(model) -> None:
    spec = json.loads(json.dumps(model.describe()))
    assert make_noise(spec) == model


def test_no_noise_is_the_identity() -> None:
    assert NoNoise().apply(GREY, np.random.default_rng(0)) is GREY


def test_gaussian_has_the_asked_spread_and_no_bias() -> None:
    out = GaussianNoise(sigma=12).apply(GREY, np.random.default_rng(0)).astype(float)
    assert out.std() == pytest.approx(12, rel=0.03)
    assert out.mean() == pytest.approx(128, abs=0.2)


def test_salt_and_pepper_hits_the_asked_fraction_of_pixels() -> None:
    out = SaltPepperNoise(amount=0.2, salt_ratio=0.25).apply(GREY, np.random.default_rng(0))
    white = (out == 255).all(axis=-1).mean()
    black = (out == 0).all(axis=-1).mean()
    assert white == pytest.approx(0.05, abs=0.01) and black == pytest.approx(0.15, abs=0.01)
    assert ((out == 128).all(axis=-1) | (out == 0).all(-1) | (out == 255).all(-1)).all()


def test_blur_keeps_flat_images_and_smooths_edges() -> None:
    assert np.array_equal(Blur(sigma=2).apply(GREY, np.random.default_rng(0)), GREY)
    board = checker_images(1)
    out = Blur(sigma=1).apply(board, np.random.default_rng(0)).astype(float)
    assert out.std() < 0.2 * board.astype(float).std()
    assert np.array_equal(Blur(sigma=0).apply(board, np.random.default_rng(0)), board)


def test_occlusion_draws_squares_of_the_asked_size_and_value() -> None:
    out = OcclusionPatches(count=1, size=0.25, value=7).apply(
        np.zeros((20, 24, 24, 3), np.uint8), np.random.default_rng(0)
    )
    assert ((out == 7).all(axis=-1).sum(axis=(1, 2)) == 36).all()  # 6x6 pixels each
    never = OcclusionPatches(count=3, probability=0.0).apply(GREY, np.random.default_rng(0))
    assert np.array_equal(never, GREY)


def test_regional_changes_only_its_box() -> None:
    model = RegionalDegradation(boxes=((0.5, 0.25, 1.0, 0.75),), sigma=20)
    images = checker_images()
    out = model.apply(images, np.random.default_rng(0))
    assert model.pixel_boxes(24, 24) == [(12, 6, 24, 18)]
    inside = np.zeros((24, 24), bool)
    inside[12:24, 6:18] = True
    assert np.array_equal(out[:, ~inside], images[:, ~inside])
    assert not np.array_equal(out[:, inside], images[:, inside])
    weaker = RegionalDegradation(boxes=model.boxes, sigma=20, strength=0.0)
    assert np.array_equal(weaker.apply(images, np.random.default_rng(0)), images)


def test_regional_contrast_and_blur_flatten_the_box() -> None:
    flat = RegionalDegradation(boxes=((0, 0, 1, 1),), contrast=0.0, sigma=0.0, shift=0.0)
    out = flat.apply(checker_images(2), np.random.default_rng(0))
    assert np.abs(out.astype(int) - 128).max() <= 1  # the box's mean colour everywhere


def _regional_step_by_step(
    model: RegionalDegradation, images: np.ndarray, rng: np.random.Generator
) -> np.ndarray:
    """The docstring's recipe, one operation at a time (the model fuses them)."""
    out = images.copy()
    for r0, c0, r1, c1 in model.pixel_boxes(*images.shape[1:3]):
        clean = images[:, r0:r1, c0:c1].astype(np.float64)
        n, h, w, _ = clean.shape
        if model.shift > 0:
            length = max(h, w)
            steps = rng.integers(0, max(1, round(model.shift * length)), size=n)
            axis = 2 if w >= h else 1
            patch = np.stack(
                [np.roll(p, s, axis=axis - 1) for p, s in zip(clean, steps, strict=True)]
            )
        else:
            patch = clean
        sigma = model.blur * min(h, w)
        if sigma > 0:  # separable Gaussian, edges repeated, as scipy's mode="nearest"
            radius = max(1, int(np.ceil(3 * sigma)))
            kernel = np.exp(-(np.arange(-radius, radius + 1) ** 2) / (2 * sigma**2))
            kernel /= kernel.sum()
            for axis in (1, 2):
                padded = np.pad(
                    patch,
                    [(radius, radius) if a == axis else (0, 0) for a in range(4)],
                    mode="edge",
                )
                size = patch.shape[axis]
                patch = sum(
                    k * np.take(padded, np.arange(i, i + size), axis=axis)
                    for i, k in enumerate(kernel)
                )
        mean = patch.mean(axis=(1, 2), keepdims=True)
        smudge = mean + model.contrast * (patch - mean)
        if model.sigma > 0:
            smudge += model.sigma * noise.standard_normal(rng, clean.shape)
        smudge = (1 - model.strength) * clean + model.strength * smudge
        out[:, r0:r1, c0:c1] = np.clip(np.floor(smudge + 0.5), 0, 255).astype(np.uint8)
    return out


@pytest.mark.parametrize(
    "settings",
    [
        {},  # the default: a wide box along the bottom floor row
        {"boxes": ((0.1, 0.2, 0.9, 0.4),)},  # a tall box: displaced along its height
        {"shift": 0.0},
        {"blur": 0.0, "contrast": 1.0},
        {"strength": 0.4, "sigma": 0.0},
        {"boxes": ((0, 0, 1, 1), (0.5, 0.5, 0.6, 0.9)), "shift": 0.3},
    ],
)
def test_regional_is_its_recipe_step_by_step(settings) -> None:
    model = RegionalDegradation(**settings)
    images = np.random.default_rng(1).integers(0, 256, (16, 48, 40, 3), dtype=np.uint8)
    got = model.apply(images, np.random.default_rng(5))
    want = _regional_step_by_step(model, images, np.random.default_rng(5))
    diff = np.abs(got.astype(int) - want.astype(int))
    # Same draws, same arithmetic up to float rounding: a pixel may round the other way.
    assert diff.max() <= 1
    assert (diff > 0).mean() < 1e-3


def _regional_channels_last(
    model: RegionalDegradation, images: np.ndarray, rng: np.random.Generator
) -> np.ndarray:
    """The model as it was before issue 16 moved its per-pixel steps to a channels-first
    layout: the same operations on a transposed view (the pixels Table 1 was made with)."""
    out = images.copy()
    for r0, c0, r1, c1 in model.pixel_boxes(*images.shape[1:3]):
        clean = images[:, r0:r1, c0:c1]
        smudge = model._displace_and_blur(clean, rng)
        n, channels, bh, bw = smudge.shape
        mean = smudge.reshape(n * channels, bh * bw).mean(axis=1)
        smudge *= model.contrast
        smudge += ((1.0 - model.contrast) * mean).reshape(n, channels, 1, 1)
        smudge = smudge.transpose(0, 2, 3, 1)
        if model.sigma > 0:
            draws = noise_base.uniform16(rng, clean.shape)
            smudge += noise_base.scaled_quantiles(model.sigma).take(draws)
        if model.strength < 1.0:
            smudge = (1.0 - model.strength) * clean.astype(np.float32) + model.strength * smudge
        out[:, r0:r1, c0:c1] = noise_base.to_uint8(smudge)
    return out


@pytest.mark.parametrize(
    "settings",
    [
        {},
        {"boxes": ((0.1, 0.2, 0.9, 0.4),)},
        {"strength": 0.4},
        {"sigma": 0.0, "shift": 0.0},
        {"boxes": ((0, 0, 1, 1), (0.5, 0.5, 0.6, 0.9)), "shift": 0.3},
    ],
)
def test_regional_gives_the_same_pixels_as_before_its_layout_change(settings) -> None:
    model = RegionalDegradation(**settings)
    images = np.random.default_rng(1).integers(0, 256, (16, 48, 40, 3), dtype=np.uint8)
    got = model.apply(images, np.random.default_rng(5))
    assert np.array_equal(got, _regional_channels_last(model, images, np.random.default_rng(5)))


def test_the_gridworld_camera_sees_the_same_pixels_as_before_the_layout_change() -> None:
    camera = GridworldCamera(noise="regional")
    rng = np.random.default_rng(0)
    x, y, d = rng.integers(1, 5, 64), rng.integers(1, 5, 64), rng.integers(0, 4, 64)
    got = camera.capture(x, y, d, rng=np.random.default_rng(7))
    model = camera.noise
    assert isinstance(model, RegionalDegradation)
    want = _regional_channels_last(model, camera.render(x, y, d), np.random.default_rng(7))
    assert np.array_equal(got, want)


def test_default_region_makes_the_corner_and_its_neighbours_look_alike() -> None:
    # With only the displacement left, the corner agent and the agent one or two cells
    # east show the same set of pictures: position under the smudge is unknowable, while
    # the picture outside the smudge and the agent's shape are untouched.
    shift_only = RegionalDegradation(blur=0.0, contrast=1.0, sigma=0.0)
    cam = GridworldCamera(size=6, tile_size=4, noise=shift_only)
    rng = np.random.default_rng(0)
    seen = []
    for x in (1, 2, 3):
        n = 400
        images = cam.capture(np.full(n, x), np.full(n, 4), np.full(n, 1), rng=rng)
        seen.append({img.tobytes() for img in images})
    assert len(seen[0]) == 12  # every displacement of the 12-pixel-wide strip
    assert seen[0] == seen[1] == seen[2]
    clean = cam.render(np.array([2]), np.array([2]), np.array([1]))
    assert {cam.capture(np.array([2]), np.array([2]), np.array([1]), rng=rng).tobytes()} == {
        clean.tobytes()
    }  # the agent elsewhere: nothing changes outside the strip


def test_compose_applies_in_order_with_one_generator() -> None:
    first = Compose(models=(OcclusionPatches(value=0, size=1.0), GaussianNoise(sigma=5)))
    out = first.apply(GREY, np.random.default_rng(0))
    assert 0 < out.mean() < 10  # noise on black, not black over noise
    rng = np.random.default_rng(3)
    by_hand = GaussianNoise(sigma=5).apply(
        OcclusionPatches(value=0, size=1.0).apply(GREY, rng), rng
    )
    assert np.array_equal(first.apply(GREY, np.random.default_rng(3)), by_hand)


# ------------------------------------------------------------------------ specs


def test_spec_formats_build_the_same_models() -> None:
    want = Compose(models=(GaussianNoise(sigma=12), SaltPepperNoise(amount=0.01)))
    assert make_noise("gaussian:sigma=12+salt_pepper:amount=0.01") == want
    assert (
        make_noise([{"name": "gaussian", "sigma": 12}, {"name": "salt_pepper", "amount": 0.01}])
        == want
    )
    assert make_noise(json.dumps(want.describe())) == want
    assert make_noise(want) is want
    assert make_noise(None) == make_noise("none") == NoNoise()
    assert make_noise(["blur"]) == Blur()
    assert parse_noise("regional:boxes=[[0.5,0,1,0.5]],sigma=3") == RegionalDegradation(
        boxes=((0.5, 0.0, 1.0, 0.5),), sigma=3
    )
    assert make_noise({"name": "compose", "models": ["gaussian"]}) == Compose(
        models=(GaussianNoise(),)
    )


def test_known_noises_lists_the_registry() -> None:
    assert known_noises() == (
        "blur",
        "gaussian",
        "none",
        "occlusion",
        "regional",
        "salt_pepper",
        "compose",
    )


@pytest.mark.parametrize("spec", ["fog", {"name": "fog"}, "gaussian+fog:level=3", ["none", "fog"]])
def test_unknown_names_list_the_known_ones(spec) -> None:
    with pytest.raises(UnknownNameError, match="gaussian") as info:
        make_noise(spec)
    assert info.value.name == "fog" and "regional" in info.value.known


@pytest.mark.parametrize(
    ("spec", "param"),
    [
        ({"name": "gaussian", "sigma": -1}, "sigma"),
        ({"name": "gaussian", "sigma": 300}, "sigma"),
        ({"name": "gaussian", "sigma": "big"}, "sigma"),
        ({"name": "gaussian", "sigma": float("nan")}, "sigma"),
        ({"name": "salt_pepper", "amount": 1.5}, "amount"),
        ({"name": "salt_pepper", "salt_ratio": -0.1}, "salt_ratio"),
        ({"name": "blur", "sigma": 40}, "sigma"),
        ({"name": "occlusion", "count": 2.5}, "count"),
        ({"name": "occlusion", "count": 100}, "count"),
        ({"name": "occlusion", "size": 0}, "size"),
        ({"name": "occlusion", "value": 256}, "value"),
        ({"name": "occlusion", "probability": 2}, "probability"),
        ({"name": "regional", "strength": 1.2}, "strength"),
        ({"name": "regional", "contrast": -1}, "contrast"),
        ({"name": "regional", "blur": 3}, "blur"),
        ({"name": "regional", "shift": 2}, "shift"),
        ({"name": "regional", "boxes": [[0.5, 0.5, 0.4, 1.0]]}, "boxes"),
        ({"name": "regional", "boxes": [[0, 0, 1]]}, "boxes"),
        ({"name": "regional", "boxes": []}, "boxes"),
        ({"name": "regional", "boxes": "corner"}, "boxes"),
        ({"name": "gaussian", "sigm": 3}, "sigm"),
        ({"name": "compose", "modles": []}, "modles"),
        ({"sigma": 3}, "name"),
        ("gaussian:sigma", "key=value"),
        ("{not json", "JSON"),
        (42, "noise spec"),
    ],
)
def test_bad_parameters_are_named(spec, param: str) -> None:
    with pytest.raises(ConfigError, match=param):
        make_noise(spec)


def test_bad_images_are_refused() -> None:
    with pytest.raises(ValueError, match="uint8"):
        GaussianNoise().apply(np.zeros((4, 4, 3), np.uint8), np.random.default_rng(0))
    with pytest.raises(ValueError, match="uint8"):
        Blur().apply(np.zeros((1, 4, 4, 3), np.float32), np.random.default_rng(0))


def test_public_api_and_docstring_examples() -> None:
    for name in noise.__all__:
        assert getattr(noise, name) is not None
    assert doctest.testmod(noise).failed == 0
