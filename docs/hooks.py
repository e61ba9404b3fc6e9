"""MkDocs hooks: the pages that are generated from the code rather than written by hand.

* ``reference/cli.md``: ``<!-- cli-reference -->`` becomes the help of every ``noisybolt``
  subcommand, read from the argument parser itself (``noisybolt.cli.build_parser``), so
  the page cannot drift from the command.
* ``reference/api/index.md``: ``<!-- public-api -->`` becomes one mkdocstrings block per
  name of ``noisybolt.__all__``.
* ``reference/api/<package>.md``: one page per subpackage of ``noisybolt`` (what its
  ``__all__`` exports), generated, and listed in the nav under "API reference".
"""

from __future__ import annotations

import argparse
import importlib
import os
import pkgutil
from typing import Any

from mkdocs.structure.files import File, Files

# Subpackages that are not library API: the command has its own page; configs is data.
_NOT_API = {"cli", "configs"}
_API_DIR = "reference/api"


def _subpackages() -> list[str]:
    import noisybolt

    return sorted(
        info.name
        for info in pkgutil.iter_modules(noisybolt.__path__)
        if info.ispkg and info.name not in _NOT_API and not info.name.startswith("_")
    )


def on_config(config: Any) -> Any:
    """Lists one generated page per subpackage under the nav's "API reference"."""
    for entry in config.nav or []:
        if isinstance(entry, dict) and "API reference" in entry:
            pages = entry["API reference"]
            pages.extend({f"noisybolt.{name}": f"{_API_DIR}/{name}.md"} for name in _subpackages())
    return config


def on_files(files: Files, config: Any) -> Files:
    for name in _subpackages():
        files.append(File.generated(config, f"{_API_DIR}/{name}.md", content=_api_page(name)))
    return files


def _api_page(name: str) -> str:
    """A subpackage's page: what its ``__all__`` exports or, for a package that exports
    nothing itself (a namespace of modules), each of its public modules."""
    package = importlib.import_module(f"noisybolt.{name}")
    summary = (package.__doc__ or "").strip().split("\n\n")[0]
    if hasattr(package, "__all__"):
        return (
            f"# noisybolt.{name}\n\n{summary}\n\n"
            f"::: noisybolt.{name}\n"
            "    options:\n"
            "      show_root_heading: false\n"
            "      show_root_toc_entry: false\n"
            "      members_order: source\n"
        )
    modules = sorted(
        info.name
        for info in pkgutil.iter_modules(package.__path__)
        if not info.name.startswith("_")
    )
    blocks = [
        f"::: noisybolt.{name}.{module}\n"
        "    options:\n"
        "      heading_level: 2\n"
        "      members_order: source\n"
        for module in modules
    ]
    return f"# noisybolt.{name}\n\n{summary}\n\n" + "\n".join(blocks)


def _public_api() -> str:
    import noisybolt

    blocks = []
    for name in noisybolt.__all__:
        if name.startswith("__"):
            continue
        blocks.append(f"## `noisybolt.{name}`\n\n::: noisybolt.{name}\n")
    return "\n".join(blocks)


def _subcommands(parser: argparse.ArgumentParser, prog: str) -> list[tuple[str, Any]]:
    """(full command, parser) for a parser and all its subcommands, depth first."""
    found = [(prog, parser)]
    for action in parser._actions:  # argparse exposes subparsers only through _actions
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                found.extend(_subcommands(sub, f"{prog} {name}"))
    return found


def _cli_reference() -> str:
    from noisybolt.cli import build_parser

    # argparse wraps help to the terminal's width: fix it so the page is the same anywhere.
    os.environ["COLUMNS"] = "96"
    sections = []
    for command, parser in _subcommands(build_parser(), "noisybolt"):
        depth = command.count(" ")
        heading = "#" * min(2 + max(depth - 1, 0), 4)
        sections.append(f"{heading} `{command}`\n\n```text\n{parser.format_help().rstrip()}\n```\n")
    return "\n".join(sections)


_MARKERS = {
    "<!-- cli-reference -->": _cli_reference,
    "<!-- public-api -->": _public_api,
}


def on_page_markdown(markdown: str, page: Any, config: Any, files: Files) -> str:
    for marker, render in _MARKERS.items():
        if marker in markdown:
            markdown = markdown.replace(marker, render())
    return markdown
