"""Stable-Baselines3's ``VecEnv`` over a natively vectorised Gymnasium world.

SB3 wants ``reset() -> obs``, ``step_wait() -> (obs, rewards, dones, infos)`` with a list
of per-environment info dicts holding ``terminal_observation`` and
``TimeLimit.truncated``, and resets finished environments itself in the same step. A
Gymnasium :class:`~gymnasium.vector.VectorEnv` with *same-step* autoreset (such as
:class:`~noisybolt.envs.gridworld_vec.VectorGridworld`) already does the last part, so
:class:`SB3VecEnv` only translates the return values.

The world's own ``info`` is batched (arrays with a leading env axis); SB3's is a list of
per-env dicts. The batched bolt (:class:`noisybolt.wrappers.BoltVecEnv`) reads the
world–bolt contract (:mod:`noisybolt.perception.protocols`) from the batched form, which
:attr:`SB3VecEnv.batched_info` keeps from the last reset or step, as SB3 keeps a reset's
infos in ``reset_infos``: splitting the camera images into per-env dicts only for the bolt
to stack them again would cost a copy of every image every step (and make a deferred
camera render whether or not anyone looks). The per-env dicts hold SB3's keys.

Example:
    >>> from noisybolt.envs.gridworld_vec import VectorGridworld
    >>> venv = SB3VecEnv(VectorGridworld(4, obs_mode="grid"))
    >>> venv.seed(0)
    [0, 1, 2, 3]
    >>> venv.reset().shape
    (4, 6, 6, 3)
    >>> obs, rewards, dones, infos = venv.step(np.array([2, 2, 2, 2]))
    >>> rewards.dtype, infos[0]["TimeLimit.truncated"]
    (dtype('float32'), False)
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from stable_baselines3.common.vec_env import VecEnv

from noisybolt.envs.worker_world import WorkerWorld
from noisybolt.errors import ConfigError
from noisybolt.perception.protocols import CameraSpec, goal_declared

__all__ = ["SB3VecEnv"]


class SB3VecEnv(VecEnv):
    """Adapts a same-step-autoreset Gymnasium vector env to SB3's ``VecEnv``.

    ``get_attr``/``set_attr``/``env_method`` address the one vectorised object, so they
    read, write or call it once and repeat the answer for each index asked about.

    Args:
        venv: the vectorised world.

    Raises:
        ConfigError: if ``venv`` does not reset in the same step.
    """

    def __init__(self, venv: VectorEnv) -> None:
        mode = venv.metadata.get("autoreset_mode")
        if mode != AutoresetMode.SAME_STEP:
            raise ConfigError(
                f"SB3VecEnv needs a vector env with AutoresetMode.SAME_STEP, got {mode!r}"
            )
        self.venv = venv
        super().__init__(
            num_envs=venv.num_envs,
            observation_space=venv.single_observation_space,
            action_space=venv.single_action_space,
        )
        self._actions: np.ndarray | None = None
        self._batched_info: dict[str, Any] = {}

    # ------------------------------------------------------------------ SB3 VecEnv

    def reset(self) -> np.ndarray:
        """Reset every environment; uses the seed given to :meth:`seed`, if any."""
        seed = self._seeds[0]
        obs, self._batched_info = self.venv.reset(seed=seed)
        self._reset_seeds()
        self._reset_options()
        self.reset_infos = [dict() for _ in range(self.num_envs)]
        return obs

    def step_async(self, actions: np.ndarray) -> None:
        """Remember the actions for :meth:`step_wait`; a world that steps in worker
        processes (:class:`~noisybolt.envs.worker_world.WorkerWorld`) starts the step here
        and makes it while the caller goes on."""
        self._actions = np.asarray(actions)
        if isinstance(self.venv, WorkerWorld):
            self.venv.step_async(self._actions)

    def step_wait(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[dict[str, Any]]]:
        """Step; finished environments report their last observation in their info."""
        if self._actions is None:
            raise RuntimeError("step_wait called before step_async")
        if isinstance(self.venv, WorkerWorld):
            obs, rewards, terminated, truncated, vinfo = self.venv.step_wait()
        else:
            obs, rewards, terminated, truncated, vinfo = self.venv.step(self._actions)
        self._actions = None
        self._batched_info = vinfo
        dones = terminated | truncated
        infos: list[dict[str, Any]] = [{"TimeLimit.truncated": False} for _ in range(self.num_envs)]
        success = bool(getattr(self.venv, "termination_is_success", False))
        goal = self.declares_goal
        # A world of labelled envs says itself, in the ended step's info.
        final = vinfo.get("final_info", {})
        said = final.get("is_success"), final.get("_is_success")
        for i in np.flatnonzero(dones):
            infos[i]["TimeLimit.truncated"] = bool(truncated[i] and not terminated[i])
            infos[i]["terminal_observation"] = vinfo["final_obs"][i]
            # SB3's convention (Monitor, EvalCallback): did the ended episode succeed?
            # Not said at all for a world without a goal.
            if goal and said[0] is not None and said[1] is not None and said[1][i]:
                infos[i]["is_success"] = bool(said[0][i])
            elif goal:
                infos[i]["is_success"] = success and bool(terminated[i])
        return obs, rewards.astype(np.float32), dones, infos

    @property
    def declares_goal(self) -> bool:
        """Whether the world's episodes have a goal (:func:`goal_declared`): only then does
        an ended episode's info say ``is_success``."""
        return goal_declared(self.venv)

    @property
    def batched_info(self) -> dict[str, Any]:
        """The world's Gymnasium ``info`` of the last reset or step, as the world gave it:
        batched (a leading env axis, ``_key`` masks, ``final_info`` for the episodes that
        ended), before :meth:`step_wait` makes SB3's per-env dicts. Empty before the first
        reset."""
        return self._batched_info

    def close(self) -> None:
        """Close the vectorised world."""
        self.venv.close()

    def get_attr(self, attr_name: str, indices: Any = None) -> list[Any]:
        """The world's attribute, once per index."""
        value = getattr(self.venv, attr_name)
        return [value for _ in self._get_indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: Any = None) -> None:
        """Set an attribute on the world (for all environments at once)."""
        setattr(self.venv, attr_name, value)

    def env_method(
        self, method_name: str, *method_args: Any, indices: Any = None, **method_kwargs: Any
    ) -> list[Any]:
        """Call a method of the world once; its result is repeated per index."""
        result = getattr(self.venv, method_name)(*method_args, **method_kwargs)
        return [result for _ in self._get_indices(indices)]

    def env_is_wrapped(self, wrapper_class: type[gym.Wrapper], indices: Any = None) -> list[bool]:
        """Always False: there are no per-environment Gymnasium wrappers."""
        return [False for _ in self._get_indices(indices)]

    def get_images(self) -> Sequence[np.ndarray | None]:
        """Frames from the world's ``render()`` (needs ``render_mode="rgb_array"``)."""
        frames = self.venv.render()
        if frames is None:
            return [None for _ in range(self.num_envs)]
        return [np.asarray(frame) for frame in frames]

    def _get_indices(self, indices: Any) -> Iterable[int]:
        if indices is None:
            return range(self.num_envs)
        if isinstance(indices, int):
            return [indices]
        return list(indices)

    # ------------------------------------------- what the world declares besides its info

    @property
    def fluent_names(self) -> tuple[str, ...]:
        """The world's fluents, in the column order of its ``info["true_fluents"]``
        (forwarded)."""
        return self.venv.fluent_names  # type: ignore[attr-defined]

    @property
    def camera_spec(self) -> CameraSpec:
        """The world's bolt camera (forwarded)."""
        return self.venv.camera_spec  # type: ignore[attr-defined]
