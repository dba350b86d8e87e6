"""Calibration files kept beside a model file: the quality score's (:mod:`sspinn.estimator.quality`)
and the intervals' (:mod:`sspinn.estimator.uncertainty`).

Both are JSON with a ``format`` name and a ``version``, hold the SHA-256 of the model file they
were fitted for, live at ``<model>.<kind>.json`` by default, and are written atomically; a
calibration that differs from the one already there replaces it only when asked.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

from sspinn.errors import UserError
from sspinn.run_folder import atomic_write_text

T = TypeVar("T")


def file_sha256(path: str | Path) -> str:
    """SHA-256 (hex) of a file's bytes."""
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            digest.update(chunk)
    return digest.hexdigest()


def beside(model_path: str | Path, kind: str) -> Path:
    """The default place of a model's ``kind`` calibration: ``<model>.<kind>.json``."""
    model_path = Path(model_path)
    return model_path.with_name(f"{model_path.stem}.{kind}.json")


def to_json(fields: dict[str, Any], fmt: str, version: int, indent: int, allow_nan: bool = True) -> str:
    """The file's text: ``format`` and ``version``, then ``fields``."""
    return json.dumps({"format": fmt, "version": version, **fields}, indent=indent, allow_nan=allow_nan)


def fields_of(text: str, fmt: str, version: int) -> dict[str, Any]:
    """The fields of a file's text (without ``format`` and ``version``); ValueError if it is not a
    ``fmt`` file of ``version``."""
    data = json.loads(text)
    if not isinstance(data, dict) or data.get("format") != fmt:
        raise ValueError(f"not a {fmt} file")
    if data.get("version") != version:
        raise ValueError(f"version {data.get('version')!r}, this sspinn reads {version}")
    return {k: v for k, v in data.items() if k not in ("format", "version")}


def load_for_model(path: str | Path, model_path: str | Path, parse: Callable[[str, str], T], sha256: Callable[[T], str],
                   error: type[Exception], what: str, command: str) -> T:
    """The ``what`` calibration at ``path`` (``parse(text, source)``); ``error`` if it cannot be
    read or belongs to another model file than ``model_path`` (``sha256`` of the calibration
    differs from the file's; recalibrate with ``command``)."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise error(f"{path}: cannot read the {what} calibration ({exc})") from None
    cal = parse(text, str(path))
    if sha256(cal) != file_sha256(model_path):
        raise error(f"{path}: calibrated for another model file than {model_path} (SHA-256 differs); "
                    f"recalibrate with `{command} --model {model_path} ...`")
    return cal


def save_new(text: str, target: str | Path, what: str, overwrite: bool) -> Path | None:
    """Write ``text`` (a calibration's JSON) to ``target`` atomically; None, writing nothing, when
    ``target`` already holds the same text (a rerun); :class:`UserError` when it holds another
    ``what`` calibration and ``overwrite`` is not set."""
    target = Path(target)
    if target.exists() and not overwrite:
        if target.read_text() == text + "\n":
            return None
        raise UserError(f"{target}: holds another {what} calibration; replace it with --overwrite")
    return atomic_write_text(target, text + "\n")
