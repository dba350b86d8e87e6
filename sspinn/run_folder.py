"""A run folder owned by one process, and atomic writes into it.

* :class:`RunLock` — ``with RunLock(folder):`` makes the calling process the folder's only
  owner. The lock is an advisory ``fcntl.flock`` (through :mod:`filelock`) on ``<folder>/.lock``
  (never a symbolic or hard link, never a file it did not write), released by the kernel
  when the process ends however it ends (so no lock outlives its owner on this host); the file
  records the owner (PID, host, start time, command line) so that a second process is told who
  holds the folder. A lock file left by a process that died (its PID gone on this host) is taken
  over with a warning naming the dead owner.
* :func:`atomic_path` — ``with atomic_path(path) as tmp:`` write ``tmp``; on success it replaces
  ``path`` in one ``os.replace`` (a reader sees the old or the new file, never a half-written
  one), on an exception the temporary file is removed. Temporary names are unique per process and
  call (``.<name>.<pid>.<random>.tmp``), so two writers never share one. An OSError while writing
  (no space left, a read-only file system, ...) names ``path``, not the temporary file.
* :func:`output_target` — where a command writes: ``--out``, or the first free ``<out>_2``, …
  when it holds a finished result and ``--overwrite`` was not given (a finished result is never
  replaced without that flag).
* :func:`atomic_write_text`, :func:`atomic_write_json` — the same for a text or JSON file;
  :func:`json_text` refuses NaN and infinity (which are not JSON: Python would write ``NaN``
  literals that other readers reject) with :class:`NonFiniteValueError` naming the key, or
  writes them as ``null``.
"""

from __future__ import annotations

import contextlib
import errno
import json
import math
import os
import shutil
import socket
import stat
import sys
import time
import uuid
import warnings
from collections.abc import Callable, Iterator
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, Final

from sspinn.errors import UserError

LOCK_NAME: Final = ".lock"


class RunFolderBusyError(UserError):
    """Another live process owns the run folder; the message names it."""


class UnsafeLockFileError(UserError):
    """``<folder>/.lock`` is a symbolic link, a hard link or a file sspinn did not write: refused
    untouched (a lock never truncates a file it did not create)."""


class NonFiniteValueError(UserError):
    """A result holds NaN or infinity where a finite number is required; the message names the
    file and the key."""


@dataclass(frozen=True)
class LockOwner:
    """Who holds a run folder: process id, host name, start time (s since the epoch, UTC) and
    the command line."""

    pid: int
    host: str
    started: float
    command: str

    @classmethod
    def this_process(cls) -> LockOwner:
        return cls(pid=os.getpid(), host=socket.gethostname(), started=time.time(), command=" ".join(sys.argv))

    @classmethod
    def parse(cls, text: str) -> LockOwner | None:
        """The owner recorded in a lock file's text, or None if it is empty or unreadable."""
        try:
            data: Any = json.loads(text)
            return cls(pid=int(data["pid"]), host=str(data["host"]), started=float(data["started"]),
                       command=str(data.get("command", "")))
        except (ValueError, TypeError, KeyError):
            return None

    def describe(self) -> str:
        when = time.strftime("%Y-%m-%d %H:%M:%S UTC", time.gmtime(self.started))
        return f"PID {self.pid} on host {self.host} since {when} ({self.command or 'unknown command'})"

    def is_alive_here(self) -> bool | None:
        """True/False if the owner runs on this host and is alive/dead; None on another host."""
        if self.host != socket.gethostname():
            return None
        try:
            os.kill(self.pid, 0)
        except ProcessLookupError:
            return False
        except PermissionError:  # exists, owned by another user
            return True
        return True


class RunLock:
    """Exclusive ownership of a run folder for the life of a ``with`` block (or until
    :meth:`release`). Raises :class:`RunFolderBusyError` naming the owner if another process
    holds it. Re-entrant within one process is not supported: lock a folder once.

    The ``flock`` itself is :class:`filelock.UnixFileLock` (no soft fallback), which opens
    ``.lock`` with ``O_NOFOLLOW`` (a symbolic link there is refused, never followed) and creates
    it with ``O_EXCL``. Only the owner record is written here, through the lock's own descriptor,
    and only into a file that is a plain regular file with one link holding nothing or an owner
    record: a hard link to another file, or a file with other content, is refused untouched."""

    def __init__(self, folder: str | Path) -> None:
        import filelock

        self.folder = Path(folder)
        self.path = self.folder / LOCK_NAME
        self._fd: int | None = None
        self._lock = filelock.UnixFileLock(str(self.path), timeout=0, mode=0o644, fallback_to_soft=False,
                                           on_acquired=self._record_owner)

    def _record_owner(self, fd: int) -> None:
        """Called by filelock with the locked descriptor: check what the file is, warn about a
        stale owner, write ours."""
        info = os.fstat(fd)
        text = os.pread(fd, 1 << 16, 0).decode(errors="replace") if info.st_size <= 1 << 16 else "?"
        previous = LockOwner.parse(text)
        if not stat.S_ISREG(info.st_mode) or info.st_nlink != 1 or (text.strip() and previous is None):
            what = ("a hard link to another file" if stat.S_ISREG(info.st_mode) and info.st_nlink != 1
                    else "not a lock file of sspinn")
            raise UnsafeLockFileError(f"{self.path}: {what}; it is left untouched: remove it (or choose another "
                                      "output folder)")
        if previous is not None and previous.pid != os.getpid():
            # we hold the flock, so the recorded owner no longer holds it: it died (or ran on
            # another host whose lock this filesystem cannot see; warn either way)
            state = {False: "is no longer running", None: "ran on another host"}.get(previous.is_alive_here(), "released it")
            warnings.warn(
                f"{self.folder}: taking over a stale lock of {previous.describe()}, which {state}", stacklevel=5
            )
        os.ftruncate(fd, 0)
        os.pwrite(fd, json.dumps(asdict(LockOwner.this_process())).encode(), 0)
        os.fsync(fd)
        self._fd = fd

    def acquire(self) -> RunLock:
        import filelock

        self.folder.mkdir(parents=True, exist_ok=True)
        try:
            self._lock.acquire()
        except filelock.Timeout:
            owner = LockOwner.parse(_read_no_follow(self.path))
            who = owner.describe() if owner else "another process"
            raise RunFolderBusyError(
                f"{self.folder}: this run folder is in use by {who}; wait for it to finish, stop it, "
                "or choose another output folder"
            ) from None
        except OSError as exc:
            if exc.errno != errno.ELOOP and not self.path.is_symlink():
                raise
            raise UnsafeLockFileError(f"{self.path}: is a symbolic link (to {os.readlink(self.path)}); it is never "
                                      "followed: remove it (or choose another output folder)") from None
        except UnsafeLockFileError:
            self._fd = None
            raise
        return self

    def release(self) -> None:
        if self._fd is None:
            return
        with contextlib.suppress(OSError):
            os.ftruncate(self._fd, 0)  # a clean exit leaves no owner behind
        self._fd = None
        self._lock.release()  # closing the descriptor releases the flock

    def __enter__(self) -> RunLock:
        return self.acquire()

    def __exit__(self, *exc: object) -> None:
        self.release()


def _read_no_follow(path: Path) -> str:
    """The text of a lock file (at most 64 KiB), "" when it cannot be opened without following a link."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK)
    except OSError:
        return ""
    try:
        return os.pread(fd, 1 << 16, 0).decode(errors="replace")
    finally:
        os.close(fd)


def free_folder(out: str | Path, holds_result: Callable[[Path], bool], keep_suffix: bool = False) -> Path:
    """``out`` if ``holds_result(out)`` is false, else the first of ``out_2``, ``out_3``, … for which
    it is false: where a command writes when ``out`` holds a finished result that only an explicit
    ``--overwrite`` may replace. With ``keep_suffix`` the number goes before the file suffix
    (``walk.gif`` → ``walk_2.gif``); without it after the whole name (``walk_1.3`` → ``walk_1.3_2``)."""
    out = Path(out)
    k = 1
    candidate = out
    while holds_result(candidate):
        k += 1
        name = f"{out.stem}_{k}{out.suffix}" if keep_suffix else f"{out.name}_{k}"
        candidate = out.with_name(name)
    return candidate


def output_target(out: str | Path, holds_result: Callable[[Path], bool], overwrite: bool, what: str,
                  hint: str = "", keep_suffix: bool = False) -> Path:
    """Where a command writes its result: ``out``, unless ``out`` holds a finished result
    (``holds_result``: ``what`` names it in the message) and ``overwrite`` is false; then the first
    free ``out_2``, ``out_3``, … (:func:`free_folder`), announced on a ``NOTE`` line (``hint``: what
    else the user could do, ending in ", "). A finished result is never replaced without the flag.
    With ``keep_suffix`` ``out`` is a file (``walk.gif`` → ``walk_2.gif``)."""
    out = Path(out)
    if overwrite or not holds_result(out):
        return out
    new = free_folder(out, holds_result, keep_suffix)
    there = f"is {what}" if keep_suffix else f"holds {what}"  # a file (numbered before its suffix) or a folder/stem
    print(f"NOTE: {out} {there}; writing to {new} instead ({hint}replace it with --overwrite)", flush=True)
    return new


#: The ``--overwrite`` help of the commands that write one result (see :func:`output_target`).
OVERWRITE_HELP: Final = "replace the result already at --out (else a NOTE and the first free <out>_2, <out>_3, …)"


def run_outputs(folder: str | Path, names: tuple[str, ...]) -> list[str]:
    """The entries of ``names`` (files or folders a run writes) that exist in ``folder``."""
    return [name for name in names if (Path(folder) / name).exists()]


def claim_run_folder(folder: str | Path, names: tuple[str, ...], overwrite: bool, hint: str = "") -> None:
    """Make ``folder`` ready for a new run that writes ``names``: refuse (:class:`FileExistsError`
    naming what is there) when it holds any of them, unless ``overwrite``, which deletes them
    (only those: other files in the folder stay). ``hint``: how else to go on, ending in ", "."""
    present = run_outputs(folder, names)
    if present and not overwrite:
        raise FileExistsError(f"{folder} already holds a run ({', '.join(present)}); {hint}replace it with --overwrite, "
                              "or choose another --out")
    for name in present:
        path = Path(folder) / name
        if path.is_dir():
            shutil.rmtree(path)
        else:
            path.unlink()


def stem_outputs(suffixes: tuple[str, ...]) -> Callable[[Path], bool]:
    """``holds_result`` for a command whose ``--out`` is a path without suffix: true when any
    ``<out><suffix>`` exists (e.g. ``.npz``, ``.json``, ``_summary.json``)."""
    return lambda stem: any(stem.with_name(stem.name + suffix).exists() for suffix in suffixes)


@contextlib.contextmanager
def atomic_path(path: str | Path, tmp_suffix: str = ".tmp") -> Iterator[Path]:
    """Yield a unique temporary path beside ``path``; replace ``path`` with it on success.
    ``tmp_suffix``: the temporary name's ending, for writers that want one (``.tmp.pt2``)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.{uuid.uuid4().hex[:8]}{tmp_suffix}")
    try:
        yield tmp
        os.replace(tmp, path)
    except OSError as exc:
        if exc.errno is None or exc.filename not in (None, str(tmp), tmp, os.fsencode(tmp)):
            raise
        raise OSError(exc.errno, exc.strerror or os.strerror(exc.errno), str(path)) from exc
    finally:
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()


def atomic_write_text(path: str | Path, text: str) -> Path:
    """Write ``text`` to ``path`` atomically (see :func:`atomic_path`)."""
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return Path(path)


def _non_finite(value: Any, where: str = "") -> Iterator[tuple[str, float]]:
    """(key path, value) of every non-finite float in plain JSON data."""
    if isinstance(value, float) and not math.isfinite(value):
        yield where or "(top level)", value
    elif isinstance(value, dict):
        for key, item in value.items():
            yield from _non_finite(item, f"{where}.{key}" if where else str(key))
    elif isinstance(value, list):
        for k, item in enumerate(value):
            yield from _non_finite(item, f"{where}[{k}]")


def _nulled(value: Any) -> Any:
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: _nulled(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_nulled(v) for v in value]
    return value


def json_text(
    data: Any, *, non_finite: str = "refuse", indent: int | None = 2, default: Callable[[Any], Any] | None = None,
    label: object = "JSON data",
) -> str:
    """``data`` as JSON text (``default`` converts what JSON does not know, as in :func:`json.dumps`).
    NaN and infinity: ``non_finite="refuse"`` raises :class:`NonFiniteValueError` naming
    ``label`` (e.g. the file it is meant for) and the first such key; ``"null"`` writes them as
    ``null`` (for reports where a missing number is expected)."""
    if non_finite not in ("refuse", "null"):
        raise ValueError(f"non_finite must be 'refuse' or 'null', got {non_finite!r}")
    try:
        return json.dumps(data, indent=indent, default=default, allow_nan=False)
    except ValueError:  # a non-finite float somewhere: find it in the plain form
        plain = json.loads(json.dumps(data, default=default))
        if non_finite == "null":
            return json.dumps(_nulled(plain), indent=indent, allow_nan=False)
        bad = list(_non_finite(plain))
        if not bad:
            raise
        more = f" (and {len(bad) - 1} more)" if len(bad) > 1 else ""
        raise NonFiniteValueError(f"{label}: refusing to write non-finite {bad[0][1]} at {bad[0][0]}{more}") from None


def atomic_write_json(
    path: str | Path, data: Any, *, non_finite: str = "refuse", indent: int | None = 2,
    default: Callable[[Any], Any] | None = None,
) -> Path:
    """Write ``data`` as JSON to ``path`` atomically; NaN and infinity are refused (nothing is
    written) or written as ``null``, see :func:`json_text`."""
    return atomic_write_text(path, json_text(data, non_finite=non_finite, indent=indent, default=default, label=path))
