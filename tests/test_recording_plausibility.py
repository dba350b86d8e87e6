"""Each reported bad recording gets a DataFormatError naming the file, the
column and the value (the fuzzing of the readers is in tests/test_recording_fuzz.py)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from sspinn.data.dataset import DataFormatError, Recording
from sspinn.model.body import IMUPlacement
from sspinn.model.conventions import SEGMENTS
from sspinn.testing import edit_column, walking_recording


@pytest.fixture()
def saved(tmp_path: Path) -> Path:
    return walking_recording().save(tmp_path)


def _edit_csv(csv: Path, column: str, fn) -> None:
    csv.write_text("\n".join(edit_column(csv.read_text().splitlines(), column, fn)) + "\n")


def _edit_sidecar(csv: Path, fn) -> None:
    path = csv.with_suffix(".json")
    meta = json.loads(path.read_text())
    path.write_text(json.dumps(fn(meta)) if not isinstance(fn(meta), str) else fn(meta))


# ------------------------------------------------------------------------- the reported cases
def test_pelvis_gyroscope_in_deg_per_s(saved: Path) -> None:
    _edit_csv(saved, "pelvis_gyr_z", lambda v: np.degrees(v) * 0.6)  # peak ≈ 35 "rad/s"
    with pytest.raises(DataFormatError, match=r"walk.csv: column 'pelvis_gyr_z' reaches .*looks like deg/s"):
        Recording.load(saved)


@pytest.mark.parametrize(("fn", "message"), [
    (lambda v: v * 100.0, r"column 'pelvis_acc_y' reaches 10\d\d at sample \d+, beyond 490 m/s² .* \(cm/s² or mm/s²\?\)"),
    (lambda v: v * 6.0, r"pelvis_acc_x/y median magnitude 5\d(\.\d+)? m/s² is 6(\.\d+)? g, far above"),
    (lambda v: 1e308, r"column 'pelvis_acc_x' reaches 1e\+308 at sample 0, beyond 490 m/s²"),
])
def test_accelerometers_in_cm_per_s2_or_absurd(saved: Path, fn, message) -> None:
    _edit_csv(saved, "pelvis_acc_x", fn)
    _edit_csv(saved, "pelvis_acc_y", fn)
    with pytest.raises(DataFormatError, match=message):
        Recording.load(saved)


def test_a_dead_gyroscope(saved: Path) -> None:
    _edit_csv(saved, "tibia_l_gyr_z", lambda v: 0.0)
    with pytest.raises(DataFormatError, match=r"walk.csv: column 'tibia_l_gyr_z' is constant \(0\) over all 300 samples: a dead"):
        Recording.load(saved)


def test_a_saturated_gyroscope(saved: Path) -> None:
    _edit_csv(saved, "foot_r_gyr_z", lambda v: min(v, 6.0))
    with pytest.raises(DataFormatError, match=r"column 'foot_r_gyr_z' is clipped at 6 \(\d+ flat episodes"):
        Recording.load(saved)


def test_gravity_missing_in_the_low_frequency_specific_force(tmp_path: Path) -> None:
    rec = walking_recording()
    phase = 2 * np.pi * np.arange(300) / 25.0  # |a| = 12 m/s² rotating: no constant part (gravity)
    rec.imu[:, 0, 0], rec.imu[:, 0, 1] = 12.0 * np.sin(phase), 12.0 * np.cos(phase)
    with pytest.raises(DataFormatError, match=r"low-frequency specific force of pelvis_acc_x/y .* median magnitude 0\.00 g"):
        Recording(name="x", imu=rec.imu, segments=rec.segments, height=1.75, mass=70.0)


def test_imu_placement_in_cm(saved: Path) -> None:
    def cm(meta):
        meta["imu"]["placement"]["tibia_r"]["position_m"] = [0.0, -22.5]
        return meta

    _edit_sidecar(saved, cm)
    with pytest.raises(DataFormatError, match=r"walk.csv: IMU placement of tibia_r \(0, -22.5\) is 22.5 m .* in metres"):
        Recording.load(saved)
    with pytest.raises(DataFormatError, match="placement of foot_l"):
        Recording(name="x", imu=walking_recording().imu, segments=SEGMENTS, height=1.75, mass=70.0,
                  placement=IMUPlacement(positions={**IMUPlacement().positions, "foot_l": (12.0, 0.0)}))


def test_last_line_cut_inside_its_final_field(saved: Path) -> None:
    text = saved.read_text()
    saved.write_text(text[:-3])  # the newline and two digits gone
    with pytest.raises(DataFormatError, match=r"walk.csv: the last line \(row 301\) does not end with a newline"):
        Recording.load(saved)


def test_time_column_at_100_9_hz(saved: Path) -> None:
    lines = saved.read_text().splitlines()
    out = [lines[0]] + [f"{k / 100.9!r}," + line.split(",", 1)[1] for k, line in enumerate(lines[1:])]
    saved.write_text("\n".join(out) + "\n")
    with pytest.raises(DataFormatError, match=r"column 'time' must advance by 0.01 s.* drift from the 100 Hz grid .*100.9 Hz"):
        Recording.load(saved)


@pytest.mark.parametrize(("edit", "message"), [
    (lambda m: m["subject"].update(height_m=None) or m, r"walk.json: subject.height_m must be a number .* got None"),
    (lambda m: m["subject"].update(height_m="1.75 m") or m, r"subject.height_m must be a number \(SI units, no unit text\), got '1.75 m'"),
    (lambda m: [m], r"walk.json: expected a JSON object .* got a list"),
    (lambda m: m["imu"].update(segments="pelvis") or m, r"imu.segments must be a list of segment names"),
    (lambda m: m.update(sample_rate_hz="100") or m, r"sample_rate_hz must be a number"),
    (lambda m: m["imu"].update(placement={"pelvis": 3}) or m, r"bad imu.placement"),
    (lambda m: m.update(labels="q") or m, r"labels must be a list of column names"),
])
def test_sidecar_edge_cases(saved: Path, edit, message) -> None:
    _edit_sidecar(saved, edit)
    with pytest.raises(DataFormatError, match=message):
        Recording.load(saved)


def test_a_utf8_byte_order_mark_is_accepted(saved: Path) -> None:
    saved.write_bytes(b"\xef\xbb\xbf" + saved.read_bytes())
    sidecar = saved.with_suffix(".json")
    sidecar.write_bytes(b"\xef\xbb\xbf" + sidecar.read_bytes())
    assert Recording.load(saved).n_samples == 300


def test_non_numbers_and_ragged_rows_name_row_and_column(saved: Path) -> None:
    lines = saved.read_text().splitlines()
    fields = lines[5].split(",")
    fields[3] = "12,5"  # a decimal comma
    saved.write_text("\n".join([*lines[:5], ",".join(fields), *lines[6:]]) + "\n")
    with pytest.raises(DataFormatError, match=r"row 6 has \d+ values but the header has \d+ columns"):
        Recording.load(saved)
    fields[3] = "1.2.3"
    saved.write_text("\n".join([*lines[:5], ",".join(fields), *lines[6:]]) + "\n")
    with pytest.raises(DataFormatError, match=r"row 6, column 'pelvis_gyr_z': '1.2.3' is not a number"):
        Recording.load(saved)
