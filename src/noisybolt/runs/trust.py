"""Code a saved run names, followed only with the user's word.

A run's ``config.json`` may name code outside noisybolt: a world factory path
(``world.name: "mymod:make"``) or a detector factory path
(``detector.kind: "mydetectors:noisy"``), each imported and called when the run's world or
detector is built. Whoever trains a new run gave those paths; whoever *loads* a run
(``noisybolt evaluate``, ``train --resume``, a sweep's resume, ``report``, the Python
functions behind them) may have been handed the directory by someone else, and importing
a module runs its code. So loading a run lists its references first and refuses unless the
user vouches for each (:func:`check_code_trusted`): ``--trust-code`` (Python:
``trust_code=True``) for all of them, or the same reference given again
(``--world mymod:make``). The rest of the load then runs inside
:func:`~noisybolt.envs.registry.refusing_code`, so that a path this module missed is
refused too, and the current directory is searched only for a trusted path.

Nothing else a run directory holds is code: models and checkpoints are read without
unpickling (:mod:`noisybolt.runs.models`), classifiers are safetensors, and the rest is
JSON.

Example:
    >>> saved = {"world": {"name": "mymod:make"}, "detector": {"kind": "os:system"}}
    >>> [str(r) for r in code_references(saved)]
    ["world.name = 'mymod:make'", "detector.kind = 'os:system'"]
    >>> check_code_trusted(saved, given={"world.name": "mymod:make"})  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    noisybolt.errors.UntrustedCodeError: the saved run names code noisybolt would import ...
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator, Mapping
from typing import Any, NamedTuple

from noisybolt.envs.registry import is_factory_path, refusing_code
from noisybolt.errors import UntrustedCodeError

__all__ = ["CodeReference", "check_code_trusted", "code_references", "loading_run"]

#: The schema paths whose value may name code, with the flag that gives one again.
CODE_PATHS: dict[str, str] = {"world.name": "--world", "detector.kind": "--detector"}


class CodeReference(NamedTuple):
    """A reference to code in a config: its schema path and the ``module:function``."""

    path: str
    value: str

    def __str__(self) -> str:
        return f"{self.path} = {self.value!r}"


def _names_code(path: str, value: str) -> bool:
    """Whether ``value`` at ``path`` names code (a value of another type is refused by the
    schema, never imported)."""
    if path == "world.name":
        return is_factory_path(value)
    return ":" in value  # no built-in detector kind holds one


def code_references(data: Any) -> tuple[CodeReference, ...]:
    """The references to code in a saved config's data (nested, or the flat form of older
    runs, whose ``world`` is the world's name), in :data:`CODE_PATHS`' order; nothing is
    imported or validated (what is not a config has none: loading it will say why).
    """
    if not isinstance(data, Mapping):
        return ()
    found = []
    for path in CODE_PATHS:
        section, _, key = path.partition(".")
        value = data.get(section)
        if isinstance(value, Mapping):
            value = value.get(key)
        if isinstance(value, str) and _names_code(path, value):
            found.append(CodeReference(path, value))
    return tuple(found)


def check_code_trusted(
    data: Mapping[str, Any],
    *,
    trust_code: bool = False,
    given: Mapping[str, Any] | None = None,
    source: str = "the saved run",
) -> tuple[CodeReference, ...]:
    """Refuses a saved config that names code the user did not vouch for; returns its
    references (all trusted then).

    Args:
        data: the saved config's data (``config.json``), not yet loaded.
        trust_code: the user trusts whoever wrote the run: every reference is followed.
        given: settings the user gave (``{schema path: value}``, as
            :meth:`~noisybolt.runs.config.TrainConfig.build` takes them): a reference
            given again with the same value is the user's own.
        source: what holds the config, in the message (a run directory).

    Raises:
        UntrustedCodeError: listing each reference not vouched for and how to consent.
    """
    references = code_references(data)
    if trust_code:
        return references
    given = dict(given or {})
    refused = [r for r in references if given.get(r.path) != r.value]
    if refused:
        again = " ".join(f"{CODE_PATHS[r.path]} {r.value}" for r in refused)
        raise UntrustedCodeError(
            f"{source} names code noisybolt would import and run: "
            f"{', '.join(map(str, refused))}. A run directory is data, and its code is "
            "followed only with your word: if you trust whoever wrote it, pass --trust-code "
            f"(Python: trust_code=True), or give the same reference yourself ({again})",
            references=tuple(map(str, refused)),
        )
    return references


@contextlib.contextmanager
def loading_run(
    data: Mapping[str, Any],
    *,
    trust_code: bool = False,
    given: Mapping[str, Any] | None = None,
    source: str = "the saved run",
) -> Iterator[None]:
    """:func:`check_code_trusted`, then the block with every factory path but the trusted
    ones refused (:func:`~noisybolt.envs.registry.refusing_code`; everything followed
    under ``trust_code``)."""
    references = check_code_trusted(data, trust_code=trust_code, given=given, source=source)
    if trust_code:
        yield
        return
    with refusing_code(trusted=[r.value for r in references]):
        yield
