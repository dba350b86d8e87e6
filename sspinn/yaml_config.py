"""Dataclass configurations from YAML files, with errors that name the file and the option.

Values are checked against the dataclass's field types before construction (an ``int`` option
given ``"abc"``, a ``float`` option given NaN, a ``bool`` given ``3``): :class:`ConfigError`
names the file, the option and the value. Numbers that YAML 1.1 reads as strings (``1e-3``) are
accepted for ``float`` options.
"""

from __future__ import annotations

import dataclasses
import math
import typing
from pathlib import Path
from typing import Any, TypeVar

import yaml

from sspinn.errors import UserError

T = TypeVar("T")


class ConfigError(UserError):
    """A configuration file or ``--set`` override is invalid; the message names the option."""


def read_section(path: str | Path, section: str, cls: type) -> dict[str, Any]:
    """The mapping under ``section`` of the YAML file (or the whole file without that key),
    rejecting options that are not fields of the dataclass ``cls``."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such configuration file")
    data = yaml.safe_load(path.read_text()) or {}
    if not isinstance(data, dict):
        raise ConfigError(f"{path}: expected a mapping of options, got {type(data).__name__}")
    data = data.get(section, data)
    known = {f.name for f in dataclasses.fields(cls)}
    unknown = set(data) - known
    if unknown:
        raise ConfigError(f"{path}: unknown {section} option(s) {sorted(unknown)}; known: {sorted(known)}")
    return dict(data)


def construct(cls: type[T], data: dict[str, Any], path: str | Path) -> T:
    """``cls(**data)``, with a constructor or validation error prefixed by the file's path."""
    data = check_types(cls, data, str(path))
    try:
        return cls(**data)
    except (TypeError, ValueError) as exc:
        raise ConfigError(f"{path}: {exc}") from None


def check_types(cls: type, data: dict[str, Any], where: str, prefix: str = "") -> dict[str, Any]:
    """``data`` with each value checked against the type of the dataclass field it sets
    (nested dataclasses given as mappings are checked recursively; numeric strings are turned
    into ``float`` for float fields). Raises :class:`ConfigError` naming the option and value."""
    try:
        hints = typing.get_type_hints(cls)
    except (NameError, TypeError):  # an annotation that cannot be resolved here: skip the checks
        return dict(data)
    out = dict(data)
    for name, value in data.items():
        kind = hints.get(name)
        option = f"{prefix}{name}"
        if dataclasses.is_dataclass(kind) and isinstance(value, dict):
            out[name] = check_types(kind, value, where, prefix=f"{option}.")  # type: ignore[arg-type]
        elif kind is bool and not isinstance(value, bool):
            raise ConfigError(f"{where}: option {option} must be true or false, got {value!r}")
        elif kind is int and (isinstance(value, bool) or not isinstance(value, int)):
            raise ConfigError(f"{where}: option {option} must be an integer, got {value!r}")
        elif kind is float:
            if isinstance(value, str):
                try:
                    value = float(value)
                except ValueError:
                    raise ConfigError(f"{where}: option {option} must be a number, got {value!r}") from None
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise ConfigError(f"{where}: option {option} must be a number, got {value!r}")
            if not math.isfinite(value):
                raise ConfigError(f"{where}: option {option} must be a finite number, got {value!r}")
            out[name] = float(value)
        elif kind is str and not isinstance(value, str):
            raise ConfigError(f"{where}: option {option} must be a string, got {value!r}")
    return out


def apply_setting(data: dict[str, Any], assignment: str, path: str | Path) -> None:
    """Apply one ``"a.b=value"`` override (YAML value) to a loaded mapping, in place; clear
    errors for a missing ``=`` or a key that is not a section."""
    key, sep, value = assignment.partition("=")
    if not sep or not key:
        raise ConfigError(f"--set {assignment!r}: expected key=value, e.g. weights.kane=0")
    *parents, leaf = key.strip().split(".")
    node = data
    for name in parents:
        node = node.setdefault(name, {})
        if not isinstance(node, dict):
            raise ConfigError(f"--set {assignment!r}: {name!r} of {path} is not a section")
    node[leaf] = yaml.safe_load(value)
