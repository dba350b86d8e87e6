"""Dataclass configurations from YAML files, with errors that name the file and the option."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any, TypeVar

import yaml

T = TypeVar("T")


def read_section(path: str | Path, section: str, cls: type) -> dict[str, Any]:
    """The mapping under ``section`` of the YAML file (or the whole file without that key),
    rejecting options that are not fields of the dataclass ``cls``."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such configuration file")
    data = yaml.safe_load(path.read_text()) or {}
    if not isinstance(data, dict):
        raise ValueError(f"{path}: expected a mapping of options, got {type(data).__name__}")
    data = data.get(section, data)
    known = {f.name for f in dataclasses.fields(cls)}
    unknown = set(data) - known
    if unknown:
        raise ValueError(f"{path}: unknown {section} option(s) {sorted(unknown)}; known: {sorted(known)}")
    return dict(data)


def construct(cls: type[T], data: dict[str, Any], path: str | Path) -> T:
    """``cls(**data)``, with a constructor or validation error prefixed by the file's path."""
    try:
        return cls(**data)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{path}: {exc}") from None


def apply_setting(data: dict[str, Any], assignment: str, path: str | Path) -> None:
    """Apply one ``"a.b=value"`` override (YAML value) to a loaded mapping, in place; clear
    errors for a missing ``=`` or a key that is not a section."""
    key, sep, value = assignment.partition("=")
    if not sep or not key:
        raise ValueError(f"--set {assignment!r}: expected key=value, e.g. weights.kane=0")
    *parents, leaf = key.strip().split(".")
    node = data
    for name in parents:
        node = node.setdefault(name, {})
        if not isinstance(node, dict):
            raise ValueError(f"--set {assignment!r}: {name!r} of {path} is not a section")
    node[leaf] = yaml.safe_load(value)
