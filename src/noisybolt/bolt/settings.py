"""The bolt's settings as one frozen object, handed down through every layer.

The bolt is built in several places (:class:`~noisybolt.bolt.RestrainingBolt`, the
Gymnasium and the batched wrappers, :func:`~noisybolt.make_bolted_vec_env`, a run's env
stack), and each used to declare the same settings in its own signature. Now each takes one
:class:`BoltSettings` (``settings=``), as Stable-Baselines3's ``make_vec_env`` takes one
options dict per layer; their keyword arguments of old still work and are turned into one
(:func:`settings_from_keywords`), and giving both is refused.

What a scheme does to the specs (:meth:`BoltSettings.paid`): the ``paper`` scheme pays
each spec as it says (its ``terminal_reward``, on its ``reward_timing``); ``compliance``
and ``constrained`` pay the scheme's scale (or the spec's own, :attr:`BoltSettings.
spec_scales`) as the DFA comes to accept (:meth:`~noisybolt.bolt.RewardScheme.apply`),
and add the progress terms of :class:`~noisybolt.bolt.ProgressShaping`
(:meth:`BoltSettings.progress_terms`), each spec's scaled by what it pays.

Example:
    >>> settings = BoltSettings(scheme=RewardScheme("compliance", scale=40.0))
    >>> [(s.terminal_reward, s.reward_timing) for s in settings.paid([Spec("F(a)")])]
    [(40.0, 'on_change')]
    >>> BoltSettings().paid([Spec("F(a)")])[0].terminal_reward  # paper: as the spec says
    1.0
    >>> BoltSettings(cost_mode="sum")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    noisybolt.errors.ConfigError: BoltSettings.cost_mode must be one of ['count', ...
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields
from typing import Any

import numpy as np

from noisybolt.bolt.bands import DEFAULT_THRESHOLDS, Thresholds
from noisybolt.bolt.belief import BeliefSettings, Tracking, check_tracking
from noisybolt.bolt.engine import COST_MODES, CostMode
from noisybolt.bolt.schemes import RewardScheme
from noisybolt.bolt.shaping import ProgressShaping
from noisybolt.bolt.spec import Spec
from noisybolt.errors import ConfigError
from noisybolt.logic import DFA, masks_from_bool_matrix

__all__ = ["PAPER", "BoltSettings", "settings_from_keywords"]

#: The paper's scheme: each spec paid as it says, no progress terms.
PAPER = RewardScheme("paper")


@dataclass(frozen=True, kw_only=True)
class BoltSettings:
    """Everything that decides what a bolt pays and how it tracks, in one frozen object.

    Attributes:
        thresholds: the band thresholds of eq. 1.
        cost_mode: ``"count"`` (the paper) or ``"proportional"``
            (:func:`~noisybolt.bolt.bands.proportional_weights`).
        scheme: how the specs are paid (:mod:`noisybolt.bolt.schemes`; see the module
            docstring): ``RewardScheme("paper")`` (the default) pays each as it says;
            ``compliance`` and ``constrained`` pay their scale and add progress terms,
            shaped if ``scheme.shaping``.
        spec_scales: per spec, in the specs' order, a scale replacing the scheme's (None:
            the scheme's); empty: the scheme's for every spec. Not under ``paper``.
        progress_gamma: the discount of the progress terms (not ``paper``): 1, the
            scheme's objective being undiscounted (:mod:`noisybolt.bolt.shaping`).
        tracking: ``"threshold"`` (Algorithm 1) or ``"belief"``
            (:mod:`noisybolt.bolt.belief`).
        belief: the settings of belief tracking (None: :class:`BeliefSettings`'
            defaults); only with ``tracking="belief"``, which needs ``cost_mode="count"``.
        end_on_violation: a DFA that enters a rejecting sink ends the episode (off, as in
            the paper; a single environment's wrapper only).
        pay_at_truncation: an episode cut by a time limit is paid as ended
            (:class:`~noisybolt.bolt.RestrainingBolt`).

    Raises:
        ConfigError: a setting of the wrong type or out of range, naming it
            (``BoltSettings.cost_mode``); ``belief`` without belief tracking, or belief
            tracking with the proportional cost mode; ``spec_scales`` under ``paper``.
        UnknownNameError: an unknown ``tracking`` mode.
    """

    thresholds: Thresholds = DEFAULT_THRESHOLDS
    cost_mode: CostMode = "count"
    scheme: RewardScheme = PAPER
    spec_scales: tuple[float | None, ...] = ()
    progress_gamma: float = 1.0
    tracking: Tracking = "threshold"
    belief: BeliefSettings | None = None
    end_on_violation: bool = False
    pay_at_truncation: bool = True

    def __post_init__(self) -> None:
        _is(self.thresholds, Thresholds, "thresholds", "a Thresholds(truth=..., high=...)")
        if self.cost_mode not in COST_MODES:
            raise ConfigError(
                f"BoltSettings.cost_mode must be one of {list(COST_MODES)}, got {self.cost_mode!r}"
            )
        _is(self.scheme, RewardScheme, "scheme", 'a RewardScheme (RewardScheme("paper"), ...)')
        scales = self.spec_scales
        if isinstance(scales, (str, bytes)) or not isinstance(scales, Sequence):
            raise ConfigError(f"BoltSettings.spec_scales must be a sequence, got {scales!r}")
        object.__setattr__(self, "spec_scales", tuple(scales))
        for i, scale in enumerate(self.spec_scales):
            if scale is not None and not _positive(scale):
                raise ConfigError(
                    f"BoltSettings.spec_scales[{i}] must be a finite number > 0 or None, "
                    f"got {scale!r}"
                )
        if self.scheme.name == "paper" and any(s is not None for s in self.spec_scales):
            raise ConfigError(
                "BoltSettings.spec_scales are scales of the compliance and constrained "
                "schemes; the paper scheme pays each spec's own terminal_reward: set that"
            )
        gamma = self.progress_gamma
        if isinstance(gamma, bool) or not isinstance(gamma, (int, float, np.floating)):
            raise ConfigError(f"BoltSettings.progress_gamma must be a number, got {gamma!r}")
        if not 0.0 < gamma <= 1.0:
            raise ConfigError(f"BoltSettings.progress_gamma must be in (0, 1], got {gamma!r}")
        object.__setattr__(self, "progress_gamma", float(gamma))
        check_tracking(self.tracking)
        if self.belief is not None:
            _is(self.belief, BeliefSettings, "belief", "a BeliefSettings")
            if self.tracking != "belief":
                raise ConfigError(
                    "BoltSettings.belief was given but tracking is not 'belief': set "
                    "tracking='belief', or leave belief out"
                )
        if self.tracking == "belief" and self.cost_mode != "count":
            raise ConfigError(
                "BoltSettings: belief tracking charges Algorithm 1's count of low-band "
                "fluents in expectation; the proportional cost mode is not supported with it"
            )
        for name in ("end_on_violation", "pay_at_truncation"):
            if not isinstance(getattr(self, name), bool):
                raise ConfigError(
                    f"BoltSettings.{name} must be True or False, got {getattr(self, name)!r}"
                )

    @property
    def has_progress(self) -> bool:
        """Whether the bolt adds progress terms (every scheme but ``paper``)."""
        return self.scheme.name != "paper"

    @property
    def belief_settings(self) -> BeliefSettings | None:
        """Belief tracking's settings (the defaults if none were given); None under
        threshold tracking."""
        if self.tracking != "belief":
            return None
        return self.belief if self.belief is not None else BeliefSettings()

    def paid(self, specs: Sequence[Spec]) -> list[Spec]:
        """``specs`` as the scheme pays them (:meth:`RewardScheme.apply`, with
        :attr:`spec_scales`).

        Raises:
            ConfigError: ``spec_scales`` of another length than ``specs``, or a spec that
                is not a :class:`Spec`.
        """
        specs = list(specs)
        for spec in specs:
            if not isinstance(spec, Spec):
                raise ConfigError(f"expected Spec objects, got {spec!r}")
        scales = self.spec_scales or (None,) * len(specs)
        if len(scales) != len(specs):
            raise ConfigError(
                f"BoltSettings.spec_scales has {len(scales)} scale(s) for {len(specs)} spec(s)"
            )
        return [self.scheme.apply(s, scale=x) for s, x in zip(specs, scales, strict=True)]

    def progress_terms(
        self,
        dfas: Sequence[DFA],
        specs: Sequence[Spec],
        *,
        fluents: Sequence[str] = (),
        letters: np.ndarray | None = None,
    ) -> ProgressShaping | None:
        """The scheme's progress terms over ``dfas`` (None under ``paper``), each spec's
        scaled by its terminal reward (``specs`` as :meth:`paid` gives them).

        ``letters``: the true fluents the world produces (bool ``[n, len(fluents)]``, e.g.
        from random play), so that progress counts only steps the world can take.
        """
        if not self.has_progress:
            return None
        per_dfa = None
        if letters is not None:
            index = {name: i for i, name in enumerate(fluents)}
            per_dfa = [
                masks_from_bool_matrix(letters[:, [index[f] for f in dfa.fluents]]) for dfa in dfas
            ]
        return ProgressShaping(
            dfas,
            scales=[spec.terminal_reward for spec in specs],
            gamma=self.progress_gamma,
            shaping=self.scheme.shaping,
            letters=per_dfa,
        )


#: The keyword arguments of old that name a setting, with their defaults.
_DEFAULTS: dict[str, Any] = {f.name: f.default for f in fields(BoltSettings)}


def settings_from_keywords(
    settings: BoltSettings | None,
    keywords: Mapping[str, Any],
    *,
    owner: str,
    specs: Sequence[Spec] = (),
) -> BoltSettings:
    """The settings a constructor was given: ``settings`` whole, or built from its
    keyword arguments of old (``keywords``: :class:`BoltSettings` field names, and
    ``progress_gamma``/``shaping`` as :class:`~noisybolt.wrappers.BoltVecEnv` took them).

    ``progress_gamma`` (not None) with ``shaping``: progress terms on ``specs`` paid as
    given, which is the compliance scheme at each spec's own terminal reward
    (:attr:`BoltSettings.spec_scales`) and timing (``on_change`` or ``episode_end``).

    Raises:
        ConfigError: ``settings`` together with a keyword set to another value than its
            default (naming ``owner`` and the keywords); ``settings`` that is not a
            :class:`BoltSettings`; progress terms on specs of mixed or other timings.

    Example:
        >>> settings_from_keywords(None, {"cost_mode": "proportional"}, owner="f").cost_mode
        'proportional'
        >>> settings_from_keywords(BoltSettings(), {"cost_mode": "proportional"}, owner="f")
        Traceback (most recent call last):
        ...
        noisybolt.errors.ConfigError: f: give the bolt's settings either as settings= or \
as keyword arguments, not both: cost_mode=... was given beside settings=BoltSettings(...); \
put it in the BoltSettings
    """
    keywords = dict(keywords)
    gamma = keywords.pop("progress_gamma", None)
    shaping = keywords.pop("shaping", True)
    if settings is not None:
        given = sorted(k for k, v in keywords.items() if not _same(v, _DEFAULTS[k]))
        given += ["progress_gamma"] if gamma is not None else []
        given += ["shaping"] if shaping is not True else []
        if given:
            raise ConfigError(
                f"{owner}: give the bolt's settings either as settings= or as keyword "
                f"arguments, not both: {', '.join(k + '=...' for k in given)} was given "
                "beside settings=BoltSettings(...); put it in the BoltSettings"
            )
        _is(settings, BoltSettings, "settings", "a BoltSettings", where=owner)
        return settings
    if gamma is not None:
        timings = {spec.reward_timing for spec in specs}
        if not specs or len(timings) != 1 or timings - {"on_change", "episode_end"}:
            raise ConfigError(
                f"{owner}: progress_gamma adds the compliance scheme's progress terms, "
                "which pay each spec as it comes to accept (on_change) or at the episode's "
                f"end (episode_end); these specs time {sorted(timings)}: give "
                "settings=BoltSettings(scheme=RewardScheme('compliance', scale=...))"
            )
        scales = tuple(float(spec.terminal_reward) for spec in specs)
        keywords["scheme"] = RewardScheme(
            "compliance",
            scale=scales[0],
            shaping=bool(shaping),
            pay_on_change=timings == {"on_change"},
        )
        keywords["spec_scales"] = scales
        keywords["progress_gamma"] = gamma
    return BoltSettings(**keywords)


def _same(value: Any, default: Any) -> bool:
    try:
        return bool(value == default)
    except Exception:  # an array compared elementwise: not a default
        return False


def _positive(value: object) -> bool:
    return bool(
        not isinstance(value, bool)
        and isinstance(value, (int, float, np.floating))
        and math.isfinite(value)
        and value > 0
    )


def _is(value: object, kind: type, name: str, what: str, *, where: str = "BoltSettings") -> None:
    if not isinstance(value, kind):
        raise ConfigError(f"{where}.{name} must be {what}, got {value!r}")
