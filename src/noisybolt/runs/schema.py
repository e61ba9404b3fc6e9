"""Strict, typed loading of nested frozen dataclasses: the machinery of the run config.

A schema here is a frozen dataclass whose fields are plain values (``str``, ``int``,
``float``, ``bool``, their ``| None``), tuples, mappings, or other such dataclasses (its
sections). The annotations are the only type table: loading, overrides by dotted path and
command-line values all read them. A field's ``metadata={"key": ...}`` gives it another
name in the data than its attribute's (:class:`~noisybolt.runs.config.TrainConfig`'s
``world_config`` is ``world``).

Example:
    >>> from noisybolt.runs.config import DetectorConfig, TrainConfig
    >>> load(DetectorConfig, {"kind": "oracle", "samples": 10})
    DetectorConfig(kind='oracle', path=None, low_confidence=(), samples=10, epochs=30, seed=0)
    >>> load(DetectorConfig, {"sample": 10}, "detector.")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    noisybolt.errors.ConfigError: unknown config key detector.sample; known in detector: [...]
    >>> flatten(TrainConfig, {"bolt": {"tracking": "belief"}, "world.kwargs": {"noise": "x"}})
    {'bolt.tracking': 'belief', 'world.kwargs.noise': 'x'}
"""

from __future__ import annotations

import copy
import dataclasses
import json
import types
import typing
from collections.abc import Callable, Mapping
from typing import Any, NoReturn, TypeVar

import yaml

from noisybolt.errors import ConfigError

__all__ = [
    "FrozenDict",
    "check",
    "defaults",
    "dump",
    "field_keys",
    "flatten",
    "freeze",
    "hint_at",
    "leaf_paths",
    "load",
    "parse_text",
    "section_types",
    "set_path",
]

_T = TypeVar("_T")


class FrozenDict(dict):
    """A ``dict`` that refuses changes: the mappings a frozen config holds.

    It is still a ``dict`` (JSON, ``**`` and ``dict(...)`` work); change a config with
    :meth:`~noisybolt.runs.config.TrainConfig.override` instead.

    Example:
        >>> d = FrozenDict({"truth": 0.5})
        >>> d["truth"] = 0.7
        Traceback (most recent call last):
        ...
        TypeError: a config's mappings are frozen: build a new config with TrainConfig.override
    """

    def _refuse(self, *args: Any, **kwargs: Any) -> NoReturn:
        raise TypeError(
            "a config's mappings are frozen: build a new config with TrainConfig.override"
        )

    __setitem__ = __delitem__ = __ior__ = _refuse
    clear = pop = popitem = setdefault = update = _refuse

    def __reduce__(self) -> tuple[Any, ...]:
        return (FrozenDict, (dict(self),))

    def __deepcopy__(self, memo: dict[int, Any]) -> FrozenDict:
        return FrozenDict({k: copy.deepcopy(v, memo) for k, v in self.items()})


def freeze(value: Any) -> Any:
    """``value`` with every mapping inside it frozen (lists stay lists: JSON's form)."""
    if isinstance(value, Mapping):
        return FrozenDict({k: freeze(v) for k, v in value.items()})
    if isinstance(value, list):
        return [freeze(v) for v in value]
    return value


def field_keys(cls: type) -> dict[str, dataclasses.Field[Any]]:
    """The fields of ``cls`` by their key in the data."""
    return {f.metadata.get("key", f.name): f for f in dataclasses.fields(cls)}


def section_types(cls: type) -> dict[str, type]:
    """The section fields of ``cls`` (dataclass-typed) by key, with their classes."""
    hints = typing.get_type_hints(cls)
    return {
        key: hints[f.name]
        for key, f in field_keys(cls).items()
        if isinstance(hints[f.name], type) and dataclasses.is_dataclass(hints[f.name])
    }


def _is_mapping(hint: Any) -> bool:
    return hint is dict or typing.get_origin(hint) in (dict, Mapping)


def _is_section(hint: Any) -> bool:
    return isinstance(hint, type) and dataclasses.is_dataclass(hint)


_TYPE_NAMES = {str: "a string", int: "an integer", float: "a number", bool: "true or false"}


def _describe(hint: Any) -> str:
    if typing.get_origin(hint) in (typing.Union, types.UnionType):
        return " or ".join(
            "null" if a is type(None) else _describe(a) for a in typing.get_args(hint)
        )
    if typing.get_origin(hint) is tuple:
        return "a list"
    if _is_mapping(hint) or _is_section(hint):
        return "a mapping"
    return _TYPE_NAMES.get(hint, getattr(hint, "__name__", str(hint)))


def _value(value: Any, hint: Any, path: str) -> Any:
    """``value`` as the setting at ``path`` (of type ``hint``) holds it, or a ConfigError
    naming the path."""
    if _is_section(hint):
        return load(hint, value, path + ".")
    origin, args = typing.get_origin(hint), typing.get_args(hint)
    if origin in (typing.Union, types.UnionType):
        if value is None and type(None) in args:
            return None
        for arm in (a for a in args if a is not type(None)):
            try:
                return _value(value, arm, path)
            except ConfigError:
                pass
    elif hint is Any:
        return freeze(value)
    elif hint is bool:
        if isinstance(value, bool):
            return value
    elif hint is int:
        if isinstance(value, int) and not isinstance(value, bool):
            return value
    elif hint is float:
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            return float(value)
    elif hint is str:
        if isinstance(value, str):
            return value
    elif origin is tuple:
        if isinstance(value, (list, tuple)):
            return tuple(_value(v, args[0], f"{path}[{i}]") for i, v in enumerate(value))
    elif _is_mapping(hint) and isinstance(value, Mapping):
        return freeze(dict(value))
    raise ConfigError(f"config key {path} must be {_describe(hint)}, got {value!r}")


def load(cls: type[_T], data: Any, prefix: str = "") -> _T:
    """Builds ``cls`` from ``data`` strictly: unknown keys and values of the wrong type
    are refused with their path; missing keys take the field's default.

    Raises:
        ConfigError: naming the key's path (``prefix`` + key).
    """
    if not isinstance(data, Mapping):
        where = f"config key {prefix[:-1]}" if prefix else "a config"
        raise ConfigError(f"{where} must be a mapping, got {data!r}")
    keys, hints = field_keys(cls), typing.get_type_hints(cls)
    # A YAML file's keys may be numbers or null ("?", "1: x"): named as text, not sorted raw.
    unknown = sorted(map(str, set(data) - set(keys)))
    if unknown:
        where = f" in {prefix[:-1]}" if prefix else ""
        found = ", ".join(prefix + k for k in unknown)
        raise ConfigError(f"unknown config key {found}; known{where}: {sorted(keys)}")
    kwargs = {
        keys[key].name: _value(value, hints[keys[key].name], prefix + key)
        for key, value in data.items()
    }
    return cls(**kwargs)


def dump(section: Any) -> dict[str, Any]:
    """A dataclass as JSON-able data, by key (what :func:`load` reads back)."""
    out = {}
    for key, f in field_keys(type(section)).items():
        value = getattr(section, f.name)
        out[key] = dump(value) if dataclasses.is_dataclass(value) else value
    return json.loads(json.dumps(out))


def defaults(cls: type) -> dict[str, Any]:
    """The defaults of ``cls`` as data (sections built from theirs; ``cls`` itself is not
    built, so it may require what its defaults lack)."""
    sections = section_types(cls)
    out: dict[str, Any] = {}
    for key, f in field_keys(cls).items():
        if key in sections:
            out[key] = dump(sections[key]())
        elif f.default is not dataclasses.MISSING:
            out[key] = f.default
        else:
            out[key] = typing.cast(Callable[[], Any], f.default_factory)()
    return json.loads(json.dumps(out))


def hint_at(root: type, path: str) -> Any:
    """The type the setting at dotted ``path`` of ``root`` holds (Any below a
    mapping-typed setting).

    Raises:
        ConfigError: the path names no setting.
    """
    hint: Any = root
    parts = path.split(".")
    for index, part in enumerate(parts):
        where = ".".join(parts[:index])
        if _is_section(hint):
            keys = field_keys(hint)
            if part not in keys:
                known = f"known in {where}" if where else "known"
                raise ConfigError(f"unknown config key {path}; {known}: {sorted(keys)}")
            hint = typing.get_type_hints(hint)[keys[part].name]
        elif _is_mapping(hint) or hint is Any:
            return Any
        else:
            raise ConfigError(f"config key {where} is not a mapping: {path} cannot reach into it")
    return hint


def flatten(root: type, changes: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    """``changes`` as ``{dotted path: value}``: a mapping given for a section or a
    mapping-typed setting merges key by key; anything else replaces.

    Raises:
        ConfigError: a key that names no setting.
    """
    out: dict[str, Any] = {}
    for key, value in changes.items():
        path = f"{prefix}{key}"
        hint = hint_at(root, path)
        if isinstance(value, Mapping) and (_is_section(hint) or _is_mapping(hint) or hint is Any):
            out.update(flatten(root, value, path + "."))
        else:
            out[path] = value
    return out


def check(root: type, path: str, value: Any) -> Any:
    """``value`` as JSON data if the setting at ``path`` can hold it.

    Raises:
        ConfigError: an unknown path, or a value of the wrong type, naming the path.
    """
    return json.loads(json.dumps(_value(value, hint_at(root, path), path)))


def set_path(data: dict[str, Any], path: str, value: Any) -> None:
    """Sets dotted ``path`` in nested ``data``, making the mappings on the way."""
    *heads, last = path.split(".")
    node = data
    for head in heads:
        child = node.get(head)
        if not isinstance(child, dict):
            child = node[head] = {}
        node = child
    node[last] = value


def leaf_paths(root: type, prefix: str = "") -> tuple[str, ...]:
    """Every setting's path (a mapping-typed setting's keys are free below it)."""
    hints, out = typing.get_type_hints(root), list[str]()
    for key, f in field_keys(root).items():
        hint = hints[f.name]
        if _is_section(hint):
            out += leaf_paths(hint, f"{prefix}{key}.")
        else:
            out.append(prefix + key)
    return tuple(out)


def parse_text(root: type, path: str, text: str) -> Any:
    """The value a command line's ``PATH=TEXT`` means for the setting at ``path``: the
    text itself for a string setting, else ``text`` read as YAML (``[32, 32]``, ``true``,
    ``null``; ``3e-4`` as the number a user means).

    Raises:
        ConfigError: an unknown path, or text that is not YAML.
    """
    hint = hint_at(root, path)
    arms = typing.get_args(hint) if typing.get_origin(hint) is types.UnionType else (hint,)
    if str in arms and not (type(None) in arms and text.strip() in ("null", "~")):
        return text
    try:
        value = yaml.safe_load(text)
    except yaml.YAMLError as error:
        raise ConfigError(f"cannot read the value of {path}={text!r}: {error}") from None
    if isinstance(value, str):  # YAML 1.1 reads "3e-4" as a string
        try:
            return float(value)
        except ValueError:
            return value
    return value
