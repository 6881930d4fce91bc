# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Conventions shared by the console commands: one help style, one-line errors, exit codes.

Every command builds its parser with ``parser()`` (defaults shown after each option's help),
checks the paths it was given with ``input_bag`` / ``input_file`` / ``output_file`` /
``output_folder`` before it starts, and turns an error into one line on stderr with ``fail``.
Exit status, the one rule of every console command (the nodes too): 0 done; 1 the run failed
on usable inputs (a bad parameter value in a file, a bag without the expected topics or with
topics of another type, a message that cannot be decoded); 2 a usage error: a bad option or
option value, or a path on the command line that does not exist, cannot be read as what it
should be (a bag, a parameter file) or cannot be written (an existing output without
``--overwrite`` included).
"""
from __future__ import annotations

import argparse
import functools
import signal
import sys
import threading
from pathlib import Path
from typing import Callable, TypeVar

from rosbags.highlevel import AnyReader, AnyReaderError

from fastslam_ros.node_start import ArgumentParser, interrupts_unreported, one_blas_thread

EXIT_FAILURE = 1
EXIT_USAGE = 2
EXIT_INTERRUPTED = 130
"""Ctrl-C (128 + SIGINT, as a shell reports it)."""
Number = TypeVar("Number", int, float)


class UsageError(Exception):
    """A path or file given on the command line that cannot be used (exit status 2)."""


BAD_INPUT_ERRORS = (UsageError, FileNotFoundError, FileExistsError, IsADirectoryError,
                    NotADirectoryError, PermissionError, AnyReaderError)
"""Errors that mean a path given on the command line cannot be used (exit status 2)."""
BAG_ERRORS = (OSError, ValueError, AnyReaderError)
"""What reading or writing a bag can raise (``SchemaError`` is a ValueError)."""


class HelpFormatter(argparse.ArgumentDefaultsHelpFormatter, argparse.RawDescriptionHelpFormatter):
    """Keeps the description's paragraphs and shows each option's default, except an empty
    one (None, False, []) that says nothing."""

    def _get_help_string(self, action: argparse.Action) -> str:
        default = action.default
        if default is None or default is False or default is argparse.SUPPRESS or default == []:
            return action.help or ""
        return super()._get_help_string(action)


def plain(text: str | None) -> str:
    """A docstring as plain help text: without reStructuredText literals (````name````)."""
    return (text or "").replace("``", "").strip()


def parser(prog: str, description: str | None, first_paragraph: bool = False
           ) -> argparse.ArgumentParser:
    """The argument parser of command ``prog`` (``description``: a module docstring)."""
    text = plain(description)
    if first_paragraph:
        text = text.split("\n\n")[0]
    return ArgumentParser(prog=prog, description=text, formatter_class=HelpFormatter)


def positive(kind: Callable[[str], Number] = float) -> Callable[[str], Number]:
    """An argparse ``type``: a number of ``kind`` (float or int) greater than 0."""
    def parse(text: str) -> Number:
        value = kind(text)  # ValueError: argparse says "invalid float value"
        if not value > 0:  # NaN too
            raise argparse.ArgumentTypeError(f"must be > 0 (got {text})")
        return value
    parse.__name__ = getattr(kind, "__name__", "number")
    return parse


def probability(text: str) -> float:
    """An argparse ``type``: a number in [0, 1]."""
    value = float(text)  # ValueError: argparse says "invalid probability value"
    if not 0.0 <= value <= 1.0:  # NaN too
        raise argparse.ArgumentTypeError(f"must be in [0, 1] (got {text})")
    return value


def positive_list(text: str) -> list[int]:
    """An argparse ``type``: comma-separated integers greater than 0 (``10,100``)."""
    try:
        values = [int(item) for item in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated integers (got {text!r})"
                                         ) from None
    if not all(value > 0 for value in values):
        raise argparse.ArgumentTypeError(f"every value must be > 0 (got {text!r})")
    return values


def input_path(path: Path | str, what: str = "input") -> Path:
    """``path`` if it exists (a bag folder or file), else UsageError."""
    path = Path(path)
    if not path.exists():
        raise UsageError(f"{what} not found: {path}")
    return path


def input_bag(path: Path | str, what: str = "bag") -> Path:
    """``path`` if it is a rosbag2 bag that opens (mcap or sqlite3), else UsageError."""
    path = input_path(path, what)
    try:
        with AnyReader([path]):
            pass
    except (AnyReaderError, OSError) as error:
        raise UsageError(f"cannot read {what} {path}: {error}") from None
    return path


def input_file(path: Path | str, what: str = "file") -> Path:
    """``path`` if it is a readable file, else UsageError."""
    path = input_path(path, what)
    if not path.is_file():
        raise UsageError(f"{what} is not a file: {path}")
    try:
        with open(path, "rb"):
            pass
    except OSError as error:
        raise UsageError(f"cannot read {what} {path}: {error.strerror or error}") from None
    return path


def output_file(path: Path | str, what: str = "output", suffixes: tuple[str, ...] = ()
                ) -> Path:
    """``path`` if it can be written: its folder exists and, when ``suffixes`` are given, its
    suffix is one of them; else UsageError."""
    path = Path(path)
    if suffixes and path.suffix.lower().lstrip(".") not in suffixes:
        raise UsageError(f"{what} {path}: unsupported format {path.suffix or '(none)'!r} "
                         f"(use one of: {', '.join(suffixes)})")
    folder = path.parent
    if not folder.is_dir():
        raise UsageError(f"{what} {path}: folder {folder} does not exist")
    if path.is_dir():
        raise UsageError(f"{what} {path} is a folder")
    return path


def output_folder(path: Path | str, what: str = "output folder") -> Path:
    """``path`` if it is a folder or can be created as one (its parent exists); else UsageError."""
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise UsageError(f"{what} {path} is a file")
    if not path.exists() and not path.parent.is_dir():
        raise UsageError(f"{what} {path}: folder {path.parent} does not exist")
    return path


def check_scoring_paths(run: Path, ground_truth: Path | None, json_path: Path | None,
                        plot: Path | None, plot_suffixes: tuple[str, ...],
                        written: list[Path], overwrite: bool) -> None:
    """What ``fastslam-eval`` checks before it reads a run (either kind of run): ``--json`` and
    ``--plot`` can be written (the plot in one of ``plot_suffixes``), the run and the ground
    truth are bags, and every file to write (``written``) may be (``output.check_output``,
    never one of the inputs); UsageError or FileExistsError otherwise."""
    from fastslam_ros.output import check_output

    if json_path is not None:
        output_file(json_path, "--json")
    if plot is not None:
        output_file(plot, "--plot", plot_suffixes)
    input_bag(run)
    if ground_truth is not None:
        input_bag(ground_truth, "ground-truth bag")
    inputs = [run] + ([ground_truth] if ground_truth is not None else [])
    for path in written:
        check_output(path, overwrite, "file", inputs)


def fail(prog: str, error: BaseException | str, code: int | None = None) -> int:
    """Print ``prog: error`` as one line on stderr; return the exit status: 2 for an error of
    ``BAD_INPUT_ERRORS`` (whatever ``code`` says: a path that cannot be used is always a usage
    error), else ``code``, else 1."""
    if isinstance(error, BAD_INPUT_ERRORS):
        code = EXIT_USAGE
    elif code is None:
        code = EXIT_FAILURE
    message = str(error).strip().replace("\n", " ") or type(error).__name__
    print(f"{prog}: {message}", file=sys.stderr)
    return code


Main = Callable[[list[str] | None], int]


def interruptible(prog: str) -> Callable[[Main], Main]:
    """Decorate a command's ``main``: Ctrl-C ends it with one line and status 130, never a
    traceback, also when numba, compiling the kernels, turns the interrupt into an error of
    its own or swallows it in a callback."""
    def decorate(main: Main) -> Main:
        @functools.wraps(main)
        def run(argv: list[str] | None = None) -> int:
            interrupted: list[int] = []

            def on_interrupt(signum: int, frame: object) -> None:
                interrupted.append(signum)
                raise KeyboardInterrupt

            one_blas_thread()
            main_thread = threading.current_thread() is threading.main_thread()
            previous = signal.signal(signal.SIGINT, on_interrupt) if main_thread else None
            try:
                with interrupts_unreported():
                    return main(argv)
            except BaseException as error:
                if not (interrupted or isinstance(error, KeyboardInterrupt)):
                    raise
                print(f"{prog}: interrupted", file=sys.stderr)
                # Half-built compiler objects fail in their __del__ at exit: nothing to report.
                sys.unraisablehook = lambda unraisable: None
                return EXIT_INTERRUPTED
            finally:
                if main_thread:
                    signal.signal(signal.SIGINT, previous)
        return run
    return decorate
