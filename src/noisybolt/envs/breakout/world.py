"""Atari Breakout's games, stepped together: :class:`BreakoutWorld`.

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
and :meth:`BreakoutWorld.true_fluents` are views of them for sample collection): the
fluents read from RAM (:mod:`noisybolt.envs.breakout.ram`) and the camera's noisy view of
the colour frame (:mod:`noisybolt.envs.breakout.camera`).

Example:
    >>> world = BreakoutWorld(BreakoutConfig(num_envs=2, obs_mode="ram"), seed=0)
    >>> obs, info = world.reset(seed=0)
    >>> obs.shape, world.config.seed, np.asarray(info["true_fluents"]).shape
    ((2, 128), 0, (2, 7))
    >>> world.close()
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from typing import Any

import ale_py
import cv2
import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.vector import AutoresetMode

from noisybolt.bolt.schemes import ReturnBounds
from noisybolt.envs.breakout.camera import camera_resize, resolve_noise
from noisybolt.envs.breakout.config import BreakoutConfig
from noisybolt.envs.breakout.ram import (
    BRICK_COLUMNS,
    BRICK_ROWS,
    FLUENT_NAMES,
    MAX_BRICKS,
    MAX_SCORE,
    RAM_SIZE,
    breakout_fluents,
    bricks_present,
    set_bricks,
)
from noisybolt.envs.deferred import DeferredArray
from noisybolt.envs.fluents import select_fluents
from noisybolt.errors import ConfigError
from noisybolt.perception.noise import NoiseModel
from noisybolt.perception.protocols import (
    BOLT_IMAGE_KEY,
    FINAL_INFO_KEY,
    TRUE_FLUENTS_KEY,
    CameraSpec,
)

__all__ = ["BreakoutWorld"]

_FIRE = 1  # FIRE's index in Breakout's minimal action set (NOOP, FIRE, RIGHT, LEFT)
_WALL_SETTLE_FRAMES = 40  # the game sets its wall up during the first 36 frames of a game


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
        config: the world's settings (default: :class:`BreakoutConfig`'s).
        **settings: settings as keywords (the fields of :class:`BreakoutConfig`), over
            ``config``'s where both are given.

    Raises:
        ConfigError: for an out-of-range setting (see :class:`BreakoutConfig`) or noise.
        UnknownFluentError: for a fluent Breakout does not have.
    """

    termination_is_success = False

    def __init__(self, config: BreakoutConfig | None = None, **settings: Any) -> None:
        config = BreakoutConfig(**settings) if config is None else replace(config, **settings)
        self.config = config
        self.shard = config.games
        self._fluent_names, self._fluent_columns = select_fluents(
            "breakout", FLUENT_NAMES, config.fluents
        )
        noise_fn, noise_description = resolve_noise(config.noise)
        self.metadata = {"autoreset_mode": AutoresetMode.SAME_STEP}
        self.autoreset_mode = AutoresetMode.SAME_STEP
        self.num_envs = config.num_envs
        self.left_columns = config.left_columns
        self.camera_size = config.camera_size
        self.frame_skip = config.frame_skip
        self.noop_max = config.noop_max
        self.repeat_action_probability = config.repeat_action_probability
        self.frame_stack = config.frame_stack
        self.screen_size = config.screen_size
        self.max_episode_frames = config.max_episode_frames
        self.fire_on_reset = bool(config.fire_on_reset)
        self.obs_mode = config.obs_mode
        self.left_head_start = float(config.left_head_start)
        self._ram_obs = config.obs_mode in ("ram", "ram_bits")
        self._noise = noise_fn
        # A noise model's own apply_each draws each game's noise alike, in one batch.
        owner = getattr(noise_fn, "__self__", None)
        self._noise_model = owner if isinstance(owner, NoiseModel) else None
        self._seed = config.seed

        ale_py.ALEInterface.setLoggerMode(ale_py.LoggerMode.Error)
        rom = ale_py.roms.get_rom_path("breakout")
        if rom is None:  # pragma: no cover - ale-py ships the ROM
            raise RuntimeError("ale-py has no Breakout ROM; reinstall ale-py >= 0.9")
        self._rom = rom
        self._ales = [ale_py.ALEInterface() for _ in range(config.num_envs)]
        self._np_rngs = [np.random.default_rng() for _ in range(config.num_envs)]
        self._camera_rngs = [np.random.default_rng() for _ in range(config.num_envs)]
        self._seed_all(config.seed)
        self._actions = self._ales[0].getMinimalActionSet()

        self.single_observation_space: spaces.Box
        if config.obs_mode == "ram_bits":
            self.single_observation_space = spaces.Box(0, 1, (8 * RAM_SIZE,), np.uint8)
        elif self._ram_obs:
            self.single_observation_space = spaces.Box(0.0, 1.0, (RAM_SIZE,), np.float32)
        else:
            self.single_observation_space = spaces.Box(
                0, 255, (config.frame_stack, config.screen_size, config.screen_size), np.uint8
            )
        self.single_action_space = spaces.Discrete(len(self._actions))
        self.observation_space = gym.vector.utils.batch_space(
            self.single_observation_space, config.num_envs
        )
        self.action_space = gym.vector.utils.batch_space(self.single_action_space, config.num_envs)
        self._camera_spec = CameraSpec(
            world="breakout",
            height=config.camera_size,
            width=config.camera_size,
            channels=3,
            noise=noise_description,
            extra={
                "source": "ALE RGB frame 210x160, cv2.INTER_AREA",
                # What each fluent means (left_columns changes brick_clear_left), so a
                # classifier, and the cache of classifiers trained on the fly, must not
                # cross them.
                "fluents": {
                    name: (
                        {"left_columns": config.left_columns} if name == "brick_clear_left" else {}
                    )
                    for name in self._fluent_names
                },
            },
        )

        self._grey = np.zeros((config.num_envs, 2, 210, 160), np.uint8)  # last two frames
        self._stack = np.zeros(
            (config.num_envs, config.frame_stack, config.screen_size, config.screen_size), np.uint8
        )
        self._done = np.zeros(config.num_envs, dtype=bool)  # which games ended in the last step
        self._final_rgb: dict[int, np.ndarray] = {}  # their last colour frame and RAM
        self._final_ram: dict[int, np.ndarray] = {}
        self._lives = np.zeros(config.num_envs, dtype=np.int64)
        self._every = np.ones(config.num_envs, dtype=bool)  # the labels' masks: every game
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
        images = camera_resize(frames, self.camera_size)
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
