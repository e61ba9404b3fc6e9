"""The bolt's classifier on an inference engine: ONNX Runtime against noisybolt's own path.

Issue 49, part 2 asks whether an inference engine runs the gridworld's trained classifier
(the tile-reading trunk, regional-noise camera: what Table 1's case 4 and the training
throughput's variant (c) use) faster than ``ClassifierDetector.predict``, which already
runs the trunk as matrix products (and in bfloat16 from 32 images where the CPU multiplies
it natively). Measured in one process, interleaved rounds, medians, one thread each, on
the camera's own images (a batch as the bolt reads one per step: one image per
environment): milliseconds per call at several batch sizes, and the largest difference
between the two paths' probabilities. ONNX Runtime gets the network as ``forward`` gives
it (``images_to_tensor`` and the module, exported once), with its graph optimisations on.

    .venv/bin/pip install onnxruntime onnx   # not dependencies of noisybolt
    .venv/bin/python benchmarks/classifier_engines.py [--rounds 7] [--batches 8,32,64]
"""

from __future__ import annotations

import argparse
import io
import statistics
import time
from typing import Any

import numpy as np
import torch

from noisybolt.envs import make_world
from noisybolt.perception.classifier import ClassifierDetector
from noisybolt.runs import DetectorConfig
from noisybolt.runs.detectors import make_detector

INSTALL = "ONNX Runtime is not installed: .venv/bin/pip install onnxruntime onnx"


def camera_images(n: int, seed: int = 0) -> np.ndarray:
    """``n`` images of the gridworld's regional-noise camera from random play."""
    world = make_world("gridworld", num_envs=n, seed=seed, noise="regional")
    world.reset()
    rng = np.random.default_rng(seed)
    for _ in range(5):
        world.step(rng.integers(0, 3, size=n))
    _, _, _, _, info = world.step(rng.integers(0, 3, size=n))
    return np.asarray(info["bolt_image"], dtype=np.uint8)


def classifier() -> ClassifierDetector:
    world = make_world("gridworld", num_envs=1, seed=0, noise="regional")
    detector = make_detector(
        DetectorConfig(kind="classifier"),
        world="gridworld",
        world_kwargs={"noise": "regional"},
        fluent_names=world.fluent_names,
        camera_spec=world.camera_spec,
        log=lambda _: None,
    )
    inner = getattr(detector, "detector", detector)
    assert isinstance(inner, ClassifierDetector), type(inner)
    return inner


def onnx_session(detector: ClassifierDetector, sample: np.ndarray) -> Any:
    import onnxruntime as ort

    class Probabilities(torch.nn.Module):
        def __init__(self, net: torch.nn.Module) -> None:
            super().__init__()
            self.net = net

        def forward(self, images: torch.Tensor) -> torch.Tensor:  # uint8 [n, H, W, C]
            x = images.permute(0, 3, 1, 2).float() / 255.0
            return torch.sigmoid(self.net(x))

    module = Probabilities(detector.model.eval())
    buffer = io.BytesIO()
    torch.onnx.export(
        module,
        (torch.from_numpy(sample[:2]),),
        buffer,
        input_names=["images"],
        output_names=["probs"],
        dynamic_axes={"images": {0: "n"}, "probs": {0: "n"}},
        dynamo=True,
    )
    options = ort.SessionOptions()
    options.intra_op_num_threads = 1
    options.inter_op_num_threads = 1
    options.graph_optimization_level = ort.GraphOptimizationLevel.ORT_ENABLE_ALL
    return ort.InferenceSession(buffer.getvalue(), options, providers=["CPUExecutionProvider"])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--batches", default="8,32,64")
    parser.add_argument("--calls", type=int, default=200, help="calls timed per round")
    args = parser.parse_args()
    try:
        import onnxruntime  # noqa: F401
    except ImportError:
        raise SystemExit(INSTALL) from None
    torch.set_num_threads(1)
    detector = classifier()
    batches = [int(b) for b in args.batches.split(",")]
    images = camera_images(max(batches))
    session = onnx_session(detector, images)
    paths = {
        "noisybolt": lambda x: detector.predict(x),
        "onnxruntime": lambda x: session.run(None, {"images": x})[0],
    }
    print(f"{'batch':>5} {'noisybolt ms':>13} {'onnxruntime ms':>15} {'ratio':>6} {'max |dp|':>9}")
    for batch in batches:
        x = np.ascontiguousarray(images[:batch])
        gap = float(np.abs(paths["noisybolt"](x) - paths["onnxruntime"](x)).max())
        times: dict[str, list[float]] = {name: [] for name in paths}
        for _ in range(args.rounds):
            for name, run in paths.items():
                run(x)
                start = time.perf_counter()
                for _ in range(args.calls):
                    run(x)
                times[name].append((time.perf_counter() - start) / args.calls * 1e3)
        ours, theirs = (statistics.median(times[n]) for n in paths)
        print(f"{batch:>5} {ours:>13.3f} {theirs:>15.3f} {theirs / ours:>6.2f} {gap:>9.2e}")
    print("ratio: onnxruntime's time / noisybolt's (below 1: the engine is faster)")


if __name__ == "__main__":
    main()
