"""The trained fluent classifier: a small CNN with one sigmoid output per fluent.

:class:`FluentNet` shares one convolutional trunk between all fluents (three strided 3x3
convolutions, an adaptive average pool to a fixed grid so the position of things survives,
then a small dense head with ``k`` logits). :class:`ClassifierDetector` wraps a trained
net with the fluent names and the :class:`CameraSpec` it was trained for, and meets the
:class:`~noisybolt.perception.protocols.FluentDetector` protocol.

File format (one ``.safetensors`` file, written atomically): the network's tensors, and in
the safetensors header's ``__metadata__`` one entry ``"noisybolt"`` holding a JSON object
with ``format`` (``"noisybolt.fluent_classifier"``), ``version`` (1), ``fluent_names``,
``camera_spec`` (world, size, noise settings), ``config`` (the architecture),
``training`` (free-form JSON notes) and ``tensor_sha256`` (a digest of every tensor's
bytes, so a flipped bit in the weights is caught at load). Nothing is pickled.

Example:
    >>> import numpy as np, tempfile, pathlib, torch
    >>> from noisybolt.perception.protocols import BoltObservable, CameraSpec
    >>> _ = torch.manual_seed(0)
    >>> spec = CameraSpec("toy", 16, 16)
    >>> detector = ClassifierDetector.untrained(fluent_names=("a", "b"), camera_spec=spec)
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "c.safetensors"
    >>> detector.save(path)
    >>> again = ClassifierDetector.load(path, fluent_names=("a", "b"), camera_spec=spec)
    >>> images = np.zeros((3, 16, 16, 3), np.uint8)
    >>> bool(np.array_equal(detector.predict(images), again.predict(images)))
    True
"""

from __future__ import annotations

import hashlib
import json
import struct
from collections.abc import Collection, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import torch
from safetensors.torch import load as load_safetensors
from safetensors.torch import save as save_safetensors
from torch import nn

from noisybolt.errors import ConfigError, CorruptFileError
from noisybolt.io import atomic_write_bytes
from noisybolt.perception.compat import (
    camera_spec_from_dict,
    camera_spec_to_dict,
    check_compatible,
)
from noisybolt.perception.protocols import BoltObservable, CameraSpec

__all__ = [
    "BFLOAT16_MIN_BATCH",
    "CLASSIFIER_FORMAT",
    "CLASSIFIER_VERSION",
    "ClassifierConfig",
    "ClassifierDetector",
    "FluentNet",
    "fast_inference_dtype",
    "images_to_tensor",
    "load_classifier",
]

CLASSIFIER_FORMAT = "noisybolt.fluent_classifier"
CLASSIFIER_VERSION = 1


@dataclass(frozen=True)
class ClassifierConfig:
    """The architecture of a :class:`FluentNet`.

    Attributes:
        channels: output channels of each convolution.
        pool: side of the grid the trunk's features are averaged to before the head.
        hidden: width of the dense hidden layer.
        patch: None for a trunk of stride-2 3x3 convolutions; an integer ``p`` for a
            camera drawn in tiles of ``p`` pixels: the first convolution then reads one
            whole tile per output (kernel and stride ``p``) and the rest are 3x3 stride-1
            convolutions over the grid of cells. It costs about a quarter of the default
            trunk's multiply-adds on the gridworld's 48x48 camera.
    """

    channels: tuple[int, ...] = (16, 32, 32)
    pool: int = 4
    hidden: int = 64
    patch: int | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "channels", tuple(int(c) for c in self.channels))
        if not self.channels or min(self.channels) < 1:
            raise ConfigError(
                f"channels must be a non-empty tuple of positive ints, got {self.channels}"
            )
        if self.pool < 1 or self.hidden < 1:
            raise ConfigError(f"pool and hidden must be positive, got {self.pool}, {self.hidden}")
        if self.patch is not None and int(self.patch) < 1:
            raise ConfigError(f"patch must be None or a positive pixel count, got {self.patch}")

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> ClassifierConfig:
        """The config from :func:`dataclasses.asdict` output (as saved in a file)."""
        patch = data.get("patch")  # absent from files written before it existed
        return cls(
            channels=tuple(data["channels"]),
            pool=int(data["pool"]),
            hidden=int(data["hidden"]),
            patch=None if patch is None else int(patch),
        )


class FluentNet(nn.Module):
    """CNN trunk shared by all fluents, one logit per fluent.

    Input: float ``[n, C, H, W]`` in [0, 1]. Output: logits ``[n, k]``.
    """

    def __init__(self, *, in_channels: int, n_fluents: int, config: ClassifierConfig) -> None:
        super().__init__()
        self.config = config
        self._plans: dict[tuple[int, int, torch.dtype], _InferencePlan] = {}
        layers: list[nn.Module] = []
        previous = in_channels
        for i, channels in enumerate(config.channels):
            if config.patch is None:
                conv = nn.Conv2d(previous, channels, 3, stride=2, padding=1)
            elif i == 0:
                conv = nn.Conv2d(previous, channels, config.patch, stride=config.patch)
            else:
                conv = nn.Conv2d(previous, channels, 3, stride=1, padding=1)
            layers += [conv, nn.ReLU()]
            previous = channels
        # Average to a fixed grid rather than globally: where a thing is in the image
        # (a corner, the left column) is what most fluents are about.
        layers += [nn.AdaptiveAvgPool2d(config.pool), nn.Flatten()]
        self.trunk = nn.Sequential(*layers)
        self.head = nn.Sequential(
            nn.Linear(previous * config.pool * config.pool, config.hidden),
            nn.ReLU(),
            nn.Linear(config.hidden, n_fluents),
        )

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """Logits ``[n, k]`` for float images ``[n, C, H, W]``."""
        out: torch.Tensor = self.head(self.trunk(x))
        return out

    def infer(self, images: torch.Tensor, *, dtype: torch.dtype = torch.float32) -> torch.Tensor:
        """Logits ``[n, k]`` for uint8 images ``[n, H, W, C]`` (channels last), no grad.

        The same function as ``forward(images_to_tensor(images))`` to float rounding
        (tested), written for the bolt's per-step call on a handful of small images, where
        torch's convolution and adaptive pooling spend most of their time outside the
        arithmetic (a 3x3 convolution over 8 images of 6x6 cells: 85 us; the pool: 50 us).
        Here every convolution is one matrix product over patches unfolded from the
        channels-last activations, the 1/255 scaling is folded into the first layer and
        the (linear) pool into the first dense layer. The derived weight matrices are
        cached and rebuilt whenever a parameter changes (``Tensor._version``), so it always
        agrees with the current weights.

        ``dtype`` is the convolutions' number format: ``torch.bfloat16`` multiplies about
        six times faster than float32 on a CPU with bfloat16 matrix units (AMX,
        AVX512-BF16) and far slower on one without (see :func:`fast_inference_dtype`).
        Pixels (integers 0..255) are exact in bfloat16; the weights and activations are
        rounded to 8 significant bits, and the products accumulate in float32. The dense
        head always runs in float32.
        """
        n, height, width, _ = images.shape
        plan = self._inference_plan(height, width, dtype)
        x = images
        for i, (weight, bias, kernel, stride, padding) in enumerate(plan.convs):
            if padding:
                x = nn.functional.pad(x, (0, 0, padding, padding, padding, padding))
            # [n, rows, cols, C, kh, kw] -> (kh, kw, C) innermost: copies contiguous runs.
            patches = x.unfold(1, kernel, stride).unfold(2, kernel, stride)
            rows, cols = patches.shape[1:3]
            # The first layer's copy moves uint8 pixels, a quarter of the bytes of floats.
            patches = patches.permute(0, 1, 2, 4, 5, 3).reshape(n * rows * cols, -1)
            if i == 0:
                patches = patches.to(dtype)
            x = torch.addmm(bias, patches, weight).relu_()
            x = x.reshape(n, rows, cols, -1)
        x = torch.addmm(plan.hidden_bias, x.reshape(n, -1).float(), plan.hidden).relu_()
        return torch.addmm(plan.out_bias, x, plan.out)

    def _inference_plan(
        self, height: int, width: int, dtype: torch.dtype = torch.float32
    ) -> _InferencePlan:
        # Which tensors, and how often modified in place (optimiser steps,
        # load_state_dict); cheaper than walking self.parameters() on every call. The
        # plan holds the tensors themselves, so their ids cannot be reused while it lives.
        sources = tuple(
            tensor
            for layer in (*self.trunk, *self.head)
            if isinstance(layer, nn.Conv2d | nn.Linear)
            for tensor in (layer.weight, layer.bias)
            if tensor is not None
        )
        versions = tuple((id(tensor), tensor._version) for tensor in sources)
        cached = self._plans.get((height, width, dtype))
        if cached is not None and cached.versions == versions:
            return cached
        with torch.no_grad():
            convs: list[tuple[torch.Tensor, torch.Tensor, int, int, int]] = []
            scale = 1.0 / 255.0
            h, w = height, width
            for layer in self.trunk:
                if not isinstance(layer, nn.Conv2d):
                    continue
                # FluentNet's convolutions are square, with integer padding and a bias.
                kernel, stride = layer.kernel_size[0], layer.stride[0]
                padding = int(layer.padding[0])
                assert layer.bias is not None
                matrix = (
                    layer.weight.permute(2, 3, 1, 0).reshape(-1, layer.out_channels) * scale
                ).contiguous()
                convs.append(
                    (
                        matrix.to(dtype),
                        layer.bias.detach().to(dtype, copy=True),
                        kernel,
                        stride,
                        padding,
                    )
                )
                scale = 1.0
                h = (h + 2 * padding - kernel) // stride + 1
                w = (w + 2 * padding - kernel) // stride + 1
            channels = convs[-1][0].shape[1]
            hidden, out = self.head[0], self.head[2]
            assert isinstance(hidden, nn.Linear) and isinstance(out, nn.Linear)
            pool = self.config.pool
            # hidden(flatten(pool(x))) is linear in x: one matrix over the NHWC activations.
            folded = torch.einsum(
                "kcij,ai,bj->kabc",
                hidden.weight.reshape(-1, channels, pool, pool),
                _adaptive_pool_matrix(h, pool),
                _adaptive_pool_matrix(w, pool),
            )
            plan = _InferencePlan(
                sources=sources,
                versions=versions,
                convs=tuple(convs),
                hidden=folded.reshape(folded.shape[0], -1).t().contiguous(),
                hidden_bias=hidden.bias.detach().clone(),
                out=out.weight.detach().t().contiguous(),
                out_bias=out.bias.detach().clone(),
            )
        self._plans[(height, width, dtype)] = plan
        return plan


@dataclass(frozen=True)
class _InferencePlan:
    """:meth:`FluentNet.infer`'s weights for one input size, as matrices."""

    sources: tuple[torch.Tensor, ...]
    versions: tuple[tuple[int, int], ...]
    convs: tuple[tuple[torch.Tensor, torch.Tensor, int, int, int], ...]
    hidden: torch.Tensor
    hidden_bias: torch.Tensor
    out: torch.Tensor
    out_bias: torch.Tensor


def _adaptive_pool_matrix(size: int, bins: int) -> torch.Tensor:
    """``[size, bins]``: column ``i`` averages the inputs of adaptive pooling's bin ``i``."""
    matrix = torch.zeros(size, bins)
    for i in range(bins):
        start, end = (i * size) // bins, -((-(i + 1) * size) // bins)
        matrix[start:end, i] = 1.0 / (end - start)
    return matrix


#: ``ClassifierDetector.precision`` values.
PRECISIONS: tuple[str, ...] = ("auto", "float32", "bfloat16")
#: The smallest call that ``precision="auto"`` runs in bfloat16. Inside PPO training on the
#: gridworld (variants interleaved every 2,048 frames, two rounds each), bfloat16 raised
#: the classifier bolt's share of the bare world's speed from 0.78 to 0.81 at 32
#: environments but lowered it from 0.74 to 0.69 at 8, although alone it was faster at
#: both sizes (0.58 -> 0.32 ms for 8 images): the matrix units' set-up between the
#: policy's own float32 calls costs more than a small product saves.
BFLOAT16_MIN_BATCH = 32


def fast_inference_dtype() -> torch.dtype:
    """The faster number format for :meth:`FluentNet.infer` on this CPU.

    ``torch.bfloat16`` where the CPU multiplies bfloat16 matrices natively (Intel AMX or
    AVX512-BF16: a batch of 32 gridworld images in 0.84 ms against 2.4 ms in float32),
    ``torch.float32`` elsewhere, where bfloat16 would be emulated and slower. On the
    gridworld's regional-noise classifier the two agreed on every truth value of 4,000
    fresh images (probabilities within 0.009; 2 of 28,000 confidence bands differed).
    """
    probes = ("_is_amx_tile_supported", "_is_avx512_bf16_supported")
    # Private torch probes (stable since 2.1); absent ones mean "no".
    native = any(bool(getattr(torch.cpu, name, lambda: False)()) for name in probes)
    return torch.bfloat16 if native else torch.float32


def images_to_tensor(images: np.ndarray) -> torch.Tensor:
    """uint8 ``[n, H, W, C]`` numpy images to float ``[n, C, H, W]`` in [0, 1]."""
    return torch.from_numpy(np.ascontiguousarray(images)).permute(0, 3, 1, 2).float().div_(255.0)


def _tensor_digest(tensors: dict[str, torch.Tensor]) -> str:
    digest = hashlib.sha256()
    for name in sorted(tensors):
        digest.update(name.encode("utf-8"))
        digest.update(tensors[name].detach().cpu().contiguous().numpy().tobytes())
    return digest.hexdigest()


@dataclass(eq=False)
class ClassifierDetector:
    """A trained :class:`FluentNet` as a fluent detector for one camera.

    Attributes:
        model: the network (kept in eval mode by :meth:`predict`).
        fluent_names: the fluents of its outputs, in column order.
        camera_spec: the camera it was trained on; :meth:`predict` refuses other shapes.
        config: the network's architecture.
        training: JSON-able notes on how it was trained (saved with it).
        batch_size: images per forward pass in :meth:`predict`.
        precision: the tile-reading trunk's number format in :meth:`predict`:
            ``"float32"``, ``"bfloat16"``, or ``"auto"``: bfloat16 for calls of at least
            :data:`BFLOAT16_MIN_BATCH` images where this CPU multiplies it natively
            (:func:`fast_inference_dtype`), float32 otherwise. Not saved with the file: it
            is how this machine runs the network, not part of it.
    """

    model: FluentNet
    fluent_names: tuple[str, ...]
    camera_spec: CameraSpec
    config: ClassifierConfig = field(default_factory=ClassifierConfig)
    training: dict[str, Any] = field(default_factory=dict)
    batch_size: int = 64
    precision: str = "auto"

    def __post_init__(self) -> None:
        if self.precision not in PRECISIONS:
            raise ConfigError(
                f"precision must be one of {list(PRECISIONS)}, got {self.precision!r}"
            )
        self._dtype = (
            fast_inference_dtype()
            if self.precision == "auto"
            else {"float32": torch.float32, "bfloat16": torch.bfloat16}[self.precision]
        )
        self.fluent_names = tuple(self.fluent_names)
        if len(set(self.fluent_names)) != len(self.fluent_names) or not self.fluent_names:
            raise ConfigError(f"fluent names must be non-empty and distinct: {self.fluent_names}")

    @property
    def training_prior(self) -> tuple[float, ...] | None:
        """Each fluent's frequency in the images it was trained on, in column order (the
        prior its probabilities carry); None for a file that did not record it."""
        freqs = self.training.get("label_frequencies")
        if not isinstance(freqs, dict) or set(freqs) != set(self.fluent_names):
            return None
        return tuple(float(freqs[name]) for name in self.fluent_names)

    @classmethod
    def untrained(
        cls,
        *,
        fluent_names: Sequence[str],
        camera_spec: CameraSpec,
        config: ClassifierConfig | None = None,
    ) -> ClassifierDetector:
        """A freshly initialised (torch's global RNG) detector, e.g. to train."""
        config = config or ClassifierConfig()
        model = FluentNet(
            in_channels=camera_spec.channels, n_fluents=len(fluent_names), config=config
        )
        return cls(
            model=model, fluent_names=tuple(fluent_names), camera_spec=camera_spec, config=config
        )

    @property
    def needs_truth(self) -> bool:
        """Always False: it looks at the images only."""
        return False

    def predict(self, images: np.ndarray, *, truth: np.ndarray | None = None) -> np.ndarray:
        """float32 ``[n, k]`` probabilities for uint8 images ``[n, H, W, C]``.

        ``truth`` is ignored (it is part of the detector protocol for cheating detectors).

        Raises:
            ValueError: if the images are not uint8 of the camera's shape.
        """
        del truth
        images = np.asarray(images)
        if (
            images.dtype != np.uint8
            or images.ndim != 4
            or images.shape[1:] != (self.camera_spec.shape)
        ):
            raise ValueError(
                f"expected uint8 images [n, {', '.join(map(str, self.camera_spec.shape))}] "
                f"from camera {self.camera_spec.world!r}, got {images.dtype} {images.shape}"
            )
        if self.model.training:  # eval() walks every module: only when needed
            self.model.eval()
        out = np.empty((images.shape[0], len(self.fluent_names)), dtype=np.float32)
        # The matrix-product path wins for the tile-reading trunk (0.27 -> 0.16 ms for 8
        # gridworld images); for strided 3x3 convolutions over an 84x84 frame, torch's own
        # convolution is faster at batch 8 and up (measured 0.14 vs 0.18 ms per image).
        fast = self.config.patch is not None
        pixels = torch.from_numpy(np.ascontiguousarray(images))
        with torch.inference_mode():
            for start in range(0, images.shape[0], self.batch_size):
                if fast:
                    batch = pixels[start : start + self.batch_size]
                    small = self.precision == "auto" and batch.shape[0] < BFLOAT16_MIN_BATCH
                    logits = self.model.infer(batch, dtype=torch.float32 if small else self._dtype)
                else:
                    logits = self.model(images_to_tensor(images[start : start + self.batch_size]))
                out[start : start + logits.shape[0]] = torch.sigmoid(logits).numpy()
        return out

    def save(self, path: str | Path) -> None:
        """Writes the detector to one ``.safetensors`` file, atomically."""
        tensors = {k: v.detach().cpu().contiguous() for k, v in self.model.state_dict().items()}
        header = {
            "format": CLASSIFIER_FORMAT,
            "version": CLASSIFIER_VERSION,
            "fluent_names": list(self.fluent_names),
            "camera_spec": camera_spec_to_dict(self.camera_spec),
            "config": asdict(self.config),
            "training": self.training,
            "tensor_sha256": _tensor_digest(tensors),
        }
        data = save_safetensors(tensors, metadata={"noisybolt": json.dumps(header)})
        atomic_write_bytes(path, data)

    @classmethod
    def load(
        cls,
        path: str | Path,
        *,
        world: BoltObservable | None = None,
        fluent_names: Sequence[str] | None = None,
        camera_spec: CameraSpec | None = None,
        ignore: Collection[str] = (),
    ) -> ClassifierDetector:
        """Reads a detector written by :meth:`save`; see :func:`load_classifier`."""
        return load_classifier(
            path, world=world, fluent_names=fluent_names, camera_spec=camera_spec, ignore=ignore
        )


def _read_header(data: bytes) -> dict[str, Any]:
    if len(data) < 8:
        raise ValueError("shorter than a safetensors header")
    (length,) = struct.unpack("<Q", data[:8])
    if length > len(data) - 8:
        raise ValueError(f"header of {length} bytes does not fit in {len(data)} bytes")
    header = json.loads(data[8 : 8 + length].decode("utf-8"))
    meta = header.get("__metadata__") or {}
    if "noisybolt" not in meta:
        raise ValueError("a safetensors file without a noisybolt header")
    ours = json.loads(meta["noisybolt"])
    if not isinstance(ours, dict) or ours.get("format") != CLASSIFIER_FORMAT:
        raise ValueError("not a noisybolt fluent classifier")
    if ours.get("version") != CLASSIFIER_VERSION:
        raise ValueError(f"unsupported version {ours.get('version')!r}")
    return ours


def load_classifier(
    path: str | Path,
    *,
    world: BoltObservable | None = None,
    fluent_names: Sequence[str] | None = None,
    camera_spec: CameraSpec | None = None,
    ignore: Collection[str] = (),
) -> ClassifierDetector:
    """Reads a classifier file and, if told the world it is for, checks that it fits.

    Args:
        path: the ``.safetensors`` file written by :meth:`ClassifierDetector.save`.
        world: the world it will be used with; the same as passing its ``fluent_names``
            and ``camera_spec``.
        fluent_names: the world's fluents; with ``camera_spec``, the classifier must have
            been trained for exactly these, in this order.
        camera_spec: the world's camera spec (world, size and noise settings).
        ignore: camera fields not to compare (e.g. ``{"noise"}`` to evaluate a classifier
            trained on clean images under noise, on purpose).

    Raises:
        FileNotFoundError: if there is no such file.
        CorruptFileError: if the file is truncated, corrupt or not a noisybolt classifier.
        IncompatibleError: if it was trained for other fluents or another camera.
    """
    if world is not None:
        if fluent_names is not None or camera_spec is not None:
            raise ValueError("give world, or fluent_names and camera_spec, not both")
        fluent_names, camera_spec = tuple(world.fluent_names), world.camera_spec
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no classifier file at {path}")
    data = path.read_bytes()
    try:
        header = _read_header(data)
        tensors = load_safetensors(data)
        if _tensor_digest(tensors) != header["tensor_sha256"]:
            raise ValueError("the weights do not match their recorded SHA-256")
        names = tuple(header["fluent_names"])
        if not all(isinstance(name, str) for name in names):
            raise ValueError(f"fluent names must be strings, got {list(names)!r}")
        spec = camera_spec_from_dict(header["camera_spec"])
        config = ClassifierConfig.from_dict(header["config"])
        model = FluentNet(in_channels=spec.channels, n_fluents=len(names), config=config)
        model.load_state_dict(tensors, strict=True)
        training = header.get("training", {})
        if not isinstance(training, dict):
            raise ValueError(f"its training record must be a mapping, got {training!r}")
    except Exception as error:  # safetensors raises its own error types; all mean corrupt
        raise CorruptFileError(
            f"classifier file {path} is truncated or corrupt ({type(error).__name__}: "
            f"{error}); train it again (noisybolt classifiers train)"
        ) from error
    detector = ClassifierDetector(
        model=model, fluent_names=names, camera_spec=spec, config=config, training=training
    )
    if (fluent_names is None) != (camera_spec is None):
        raise ValueError("give both fluent_names and camera_spec, or neither")
    if fluent_names is not None and camera_spec is not None:
        check_compatible(
            f"classifier {path}",
            fluent_names=names,
            camera_spec=spec,
            expected_fluents=fluent_names,
            expected_camera=camera_spec,
            ignore=ignore,
        )
    return detector
