"""The recording/dataset format: round trips and clear errors for corrupted files."""

from __future__ import annotations

import json

import numpy as np
import pytest

from sspinn.data.csv_readers import read_averaged_stride, read_csv_recording
from sspinn.data.dataset import DataFormatError, Dataset, Recording
from sspinn.model.conventions import GRAVITY, SEGMENTS
from sspinn.testing import make_recording
from tests.conftest import shared_data


def test_round_trip(tmp_path):
    rec = make_recording()
    csv = rec.save(tmp_path)
    again = Recording.load(csv)
    np.testing.assert_allclose(again.imu, rec.imu, rtol=1e-8, atol=1e-8)
    assert again.labels.columns() == rec.labels.columns()
    assert "grf_x_l" in again.labels.missing and np.isnan(again.labels.grf[:, 2]).all()
    np.testing.assert_allclose(again.labels.column("grf_y_r"), 700.0)
    assert again.segments == SEGMENTS and again.height == 1.75 and again.subject == "s01"


def test_select_imus():
    rec = make_recording().select_imus(["foot_r", "femur_r"])
    assert rec.segments == ("femur_r", "foot_r") and rec.imu.shape[1:] == (2, 3)
    with pytest.raises(DataFormatError, match="no IMU on"):
        rec.select_imus(["pelvis"])


def _corrupt(tmp_path, edit_csv=None, edit_json=None):
    csv = make_recording().save(tmp_path)
    if edit_csv:
        lines = csv.read_text().splitlines()
        csv.write_text("\n".join(edit_csv(lines)) + "\n")
    if edit_json:
        side = csv.with_suffix(".json")
        meta = json.loads(side.read_text())
        edit_json(meta)
        side.write_text(json.dumps(meta))
    return csv


def _drop_column(name):
    def edit(lines):
        header = lines[0].split(",")
        k = header.index(name)
        return [",".join(v for i, v in enumerate(line.split(",")) if i != k) for line in lines]

    return edit


def _scale_column(prefix, factor):
    def edit(lines):
        header = lines[0].split(",")
        ks = [i for i, h in enumerate(header) if h.startswith(prefix)]
        out = [lines[0]]
        for line in lines[1:]:
            v = line.split(",")
            for k in ks:
                v[k] = repr(float(v[k]) * factor)
            out.append(",".join(v))
        return out

    return edit


@pytest.mark.parametrize(
    "edit_csv, edit_json, match",
    [
        (_drop_column("tibia_l_gyr_z"), None, r"missing IMU column\(s\) \['tibia_l_gyr_z'\]"),
        (lambda ls: ls[:5] + [ls[5].replace(ls[5].split(",")[3], "nan", 1)] + ls[6:], None, "column 'pelvis_gyr_z' has a non-finite value .* at sample 4"),
        (_scale_column("time", 0.5), None, "must advance by 0.01 s"),
        (_scale_column("foot_r_gyr_z", 180 / np.pi * 50), None, "deg/s"),
        (_scale_column("pelvis_acc", 1 / GRAVITY), None, "units of g"),
        (_scale_column("grf_y_r", 1 / 686.7), None, "body weights"),
        (_scale_column("hip_r", 180 / np.pi * 30), None, "degrees"),
        (None, lambda m: m.update(sample_rate_hz=200), "sample_rate_hz must be 100"),
        (None, lambda m: m.update(version=7), "unsupported version 7"),
        (None, lambda m: m["subject"].update(height_m=175), "height 175"),
        (None, lambda m: m["imu"].update(segments=["pelvis", "hand"]), "unknown IMU segment"),
        (_drop_column("speed"), None, r"label column\(s\) \['speed'\] declared"),
    ],
)
def test_corrupted_files_are_rejected_with_clear_messages(tmp_path, edit_csv, edit_json, match):
    csv = _corrupt(tmp_path, edit_csv, edit_json)
    with pytest.raises(DataFormatError, match=match) as info:
        Recording.load(csv)
    assert "rec." in str(info.value), "the message must name the file"


def test_dataset_split_by_subject(tmp_path):
    ds = Dataset.write(tmp_path, {"train": [make_recording("a", "s1"), make_recording("b", "s2")], "test": [make_recording("c", "s3")]})
    again = Dataset.open(tmp_path)
    assert [r.name for r in again.load("train")] == ["a", "b"]
    assert again.splits == ds.splits
    with pytest.raises(DataFormatError, match="appears in splits"):
        Dataset.write(tmp_path / "x", {"train": [make_recording("a", "s1")], "test": [make_recording("c", "s1")]})
    (tmp_path / "b.csv").unlink()
    with pytest.raises(DataFormatError, match="b.csv is missing"):
        Dataset.open(tmp_path)


def test_csv_reader_converts_units_and_resamples(tmp_path):
    fs = 200.0
    t = np.arange(400) / fs
    path = tmp_path / "raw.csv"
    # accelerations that vary a little (a constant channel is a dead sensor, see sspinn.data.plausibility)
    cols = {"ax": 0.1 + 0.01 * np.sin(3 * t), "ay": 1.0 + 0.01 * np.cos(t), "gz": 57.29577951308232 * np.sin(t)}
    np.savetxt(path, np.column_stack(list(cols.values())), delimiter=",", header="ax,ay,gz", comments="")
    rec = read_csv_recording(path, {"foot_r_acc_x": "ax", "foot_r_acc_y": "ay", "foot_r_gyr_z": "gz"}, fs, 1.75, 70, gyro_unit="deg/s", acc_unit="g")
    assert rec.segments == ("foot_r",) and rec.n_samples == 200
    np.testing.assert_allclose(rec.imu[:, 0, 1], GRAVITY * (1.0 + 0.01 * np.cos(np.arange(200) / 100.0)), rtol=1e-6)
    np.testing.assert_allclose(rec.imu[:, 0, 2], np.sin(np.arange(200) / 100.0), atol=1e-6)
    with pytest.raises(DataFormatError, match="incomplete"):
        read_csv_recording(path, {"foot_r_acc_x": "ax"}, fs, 1.75, 70)
    with pytest.raises(DataFormatError, match="not in the file"):
        read_csv_recording(path, {"foot_r_acc_x": "ax", "foot_r_acc_y": "ay", "foot_r_gyr_z": "gyro"}, fs, 1.75, 70)


def test_averaged_stride_reader():
    folder = shared_data("dorschky_P03_walking")
    rec = read_averaged_stride(folder, periods=2)
    meta = json.loads((folder / "meta.json").read_text())
    assert rec.n_samples == round(2 * meta["stride_duration_s"]["mean"] * 100)
    assert len(rec.segments) == 7
    # periodic: one stride later the signals repeat (up to interpolation at shifted phases)
    period = meta["stride_duration_s"]["mean"] * 100
    k = 10
    assert abs(rec.imu[k, 0, 1] - rec.imu[int(round(k + period)), 0, 1]) < 0.5
    grf = rec.labels.column("grf_y_r")
    assert 1.0 * 70 * GRAVITY < grf.max() < 1.4 * 70 * GRAVITY  # walking: ~1.1 BW peaks, in N
    assert rec.labels.column("knee_r").min() < -0.8  # knee flexion negative, ~60° in swing
