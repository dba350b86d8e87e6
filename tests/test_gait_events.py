"""Gait events from vertical GRF, their timing error, and the GRF-profile baseline."""

from __future__ import annotations

import numpy as np
import pytest

from sspinn.data.dataset import Labels, Recording
from sspinn.data.gait_events import contact_mask, detect_events, event_timing
from sspinn.estimator.trivial_predictors import GRFProfilePredictor, TrivialPredictor
from sspinn.model.conventions import GRAVITY, SEGMENTS

RATE = 100.0


def stance_force(n: int, period: int, stance: int, shift: int, weight: float) -> np.ndarray:
    """A vertical GRF: a half-sine bump of ``stance`` samples every ``period`` samples."""
    t = (np.arange(n) - shift) % period
    return np.where(t < stance, weight * np.sin(np.pi * t / stance), 0.0)


def test_events_are_found_and_chatter_is_ignored() -> None:
    f = stance_force(1000, 100, 60, 10, 700.0)
    ev = detect_events(f, 700.0, RATE)
    # 10 % BW of a half sine of 60 samples is crossed 2 samples after its start and before its end
    np.testing.assert_array_equal(ev.heel_strikes, np.arange(12, 1000, 100))
    np.testing.assert_array_equal(ev.toe_offs, np.arange(69, 1000, 100))
    chattering = f.copy()
    chattering[[450, 452, 454]] = 100.0  # spikes in swing, each one sample
    chattering[140:142] = 0.0  # a 2-sample dropout in stance
    again = detect_events(chattering, 700.0, RATE)
    np.testing.assert_array_equal(again.heel_strikes, ev.heel_strikes)
    np.testing.assert_array_equal(again.toe_offs, ev.toe_offs)
    assert not detect_events(chattering, 700.0, RATE, min_phase_s=0.0).heel_strikes.size == ev.heel_strikes.size


def test_contact_mask_keeps_phases_cut_by_the_edges() -> None:
    on = np.r_[np.ones(3), np.zeros(20), np.ones(20), np.zeros(3)]
    np.testing.assert_array_equal(contact_mask(on, 0.5, 5), on.astype(bool))


def test_event_timing() -> None:
    ref = np.array([100, 200, 300, 400])
    t = event_timing(ref + 3, ref, RATE, 0.3)
    assert t.mean_abs_ms == pytest.approx(30.0) and t.bias_ms == pytest.approx(30.0) and t.matched == 4
    early_and_missing = event_timing(np.array([98, 198, 298]), ref, RATE, 0.05)
    assert early_and_missing.bias_ms == pytest.approx(-20.0) and early_and_missing.matched == 3
    assert np.isnan(event_timing(np.array([], dtype=int), ref, RATE, 0.3).mean_abs_ms)


def grf_recording(name: str, period: int, mass: float, n: int = 1500) -> Recording:
    w = mass * GRAVITY
    right, left = stance_force(n, period, int(0.6 * period), 0, w), stance_force(n, period, int(0.6 * period), period // 2, w)
    horizontal = lambda v: -0.1 * np.gradient(v) * period / np.pi  # noqa: E731 - braking then propulsion
    labels = Labels.from_columns({"grf_x_r": horizontal(right), "grf_y_r": right, "grf_x_l": horizontal(left),
                                  "grf_y_l": left, "speed": np.full(n, 1.0)}, n)
    imu = np.random.default_rng(0).normal(scale=0.1, size=(n, len(SEGMENTS), 3))
    imu[:, :, 1] += GRAVITY
    return Recording(name=name, imu=imu, segments=SEGMENTS, height=1.75, mass=mass, labels=labels)


def test_grf_profile_follows_the_measured_strides() -> None:
    train = [grf_recording("a", 100, 60.0), grf_recording("b", 110, 80.0)]
    profile = GRFProfilePredictor.fit(train, "test")
    assert profile.strides >= 10 and profile.profile.shape == (2, 101, 2)
    test = grf_recording("c", 125, 70.0)  # slower strides, another body weight: the shape in BW still fits
    est = profile.predict_grf(test)
    ref = test.labels.grf
    inner = slice(200, 1300)
    err = np.sqrt(np.mean((est[inner] - ref[inner]) ** 2)) / (70.0 * GRAVITY)
    const = TrivialPredictor.fit(train, "test").predict(test).grf
    err_const = np.sqrt(np.mean((const[inner] - ref[inner]) ** 2)) / (70.0 * GRAVITY)
    assert err < 0.05 and err_const > 0.25
    with pytest.raises(ValueError, match="no complete stride"):
        GRFProfilePredictor.fit([Recording(name="x", imu=test.imu, segments=SEGMENTS, height=1.75, mass=70.0)], "empty")


def test_heel_strike_timing_of_an_estimate() -> None:
    from sspinn.estimator.evaluation import heel_strike_timing

    rec = grf_recording("a", 100, 70.0, n=1000)
    late = np.roll(rec.labels.grf, 4, axis=0)  # every event 40 ms late
    ms, matched = heel_strike_timing(late, rec.labels, slice(0, None), 70.0 * GRAVITY)
    assert ms == pytest.approx(40.0) and matched == 1.0
    mirrored = np.roll(rec.labels.grf, 50, axis=0)  # right and left swapped: half a stride off
    ms, matched = heel_strike_timing(mirrored[:, [2, 3, 0, 1]], rec.labels, slice(0, None), 70.0 * GRAVITY)
    assert ms == pytest.approx(0.0, abs=10.0)  # the swap itself is what the shift undoes
    ms, matched = heel_strike_timing(mirrored, rec.labels, slice(0, None), 70.0 * GRAVITY)
    assert np.isnan(ms) and matched == 0.0  # stance on the wrong foot: nothing within 0.3 s


def test_contact_onsets_raw_and_periodic() -> None:
    from sspinn.data.gait_events import contact_onsets, stance_fractions

    fy = np.array([0.5, 0.5, 0.0, 0.0, 0.5, 0.5, 0.0, 0.5])
    assert contact_onsets(fy).tolist() == [4, 7]  # a signal loaded from its first sample has no onset there
    assert contact_onsets(fy, periodic=True).tolist() == [4, 7]
    wrap = np.array([0.5, 0.5, 0.0, 0.0])
    assert contact_onsets(wrap, periodic=True).tolist() == [0]  # the cycle's last sample precedes its first
    assert contact_onsets(wrap, threshold_bw=0.6, periodic=True).tolist() == []
    st = stance_fractions(fy, fy[::-1])
    assert st["stance_r"] == 0.625 and st["double_support"] + st["flight"] <= 1.0


def test_foot_imu_heel_strikes_are_the_rate_minima_after_each_swing_peak():
    from sspinn.data.gait_events import foot_imu_heel_strikes

    rate, stride = 100.0, 110
    t = np.arange(stride)
    one = np.zeros(stride)
    one[20:60] = 4.0 * np.sin(np.pi * (t[20:60] - 20) / 40)  # swing: the toe rises, the foot swings
    one[60:70] = -3.0 * np.sin(np.pi * (t[60:70] - 60) / 10)  # the foot slaps flat: minimum at 65
    gyr = np.tile(one, 6) + np.random.default_rng(0).normal(scale=0.05, size=6 * stride)
    found = foot_imu_heel_strikes(gyr, rate)
    assert len(found) == 6 and np.abs(found - (65 + stride * np.arange(6))).max() <= 1  # noise may move it a sample
    with pytest.raises(ValueError, match="finite 1-D"):
        foot_imu_heel_strikes(np.array([0.0, np.nan]), rate)


def test_the_grf_profile_follows_the_heel_strikes_it_is_given():
    from sspinn.testing import make_recording

    profile = GRFProfilePredictor(np.ones((2, 101, 2)) * np.linspace(0, 1, 101)[None, :, None], np.zeros(4), 3, "test")
    rec = make_recording("r", "s", 300)
    grf = profile.predict_grf(rec, [np.array([50, 150]), np.array([100, 200])]) / (rec.mass * 9.81)
    assert grf[50, 1] == pytest.approx(0.0) and grf[149, 1] == pytest.approx(0.99, abs=0.01)
    assert grf[100, 3] == pytest.approx(0.0) and grf[40, 1] == 0.0  # outside a stride: the constant mean


def test_standing_is_both_feet_down_for_half_a_second() -> None:
    from sspinn.data.gait_events import standing_mask

    weight = 700.0
    walk_r = stance_force(600, 100, 62, 0, weight)  # walking: double support 12 samples at a time
    walk_l = stance_force(600, 100, 62, 50, weight)
    grf = np.zeros((800, 4))
    grf[:200, 1] = grf[:200, 3] = weight / 2  # 2 s of standing, then walking
    grf[200:, 1], grf[200:, 3] = walk_r, walk_l
    standing = standing_mask(grf, weight, RATE)
    assert standing[:200].all() and not standing[215:].any()  # the first step's double support ends it
    n = standing.sum()
    grf[:40, 3] = 0.0  # standing on one foot first: 0.4 s less on both
    assert standing_mask(grf, weight, RATE).sum() == n - 40
    with pytest.raises(ValueError, match="grf must be"):
        standing_mask(grf[:, :2], weight, RATE)
