"""A Griffe extension for the API reference: noisybolt's docstrings head their doctests
``Example:`` (as Gymnasium's do), which Google-style parsing in Griffe knows only as
``Examples:``; read as the same section, the doctests render as code."""

from __future__ import annotations

import re
from typing import Any

import griffe

_EXAMPLE = re.compile(r"^(\s*)Example:\s*$", re.MULTILINE)


class ExampleSections(griffe.Extension):
    def on_object(self, *, obj: griffe.Object, **kwargs: Any) -> None:
        if obj.docstring is not None:
            obj.docstring.value = _EXAMPLE.sub(r"\1Examples:", obj.docstring.value)
