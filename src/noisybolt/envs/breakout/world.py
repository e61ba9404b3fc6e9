"""Atari Breakout as a vectorised world for the restraining bolt.

:class:`BreakoutWorld` runs ``num_envs`` Arcade Learning Environment (ale-py, ROM bundled,
no download) instances of Breakout behind Gymnasium's vector API, with the standard Atari
preprocessing for the agent: each action repeated for 4 frames with the last two frames
max-pooled, grayscale, resized to 84x84 (``cv2.INTER_AREA``), a stack of the last 4 such
frames, 1 to 30 random no-ops after each reset, sticky actions (0.25) and a 108,000-frame
episode limit (truncation) as in ``ALE/Breakout-v5``. It computes the same observations
as ``AtariPreprocessing(gym.make("ALE/Breakout-v5", frameskip=1))`` under
``FrameStackObservation(4)`` (tested with sticky actions and no-ops off, where both are
deterministic) but drives the ALE directly: about 1.3x the steps per second of the
wrapped Gymnasium env on one core, and it gives the bolt direct access to RAM and colour
frames, which ale-py's own threaded ``AtariVectorEnv`` does not expose.

The bolt's side, through ``infos`` (the contract of :mod:`noisybolt.perception.protocols`:
``infos["bolt_image"]`` and ``infos["true_fluents"]`` batched at reset and step, the ended
games' last ones in ``infos["final_info"]``, as :class:`~noisybolt.envs.deferred.DeferredArray` s
that render the camera and read the RAM only when read; :meth:`BreakoutWorld.bolt_images`
and :meth:`BreakoutWorld.true_fluents` are views of them for sample collection):

* fluent ``brick_clear_left``: every brick of the leftmost ``left_columns`` brick
  column(s) is gone, read from RAM (:func:`bricks_present`);
* fluents ``left_gone_row0`` .. ``left_gone_row5``: the brick of that row (0 = top) in
  the leftmost column is gone: the milestones on the way to ``brick_clear_left``, so that
  a bolt can reward progress the agent can actually make (``F(brick_clear_left)`` alone
  pays nothing until the whole column is gone, which random play never achieves);
* camera: the colour frame (210x160) resized to ``camera_size`` squared with
  ``cv2.INTER_AREA``, then the camera's own seeded noise, each game's from its own
  generator (so a game looks the same in any shard of the world: ``shard``, for
  :class:`~noisybolt.envs.worker_world.WorkerWorld`).

RAM layout of the wall (verified by poking every bit with ``ale.setRAM`` and diffing the
rendered frame; ``tests/envs/test_breakout.py`` re-checks it brick by brick). Bytes 0-35
hold the wall (OCAtari's Breakout reads ``ram[0:36]``; the AtariARI map of Anand et al.
2019 lists only bytes 0-29 and so misses the leftmost column). They form six groups of six
bytes, one byte per brick row, the row's byte at ``group_base + 5 - row`` (row 0 is the
top, red row at y 57-62; row 5 the bottom, blue row at y 87-92; 6 pixels per row). Each
brick is 8 pixels wide and owns two bits, one per 4-pixel playfield cell; the columns,
left to right (x = 8 + 8 * column), are in :data:`BRICK_BITS`. The leftmost column is
bits 6-7 of bytes 30-35, so it is clear iff ``ram[30 + i] & 0xC0 == 0`` for i in 0..5.
Caveat: during the first 36 frames after ``reset_game`` the game is still setting up
the wall and overwrites any pokes (measured: pokes at frame 36 are undone, at frame 37
they stay); :meth:`BreakoutWorld.sample_collection_states` waits for that.

Example:
    >>> world = make_breakout_world(num_envs=2, seed=0)
    >>> obs, info = world.reset(seed=0)
    >>> obs.shape, np.asarray(info["bolt_image"]).shape, np.asarray(info["true_fluents"]).any()
    ((2, 4, 84, 84), (2, 84, 84, 3), np.False_)
    >>> world.close()
"""

from __future__ import annotations

import inspect
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import ale_py
import cv2
import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.vector import AutoresetMode

from noisybolt.bolt.schemes import ReturnBounds
from noisybolt.envs.deferred import DeferredArray
from noisybolt.envs.fluents import select_fluents
from noisybolt.errors import ConfigError
from noisybolt.perception.noise import NoiseModel, make_noise
from noisybolt.perception.protocols import (
    BOLT_IMAGE_KEY,
    FINAL_INFO_KEY,
    TRUE_FLUENTS_KEY,
    CameraSpec,
)

#: The most points a game of Breakout can score: two walls of 432 (see return_bounds).
MAX_SCORE = 864.0
#: The bricks of a game: two walls of 6 rows of 18 (see clipped_return_bounds).
MAX_BRICKS = 216

__all__ = [
    "BRICK_BITS",
    "BRICK_COLUMNS",
    "BRICK_ROWS",
    "FLUENT_NAMES",
    "LEFT_ROW_FLUENTS",
    "OBS_MODES",
    "BreakoutEnv",
    "BreakoutWorld",
    "NoiseFn",
    "area_resize_84",
    "breakout_fluents",
    "brick_box",
    "bricks_present",
    "left_columns_clear",
    "make_breakout_ram_env",
    "make_breakout_ram_world",
    "make_breakout_world",
    "resolve_noise",
    "set_bricks",
]

BRICK_ROWS = 6
#: ``left_gone_row{r}``: the leftmost column's brick of row ``r`` (0 = top) is gone.
LEFT_ROW_FLUENTS: tuple[str, ...] = tuple(f"left_gone_row{r}" for r in range(BRICK_ROWS))
#: Every Breakout fluent, in the column order of :func:`breakout_fluents`.
FLUENT_NAMES: tuple[str, ...] = ("brick_clear_left", *LEFT_ROW_FLUENTS)
BRICK_COLUMNS = 18
#: The agent's observations: ``stack`` (the preprocessed grey frames, for the convolutions),
#: ``ram`` (the console's 128 RAM bytes scaled to [0, 1], for a dense network) or
#: ``ram_bits`` (the same bytes as their 1,024 bits, 0 or 1: Breakout keeps its wall as bit
#: fields, one brick per bit, which a byte scaled to [0, 1] blurs into one number).
OBS_MODES: tuple[str, ...] = ("stack", "ram", "ram_bits")
RAM_SIZE = 128

#: ``(byte group base, bit mask)`` of each brick column, left to right; a brick of row
#: ``r`` (0 = top) lives in ``ram[base + 5 - r] & mask``. Measured, see the module doc.
BRICK_BITS: tuple[tuple[int, int], ...] = (
    (30, 0xC0),
    (24, 0xC0), (24, 0x30), (24, 0x0C), (24, 0x03),
    (18, 0x03), (18, 0x0C), (18, 0x30), (18, 0xC0),
    (12, 0x30), (12, 0xC0),
    (6, 0xC0), (6, 0x30), (6, 0x0C), (6, 0x03),
    (0, 0x03), (0, 0x0C), (0, 0x30),
)  # fmt: skip

# byte index and mask of every brick, as [rows, columns] arrays for vectorised reads.
_BRICK_BYTE = np.array(
    [[base + 5 - row for base, _ in BRICK_BITS] for row in range(BRICK_ROWS)], dtype=np.intp
)
_BRICK_MASK = np.array(
    [[mask for _, mask in BRICK_BITS] for _ in range(BRICK_ROWS)], dtype=np.uint8
)
_FIRE = 1  # FIRE's index in Breakout's minimal action set (NOOP, FIRE, RIGHT, LEFT)
_WALL_SETTLE_FRAMES = 40  # the game sets its wall up during the first 36 frames of a game

NoiseFn = Callable[[np.ndarray, np.random.Generator], np.ndarray]
"""A camera noise model: uint8 images ``[n, H, W, C]`` and a generator -> noisy images."""


def brick_box(row: int, column: int) -> tuple[slice, slice]:
    """``(y slice, x slice)`` of a brick in the 210x160 frame."""
    if not (0 <= row < BRICK_ROWS and 0 <= column < BRICK_COLUMNS):
        raise ValueError(f"no brick at row {row}, column {column}")
    return slice(57 + 6 * row, 63 + 6 * row), slice(8 + 8 * column, 16 + 8 * column)


def bricks_present(ram: np.ndarray) -> np.ndarray:
    """bool ``[..., 6, 18]``: which bricks are (at least partly) standing.

    Args:
        ram: uint8 ``[..., 128]`` Breakout RAM (one or a batch of consoles).
    """
    ram = np.asarray(ram)
    return (ram[..., _BRICK_BYTE] & _BRICK_MASK) != 0


def left_columns_clear(ram: np.ndarray, left_columns: int = 1) -> np.ndarray:
    """bool ``[...]``: every brick of the leftmost ``left_columns`` columns is gone.

    Example:
        >>> ram = np.zeros(128, np.uint8)
        >>> ram[30:36] = 0xC0  # the leftmost column standing
        >>> bool(left_columns_clear(ram)), bool(left_columns_clear(ram & 0x3F))
        (False, True)
    """
    if not 1 <= left_columns <= BRICK_COLUMNS:
        raise ConfigError(f"left_columns must be in 1..{BRICK_COLUMNS}, got {left_columns}")
    return np.asarray(~bricks_present(ram)[..., :left_columns].any(axis=(-1, -2)))


def breakout_fluents(ram: np.ndarray, left_columns: int = 1) -> np.ndarray:
    """bool ``[n, 7]``: every fluent of :data:`FLUENT_NAMES` for RAMs ``[n, 128]``.

    Example:
        >>> ram = np.zeros((1, 128), np.uint8)
        >>> ram[0, 30:36] = 0xC0  # the leftmost column standing ...
        >>> ram[0, 30 + 5 - 4] = 0  # ... but for its brick in row 4
        >>> breakout_fluents(ram).astype(int).tolist()
        [[0, 0, 0, 0, 0, 1, 0]]
    """
    gone = ~bricks_present(ram)[..., :, 0]  # [n, rows]: the leftmost column
    return np.concatenate([left_columns_clear(ram, left_columns)[..., None], gone], axis=-1)


def set_bricks(ale: ale_py.ALEInterface, present: np.ndarray) -> None:
    """Writes a whole wall (bool ``[6, 18]``) into a console's RAM.

    The frame shows it from the next emulated frame on; during the first 36 frames of a
    game the game's own wall set-up overwrites it.
    """
    present = np.asarray(present, dtype=bool)
    if present.shape != (BRICK_ROWS, BRICK_COLUMNS):
        raise ValueError(f"a wall is bool [{BRICK_ROWS}, {BRICK_COLUMNS}], got {present.shape}")
    ram = ale.getRAM()
    values = {int(b): int(ram[b]) for b in np.unique(_BRICK_BYTE)}
    for (row, column), mask in np.ndenumerate(_BRICK_MASK):
        byte = int(_BRICK_BYTE[row, column])
        values[byte] = (
            (values[byte] | int(mask))
            if present[row, column]
            else (values[byte] & ~int(mask) & 0xFF)
        )
    for byte, value in values.items():
        if value != ram[byte]:
            ale.setRAM(byte, value)


_AREA_84_SIZE = 84


def area_resize_84(frames: np.ndarray) -> np.ndarray:
    """ALE frames uint8 ``[n, 210, 160, 3]`` resized to ``[n, 84, 84, 3]`` by area
    averaging: ``cv2.INTER_AREA``'s pixels, in half its time for a batch of 4.

    OpenCV's area resize takes its general path for factors that are not integers (2.5
    down, 40/21 across: 0.16 ms a frame here, a tenth of a Breakout training frame's CPU).
    Down, every 5 rows make 2, the averages (r0 + r1 + r2/2) / 2.5 and (r2/2 + r3 + r4)
    / 2.5, kept as the exact sums 2r0 + 2r1 + r2 and r2 + 2r3 + 2r4 (5 times the average,
    in float32); across, OpenCV's own area resize of those sums (the frames stacked, one
    call, factor 1 down), then a fifth of it, rounded. The same pixels as
    ``cv2.resize(frame, (84, 84), interpolation=cv2.INTER_AREA)`` on every frame of
    Breakout play tested; on random images a value on an exact half may round the other
    way (under 0.1 % of values, one level apart).

    Example:
        >>> frame = np.random.default_rng(0).integers(0, 256, (1, 210, 160, 3), np.uint8)
        >>> ours = area_resize_84(frame)[0].astype(int)
        >>> theirs = cv2.resize(frame[0], (84, 84), interpolation=cv2.INTER_AREA).astype(int)
        >>> ours.shape, int(abs(ours - theirs).max()) <= 1
        ((84, 84, 3), True)
    """
    n = frames.shape[0]
    if frames.shape[1:] != (210, 160, 3) or frames.dtype != np.uint8:
        raise ValueError(f"expected uint8 ALE frames [n, 210, 160, 3], got {frames.shape}")
    rows = frames.reshape(n, 42, 5, 160 * 3)
    sums = np.empty((n, 42, 2, 160 * 3), np.float32)  # 2x(row0 + row1) + row2, row2 + 2x(...)
    np.add(rows[:, :, 0], rows[:, :, 1], out=sums[:, :, 0], dtype=np.float32)
    np.add(rows[:, :, 3], rows[:, :, 4], out=sums[:, :, 1], dtype=np.float32)
    sums *= 2
    sums += rows[:, :, 2, None]
    tall = sums.reshape(n * 84, 160, 3)  # the frames one above the other: factor 1 down
    out = np.asarray(cv2.resize(tall, (84, n * 84), interpolation=cv2.INTER_AREA), np.float32)
    out *= np.float32(0.2)
    np.rint(out, out=out)
    return out.astype(np.uint8).reshape(n, 84, 84, 3)


def resolve_noise(noise: Any) -> tuple[NoiseFn | None, dict[str, Any]]:
    """The camera's noise function and its JSON description (for :class:`CameraSpec`).

    Accepts None (clean), a :mod:`noisybolt.perception.noise` model or any object with
    ``apply(images, rng)`` (and ideally ``describe()``), a spec that
    :func:`~noisybolt.perception.noise.make_noise` reads (a name or command-line text such
    as ``"gaussian:sigma=12"``, a mapping, a list), or a plain ``noise(images, rng)``
    callable.

    Raises:
        ConfigError: for anything else (and, through ``make_noise``, for bad specs;
            ``UnknownNameError`` for unknown noise names).
    """
    if noise is None:
        return None, {"name": "none"}  # what NoNoise().describe() says
    if isinstance(noise, str | Mapping | list | tuple):
        noise = make_noise(noise)
    apply = getattr(noise, "apply", None)
    if callable(apply):
        describe = getattr(noise, "describe", None)
        description = describe() if callable(describe) else {"name": type(noise).__name__}
        if description.get("name") == "none":
            return None, description
        return apply, description
    if callable(noise):
        return noise, {"name": getattr(noise, "__name__", type(noise).__name__)}
    raise ConfigError(
        f"noise must be a noise spec, a noise model or a callable noise(images, rng), got {noise!r}"
    )


class BreakoutWorld(gym.vector.VectorEnv):
    """``num_envs`` Breakout games stepped together, seen by the agent and by the bolt.

    An episode terminates when the game is lost (``termination_is_success`` is False).

    Gymnasium vector API with **same-step autoreset**, like
    :class:`~noisybolt.envs.gridworld_vec.VectorGridworld` and SB3: a step that ends an
    episode returns the new episode's first observation, the ended one's last in
    ``infos["final_obs"]`` (object array, mask ``infos["_final_obs"]``), and the bolt's
    labels of the state each game *reached* before the reset in ``infos["final_info"]``
    (``infos`` also holds the current labels and ``lives``; see the module docs).
    Observations (``obs_mode="stack"``): uint8
    ``[num_envs, frame_stack, 84, 84]``; with ``obs_mode="ram"``: float32 ``[num_envs,
    128]``, the RAM bytes divided by 255 (SB3 scales only images, and raw bytes up to 255
    would swamp a dense layer's initial weights); with ``obs_mode="ram_bits"``: uint8
    ``[num_envs, 1024]``, each byte's bits (most significant first), 0 or 1. Actions:
    ``Discrete(4)`` per game (NOOP, FIRE, RIGHT, LEFT); rewards: the game score gained.

    Args:
        num_envs: number of games.
        seed: seeds the games (sticky actions, no-ops) and the camera noise; ``reset(seed=)``
            re-seeds.
        noise: the bolt camera's noise (None: clean): a noise spec or model of
            :mod:`noisybolt.perception.noise` (e.g. ``"gaussian:sigma=12"``) or a callable
            ``noise(images, rng) -> images``; see :func:`resolve_noise`.
        left_columns: how many brick columns, from the left, ``brick_clear_left`` covers.
        fluents: the bolt's fluents, in order (default: all of :data:`FLUENT_NAMES`).
        camera_size: side of the bolt's square colour image.
        frame_skip: frames per action.
        noop_max: a reset is followed by 1..``noop_max`` random no-ops (0: none).
        repeat_action_probability: sticky-action probability of the ALE.
        frame_stack: frames in the agent's observation.
        screen_size: side of the agent's square grayscale frames.
        max_episode_frames: emulator frames after which an episode is truncated.
        fire_on_reset: press FIRE (one agent step's frames) after every reset and every lost
            life, as SB3's ``FireResetEnv`` with ``EpisodicLifeEnv`` does: Breakout waits
            for FIRE to serve the ball, and an agent that has not learnt to press it
            wastes its episode until truncation. Off by default (plain ALE v5); the
            Breakout training settings turn it on (``configs/hyperparams/breakout.yaml``).
        obs_mode: the agent's observation, one of :data:`OBS_MODES`. ``ram`` and
            ``ram_bits`` skip the grey frames altogether (``frame_stack`` and
            ``screen_size`` are then unused); the bolt's camera, fluents and everything
            else are the same in all, so a RAM agent is watched by the same noisy camera
            and classifier as an image agent.
        left_head_start: the probability that a game starts with the bottom ``k`` bricks
            of the leftmost ``left_columns`` column(s) already gone, ``k`` uniform in
            1..5 (never the whole column), the rest of the wall as the game sets it up:
            a start-state curriculum for a learner (``world.train_kwargs``), so that
            the column's top bricks, which a player reaches only after the bottom ones,
            are met early and often. 0 (default): every game as the ALE starts it (and
            no random draw is spent on it). A missing brick scores nothing, and the
            bolt's fluents see it gone from the first frame: under threshold tracking a
            spec it satisfies is paid nothing for it (the compliance scheme pays no
            acceptance the first observation gives); belief tracking, which believes a
            fluent that comes on only after ``min_dwell`` frames and treats the first
            frame as such an onset, pays for it over the first steps, whatever the
            agent does (an offset to the return, not a gradient).
        shard: ``(first, total)``: these ``num_envs`` games are games ``first`` ..
            ``first + num_envs - 1`` of a world of ``total`` games with this ``seed``, and
            play exactly as those do there (each game's ALE, no-ops and camera noise are
            seeded from the seed and the game's index in the whole world). None: the whole
            world, ``(0, num_envs)``. For :class:`~noisybolt.envs.worker_world.WorkerWorld`,
            which runs the shards in worker processes.
    """

    termination_is_success = False

    def __init__(
        self,
        *,
        num_envs: int = 8,
        seed: int | None = None,
        noise: Any = None,
        left_columns: int = 1,
        fluents: Sequence[str] | None = None,
        camera_size: int = 84,
        frame_skip: int = 4,
        noop_max: int = 30,
        repeat_action_probability: float = 0.25,
        frame_stack: int = 4,
        screen_size: int = 84,
        max_episode_frames: int = 108_000,
        fire_on_reset: bool = False,
        obs_mode: str = "stack",
        left_head_start: float = 0.0,
        shard: tuple[int, int] | None = None,
    ) -> None:
        if obs_mode not in OBS_MODES:
            raise ConfigError(
                f"breakout: obs_mode must be one of {list(OBS_MODES)}, got {obs_mode!r}"
            )
        if num_envs < 1:
            raise ConfigError(f"num_envs must be >= 1, got {num_envs}")
        if not 1 <= left_columns <= BRICK_COLUMNS:
            raise ConfigError(f"left_columns must be in 1..{BRICK_COLUMNS}, got {left_columns}")
        if camera_size < 8 or screen_size < 8:
            raise ConfigError(
                f"camera_size and screen_size must be >= 8, got {camera_size}, {screen_size}"
            )
        if frame_skip < 1 or frame_stack < 1 or noop_max < 0 or max_episode_frames < 1:
            raise ConfigError(
                "frame_skip, frame_stack and max_episode_frames must be >= 1 and noop_max "
                f">= 0, got {frame_skip}, {frame_stack}, {max_episode_frames}, {noop_max}"
            )
        if not 0.0 <= repeat_action_probability <= 1.0:
            raise ConfigError(
                f"repeat_action_probability must be in [0, 1], got {repeat_action_probability}"
            )
        if not 0.0 <= left_head_start <= 1.0:
            raise ConfigError(f"left_head_start must be in [0, 1], got {left_head_start}")
        if shard is None:
            shard = (0, num_envs)
        first, total = (int(v) for v in shard)
        if not (first >= 0 and first + num_envs <= total):
            raise ConfigError(
                f"shard (first game, games in all) must hold this world's {num_envs} games, "
                f"got {shard}"
            )
        self.shard = (first, total)
        self._fluent_names, self._fluent_columns = select_fluents("breakout", FLUENT_NAMES, fluents)
        noise_fn, noise_description = resolve_noise(noise)
        self.metadata = {"autoreset_mode": AutoresetMode.SAME_STEP}
        self.autoreset_mode = AutoresetMode.SAME_STEP
        self.num_envs = num_envs
        self.left_columns = left_columns
        self.camera_size = camera_size
        self.frame_skip = frame_skip
        self.noop_max = noop_max
        self.repeat_action_probability = repeat_action_probability
        self.frame_stack = frame_stack
        self.screen_size = screen_size
        self.max_episode_frames = max_episode_frames
        self.fire_on_reset = bool(fire_on_reset)
        self.obs_mode = obs_mode
        self.left_head_start = float(left_head_start)
        self._ram_obs = obs_mode in ("ram", "ram_bits")
        self._noise = noise_fn
        # A noise model's own apply_each draws each game's noise alike, in one batch.
        owner = getattr(noise_fn, "__self__", None)
        self._noise_model = owner if isinstance(owner, NoiseModel) else None
        self._seed = seed

        ale_py.ALEInterface.setLoggerMode(ale_py.LoggerMode.Error)
        rom = ale_py.roms.get_rom_path("breakout")
        if rom is None:  # pragma: no cover - ale-py ships the ROM
            raise RuntimeError("ale-py has no Breakout ROM; reinstall ale-py >= 0.9")
        self._rom = rom
        self._ales = [ale_py.ALEInterface() for _ in range(num_envs)]
        self._np_rngs = [np.random.default_rng() for _ in range(num_envs)]
        self._camera_rngs = [np.random.default_rng() for _ in range(num_envs)]
        self._seed_all(seed)
        self._actions = self._ales[0].getMinimalActionSet()

        self.single_observation_space: spaces.Box
        if obs_mode == "ram_bits":
            self.single_observation_space = spaces.Box(0, 1, (8 * RAM_SIZE,), np.uint8)
        elif self._ram_obs:
            self.single_observation_space = spaces.Box(0.0, 1.0, (RAM_SIZE,), np.float32)
        else:
            self.single_observation_space = spaces.Box(
                0, 255, (frame_stack, screen_size, screen_size), np.uint8
            )
        self.single_action_space = spaces.Discrete(len(self._actions))
        self.observation_space = gym.vector.utils.batch_space(
            self.single_observation_space, num_envs
        )
        self.action_space = gym.vector.utils.batch_space(self.single_action_space, num_envs)
        self._camera_spec = CameraSpec(
            world="breakout",
            height=camera_size,
            width=camera_size,
            channels=3,
            noise=noise_description,
            extra={
                "source": "ALE RGB frame 210x160, cv2.INTER_AREA",
                # What each fluent means (left_columns changes brick_clear_left), so a
                # classifier, and the cache of classifiers trained on the fly, must not
                # cross them.
                "fluents": {
                    name: ({"left_columns": left_columns} if name == "brick_clear_left" else {})
                    for name in self._fluent_names
                },
            },
        )

        self._grey = np.zeros((num_envs, 2, 210, 160), np.uint8)  # last two frames
        self._stack = np.zeros((num_envs, frame_stack, screen_size, screen_size), np.uint8)
        self._done = np.zeros(num_envs, dtype=bool)  # which games ended in the last step
        self._final_rgb: dict[int, np.ndarray] = {}  # their last colour frame and RAM
        self._final_ram: dict[int, np.ndarray] = {}
        self._lives = np.zeros(num_envs, dtype=np.int64)
        self._every = np.ones(num_envs, dtype=bool)  # the labels' masks: every game
        self._every.setflags(write=False)
        # The labels of the last reset or step (and of the states it reached before any
        # autoreset); the info and the bolt_images()/true_fluents() views share them.
        self._labels: dict[str, Any] = {}
        self._final_labels: dict[str, Any] = {}
        self._started = False
        self._info()

    # -- seeding and resets ---------------------------------------------------------------
    def _seed_all(self, seed: int | None) -> None:
        # Game g of the whole world (g = shard's first + i) draws from the g-th child of the
        # seed, whichever process runs it: a world split into shards plays the same games.
        first, total = self.shard
        children = np.random.SeedSequence(seed).spawn(total + 1)[first : first + self.num_envs]
        for i, ale in enumerate(self._ales):
            np_seed, ale_seed = children[i].generate_state(2)
            self._np_rngs[i] = np.random.default_rng(int(np_seed))
            self._camera_rngs[i] = np.random.default_rng(children[i].spawn(1)[0])
            ale.setInt("random_seed", int(np.int32(ale_seed)))
            ale.setFloat("repeat_action_probability", self.repeat_action_probability)
            ale.setInt("max_num_frames_per_episode", self.max_episode_frames)
            ale.setInt("frame_skip", 1)
            ale.loadROM(self._rom)

    def _processed(self, i: int) -> np.ndarray:
        frame = self._grey[i, 0]
        if self.frame_skip > 1:
            np.maximum(self._grey[i, 0], self._grey[i, 1], out=frame)
        return cv2.resize(frame, (self.screen_size, self.screen_size), interpolation=cv2.INTER_AREA)

    def _reset_one(self, i: int) -> None:
        ale = self._ales[i]
        ale.reset_game()
        if self.noop_max > 0:
            for _ in range(int(self._np_rngs[i].integers(1, self.noop_max + 1))):
                ale.act(self._actions[0])
                if ale.game_over():
                    ale.reset_game()
        if self.left_head_start and self._np_rngs[i].random() < self.left_head_start:
            self._remove_bottom_left(i, int(self._np_rngs[i].integers(1, BRICK_ROWS)))
        if not self._ram_obs:
            ale.getScreenGrayscale(self._grey[i, 0])
            self._grey[i, 1].fill(0)
        if self.fire_on_reset:
            self._act(i, _FIRE)
        if not self._ram_obs:
            self._stack[i] = self._processed(i)
        self._lives[i] = ale.lives()

    def _remove_bottom_left(self, i: int, bricks: int) -> None:
        """Game ``i`` (just reset): the bottom ``bricks`` bricks of the leftmost
        ``left_columns`` column(s) taken out of the wall (``left_head_start``), once the
        game has set up its own, then one NOOP so that the frame shows the new wall."""
        ale = self._ales[i]
        self._settle_wall(ale)
        wall = bricks_present(ale.getRAM())
        wall[BRICK_ROWS - bricks :, : self.left_columns] = False
        set_bricks(ale, wall)
        ale.act(self._actions[0])

    def _settle_wall(self, ale: ale_py.ALEInterface) -> None:
        """NOOPs until the game has set up its wall (a wall written into RAM before then
        is overwritten), or is over."""
        while ale.getEpisodeFrameNumber() < _WALL_SETTLE_FRAMES and not ale.game_over():
            ale.act(self._actions[0])

    def _act(self, i: int, action: int) -> int:
        """One agent step of game ``i`` (``frame_skip`` frames of minimal action index
        ``action``); keeps the last two frames for max-pooling; returns the score gained."""
        ale = self._ales[i]
        chosen = self._actions[action]
        last, second = self.frame_skip - 1, self.frame_skip - 2
        total = 0
        for t in range(self.frame_skip):
            total += ale.act(chosen)
            if ale.game_over():  # terminal or truncated: keep the last processed frames
                break
            if self._ram_obs:  # the RAM is read when the observation is made
                continue
            if t == second:
                ale.getScreenGrayscale(self._grey[i, 1])
            elif t == last:
                ale.getScreenGrayscale(self._grey[i, 0])
        return total

    def reset(
        self, *, seed: int | list[int] | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Resets every game (re-seeding them and the camera noise if ``seed`` is given).

        Options: ``reset_mask`` (bool ``[num_envs]``) resets only those games.
        """
        if isinstance(seed, list):
            raise ConfigError("BreakoutWorld.reset takes one int seed for the whole batch")
        mask = np.ones(self.num_envs, dtype=bool)
        if options and "reset_mask" in options:
            mask = np.asarray(options["reset_mask"], dtype=bool)
            if mask.shape != (self.num_envs,):
                raise ValueError(f"reset_mask must be bool [{self.num_envs}], got {mask.shape}")
        if seed is not None:
            self._seed = seed
            self._seed_all(seed)
            mask[:] = True
        for i in np.flatnonzero(mask):
            self._reset_one(int(i))
        self._clear_step_state()
        self._started = True
        return self._observations(), self._info()

    def _observations(self) -> np.ndarray:
        """The agent's observations of every game now."""
        if self._ram_obs:
            return self._ram_view(self.rams())
        return self._stack.copy()

    def _ram_view(self, rams: np.ndarray) -> np.ndarray:
        """The agent's observation of RAM bytes ``[..., 128]`` (``ram``, ``ram_bits``)."""
        if self.obs_mode == "ram_bits":
            return np.unpackbits(rams, axis=-1)
        return rams.astype(np.float32) / np.float32(255)

    def _info(self) -> dict[str, Any]:
        """The info of a reset or step: lives, and the bolt's labels of the states it
        reached (new labels: the last ones expire)."""
        for labels in (self._labels, self._final_labels):
            for value in labels.values():
                if isinstance(value, DeferredArray):
                    value.expire()
        n, k = self.num_envs, len(self._fluent_names)
        images_shape = (n, self.camera_size, self.camera_size, 3)
        images = DeferredArray(
            lambda: self._capture([ale.getScreenRGB() for ale in self._ales], range(n)),
            shape=images_shape,
            dtype=np.uint8,
        )
        self._labels = {
            BOLT_IMAGE_KEY: images,
            TRUE_FLUENTS_KEY: DeferredArray(
                lambda: self._fluents(self.rams()), shape=(n, k), dtype=bool
            ),
        }
        info: dict[str, Any] = {
            "lives": self._lives.copy(),
            "_lives": self._every,
            **self._labels,
            **{f"_{key}": self._every for key in self._labels},
        }
        if not self._final_rgb:
            self._final_labels = self._labels
            return info
        final_rgb, final_ram, done = dict(self._final_rgb), dict(self._final_ram), self._done

        def final_images() -> np.ndarray:
            # The current view first, then the ended games' last frames: the camera's
            # noise draws keep that order however the values are read.
            out = images.value.copy()
            idx = sorted(final_rgb)
            out[idx] = self._capture([final_rgb[i] for i in idx], idx)
            return out

        def final_fluents() -> np.ndarray:
            rams = self.rams()
            for i, ram in final_ram.items():
                rams[i] = ram
            return self._fluents(rams)

        self._final_labels = {
            BOLT_IMAGE_KEY: DeferredArray(final_images, shape=images_shape, dtype=np.uint8),
            TRUE_FLUENTS_KEY: DeferredArray(final_fluents, shape=(n, k), dtype=bool),
            f"_{BOLT_IMAGE_KEY}": done,
            f"_{TRUE_FLUENTS_KEY}": done,
        }
        return info

    # -- stepping -------------------------------------------------------------------------
    def step(
        self, actions: Any
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """Advances every game by one agent step (``frame_skip`` frames)."""
        if not self._started:
            raise RuntimeError("call reset() before step()")
        actions = np.asarray(actions)
        if actions.shape != (self.num_envs,):
            raise ValueError(f"actions must be [{self.num_envs}], got {actions.shape}")
        if (
            not np.issubdtype(actions.dtype, np.integer)
            or actions.min() < 0
            or (actions.max() >= len(self._actions))
        ):
            raise ValueError(f"actions must be integers in [0, {len(self._actions)})")
        rewards = np.zeros(self.num_envs, dtype=np.float64)
        terminated = np.zeros(self.num_envs, dtype=bool)
        truncated = np.zeros(self.num_envs, dtype=bool)
        self._clear_step_state()
        final_obs: np.ndarray | None = None
        for i, ale in enumerate(self._ales):
            total = self._act(i, int(actions[i]))
            if self.fire_on_reset and not ale.game_over() and ale.lives() < self._lives[i]:
                total += self._act(i, _FIRE)  # serve the next ball
            rewards[i] = total
            terminated[i] = ale.game_over(with_truncation=False)
            truncated[i] = ale.game_truncated()
            if not self._ram_obs:
                self._stack[i, :-1] = self._stack[i, 1:]
                self._stack[i, -1] = self._processed(i)
            if terminated[i] or truncated[i]:
                if final_obs is None:
                    final_obs = np.full(self.num_envs, None, dtype=object)
                self._final_rgb[i] = ale.getScreenRGB()
                self._final_ram[i] = ale.getRAM().copy()
                final_obs[i] = (
                    self._ram_view(self._final_ram[i]) if self._ram_obs else self._stack[i].copy()
                )
                self._reset_one(i)
            self._lives[i] = ale.lives()
        self._done = terminated | truncated
        infos = self._info()
        if final_obs is not None:
            infos.update(
                final_obs=final_obs,
                _final_obs=self._done.copy(),
                **{FINAL_INFO_KEY: self._final_labels, f"_{FINAL_INFO_KEY}": self._done.copy()},
            )
        return self._observations(), rewards, terminated, truncated, infos

    def _clear_step_state(self) -> None:
        self._done = np.zeros(self.num_envs, dtype=bool)
        self._final_rgb = {}
        self._final_ram = {}

    # -- the bolt's view ------------------------------------------------------------------
    def return_bounds(self) -> ReturnBounds:
        """Bounds on an episode's game score (see :mod:`noisybolt.envs.bounds`): 0 to two
        walls of 108 bricks, each wall worth (1 + 1 + 4 + 4 + 7 + 7) * 18 = 432 points."""
        return ReturnBounds(0.0, MAX_SCORE)

    def clipped_return_bounds(self) -> ReturnBounds:
        """Bounds on an episode's score clipped to its sign step by step (what a learner
        with the Atari convention ``clip_reward`` is paid): 0 to one point per brick of
        two walls, 216 (a step that takes a brick scores, and no step scores without
        one)."""
        return ReturnBounds(0.0, float(MAX_BRICKS))

    @property
    def fluent_names(self) -> tuple[str, ...]:
        """The bolt's fluents, in the column order of :meth:`true_fluents`."""
        return self._fluent_names

    @property
    def monotone_fluents(self) -> tuple[str, ...]:
        """Fluents that, once true, stay true for the rest of the episode: all of them (a
        brick gone stays gone). Belief tracking is told so (``BeliefSettings.monotone``):
        a brick read as standing again after it was seen gone is the camera's error, not
        the game. (A second wall comes only once the first is cleared, when every ``F``
        spec over these has long been accepted.)"""
        return self._fluent_names

    @property
    def camera_spec(self) -> CameraSpec:
        """The bolt camera's size and noise."""
        return self._camera_spec

    def lives(self) -> np.ndarray:
        """Lives left in each game (int ``[num_envs]``; a new game starts with 5)."""
        return self._lives.copy()

    def rams(self) -> np.ndarray:
        """uint8 ``[num_envs, 128]``: every console's RAM now."""
        return np.stack([ale.getRAM() for ale in self._ales])

    def ended_rams(self) -> dict[int, np.ndarray]:
        """uint8 ``[128]`` by game index: the RAM each game that ended on the last step
        had at its end (its whole wall; :meth:`rams` already holds the next game's), none
        after a reset or a step where no game ended.

        Example:
            >>> world = BreakoutWorld(num_envs=2, seed=0)
            >>> _ = world.reset(seed=0)
            >>> world.ended_rams()
            {}
        """
        return {i: ram.copy() for i, ram in self._final_ram.items()}

    def frames(self) -> np.ndarray:
        """uint8 ``[num_envs, 210, 160, 3]``: the raw colour frames now."""
        return np.stack([ale.getScreenRGB() for ale in self._ales])

    def true_fluents(self) -> np.ndarray:
        """bool ``[num_envs, n_fluents]``: the fluents from RAM (a view of
        ``infos["true_fluents"]`` of the last reset or step)."""
        return np.asarray(self._labels[TRUE_FLUENTS_KEY])

    def _fluents(self, rams: np.ndarray) -> np.ndarray:
        return breakout_fluents(rams, self.left_columns)[:, self._fluent_columns]

    def final_true_fluents(self) -> np.ndarray:
        """Ground truth of the states the last step reached, before autoreset (a view of
        ``infos["final_info"]["true_fluents"]``, rows that did not end as now)."""
        return np.asarray(self._final_labels[TRUE_FLUENTS_KEY])

    @property
    def dones(self) -> np.ndarray:
        """bool ``[num_envs]``: which games ended an episode in the last step."""
        return self._done.copy()

    def _capture(self, frames: list[np.ndarray], games: Sequence[int]) -> np.ndarray:
        """The camera's images of ``frames``, those of ``games``: each game's noise comes
        from its own generator, so a game looks the same in any shard of the world."""
        size = (self.camera_size, self.camera_size)
        if self.camera_size == _AREA_84_SIZE:
            images = area_resize_84(np.stack(frames))
        else:
            images = np.stack([cv2.resize(f, size, interpolation=cv2.INTER_AREA) for f in frames])
        if self._noise is not None:
            rngs = [self._camera_rngs[g] for g in games]
            if self._noise_model is not None:
                images = np.asarray(self._noise_model.apply_each(images, rngs))
            else:
                images = np.concatenate(
                    [np.asarray(self._noise(images[j : j + 1], rng)) for j, rng in enumerate(rngs)]
                )
            if images.dtype != np.uint8 or images.shape != (len(frames), *size, 3):
                raise ValueError(
                    f"the camera noise returned {images.dtype} {images.shape}; it must "
                    "keep uint8 images of the same shape"
                )
        return images

    def bolt_images(self) -> np.ndarray:
        """uint8 ``[num_envs, S, S, 3]``: the camera's noisy view, a view of
        ``infos["bolt_image"]`` of the last reset or step (one capture per step)."""
        return np.asarray(self._labels[BOLT_IMAGE_KEY])

    def final_bolt_images(self) -> np.ndarray:
        """The bolt's view of the states the last step *reached*, before autoreset (a view
        of ``infos["final_info"]["bolt_image"]``; rows that did not end as now)."""
        return np.asarray(self._final_labels[BOLT_IMAGE_KEY])

    def render(self) -> tuple[np.ndarray, ...] | None:
        """The raw colour frames, one per game."""
        return tuple(self.frames())

    # -- scripted exploration for sample collection ------------------------------------------
    def sample_collection_states(self, rng: np.random.Generator) -> None:
        """Pokes a random wall into every game so both fluent values are common.

        In random play the left column is almost never cleared, so for collection each
        game gets a fresh wall written into RAM: with probability 1/2 the left
        ``left_columns`` column(s) are empty (a positive), otherwise a random non-empty
        subset of their bricks stands (a negative, down to a single brick: the hard
        case); every other brick is kept with a probability drawn uniformly per game, and
        at least one always stays (an empty wall would start the next level). One NOOP
        frame is then emulated so the frame shows the new wall, and the agent's frame
        stack is refilled with that frame.
        """
        self._clear_step_state()
        for i, ale in enumerate(self._ales):
            self._settle_wall(ale)
            if ale.game_over():
                self._reset_one(i)
                for _ in range(_WALL_SETTLE_FRAMES):
                    ale.act(self._actions[0])
            keep = rng.random()
            wall = rng.random((BRICK_ROWS, BRICK_COLUMNS)) < keep
            left = wall[:, : self.left_columns]
            if rng.random() < 0.5:
                left[:] = False
            else:
                left[:] = rng.random(left.shape) < rng.random()
                if not left.any():
                    left.flat[rng.integers(left.size)] = True
            rest = wall[:, self.left_columns :]
            if rest.size and not rest.any():
                rest.flat[rng.integers(rest.size)] = True
            set_bricks(ale, wall)
            ale.act(self._actions[0])
            if not self._ram_obs:
                ale.getScreenGrayscale(self._grey[i, 0])
                self._grey[i, 1].fill(0)
                self._stack[i] = self._processed(i)
            self._lives[i] = ale.lives()
        self._info()  # the views (bolt_images, true_fluents) show the new walls

    def close_extras(self, **kwargs: Any) -> None:
        """Releases the consoles."""
        self._ales = []


class BreakoutEnv(gym.Env[np.ndarray, np.int64]):
    """One game of :class:`BreakoutWorld` as a plain Gymnasium env, labelled for the bolt
    (``info["bolt_image"]`` and ``info["true_fluents"]`` at reset and step), for
    :class:`~noisybolt.wrappers.RestrainingBoltWrapper` and recorded episodes (GIFs).

    After a step that ends the game it shows that game's last state (observation, bolt
    image, fluents, ``render()``) until :meth:`reset`, as a Gymnasium env must, although
    the world underneath has already started the next game.

    Args:
        render_mode: ``"rgb_array"`` (the raw colour frame) or None.
        **kwargs: :class:`BreakoutWorld` settings (``seed``, ``noise``, ``fluents``, ...).

    Example:
        >>> env = BreakoutEnv(seed=0, fluents=["left_gone_row5"])
        >>> obs, _ = env.reset(seed=0)
        >>> obs.shape, env.bolt_image().shape, env.true_fluents().tolist(), env.render().shape
        ((4, 84, 84), (84, 84, 3), [False], (210, 160, 3))
        >>> env.close()
    """

    metadata: dict[str, Any] = {"render_modes": ["rgb_array"]}  # noqa: RUF012 (gym's API)

    def __init__(self, *, render_mode: str | None = "rgb_array", **kwargs: Any) -> None:
        if render_mode not in (None, "rgb_array"):
            raise ConfigError(
                f"breakout: render_mode must be 'rgb_array' or None, not {render_mode!r}"
            )
        if kwargs.get("obs_mode", "stack") is None:
            kwargs.pop("obs_mode")  # the factory's "world default"
        self._world = BreakoutWorld(num_envs=1, **kwargs)
        self.render_mode = render_mode
        self.observation_space = self._world.single_observation_space
        self.action_space = self._world.single_action_space
        self._ended = False
        self._world_labels: dict[str, Any] = {}  # the world's labels of the state shown

    @property
    def world(self) -> BreakoutWorld:
        """The one-game world underneath."""
        return self._world

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Starts a new game (re-seeded when ``seed`` is given)."""
        super().reset(seed=seed)
        obs, info = self._world.reset(seed=seed, options=options)
        self._ended = False
        self._world_labels = info
        return obs[0], self._labelled({"lives": int(info["lives"][0])})

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """One agent step (``frame_skip`` frames)."""
        if self._ended:
            raise RuntimeError("the game has ended: call reset()")
        obs, rewards, terminated, truncated, info = self._world.step(np.array([int(action)]))
        self._ended = bool(terminated[0] or truncated[0])
        self._world_labels = info
        if self._ended:
            obs = info["final_obs"][0][None]
            self._world_labels = info[FINAL_INFO_KEY]
        info = self._labelled({})
        return obs[0], float(rewards[0]), bool(terminated[0]), bool(truncated[0]), info

    def _labelled(self, info: dict[str, Any]) -> dict[str, Any]:
        # The world–bolt contract (noisybolt.perception.protocols), read by the bolt.
        info[TRUE_FLUENTS_KEY] = self.true_fluents()
        info[BOLT_IMAGE_KEY] = self.bolt_image()
        return info

    @property
    def fluent_names(self) -> tuple[str, ...]:
        """The bolt's fluents."""
        return self._world.fluent_names

    @property
    def camera_spec(self) -> CameraSpec:
        """The bolt camera's size and noise."""
        return self._world.camera_spec

    def bolt_image(self) -> np.ndarray:
        """uint8 ``[S, S, 3]``: the bolt's noisy view of the state the last step reached
        (row 0 of the world's ``info["bolt_image"]``, or of its ``final_info``'s)."""
        return np.asarray(self._world_labels[BOLT_IMAGE_KEY])[0]

    def true_fluents(self) -> np.ndarray:
        """bool ``[n_fluents]``: the ground truth of that state."""
        return np.asarray(self._world_labels[TRUE_FLUENTS_KEY])[0]

    def render(self) -> np.ndarray | None:
        """The raw colour frame (210x160) of that state."""
        if self.render_mode is None:
            return None
        if self._ended and 0 in self._world._final_rgb:
            return self._world._final_rgb[0].copy()
        return self._world.frames()[0]

    def close(self) -> None:
        """Releases the console."""
        self._world.close()


def make_breakout_world(
    *,
    num_envs: int = 8,
    seed: int | None = None,
    noise: Any = None,
    obs_mode: str | None = None,
    left_columns: int = 1,
    fluents: Sequence[str] | None = None,
    camera_size: int = 84,
    frame_skip: int = 4,
    noop_max: int = 30,
    repeat_action_probability: float = 0.25,
    frame_stack: int = 4,
    screen_size: int = 84,
    max_episode_frames: int = 108_000,
    fire_on_reset: bool = False,
    left_head_start: float = 0.0,
    shard: tuple[int, int] | None = None,
) -> BreakoutWorld:
    """The registry's factory for ``"breakout"`` (``make_world("breakout", ...)``).

    Args:
        num_envs: number of games.
        seed: seeds the games and the camera noise.
        noise: the bolt camera's noise (see :func:`resolve_noise`).
        obs_mode: the agent's observation: None or ``"stack"`` (the standard preprocessed
            grayscale frame stack), ``"ram"`` (the 128 RAM bytes) or ``"ram_bits"`` (their
            1,024 bits); see :func:`make_breakout_ram_world`.
        left_columns: brick columns covered by ``brick_clear_left``.
        fluents: the bolt's fluents, in order (default: all of :data:`FLUENT_NAMES`).
        camera_size: side of the bolt's square colour image.
        frame_skip: frames per action.
        noop_max: at most this many random no-ops after a reset.
        repeat_action_probability: sticky actions.
        frame_stack: frames in the agent's observation.
        screen_size: side of the agent's frames.
        max_episode_frames: truncation limit in emulator frames.
        fire_on_reset: press FIRE after every reset and lost life.
        left_head_start: the share of games that start with the leftmost column's bottom
            bricks gone (a learner's curriculum; see :class:`BreakoutWorld`).
        shard: these games' place in a larger world (see :class:`BreakoutWorld`).

    Raises:
        ConfigError: for an unknown ``obs_mode`` or an out-of-range setting.

    Example:
        >>> world = make_breakout_world(num_envs=1, seed=3, fluents=["brick_clear_left"])
        >>> world.fluent_names, world.camera_spec.shape
        (('brick_clear_left',), (84, 84, 3))
    """
    return BreakoutWorld(
        obs_mode="stack" if obs_mode is None else obs_mode,
        num_envs=num_envs,
        seed=seed,
        noise=noise,
        left_columns=left_columns,
        fluents=fluents,
        camera_size=camera_size,
        frame_skip=frame_skip,
        noop_max=noop_max,
        repeat_action_probability=repeat_action_probability,
        frame_stack=frame_stack,
        screen_size=screen_size,
        max_episode_frames=max_episode_frames,
        fire_on_reset=fire_on_reset,
        left_head_start=left_head_start,
        shard=shard,
    )


def make_breakout_ram_world(*, obs_mode: str | None = "ram", **settings: Any) -> BreakoutWorld:
    """The registry's factory for ``"breakout-ram"``: Breakout whose agent reads the RAM.

    The same game, fluents and bolt camera as ``"breakout"`` (the bolt still looks through
    its noisy camera and classifier), but the agent observes the console's 128 RAM bytes
    (``obs_mode="ram"``), which a small dense network reads several times faster than
    convolutions read frames. A world of its own name so that it has its own
    hyperparameters (``configs/hyperparams/breakout-ram.yaml``).

    Args:
        obs_mode: ``"ram"`` (default), ``"ram_bits"`` or ``"stack"``.
        **settings: every other keyword of :func:`make_breakout_world`.

    Raises:
        ConfigError: a keyword :func:`make_breakout_world` does not take, or a bad value.

    Example:
        >>> world = make_breakout_ram_world(num_envs=2, seed=0)
        >>> obs, _ = world.reset(seed=0)
        >>> obs.shape, obs.dtype, world.bolt_images().shape
        ((2, 128), dtype('float32'), (2, 84, 84, 3))
        >>> world.close()
    """
    known = inspect.signature(make_breakout_world).parameters
    unknown = sorted(set(settings) - set(known))
    if unknown:
        raise ConfigError(
            f"world 'breakout-ram' takes no parameter(s) {', '.join(unknown)}; it takes: "
            f"{', '.join(known)}"
        )
    return make_breakout_world(obs_mode=obs_mode or "ram", **settings)


def make_breakout_ram_env(**settings: Any) -> BreakoutEnv:
    """One labelled game of ``"breakout-ram"`` (for recordings): :class:`BreakoutEnv`
    observing the RAM unless ``obs_mode`` says otherwise."""
    settings["obs_mode"] = settings.get("obs_mode") or "ram"
    return BreakoutEnv(**settings)
