"""Algorithm 1 of the paper over a batch of environments and several specs at once.

For every environment and spec, one transition of the spec's *original* DFA (never the
expanded DFA of the paper's Fig. 2a, see :mod:`noisybolt.bolt.augmented`):

1. the truth assignment is ``p >= thresholds.truth`` over the bolt's fluents;
2. the DFA takes the edge that assignment selects: ``q' = δ(q, assignment)``;
3. every fluent in the *support* of that edge's guard (the fluents the guard depends on)
   whose probability lies in the low band ``truth <= p <= high`` costs the spec's
   ``low_confidence_cost`` (``cost_mode="count"``), or that cost scaled by
   :func:`~noisybolt.bolt.bands.proportional_weights` (``cost_mode="proportional"``);
4. the spec's ``terminal_reward`` is paid if ``q'`` is accepting, subject to the spec's
   ``reward_timing`` (``on_change``: on entering acceptance, taken back on leaving it).

Sign convention: :attr:`BoltStep.low_confidence` holds the cost *as a reward term*, so it
is ``<= 0``; ``reward = terminal + low_confidence``.

The engine is stateless: it maps ``(states, probs)`` to the next states and rewards.
:class:`~noisybolt.bolt.restraining_bolt.RestrainingBolt` keeps the states between steps
and implements the episode timing (reset, carried reward, auto-reset).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Literal, NamedTuple, get_args

import numpy as np

from noisybolt.bolt._bits import bit_columns, popcount
from noisybolt.bolt.bands import DEFAULT_THRESHOLDS, Thresholds, check_probs, proportional_weights
from noisybolt.bolt.spec import Spec
from noisybolt.errors import ConfigError, UnknownFluentError
from noisybolt.logic.dfa import DENSE_TABLE_LIMIT, DFA, MAX_FLUENTS

__all__ = ["COST_MODES", "BoltEngine", "BoltStep", "CostMode", "check_fluents", "env_flags"]

#: How the low-confidence cost of a fluent is computed: ``"count"`` charges the spec's
#: cost per low-band support fluent (the paper); ``"proportional"`` scales it by
#: :func:`~noisybolt.bolt.bands.proportional_weights` (the paper's suggested extension).
CostMode = Literal["count", "proportional"]
#: The accepted values of :data:`CostMode`.
COST_MODES: tuple[str, ...] = get_args(CostMode)


class BoltStep(NamedTuple):
    """The outcome of one bolt transition for a batch of environments.

    Attributes:
        next_states: int64 ``[n_envs, n_specs]``, each DFA's state after the transition.
        terminal: float64 ``[n_envs, n_specs]``, the terminal reward paid on this
            transition under the spec's reward timing (0 where not paid).
        low_confidence: float64 ``[n_envs, n_specs]``, the low-confidence term *as a
            reward*: ``-low_confidence_cost * n_low`` (count mode) or
            ``-low_confidence_cost * sum of proportional weights`` (proportional mode).
            Never positive.
        n_low: int64 ``[n_envs, n_specs]``, how many support fluents of the taken edge were
            in the low band (in both cost modes).
        accepting: bool ``[n_envs, n_specs]``, whether ``next_states`` is accepting.
        violated: bool ``[n_envs, n_specs]``, whether ``next_states`` is a rejecting sink
            (the spec can no longer be satisfied in this episode).
        progress: float64 ``[n_envs, n_specs]``, the progress-shaping term (only
            :class:`RestrainingBolt` with ``shaping`` sets it; 0 otherwise).
        reward: float64 ``[n_envs, n_specs]``, ``terminal + low_confidence + progress``.
        carried: float64 ``[n_envs]``, reward carried over from the reset transition and
            added to ``total`` (only :meth:`RestrainingBolt.step` sets it; 0 otherwise).
        total: float64 ``[n_envs]``, ``reward.sum(axis=1) + carried``: the bolt's reward.
        terminate: bool ``[n_envs]``, the bolt asks for the episode to end here (only with
            ``end_on_violation``, where some spec is violated).
    """

    next_states: np.ndarray
    terminal: np.ndarray
    low_confidence: np.ndarray
    n_low: np.ndarray
    accepting: np.ndarray
    violated: np.ndarray
    progress: np.ndarray
    reward: np.ndarray
    carried: np.ndarray
    total: np.ndarray
    terminate: np.ndarray


def _dense_tables(dfa: DFA) -> tuple[np.ndarray, np.ndarray] | None:
    """The DFA's dense ``(next_state, support)`` tables, or None if it has none.

    DFAs over large vocabularies may come in a compact form whose dense tables would not
    fit (they raise or are absent); the engine then steps them through ``step_batch``.
    """
    if getattr(dfa, "is_compact", False) or dfa.n_states << dfa.n_fluents > DENSE_TABLE_LIMIT:
        return None
    try:
        next_state, support = dfa.next_state, dfa.support
    except (AttributeError, ValueError, RuntimeError, MemoryError):
        return None
    shape = (dfa.n_states, 1 << dfa.n_fluents)
    if not isinstance(next_state, np.ndarray) or not isinstance(support, np.ndarray):
        return None
    if next_state.shape != shape or support.shape != shape:
        return None
    return next_state, support


def env_flags(value: object, n_envs: int, name: str) -> np.ndarray:
    """A bool ``[n_envs]`` array from None (all False), a Python bool or an array-like.

    Raises:
        ValueError: an array that is not bool or not of shape ``(n_envs,)`` (named ``name``).
    """
    if value is None:
        return np.zeros(n_envs, dtype=bool)
    if isinstance(value, (bool, np.bool_)):
        return np.full(n_envs, bool(value))
    flags = np.asarray(value)
    if flags.dtype != np.bool_:
        raise ValueError(f"{name} must be a bool array [n_envs], got dtype {flags.dtype}")
    if flags.shape != (n_envs,):
        raise ValueError(f"{name} must have shape ({n_envs},), got {flags.shape}")
    return flags


class BoltEngine:
    """Algorithm 1, batched over environments and specs; stateless.

    The specs' DFAs may use any subset of the bolt's fluents in any order: each DFA letter
    is packed from the bolt's columns that its vocabulary names. DFAs with dense tables
    are stacked into one flat table so a step is one gather for all specs; others are
    stepped through :meth:`DFA.step_batch`.

    Args:
        specs: the specifications, one per DFA.
        dfas: their DFAs, in the same order.
        fluents: the bolt's fluent vocabulary, the column order of ``probs``.
        thresholds: the band thresholds of eq. 1.
        cost_mode: ``"count"`` or ``"proportional"`` (see :data:`CostMode`).

    Raises:
        UnknownFluentError: a DFA reads a fluent outside ``fluents``.
        ConfigError: no specs, a different number of specs and DFAs, duplicate or invalid
            fluent names, duplicate spec names, or an unknown ``cost_mode``.

    Example:
        >>> from noisybolt.logic import DFA
        >>> f_e_and_t = DFA.from_function(["e", "t"], n_states=2, initial_state=0,
        ...     accepting=[False, True], delta=lambda q, m: 1 if q == 1 or m == 0b11 else 0)
        >>> spec = Spec("F(e & t)", terminal_reward=10.0, low_confidence_cost=2.0)
        >>> engine = BoltEngine([spec], [f_e_and_t], ["e", "t"])
        >>> out = engine.step(np.array([[0]]), np.array([[0.7, 0.95]]))
        >>> out.next_states.tolist(), out.terminal.tolist(), out.low_confidence.tolist()
        ([[1]], [[10.0]], [[-2.0]])
        >>> out.total.tolist()
        [8.0]
    """

    def __init__(
        self,
        specs: Sequence[Spec],
        dfas: Sequence[DFA],
        fluents: Sequence[str],
        *,
        thresholds: Thresholds = DEFAULT_THRESHOLDS,
        cost_mode: CostMode = "count",
    ) -> None:
        specs = tuple(specs)
        dfas = tuple(dfas)
        self._fluents = check_fluents(fluents)
        if not specs:
            raise ConfigError("a restraining bolt needs at least one Spec")
        for spec in specs:
            if not isinstance(spec, Spec):
                raise ConfigError(f"expected Spec objects, got {spec!r}")
        names = [spec.name for spec in specs]
        duplicates = sorted({n for n in names if names.count(n) > 1})
        if duplicates:
            raise ConfigError(f"spec names must be unique; give these a name=: {duplicates}")
        if len(dfas) != len(specs):
            raise ConfigError(f"got {len(specs)} specs but {len(dfas)} DFAs")
        if not isinstance(thresholds, Thresholds):
            raise ConfigError(f"thresholds must be a Thresholds, got {thresholds!r}")
        if cost_mode not in COST_MODES:
            raise ConfigError(f"cost_mode {cost_mode!r} is not one of {list(COST_MODES)}")
        self._specs = specs
        self._dfas = dfas
        self._thresholds = thresholds
        self._cost_mode: CostMode = cost_mode

        index = {name: i for i, name in enumerate(self._fluents)}
        n_fluents, n_specs = len(self._fluents), len(specs)
        self._columns: list[np.ndarray] = []
        # letters[env, s] = truth[env] @ letter_weights[:, s]: bit i of spec s's letter is
        # the bolt column that the DFA's i-th fluent names.
        self._letter_weights = np.zeros((n_fluents, n_specs), dtype=np.int64)
        for s, (spec, dfa) in enumerate(zip(specs, dfas, strict=True)):
            if not isinstance(dfa, DFA):
                raise ConfigError(f"spec {spec.name!r}: expected a DFA, got {dfa!r}")
            unknown = tuple(f for f in dfa.fluents if f not in index)
            if unknown:
                raise UnknownFluentError(
                    f"spec {spec.name!r} reads fluent(s) {list(unknown)} that the bolt does "
                    f"not observe; the bolt's vocabulary is {list(self._fluents)}",
                    unknown=unknown,
                    known=self._fluents,
                )
            cols = np.array([index[f] for f in dfa.fluents], dtype=np.int64)
            self._columns.append(cols)
            self._letter_weights[cols, s] = np.left_shift(1, np.arange(len(cols), dtype=np.int64))

        self._n_states = tuple(dfa.n_states for dfa in dfas)
        self._initial = np.array([dfa.initial_state for dfa in dfas], dtype=np.int64)
        self._state_offsets = np.cumsum((0, *self._n_states[:-1]), dtype=np.int64)
        self._accepting_flat = np.concatenate([dfa.accepting for dfa in dfas])
        self._rejecting_flat = np.concatenate([dfa.rejecting_sinks for dfa in dfas])
        self._n_states_array = np.array(self._n_states, dtype=np.int64)

        self._terminal = np.array([spec.terminal_reward for spec in specs], dtype=np.float64)
        self._cost = np.array([spec.low_confidence_cost for spec in specs], dtype=np.float64)
        timings = np.array([spec.reward_timing for spec in specs])
        self._every_step = timings == "every_step"
        self._on_entry = timings == "on_entry"
        self._episode_end = timings == "episode_end"
        self._on_change = timings == "on_change"
        self._build_flat_tables()

    def _build_flat_tables(self) -> None:
        """Stacks every DFA's dense tables into one flat array."""
        tables = [_dense_tables(dfa) for dfa in self._dfas]
        self._flat_next: np.ndarray | None = None
        self._flat_support: np.ndarray | None = None
        if any(t is None for t in tables):
            return
        nexts, supports, offsets = [], [], [0]
        for table in tables:
            assert table is not None
            next_state, support = table
            nexts.append(next_state.ravel())
            supports.append(support.ravel())
            offsets.append(offsets[-1] + next_state.size)
        self._flat_next = np.concatenate(nexts).astype(np.int64)
        self._flat_support = np.concatenate(supports)
        self._table_offsets = np.array(offsets[:-1], dtype=np.int64)
        self._n_letters = np.array([1 << len(c) for c in self._columns], dtype=np.int64)

    # ------------------------------------------------------------------ properties
    @property
    def specs(self) -> tuple[Spec, ...]:
        """The specifications, in order."""
        return self._specs

    @property
    def dfas(self) -> tuple[DFA, ...]:
        """The specs' DFAs, in order."""
        return self._dfas

    @property
    def fluents(self) -> tuple[str, ...]:
        """The bolt's vocabulary: the column order of ``probs``."""
        return self._fluents

    @property
    def n_fluents(self) -> int:
        """Number of fluents in the bolt's vocabulary."""
        return len(self._fluents)

    @property
    def n_specs(self) -> int:
        """Number of specs."""
        return len(self._specs)

    @property
    def n_states(self) -> tuple[int, ...]:
        """Number of DFA states of each spec (the ``nvec`` of a MultiDiscrete space)."""
        return self._n_states

    @property
    def thresholds(self) -> Thresholds:
        """The band thresholds."""
        return self._thresholds

    @property
    def cost_mode(self) -> CostMode:
        """``"count"`` or ``"proportional"``."""
        return self._cost_mode

    def initial_states(self, n_envs: int) -> np.ndarray:
        """int64 ``[n_envs, n_specs]``: every DFA in its initial state (the empty trace)."""
        return np.tile(self._initial, (n_envs, 1))

    # ------------------------------------------------------------------ checks
    def check_states(self, states: object, *, n_envs: int) -> np.ndarray:
        """Checks DFA states ``[n_envs, n_specs]`` and returns them as int64.

        Raises:
            ValueError: wrong shape or dtype, or a state outside its DFA, naming the first
                offending ``[env, spec]`` index.
        """
        array = np.asarray(states)
        if not np.issubdtype(array.dtype, np.integer):
            raise ValueError(f"states must be an integer array, got dtype {array.dtype}")
        if array.shape != (n_envs, self.n_specs):
            raise ValueError(
                f"states must have shape [n_envs, n_specs] = ({n_envs}, {self.n_specs}), "
                f"got {array.shape}"
            )
        array = array.astype(np.int64, copy=False)
        bad = (array < 0) | (array >= self._n_states_array)
        if bad.any():
            env, s = (int(i) for i in np.argwhere(bad)[0])
            raise ValueError(
                f"states[{env}, {s}] = {int(array[env, s])} is not a state of spec "
                f"{self._specs[s].name!r}, which has states 0..{self._n_states[s] - 1}"
            )
        return array

    # ------------------------------------------------------------------ stepping
    def step(
        self,
        states: np.ndarray,
        probs: np.ndarray,
        *,
        done: np.ndarray | bool | None = None,
        first: np.ndarray | bool = False,
        end_on_violation: bool = False,
    ) -> BoltStep:
        """One transition of every spec's DFA for every environment.

        Args:
            states: int ``[n_envs, n_specs]`` current DFA states.
            probs: float ``[n_envs, n_fluents]`` fluent probabilities of the observation
                that the transition reads.
            done: bool ``[n_envs]`` (or one bool): the episode ends with this transition,
                so ``episode_end`` specs are paid if accepting. None: no episode ends.
            first: bool ``[n_envs]`` (or one bool): this is the episode's first
                transition (read at reset); ``on_entry`` specs then count landing on an
                accepting state as an entry even if the initial state is accepting.
            end_on_violation: set ``terminate`` where a spec is violated, and treat those
                environments as done for ``episode_end`` specs.

        Returns:
            The :class:`BoltStep` (``carried`` is 0).

        Raises:
            ValueError: bad ``probs`` (see :func:`~noisybolt.bolt.bands.check_probs`),
                ``states``, ``done`` or ``first``.
        """
        probs = check_probs(probs, n_fluents=self.n_fluents, fluents=self._fluents)
        n_envs = probs.shape[0]
        return self._step(
            self.check_states(states, n_envs=n_envs),
            probs,
            done=env_flags(done, n_envs, "done"),
            first=env_flags(first, n_envs, "first"),
            end_on_violation=end_on_violation,
        )

    def _step(
        self,
        states: np.ndarray,
        probs: np.ndarray,
        *,
        done: np.ndarray,
        first: np.ndarray,
        end_on_violation: bool,
    ) -> BoltStep:
        """:meth:`step` on inputs already checked (int64 states, float64 probs, bool flags)."""
        n_envs = probs.shape[0]
        truth = probs >= self._thresholds.truth
        low = truth & (probs <= self._thresholds.high)
        letters = truth.astype(np.int64) @ self._letter_weights  # [n_envs, n_specs]
        # The low-band fluents packed like the letters: in each DFA's own bit order.
        low_letters = (low.astype(np.int64) @ self._letter_weights).view(np.uint64)
        next_states, support = self._transition(states, letters)
        n_low = popcount(support & low_letters)
        if self._cost_mode == "count":
            low_term = 0.0 - n_low * self._cost  # 0.0 - x: no -0.0 in outputs
        else:
            weights = proportional_weights(probs, self._thresholds)  # [n_envs, n_fluents]
            scaled = np.empty(support.shape)
            for s, cols in enumerate(self._columns):
                on_edge = bit_columns(support[:, s], len(cols))  # [n_envs, n_dfa_fluents]
                scaled[:, s] = (on_edge * weights[:, cols]).sum(axis=1)
            low_term = 0.0 - scaled * self._cost

        accepting = self._accepting_flat[next_states + self._state_offsets]
        violated = self._rejecting_flat[next_states + self._state_offsets]
        terminate: np.ndarray = (
            np.any(violated, axis=1) if end_on_violation else np.zeros(n_envs, dtype=bool)
        )
        ended = done | terminate
        held = self._accepting_flat[states + self._state_offsets] & ~first[:, None]
        terminal = self.terminal_rewards(
            accepting,
            entered=~held,
            ended=ended,
            gained=~held,
            lost=held & ~accepting,
            first=first,
        )
        reward = terminal + low_term
        return BoltStep(
            next_states=next_states,
            terminal=terminal,
            low_confidence=low_term,
            n_low=n_low,
            accepting=accepting,
            violated=violated,
            progress=np.zeros(terminal.shape),
            reward=reward,
            carried=np.zeros(n_envs),
            total=reward.sum(axis=1),
            terminate=terminate,
        )

    @property
    def low_confidence_costs(self) -> np.ndarray:
        """float64 ``[n_specs]``: each spec's ``low_confidence_cost``."""
        return self._cost.copy()

    def terminal_rewards(
        self,
        accepting: np.ndarray,
        *,
        entered: np.ndarray,
        ended: np.ndarray,
        gained: np.ndarray,
        lost: np.ndarray,
        first: np.ndarray | bool = False,
    ) -> np.ndarray:
        """float64 ``[n_envs, n_specs]``: the terminal rewards paid under each spec's timing.

        ``on_change`` pays nothing on an episode's first transition (read at reset, before
        any action): where the episode starts is its baseline, and only what the agent's
        steps change is paid. A payment there would depend on nothing the agent did, and
        come at a time its observation does not show (the first step of every episode):
        on CartPole a spec that accepts from the start and is never broken paid the scale
        on every episode's first step, and the learner's values could not tell that step
        from the others (PPO's return 99-120 against 500 unbolted at 100k frames; 500 once
        not paid).

        Args:
            accepting: bool ``[n_envs, n_specs]``, the spec counts as accepting now.
            entered: bool ``[n_envs, n_specs]``, this is an entry (``on_entry`` pays).
            ended: bool ``[n_envs]``, the episode ends here (``episode_end`` pays).
            gained: bool ``[n_envs, n_specs]``, the spec did not count as accepting before
                this transition (``on_change`` pays where it does now).
            lost: bool ``[n_envs, n_specs]``, the spec counted as accepting before this
                transition and does not now (``on_change`` takes its reward back).
            first: bool ``[n_envs]`` (or one bool), the episode's first transition
                (``on_change`` pays nothing on it).
        """
        later = ~np.asarray(first, dtype=bool)
        if later.ndim:
            later = later[:, None]
        paid = accepting & (
            self._every_step
            | (self._on_entry & entered)
            | (self._episode_end & ended[:, None])
            | (self._on_change & gained & later)
        )
        taken = self._on_change & lost
        return np.where(paid, self._terminal, 0.0) - np.where(taken, self._terminal, 0.0)

    @property
    def pays_on_change(self) -> np.ndarray:
        """bool ``[n_specs]``: the specs whose timing is ``on_change``."""
        return self._on_change.copy()

    def state_flags(self, states: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(accepting, violated)`` bool ``[n_envs, n_specs]`` of checked int64 states."""
        cells = states + self._state_offsets
        return self._accepting_flat[cells], self._rejecting_flat[cells]

    def _transition(self, states: np.ndarray, letters: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(next_states int64, support uint64)``, both ``[n_envs, n_specs]``.

        Bit ``i`` of ``support[:, s]`` is spec ``s``'s DFA fluent ``i`` (its own order).
        """
        if self._flat_next is not None and self._flat_support is not None:
            cells = self._table_offsets + states * self._n_letters + letters
            return self._flat_next[cells], self._flat_support[cells]
        next_states = np.empty_like(states)
        support = np.empty(states.shape, dtype=np.uint64)
        for s, dfa in enumerate(self._dfas):
            next_states[:, s], support[:, s] = dfa.step_batch(
                states[:, s], letters[:, s].astype(np.uint64)
            )
        return next_states, support


def check_fluents(fluents: Sequence[str]) -> tuple[str, ...]:
    """The bolt's fluent vocabulary as a tuple, checked.

    Raises:
        ConfigError: a bare string, an empty vocabulary, empty or non-string names,
            duplicates, or more than :data:`~noisybolt.logic.dfa.MAX_FLUENTS` names.
    """
    if isinstance(fluents, str):
        raise ConfigError(f"fluents must be a sequence of names, not the string {fluents!r}")
    names = tuple(fluents)
    if not names:
        raise ConfigError("the bolt's fluent vocabulary is empty")
    bad = [n for n in names if not isinstance(n, str) or not n]
    if bad:
        raise ConfigError(f"fluent names must be non-empty strings, got {bad}")
    duplicates = sorted({n for n in names if names.count(n) > 1})
    if duplicates:
        raise ConfigError(f"duplicate fluent names in the bolt's vocabulary: {duplicates}")
    if len(names) > MAX_FLUENTS:
        raise ConfigError(f"at most {MAX_FLUENTS} fluents are supported, got {len(names)}")
    return names
