"""Training callbacks in Stable-Baselines3's style: each does one thing.

* :class:`EvaluationCallback` evaluates the policy every ``eval_freq`` frames (compliance
  from ground truth), records ``metrics.json`` and TensorBoard, and steps its children:
  ``callback_on_new_best`` when the shaped return is the best so far, and
  ``callback_after_eval`` after every evaluation (e.g.
  :class:`noisybolt.runs.stopping.StopWhenSolved`), as SB3's ``EvalCallback`` does.
* :class:`SaveBestModel`: the new-best child that keeps that model (``keep_best``).
* :class:`CheckpointCallback` writes a complete checkpoint every ``checkpoint_freq``
  frames with the evaluation callback's bookkeeping.
* :class:`LinearSchedule` moves the entropy coefficient, the learning rate or PPO's clip
  range over the run's frames (:func:`linear_schedules` reads them from the run's
  hyperparameters).
* :class:`UpdateThreads` gives an on-policy update the cores a world in worker processes
  leaves idle while it waits for the next rollout.
"""

from __future__ import annotations

import os
import shutil
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import torch
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.utils import ConstantSchedule
from stable_baselines3.common.vec_env import VecEnv

from noisybolt.agents.constraint import LagrangianCallback
from noisybolt.agents.hyperparams import SCHEDULED, constructor_defaults
from noisybolt.errors import ConfigError
from noisybolt.runs.checkpoints import BEST_DIR, best_folder, save_checkpoint, save_model_files
from noisybolt.runs.config import TrainConfig
from noisybolt.runs.evaluation import EvalResult, evaluate_bolted_policy
from noisybolt.runs.rundir import RunDirectory

__all__ = [
    "CheckpointCallback",
    "EvaluationCallback",
    "LinearSchedule",
    "SaveBestModel",
    "UpdateThreads",
    "budget_score",
    "linear_schedules",
    "shaped_return",
]


def shaped_return(result: EvalResult) -> float:
    """What the agent is trained to maximise, as measured: env + bolt return (means)."""
    return float(result.env_return_mean + result.bolt_return_mean)


def budget_score(result: EvalResult, *, scale: float, cost_limit: float) -> float:
    """What chooses the kept model under the ``constrained`` scheme: the world's mean
    return, less ``scale`` for every spec an episode leaves unsatisfied (as the bolt
    sees it: :attr:`~noisybolt.runs.evaluation.EvalResult.bolt_cost_mean`) beyond the
    budget ``cost_limit``, on average.

    The constrained learner maximises its return subject to its cost staying within the
    budget; judged by the shaped return at the full price instead, every violation
    within the budget is charged too, and a model that spends its budget loses to one
    that complies more than asked: on the toll road (A2C seed 2, ``d`` 0.1, ground truth
    as the cost), the shaped return kept an evaluation violating in 1 % of episodes
    (return 0.005) where this keeps one at 12 % (0.106). At a budget near 0 the two
    choose alike (the world suite's kept models are the same under either). An
    evaluation that did not record the bolt's view falls back to the shaped return.

    Example:
        >>> from noisybolt.runs.evaluation import EvalResult
        >>> def result(ret, cost):
        ...     return EvalResult(20, ret, 0.0, 0.0, 10.0, None, {}, 0.0, bolt_cost_mean=cost)
        >>> budget_score(result(0.3, 0.1), scale=1.1, cost_limit=0.1)  # within the budget
        0.3
        >>> round(budget_score(result(0.5, 0.3), scale=1.1, cost_limit=0.1), 2)  # 0.2 over
        0.28
    """
    if result.bolt_cost_mean is None:
        return shaped_return(result)
    excess = max(0.0, result.bolt_cost_mean - cost_limit)
    return float(result.env_return_mean - scale * excess)


def next_multiple(value: int, step: int) -> int:
    """The first multiple of ``step`` above ``value`` (0 when ``step`` is 0: never)."""
    return (value // step + 1) * step if step else 0


class EvaluationCallback(BaseCallback):
    """Periodic evaluation of the policy, from ground truth, recorded in the run.

    Args:
        config: the run.
        run: its directory (``metrics.json``).
        eval_env: the evaluation envs (:func:`noisybolt.runs.environments.make_env`).
        spec_names: the specs' names, in order.
        history: the evaluations so far (a resumed run's), appended to.
        frames_to_comply: N_frames so far (None while not reached).
        best: the best evaluation so far, ``{"frames", "shaped_return"}`` (None: none).
        callback_on_new_best: stepped after an evaluation whose shaped return is at
            least the best so far (ties go to the later, longer trained, model).
        callback_after_eval: stepped after every evaluation; returning False ends
            training.

    Attributes:
        last_result: the latest evaluation (None before the first).
    """

    def __init__(
        self,
        *,
        config: TrainConfig,
        run: RunDirectory,
        eval_env: VecEnv,
        spec_names: Sequence[str],
        history: list[dict[str, Any]],
        frames_to_comply: int | None = None,
        best: dict[str, Any] | None = None,
        callback_on_new_best: BaseCallback | None = None,
        callback_after_eval: BaseCallback | None = None,
    ) -> None:
        super().__init__(verbose=0)
        self.config = config
        self.run = run
        self.eval_env = eval_env
        self.spec_names = list(spec_names)
        self.history = history
        self.frames_to_comply = frames_to_comply
        self.best = best
        self.callback_on_new_best = callback_on_new_best
        self.callback_after_eval = callback_after_eval
        for child in (callback_on_new_best, callback_after_eval):
            if child is not None:
                child.parent = self
        self.last_result: EvalResult | None = None
        #: The constrained scheme's callback, whose raised scale (where the world's
        #: returns outran an estimated one) judges the kept model; None: the config's.
        self.constraint: LagrangianCallback | None = None
        self._next_eval = 0
        self._stop = False

    def _init_callback(self) -> None:
        self._next_eval = next_multiple(self.model.num_timesteps, self.config.evaluation.freq)
        self._stop = False
        for child in (self.callback_on_new_best, self.callback_after_eval):
            if child is not None:
                child.init_callback(self.model)

    def missed(self) -> bool:
        """Whether the evaluation due at the model's frames is not in the history: a run
        stopped during a periodic evaluation (Ctrl-C, SIGTERM) saves its checkpoint at
        those very frames, and a resume would otherwise go on to the next one, leaving a
        hole in the learning curve."""
        frames, freq = int(self.model.num_timesteps), self.config.evaluation.freq
        return bool(
            freq
            and frames > 0
            and frames % freq == 0
            and not any(record["frames"] == frames for record in self.history)
        )

    def _on_training_start(self) -> None:
        # learn() has set up the logger evaluations record to: catch up on a missed one,
        # at the frames it was due (its actions seeded by them, as it would have been).
        if self.missed():
            self.evaluate()
            if self.callback_after_eval is not None:
                self._stop = not self.callback_after_eval.on_step()

    @property
    def success_rate(self) -> float:
        """The latest evaluation's share of episodes at the goal and compliant (0 before)."""
        return self.last_result.success_rate if self.last_result is not None else 0.0

    def evaluate(self) -> EvalResult:
        """Evaluates the current policy and records it (metrics.json, TensorBoard)."""
        model = self.model
        deterministic = self.config.evaluation.deterministic
        frames = int(model.num_timesteps)
        # Sampled evaluation actions draw from torch's and numpy's global generators (DQN's
        # epsilon uses numpy's). Draw them from generators of their own, seeded by the
        # frame count, so that how often a run is evaluated does not change its training.
        numpy_state = np.random.get_state()  # noqa: NPY002 (SB3 uses the legacy global)
        with torch.random.fork_rng(devices=[]):
            torch.manual_seed(self.config.seed * 1_000_003 + frames)
            np.random.seed((self.config.seed * 1_000_003 + frames) % 2**32)  # noqa: NPY002
            try:
                result = evaluate_bolted_policy(
                    lambda obs: model.predict(obs, deterministic=deterministic)[0],
                    self.eval_env,
                    n_episodes=self.config.evaluation.episodes,
                    spec_names=self.spec_names,
                )
            finally:
                np.random.set_state(numpy_state)  # noqa: NPY002
        self.last_result = result
        if (
            self.frames_to_comply is None
            and result.success_rate >= self.config.evaluation.success_threshold
        ):
            self.frames_to_comply = frames
        self.history.append({"frames": frames, **result.to_dict()})
        self.run.write_metrics(self.history)
        for key in ("env_return_mean", "length_mean", "goal_rate", "success_rate"):
            if getattr(result, key) is not None:  # goal_rate: None for a world without goal
                model.logger.record(f"eval/{key}", getattr(result, key))
        for name, rate in result.compliance.items():
            model.logger.record(f"eval/compliance/{name}", rate)
        if self.callback_on_new_best is not None:
            score = self.score(result)
            if self.best is None or score >= self._best_score(self.best):
                self.best = {"frames": frames, "shaped_return": shaped_return(result)}
                self.best["score"] = score
                self.callback_on_new_best.on_step()
        return result

    def _best_score(self, best: Mapping[str, Any]) -> float:
        """The kept evaluation's score; a run resumed from a checkpoint written before
        scores were kept has its best evaluation scored again from the history."""
        if "score" in best:
            return float(best["score"])
        for record in self.history:
            if record["frames"] == best["frames"]:
                return self.score(EvalResult.from_record(record))
        return float(best["shaped_return"])

    def score(self, result: EvalResult) -> float:
        """What chooses the kept model: :func:`budget_score` under the ``constrained``
        scheme (the world's return within the cost budget), else :func:`shaped_return`."""
        bolt = self.config.bolt
        if not (bolt.bolted and bolt.reward == "constrained"):
            return shaped_return(result)
        # Over budget, an episode costs at least its dearest spec's scale.
        scales = [
            float(spec.get("reward_scale") or bolt.reward_scale or 1.0) for spec in bolt.specs
        ]
        factor = 1.0 if self.constraint is None else self.constraint.scale_factor
        return budget_score(
            result,
            scale=max(scales, default=1.0) * factor,
            cost_limit=bolt.cost_limit.cost_limit,
        )

    def _on_step(self) -> bool:
        if self._stop:  # the caught-up evaluation ended the run
            return False
        frames = self.model.num_timesteps
        if not self.config.evaluation.freq or frames < self._next_eval:
            return True
        self.evaluate()
        self._next_eval = next_multiple(frames, self.config.evaluation.freq)
        if self.callback_after_eval is not None:
            return self.callback_after_eval.on_step()
        return True


class SaveBestModel(BaseCallback):
    """Child of :class:`EvaluationCallback`: saves the new best model in ``best/step_N``."""

    def __init__(self, run: RunDirectory, *, algo: str) -> None:
        super().__init__(verbose=0)
        self.run = run
        self.algo = algo

    def _on_step(self) -> bool:
        parent = self.parent
        if not isinstance(parent, EvaluationCallback) or parent.best is None:
            raise ConfigError("SaveBestModel is the callback_on_new_best of EvaluationCallback")
        env = self.model.get_env()
        assert env is not None
        folder = best_folder(self.run, int(parent.best["frames"]))
        save_model_files(self.model, env, folder, algo=self.algo)
        return True


class CheckpointCallback(BaseCallback):
    """A complete checkpoint every ``checkpoint_freq`` frames (0: only when asked).

    Its bookkeeping (evaluations, N_frames, the best model) is the evaluation callback's,
    so it follows that callback in a ``CallbackList``.
    """

    def __init__(
        self,
        *,
        config: TrainConfig,
        run: RunDirectory,
        evaluation: EvaluationCallback,
        constraint: LagrangianCallback | None = None,
    ):
        super().__init__(verbose=0)
        self.config = config
        self.run = run
        self.evaluation = evaluation
        #: The constrained scheme's callback (its multiplier is saved), or None.
        self.constraint = constraint
        self._next_checkpoint = 0

    def _init_callback(self) -> None:
        self._next_checkpoint = next_multiple(self.model.num_timesteps, self.config.checkpoint_freq)

    def checkpoint(self) -> None:
        """Saves a complete checkpoint now."""
        env = self.model.get_env()
        assert env is not None
        evaluation = self.evaluation
        state = {
            "frames_to_comply": evaluation.frames_to_comply,
            "history": evaluation.history,
            "best": evaluation.best,
        }
        if self.constraint is not None:
            state["multiplier"] = self.constraint.state_dict()
        save_checkpoint(self.model, env, self.run, state, algo=self.config.algorithm.name)
        # Only now that the newest checkpoint names this best model may the older ones
        # go: a run killed earlier resumes from a checkpoint naming one of them.
        if evaluation.best is not None:
            keep = best_folder(self.run, evaluation.best["frames"])
            for folder in self.run.file(BEST_DIR).glob("step_*"):
                if folder != keep:
                    shutil.rmtree(folder, ignore_errors=True)

    def _on_step(self) -> bool:
        frames = self.model.num_timesteps
        if self.config.checkpoint_freq and frames >= self._next_checkpoint:
            self.checkpoint()
            self._next_checkpoint = next_multiple(frames, self.config.checkpoint_freq)
        return True


class LinearSchedule(BaseCallback):
    """A hyperparameter of :data:`~noisybolt.agents.hyperparams.SCHEDULED` moved linearly
    from ``start`` to ``end`` over a run's frames.

    SB3 reads ``model.ent_coef`` at every update but schedules only the learning rate and
    PPO's clip range, and those over the fraction of one ``learn()`` call done, which a
    resumed run or one given more frames restarts or stretches. Here the value is set
    before each rollout from the run's own frames done (``model.num_timesteps``), so a
    resumed run continues the same schedule, and ``<name>_frames`` fixes it in frames
    whatever the budget. Why each: a high entropy bonus early keeps the policy trying
    routes that pay a little more (A2C settled on ``!F(t)``'s shortcut through the corner
    at 0.01), a low one late lets it act as surely as it has learnt (at 0.05 throughout,
    sampled ``G(on_edge)`` episodes stepped off the edge in up to 6 %); the RL Zoo's Atari
    settings anneal PPO's learning rate and clip range to zero (the Breakout players of
    results/breakout stalled at a constant 2.5e-4 and moved again at 1e-4).

    Args:
        name: ``ent_coef`` (PPO, A2C), ``learning_rate`` (any) or ``clip_range`` (PPO).
        start: value at frame 0.
        end: value from ``frames`` on.
        frames: frames over which it moves (the hyperparameter ``<name>_frames``, or the
            run's budget without it).
    """

    def __init__(self, name: str, start: float, end: float, frames: int) -> None:
        super().__init__(verbose=0)
        if name not in SCHEDULED:
            raise ConfigError(f"no schedule for {name!r}; scheduled: {list(SCHEDULED)}")
        if start < 0 or end < 0 or frames < 1:
            raise ConfigError(
                f"{name} schedule: values must be >= 0 and frames >= 1, got {start}, {end}, "
                f"{frames}"
            )
        self.name = name
        self.start, self.end, self.frames = float(start), float(end), int(frames)

    def value(self, frames_done: int) -> float:
        """The value after ``frames_done`` frames."""
        progress = min(1.0, max(0, frames_done) / self.frames)
        return self.start + (self.end - self.start) * progress

    def _on_rollout_start(self) -> None:
        value = self.value(self.model.num_timesteps)
        model: Any = self.model
        if self.name == "ent_coef":
            model.ent_coef = value
        elif self.name == "learning_rate":
            # SB3 sets the optimiser's rate from lr_schedule at each update (and logs it);
            # learning_rate is what model.zip shows.
            model.learning_rate = value
            model.lr_schedule = ConstantSchedule(value)
        else:
            model.clip_range = ConstantSchedule(value)

    def _on_step(self) -> bool:
        return True


def linear_schedules(
    hyperparams: Mapping[str, Any], *, algo: str, frames: int
) -> list[LinearSchedule]:
    """The schedules a run's hyperparameters ask for: one per ``<name>_final`` given, from
    ``<name>`` (SB3's default where unset) over ``<name>_frames`` or the run's ``frames``.

    Example:
        >>> [s.value(500) for s in linear_schedules(
        ...     {"learning_rate": 1e-3, "learning_rate_final": 0.0}, algo="ppo", frames=1000)]
        [0.0005]
    """
    defaults = constructor_defaults(algo)
    out = []
    for name in SCHEDULED:
        end = hyperparams.get(f"{name}_final")
        if end is None:
            continue
        start = hyperparams.get(name, defaults.get(name, 0.0))
        span = hyperparams.get(f"{name}_frames") or frames
        out.append(LinearSchedule(name, float(start), float(end), int(span)))
    return out


class UpdateThreads(BaseCallback):
    """More torch threads for an on-policy update, one for the rollouts.

    A run computes on one torch thread (``torch.set_num_threads(1)``: with the world in
    the same process, a second thread only fights the emulator for the cores; PPO ran at
    71 frames/s on two threads against 620 on one). With the world in worker processes
    (``world.workers``) the workers wait, blocked on their pipes, while PPO or A2C
    updates, so for that stretch the other cores are idle: this callback gives the update
    ``threads`` threads (set as the rollout ends, just before SB3's ``train()``) and takes
    them back as the next rollout starts. Measured on the 2-core machine (Breakout RAM
    PPO, 1,024 frames a rollout, 16 minibatches of 256): 113 ms an update on one thread,
    90 on two.

    Args:
        threads: torch threads for the update (the rollouts always get 1).
    """

    def __init__(self, threads: int) -> None:
        super().__init__(verbose=0)
        if threads < 1:
            raise ConfigError(f"update threads must be >= 1, got {threads}")
        self.threads = int(threads)

    @staticmethod
    def for_this_machine() -> UpdateThreads:
        """As many threads as this process may run on, at most 4 (a 256-unit network's
        products gain little past that)."""
        try:
            cores = len(os.sched_getaffinity(0))
        except AttributeError:  # not Linux
            cores = os.cpu_count() or 1
        return UpdateThreads(min(cores, 4))

    def _on_rollout_end(self) -> None:
        torch.set_num_threads(self.threads)

    def _on_rollout_start(self) -> None:
        torch.set_num_threads(1)

    def _on_training_end(self) -> None:
        torch.set_num_threads(1)

    def _on_step(self) -> bool:
        return True
