"""Checks that a saved dataset or classifier fits the world it is used with.

A classifier trained on one camera (resolution, world, noise) silently gives garbage on
another, and one trained for other fluents silently mislabels its columns. So loading
against a world compares fluent names (and their order) and the camera spec, and raises
:class:`~noisybolt.errors.IncompatibleError` naming every difference.
"""

from __future__ import annotations

import json
from collections.abc import Collection, Sequence
from dataclasses import asdict
from typing import Any

from noisybolt.errors import IncompatibleError
from noisybolt.perception.protocols import CameraSpec

__all__ = ["camera_spec_from_dict", "camera_spec_to_dict", "check_compatible"]

_CAMERA_FIELDS = ("world", "height", "width", "channels", "noise", "extra")


def camera_spec_to_dict(spec: CameraSpec) -> dict[str, Any]:
    """The spec as plain JSON types (tuples become lists), so specs compare after a save.

    Raises:
        TypeError: if the spec's ``noise`` or ``extra`` hold values JSON cannot represent.
    """
    result: dict[str, Any] = json.loads(json.dumps(asdict(spec), sort_keys=True))
    return result


def camera_spec_from_dict(data: Any) -> CameraSpec:
    """Rebuilds a :class:`CameraSpec` from :func:`camera_spec_to_dict`'s output.

    Raises:
        ValueError: if ``data`` is not such a dict.
    """
    if not isinstance(data, dict) or set(data) != set(_CAMERA_FIELDS):
        raise ValueError(f"a camera spec needs exactly the fields {_CAMERA_FIELDS}")
    for key in ("height", "width", "channels"):
        if not isinstance(data[key], int) or data[key] < 1:
            raise ValueError(f"camera spec {key} must be a positive integer, got {data[key]!r}")
    if not isinstance(data["world"], str):
        raise ValueError("camera spec world must be a string")
    if not isinstance(data["noise"], dict) or not isinstance(data["extra"], dict):
        raise ValueError("camera spec noise and extra must be dicts")
    return CameraSpec(**data)


def check_compatible(
    what: str,
    *,
    fluent_names: Sequence[str],
    camera_spec: CameraSpec,
    expected_fluents: Sequence[str],
    expected_camera: CameraSpec,
    ignore: Collection[str] = (),
) -> None:
    """Raises unless the fluents and camera of ``what`` equal the expected ones.

    Args:
        what: what is being checked, for the message (e.g. ``"classifier 'c.safetensors'"``).
        fluent_names: the fluents it was made for, in column order.
        camera_spec: the camera it was made for.
        expected_fluents: the world's fluents, in column order.
        expected_camera: the world's camera.
        ignore: camera fields not to compare (e.g. ``{"noise"}`` to evaluate a classifier
            trained on clean images under noise, on purpose).

    Raises:
        IncompatibleError: naming each difference.
    """
    unknown = set(ignore) - set(_CAMERA_FIELDS)
    if unknown:
        raise ValueError(f"cannot ignore {sorted(unknown)}; camera fields: {_CAMERA_FIELDS}")
    problems = []
    have, want = tuple(fluent_names), tuple(expected_fluents)
    if have != want:
        missing = [f for f in want if f not in have]
        extra = [f for f in have if f not in want]
        if missing or extra:
            problems.append(
                f"fluents differ (missing {missing}, not in the world {extra}; "
                f"it has {list(have)}, the world {list(want)})"
            )
        else:
            problems.append(f"fluent order differs: it has {list(have)}, the world {list(want)}")
    mine, theirs = camera_spec_to_dict(camera_spec), camera_spec_to_dict(expected_camera)
    for key in _CAMERA_FIELDS:
        if key not in ignore and mine[key] != theirs[key]:
            problems.append(
                f"camera {key} differs: it has {mine[key]!r}, the world {theirs[key]!r}"
            )
    if problems:
        raise IncompatibleError(
            f"{what} does not match the world: "
            + "; ".join(problems)
            + ". Collect and train for this world and camera, or use the matching world."
        )
