"""Unit tests of :mod:`sspinn.data.signal_checks` that need no real data: the estimate checks, how
the CLIs print the warnings, and that checking changes nothing (the property-based detection
tests on real walking are in ``test_signal_checks_property.py``)."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from sspinn.data.dataset import Recording
from sspinn.data.signal_checks import (
    ImpossibleSignalError,
    SignalWarning,
    check_recording,
    estimate_findings,
    gait_rhythm,
    recording_findings,
)
from sspinn.errors import run_cli
from sspinn.model.body import IMUPlacement
from sspinn.model.conventions import GRAVITY, SEGMENTS
from sspinn.testing import walking_recording
from sspinn.testing.sensor_mounting import read_gait_csv, synthetic_walk

GAIT = Path(__file__).resolve().parent / "fixtures" / "predicted_walk_1.3.csv"


@pytest.fixture(scope="module")
def walk() -> Recording:
    """A predicted 1.3 m/s walk as virtual IMUs: 2 s standing + 12 strides."""
    gait = read_gait_csv(GAIT)
    imu = synthetic_walk(gait.q, gait.u, gait.qdd, strides=12, standing_s=2.0)
    return Recording(name="walk", imu=imu, segments=SEGMENTS, height=1.75, mass=70.0, placement=IMUPlacement.default(1.75))


def test_predicted_walk_is_silent_and_its_stride_found(walk):
    gait = read_gait_csv(GAIT)
    rhythm = gait_rhythm(walk.imu, walk.segments)
    assert rhythm is not None and rhythm.period_s == pytest.approx(len(gait.q) / 100.0, abs=0.02)  # one stride of the file
    assert recording_findings(walk, "walk") == []


def test_short_or_still_recordings_are_not_judged():
    assert gait_rhythm(walking_recording().imu, SEGMENTS) is None  # 3 s: shorter than four slow strides
    still = walking_recording(n=1000)
    still.imu[:, :, 2] = 0.01 * np.random.default_rng(0).normal(size=(1000, 7))
    assert gait_rhythm(still.imu, SEGMENTS) is None


def test_estimate_with_too_little_vertical_force_or_an_implausible_speed_warns(walk):
    n = walk.n_samples
    weight = walk.mass * GRAVITY
    ok = estimate_findings("walk", np.full(n, weight), np.full(n, 1.3), walk.imu, walk.segments, walk.height, walk.mass)
    assert ok == []
    light = estimate_findings("walk", np.full(n, 0.1 * weight), np.full(n, 1.3), walk.imu, walk.segments, walk.height, walk.mass)
    assert len(light) == 1 and "averages 0.10 body weights" in light[0]
    fast = estimate_findings("walk", np.full(n, weight), np.full(n, 6.0), walk.imu, walk.segments, walk.height, walk.mass)
    assert len(fast) == 1 and "the estimated speed 6.00 m/s" in fast[0] and "Alexander" in fast[0]


def test_negated_accelerometers_everywhere_are_an_error(walk):
    imu = walk.imu.copy()
    imu[:, :, :2] *= -1
    bad = Recording(name="neg", imu=imu, segments=walk.segments, height=1.75, mass=70.0, placement=walk.placement)
    with pytest.raises(ImpossibleSignalError, match="the accelerometers are negated"):
        recording_findings(bad, "neg.csv")


def test_checking_changes_nothing_and_warns_once(walk):
    imu = walk.imu.copy()
    imu[:, walk.segments.index("tibia_l"), 2] *= -1
    rec = Recording(name="flip", imu=imu, segments=walk.segments, height=1.75, mass=70.0, placement=walk.placement)
    before = rec.imu.copy()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_recording(rec, "flip.csv")
        check_recording(rec, "flip.csv")  # the same array again: not re-checked
    assert np.array_equal(rec.imu, before)
    assert [w.category for w in caught] == [SignalWarning]
    assert "flip.csv: the left-leg sensors do not move like one leg" in str(caught[0].message)


def test_cli_prints_signal_warnings_as_one_warning_line(capsys):
    def main(argv: list[str]) -> int:
        warnings.warn("rec.csv: sensor foot_l is not on a moving body", SignalWarning, stacklevel=1)
        return 0

    assert run_cli(main, "sspinn", []) == 0
    assert capsys.readouterr().err == "WARNING: rec.csv: sensor foot_l is not on a moving body\n"


def _edited(walk: Recording, imu: np.ndarray | None = None, speed: float | None = None) -> Recording:
    from sspinn.data.dataset import Labels

    labels = None if speed is None else Labels.from_columns({"speed": np.full(walk.n_samples, speed)}, walk.n_samples)
    return Recording(name="walk", imu=walk.imu if imu is None else imu, segments=walk.segments, height=walk.height,
                     mass=walk.mass, placement=walk.placement, labels=labels)


def test_scaled_accelerometers_biased_gyroscopes_and_a_turned_leg_are_named(walk):
    from sspinn.data.signal_checks import label_findings

    scaled = walk.imu.copy()
    scaled[:, :, :2] *= 1.5
    found = recording_findings(_edited(walk, scaled), "walk")
    assert any("the accelerometer looks scaled by 1.5" in f for f in found), found
    biased = walk.imu.copy()
    biased[:, :, 2] += 0.5
    found = recording_findings(_edited(walk, biased), "walk")
    assert any("every gyroscope looks biased" in f for f in found), found
    turned = walk.imu.copy()
    for s in ("femur_l", "tibia_l", "foot_l"):
        turned[:, SEGMENTS.index(s), 0] *= -1
        turned[:, SEGMENTS.index(s), 2] *= -1
    found = recording_findings(_edited(walk, turned), "walk")
    assert any("the right and left legs swing in phase" in f for f in found), found
    # a speed label against the cadence: the walk's own 1.3 m/s is silent, 13 m/s is not
    assert label_findings(_edited(walk, speed=1.3), "walk") == []
    found = label_findings(_edited(walk, speed=13.0), "walk")
    assert len(found) == 1 and "the speed label looks wrong" in found[0], found


def test_a_placement_angle_beyond_pi_is_refused_as_degrees(tmp_path):
    import json

    from sspinn.data.dataset import DataFormatError

    csv = walking_recording(n=300).save(tmp_path)
    sidecar = csv.with_suffix(".json")
    meta = json.loads(sidecar.read_text())
    meta["imu"]["placement"]["tibia_r"]["angle_rad"] = 12.0
    sidecar.write_text(json.dumps(meta))
    with pytest.raises(DataFormatError, match=r"imu.placement.tibia_r.angle_rad 12: beyond ±π rad — in degrees\?"):
        Recording.load(csv)
