"""The ``noisybolt`` command: one entry point, one module per subcommand group.

Each module in :data:`COMMAND_MODULES` exposes ``register(subparsers)``, which adds its
subcommand(s) and sets ``func`` on the parser to a callable taking the parsed namespace
and returning an exit code.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence

from noisybolt import __version__
from noisybolt.errors import NoisyboltError

__all__ = ["COMMAND_MODULES", "build_parser", "main"]

COMMAND_MODULES: tuple[str, ...] = (
    "noisybolt.cli.demo",
    "noisybolt.cli.classifiers",
    "noisybolt.cli.train",
    "noisybolt.cli.check",
    "noisybolt.cli.experiments",
)


def build_parser() -> argparse.ArgumentParser:
    """The full argument parser, with every subcommand registered."""
    parser = argparse.ArgumentParser(
        prog="noisybolt",
        description="Reinforcement learning under restraining bolts with noisy perception.",
    )
    parser.add_argument("--version", action="version", version=f"noisybolt {__version__}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMAND_MODULES:
        importlib.import_module(name).register(subparsers)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Runs the command line; returns the exit code (2 for bad input, 1 for failures)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if not hasattr(args, "func"):
        parser.print_help()
        return 2
    try:
        return int(args.func(args) or 0)
    except NoisyboltError as error:
        print(f"noisybolt {args.command}: error: {error}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
