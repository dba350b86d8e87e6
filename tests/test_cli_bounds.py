"""Every numeric option of ``python -m predictive`` and ``python -m agents`` has a range: a value
outside it is one line naming the option, the value and the range (exit status 2), never a run
that grows without bound or a value silently changed. The gait generator refuses speeds and
bodies outside the ranges it was trained on (``--force`` generates with a WARNING), and its
summary never holds NaN."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import pytest

import predictive.__main__ as predictive_cli
from agents.__main__ import build_parser as agents_parser
from agents.__main__ import main as agents_main
from agents.plot_learning_curve import main as plot_main
from sspinn.errors import bounded

#: Numeric options checked after parsing, by the model's own limits (predictive.ocp.limits:
#: check_speed, check_body — their messages name the range and catch a height in cm).
CHECKED_AFTER_PARSING = {"speed", "height", "mass"}
HUGE = "1" + "0" * 30


def _numeric_actions(parser: argparse.ArgumentParser) -> list[tuple[str, argparse.Action]]:
    """(sub-command, action) of every option whose value is converted by a ``type``."""
    found = []
    for action in parser._actions:  # argparse offers no public walk over its actions
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                found += [(name, a) for _, a in _numeric_actions(sub)]
        elif action.type not in (None, str, Path) and action.option_strings:
            found.append(("", action))
    return found


@pytest.mark.parametrize("parser", [predictive_cli.build_parser(), agents_parser()], ids=["predictive", "agents"])
def test_every_numeric_option_has_a_range(parser: argparse.ArgumentParser) -> None:
    actions = _numeric_actions(parser)
    assert len(actions) >= 10
    unbounded = []
    for command, action in actions:
        if action.dest in CHECKED_AFTER_PARSING:
            continue
        for text in (HUGE, "-" + HUGE, "nan"):
            try:
                action.type(text)
            except (argparse.ArgumentTypeError, ValueError):
                continue
            unbounded.append(f"{command} {action.option_strings[0]} accepts {text[:6]}…")
    assert not unbounded, unbounded


def _exit(main, argv: list[str], capsys) -> tuple[int, str]:
    try:
        code = main(argv)
    except SystemExit as exc:  # a usage error
        code = int(exc.code)
    err = capsys.readouterr().err
    assert err.count("\n") <= 1 and "Traceback" not in err, err
    return code, err


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["generate", "--model", "g.pt", "--speed", "1.3", "--refine", "100000000"], "argument --refine: 100000000 is outside 0–5000"),
        (["generate", "--model", "g.pt", "--speed", "1.3", "--refine", "-5"], "argument --refine: -5 is outside 0–5000"),
        (["generate", "--model", "g.pt", "--speed", "1.3", "--refine", "1e8"], "argument --refine: '1e8' is not an integer in 0–5000"),
        (["generate", "--model", "g.pt", "--speed", "inf"], "--speed inf m/s is outside what the model can do"),
        (["track-imu", "--data", "d", "--nodes", "1000000"], "argument --nodes: 1000000 is outside 4–1000"),
        (["track-imu", "--data", "d", "--effort-weight", "-1"], "argument --effort-weight: -1 is outside 0–1e+06"),
        (["track-imu", "--data", "d", "--speed-guess", "1.2", "50"], "argument --speed-guess: 50 is outside 0–10 m/s"),
        (["synth", "--workers", "0"], "argument --workers: 0 is outside 1–256"),
        (["synth", "--seed", "-1"], "argument --seed: -1 is outside 0–4.29497e+09"),
        (["compare", "--seeds", "-5"], "argument --seeds: -5 is outside 1–1000"),
    ],
)
def test_predictive_options_out_of_range(tmp_path: Path, capsys, argv: list[str], message: str) -> None:
    code, err = _exit(predictive_cli.main, [*argv, "--out", str(tmp_path / "o")], capsys)
    assert code == 2 and message in err, err
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["evaluate", "--checkpoint", "m.zip", "--episodes", "0"], "argument --episodes: 0 is outside 1–1000"),
        (["evaluate", "--checkpoint", "m.zip", "--fps", "1000"], "argument --fps: 1000 is outside 1–100"),
        (["evaluate", "--checkpoint", "m.zip", "--max-steps", "1000000000"], "argument --max-steps: 1000000000 is outside 1–60000"),
        (["record", "--checkpoint", "m.zip", "--target-speed", "1e6"], "argument --target-speed: 1e6 is outside 0–12 m/s"),
        (["record", "--checkpoint", "m.zip", "--seed", "-1"], "argument --seed: -1 is outside 0–4.29497e+09"),
        (["train", "--config", "c.yaml", "--total-timesteps", "1000000000000"], "argument --total-timesteps: must be an integer > 0 and <= 1e+11"),
        (["train", "--config", "c.yaml", "--seed", "-3"], "argument --seed: must be an integer in [0, 4.29497e+09]"),
    ],
)
def test_agents_options_out_of_range(tmp_path: Path, capsys, argv: list[str], message: str) -> None:
    code, err = _exit(agents_main, [*argv, "--out", str(tmp_path / "o")], capsys)
    assert code == 2 and message in err, err


def test_plot_learning_curve_window(tmp_path: Path, capsys) -> None:
    code, err = _exit(plot_main, [str(tmp_path), "--window", "0"], capsys)
    assert code == 2 and "argument --window: 0 is outside 1–100000" in err
    code, err = _exit(plot_main, [str(tmp_path / "none")], capsys)
    assert code == 2 and "no monitor files" in err


def test_bounded() -> None:
    parse = bounded(float, 0.5, 2.0, " m")
    assert parse("1.25") == 1.25 and parse("2") == 2.0
    for text, message in (("3", "3 is outside 0.5–2 m"), ("nan", "nan is outside"), ("x", "'x' is not a number in 0.5–2 m")):
        with pytest.raises(argparse.ArgumentTypeError, match=message):
            parse(text)
    with pytest.raises(argparse.ArgumentTypeError, match="'2.5' is not an integer"):
        bounded(int, 1, 5)("2.5")


# ------------------------------------------------------------------------------------------------
# the gait generator's training range, and summaries without NaN
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--speed", "2.0"], "speed 2 m/s is outside its training range 1–1.5 m/s"),
        (["--speed", "1.2", "--height", "2.2"], "height 2.2 m is outside its training range 1.6–1.9 m"),
        (["--speed", "1.2", "--mass", "120"], "mass 120 kg is outside its training range 55–90 kg"),
    ],
)
def test_generate_refuses_requests_outside_the_training_range(small_generator, tmp_path, capsys, args, message) -> None:
    code, err = _exit(predictive_cli.main, ["generate", "--model", str(small_generator), *args, "--out", str(tmp_path / "g")], capsys)
    assert code == 2 and message in err and "use --force" in err, err
    assert not list(tmp_path.iterdir())


def test_generate_force_warns_and_records_the_extrapolation(small_generator, tmp_path, capsys) -> None:
    code = predictive_cli.main(["generate", "--model", str(small_generator), "--speed", "2.5", "--force", "--out", str(tmp_path / "g")])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    assert "WARNING: speed 2.5 m/s is outside its training range 1–1.5 m/s" in captured.err
    summary = json.loads((tmp_path / "g_summary.json").read_text())
    assert summary["extrapolated"] == ["speed 2.5 m/s is outside its training range 1–1.5 m/s"]
    assert "NaN" not in (tmp_path / "g_summary.json").read_text() and "NaN" not in (tmp_path / "g.json").read_text()
    from predictive.ocp.solution import GaitSolution

    again = GaitSolution.load(tmp_path / "g")  # no build time or objective: null in the file, NaN again here
    assert np.isnan(again.objective) and np.isnan(again.build_time) and again.q.shape[1] == 9


def test_generate_never_writes_nan_into_the_summary(small_generator, tmp_path, capsys, monkeypatch) -> None:
    from predictive.ocp.solution import GaitSolution

    real = GaitSolution.summary
    monkeypatch.setattr(GaitSolution, "summary", lambda self: {**real(self), "stride_length": float("nan")})
    code, err = _exit(predictive_cli.main, ["generate", "--model", str(small_generator), "--speed", "1.2",
                                            "--out", str(tmp_path / "g")], capsys)
    assert code == 2 and "g_summary.json: refusing to write non-finite nan at stride_length" in err, err
    assert not list(tmp_path.iterdir())  # nothing written: neither the solution nor the summary


def test_the_generate_function_refuses_too(small_generator) -> None:
    from predictive.generator.gait_generator import generate, load_generator
    from predictive.ocp.limits import RequestError

    model, config = load_generator(small_generator)
    with pytest.raises(RequestError, match="speed 3 m/s is outside its training range 1–1.5 m/s"):
        generate(model, 3.0, n=8, config=config)
    assert generate(model, 3.0, n=8, config=config, force=True).q.shape == (8, 9)
    with pytest.raises(RequestError, match="refine_iterations -5 is outside 0–5000"):
        generate(model, 1.2, n=8, config=config, refine_iterations=-5)
