"""Model and checkpoint files: one safe writer and one safe loader for every ``.pt`` of the project.

A file is a ``torch.save`` of a dict ``{"format": <kind>, "version": FORMAT_VERSION, ...}`` that
holds only tensors and plain data (numbers, strings, lists, tuples, dicts). It is read with
``torch.load(weights_only=True)``, which refuses anything else, so a crafted file cannot run code.
:func:`load_torch_file` turns every way a file can be wrong into one :class:`ModelFileError` that
names the file, says what is wrong (missing, a folder, empty, truncated or not a torch file,
unsafe content, another kind of file, a newer format version, missing entries) and what to do.
Files written before the format version existed (no ``"format"`` entry) are read as version 0
when they hold the expected entries.

:func:`save_torch_file` writes atomically under a unique temporary name (see
:func:`sspinn.run_folder.atomic_path`), so an interrupted or concurrent writer never leaves a
half-written file.
"""

from __future__ import annotations

import io
import pickle
import warnings
import zipfile
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any, Final

import torch

from sspinn.errors import UserError
from sspinn.run_folder import atomic_path

#: Version of the file layout written by this code; files with a larger version are refused.
FORMAT_VERSION: Final = 1
#: Kinds of file (the ``"format"`` entry).
MODEL: Final = "sspinn-model"
_ZIP_MAGIC: Final = b"PK\x03\x04"
CHECKPOINT: Final = "sspinn-checkpoint"


class ModelFileError(UserError):
    """A model or checkpoint file cannot be used; the message names it, the problem and the fix."""


def save_torch_file(path: str | Path, kind: str, payload: Mapping[str, Any]) -> Path:
    """Write ``payload`` (tensors and plain data only) as a ``kind`` file, atomically. The file is
    serialised in memory first: torch's writer reports a full disk as a RuntimeError, a plain
    write as the OSError that names the file."""
    path = Path(path)
    state = {"format": kind, "version": FORMAT_VERSION, **payload}
    buffer = io.BytesIO()
    torch.save(state, buffer)
    with atomic_path(path) as tmp:
        tmp.write_bytes(buffer.getbuffer())
    return path


def load_torch_file(
    path: str | Path,
    kinds: Iterable[str],
    required: Iterable[str],
    hint: str,
    map_location: str | torch.device = "cpu",
) -> dict[str, Any]:
    """The dict stored in ``path``, checked to be one of ``kinds`` with the ``required`` entries.

    Args:
        path: the file.
        kinds: accepted ``"format"`` values (the first is named in messages).
        required: entries the file must have.
        hint: what to do when the file is unusable, e.g. "train a model with `sspinn train`".
        map_location: where tensors go.

    Raises:
        ModelFileError: with the file, the problem and ``hint``.
    """
    path = Path(path)
    kinds = tuple(kinds)
    what = kinds[0].replace("sspinn-", "").replace("-", " ")

    def fail(problem: str) -> ModelFileError:
        return ModelFileError(f"{path}: {problem}; {hint}")

    if not path.exists():
        raise fail(f"no such file (expected a {what} file)")
    if path.is_dir():
        raise fail(f"is a folder, not a {what} file")
    if path.stat().st_size == 0:
        raise fail(f"the file is empty (an interrupted copy or write?), not a {what} file")
    with path.open("rb") as fh:
        magic = fh.read(4)
    if magic != _ZIP_MAGIC:
        raise fail(f"not a torch file (it starts with {magic!r}; torch files written by sspinn are zip archives)")
    if not zipfile.is_zipfile(path):
        raise fail("truncated (the end of the archive is missing: an interrupted write or copy?)")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            state = torch.load(path, map_location=map_location, weights_only=True)
    except pickle.UnpicklingError as exc:
        if "GLOBAL" in str(exc):
            raise fail(
                "holds Python objects other than tensors and plain data, which could run code when loaded; "
                "refusing to load it (only use files written by sspinn itself)"
            ) from None
        raise fail(f"not a readable torch file ({_last_line(exc)})") from None
    except (RuntimeError, EOFError, OSError, zipfile.BadZipFile, ValueError, KeyError, IndexError,
            AttributeError, TypeError, UnicodeDecodeError, MemoryError, OverflowError) as exc:
        raise fail(f"damaged or not a torch file ({_last_line(exc)})") from None
    if not isinstance(state, dict):
        raise fail(f"holds a {type(state).__name__}, not a {what} (a dict of weights and settings)")
    kind = state.get("format")
    version = state.get("version", 0)
    if kind is None and "version" not in state:  # written before files had a format entry
        kind, version = kinds[0], 0
    if kind not in kinds:
        raise fail(f"is a {kind!r} file, not one of {list(kinds)}")
    if not isinstance(version, int) or version > FORMAT_VERSION:
        raise fail(f"format version {version!r} is newer than this sspinn reads ({FORMAT_VERSION}): upgrade sspinn")
    missing = [k for k in required if k not in state]
    if missing:
        raise fail(f"lacks the entries {missing} of a {what} file (has {sorted(state)})")
    return state


def check_finite_weights(path: str | Path, weights: Mapping[str, torch.Tensor], hint: str) -> None:
    """Raise :class:`ModelFileError` if a weight tensor holds NaN or inf (a diverged or damaged
    model would write all-NaN estimates)."""
    for name, value in weights.items():
        if torch.is_tensor(value) and value.is_floating_point() and not bool(torch.isfinite(value).all()):
            bad = int((~torch.isfinite(value)).sum())
            raise ModelFileError(f"{path}: weight {name!r} has {bad} non-finite value(s); {hint}")


def _last_line(exc: BaseException) -> str:
    """The most specific line of a (torch) error message."""
    lines = [line.strip() for line in str(exc).splitlines() if line.strip() and not line.startswith("Check the documentation")]
    return lines[-1] if lines else type(exc).__name__

