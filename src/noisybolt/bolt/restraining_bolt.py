"""The restraining bolt: DFA states of a batch of environments, and the episode timing.

Timing (DESIGN.md, "Semantics fixed here"): the trace starts at the first observation.

* :meth:`RestrainingBolt.reset` reads the *first* observation of an episode: every DFA
  starts in its initial state (the empty trace) and takes its first transition on those
  probabilities. That transition's reward (terminal reward and low-confidence cost; for
  ``on_change`` specs only the cost: where an episode starts is its baseline) is
  not returned to the agent now (Gymnasium's ``reset`` has no reward); it is held as
  ``pending`` and added to the reward of the episode's first :meth:`~RestrainingBolt.step`.
* :meth:`RestrainingBolt.step` reads the observation that *follows* an action: each DFA
  takes one transition on its probabilities. ``done`` marks the transitions that end an
  episode (terminated or truncated); ``episode_end`` specs are paid on those. An ended
  environment must be reset before its next step.

Vectorised environments that reset automatically deliver the last observation of the old
episode and the first observation of the new one together. Both kinds are handled:

* **Same step** (Stable-Baselines3 ``VecEnv``; Gymnasium ``AutoresetMode.SAME_STEP``): the
  step returns the new episode's first observation, and the old episode's last one in
  ``infos[i]["terminal_observation"]`` (``infos["final_obs"]``). Call
  ``out = bolt.step(final_probs, done=dones)`` with, for ended environments, the
  probabilities of the *final* observation (for the others, of the returned one); the
  agent's reward is ``env_reward + out.total``, and ``out.next_states`` are the ended
  episodes' final DFA states (for the terminal observation). Then call
  ``bolt.reset(first_probs, env_mask=dones)`` with the probabilities of the returned
  observations: the ended environments restart on their new episode's first
  observation, its reward is held for their next step, and :attr:`states` is what the
  returned observation should carry.
* **Next step** (Gymnasium ``AutoresetMode.NEXT_STEP``, the default of Gymnasium 1.x
  vector envs): the step after ``done`` is a reset step for those environments (their
  action is ignored and their observation is the new episode's first). Call
  ``bolt.reset(probs, env_mask=autoreset)`` and ``bolt.step(probs, done=dones,
  env_mask=~autoreset)`` with the same probabilities; the reset environments get no bolt
  reward on that step (the env gives none either), their first transition's reward is
  paid on their next step.

Rows of ``probs`` outside ``env_mask`` are checked but not read.

Tracking (``tracking=``): ``"threshold"`` is Algorithm 1 as above. ``"belief"`` keeps a
distribution over each spec's DFA states (:mod:`noisybolt.bolt.belief`) with the same
episode timing; its :class:`BoltStep` reports the decisions taken on the belief:
``next_states`` the most likely states, ``accepting`` (``violated``) where the probability
of an accepting state (a rejecting sink) is at least the confidence level, ``terminal``
paid on those decisions under each spec's timing (``on_entry``: once when the belief
becomes confident, again only after it has been as confident of the opposite, so one
event is not paid twice; ``on_change``: whenever the decision turns to accepting, taken
back whenever it turns away),
``low_confidence`` Algorithm 1's charge averaged over the belief of the state the step
leaves (``n_low``: the count under the most likely one), and ``progress`` the progress
terms in expectation over the belief (still potential-based: the potential of a belief
is its expected potential).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from noisybolt.bolt.bands import DEFAULT_THRESHOLDS, Thresholds, check_probs
from noisybolt.bolt.belief import BeliefEngine, BeliefSettings, Tracking
from noisybolt.bolt.engine import BoltEngine, BoltStep, CostMode, check_fluents, env_flags
from noisybolt.bolt.settings import BoltSettings, settings_from_keywords
from noisybolt.bolt.shaping import ProgressShaping
from noisybolt.bolt.spec import Spec
from noisybolt.errors import ConfigError
from noisybolt.logic import DFA, compile_ltlf

__all__ = ["RestrainingBolt"]


class RestrainingBolt:
    """Algorithm 1 with episode timing, for ``n_envs`` environments and several specs.

    See the module docstring for which probabilities each call reads and for the recipes
    for auto-resetting vectorised environments.

    Args:
        specs: the bolt's specifications; their rewards add up.
        fluents: the bolt's fluent vocabulary, the column order of every ``probs``.
        dfas: pre-built DFAs, one per spec (their vocabularies must be subsets of
            ``fluents``); None compiles each ``spec.formula`` with
            :func:`noisybolt.logic.compile_ltlf` over ``fluents``.
        settings: the bolt's settings (:class:`~noisybolt.bolt.BoltSettings`): bands,
            cost mode, reward scheme (the specs are paid as it says; a scheme other than
            ``paper`` adds its progress terms), tracking, ending. None: built from the
            keyword arguments below, which stay for code written before it; giving both
            is refused.
        n_envs: number of environments in the batch.
        shaping: progress terms to use instead of the scheme's
            (:class:`~noisybolt.bolt.ProgressShaping`; its DFAs must be this bolt's, in
            order), e.g. built with the world's letters; None: the scheme's (none under
            ``paper``: Algorithm 1 as the paper states it).
        thresholds, cost_mode, end_on_violation, pay_at_truncation, tracking, belief:
            the fields of :class:`~noisybolt.bolt.BoltSettings` of these names, as
            keywords. ``end_on_violation``: when a DFA enters a rejecting sink, set
            ``terminate`` in the step's result (the caller should end the episode) and
            pay ``episode_end`` specs there; a violation on the first observation is
            reported by :meth:`reset` and sets ``terminate`` at the first step.
            ``pay_at_truncation``: whether an episode cut by a time limit (``truncated``
            in :meth:`step`) is paid as ended (``episode_end`` rewards, the progress
            terms' end charge). True by default (plain LTLf on the trace so far), and
            what training uses under both schemes. False suits a learner that
            bootstraps at a time limit (SB3 does), which then counts the outcome twice;
            measured on ``F(top_right_corner) & F(bottom_left_corner)`` (PPO, 60k
            frames) paying there taught the 9-step detour in 2 of 3 seeds, not paying
            in 0 of 3: early on, episodes that visit both corners mostly end by the
            time limit.

    Raises:
        UnknownFluentError: a spec reads a fluent outside ``fluents``.
        SpecSyntaxError, BackendUnavailableError, CompilationError: from
            :func:`~noisybolt.logic.compile_ltlf`, when ``dfas`` is None.
        ConfigError: see :class:`~noisybolt.bolt.engine.BoltEngine` and
            :class:`~noisybolt.bolt.BoltSettings`; or a bad ``n_envs``; or ``settings``
            beside a keyword argument of a setting.
        UnknownNameError: an unknown ``tracking`` mode.

    Example:
        >>> from noisybolt.logic import DFA
        >>> f_e_and_t = DFA.from_function(["e", "t"], n_states=2, initial_state=0,
        ...     accepting=[False, True], delta=lambda q, m: 1 if q == 1 or m == 0b11 else 0)
        >>> bolt = RestrainingBolt(
        ...     [Spec("F(e & t)", terminal_reward=10.0, low_confidence_cost=2.0)],
        ...     ["e", "t"], dfas=[f_e_and_t], n_envs=2)
        >>> bolt.n_states
        (2,)
        >>> first = bolt.reset(np.array([[0.1, 0.1], [0.7, 0.95]]))
        >>> bolt.states.tolist(), bolt.pending.tolist()
        ([[0], [1]], [0.0, 8.0])
        >>> out = bolt.step(np.array([[0.95, 0.95], [0.2, 0.2]]), done=np.array([False, True]))
        >>> out.total.tolist()  # env 1: 10 for being accepting + 8 carried from reset
        [10.0, 18.0]
    """

    def __init__(
        self,
        specs: Sequence[Spec],
        fluents: Sequence[str],
        *,
        dfas: Sequence[DFA] | None = None,
        settings: BoltSettings | None = None,
        n_envs: int = 1,
        shaping: ProgressShaping | None = None,
        thresholds: Thresholds = DEFAULT_THRESHOLDS,
        cost_mode: CostMode = "count",
        end_on_violation: bool = False,
        pay_at_truncation: bool = True,
        tracking: Tracking = "threshold",
        belief: BeliefSettings | None = None,
    ) -> None:
        settings = settings_from_keywords(
            settings,
            {
                "thresholds": thresholds,
                "cost_mode": cost_mode,
                "end_on_violation": end_on_violation,
                "pay_at_truncation": pay_at_truncation,
                "tracking": tracking,
                "belief": belief,
            },
            owner="RestrainingBolt",
        )
        if isinstance(n_envs, bool) or not isinstance(n_envs, (int, np.integer)) or n_envs < 1:
            raise ConfigError(f"n_envs must be a positive integer, got {n_envs!r}")
        specs = settings.paid(specs)
        vocabulary = check_fluents(fluents)
        if dfas is None:
            dfas = [compile_ltlf(spec.formula, vocabulary) for spec in specs]
        self._engine = BoltEngine(
            specs, dfas, vocabulary, thresholds=settings.thresholds, cost_mode=settings.cost_mode
        )
        if shaping is None:
            shaping = settings.progress_terms(self._engine.dfas, self._engine.specs)
        if shaping is not None and (
            not isinstance(shaping, ProgressShaping)
            or len(shaping.dfas) != len(self._engine.dfas)
            or any(a is not b for a, b in zip(shaping.dfas, self._engine.dfas, strict=True))
        ):
            raise ConfigError("shaping must be a ProgressShaping over this bolt's own DFAs")
        self._settings = settings
        self._shaping = shaping
        self._pay_at_truncation = settings.pay_at_truncation
        self._n_envs = int(n_envs)
        self._end_on_violation = settings.end_on_violation
        self._states = self._engine.initial_states(self._n_envs)
        self._pending = np.zeros(self._n_envs)
        self._price = 1.0
        self._needs_reset = np.ones(self._n_envs, dtype=bool)
        self._tracking: Tracking = settings.tracking
        self._belief: BeliefEngine | None = None
        if settings.belief_settings is not None:
            self._init_belief(settings.belief_settings)

    # ------------------------------------------------------------------ properties
    @property
    def settings(self) -> BoltSettings:
        """The bolt's settings, as given or built from its keyword arguments."""
        return self._settings

    @property
    def engine(self) -> BoltEngine:
        """The stateless Algorithm 1 engine."""
        return self._engine

    @property
    def specs(self) -> tuple[Spec, ...]:
        """The specifications, in order."""
        return self._engine.specs

    @property
    def dfas(self) -> tuple[DFA, ...]:
        """The specs' DFAs, in order."""
        return self._engine.dfas

    @property
    def fluents(self) -> tuple[str, ...]:
        """The bolt's vocabulary: the column order of ``probs``."""
        return self._engine.fluents

    @property
    def n_envs(self) -> int:
        """Number of environments."""
        return self._n_envs

    @property
    def n_specs(self) -> int:
        """Number of specs."""
        return self._engine.n_specs

    @property
    def n_states(self) -> tuple[int, ...]:
        """DFA states per spec: the ``nvec`` of a ``MultiDiscrete`` observation space."""
        return self._engine.n_states

    @property
    def states(self) -> np.ndarray:
        """int64 ``[n_envs, n_specs]``: a copy of the current DFA states."""
        return self._states.copy()

    @property
    def pending(self) -> np.ndarray:
        """float64 ``[n_envs]``: reward of the reset transitions, paid at the next step."""
        return self._pending.copy()

    @property
    def needs_reset(self) -> np.ndarray:
        """bool ``[n_envs]``: environments whose episode ended (or never started)."""
        return self._needs_reset.copy()

    @property
    def thresholds(self) -> Thresholds:
        """The band thresholds."""
        return self._engine.thresholds

    @property
    def cost_mode(self) -> CostMode:
        """``"count"`` or ``"proportional"``."""
        return self._engine.cost_mode

    @property
    def shaping(self) -> ProgressShaping | None:
        """The progress shaping added to every transition, if any."""
        return self._shaping

    @property
    def tracking(self) -> Tracking:
        """``"threshold"`` (Algorithm 1) or ``"belief"``."""
        return self._tracking

    @property
    def belief_settings(self) -> BeliefSettings | None:
        """The settings of belief tracking (None under threshold tracking)."""
        return None if self._belief is None else self._belief.settings

    @property
    def beliefs(self) -> np.ndarray:
        """float64 ``[n_envs, sum(n_states)]``: each spec's distribution over its DFA
        states, concatenated in spec order (one-hot of :attr:`states` under threshold
        tracking)."""
        if self._belief is None:
            return np.concatenate(
                [np.eye(n)[self._states[:, s]] for s, n in enumerate(self.n_states)], axis=1
            )
        return np.concatenate(
            [self._marg_states[:, s, :n] for s, n in enumerate(self.n_states)], axis=1
        )

    @property
    def price(self) -> float:
        """What the specs' terminal rewards and progress terms are multiplied by (1: as
        the specs say). The ``constrained`` scheme sets it to its learned multiplier
        (:mod:`noisybolt.bolt.constraint`) between rollouts; the low-confidence charges are
        not scaled. A reward already pending from a reset keeps the price it was paid at.

        Raises:
            ConfigError: (on setting) a price that is negative or not finite.
        """
        return self._price

    @price.setter
    def price(self, value: float) -> None:
        if (
            isinstance(value, bool)
            or not isinstance(value, (int, float, np.floating))
            or not math.isfinite(value)
            or value < 0
        ):
            raise ConfigError(f"a bolt's price must be a finite number >= 0, got {value!r}")
        self._price = float(value)

    @property
    def end_on_violation(self) -> bool:
        """Whether a violated spec sets ``terminate``."""
        return self._end_on_violation

    # ------------------------------------------------------------------ episode timing
    def reset(self, probs: np.ndarray, env_mask: np.ndarray | None = None) -> BoltStep:
        """Starts new episodes on their first observation.

        Every DFA of the selected environments starts in its initial state and takes its
        first transition on ``probs``; the transition's total reward becomes
        :attr:`pending` (replacing any pending reward of an abandoned episode) and is
        added to the next :meth:`step`.

        Args:
            probs: float ``[n_envs, n_fluents]``, probabilities of each selected
                environment's *first* observation of its new episode.
            env_mask: bool ``[n_envs]``, the environments to reset (None: all).

        Returns:
            The first transition as a :class:`BoltStep` whose ``total`` is the reward now
            pending. Rows outside ``env_mask`` keep their states and have zero rewards.

        Raises:
            ValueError: bad ``probs`` or ``env_mask``.
        """
        probs = check_probs(
            probs, n_envs=self._n_envs, n_fluents=self._engine.n_fluents, fluents=self.fluents
        )
        rows = self._rows(env_mask)
        n_rows = self._n_envs if isinstance(rows, slice) else len(rows)
        initial = self._engine.initial_states(n_rows)
        no_end = np.zeros(n_rows, dtype=bool)
        if self._belief is not None:
            out = self._priced(self._belief_step(rows, probs[rows], done=no_end, first=True))
            self._pending[rows] = out.total
            self._needs_reset[rows] = False
            return self._expand(out, rows)
        out = self._engine._step(
            initial,
            probs[rows],
            done=no_end,
            first=np.ones(n_rows, dtype=bool),
            end_on_violation=False,
        )
        out = self._priced(self._shaped(out, initial, no_end, first=True))
        self._states[rows] = out.next_states
        self._pending[rows] = out.total
        self._needs_reset[rows] = False
        return self._expand(out, rows)

    def step(
        self,
        probs: np.ndarray,
        done: np.ndarray | bool | None = None,
        env_mask: np.ndarray | None = None,
        truncated: np.ndarray | bool | None = None,
    ) -> BoltStep:
        """One transition for every selected environment, on the observation after its action.

        Args:
            probs: float ``[n_envs, n_fluents]``, probabilities of the observation that
                follows the action; for an environment whose episode ends here, of its
                *final* observation (not the first one of the next episode).
            done: bool ``[n_envs]`` (or one bool): the episode ends with this step
                (terminated or truncated). Ended environments must be :meth:`reset`
                before their next step.
            env_mask: bool ``[n_envs]``, the environments that step (None: all).
            truncated: bool ``[n_envs]`` (or one bool): of the ``done`` episodes, those
                cut by a time limit rather than ended by the task (see
                ``pay_at_truncation``); None: none.

        Returns:
            The :class:`BoltStep`; ``total`` includes the reward ``carried`` from reset.
            Rows outside ``env_mask`` keep their states and have zero rewards.

        Raises:
            ValueError: bad ``probs``, ``done`` or ``env_mask``, or ``done`` set outside
                ``env_mask``.
            RuntimeError: a selected environment has not been reset since its episode
                ended (or ever).
        """
        probs = check_probs(
            probs, n_envs=self._n_envs, n_fluents=self._engine.n_fluents, fluents=self.fluents
        )
        done = env_flags(done, self._n_envs, "done")
        rows = self._rows(env_mask)
        if not isinstance(rows, slice):
            outside = done.copy()
            outside[rows] = False
            if outside.any():
                raise ValueError(
                    f"done is set for environments {np.flatnonzero(outside).tolist()} that "
                    "are outside env_mask"
                )
        stale = self._needs_reset[rows]
        if stale.any():
            envs = np.arange(self._n_envs)[rows][stale].tolist()
            raise RuntimeError(
                f"environments {envs} have no episode in progress: call "
                "reset(probs, env_mask=...) on the first observation of their new episode "
                "before stepping them"
            )
        states = self._states[rows]
        paid_end = (
            done
            if self._pay_at_truncation
            else done & ~env_flags(truncated, self._n_envs, "truncated")
        )
        if self._belief is not None:
            out = self._priced(
                self._belief_step(rows, probs[rows], done=paid_end[rows], first=False)
            )
            carried = self._pending[rows].copy()
            out = out._replace(carried=carried, total=out.total + carried)
            self._pending[rows] = 0.0
            self._needs_reset[rows] = done[rows] | out.terminate
            return self._expand(out, rows)
        out = self._engine._step(
            states,
            probs[rows],
            done=paid_end[rows],
            first=np.zeros(len(states), dtype=bool),
            end_on_violation=self._end_on_violation,
        )
        out = self._priced(self._shaped(out, states, paid_end[rows] | out.terminate))
        carried = self._pending[rows].copy()  # a view when rows is a slice
        out = out._replace(carried=carried, total=out.total + carried)
        self._pending[rows] = 0.0
        self._states[rows] = out.next_states
        self._needs_reset[rows] = done[rows] | out.terminate
        return self._expand(out, rows)

    # ------------------------------------------------------------------ helpers
    def _shaped(
        self, out: BoltStep, states: np.ndarray, ended: np.ndarray, *, first: bool = False
    ) -> BoltStep:
        """``out`` with the progress shaping of ``states -> out.next_states`` added (on an
        episode's ``first`` transition, none for ``on_change`` specs: see
        :meth:`~noisybolt.bolt.engine.BoltEngine.terminal_rewards`)."""
        if self._shaping is None:
            return out
        progress = self._shaping(states, out.next_states, done=ended)
        if first:
            progress = np.where(self._engine.pays_on_change, 0.0, progress)
        reward = out.reward + progress
        return out._replace(progress=progress, reward=reward, total=reward.sum(axis=1))

    def _priced(self, out: BoltStep) -> BoltStep:
        """``out`` with its scale-linear terms (terminal rewards and progress terms) at
        :attr:`price`; the low-confidence charges are Algorithm 1's and keep their size."""
        if self._price == 1.0:
            return out
        terminal, progress = self._price * out.terminal, self._price * out.progress
        reward = terminal + progress + out.low_confidence
        return out._replace(
            terminal=terminal, progress=progress, reward=reward, total=reward.sum(axis=1)
        )

    def _rows(self, env_mask: np.ndarray | None) -> slice | np.ndarray:
        """The selected rows: a full slice, or the indices where ``env_mask`` is set."""
        if env_mask is None:
            return slice(None)
        mask = env_flags(env_mask, self._n_envs, "env_mask")
        return slice(None) if mask.all() else np.flatnonzero(mask)

    def _expand(self, out: BoltStep, rows: slice | np.ndarray) -> BoltStep:
        """Scatters a result over selected rows into full ``[n_envs, ...]`` arrays."""
        if isinstance(rows, slice):
            return out
        if self._belief is None:
            accepting, violated = self._engine.state_flags(self._states)
        else:
            level = self._belief.settings.confidence
            accepting, violated = self._acc_prob >= level, self._viol_prob >= level
        full = BoltStep(
            next_states=self._states.copy(),
            terminal=np.zeros(self._states.shape),
            low_confidence=np.zeros(self._states.shape),
            n_low=np.zeros(self._states.shape, dtype=np.int64),
            accepting=accepting,
            violated=violated,
            progress=np.zeros(self._states.shape),
            reward=np.zeros(self._states.shape),
            carried=np.zeros(self._n_envs),
            total=np.zeros(self._n_envs),
            terminate=np.zeros(self._n_envs, dtype=bool),
        )
        for name, part in zip(BoltStep._fields, out, strict=True):
            getattr(full, name)[rows] = part
        return full

    # ------------------------------------------------------------------ belief tracking
    def _init_belief(self, settings: BeliefSettings) -> None:
        self._belief = BeliefEngine(self.dfas, self.fluents, settings)
        n_specs, q_max = self.n_specs, max(self.n_states)
        self._joint = np.zeros((n_specs, self._n_envs, self._belief.n_cells))
        initial = self._engine.initial_states(1)[0]
        self._initial_beliefs = np.zeros((n_specs, q_max))
        self._initial_beliefs[np.arange(n_specs), initial] = 1.0
        self._marg_states = np.tile(self._initial_beliefs, (self._n_envs, 1, 1))
        self._acc_prob = np.zeros((self._n_envs, n_specs))
        self._viol_prob = np.zeros((self._n_envs, n_specs))
        self._armed = np.ones((self._n_envs, n_specs), dtype=bool)
        self._expected_terms: np.ndarray | None = None
        if self._shaping is not None:
            self._expected_terms = self._shaping_tables(initial, q_max)

    def _shaping_tables(self, initial: np.ndarray, q_max: int) -> np.ndarray:
        """float64 ``[2 (done), 3, n_specs, q_max]``: the progress terms as
        ``F(q, q') = u(q') - w(q)``, read off the shaping at ``F(q0, q')``, ``F(q, q0)`` and
        ``F(q0, q0)`` (every term of :class:`ProgressShaping` separates so), so that their
        expectation over a belief needs only these tables."""
        assert self._shaping is not None
        column = np.arange(q_max)[:, None]
        valid = column < np.array(self.n_states)[None, :]
        states = np.where(valid, column, initial[None, :])  # [q_max, n_specs]
        start = np.tile(initial, (q_max, 1))
        tables = np.zeros((2, 3, self.n_specs, q_max))
        for d in (0, 1):
            done = np.full(q_max, bool(d))
            tables[d, 0] = self._shaping(start, states, done=done).T  # F(q0, q')
            tables[d, 1] = self._shaping(states, start, done=done).T  # F(q, q0)
            tables[d, 2] = self._shaping(start, start, done=done).T  # F(q0, q0)
        return tables

    def _belief_step(
        self, rows: slice | np.ndarray, probs: np.ndarray, *, done: np.ndarray, first: bool
    ) -> BoltStep:
        """One transition on the belief of the selected rows (see the module docstring)."""
        engine = self._belief
        assert engine is not None
        level = engine.settings.confidence
        n_rows = len(probs)
        if first:
            joint = engine.reset_joint(probs)
            before = np.broadcast_to(self._initial_beliefs, (n_rows, *self._initial_beliefs.shape))
            armed = np.ones((n_rows, self.n_specs), dtype=bool)
            held = np.zeros((n_rows, self.n_specs), dtype=bool)
        else:
            joint = engine.step_joint(self._joint[:, rows], probs)
            before = self._marg_states[rows]
            armed = self._armed[rows]
            held = self._acc_prob[rows] >= level  # the last step's decision (on_change)
        marg = engine.marginals(joint)
        accepting = marg.accepting >= level
        violated = marg.violated >= level
        terminate = (
            np.any(violated, axis=1)
            if self._end_on_violation and not first
            else np.zeros(n_rows, dtype=bool)
        )
        ended = done | terminate
        entered = accepting & armed
        terminal = self._engine.terminal_rewards(
            accepting,
            entered=entered,
            ended=ended,
            gained=~held,
            lost=held & ~accepting,
            first=first,
        )
        truth = probs >= self.thresholds.truth
        low = truth & (probs <= self.thresholds.high)
        counts = engine.low_band_counts(truth, low)  # [n_rows, n_specs, q_max]
        expected_low = (counts * before).sum(axis=2)
        n_low = np.take_along_axis(counts, before.argmax(axis=2)[:, :, None], axis=2)[:, :, 0]
        low_term = 0.0 - expected_low * self._engine.low_confidence_costs
        progress = np.zeros(terminal.shape)
        if self._expected_terms is not None:
            tables = self._expected_terms[ended.astype(np.intp)]  # [n_rows, 3, n_specs, q]
            progress = (
                (marg.states * tables[:, 0]).sum(axis=2)
                + (before * tables[:, 1]).sum(axis=2)
                - tables[:, 2, :, 0]
            )
            if first:
                progress = np.where(self._engine.pays_on_change, 0.0, progress)
        reward = terminal + low_term + progress
        next_states = marg.states.argmax(axis=2)
        self._joint[:, rows] = joint
        self._marg_states[rows] = marg.states
        self._acc_prob[rows] = marg.accepting
        self._viol_prob[rows] = marg.violated
        # Re-armed only once the bolt is as sure that the spec is *not* accepting.
        self._armed[rows] = np.where(entered, False, armed | (marg.accepting <= 1.0 - level))
        self._states[rows] = next_states
        return BoltStep(
            next_states=next_states,
            terminal=terminal,
            low_confidence=low_term,
            n_low=n_low.astype(np.int64),
            accepting=accepting,
            violated=violated,
            progress=progress,
            reward=reward,
            carried=np.zeros(n_rows),
            total=reward.sum(axis=1),
            terminate=terminate,
        )
