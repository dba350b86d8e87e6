"""One error path for every command line of the project (``sspinn``, ``python -m predictive``,
``python -m agents``).

* :class:`UserError` — bad input the user can fix (a file, a field, a value). Its message is one
  line: what was given, where, what is wrong and what to do. Library code raises it (or a
  subclass such as :class:`sspinn.data.dataset.DataFormatError`); it is a :class:`ValueError`, so
  callers that catch ``ValueError`` keep working.
* :func:`run_cli` — runs a ``main(argv) -> int`` so that a user error prints one line on stderr
  and exits with status 2, Ctrl-C exits with 130, and anything else (a bug) prints one line with
  a hint; ``--debug`` anywhere on the command line shows the full traceback instead. An error of
  the operating system about a path (no space left, read-only file system, permission denied, a
  file where a folder is expected, ...) is a user error: :func:`describe_os_error` names the path.
* :func:`bounded` — an argparse ``type`` for a numeric option with its valid range, so that an
  out-of-range value is a usage error naming the option, the value and the range.

This module is part of the core: it imports nothing from ``envs``, ``predictive`` or ``agents``.
"""

from __future__ import annotations

import argparse
import errno
import math
import os
import sys
import warnings
from collections.abc import Callable, Sequence
from typing import Final, NoReturn

#: Exit status of a user error (argparse uses the same for usage errors).
EXIT_USER_ERROR: Final = 2
#: Exit status of an unexpected internal error.
EXIT_INTERNAL_ERROR: Final = 1
#: Exit status after Ctrl-C (128 + SIGINT).
EXIT_INTERRUPTED: Final = 130
#: The flag (and environment variable ``SSPINN_DEBUG=1``) that shows tracebacks.
DEBUG_FLAG: Final = "--debug"


class UserError(ValueError):
    """Bad input that the user can fix; the message names the file, field or value and what to do."""


class InputWarning(UserWarning):
    """Input that is accepted but probably wrong (a sensor's sign, the stated rate, ...); the CLIs
    under :func:`run_cli` print it as one ``WARNING: <message>`` line on stderr."""


def _show_input_warning(message, category, filename, lineno, file=None, line=None, _default=warnings.showwarning):  # noqa: ANN001
    """``warnings.showwarning`` that prints :class:`InputWarning` s as ``WARNING: <message>``."""
    if issubclass(category, InputWarning):
        print(f"WARNING: {one_line(message)}", file=sys.stderr if file is None else file)
    else:
        _default(message, category, filename, lineno, file, line)


class DataFormatError(UserError):
    """A recording or dataset file is malformed; the message names the file and what is wrong
    (re-exported by :mod:`sspinn.data.dataset`, where the format is defined)."""


#: Exceptions from the operating system that are about the user's paths, not bugs.
_PATH_ERRORS: Final = (FileNotFoundError, IsADirectoryError, NotADirectoryError, PermissionError, FileExistsError)

#: errno values of an OSError that is about the user's files or disk → what to do about it.
_OS_ERROR_HINTS: Final = {
    errno.ENOSPC: "free some space or choose an output folder on another disk",
    errno.EDQUOT: "free some space or choose an output folder on another disk",
    errno.EFBIG: "the file is larger than this file system allows; choose another output folder",
    errno.EROFS: "choose an output folder on a writable file system",
    errno.EACCES: "check the permissions or choose another path",
    errno.EPERM: "check the permissions or choose another path",
    errno.ENOTDIR: "a part of this path is a file where a folder is expected",
    errno.EISDIR: "this is a folder where a file is expected",
    errno.EEXIST: "it exists already; remove it or choose another path",
    errno.ENOENT: "check the path",
    errno.ENAMETOOLONG: "choose a shorter path",
    errno.ELOOP: "the path has a loop of symbolic links",
    errno.ENOTEMPTY: "the folder is not empty",
}


class ArgumentParser(argparse.ArgumentParser):
    """An :class:`argparse.ArgumentParser` whose usage errors are one line on stderr (the
    option, the value, what is wrong, where to look) with exit status 2, like every other user
    error; its sub-command parsers are of this class too."""

    def error(self, message: str) -> NoReturn:
        self.exit(EXIT_USER_ERROR, f"{self.prog}: error: {one_line(message)} (see {self.prog} --help)\n")


def bounded(kind: type, low: float, high: float, unit: str = "") -> Callable[[str], float]:
    """An argparse ``type`` accepting finite ``kind`` (int or float) values in [low, high]; any
    other value is a usage error naming the range (``"--nodes 1000000 is outside 4–2000"``)."""

    def parse(text: str) -> float:
        try:
            value = kind(text)
        except ValueError:
            noun = "an integer" if kind is int else "a number"
            raise argparse.ArgumentTypeError(f"{text!r} is not {noun} in {low:g}–{high:g}{unit}") from None
        if not math.isfinite(value) or not low <= value <= high:
            raise argparse.ArgumentTypeError(f"{text} is outside {low:g}–{high:g}{unit}")
        return value

    parse.__name__ = kind.__name__
    return parse


def describe_os_error(exc: OSError) -> str:
    """One line for an OSError about a path: ``"<path>: <reason>; <what to do>"`` (its own text
    when it names no path and has no errno this module knows)."""
    hint = _OS_ERROR_HINTS.get(exc.errno) if exc.errno is not None else None
    if exc.filename is None:
        plain = bool(exc.strerror) and str(exc) == f"[Errno {exc.errno}] {exc.strerror}"
        text = exc.strerror if plain else one_line(exc)
        return f"{text}; {hint}" if plain and hint else text
    where = f"{os.fsdecode(exc.filename)}" + (f" → {os.fsdecode(exc.filename2)}" if exc.filename2 is not None else "")
    if exc.errno == errno.EEXIST and os.path.lexists(exc.filename) and not os.path.isdir(exc.filename):
        hint = "this is a file where a folder is expected"  # mkdir of an output folder
    return f"{where}: {exc.strerror or one_line(exc)}" + (f"; {hint}" if hint else "")


def _is_user_os_error(exc: BaseException) -> bool:
    return isinstance(exc, OSError) and (isinstance(exc, _PATH_ERRORS) or exc.errno in _OS_ERROR_HINTS)


def one_line(message: object) -> str:
    """The message on a single line (newlines folded into " | ")."""
    return " | ".join(part.strip() for part in str(message).strip().splitlines() if part.strip())


def run_cli(
    main: Callable[[list[str]], int],
    prog: str,
    argv: Sequence[str] | None = None,
    user_errors: tuple[type[BaseException], ...] = (),
) -> int:
    """Run ``main(argv)`` (``argv`` default ``sys.argv[1:]``) with the project's error path and
    return the exit status (call ``sys.exit(run_cli(...))``).

    Args:
        main: the command's entry point, taking the arguments without ``--debug``.
        prog: the program's name for messages, e.g. ``"sspinn"``.
        argv: the arguments; ``--debug`` is removed before ``main`` sees them.
        user_errors: further exception types treated as user errors (e.g. a package's own
            ``ConfigError`` that predates :class:`UserError`).
    """
    args = list(sys.argv[1:] if argv is None else argv)
    debug = DEBUG_FLAG in args or os.environ.get("SSPINN_DEBUG", "") not in ("", "0")
    args = [a for a in args if a != DEBUG_FLAG]
    try:
        with warnings.catch_warnings():
            warnings.showwarning = _show_input_warning
            return main(args)
    except (UserError, *_PATH_ERRORS, *user_errors) as exc:
        if debug:
            raise
        text = describe_os_error(exc) if isinstance(exc, OSError) else one_line(exc)
        print(f"{prog}: error: {text}", file=sys.stderr)
        return EXIT_USER_ERROR
    except KeyboardInterrupt:
        if debug:
            raise
        print(f"{prog}: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except Exception as exc:  # a bug: one line and a hint, the traceback with --debug
        if debug:
            raise
        if _is_user_os_error(exc):  # no space, a read-only file system, ...: about the user's files
            print(f"{prog}: error: {describe_os_error(exc)}", file=sys.stderr)  # type: ignore[arg-type]
            return EXIT_USER_ERROR
        print(
            f"{prog}: internal error: {type(exc).__name__}: {one_line(exc)} "
            f"(run again with {DEBUG_FLAG} for the traceback and report it)",
            file=sys.stderr,
        )
        return EXIT_INTERNAL_ERROR
