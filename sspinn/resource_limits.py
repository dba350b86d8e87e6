"""Upper bounds on what a user's input may make the program read or allocate, checked before
the work starts (so a typo never fills the memory, the disk or the clock).

* :func:`input_file` — a file the program reads must be a regular file (a FIFO, a device such as
  ``/dev/zero`` or a socket is refused: reading one blocks forever or never ends) no larger than
  a stated limit (:data:`MAX_INPUT_BYTES` for data files, :data:`MAX_CONFIG_BYTES` for YAML/JSON
  configurations and maps); :func:`read_input_text` reads one as UTF-8 text, naming the file in
  every error (also a file that is not UTF-8).
* :func:`physical_memory_bytes` — this machine's memory; :func:`check_allocation` refuses an
  estimated allocation above :data:`MEMORY_SHARE` of it, naming the option and the value that
  asked for it.
* :data:`SIZE_LIMITS` — upper bounds of the size-like configuration fields (by name) that their
  dataclass gives no range for (:func:`sspinn.yaml_config.check_options` applies them).

Hand-written rather than psutil: the total memory is one ``sysconf`` call on the platforms the
project runs on (Linux, macOS), and psutil is not a dependency.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path
from typing import Final

from sspinn.errors import UserError

#: Largest data file read (recording CSVs and sidecars, IMU exports, GRF files), bytes: 1 GiB
#: (a 100 Hz recording of 7 IMUs is about 30 MB per hour).
MAX_INPUT_BYTES: Final = 1 << 30
#: Largest configuration, sensor map or other YAML/JSON settings file read, bytes: 16 MiB.
MAX_CONFIG_BYTES: Final = 16 << 20
#: Most data rows read from one table: 5 million (almost 14 h at 100 Hz).
MAX_ROWS: Final = 5_000_000
#: Largest share of the machine's memory one estimated allocation may ask for.
MEMORY_SHARE: Final = 0.5
#: Upper bounds of size-like configuration fields (by field name) where the class states none:
#: optimiser steps and step counts (10⁸), windows per batch, samples per window.
SIZE_LIMITS: Final[dict[str, int]] = {
    "steps": 10**8, "start_steps": 10**8, "finetune_last": 10**8, "log_every": 10**8, "checkpoint_every": 10**8,
    "starts": 1000, "batch_size": 1_000_000, "window": 100_000, "threads": 4096,
}

#: Memory a training step takes per sample of its batch (``batch_size × window`` samples),
#: bytes: a lower bound of the 58 kB measured for the default network (peak resident memory of
#: 2 steps at batch 8 and 64, window 256: 848 and 1677 MB), used to refuse a batch that cannot fit.
BYTES_PER_TRAINING_SAMPLE: Final = 40_000


class ResourceLimitError(UserError):
    """An input would make the program read or allocate more than its stated limit."""


def _kind(mode: int) -> str | None:
    for test, name in ((stat.S_ISFIFO, "a FIFO (named pipe)"), (stat.S_ISCHR, "a character device"),
                       (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket"), (stat.S_ISDIR, "a folder")):
        if test(mode):
            return name
    return None


def input_file(path: str | Path, max_bytes: int = MAX_INPUT_BYTES, what: str = "file") -> Path:
    """``path`` if it is a regular file (symbolic links followed) of at most ``max_bytes``;
    :class:`ResourceLimitError` naming it otherwise. A path that does not exist is returned
    unchanged (the caller says what it expected there)."""
    path = Path(path)
    try:
        info = os.stat(path)
    except FileNotFoundError:
        return path
    except OSError as exc:
        raise ResourceLimitError(f"{path}: cannot read the {what} ({exc.strerror})") from None
    kind = _kind(info.st_mode)
    if kind is not None:
        raise ResourceLimitError(f"{path}: is {kind}, not a regular {what}; give a file")
    if info.st_size > max_bytes:
        raise ResourceLimitError(f"{path}: {info.st_size / 2**20:.0f} MiB, more than the {max_bytes / 2**20:.0f} MiB "
                                 f"a {what} may have here; split or crop it")
    return path


def read_input_text(path: str | Path, max_bytes: int = MAX_INPUT_BYTES, what: str = "file",
                    encoding: str = "utf-8-sig") -> str:
    """The text of ``path`` (:func:`input_file` checks; a UTF-8 byte-order mark ignored);
    :class:`ResourceLimitError` naming the file for text that is not UTF-8."""
    path = input_file(path, max_bytes, what)
    data = path.read_bytes()
    if len(data) > max_bytes:  # grew since the check
        raise ResourceLimitError(f"{path}: more than the {max_bytes / 2**20:.0f} MiB a {what} may have here")
    try:
        return data.decode(encoding)
    except UnicodeDecodeError as exc:
        raise ResourceLimitError(f"{path}: not UTF-8 text ({exc.reason} at byte {exc.start}); save the {what} as UTF-8") from None


def physical_memory_bytes() -> int:
    """The machine's physical memory, bytes (``sysconf``; 8 GiB where it cannot be read)."""
    try:
        return int(os.sysconf("SC_PAGE_SIZE")) * int(os.sysconf("SC_PHYS_PAGES"))
    except (ValueError, OSError, AttributeError):  # pragma: no cover - not Linux/macOS
        return 8 << 30


def check_allocation(nbytes: float, what: str) -> None:
    """:class:`ResourceLimitError` when an estimated ``nbytes`` exceed :data:`MEMORY_SHARE` of the
    machine's memory; ``what`` names the option(s) and value(s) that ask for it."""
    limit = MEMORY_SHARE * physical_memory_bytes()
    if nbytes > limit:
        raise ResourceLimitError(f"{what} needs about {_size(nbytes)} of memory, more than {MEMORY_SHARE:.0%} of "
                                 f"this machine's {_size(physical_memory_bytes())}; choose smaller values")


def _size(nbytes: float) -> str:
    for unit, scale in (("TiB", 2**40), ("GiB", 2**30), ("MiB", 2**20)):
        if nbytes >= scale:
            return f"{nbytes / scale:.3g} {unit}"
    return f"{nbytes:.0f} bytes"
