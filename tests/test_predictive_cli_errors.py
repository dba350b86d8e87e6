"""The predictive CLI rejects impossible requests up front with one line and
exit code 2, and reports a solution that violates the dynamics or physics as failed (exit 1)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import predictive.__main__ as predictive_cli
import predictive.ocp.cli as solve_cli
from predictive.ocp.collocation import solve_predictive
from predictive.ocp.limits import RequestError, check_body, check_speed, solution_problems
from predictive.ocp.solution import GaitSolution
from sspinn.errors import UserError


def run_main(argv: list[str]) -> int:
    """``python -m predictive`` in-process: its exit status, also for a usage error (SystemExit)."""
    try:
        return predictive_cli.main(argv)
    except SystemExit as exc:
        return int(exc.code)


@pytest.fixture(scope="module")
def standing() -> GaitSolution:
    return solve_predictive(0.0, n_nodes=6, duration=0.4)


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--speed", "50"], "--speed 50.0 m/s is outside what the model can do"),
        (["--speed", "-1"], "--speed -1.0 m/s is outside"),
        (["--speed", "nan"], "--speed nan m/s is outside"),
        (["--speed", "1.3", "--height", "175"], "body height 175.0 m is outside the anthropometric range 1–2.3 m (a height in cm? give metres)"),
        (["--speed", "1.3", "--mass", "0"], "body mass 0.0 kg is outside"),
        (["--speed", "1.3", "--nodes", "2"], "argument --nodes: 2 is outside 4–1000"),
        (["--speed", "1.3", "--nodes", "1000000"], "argument --nodes: 1000000 is outside 4–1000"),
        (["--speed", "1.3", "--rate-hz", "nan"], "argument --rate-hz: nan is outside 1–1000 Hz"),
        (["--speed", "1.3", "--rate-hz", "1e6"], "argument --rate-hz: 1e6 is outside 1–1000 Hz"),
        (["--speed", "1.3", "--rate-hz", "1000", "--cycle", "full", "--duration", "2.5"],
         "rate_hz 1000 Hz over a 2.5 s stride (full cycle) gives 2500 collocation nodes; the solver takes 4–1000"),
        (["--speed", "1.3", "--duration", "30"], "argument --duration: 30 is outside 0.2–3 s"),
        (["--speed", "1.3", "--w-acc", "-1"], "argument --w-acc: -1 is outside 0–1e+06"),
        (["--speed", "1.3", "--guess", "missing.npz"], "missing.npz not found"),
    ],
)
def test_impossible_requests_are_one_line_errors(tmp_path: Path, capsys, args, message) -> None:
    code = run_main(["solve", *args, "--out", str(tmp_path / "x")])
    err = capsys.readouterr().err
    assert code == 2 and message in err and err.count("\n") == 1 and "Traceback" not in err, err
    assert not list(tmp_path.iterdir())


def test_the_solve_entry_point_rejects_impossible_speeds() -> None:
    with pytest.raises(RequestError, match="speed 50 m/s is outside"):
        solve_predictive(50)
    with pytest.raises(RequestError, match="speed nan"):
        solve_predictive(float("nan"))
    assert check_speed(0.0) == 0.0 and check_speed(9.9) == 9.9
    with pytest.raises(RequestError):
        check_speed(0.0, allow_zero=False)
    check_body(1.75, 70.0)


def test_missing_or_broken_data_is_one_line(tmp_path: Path, capsys) -> None:
    code = predictive_cli.main(["track-imu", "--data", str(tmp_path / "nowhere"), "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert code == 2 and "nowhere/meta.json: file not found" in err and err.count("\n") == 1
    folder = tmp_path / "stride"
    folder.mkdir()
    (folder / "meta.json").write_text('{"stride_duration_s": {"mean": 1.1}, "samples_per_stride": 2}')
    (folder / "signals.csv").write_text("pelvis_acc_x,pelvis_acc_y,pelvis_gyr_z\n0,9.8,nan\n0,9.8,0.1\n")
    code = predictive_cli.main(["track-imu", "--data", str(folder), "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert code == 2 and "column 'pelvis_gyr_z' has a non-finite value at row 2" in err, err
    code = predictive_cli.main(["track-imu", "--data", str(folder), "--height", "175", "--out", str(tmp_path / "o")])
    assert code == 2 and "a height in cm?" in capsys.readouterr().err


def test_a_solution_violating_the_dynamics_is_reported_as_failed(standing, tmp_path: Path, monkeypatch, capsys) -> None:
    assert solution_problems(standing) == []
    broken = GaitSolution.load(standing.save(tmp_path / "ok"))
    broken.tau = broken.tau + 50.0  # 50 N·m the dynamics do not explain
    assert any("Kane residual at its own nodes" in p for p in solution_problems(broken))
    monkeypatch.setattr(solve_cli, "solve_predictive", lambda *a, **k: broken)
    code = predictive_cli.main(["solve", "--speed", "0", "--nodes", "6", "--duration", "0.4", "--out", str(tmp_path / "s")])
    err = capsys.readouterr().err
    assert code == 1 and "FAILED: IPOPT reported Solve_Succeeded, but the solution is not acceptable" in err
    assert not (tmp_path / "s.npz").exists() and (tmp_path / "s_failed.npz").exists()
    broken.grf = broken.grf * 20
    assert any("peak vertical GRF" in p for p in solution_problems(broken))
    broken.q[2, 3] = np.nan
    assert solution_problems(broken) == ["q has 1 non-finite value(s)"]
    with pytest.raises(UserError, match="refusing to write a gait solution with non-finite"):
        broken.save(tmp_path / "nan")


def test_broken_solution_files_are_one_line(tmp_path: Path, capsys) -> None:
    (tmp_path / "g.npz").write_bytes(b"junk")
    (tmp_path / "g.json").write_text("{}")
    with pytest.raises(UserError, match="not a readable gait solution"):
        GaitSolution.load(tmp_path / "g")


def test_debug_shows_the_traceback(tmp_path: Path) -> None:
    with pytest.raises(RequestError):
        predictive_cli.main(["solve", "--speed", "50", "--debug", "--out", str(tmp_path / "x")])


def test_generate_rejects_impossible_requests_before_loading(tmp_path: Path, capsys) -> None:
    for args, message in ((["--speed", "50"], "--speed 50.0 m/s is outside"), (["--speed", "1.3", "--height", "175"], "a height in cm?")):
        code = predictive_cli.main(["generate", "--model", str(tmp_path / "none.pt"), *args, "--out", str(tmp_path / "g")])
        err = capsys.readouterr().err
        assert code == 2 and message in err and err.count("\n") == 1, err
    code = predictive_cli.main(["generate", "--model", str(tmp_path / "none.pt"), "--speed", "1.3", "--out", str(tmp_path / "g")])
    assert code == 2 and "no gait generator" in capsys.readouterr().err
