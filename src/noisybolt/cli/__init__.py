"""The ``noisybolt`` command: one entry point, one module per subcommand group.

Each module in :data:`COMMAND_MODULES` exposes ``register(subparsers)``, which adds its
subcommand(s) and sets ``func`` on the parser to a callable taking the parsed namespace
and returning an exit code.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import signal
import sys
import threading
import warnings
from collections.abc import Iterator, Sequence

from noisybolt.errors import NoisyboltError
from noisybolt.version import __version__

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
    # The command as given, for the run directories that record it (main(argv) called
    # from Python records its argv, not the host process's).
    args.command_line = ["noisybolt", *argv] if argv is not None else list(sys.argv)
    if not hasattr(args, "func"):
        parser.print_help()
        return 2
    from noisybolt.envs.labels import headless_rendering

    headless_rendering()
    try:
        with _plain_warnings(f"noisybolt {args.command}"), sigterm_as_interrupt():
            return int(args.func(args) or 0)
    except NoisyboltError as error:
        print(f"noisybolt {args.command}: error: {error}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        # Training saves a checkpoint on the way out and says how to resume; the rest
        # is a plain line, not a traceback through the library.
        print(f"noisybolt {args.command}: interrupted", file=sys.stderr)
        return 130


@contextlib.contextmanager
def sigterm_as_interrupt() -> Iterator[None]:
    """SIGTERM (``kill``, a batch scheduler's notice) raises KeyboardInterrupt meanwhile,
    so that a stopped command (a training, a sweep's trial) saves a checkpoint as Ctrl-C
    does."""

    def interrupt(signum: int, frame: object) -> None:
        raise KeyboardInterrupt

    if threading.current_thread() is not threading.main_thread():
        yield  # signal handlers can only be set from the main thread
        return
    previous = signal.signal(signal.SIGTERM, interrupt)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


@contextlib.contextmanager
def _plain_warnings(prog: str) -> Iterator[None]:
    """noisybolt's own warnings printed as a sentence for the user ("noisybolt train:
    warning: ..."), not with the file and source line of the library code that raised
    them; other libraries' warnings as Python prints them."""
    original = warnings.formatwarning

    def format_warning(
        message: Warning | str,
        category: type[Warning],
        filename: str,
        lineno: int,
        line: str | None = None,
    ) -> str:
        if category.__module__.startswith("noisybolt"):
            return f"{prog}: warning: {message}\n"
        return original(message, category, filename, lineno, line)

    warnings.formatwarning = format_warning
    try:
        yield
    finally:
        warnings.formatwarning = original


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
