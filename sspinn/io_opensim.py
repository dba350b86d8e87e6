"""Small, dependency-free readers for OpenSim files (storage tables ``.mot``/``.sto``).

An OpenSim storage file is a text file made of

* a free-form header (a title line and ``key=value`` lines such as ``nRows=151`` or
  ``inDegrees=yes``) that ends with a line reading ``endheader``,
* one line of column names (tab separated; the first is usually ``time``),
* one line of numbers per sample, separated by tabs or spaces.

Files written by some tools pad every line with trailing tabs; those are ignored. Values are
returned as they are stored: angles stay in degrees when the header says ``inDegrees=yes`` (see
:func:`read_opensim_header`), translations in m, forces in N, moments in N·m. Coordinate signs are
OpenSim's, which are also sspinn's (see :mod:`sspinn.conventions`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

__all__ = ["OpenSimFormatError", "read_opensim_header", "read_opensim_table"]


class OpenSimFormatError(ValueError):
    """Raised for a storage file that cannot be parsed; the message names the file and line."""


def _lines(path: Path) -> list[str]:
    try:
        return path.read_text(encoding="utf-8", errors="replace").splitlines()
    except FileNotFoundError:
        raise FileNotFoundError(f"OpenSim table not found: {path}") from None


def _endheader_index(path: Path, lines: list[str]) -> int:
    for i, line in enumerate(lines):
        if line.strip().lower() == "endheader":
            return i
    raise OpenSimFormatError(f"{path}: no 'endheader' line found; not an OpenSim storage (.mot/.sto) file")


def read_opensim_header(path: str | Path) -> dict[str, str]:
    """The ``key=value`` entries of the header of an OpenSim storage file.

    Keys and values are stripped strings, e.g. ``{"version": "1", "nRows": "151",
    "inDegrees": "yes"}``; header lines without ``=`` (the title) are skipped.

    Raises:
        FileNotFoundError: the file does not exist.
        OpenSimFormatError: there is no ``endheader`` line.
    """
    path = Path(path)
    lines = _lines(path)
    header: dict[str, str] = {}
    for line in lines[: _endheader_index(path, lines)]:
        if "=" in line:
            key, _, value = line.strip().partition("=")
            header[key.strip()] = value.strip()
    return header


def read_opensim_table(path: str | Path) -> tuple[list[str], np.ndarray]:
    """Read an OpenSim ``.mot``/``.sto`` table.

    Returns:
        ``(column_names, data)``: the names from the line after ``endheader`` (e.g. ``["time",
        "pelvis_tilt", ...]``) and a float64 array of shape (n_rows, n_columns) in the file's
        units (check :func:`read_opensim_header` for ``inDegrees``). ``nan`` entries are kept.

    Raises:
        FileNotFoundError: the file does not exist.
        OpenSimFormatError: no ``endheader`` line, no column-name line, duplicate column names, a
            row with the wrong number of fields or a non-numeric field, or no data rows. The
            message names the file and the (1-based) line.
    """
    path = Path(path)
    lines = _lines(path)
    i = _endheader_index(path, lines) + 1
    while i < len(lines) and not lines[i].strip():
        i += 1
    if i >= len(lines):
        raise OpenSimFormatError(f"{path}: no column-name line after 'endheader'")
    names_line = lines[i].strip()
    names = [n.strip() for n in (names_line.split("\t") if "\t" in names_line else names_line.split())]
    names = [n for n in names if n]
    duplicates = sorted({n for n in names if names.count(n) > 1})
    if duplicates:
        raise OpenSimFormatError(f"{path}, line {i + 1}: duplicate column name(s) {duplicates}")
    rows: list[list[float]] = []
    for lineno, line in enumerate(lines[i + 1 :], start=i + 2):
        fields = line.split()
        if not fields:
            continue
        if len(fields) != len(names):
            raise OpenSimFormatError(
                f"{path}, line {lineno}: expected {len(names)} values (one per column), got {len(fields)}"
            )
        try:
            rows.append([float(f) for f in fields])
        except ValueError:
            bad = next(f for f in fields if not _is_float(f))
            raise OpenSimFormatError(f"{path}, line {lineno}: non-numeric value {bad!r}") from None
    if not rows:
        raise OpenSimFormatError(f"{path}: no data rows after the column names")
    return names, np.asarray(rows, dtype=np.float64)


def _is_float(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True
