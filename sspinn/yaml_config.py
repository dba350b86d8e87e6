"""The one loader of the project's configurations: YAML (or plain data) → nested dataclasses.

Every configuration (``TrainConfig``, ``AgentConfig``, ``WalkerConfig``, body parameters, the IMU
error model, ...) is a dataclass and is read by :func:`load_config` (a file) or
:func:`config_from_mapping` (parsed data). Construction goes through ``dacite``; this module adds
what the project needs on top of it:

* **Unknown keys** are errors at every nesting level; the message names the file, the dotted
  option (``network.hiden``) and lists the known ones.
* **Types** are checked against the field annotations (nested dataclasses, ``Optional``, unions,
  ``list``/``tuple``/``Mapping`` items): an ``int`` given ``"abc"``, a ``float`` given NaN or inf,
  a ``bool`` given ``3`` give one line naming the file, the option and the value. ``float``
  fields accept ints and numeric strings and are stored as ``float``; lists given for ``tuple``
  fields become tuples. A ``null`` section (``env:`` with nothing under it) means its defaults.
* **YAML numbers**: ``3e-4`` is a float (YAML 1.1 reads it as a string) in files, ``--set``
  values and command-line flags alike.
* **Field options** (:func:`option`): ``choices`` and ranges (``ge``, ``gt``, ``le``) checked after
  construction, and a ``help`` text (else the class docstring's ``Attributes:`` entry) that
  :func:`add_config_flags` turns into command-line flags, so that flags mirroring config fields
  are not written by hand.
* **Overrides**: ``overrides`` (``{"steps": 5, "env.n_envs": 2}``) and ``--set a.b=value`` strings
  (:func:`apply_setting`) change the loaded data before construction; ``base`` (an existing
  instance) fills what the data leaves out (partial sections are merged field by field).
* **Variants**: a file whose top level has ``extends: other.yaml`` is that file with its own keys
  merged in (:func:`read_config_file`), so a variant names only what it changes.

Errors are :class:`ConfigError` (a :class:`sspinn.errors.UserError`, hence a ``ValueError``); a
loader with its own error type passes ``error=``. A missing file raises
:class:`MissingConfigFileError` (also a ``FileNotFoundError``).

The configurations shipped with the project (``configs/``) are found by :func:`shipped_path`
from the installed package, not the working directory, so that a default ``--config`` works
from any folder.
"""

from __future__ import annotations

import argparse
import dataclasses
import functools
import inspect
import io
import math
import re
import types
import typing
from collections.abc import Collection, Hashable, Iterable, Mapping
from pathlib import Path
from typing import Any, Final, TypeVar

import dacite
import yaml

from sspinn.errors import UserError, one_line
from sspinn.resource_limits import MAX_CONFIG_BYTES, SIZE_LIMITS, ResourceLimitError, read_input_text

T = TypeVar("T")

#: Key of a field's ``metadata`` under which :func:`option` stores help, choices and ranges.
METADATA_KEY = "sspinn"
#: Prefix of the ``dest`` of the flags made by :func:`add_config_flags` (see :func:`flag_overrides`).
FLAG_DEST_PREFIX = "config:"
#: The repository (or source tree) the ``sspinn`` package lives in: the parent of its folder.
REPOSITORY_ROOT = Path(__file__).resolve().parents[1]


def shipped_path(relative: str | Path) -> Path:
    """A file shipped with the project, e.g. ``shipped_path("configs/synth/default.yaml")``: the
    path below :data:`REPOSITORY_ROOT` (whatever the working directory is)."""
    return REPOSITORY_ROOT / relative


class ConfigError(UserError):
    """A configuration file, mapping, ``--set`` override or flag is invalid; the message names
    the source (file), the option and the value."""


class MissingConfigFileError(ConfigError, FileNotFoundError):
    """The configuration file does not exist."""


# --------------------------------------------------------------------------------------------
# YAML
# --------------------------------------------------------------------------------------------
class _Loader(yaml.SafeLoader):
    """SafeLoader that also reads ``3e-4`` as a float (YAML 1.1 insists on ``3.0e-4``)."""


_Loader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:[0-9][0-9_]*)(?:\.[0-9_]*)?[eE][-+]?[0-9]+$"),
    list("-+0123456789"),
)


def _mapping_without_duplicates(loader: _Loader, node: yaml.MappingNode, deep: bool = False) -> dict[Any, Any]:
    """A YAML mapping; a key given twice is an error naming it and its line (PyYAML keeps the
    last silently). Keys merged in with ``<<`` may be overridden, as YAML intends."""
    seen: set[Any] = set()
    for key_node, _ in node.value:
        if key_node.tag == "tag:yaml.org,2002:merge":
            continue
        key = loader.construct_object(key_node, deep=True)
        if isinstance(key, Hashable):
            if key in seen:
                raise yaml.constructor.ConstructorError(None, None, f"duplicate key {key!r}", key_node.start_mark)
            seen.add(key)
    return loader.construct_mapping(node, deep=deep)


_Loader.add_constructor("tag:yaml.org,2002:map", _mapping_without_duplicates)

#: Deepest nesting of lists and mappings a configuration may have (the shipped ones use 4).
MAX_NESTING: Final = 50


def _depth(value: Any, limit: int) -> int:
    """The nesting depth of plain data, counted up to ``limit + 1``."""
    if limit < 0 or not isinstance(value, (Mapping, list, tuple)):
        return 0
    items = value.values() if isinstance(value, Mapping) else value
    return 1 + max((_depth(v, limit - 1) for v in items), default=0)


def parse_yaml(text: str, source: str = "YAML text") -> Any:
    """``text`` parsed as YAML (safe, with ``3e-4`` read as a float; a duplicate key, or lists
    and mappings nested more than :data:`MAX_NESTING` deep, are a :class:`ConfigError` naming
    ``source``)."""
    stream = io.StringIO(text)
    stream.name = source  # PyYAML names the stream in its marks ("in <source>, line 3")
    try:
        data = yaml.load(stream, Loader=_Loader)  # noqa: S506 (a SafeLoader subclass)
    except RecursionError:
        raise ConfigError(f"{source}: lists or mappings nested too deeply (at most {MAX_NESTING} levels)") from None
    if _depth(data, MAX_NESTING) > MAX_NESTING:
        raise ConfigError(f"{source}: lists or mappings nested more than {MAX_NESTING} levels deep")
    return data


def read_yaml(path: str | Path, section: str | None = None) -> Any:
    """The parsed YAML file; with ``section``, the value under that top-level key when the file
    has it (else the whole file). An empty file is ``None``. A path that is no regular file (a
    folder, ``/dev/zero``, a FIFO), a file over :data:`~sspinn.resource_limits.MAX_CONFIG_BYTES`
    or not UTF-8 is a :class:`ConfigError` naming it."""
    path = Path(path)
    if not path.exists():
        raise MissingConfigFileError(f"{path}: no such configuration file")
    try:
        data = parse_yaml(read_input_text(path, MAX_CONFIG_BYTES, "configuration file"), str(path))
    except ResourceLimitError as exc:
        raise ConfigError(str(exc)) from None
    except yaml.YAMLError as exc:
        raise ConfigError(f"{path}: not valid YAML: {one_line(exc)}") from None
    if section is not None and isinstance(data, Mapping) and section in data:
        data = data[section]
    return data


#: Top-level key of a configuration file naming the file it changes (see :func:`read_config_file`).
EXTENDS_KEY = "extends"


def read_config_file(path: str | Path, error: type[Exception] = ConfigError, _chain: tuple[Path, ...] = ()) -> Any:
    """The parsed YAML file with its ``extends:`` chain resolved: a file whose top level has
    ``extends: other.yaml`` (a path relative to the file's folder) is ``other.yaml`` with this
    file's keys merged in, mappings key by key and every other value (lists included) replaced.
    A variant of a configuration thus names only what it changes."""
    path = Path(path)
    data = read_yaml(path)
    if not isinstance(data, Mapping) or EXTENDS_KEY not in data:
        return data
    parent = data[EXTENDS_KEY]
    if not isinstance(parent, str) or not parent:
        raise error(f"{path}: {EXTENDS_KEY} must be the path of another configuration file, got {parent!r}")
    parent_path = (path.parent / parent).resolve()
    chain = (*_chain, path.resolve())
    if parent_path in chain:
        raise error(f"{path}: {EXTENDS_KEY}: {parent} closes a loop ({' → '.join(p.name for p in (*chain, parent_path))})")
    try:
        base = read_config_file(parent_path, error, chain)
    except MissingConfigFileError as exc:  # name the file that extends the missing one
        raise MissingConfigFileError(f"{path}: {EXTENDS_KEY}: {exc}") from None
    if not isinstance(base, Mapping):
        raise error(f"{path}: {EXTENDS_KEY}: {parent_path} is not a mapping of options")
    return _merged(base, {k: v for k, v in data.items() if k != EXTENDS_KEY})


def _merged(base: Mapping[str, Any], changes: Mapping[str, Any]) -> dict[str, Any]:
    """``base`` with ``changes`` merged in: mappings key by key, anything else replaced."""
    out = dict(base)
    for key, value in changes.items():
        old = out.get(key)
        out[key] = _merged(old, value) if isinstance(old, Mapping) and isinstance(value, Mapping) else value
    return out


def _read_mapping(path: str | Path, section: str | None, error: type[Exception] = ConfigError) -> dict[str, Any]:
    """:func:`read_config_file` (its ``section`` when the file has that top-level key), which
    must be a mapping (an empty section: ``{}``). An empty file is an error: it is more often a
    failed write or the wrong file than a wish for every default (``{}`` says that)."""
    data = read_config_file(path, error)
    if data is None:
        raise error(f"{path}: the configuration file is empty; write {{}} to take every default")
    if section is not None and isinstance(data, Mapping) and section in data:
        data = data[section]
    data = {} if data is None else data
    if not isinstance(data, Mapping):
        raise error(f"{path}: expected a mapping of options, got {type(data).__name__}")
    return dict(data)


# --------------------------------------------------------------------------------------------
# Field options
# --------------------------------------------------------------------------------------------
def option(
    default: Any = dataclasses.MISSING,
    *,
    default_factory: Any = dataclasses.MISSING,
    help: str | None = None,  # noqa: A002 (argparse's name)
    choices: Iterable[Any] | None = None,
    ge: float | None = None,
    gt: float | None = None,
    le: float | None = None,
    unit: str | None = None,
) -> Any:
    """A dataclass field with loader options: ``choices`` (allowed values), ``ge``/``gt``/``le``
    (range; None values of an ``Optional`` field are not checked), ``unit`` (for messages) and
    ``help`` (for :func:`add_config_flags`; default: the class docstring's ``Attributes:`` entry)."""
    spec = {"help": help, "choices": None if choices is None else tuple(choices), "ge": ge, "gt": gt, "le": le,
            "unit": unit}
    metadata = {METADATA_KEY: {k: v for k, v in spec.items() if v is not None}}
    return dataclasses.field(default=default, default_factory=default_factory, metadata=metadata)


def _spec(f: dataclasses.Field) -> dict[str, Any]:
    return dict(f.metadata.get(METADATA_KEY, {}))


@functools.cache
def _hints(cls: type) -> dict[str, Any]:
    return typing.get_type_hints(cls)


def _fields(cls: type) -> list[dataclasses.Field]:
    return [f for f in dataclasses.fields(cls) if f.init]


def _members(hint: Any) -> tuple[Any, ...]:
    """The members of a union (``X | None`` → (X, NoneType)); ``(hint,)`` for anything else."""
    if typing.get_origin(hint) in (typing.Union, types.UnionType):
        return typing.get_args(hint)
    return (hint,)


def _section(hint: Any) -> type | None:
    """The dataclass of a section field (``X`` or ``X | None`` with ``X`` a dataclass), else None."""
    members = [m for m in _members(hint) if m is not type(None)]
    if len(members) == 1 and dataclasses.is_dataclass(members[0]) and isinstance(members[0], type):
        return members[0]
    return None


def _is_container(hint: Any) -> bool:
    origin = typing.get_origin(hint) or hint
    return isinstance(origin, type) and issubclass(origin, Collection) and origin is not str


def _is_mapping(hint: Any) -> bool:
    origin = typing.get_origin(hint) or hint
    return isinstance(origin, type) and issubclass(origin, Mapping)


# --------------------------------------------------------------------------------------------
# Values: hooks (run by dacite before its type check) and messages
# --------------------------------------------------------------------------------------------
class _BadValue(dacite.DaciteFieldError):
    """A value that passes ``isinstance`` but is not accepted (a bool for an int, NaN)."""

    def __init__(self, expected: str, value: Any, field_path: str | None = None) -> None:
        super().__init__(field_path)
        self.expected, self.value = expected, value


def _int_hook(value: Any) -> Any:
    if isinstance(value, bool):
        raise _BadValue("an integer", value)
    return value


def _float_hook(value: Any) -> Any:
    if isinstance(value, str):  # "1e-3" from a YAML 1.1 reader, "nan"
        try:
            value = float(value)
        except ValueError:
            raise _BadValue("a number", value) from None
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise _BadValue("a number", value)
    if not math.isfinite(value):
        raise _BadValue("a finite number", value)
    return float(value)


_HOOKS: dict[type, Any] = {int: _int_hook, float: _float_hook}
_DACITE = dacite.Config(type_hooks=_HOOKS, cast=[tuple], check_types=True)

_NOUNS = {bool: ("true or false", "true/false values"), int: ("an integer", "integers"), float: ("a number", "numbers"),
          str: ("a string", "strings")}


def _expected(hint: Any) -> str:
    """What a value of type ``hint`` is, in words (``"null or a number"``)."""
    members = _members(hint)
    if len(members) > 1:
        words = [_expected(m) for m in members if m is not type(None)]
        return ("null or " if type(None) in members else "") + " or ".join(words)
    if hint in _NOUNS:
        return _NOUNS[hint][0]
    if dataclasses.is_dataclass(hint):
        return "a mapping of options"
    origin, args = typing.get_origin(hint) or hint, typing.get_args(hint)
    if _is_mapping(hint):
        if len(args) == 2 and args[0] in _NOUNS and args[1] in _NOUNS:
            return f"a mapping of {_NOUNS[args[0]][1]} to {_NOUNS[args[1]][1]}"
        return "a mapping"
    if _is_container(hint):
        if origin is tuple and args and args[-1] is not Ellipsis:
            return f"a list of {len(args)} {_NOUNS.get(args[0], ('', 'values'))[1]}"
        return f"a list of {_NOUNS.get(args[0] if args else Any, ('', 'values'))[1]}"
    return getattr(hint, "__name__", str(hint))


def _join(prefix: str, name: str) -> str:
    return f"{prefix}.{name}" if prefix else name


def _type_message(cls: type, exc: dacite.DaciteFieldError, source: str, prefix: str) -> str:
    path = _join(prefix, exc.field_path or "")
    if isinstance(exc, _BadValue):
        return f"{source}: option {path} must be {exc.expected}, got {exc.value!r}"
    if isinstance(exc, dacite.MissingValueError):
        choices = _spec(_field_at(cls, exc.field_path)[1]).get("choices")
        return f"{source}: '{path}' is required" + (f" (one of {', '.join(map(str, choices))})" if choices else "")
    if isinstance(exc, dacite.WrongTypeError):
        if _section(exc.field_type) is not None and not isinstance(exc.value, Mapping):
            return f"{source}: section '{path}' must be {_expected(exc.field_type)}, got {exc.value!r}"
        return f"{source}: option {path} must be {_expected(exc.field_type)}, got {exc.value!r}"
    return f"{source}: option {path}: {exc}"


# --------------------------------------------------------------------------------------------
# Loading
# --------------------------------------------------------------------------------------------
def check_keys(
    cls: type,
    data: Mapping[str, Any],
    source: str,
    *,
    what: str = "option",
    prefix: str = "",
    other_keys: Collection[str] = (),
    error: type[Exception] = ConfigError,
) -> None:
    """Raise ``error`` for a key of ``data`` (or of a nested section) that is not a field of the
    dataclass ``cls``; ``other_keys`` are accepted too at the top level."""
    known = [f.name for f in _fields(cls)] + list(other_keys)
    unknown = sorted(set(data) - set(known), key=str)
    if unknown:
        raise error(
            f"{source}: unknown {what}(s) {[_join(prefix, str(k)) for k in unknown]}; "
            f"known: {sorted(_join(prefix, k) for k in known)}"
        )
    hints = _hints(cls)
    for f in _fields(cls):
        sub = _section(hints[f.name])
        if sub is not None and isinstance(data.get(f.name), Mapping):
            check_keys(sub, data[f.name], source, what=what, prefix=_join(prefix, f.name), error=error)


def _prepare(cls: type, data: Mapping[str, Any], base: Any) -> dict[str, Any]:
    """The constructor data: ``null`` sections dropped (→ defaults), missing fields taken from
    ``base`` (a partial section merged with ``base``'s section); a list field given a string or
    a mapping field given a non-mapping is an error (dacite would split the string)."""
    hints = _hints(cls)
    out: dict[str, Any] = {}
    for f in _fields(cls):
        hint, present = hints[f.name], f.name in data
        value = data.get(f.name)
        nullable = type(None) in _members(hint) or hint is Any
        if present and value is None and not nullable and (_section(hint) is not None or _is_container(hint)):
            present = False  # `env:` with nothing under it: the defaults
        sub = _section(hint)
        base_value = getattr(base, f.name) if base is not None else None
        if present and sub is not None and isinstance(value, Mapping):
            try:
                out[f.name] = _prepare(sub, value, base_value if isinstance(base_value, sub) else None)
            except dacite.DaciteFieldError as exc:
                exc.update_path(f.name)
                raise
        elif present:
            if _is_container(hint) and not isinstance(value, Mapping if _is_mapping(hint) else (list, tuple)):
                raise _BadValue(_expected(hint), value, field_path=f.name)
            out[f.name] = value
        elif base is not None:
            out[f.name] = base_value
    return out


def config_from_mapping(
    cls: type[T],
    data: Any,
    source: str = "<mapping>",
    *,
    what: str = "option",
    prefix: str = "",
    base: T | None = None,
    other_keys: Collection[str] = (),
    error: type[Exception] = ConfigError,
) -> T:
    """The dataclass ``cls`` built from plain data (parsed YAML): unknown keys, types, choices
    and ranges checked (see the module docstring); constructor errors (``__post_init__``)
    prefixed by ``source``.

    Args:
        cls: the configuration's dataclass.
        data: a mapping of its fields (partial: missing fields take their defaults or ``base``'s).
        source: where the data comes from, for messages (the file's path).
        what: the word for a key in messages ("option", "body parameter").
        prefix: dotted path of ``data`` inside a larger configuration, for messages ("env.kwargs").
        base: an instance of ``cls`` that supplies the fields ``data`` leaves out.
        other_keys: further top-level keys accepted (and left out of the construction).
        error: the exception class raised.
    """
    if not isinstance(data, Mapping):
        where = f" for {prefix}" if prefix else ""
        raise error(f"{source}: expected a mapping of {what}s{where}, got {type(data).__name__}")
    check_keys(cls, data, source, what=what, prefix=prefix, other_keys=other_keys, error=error)
    try:
        prepared = _prepare(cls, {k: v for k, v in data.items() if k not in other_keys}, base)
        config = dacite.from_dict(cls, prepared, _DACITE)
    except dacite.DaciteFieldError as exc:
        raise error(_type_message(cls, exc, source, prefix)) from None
    except (TypeError, ValueError) as exc:  # the dataclass's own validation
        raise error(f"{source}: {prefix + ': ' if prefix else ''}{one_line(exc)}") from None
    check_options(config, source, prefix=prefix, error=error)
    if not prefix:
        check_batch_memory(config, source, error)
    return config


def load_config(
    cls: type[T],
    path: str | Path,
    section: str | None = None,
    overrides: Mapping[str, Any] | None = None,
    settings: Iterable[str] = (),
    *,
    what: str | None = None,
    error: type[Exception] = ConfigError,
) -> T:
    """The dataclass ``cls`` from the YAML file ``path`` (its ``section`` when the file has that
    top-level key), with ``overrides`` (dotted keys → values; None = keep the file's) and then
    ``settings`` (``"a.b=value"`` strings, YAML values) applied first. ``what`` names a key in
    messages (default ``"<section> option"``)."""
    data = _read_mapping(path, section, error)
    for key, value in (overrides or {}).items():
        if value is not None:
            set_option(data, key, value, path)
    for assignment in settings:
        apply_setting(data, assignment, path)
    what = what or (f"{section} option" if section else "option")
    return config_from_mapping(cls, data, str(path), what=what, error=error)


def check_options(config: Any, source: str, *, prefix: str = "", error: type[Exception] = ConfigError) -> None:
    """Check the ``choices`` and ranges of :func:`option` fields of ``config`` and of its sections."""
    hints = _hints(type(config))
    for f in _fields(type(config)):
        value, path = getattr(config, f.name), _join(prefix, f.name)
        if _section(hints[f.name]) is not None and dataclasses.is_dataclass(value):
            check_options(value, source, prefix=path, error=error)
        spec = _implied_spec(f, value, prefix)
        if value is not None and not _allowed(value, spec):
            raise error(f"{source}: option {path} must be {describe(hints[f.name], spec)}, got {value!r}")


def check_batch_memory(config: Any, source: str, error: type[Exception] = ConfigError) -> None:
    """Refuse a configuration whose ``batch_size × window`` samples per training step need more
    than half the machine's memory (:data:`sspinn.resource_limits.BYTES_PER_TRAINING_SAMPLE`)."""
    from sspinn.resource_limits import BYTES_PER_TRAINING_SAMPLE, check_allocation

    batch, window = getattr(config, "batch_size", None), getattr(config, "window", None)
    if isinstance(batch, int) and isinstance(window, int):
        try:
            check_allocation(batch * window * BYTES_PER_TRAINING_SAMPLE,
                             f"batch_size {batch} × window {window} (samples per training step)")
        except ResourceLimitError as exc:
            raise error(f"{source}: {exc}") from None


def _implied_spec(f: dataclasses.Field, value: Any, prefix: str) -> dict[str, Any]:
    """The :func:`option` spec of ``f`` plus the ranges every configuration gets by convention:
    an upper bound for a size-like integer field the class bounds not
    (:data:`sspinn.resource_limits.SIZE_LIMITS`), a learning rate ``lr`` in (0, 1], and ``>= 0`` for a number in a section named
    ``weights`` (loss or cost weights: a negative one rewards the error it should punish)."""
    spec = _spec(f)
    if "choices" in spec:
        return spec
    if f.name in SIZE_LIMITS and isinstance(value, int) and not isinstance(value, bool):
        spec.setdefault("le", SIZE_LIMITS[f.name])
    if f.name == "lr" and isinstance(value, (int, float)) and not isinstance(value, bool):  # Adam's step size
        spec.setdefault("gt", 0)
        spec.setdefault("le", 1.0)
    if prefix.rsplit(".", 1)[-1] == "weights" and isinstance(value, (int, float)) and not isinstance(value, bool):
        spec.setdefault("ge", 0)
    return spec


def _allowed(value: Any, spec: Mapping[str, Any]) -> bool:
    """Whether ``value`` is among the ``choices`` and within the range of an :func:`option` spec."""
    if spec.get("choices"):
        return value in spec["choices"]
    return (("ge" not in spec or value >= spec["ge"]) and ("gt" not in spec or value > spec["gt"])
            and ("le" not in spec or value <= spec["le"]))


def describe(hint: Any, spec: Mapping[str, Any]) -> str:
    """The allowed values of a field in words (``"null or a number in [0, 12] m/s"``)."""
    if spec.get("choices"):
        return "one of " + ", ".join(str(c) for c in spec["choices"])
    members = _members(hint)
    kind = _expected(next(m for m in members if m is not type(None)))
    if "ge" in spec and "le" in spec:
        bounds = f"in [{spec['ge']:g}, {spec['le']:g}]"
    else:
        bounds = " and ".join(f"{op} {spec[key]:g}" for key, op in (("ge", ">="), ("gt", ">"), ("le", "<=")) if key in spec)
    unit = f" {spec['unit']}" if spec.get("unit") else ""
    return f"{'null or ' if type(None) in members else ''}{kind} {bounds}{unit}"


# --------------------------------------------------------------------------------------------
# Overrides
# --------------------------------------------------------------------------------------------
def set_option(data: dict[str, Any], key: str, value: Any, path: str | Path, what: str | None = None) -> None:
    """Set the dotted ``key`` of a loaded mapping to ``value``, in place (sections created)."""
    *parents, leaf = key.strip().split(".")
    node = data
    for name in parents:
        child = node.get(name)
        if child is None:
            child = node[name] = {}
        elif not isinstance(child, dict):
            raise ConfigError(f"{what or key}: {name!r} of {path} is not a section")
        else:
            child = node[name] = dict(child)  # copy: the caller's nested data stays as it was
        node = child
    node[leaf] = value


def apply_setting(data: dict[str, Any], assignment: str, path: str | Path) -> None:
    """Apply one ``"a.b=value"`` override (YAML value) to a loaded mapping, in place; clear
    errors for a missing ``=`` or a key that is not a section."""
    key, sep, value = assignment.partition("=")
    if not sep or not key:
        raise ConfigError(f"--set {assignment!r}: expected key=value, e.g. weights.kane=0")
    try:
        parsed = parse_yaml(value, f"{path}: --set {assignment}")
    except yaml.YAMLError as exc:
        raise ConfigError(f"--set {assignment!r}: not a YAML value: {one_line(exc)}") from None
    set_option(data, key, parsed, path, what=f"--set {assignment!r}")


# --------------------------------------------------------------------------------------------
# Command-line flags that mirror config fields
# --------------------------------------------------------------------------------------------
@functools.cache
def docstring_attributes(cls: type) -> dict[str, str]:
    """``name → text`` of the ``Attributes:`` section of a (Google-style) class docstring."""
    lines = (inspect.getdoc(cls) or "").splitlines()
    out: dict[str, str] = {}
    inside, indent, name = False, None, None
    for line in lines:
        if line.strip() == "Attributes:":
            inside, indent, name = True, None, None
            continue
        if not inside:
            continue
        if line.strip() and not line.startswith(" "):  # the next section
            break
        stripped = line.strip()
        level = len(line) - len(line.lstrip())
        indent = level if indent is None and stripped else indent
        match = re.match(r"^(\w+)(?: \([^)]*\))?: (.*)$", stripped)
        if match and level == indent:
            name = match.group(1)
            out[name] = match.group(2)
        elif name and stripped:
            out[name] += " " + stripped
    return out


def field_help(cls: type, name: str) -> str:
    """The help text of a field: its :func:`option` ``help``, else its docstring entry (plain text)."""
    spec = _spec(next(f for f in dataclasses.fields(cls) if f.name == name))
    text = spec.get("help") or docstring_attributes(cls).get(name, "").rstrip(".")
    return re.sub(r":\w+:`~?([^`]+)`", r"\1", text).replace("``", "")


def _field_at(cls: type, path: str) -> tuple[type, dataclasses.Field, Any]:
    """(owning dataclass, field, type) of the dotted ``path`` in ``cls``."""
    owner, names = cls, path.split(".")
    for i, name in enumerate(names):
        f = next((f for f in _fields(owner) if f.name == name), None)
        if f is None:
            raise KeyError(f"{cls.__name__} has no field {path!r}")
        hint = _hints(owner)[name]
        if i == len(names) - 1:
            return owner, f, hint
        owner = _section(hint)
        if owner is None:
            raise KeyError(f"{cls.__name__}: {'.'.join(names[: i + 1])} is not a section")
    raise KeyError(path)


def _flag_type(kind: type, spec: Mapping[str, Any]) -> Any:
    """An argparse ``type`` for a field of type ``kind``: the text read as YAML and checked like
    a configuration value (type, finiteness, range)."""
    if kind is str:
        return str

    def parse(text: str) -> Any:
        try:
            value = _HOOKS.get(kind, lambda v: v)(parse_yaml(text))
        except (_BadValue, yaml.YAMLError) as exc:
            raise argparse.ArgumentTypeError(f"must be {getattr(exc, 'expected', _expected(kind))}, got {text!r}") from None
        if isinstance(value, bool) != (kind is bool) or not isinstance(value, kind):
            raise argparse.ArgumentTypeError(f"must be {_expected(kind)}, got {text!r}")
        if not _allowed(value, spec):
            raise argparse.ArgumentTypeError(f"must be {describe(kind, spec)}, got {text!r}")
        return value

    parse.__name__ = kind.__name__
    return parse


def add_config_flags(
    parser: argparse.ArgumentParser,
    cls: type,
    fields: Iterable[str],
    *,
    flags: Mapping[str, str] | None = None,
    helps: Mapping[str, str] | None = None,
) -> None:
    """Add one flag per (dotted) config field of ``cls``: ``--name-with-dashes`` (or
    ``flags[field]``), typed and checked like the field (bool → a switch), with its choices, and
    its help text (:func:`field_help`, or ``helps[field]``). Not given, a flag is None; read the
    given ones with :func:`flag_overrides`."""
    flags, helps = dict(flags or {}), dict(helps or {})
    for path in fields:
        owner, f, hint = _field_at(cls, path)
        kinds = [m for m in _members(hint) if m is not type(None)]
        if len(kinds) != 1 or kinds[0] not in _NOUNS:
            raise TypeError(f"{cls.__name__}.{path}: only bool, int, float and str fields become flags, not {hint}")
        kind = kinds[0]
        spec = _implied_spec(f, kind() if kind in (int, float) else None, path.rpartition(".")[0])
        name = flags.get(path, "--" + f.name.replace("_", "-"))
        text = (helps.get(path) or field_help(owner, f.name)).replace("%", "%%")
        kwargs: dict[str, Any] = {"dest": FLAG_DEST_PREFIX + path, "default": None, "help": text or None}
        if kind is bool:
            parser.add_argument(name, action="store_true", **kwargs)
            continue
        if spec.get("choices"):
            kwargs["choices"] = spec["choices"]
        else:
            kwargs["metavar"] = name.lstrip("-").replace("-", "_").upper()
        parser.add_argument(name, type=_flag_type(kind, spec), **kwargs)


def flag_overrides(args: argparse.Namespace) -> dict[str, Any]:
    """The flags of :func:`add_config_flags` that were given: dotted field → value (for
    ``overrides`` of :func:`load_config`)."""
    n = len(FLAG_DEST_PREFIX)
    return {k[n:]: v for k, v in vars(args).items() if k.startswith(FLAG_DEST_PREFIX) and v is not None}
