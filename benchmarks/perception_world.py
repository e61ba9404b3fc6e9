"""Speed of the gridworld and of the bolt's camera: ours (numpy, batched) against MiniGrid's.

Measures, in one run, on the 6x6 gridworld:

* **camera**: frames/s of MiniGrid's ``get_frame(highlight=False)`` (one env, one frame at
  a time) and of our tile compositor (:class:`noisybolt.envs.gridworld.GridworldCamera`,
  a batch of 64 frames per call, and one frame per call), at 8- and 32-pixel tiles, with
  the ratio (issue 3's target: at least 10x);
* **noise**: images/s of each noise model on batches of 64 camera frames;
* **world**: env-steps/s of :class:`noisybolt.envs.gridworld_vec.VectorGridworld` at 8 and
  64 envs, for each agent observation mode, without the camera and with it (every step
  the bolt's labels read from the step's batched ``info``, as the batched bolt reads them:
  ``info["bolt_image"]`` and ``info["true_fluents"]``, clean, with the default
  ``regional`` noise and with ``gaussian`` noise); the target is >= 50k env-steps/s with
  the camera at 64 envs;
* **SB3**: env-steps/s through SB3's ``VecEnv`` API (``step`` = ``step_async`` +
  ``step_wait``) for our adapter at 8 and 64 envs against ``DummyVecEnv`` over 8 MiniGrid
  envs, uniformly random actions.

Every figure is the median of ``--repeats`` timed runs of at least ``--seconds`` each, after
a warm-up. One thread for numpy's BLAS is irrelevant here (no matrix products); nothing
runs in parallel.

Run: ``.venv/bin/python benchmarks/perception_world.py`` (``--help`` for the options).
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import sys
import time
from collections.abc import Callable
from functools import partial

import numpy as np

from noisybolt.envs.gridworld import GridworldCamera, GridworldEnv
from noisybolt.envs.gridworld_vec import VectorGridworld
from noisybolt.envs.sb3 import SB3VecEnv
from noisybolt.perception.noise import NoiseModel, make_noise

#: Issue 3's targets.
CAMERA_RATIO_TARGET = 10.0
WORLD_TARGET = 50_000.0

#: (agent observation, camera) pairs timed for the world: the camera off, clean, or with
#: a noise model (the default ``regional`` one, and ``gaussian`` sigma 8).
WORLD_CASES = (
    ("grid", "off"),
    ("grid", "clean"),
    ("grid", "regional"),
    ("grid", "gaussian"),
    ("view", "off"),
    ("view", "clean"),
    ("view", "regional"),
    ("rgb", "off"),
    ("rgb", "clean"),
    ("rgb", "regional"),
)

NOISES = (
    "none",
    "gaussian",
    "salt_pepper",
    "blur",
    "occlusion",
    "regional",
    "gaussian+salt_pepper",
)


def rate(work: Callable[[], int], *, seconds: float, repeats: int) -> float:
    """Median items/s of ``work`` (which returns how many items it did) over ``repeats`` runs."""
    work()  # warm-up: caches, first allocations
    rates = []
    for _ in range(repeats):
        done, start = 0, time.perf_counter()
        while (elapsed := time.perf_counter() - start) < seconds:
            done += work()
        rates.append(done / elapsed)
    return statistics.median(rates)


def camera_rows(seconds: float, repeats: int) -> list[tuple[str, float, float]]:
    rows = []
    rng = np.random.default_rng(0)
    x, y, d = rng.integers(1, 5, 64), rng.integers(1, 5, 64), rng.integers(0, 4, 64)

    def frames(cam: GridworldCamera, n: int) -> int:
        return len(cam.render(x[:n], y[:n], d[:n]))

    for tile in (8, 32):
        env = GridworldEnv()
        env.reset(seed=0)

        def minigrid(env: GridworldEnv = env, tile: int = tile) -> int:
            env.get_frame(highlight=False, tile_size=tile)
            return 1

        cam = GridworldCamera(size=6, tile_size=tile)
        theirs = rate(minigrid, seconds=seconds, repeats=repeats)
        batch = rate(partial(frames, cam, 64), seconds=seconds, repeats=repeats)
        one = rate(partial(frames, cam, 1), seconds=seconds, repeats=repeats)
        rows.append((f"MiniGrid get_frame, tile {tile}", theirs, 1.0))
        rows.append((f"ours, batch 64, tile {tile}", batch, batch / theirs))
        rows.append((f"ours, batch 1, tile {tile}", one, one / theirs))
    return rows


def noise_rows(seconds: float, repeats: int) -> list[tuple[str, float]]:
    cam = GridworldCamera(size=6, tile_size=8)
    rng = np.random.default_rng(0)
    images = cam.render(rng.integers(1, 5, 64), rng.integers(1, 5, 64), rng.integers(0, 4, 64))
    rows = []
    for spec in NOISES:
        model = make_noise(spec)

        def noisy(model: NoiseModel = model) -> int:
            return len(model.apply(images, rng))

        rows.append((spec, rate(noisy, seconds=seconds, repeats=repeats)))
    return rows


def stepper(world: VectorGridworld, n: int, *, with_camera: bool) -> Callable[[], int]:
    """32 steps of uniformly random actions (and, if asked, the bolt's camera and fluents
    read from the step's info: the camera renders only when they are read)."""
    actions = np.random.default_rng(0).integers(0, 4, size=(1024, n))
    counter = iter(range(10**12))

    def work() -> int:
        for _ in range(32):
            info = world.step(actions[next(counter) % 1024])[4]
            if with_camera:
                np.asarray(info["bolt_image"])
                np.asarray(info["true_fluents"])
        return 32 * n

    return work


def vec_stepper(venv: object, n: int, steps: int) -> Callable[[], int]:
    """``steps`` SB3 ``VecEnv.step`` calls with uniformly random actions."""
    actions = np.random.default_rng(0).integers(0, 4, size=(1024, n))
    counter = iter(range(10**12))

    def work() -> int:
        for _ in range(steps):
            venv.step(actions[next(counter) % 1024])  # type: ignore[attr-defined]
        return steps * n

    return work


def world_rows(seconds: float, repeats: int) -> list[tuple[int, str, str, float]]:
    rows = []
    for n in (8, 64):
        for mode, camera in WORLD_CASES:
            noise = "none" if camera in ("off", "clean") else camera
            world = VectorGridworld(n, obs_mode=mode, noise=noise, seed=0)
            world.reset(seed=0)
            work = stepper(world, n, with_camera=camera != "off")
            rows.append((n, mode, camera, rate(work, seconds=seconds, repeats=repeats)))
    return rows


def sb3_rows(seconds: float, repeats: int) -> list[tuple[str, float]]:
    from stable_baselines3.common.vec_env import DummyVecEnv

    rows = []
    for n in (8, 64):
        venv = SB3VecEnv(VectorGridworld(n, obs_mode="grid"))
        venv.reset()
        ours = rate(vec_stepper(venv, n, 32), seconds=seconds, repeats=repeats)
        rows.append((f"SB3VecEnv(VectorGridworld), {n} envs", ours))
    # The plain MiniGrid step, as before the env labelled its info (no bolt camera render).
    plain = [lambda: GridworldEnv(obs_mode="grid", bolt_labels=False) for _ in range(8)]
    dummy = DummyVecEnv(plain)
    dummy.reset()
    theirs = rate(vec_stepper(dummy, 8, 8), seconds=seconds, repeats=repeats)
    rows.append(("DummyVecEnv(8 x GridworldEnv, MiniGrid)", theirs))
    return rows


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=0.5, help="minimum time per run")
    parser.add_argument("--repeats", type=int, default=3, help="timed runs per figure")
    args = parser.parse_args(argv)
    print(
        f"# perception_world: python {platform.python_version()}, numpy {np.__version__}, "
        f"{platform.machine()}, {os.cpu_count()} CPUs; median of {args.repeats} x "
        f">= {args.seconds} s"
    )

    print("\n## Bolt camera (6x6 room), frames/s")
    print(f"{'renderer':36s} {'frames/s':>12s} {'vs MiniGrid':>12s}")
    camera = camera_rows(args.seconds, args.repeats)
    for name, fps, ratio in camera:
        print(f"{name:36s} {fps:12,.0f} {ratio:11.1f}x")

    print("\n## Noise models on 48x48x3 frames, batch 64, images/s")
    for name, ips in noise_rows(args.seconds, args.repeats):
        print(f"{name:36s} {ips:12,.0f}")

    print("\n## VectorGridworld, env-steps/s (camera: info's bolt_image + true_fluents per step)")
    print(f"{'envs':>4s} {'obs':>5s} {'camera':>9s} {'env-steps/s':>14s}")
    world = world_rows(args.seconds, args.repeats)
    for n, mode, cam, sps in world:
        print(f"{n:4d} {mode:>5s} {cam:>9s} {sps:14,.0f}")

    print("\n## Through SB3's VecEnv API, env-steps/s (grid observations, no camera)")
    for name, sps in sb3_rows(args.seconds, args.repeats):
        print(f"{name:44s} {sps:12,.0f}")

    worst_ratio = min(r for name, _, r in camera if "batch 64" in name)
    worst_world = min(s for n, _, cam, s in world if n == 64 and cam != "off")
    ok = worst_ratio >= CAMERA_RATIO_TARGET and worst_world >= WORLD_TARGET
    print(
        f"\ntargets: camera >= {CAMERA_RATIO_TARGET:.0f}x MiniGrid (batch 64, worst: "
        f"{worst_ratio:,.0f}x); >= {WORLD_TARGET:,.0f} env-steps/s with camera at 64 envs "
        f"(worst: {worst_world:,.0f}) -> {'met' if ok else 'NOT met'}"
    )
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
