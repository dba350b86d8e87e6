"""The one configuration loader (sspinn.yaml_config): unknown keys at every level, YAML 1.1
numbers, tuples, types, ranges, overrides and --set, and the command-line flags made from the
dataclasses."""

from __future__ import annotations

import argparse
import dataclasses
import typing
from dataclasses import dataclass, field
from pathlib import Path

import pytest

from sspinn.errors import ArgumentParser, UserError
from sspinn.yaml_config import (
    ConfigError,
    MissingConfigFileError,
    add_config_flags,
    apply_setting,
    config_from_mapping,
    flag_overrides,
    load_config,
    option,
)


@dataclass(frozen=True)
class Inner:
    """A section.

    Attributes:
        size: layer size.
        span: (low, high), m.
    """

    size: int = 4
    span: tuple[float, float] = (0.0, 1.0)
    rate: float | None = None


@dataclass(frozen=True)
class Outer:
    """A configuration.

    Attributes:
        kind: what to run.
        steps: optimiser steps, more than 0.
        lr: learning rate.
        verbose: print progress.
        time_limit_s: stop after this
            many seconds.
    """

    kind: str = option(choices=("a", "b"))
    steps: int = option(10, gt=0)
    lr: float = 1e-3
    verbose: bool = False
    speed: float | None = option(None, ge=0, le=12, unit="m/s")
    time_limit_s: float = 0.0
    names: tuple[str, ...] = ()
    tags: dict[str, int] = field(default_factory=dict)
    inner: Inner = field(default_factory=Inner)


def _yaml(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "run.yaml"
    path.write_text(text)
    return path


def _error(tmp_path: Path, text: str, **kwargs) -> str:
    with pytest.raises(ConfigError) as info:
        load_config(Outer, _yaml(tmp_path, text), **kwargs)
    message = str(info.value)
    assert "\n" not in message and isinstance(info.value, UserError)
    return message


def test_a_nested_file_loads_with_scientific_notation_and_tuples(tmp_path: Path) -> None:
    path = _yaml(tmp_path, "run:\n  kind: b\n  lr: 3e-4\n  names: [x, y]\n  inner: {span: [1, 2], rate: 1e-3}\n")
    config = load_config(Outer, path, section="run")
    assert config.lr == pytest.approx(3e-4) and isinstance(config.lr, float)  # YAML 1.1 reads 3e-4 as a string
    assert config.names == ("x", "y") and config.inner.span == (1.0, 2.0) and isinstance(config.inner.span[0], float)
    assert config.inner.rate == pytest.approx(1e-3) and config.inner.size == 4
    assert load_config(Outer, _yaml(tmp_path, "kind: a\ninner:\n")).inner == Inner()  # an empty section: defaults


def test_unknown_keys_are_named_with_their_dotted_path_at_every_level(tmp_path: Path) -> None:
    message = _error(tmp_path, "kind: a\ninner: {sise: 3}\n")
    assert message.startswith(f"{tmp_path / 'run.yaml'}: unknown option(s) ['inner.sise']")
    assert "known: ['inner.rate', 'inner.size', 'inner.span']" in message
    assert "unknown run option(s) ['stepz']" in _error(tmp_path, "run: {kind: a, stepz: 3}\n", section="run")


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("kind: a\nsteps: abc\n", "option steps must be an integer, got 'abc'"),
        ("kind: a\nsteps: true\n", "option steps must be an integer, got True"),
        ("kind: a\nsteps: 2.5\n", "option steps must be an integer, got 2.5"),
        ("kind: a\nlr: .nan\n", "option lr must be a finite number, got nan"),
        ("kind: a\nlr: .inf\n", "option lr must be a finite number, got inf"),
        ("kind: a\nlr: fast\n", "option lr must be a number, got 'fast'"),
        ("kind: a\nverbose: 3\n", "option verbose must be true or false, got 3"),
        ("kind: a\nnames: x\n", "option names must be a list of strings, got 'x'"),
        ("kind: a\ntags: x\n", "option tags must be a mapping of strings to integers, got 'x'"),
        ("kind: a\ntags: {x: y}\n", "option tags must be a mapping of strings to integers, got {'x': 'y'}"),
        ("kind: a\ninner: {span: [1, 2, 3]}\n", "option inner.span must be a list of 2 numbers, got (1.0, 2.0, 3.0)"),
        ("kind: a\ninner: {size: [1]}\n", "option inner.size must be an integer, got [1]"),
        ("kind: a\ninner: {rate: .nan}\n", "option inner.rate must be a finite number, got nan"),
        ("kind: a\ninner: 3\n", "section 'inner' must be a mapping of options, got 3"),
        ("kind: c\n", "option kind must be one of a, b, got 'c'"),
        ("kind: a\nsteps: 0\n", "option steps must be an integer > 0 and <= 1e+08, got 0"),
        ("kind: a\nspeed: 13\n", "option speed must be null or a number in [0, 12] m/s, got 13.0"),
        ("steps: 3\n", "'kind' is required (one of a, b)"),
        ("[1, 2]\n", "expected a mapping of options, got list"),
        ("kind: a\n  bad: [indent\n", "not valid YAML"),
    ],
)
def test_bad_values_are_one_line_errors_naming_file_option_and_value(tmp_path: Path, text: str, message: str) -> None:
    error = _error(tmp_path, text)
    assert message in error and error.startswith(str(tmp_path / "run.yaml")), error


def test_a_variant_extends_a_file_and_names_only_what_it_changes(tmp_path: Path) -> None:
    (tmp_path / "parent").mkdir()
    (tmp_path / "parent" / "base.yaml").write_text("kind: a\nsteps: 5\nnames: [x, y]\ninner: {size: 8, rate: 0.5}\n")
    path = _yaml(tmp_path, "extends: parent/base.yaml\nsteps: 7\nnames: [z]\ninner: {rate: 0.25}\n")
    config = load_config(Outer, path)
    assert (config.kind, config.steps, config.names) == ("a", 7, ("z",))  # lists are replaced, not appended
    assert config.inner == Inner(size=8, rate=0.25)  # sections merge key by key
    (tmp_path / "grand.yaml").write_text("extends: run.yaml\nlr: 0.5\n")  # a chain of two
    assert load_config(Outer, tmp_path / "grand.yaml") == dataclasses.replace(config, lr=0.5)
    assert load_config(Outer, path, overrides={"steps": 9}).steps == 9  # overrides apply after the merge


@pytest.mark.parametrize(("text", "message"), [
    ("extends: run.yaml\nkind: a\n", "closes a loop (run.yaml → run.yaml)"),
    ("extends: 3\nkind: a\n", "extends must be the path of another configuration file, got 3"),
    ("extends: missing.yaml\nkind: a\n", "run.yaml: extends: "),
    ("extends: list.yaml\nkind: a\n", "list.yaml is not a mapping of options"),
])
def test_a_bad_extends_is_a_one_line_error(tmp_path: Path, text: str, message: str) -> None:
    (tmp_path / "list.yaml").write_text("[1, 2]\n")
    assert message in _error(tmp_path, text)


def test_a_missing_file_is_both_a_config_error_and_file_not_found(tmp_path: Path) -> None:
    with pytest.raises(MissingConfigFileError, match="nope.yaml: no such configuration file") as info:
        load_config(Outer, tmp_path / "nope.yaml")
    assert isinstance(info.value, FileNotFoundError) and isinstance(info.value, ConfigError)


def test_overrides_and_set(tmp_path: Path) -> None:
    path = _yaml(tmp_path, "kind: a\nsteps: 5\ninner: {size: 2}\n")
    config = load_config(Outer, path, overrides={"steps": None, "lr": 0.5, "inner.rate": 2}, settings=["inner.span=[3, 4]", "lr=1e-2"])
    assert (config.steps, config.lr, config.inner) == (5, 1e-2, Inner(size=2, span=(3.0, 4.0), rate=2.0))
    with pytest.raises(ConfigError, match=r"option inner.size must be an integer, got 'big'"):
        load_config(Outer, path, settings=["inner.size=big"])
    with pytest.raises(ConfigError, match=r"--set 'steps': expected key=value"):
        apply_setting({}, "steps", path)
    with pytest.raises(ConfigError, match=r"--set 'steps.x=1': 'steps' of .* is not a section"):
        apply_setting({"steps": 5}, "steps.x=1", path)
    data = {"inner": {"size": 2}}
    apply_setting(data, "inner.size=3", path)
    assert data == {"inner": {"size": 3}}


def test_mappings_with_a_base_prefix_and_error_class() -> None:
    base = Outer(kind="b", steps=3, inner=Inner(size=7, rate=0.5))
    config = config_from_mapping(Outer, {"inner": {"span": [0, 2]}}, "here", base=base)
    assert config == Outer(kind="b", steps=3, inner=Inner(size=7, span=(0.0, 2.0), rate=0.5))
    with pytest.raises(KeyError, match=r"here: unknown key\(s\) \['env.zap'\]; known: \['env.extra', 'env.rate'"):
        config_from_mapping(Inner, {"zap": 1}, "here", what="key", prefix="env", other_keys=("extra",), error=KeyError)
    assert config_from_mapping(Inner, {"extra": object(), "size": 1}, other_keys=("extra",)) == Inner(size=1)


def test_flags_are_made_from_the_fields(capsys: pytest.CaptureFixture[str]) -> None:
    parser = ArgumentParser(prog="prog")
    add_config_flags(parser, Outer, ["kind", "steps", "lr", "verbose", "speed", "time_limit_s", "inner.size"],
                     flags={"time_limit_s": "--time-limit"}, helps={"lr": "step size"})
    args = parser.parse_args(["--steps", "3", "--lr", "3e-4", "--verbose", "--time-limit", "60", "--size", "2"])
    assert flag_overrides(args) == {"steps": 3, "lr": 3e-4, "verbose": True, "time_limit_s": 60.0, "inner.size": 2}
    assert flag_overrides(parser.parse_args([])) == {}
    text = parser.format_help()
    for piece in ("--kind {a,b}", "--steps STEPS", "optimiser steps, more than 0", "step size", "--time-limit TIME_LIMIT",
                  "stop after this many seconds", "layer size"):
        assert piece in text, piece
    for argv, message in ((["--steps", "abc"], "argument --steps: must be an integer, got 'abc'"),
                          (["--steps", "0"], "argument --steps: must be an integer > 0 and <= 1e+08, got '0'"),
                          (["--lr", "nan"], "argument --lr: must be a finite number, got 'nan'"),
                          (["--speed", "30"], "argument --speed: must be a number in [0, 12] m/s, got '30'"),
                          (["--kind", "c"], "argument --kind: invalid choice")):
        with pytest.raises(SystemExit):
            parser.parse_args(argv)
        assert message in capsys.readouterr().err
    with pytest.raises(TypeError, match="only bool, int, float and str fields"):
        add_config_flags(argparse.ArgumentParser(), Outer, ["names"])


def test_the_command_lines_flags_mirror_the_configs(capsys: pytest.CaptureFixture[str]) -> None:
    from agents.__main__ import build_parser
    from agents.config import EnvConfig, LoggingConfig
    from envs.config import WalkerConfig
    from sspinn.cli import main

    for command in ("train", "finetune"):
        with pytest.raises(SystemExit):
            main([command, "--help"])
        text = capsys.readouterr().out
        for flag in ("--steps STEPS", "--seed SEED", "--device DEVICE", "--time-limit TIME_LIMIT", "--set KEY=VALUE"):
            assert flag in text, (command, flag)
        assert ("--learn-placement" in text) == (command == "finetune")
    parser = build_parser()
    train = parser.parse_args(["train", "--config", "c.yaml", "--out", "o", "--algo", "sac", "--total-timesteps", "100",
                               "--seed", "2", "--target-speed", "1.5"])
    assert flag_overrides(train) == {"algo": "sac", "total_timesteps": 100, "seed": 2, "env.eval_target_speed": 1.5}
    # evaluate/record take function arguments, not config fields; those that mirror a field have its type
    evaluate = parser.parse_args(["evaluate", "--checkpoint", "c.zip", "--out", "o", "--target-speed", "1.5",
                                  "--episodes", "3", "--max-steps", "7"])
    mirrored = {"target_speed": (EnvConfig, "eval_target_speed"), "episodes": (LoggingConfig, "eval_episodes"),
                "max_steps": (WalkerConfig, "max_episode_steps")}
    for dest, (cls, name) in mirrored.items():
        kind = typing.get_type_hints(cls)[name]
        assert type(getattr(evaluate, dest)) in typing.get_args(kind) + (kind,), (dest, kind)


def test_walker_config_from_a_mapping() -> None:
    from envs.config import WalkerConfig

    config = WalkerConfig.from_mapping({"target_speed": [1, 2], "max_torque": {"hip": 2}, "tracking_width": "5e-1"})
    assert config.target_range == (1.0, 2.0) and config.tracking_width == 0.5
    with pytest.raises(ConfigError, match=r"cfg.yaml: env.kwargs: tracking_width must be > 0 m/s"):
        WalkerConfig.from_mapping({"tracking_width": 0}, "cfg.yaml", prefix="env.kwargs")
    with pytest.raises(ConfigError, match=r"option env.kwargs.max_episode_steps must be an integer, got 'long'"):
        WalkerConfig.from_mapping({"max_episode_steps": "long"}, "cfg.yaml", prefix="env.kwargs")
    with pytest.raises(ConfigError, match=r"body: unknown body parameter\(s\) \['femur_r.mas'\]"):
        WalkerConfig.from_mapping({"body": {"height": 1.8, "mass": 80, "femur_r": {"mas": 3}}}, "cfg.yaml")
