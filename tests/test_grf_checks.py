"""GRF files that do not fit the IMUs or the subject (``sspinn.imu.grf_checks`` and the alignment's
checks): edited copies of the real CMU Sub01 CSBaseline GRF imported with the first 10 s of its
IMU export — sides swapped, one channel delayed, negated, in kgf or body weights, contact lost,
a wrong mass — and the real Sub05 CSBaseline trial, whose lag is ambiguous."""

from __future__ import annotations

import contextlib
import io
import re
from pathlib import Path

import numpy as np
import pytest

from sspinn.cli import main
from sspinn.data.dataset import Recording
from sspinn.imu import pipeline as imu_import
from sspinn.imu.grf_checks import GRFFileError, check_vertical_force, unloaded_share_warning
from sspinn.model.conventions import GRAVITY
from sspinn.testing import (
    grf_clock_jump,
    grf_scaled,
    grf_side_delayed,
    grf_sides_swapped,
    grf_unloaded,
    write_grf_edited,
)
from tests.conftest import shared_data

REPO = Path(__file__).resolve().parents[1]
CMU_MAP = REPO / "configs" / "sensor_maps" / "cmu_treadmill.yaml"
#: The CMU left forefoot sensor's gain warning, printed on every CMU import.
GAIN = "sensor 'toes_l_imu_offset_imu' (foot_l): |specific force|"


def _import(trial: Path, grf: Path, out: Path, mass: str = "66.7", end: str = "10", extra: list[str] | None = None) -> tuple[int, str, str]:
    """Import the first ``end`` s of the trial's IMU export with ``grf`` (no figure): (status, stdout, stderr)."""
    stem = trial.name.replace("_Accel.trc.gz", "")
    out_text, err_text = io.StringIO(), io.StringIO()
    with pytest.MonkeyPatch.context() as patch, contextlib.redirect_stdout(out_text), contextlib.redirect_stderr(err_text):
        patch.setattr(imu_import, "plot_calibration", lambda path, *args, **kwargs: Path(path))
        status = main(["import", "--imu", str(trial), "--sensor-map", str(CMU_MAP), "--height", "1.75", "--mass", mass,
                       "--grf", str(grf), "--end", end, "--out", str(out), "--name", stem, *(extra or [])])
    return status, out_text.getvalue(), err_text.getvalue()


def _warnings(printed: str) -> list[str]:
    return [line.strip().removeprefix("WARNING: ") for line in printed.splitlines()
            if line.strip().startswith("WARNING:") and GAIN not in line]


@pytest.fixture(scope="module")
def sub01() -> tuple[Path, Path]:
    folder = shared_data("cmu_treadmill_imu_grf") / "Sub01" / "CSBaseline"
    return folder / "OpenSim_Sub01_CSBaseline_Accel.trc.gz", folder / "OpenSim_Sub01_CSBaseline_GRF.mot.gz"


@pytest.mark.parametrize("edit, mass, expected", [
    (None, "66.7", None),
    (grf_sides_swapped, "66.7", r"\S+grf\.mot: right and left look swapped between the GRF file and the IMUs: with the force "
                                r"channels' sides exchanged the best fit within ±0\.\d\d s of \+0\.00 s is at .* ratio \d+\.\d+ "
                                r"\(above 1\)"),
    (grf_side_delayed("l", 0.15), "66.7", r"\S+grf\.mot: the right and left force channels look offset in time: the right "
                                          r"foot's stance aligns at lag -0\.0\d s, the left at \+0\.1\d s"),
    (grf_unloaded(15.0, 10.0), "66.7", r"\S+grf\.mot: both feet carry less than 5% of body weight \(33 N\) in 17% of the 5950 "
                                       r"samples with the subject on the treadmill"),
    (None, "100", r"\S+OpenSim_Sub01_CSBaseline_GRF\.mot\.gz: the vertical forces \(rFy \+ lFy\) over the file average 652\.\d N, "
                  r"0\.665 × the body weight \(981 N for 100 kg\), outside 0\.85–1\.15"),
], ids=["as recorded", "sides swapped", "left channel 0.15 s late", "contact lost for 10 s", "mass 100 kg instead of 66.7"])
def test_grf_warnings_name_the_file(sub01, tmp_path, edit, mass, expected) -> None:
    accel, grf = sub01
    path = grf if edit is None else write_grf_edited(grf, tmp_path / "grf.mot", edit)
    status, out, err = _import(accel, path, tmp_path / "out", mass=mass)
    assert status == 0, err
    warned = _warnings(out)
    rec = Recording.load(tmp_path / "out" / "OpenSim_Sub01_CSBaseline.csv")
    if expected is None:
        assert warned == [] and rec.provenance["grf_alignment"]["warnings"] == []
        assert abs(rec.provenance["grf_alignment"]["side_lags_s"]["r"] - rec.provenance["grf_alignment"]["side_lags_s"]["l"]) <= 0.05
        return
    matches = [w for w in warned if re.fullmatch(expected + ".*", w)]
    assert len(matches) == 1, warned
    assert matches[0] in rec.provenance["warnings"]  # in the provenance as printed


def test_a_jump_of_the_grf_clock_is_warned_and_its_span_stored(sub01, tmp_path) -> None:
    """The GRF file loses 0.2 s of samples at 15 s (the first 30 s imported): the rest fits 0.2 s
    away from the lag used, warned with its span, stored as ``grf_misaligned_s``."""
    accel, grf = sub01
    status, out, err = _import(accel, write_grf_edited(grf, tmp_path / "grf.mot", grf_clock_jump(15.0, 0.2)), tmp_path / "out",
                               end="30")
    assert status == 0, err
    [warned] = [w for w in _warnings(out) if "jumps" in w]
    assert re.fullmatch(r"\S+grf\.mot: the lag between the IMU and the GRF jumps: from 1\d\.\d to 30\.0 s \(IMU time\) the GRF fits "
                        r"-0\.(1[7-9]|2[0-3]) s away from the lag used .*", warned), warned
    rec = Recording.load(tmp_path / "out" / "OpenSim_Sub01_CSBaseline.csv")
    [(start, stop, offset)] = rec.provenance_spans("grf_misaligned_s")
    assert 10.0 <= start <= 17.5 and stop == pytest.approx(rec.duration, abs=0.02) and offset[0] == pytest.approx(-0.2, abs=0.03)


@pytest.mark.parametrize("factor, message", [
    (-1.0, r"-0\.997 × the body weight \(654 N for 66\.7 kg\): the vertical axis points down: negate the vertical columns"),
    (1 / GRAVITY, r"0\.102 × the body weight .*outside 0\.5–2 .*: it looks like kgf \(kilograms\): give newtons"),
    (1 / (66.7 * GRAVITY), r"0\.00152 × the body weight .*: it looks like body weights: give newtons"),
], ids=["negated", "kgf", "body weights"])
def test_grf_sign_and_unit_errors_are_one_line(sub01, tmp_path, factor, message) -> None:
    accel, grf = sub01
    status, _, err = _import(accel, write_grf_edited(grf, tmp_path / "grf.mot", grf_scaled(factor)), tmp_path / "out")
    assert status == 2 and len(err.strip().splitlines()) == 1, err
    assert re.search(r"sspinn: error: \S+grf\.mot: the vertical forces \(rFy \+ lFy\) over the file average .*" + message, err), err


def test_ambiguous_real_lag_is_warned_on_screen_and_in_the_provenance(tmp_path) -> None:
    """Sub05 CSBaseline's files start together and last equally long: imported as they are, the
    shared clock pins the lag (no warning, the clock named on a NOTE line); with
    ``--separate-clocks`` the search finds no change of activity that tells whole strides apart."""
    folder = shared_data("cmu_treadmill_imu_grf") / "Sub05" / "CSBaseline"
    files = (folder / "OpenSim_Sub05_CSBaseline_Accel.trc.gz", folder / "OpenSim_Sub05_CSBaseline_GRF.mot.gz")
    status, out, err = _import(*files, tmp_path / "clock", mass="73.0", end="20")
    assert status == 0 and _warnings(out) == [], (err, out)
    assert re.search(r"NOTE: time alignment: GRF OpenSim_Sub05_CSBaseline_GRF\.mot\.gz: lag \+0\.000 s between the files' starts "
                     r"\(t_GRF = t_IMU \+ lag\), from the files' shared clock \(same start and duration\); measured \+0\.0\d+ s", out), out
    assert Recording.load(tmp_path / "clock" / "OpenSim_Sub05_CSBaseline.csv").provenance["grf_alignment"]["clock"] == "files"
    assert "**Lag from: the files' shared clock (same start and duration)**" in (
        tmp_path / "clock" / "OpenSim_Sub05_CSBaseline_calibration.md").read_text()
    status, out, err = _import(*files, tmp_path / "out", mass="73.0", end="20", extra=["--separate-clocks"])
    assert status == 0, err
    (warned,) = [w for w in _warnings(out) if "ambiguous" in w]
    alignment = Recording.load(tmp_path / "out" / "OpenSim_Sub05_CSBaseline.csv").provenance["grf_alignment"]
    best, runner = alignment["best"]["lag_s"], alignment["runner_up"]["lag_s"]
    assert warned.startswith(f"{folder / 'OpenSim_Sub05_CSBaseline_GRF.mot.gz'}: the time alignment is ambiguous: lags "
                             f"{best:+.2f} s (score") and f"and {runner:+.2f} s (score" in warned
    assert alignment["ratio"] < 1.05 and any("ambiguous" in w for w in alignment["warnings"])
    assert "## Warnings" in (tmp_path / "out" / "OpenSim_Sub05_CSBaseline_calibration.md").read_text()


def test_vertical_force_checks_on_synthetic_forces() -> None:
    t = np.arange(1000) / 100.0
    stance = np.maximum(np.sin(2 * np.pi * t), 0.0)  # each foot loaded half the time, the two in antiphase
    mass = 70.0
    weight = mass * GRAVITY
    forces = {"r": np.column_stack([0 * t, weight * (0.5 + stance - 1 / np.pi)]),
              "l": np.column_stack([0 * t, weight * (0.5 + np.roll(stance, 50) - 1 / np.pi)])}
    columns = {"r": ("rFx", "rFy"), "l": ("lFx", "lFy")}
    assert check_vertical_force("f.mot", forces, columns, mass) == []
    (warning,) = check_vertical_force("f.mot", forces, columns, 1.3 * mass)
    assert warning.startswith("f.mot: the vertical forces (rFy + lFy) over the file average ") and "outside 0.85–1.15" in warning
    with pytest.raises(GRFFileError, match=r"f\.mot: .* 0\.001 × the body weight .*: it looks like kN"):
        check_vertical_force("f.mot", {s: f / 1000 for s, f in forces.items()}, columns, mass)
    with pytest.raises(GRFFileError, match=r"it looks like N/kg"):
        check_vertical_force("f.mot", {s: f / mass for s, f in forces.items()}, columns, mass)
    assert unloaded_share_warning("f.mot", forces["r"][:, 1], forces["l"][:, 1], mass) is None
    lifted = np.where((t < 1.0) | ((t >= 3.0) & (t < 5.0)), 0.0, 1.0)  # not on the treadmill yet for 1 s, then lost for 2 s
    message = unloaded_share_warning("f.mot", forces["r"][:, 1] * lifted, forces["l"][:, 1] * lifted, mass)
    assert message is not None and re.match(r"f\.mot: both feet carry less than 5% of body weight \(34 N\) in 22% of the 89\d "
                                            r"samples with the subject on the treadmill", message)


def test_per_foot_alignment_undoes_a_late_channel(sub01, tmp_path) -> None:
    """The left channel 0.15 s late, imported with ``--align per-foot``: no channels-offset
    warning, each foot's own lag in the provenance (0.15 s apart) and the left foot's heel
    strikes where the file as recorded puts them."""
    from sspinn.data.gait_events import detect_events

    accel, grf = sub01
    late = write_grf_edited(grf, tmp_path / "grf.mot", grf_side_delayed("l", 0.15))
    recs = {}
    for name, path in (("late", late), ("recorded", grf)):
        status, out, err = _import(accel, path, tmp_path / name, extra=["--align", "per-foot"])
        assert status == 0 and _warnings(out) == [], (err, out)
        assert "NOTE: time alignment: GRF " in out and "lags per foot r " in out
        recs[name] = Recording.load(tmp_path / name / "OpenSim_Sub01_CSBaseline.csv")
    lags = recs["late"].provenance["grf_alignment"]["label_lags_s"]
    assert recs["late"].provenance["grf_alignment"]["align"] == "per-foot"
    assert lags["l"] - lags["r"] == pytest.approx(0.15, abs=0.04)
    strikes = {}
    for name, rec in recs.items():
        t0 = rec.provenance["start_s_in_files"]
        strikes[name] = t0 + detect_events(rec.labels.column("grf_y_l"), 66.7 * GRAVITY, 100.0).heel_strikes / 100.0
    assert len(strikes["late"]) == len(strikes["recorded"]) >= 5
    assert np.abs(strikes["late"] - strikes["recorded"]).max() <= 0.04


def test_clock_options_exclude_each_other(sub01, tmp_path, capsys) -> None:
    accel, grf = sub01
    with pytest.raises(SystemExit) as exit_info:
        main(["import", "--imu", str(accel), "--sensor-map", str(CMU_MAP), "--height", "1.75", "--mass", "66.7",
              "--grf", str(grf), "--out", str(tmp_path), "--same-clock", "--separate-clocks"])
    assert exit_info.value.code == 2 and "not allowed with argument" in capsys.readouterr().err
