"""Per-window estimate quality: the loss terms on the recording itself, their calibration, and
what ``sspinn infer`` writes and warns about."""

from __future__ import annotations

import dataclasses
import shutil

import numpy as np
import pytest

from sspinn.cli import main
from sspinn.data.dataset import Dataset
from sspinn.estimator.quality import (
    QUALITY_TERMS,
    QualityCalibration,
    QualityCalibrationError,
    calibrate,
    calibration_path,
    input_findings,
    load_calibration,
    save_calibration,
    training_recordings,
    windows,
)
from sspinn.estimator.sspinnpose import SSPINNpose
from sspinn.testing import make_recording, walking_recording


@pytest.fixture(scope="module")
def model(tiny_run, tmp_path_factory):
    """A copy of the tiny run's model (calibration files are written beside it)."""
    folder = tmp_path_factory.mktemp("quality_model")
    shutil.copy(tiny_run[4] / "model.pt", folder / "model.pt")
    return folder / "model.pt"


def _noisy(rec, scale=5.0, seed=1):
    rng = np.random.default_rng(seed)
    return dataclasses.replace(rec, imu=rec.imu + rng.normal(size=rec.imu.shape) * np.array([scale, scale, scale / 5]))


def test_windows_tile_the_recording():
    for n in (1, 150, 200, 399, 400, 1234):
        start, stop = windows(n)
        assert start[0] == 0 and stop[-1] == n and np.all(start[1:] == stop[:-1])
        assert len(start) == max(1, n // 200) and np.all(stop - start >= min(n, 200))


def test_quality_terms_are_finite_and_per_window(model):
    est = SSPINNpose.load(model)
    rec = walking_recording(650)
    q = est.quality(rec)
    assert q.n_windows == 3 and q.score is None and q.flagged is None
    assert set(q.terms) == set(QUALITY_TERMS[est.network_.config.grf])
    for values in [*q.terms.values(), q.speed]:
        assert values.shape == (3,) and np.isfinite(values).all()
    assert all((v >= 0).all() for v in q.terms.values())
    # the windows differ: the terms are computed on each, not once for the recording
    assert len(np.unique(q.terms["imu"])) == 3


def test_the_quality_speed_is_the_estimates_also_where_the_body_rests(model):
    est = SSPINNpose.load(model)
    rec = walking_recording(650)
    quiet = rec.imu.copy()
    quiet[:, :, :] = [0.0, 9.81, 0.0]  # every sensor still (specific force = gravity), the first 4 s
    rec = dataclasses.replace(rec, imu=np.where(np.arange(650)[:, None, None] < 400, quiet, rec.imu))
    q, estimate = est.quality(rec), est.predict(rec)
    assert np.all(estimate.u[:400, 0] == 0.0)
    np.testing.assert_allclose(q.speed, [estimate.u[a:b, 0].mean() for a, b in zip(q.start, q.stop)], atol=1e-3)
    assert q.speed[0] == 0.0 and q.rest[0] == 1.0 and q.rest[-1] == 0.0
    # the resting windows are named as such, not as a speed outside the training range
    cal = QualityCalibration(
        model_sha256="", grf=est.network_.config.grf, window_s=2.0, term_median={k: 1.0 for k in q.terms}, threshold=0.0,
        error_median={"jae_deg": 1.0, "grfe_pct_bw": 1.0}, error_threshold=1.0,
        input_ranges={"speed_m_s": [1e-6, 200.0]}, calibrated_on=[], source="x", ranges_from="training",
    )
    [line] = input_findings(rec, q, cal, "m.pt")
    assert "the whole body rests in 2 of 3 windows" in line
    assert ("estimated speed" in line) == (q.speed[2] < 1e-6)  # only the walking window's speed is judged
    cal.input_ranges = {"speed_m_s": [0.0, 200.0]}  # a model that saw standing
    assert input_findings(rec, q, cal, "m.pt") == []


def test_a_corrupted_recording_scores_worse_than_the_clean_one(model, tiny_run):
    est = SSPINNpose.load(model)
    train = tiny_run[3]
    cal, qualities, _ = calibrate(est.network_, est.segments_, est.imu_std_, est.config_.joint_limits, train,
                                  [est.predict(r) for r in train], model, "tiny")
    assert all(np.isfinite(q.score).all() for q in qualities)
    clean = walking_recording(650)
    q_clean, q_noisy = cal.apply(est.quality(clean)), cal.apply(est.quality(_noisy(clean)))
    assert (q_noisy.terms["imu"] > 1.1 * q_clean.terms["imu"]).all()
    assert (q_noisy.score > q_clean.score).all()


def test_calibration_round_trips_and_refuses_another_model_or_a_broken_file(model, tiny_run, tmp_path):
    est = SSPINNpose.load(model)
    train = tiny_run[3]
    cal, _, _ = calibrate(est.network_, est.segments_, est.imu_std_, est.config_.joint_limits, train,
                          [est.predict(r) for r in train], model, "tiny")
    path = save_calibration(cal, tmp_path / "q.json")
    assert load_calibration(path, model) == cal
    other = tmp_path / "other.pt"
    other.write_bytes(model.read_bytes() + b"\0")
    with pytest.raises(QualityCalibrationError, match="another model file"):
        load_calibration(path, other)
    path.write_text('{"format": "sspinn-quality-calibration", "version": 1, "threshold": "x"}')
    with pytest.raises(QualityCalibrationError, match=r"q\.json: not a usable quality calibration"):
        load_calibration(path, model)
    # an unlabelled recording cannot calibrate
    bare = dataclasses.replace(train[0], labels=None)
    with pytest.raises(QualityCalibrationError, match="no labels"):
        calibrate(est.network_, est.segments_, est.imu_std_, est.config_.joint_limits, [bare], [est.predict(bare)], model, "x")


def test_inputs_outside_the_calibration_ranges_are_named(model):
    est = SSPINNpose.load(model)
    rec = walking_recording(650)
    q = est.quality(rec)
    cal = QualityCalibration(
        model_sha256="", grf=est.network_.config.grf, window_s=2.0, term_median={k: 1.0 for k in q.terms}, threshold=0.0,
        error_median={"jae_deg": 1.0, "grfe_pct_bw": 1.0}, error_threshold=1.0,
        input_ranges={"height_m": [1.8, 1.9], "mass_kg": [60.0, 80.0], "speed_m_s": [100.0, 200.0]}, calibrated_on=[], source="x",
    )
    [line] = input_findings(rec, q, cal, "m.pt")
    assert line.startswith("walk: its inputs lie outside those of the recordings m.pt was calibrated on: ")
    assert "height 1.75 m outside their range 1.8–1.9 m" in line
    assert "estimated speed" in line and "100% of windows outside" in line and "mass" not in line
    cal.ranges_from = "training"
    [line] = input_findings(rec, q, cal, "m.pt")
    assert "the recordings m.pt was trained on: " in line
    cal.input_ranges = {"height_m": [1.7, 1.8]}
    assert input_findings(rec, q, cal, "m.pt") == []


def test_a_threshold_from_held_out_recordings_keeps_the_training_inputs_ranges(model, tiny_run):
    """Calibrated on recordings the model never saw, the input ranges are still those of its
    training recordings (``training``), found by the names the model file stores."""
    est = SSPINNpose.load(model)
    data = Dataset.open(tiny_run[1])
    train, test = data.load("train"), data.load("test")
    everything = train + test
    assert [r.name for r in training_recordings(everything, est.trained_on_)] == [r.name for r in train]
    assert training_recordings(test, est.trained_on_) == []  # not all of them there: none
    assert training_recordings(everything, ()) == []
    test = [dataclasses.replace(r, height=1.6) for r in test]  # unlike the training subjects (1.75 m)
    cal, _, _ = calibrate(est.network_, est.segments_, est.imu_std_, est.config_.joint_limits, test,
                          [est.predict(r) for r in test], model, "tiny (test)", training=train)
    assert cal.ranges_from == "training" and cal.calibrated_on == [r.name for r in test]
    assert cal.input_ranges["height_m"] == [1.75, 1.75]
    alone, _, _ = calibrate(est.network_, est.segments_, est.imu_std_, est.config_.joint_limits, test,
                            [est.predict(r) for r in test], model, "tiny (test)")
    assert alone.ranges_from == "calibration" and alone.threshold == cal.threshold
    assert alone.input_ranges["height_m"] == [1.6, 1.6]


def test_infer_writes_the_quality_and_warns(model, tiny_run, tmp_path, capsys):
    data = tiny_run[1]
    assert main(["calibrate-quality", "--model", str(model), "--data", str(data)]) == 0
    assert "calibrated on 2 recordings" in capsys.readouterr().out
    assert calibration_path(model).exists()
    # the same calibration again leaves the file alone; a different one needs --overwrite
    assert main(["calibrate-quality", "--model", str(model), "--data", str(data)]) == 0
    assert "unchanged" in capsys.readouterr().out
    before = calibration_path(model).read_text()
    assert main(["calibrate-quality", "--model", str(model), "--data", str(data), "--split", "train", "test"]) == 2
    assert "--overwrite" in capsys.readouterr().err and calibration_path(model).read_text() == before
    # a recording far from the calibration data: a short, light subject with noisy IMUs
    rec = _noisy(dataclasses.replace(walking_recording(650), name="odd", height=1.5, mass=45.0))
    Dataset.write(tmp_path / "odd", {"test": [rec]})
    assert main(["infer", "--model", str(model), "--data", str(tmp_path / "odd"), "--out", str(tmp_path / "out")]) == 0
    captured = capsys.readouterr()
    assert "no quality calibration" not in captured.out
    warning_lines = [line for line in captured.err.splitlines() if line.startswith("WARNING: odd: ")]
    assert any("flagged as unreliable" in line and "3 of 3 windows (100%)" in line for line in warning_lines), captured.err
    assert any("was trained on: " in line and "height 1.5 m outside their range" in line and "mass 45 kg" in line
               for line in warning_lines), captured.err
    lines = (tmp_path / "out" / "odd_quality.csv").read_text().splitlines()
    header = lines[0].split(",")
    assert header[:3] == ["window", "start_s", "end_s"] and {"imu", "kane", "stance", "score", "flagged"} <= set(header)
    assert len(lines) == 4 and lines[1].split(",")[-1] == "1"
    assert (tmp_path / "out" / "odd_estimate.csv").exists()
    calibration_path(model).unlink()


def test_a_model_without_calibration_still_infers_with_a_note(tiny_run, tmp_path, capsys):
    data = tiny_run[1]
    shutil.copy(tiny_run[4] / "model.pt", tmp_path / "model.pt")
    assert main(["infer", "--model", str(tmp_path / "model.pt"), "--data", str(data), "--out", str(tmp_path / "out")]) == 0
    out = capsys.readouterr().out
    assert sum(line.startswith("NOTE: ") and "no quality calibration" in line for line in out.splitlines()) == 1
    header = (tmp_path / "out" / "c_quality.csv").read_text().splitlines()[0].split(",")
    assert "imu" in header and "score" not in header
    # an explicitly named calibration that is not there is an error, not a silent skip
    assert main(["infer", "--model", str(tmp_path / "model.pt"), "--data", str(data), "--out", str(tmp_path / "o2"),
                 "--quality", str(tmp_path / "missing.json")]) == 2
    assert "missing.json: cannot read the quality calibration" in capsys.readouterr().err


def test_a_recording_shorter_than_a_window_has_one_window(model):
    q = SSPINNpose.load(model).quality(make_recording("short", n=120))
    assert q.n_windows == 1 and q.stop[0] == 120
