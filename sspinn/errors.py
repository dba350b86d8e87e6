"""One error path for every command line of the project (``sspinn``, ``python -m predictive``,
``python -m agents``).

* :class:`UserError` — bad input the user can fix (a file, a field, a value). Its message is one
  line: what was given, where, what is wrong and what to do. Library code raises it (or a
  subclass such as :class:`sspinn.data.dataset.DataFormatError`); it is a :class:`ValueError`, so
  callers that catch ``ValueError`` keep working.
* :func:`run_cli` — runs a ``main(argv) -> int`` so that a user error prints one line on stderr
  and exits with status 2, Ctrl-C exits with 130, and anything else (a bug) prints one line with
  a hint; ``--debug`` anywhere on the command line shows the full traceback instead.

This module is part of the core: it imports nothing from ``envs``, ``predictive`` or ``agents``.
"""

from __future__ import annotations

import argparse
import os
import sys
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


class DataFormatError(UserError):
    """A recording or dataset file is malformed; the message names the file and what is wrong
    (re-exported by :mod:`sspinn.data.dataset`, where the format is defined)."""


#: Exceptions from the operating system that are about the user's paths, not bugs.
_PATH_ERRORS: Final = (FileNotFoundError, IsADirectoryError, NotADirectoryError, PermissionError, FileExistsError)


class ArgumentParser(argparse.ArgumentParser):
    """An :class:`argparse.ArgumentParser` whose usage errors are one line on stderr (the
    option, the value, what is wrong, where to look) with exit status 2, like every other user
    error; its sub-command parsers are of this class too."""

    def error(self, message: str) -> NoReturn:
        self.exit(EXIT_USER_ERROR, f"{self.prog}: error: {one_line(message)} (see {self.prog} --help)\n")


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
        return main(args)
    except (UserError, *_PATH_ERRORS, *user_errors) as exc:
        if debug:
            raise
        print(f"{prog}: error: {one_line(exc)}", file=sys.stderr)
        return EXIT_USER_ERROR
    except KeyboardInterrupt:
        if debug:
            raise
        print(f"{prog}: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except Exception as exc:  # a bug: one line and a hint, the traceback with --debug
        if debug:
            raise
        print(
            f"{prog}: internal error: {type(exc).__name__}: {one_line(exc)} "
            f"(run again with {DEBUG_FLAG} for the traceback and report it)",
            file=sys.stderr,
        )
        return EXIT_INTERNAL_ERROR
