"""Where the optional public recordings live: the folder named by ``SSPINN_SHARED_DATA``.

Some comparisons use public recordings that sspinn does not ship (Winter's averaged normal
walking, OpenSim's example walking and running trials, the CSU inverse-dynamics trial, ...), each
in a sub-folder of one data folder. sspinn looks for that folder only where it is told: a
function's ``data_dir``/``directory`` argument (``--data-dir`` on the command lines) or else the
environment variable ``SSPINN_SHARED_DATA``. There is no default location; without either, a
comparison that needs the data is skipped with a note (or, where it is the whole job, stops with
a one-line error saying how to point to it).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Final

#: The environment variable naming the folder of the optional public recordings.
ENV_VAR: Final = "SSPINN_SHARED_DATA"


def shared_data_dir() -> Path | None:
    """The folder named by ``$SSPINN_SHARED_DATA``, or None when the variable is unset or empty."""
    value = os.environ.get(ENV_VAR, "").strip()
    return Path(value) if value else None


def shared_data_folder(name: str, data_dir: str | Path | None = None) -> Path:
    """``<data_dir>/<name>``, with ``data_dir`` defaulting to :func:`shared_data_dir`;
    :class:`FileNotFoundError` with a one-line message when neither is given or the folder is
    not there."""
    root = Path(data_dir) if data_dir is not None else shared_data_dir()
    if root is None:
        raise FileNotFoundError(
            f"{name}: no data folder given; pass the folder that holds {name}/ or set {ENV_VAR} to it"
        )
    folder = root / name
    if not folder.is_dir():
        raise FileNotFoundError(f"{folder}: not found (the folder holding {name}/ is optional public data, not shipped)")
    return folder
