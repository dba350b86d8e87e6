"""Turns while walking: found in the pelvis sensor's yaw rate, left out of the calibration, and
marked in an imported recording."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from sspinn.imu.calibration import calibrate
from sspinn.imu.sensor_map import SensorAssignment
from sspinn.imu.turns import MIN_TURN_DEG, detect_turns, turn_findings, turning_mask
from sspinn.model.conventions import SEGMENTS
from sspinn.testing import walking_recording
from sspinn.testing.sensor_mounting import OutOfPlane, embed_in_3d, random_mounting, read_gait_csv, synthetic_walk

GAIT = Path(__file__).resolve().parent / "fixtures" / "predicted_walk_1.3.csv"
RATE = 100.0


def _turn_rate(n: int, centre_s: float, duration_s: float, degrees: float) -> np.ndarray:
    """A raised-cosine yaw-rate pulse (rad/s, (n,)) turning by ``degrees`` over ``duration_s``."""
    t = np.arange(n) / RATE
    phase = np.clip((t - centre_s + duration_s / 2) / duration_s, 0.0, 1.0)
    pulse = np.where((phase > 0) & (phase < 1), 1 - np.cos(2 * np.pi * phase), 0.0)
    return np.radians(degrees) * pulse / duration_s


def _pelvis_gyr(yaw: np.ndarray, up: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """A pelvis gyroscope: ``yaw`` about ``up``, a large rate about a horizontal axis (the step's
    tilt and roll) and noise."""
    side = np.cross(up, [0.3, 0.5, 0.8])
    side /= np.linalg.norm(side)
    t = np.arange(len(yaw)) / RATE
    return yaw[:, None] * up + (1.5 * np.sin(2 * np.pi * t / 0.55))[:, None] * side + rng.normal(scale=0.02, size=(len(yaw), 3))


def test_a_turn_is_found_and_the_step_oscillation_is_not() -> None:
    rng = np.random.default_rng(0)
    n, period = 2000, 1.1
    up = rng.normal(size=3)
    up /= np.linalg.norm(up)
    steps = np.radians(30.0) * np.sin(2 * np.pi * np.arange(n) / RATE / period)  # ±30°/s each stride: no turn
    [turn] = detect_turns(_pelvis_gyr(steps + _turn_rate(n, 10.0, 2.5, 180.0), up, rng), up * 9.81, RATE, period)
    assert turn.heading_change_deg == pytest.approx(180.0, abs=8.0) and turn.peak_rate_deg_s > 60
    assert 8.0 <= turn.start / RATE <= 9.0 and 11.0 <= turn.stop / RATE <= 12.0
    [right] = detect_turns(_pelvis_gyr(steps - _turn_rate(n, 10.0, 2.5, 90.0), up, rng), up, RATE, period)
    assert right.heading_change_deg == pytest.approx(-90.0, abs=8.0)
    assert f"(heading {right.heading_change_deg:+.0f}°, up to" in right.describe(RATE)
    assert detect_turns(_pelvis_gyr(steps, up, rng), up, RATE, period) == []
    drift = steps + np.radians(1.0)  # a walking direction drifting 1°/s, or an uncorrected gyroscope bias
    assert detect_turns(_pelvis_gyr(drift, up, rng), up, RATE, period) == []
    small = steps + _turn_rate(n, 10.0, 1.0, 0.8 * MIN_TURN_DEG)  # quick, but too small to count
    assert detect_turns(_pelvis_gyr(small, up, rng), up, RATE, period) == []


def test_calibration_leaves_a_turn_out_and_names_it() -> None:
    gait = read_gait_csv(GAIT)
    rng = np.random.default_rng(5)
    imu2d = synthetic_walk(gait.q, gait.u, gait.qdd, strides=20, standing_s=2.0)
    mountings = {s: random_mounting(rng) for s in SEGMENTS}
    signals = {s: embed_in_3d(imu2d[:, i], mountings[s], rng, OutOfPlane(), still=200) for i, s in enumerate(SEGMENTS)}
    assignments = {s: SensorAssignment(f"s_{s}", s) for s in SEGMENTS}
    straight = calibrate(signals, assignments)
    assert straight.turns == [] and not any("turning" in w for w in straight.warnings)
    acc, gyr = signals["pelvis"]
    up = mountings["pelvis"] @ np.array([0.0, 1.0, 0.0])  # the HAT's long axis, nearly vertical while walking
    turned = calibrate({**signals, "pelvis": (acc, gyr + _turn_rate(len(gyr), 10.0, 2.5, -180.0)[:, None] * up)}, assignments)
    [turn] = turned.turns
    assert turn.heading_change_deg == pytest.approx(-180.0, abs=15.0)
    assert all(b <= turn.start or a >= turn.stop for a, b in turned.walking_runs)  # left out of the walking
    assert turned.walking_s < straight.walking_s - 2.0
    assert sum("turning at" in w and "heading -1" in w for w in turned.warnings) == 1


def test_turning_mask_reads_the_import_provenance() -> None:
    plain = walking_recording(500)
    rec = dataclasses.replace(plain, provenance={"start_s_in_files": 2.0, "turning_s": [[2.5, 3.0, 170.0], [6.5, 9.0, -90.0]]})
    mask = turning_mask(rec)
    assert mask.sum() == 50 + 50 and mask[50:100].all() and mask[450:].all() and not mask[:50].any()
    assert not turning_mask(plain).any()


def test_infer_names_the_turns_of_an_imported_recording(tiny_run, tmp_path, capsys) -> None:
    from sspinn.cli import main
    from sspinn.data.dataset import Dataset

    rec = dataclasses.replace(walking_recording(500), name="turned",
                              provenance={"start_s_in_files": 2.0, "turning_s": [[2.5, 3.0, -170.0]]})
    [line] = turn_findings(rec)
    assert line.startswith("turned: turning at 0.50–1.00 s (heading -170°)")
    assert turn_findings(walking_recording(500)) == []
    Dataset.write(tmp_path / "data", {"test": [rec]})
    model = tiny_run[4] / "model.pt"
    assert main(["infer", "--model", str(model), "--data", str(tmp_path / "data"), "--out", str(tmp_path / "out")]) == 0
    assert "WARNING: turned: turning at 0.50–1.00 s" in capsys.readouterr().err


def test_evaluate_names_the_spans_whose_labels_do_not_measure_the_gait() -> None:
    from sspinn.estimator.evaluation import unreliable_label_findings

    rec = dataclasses.replace(walking_recording(500), name="odd", provenance={
        "start_s_in_files": 1.0, "turning_s": [[0.5, 1.5, 90.0]], "grf_misaligned_s": [[4.0, 9.0, 0.17]]})
    [line] = unreliable_label_findings([rec, walking_recording(500)])
    assert line.startswith("odd: turning (a sagittal model does not describe a turn) at 0.0–0.5 s; GRF labels off in time")
    assert "at 3.0–5.0 s: its metrics include these samples" in line  # clipped to the recording's 5 s
    assert rec.provenance_spans("grf_misaligned_s") == [(3.0, 5.0, (0.17,))]


def test_training_windows_leave_the_turns_out() -> None:
    """No training window overlaps a turn the import found; a recording without turns is
    sampled with the same random draws as before (same windows, same seed)."""
    from sspinn.estimator.training import WindowSampler, prepare

    plain = walking_recording(600)
    turned = dataclasses.replace(walking_recording(600), name="turned",
                                 provenance={"start_s_in_files": 0.0, "turning_s": [[1.0, 3.0, 120.0]]})
    data = prepare([plain, turned], plain.segments, zupt=False)
    sampler = WindowSampler(data, 64, np.random.default_rng(0))
    which, starts = sampler.sample(4000)
    for k, s in zip(which, starts):
        if k == 1:
            assert s + 64 <= 100 or s >= 300, s
    assert sampler.prob[1] == pytest.approx((600 - 64 + 1 - (300 - 100 + 63)) / (2 * (600 - 64 + 1) - (300 - 100 + 63)))
    rng_a, rng_b = np.random.default_rng(7), np.random.default_rng(7)
    alone = WindowSampler(prepare([plain], plain.segments, zupt=False), 64, rng_a).sample(50)
    expected = [int(rng_b.integers(0, 600 - 64 + 1)) for _ in rng_b.choice(1, size=50, p=[1.0])]
    assert alone[1] == expected
    blocked = dataclasses.replace(turned, provenance={"turning_s": [[0.0, 6.0, 180.0]]})
    with pytest.raises(ValueError, match="turned: no 64-sample window outside its turns"):
        WindowSampler(prepare([blocked], plain.segments, zupt=False), 64, np.random.default_rng(0))
