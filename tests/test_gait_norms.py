"""Human gait norms: human recordings pass, gaits no person walks or runs like fail the check that
says why (synthetic vertical-GRF arrays with known answers, Winter's walking, Hamner's running)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from sspinn.data.gait_events import phase_fractions, split_taps, stance_fractions
from sspinn.data.gait_norms import check_gait_norms, human_ranges
from sspinn.model.trajectory import Trajectory

SHARED = Path(__file__).resolve().parents[1].parent / "shared" / "data"
RATE = 100.0


def _profile(samples: int, peak: float, double: bool) -> np.ndarray:
    """A stance's vertical GRF (BW) over ``samples``: two humps and a midstance valley (walking,
    valley ≈ 0.66 × peak) or one hump (running), largest value ``peak``, at least 0.12 × ``peak``
    (above the contact threshold from the first to the last sample)."""
    s = (np.arange(samples) + 0.5) / samples
    g = np.sin(np.pi * s) + (0.3 * np.sin(3 * np.pi * s) if double else 0.0)
    return peak * np.maximum(g / g.max(), 0.12)


def _gait(stride_s: float = 1.1, stance: float = 0.6, peak: float = 1.1, double: bool = True, n_strides: int = 6,
          lag: float = 0.5) -> np.ndarray:
    """(N, 2) vertical GRF in BW at :data:`RATE`: each foot down ``stance`` of each stride, the left
    foot ``lag`` of a stride after the right one."""
    period = int(round(stride_s * RATE))
    n = n_strides * period
    out = np.zeros((n + period, 2))
    down = int(round(stance * period))
    for f, shift in enumerate((0, int(round(lag * period)))):
        for k in range(-1, n_strides + 1):  # the left foot's stance before the first sample too: a steady gait
            start = shift + k * period + 5
            profile = _profile(down, peak, double)
            keep = (np.arange(start, start + down) >= 0) & (np.arange(start, start + down) < len(out))
            out[np.arange(start, start + down)[keep], f] = profile[keep]
    return out[:n]


def test_a_human_like_walk_passes_and_its_shares_are_the_constructed_ones() -> None:
    report = check_gait_norms(_gait(), 1.3, rate_hz=RATE)
    assert report.passed and report.fraction_inside == 1.0, report.summary()
    assert report.stance_percent == pytest.approx(60.0, abs=1.0)
    assert report.double_support_percent == pytest.approx(20.0, abs=1.5)  # 2 × (60 − 50) %
    assert report.flight_percent == 0.0 and report.taps == 0
    assert report.cadence_steps_per_min == pytest.approx(60 / 0.55, rel=0.01)
    assert report.peak_bw == pytest.approx(1.1, abs=0.01) and 0.6 <= report.valley_bw <= 0.9
    assert len(report.stances) >= 10 and all(s.passed for s in report.stances)
    assert report.as_dict()["stances"][-1]["stance_percent"] is None  # the last stances begin no complete stride


def test_a_bouncy_walk_fails_the_peak_check() -> None:
    report = check_gait_norms(_gait(peak=1.8), 1.3, rate_hz=RATE)
    assert not report.passed and report.checks["peak"] is False and report.checks["stance"] is True
    assert report.fraction_inside == 0.0 and "peak 1.80 [1–1.35] OUT" in report.summary()


def test_a_walk_with_flight_fails_flight_and_double_support() -> None:
    """Each foot down 45 % of the stride, half a stride apart: 10 % flight, no double support."""
    report = check_gait_norms(_gait(stance=0.45), 1.3, rate_hz=RATE)
    assert report.flight_percent == pytest.approx(10.0, abs=1.5) and report.double_support_percent == 0.0
    assert report.checks["flight"] is False and report.checks["double_support"] is False and not report.passed


def test_a_tapping_swing_foot_is_counted_and_fails() -> None:
    """The swing foot touches the ground for 60 ms right after the other foot lands: taps, not
    steps, so the cadence stays the walk's."""
    grf = _gait()
    for k in range(6):  # the right foot swings from sample 71 to 115 of each 110-sample stride
        grf[k * 110 + 80 : k * 110 + 86, 0] = 0.3
    report = check_gait_norms(grf, 1.3, rate_hz=RATE)
    assert report.taps >= 5 and report.checks["taps"] is False and not report.passed
    assert report.cadence_steps_per_min == pytest.approx(60 / 0.55, rel=0.01)


def test_hopping_on_one_leg_has_no_steps_and_fails() -> None:
    grf = _gait()
    grf[:, 1] = 0.0
    report = check_gait_norms(grf, 1.3, rate_hz=RATE)
    assert report.steps == 0 and report.checks["cadence"] is False and not report.passed


def test_a_run_passes_the_running_ranges_and_fails_the_walking_ones() -> None:
    run = _gait(stride_s=0.7, stance=0.35, peak=2.6, double=False)
    report = check_gait_norms(run, 3.5, "run", rate_hz=RATE)
    assert report.passed, report.summary()
    assert report.flight_percent == pytest.approx(30.0, abs=2.0) and report.double_support_percent == 0.0
    assert not check_gait_norms(run, 1.8, "walk", rate_hz=RATE).passed
    assert not check_gait_norms(_gait(), 3.5, "run", rate_hz=RATE).passed  # a walk is no run


def test_ranges_follow_speed() -> None:
    assert human_ranges(0.8).peak_bw == (0.95, 1.25) and human_ranges(1.8).peak_bw == (1.1, 1.6)
    assert human_ranges(1.55).peak_bw == pytest.approx((1.05, 1.475))
    assert human_ranges(1.3).rmsd_max_deg == (6.0, 8.0, 6.0) and human_ranges(0.8).rmsd_max_deg is None
    assert human_ranges(3.0, "run").peak_bw == (2.2, 3.0) and human_ranges(3.0, "run").valley_bw is None


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"data": np.zeros((10, 3)), "speed_m_s": 1.3, "rate_hz": 100.0}, r"must be \(N, 2\)"),
    ({"data": np.full((10, 2), np.nan), "speed_m_s": 1.3, "rate_hz": 100.0}, "non-finite value at row 0"),
    ({"data": np.zeros((10, 2)), "speed_m_s": 1.3}, "rate_hz must be"),
    ({"data": np.zeros((10, 2)), "speed_m_s": 9.0, "rate_hz": 100.0}, "outside the walk norms"),
    ({"data": np.zeros((10, 2)), "speed_m_s": 1.3, "mode": "hop", "rate_hz": 100.0}, "mode must be"),
])
def test_bad_input_gives_one_line_errors(kwargs, message) -> None:
    with pytest.raises(ValueError, match=message):
        check_gait_norms(**kwargs)


def test_phase_fractions_is_the_one_share_computation() -> None:
    r = np.array([1, 1, 1, 0, 0, 0, 0, 1], bool)
    l = np.array([0, 1, 0, 0, 1, 1, 0, 0], bool)
    f = phase_fractions(r, l)
    assert (f.stance_r, f.stance_l, f.double_support, f.flight) == (0.5, 0.375, 0.125, 0.25)
    assert stance_fractions(r * 1.0, l * 1.0) == {"stance_r": 0.5, "stance_l": 0.375, "double_support": 0.125, "flight": 0.25}
    with pytest.raises(ValueError, match="one length"):
        phase_fractions(r, l[:-1])


def test_taps_are_short_against_the_typical_contact() -> None:
    mask = np.zeros(300, bool)
    mask[10:60] = mask[110:160] = mask[210:260] = True  # stances of 0.5 s at 100 Hz
    mask[80:86] = True  # a 60 ms tap
    right, = split_taps([mask], 100.0)
    assert right.taps == ((80, 86),) and list(right.heel_strikes) == [10, 110, 210]
    assert not right.stance[80:86].any()


def _winter_walk():
    if not (SHARED / "winter_walking").is_dir():
        pytest.skip("../shared/data/winter_walking is not available")
    from sspinn.data.gait_metrics import load_winter

    winter = load_winter(SHARED)
    data = np.genfromtxt(SHARED / "winter_walking" / "signals.csv", delimiter=",", names=True)
    return winter, data


def test_winter_walking_passes_with_its_angles() -> None:
    winter, data = _winter_walk()
    rate = len(data) / winter.duration
    grf_bw = np.tile(np.stack([data["grf_x_r"], data["grf_y_r"], data["grf_x_l"], data["grf_y_l"]], axis=1), (4, 1))
    report = check_gait_norms(grf_bw, winter.speed, rate_hz=rate)
    assert report.passed and report.fraction_inside == 1.0, report.summary()
    n = len(grf_bw)
    q = np.zeros((n, 9))
    for j, name in enumerate(("hip_flexion", "knee_angle", "ankle_angle")):
        q[:, 3 + j], q[:, 6 + j] = np.tile(data[f"{name}_r_angle"], 4), np.tile(data[f"{name}_l_angle"], 4)
    body_weight = 56.7 * 9.81
    trajectory = Trajectory(time=np.arange(n) / rate, q=q, u=np.zeros((n, 9)), qdd=np.zeros((n, 9)), tau=np.zeros((n, 6)),
                            grf=grf_bw * body_weight, w=np.full((n, 2), 0.5))
    with_angles = check_gait_norms(trajectory, winter.speed, body_weight_n=body_weight, reference=winter)
    assert with_angles.passed and with_angles.rmsd_knee_deg < 5.0 and with_angles.checks["rmsd_knee"] is True
    q[:, [4, 7]] += np.radians(10.0)  # knees 10° straighter throughout
    stiff = check_gait_norms(Trajectory(**{**trajectory.__dict__, "q": q}), winter.speed, body_weight_n=body_weight,
                             reference=winter)
    assert stiff.checks["rmsd_knee"] is False and not stiff.passed
    with pytest.raises(ValueError, match="body_weight_n"):
        check_gait_norms(trajectory, winter.speed)


def test_hamner_running_passes_the_running_ranges() -> None:
    folder = SHARED / "opensim_hamner_run"
    if not folder.is_dir():
        pytest.skip("../shared/data/opensim_hamner_run is not available")
    from sspinn.data.opensim_files import read_opensim_columns

    grf = read_opensim_columns(folder / "subject02_running_grf.mot")
    vertical = np.stack([grf.column("ground_force_vy"), grf.column("1_ground_force_vy")], axis=1) / (65.9 * 9.81)
    rate = 1.0 / float(np.median(np.diff(grf.column("time"))))
    report = check_gait_norms(vertical, 3.5, "run", rate_hz=rate)  # the running ranges are one row for 2.5–4.5 m/s
    assert report.passed and report.fraction_inside >= 0.9 and len(report.stances) >= 20, report.summary()
    assert not check_gait_norms(vertical, 1.8, "walk", rate_hz=rate).passed
