"""Time alignment of an IMU stream with GRF: the normalised cross-correlation, a synthetic pair
with a known lag (variable strides, standing before and after), the walking direction of the
force axis, and one real CMU treadmill trial."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from sspinn.imu.time_alignment import (
    AMBIGUOUS_RATIO,
    SWAPPED_SIDES_RATIO,
    AlignmentError,
    align_to_grf,
    files_share_clock,
    normalized_xcorr,
    walking_direction_sign,
)
from sspinn.model.body import BodyParameters, IMUPlacement
from sspinn.model.conventions import SEGMENTS
from sspinn.model.kinematics import virtual_imu
from sspinn.testing.sensor_mounting import read_gait_csv
from tests.conftest import shared_data

GAIT = Path(__file__).resolve().parent / "fixtures" / "predicted_walk_1.3.csv"


def test_normalized_xcorr_matches_brute_force(rng) -> None:
    ref, sig = rng.normal(size=300), rng.normal(size=220)
    lags, c = normalized_xcorr(ref, sig, max_lag=60, min_overlap=50)
    for lag, value in zip(lags, c):
        i = np.arange(max(0, -lag), min(len(sig), len(ref) - lag))
        assert value == pytest.approx(np.corrcoef(sig[i], ref[i + lag])[0, 1], abs=1e-9)
    shifted = np.concatenate([rng.normal(size=37), sig, rng.normal(size=43)])  # sig[i] = shifted[i + 37]
    lags, c = normalized_xcorr(shifted, sig, max_lag=80, min_overlap=100)
    assert lags[np.nanargmax(c)] == 37 and np.nanmax(c) == pytest.approx(1.0)


def synthetic_pair(rng: np.random.Generator, strides: int = 30, stand_s: float = 3.0):
    """A continuous walk on one timeline (standing, strides of varying duration, standing): foot
    rate norms, shank specific force (3D) and vertical GRF per side, and the summed rate norms."""
    gait = read_gait_csv(GAIT)
    body = BodyParameters.from_anthropometry(1.75, 70.0)
    imu = virtual_imu(gait.q, gait.u, gait.qdd, IMUPlacement.default(1.75), body.vector())
    n = len(gait.q)
    parts = {"imu": [], "grf": []}
    for _ in range(strides):
        m = int(round(n * (1 + 0.03 * rng.standard_normal())))
        x = np.linspace(0, n, m, endpoint=False)
        parts["imu"].append(np.stack([[np.interp(x, np.arange(n + 1), np.append(imu[:, s, c], imu[0, s, c]))
                                       for c in range(3)] for s in range(7)]).transpose(2, 0, 1))
        parts["grf"].append(np.stack([np.interp(x, np.arange(n + 1), np.append(gait.grf[:, k], gait.grf[0, k]))
                                      for k in range(4)], axis=1))
    k = int(stand_s * 100)
    still = np.zeros((k, 7, 3))
    still[:, :, 1] = 9.81
    half = np.tile([0.0, 343.0, 0.0, 343.0], (k, 1))
    imu_all = np.concatenate([still, *parts["imu"], still]) + rng.normal(scale=0.02, size=(1, 1, 1))
    imu_all = imu_all + rng.normal(scale=0.02, size=imu_all.shape)
    grf_all = np.concatenate([half, *parts["grf"], half]) + rng.normal(scale=2.0, size=(1, 4))
    i = {s: SEGMENTS.index(s) for s in SEGMENTS}
    shank3d = {side: np.column_stack([imu_all[:, i[f"tibia_{side}"], :2], np.zeros(len(imu_all))]) for side in "rl"}
    foot_rate = {side: np.abs(imu_all[:, i[f"foot_{side}"], 2]) for side in "rl"}
    return foot_rate, shank3d, {"r": grf_all[:, 1], "l": grf_all[:, 3]}, np.abs(imu_all[:, :, 2]).sum(axis=1), grf_all


def test_a_jump_of_the_lag_is_found_and_its_span_returned(rng) -> None:
    """The GRF loses 0.2 s of samples after 40 s (a clock jump): the rest of the recording fits
    0.2 s away from the lag used; a warning names the span, which the alignment returns."""
    foot, shank, vertical, activity, _ = synthetic_pair(rng, strides=60)
    a, n_imu = 150, len(activity) - 400
    crop = slice(a, a + n_imu)
    jumped = {s: np.concatenate([v[:a + 4000], v[a + 4020:]]) for s, v in vertical.items()}
    args = ({s: v[crop] for s, v in foot.items()}, {s: v[crop] for s, v in shank.items()})
    clean = align_to_grf(*args, vertical, activity[crop], 1.14, max_lag_s=10.0)
    assert clean.lag_jumps == () and not clean.warnings and clean.to_dict()["lag_jumps"] == []
    result = align_to_grf(*args, jumped, activity[crop], 1.14, max_lag_s=10.0)
    assert result.lag_s == pytest.approx(a / 100, abs=0.021)  # most of the recording sets the lag
    [(start, stop, offset)] = result.lag_jumps
    assert offset == pytest.approx(-0.2, abs=0.03) and stop == n_imu and 3700 <= start <= 4300
    assert sum("the lag between the IMU and the GRF jumps" in w for w in result.warnings) == 1


def test_synthetic_pair_with_a_known_lag(rng) -> None:
    foot, shank, vertical, activity, _ = synthetic_pair(rng)
    a, b, n_imu = 237, 0, len(activity) - 400  # the IMU starts 2.37 s after the GRF and stops earlier
    crop = slice(a, a + n_imu)
    result = align_to_grf({s: v[crop] for s, v in foot.items()}, {s: v[crop] for s, v in shank.items()},
                          {s: v[b:] for s, v in vertical.items()}, activity[crop], 1.14, max_lag_s=10.0)
    assert result.lag_s == pytest.approx((a - b) / 100, abs=0.021)
    best, runner = result.best, result.runner_up
    assert best.activity > 0.8 and best.loading > 0.5 and best.impact > 0.5  # standing before and after: activity helps
    assert abs(abs(runner.lag_s - best.lag_s) - 1.14) < 0.2 and result.ratio > 1.05  # periodic: a stride away
    assert "t_reference = t_imu + lag_s" in str(result.to_dict()) and "lag +2.37 s" in result.describe()
    assert not result.warnings and all(abs(v - result.lag_s) < 0.03 for v in result.side_lags.values())
    assert result.swapped_sides_score < result.best.score  # the side check ran and the sides fit


def _align_crop(foot, shank, vertical, activity, a: int = 237):
    """The synthetic pair's IMU signals cropped to start ``a`` samples after the GRF, aligned."""
    crop = slice(a, a + len(activity) - 400)
    return align_to_grf({s: v[crop] for s, v in foot.items()}, {s: v[crop] for s, v in shank.items()}, vertical,
                        activity[crop], 1.14, max_lag_s=10.0)


def test_ambiguous_lag_is_a_warning_naming_both_lags() -> None:
    """No standing, no start or end of walking: the lag is only known up to whole strides."""
    foot, shank, vertical, activity, _ = synthetic_pair(np.random.default_rng(1), strides=20, stand_s=0.0)
    result = _align_crop(foot, shank, vertical, activity)
    assert result.ratio < AMBIGUOUS_RATIO
    (warning,) = result.warnings
    assert warning.startswith(f"the time alignment is ambiguous: lags {result.lag_s:+.2f} s (score {result.best.score:.3f}, used) "
                              f"and {result.runner_up.lag_s:+.2f} s (score {result.runner_up.score:.3f})")
    assert result.to_dict()["warnings"] == [warning]


def test_force_channels_offset_or_swapped_are_warned(rng) -> None:
    foot, shank, vertical, activity, _ = synthetic_pair(rng)
    late = {"r": vertical["r"], "l": np.concatenate([np.full(20, vertical["l"][0]), vertical["l"][:-20]])}  # left 0.2 s late
    result = _align_crop(foot, shank, late, activity)
    assert result.side_lags["l"] - result.side_lags["r"] == pytest.approx(0.2, abs=0.03)
    assert any(w.startswith(f"the right and left force channels look offset in time: the right foot's stance aligns at lag "
                            f"{result.side_lags['r']:+.2f} s, the left at {result.side_lags['l']:+.2f} s") for w in result.warnings)
    swapped = _align_crop(foot, shank, {"r": vertical["l"], "l": vertical["r"]}, activity)
    # without a shared clock a swap hides as half a stride of lag: warned as either
    assert abs(abs(swapped.lag_s - 2.37) - 0.57) < 0.05
    (warning,) = [w for w in swapped.warnings if w.startswith("right and left may be swapped between the GRF file and the IMUs, "
                                                              "or the lag off by half a stride")]
    assert "+2.37 s" in warning  # exchanged back: the true lag


def _crop(foot, shank, activity, a: int = 237):
    crop = slice(a, a + len(activity) - 400)
    return {s: v[crop] for s, v in foot.items()}, {s: v[crop] for s, v in shank.items()}, activity[crop]


@pytest.mark.parametrize("shift", [0.0, -0.2, 0.2], ids=["at the clock", "0.2 stride early", "0.2 stride late"])
def test_swapped_sides_are_caught_where_half_a_stride_of_lag_would_hide_them(rng, shift) -> None:
    """The GRF's sides exchanged: a lag search finds the half-stride alias (the exchanged forces
    line up there); with the files' shared clock both assignments are fitted in the same window
    of ±¼ stride around it, the exchanged one wins, the warning fires and the clock is kept —
    also with the truth anywhere in the window (the GRF shifted by ±0.2 stride)."""
    foot, shank, vertical, activity, _ = synthetic_pair(rng)
    f, s, act = _crop(foot, shank, activity)
    k = int(round(shift * 114))
    exchanged = {side: np.roll(v, k) for side, v in {"r": vertical["l"], "l": vertical["r"]}.items()}
    searched = align_to_grf(f, s, exchanged, act, 1.14, max_lag_s=10.0)
    assert abs(abs(searched.lag_s - (2.37 + k / 100)) - 0.57) < 0.05  # the half-stride alias
    result = align_to_grf(f, s, exchanged, act, 1.14, max_lag_s=10.0, clock_lag_s=2.37)
    assert result.lag_s == 2.37 and result.clock == "files"
    assert result.fit.sides_ratio > SWAPPED_SIDES_RATIO and result.fit.exchanged.lag_s == pytest.approx(2.37 + k / 100, abs=0.03)
    [warning] = result.warnings
    assert warning.startswith("right and left look swapped between the GRF file and the IMUs: with the force channels' sides "
                              "exchanged the best fit within ±0.28 s of +2.37 s")
    assert not any("swapped" in w for w in align_to_grf(f, s, vertical, act, 1.14, max_lag_s=10.0, clock_lag_s=2.37).warnings)


def test_a_shared_clock_is_kept_unless_the_evidence_is_decisive(rng) -> None:
    """The clock within the correlations' tolerance of the measured lag: kept as it is, and said
    so; 0.15 s off for both feet, or whole seconds off where another lag fits far better:
    overruled with a warning naming both."""
    foot, shank, vertical, activity, _ = synthetic_pair(rng)
    f, s, act = _crop(foot, shank, activity)
    kept = align_to_grf(f, s, vertical, act, 1.14, max_lag_s=10.0, clock_lag_s=2.42, clock_source="given")
    assert kept.lag_s == 2.42 and kept.clock == "given" and kept.measured_lag_s == pytest.approx(2.37, abs=0.011)
    assert not kept.warnings and any(n.startswith("the shared clock's lag +2.420 s is kept (measured +2.37 s") for n in kept.notes)
    assert "the shared clock (--same-clock)" in kept.describe() and kept.to_dict()["clock"] == "given"
    for clock, phrase in ((2.52, "both feet's stances align away from the files' shared clock (+2.52 s)"),
                          (7.37, "the lag +2.37 s fits the GRF to the IMUs")):
        result = align_to_grf(f, s, vertical, act, 1.14, max_lag_s=10.0, clock_lag_s=clock)
        assert result.clock == "overruled" and result.lag_s == pytest.approx(2.37, abs=0.011)
        [warning] = result.warnings
        assert warning.startswith(phrase)


def test_per_foot_alignment_labels_each_foot_with_its_own_lag(rng) -> None:
    """The left channel 0.2 s late: one common lag warns that the channels are offset; per foot,
    each foot's force is labelled with its own lag (both reported), no warning."""
    foot, shank, vertical, activity, _ = synthetic_pair(rng)
    f, s, act = _crop(foot, shank, activity)
    late = {"r": vertical["r"], "l": np.concatenate([np.full(20, vertical["l"][0]), vertical["l"][:-20]])}
    common = align_to_grf(f, s, late, act, 1.14, max_lag_s=10.0, clock_lag_s=2.37)
    assert common.label_lags == {"r": 2.37, "l": 2.37} and any("look offset in time" in w for w in common.warnings)
    per_foot = align_to_grf(f, s, late, act, 1.14, max_lag_s=10.0, clock_lag_s=2.37, per_foot=True)
    assert per_foot.label_lags["r"] == pytest.approx(2.37, abs=0.011) and per_foot.label_lags["l"] == pytest.approx(2.57, abs=0.021)
    assert not per_foot.warnings and per_foot.to_dict()["align"] == "per-foot" and "(used per foot)" in per_foot.describe()
    assert per_foot.lag_s == 2.37  # the common lag is still reported


@pytest.mark.parametrize("clock", [None, 2.37])
def test_the_lag_search_stays_within_a_quarter_stride_of_its_centre(rng, clock) -> None:
    """Every fit (lag used, per-foot lags, the exchanged sides' fit) lies within ±¼ stride of its
    window's centre: the clock, or the candidate a search chose."""
    foot, shank, vertical, activity, _ = synthetic_pair(rng)
    f, s, act = _crop(foot, shank, activity)
    exchanged = {"r": vertical["l"], "l": vertical["r"]}
    for forces in (vertical, exchanged):
        result = align_to_grf(f, s, forces, act, 1.14, max_lag_s=10.0, clock_lag_s=clock, per_foot=True)
        assert result.window_s == pytest.approx(0.25 * 1.14, abs=0.006)
        centre = result.fit.centre_s
        for lag in (result.lag_s, *result.side_lags.values(), result.fit.exchanged.lag_s, result.fit.labelled.lag_s):
            assert abs(lag - centre) <= result.window_s + 1e-9
        for window in result.window_fits:
            assert abs(window.labelled.lag_s - window.centre_s) <= result.window_s + 1e-9
            assert abs(window.exchanged.lag_s - window.centre_s) <= result.window_s + 1e-9


def test_files_share_a_clock_when_they_start_and_end_together() -> None:
    assert files_share_clock(0.0, 59.49, 0.0, 59.49) and files_share_clock(0.0, 59.49, 0.01, 59.5)
    assert not files_share_clock(0.0, 59.49, 0.0, 60.0) and not files_share_clock(1.0, 60.49, 0.0, 59.49)


def test_walking_direction_of_the_force_axis(rng) -> None:
    *_, grf = synthetic_pair(rng, strides=5)
    assert walking_direction_sign(grf[:, 0], grf[:, 1]) == 1
    assert walking_direction_sign(-grf[:, 0], grf[:, 1]) == -1
    with pytest.raises(AlignmentError, match="no stance phase"):
        walking_direction_sign(np.ones(50), np.zeros(50))


def test_real_cmu_trial_alignment() -> None:
    from sspinn.imu.calibration import calibrate
    from sspinn.imu.sensor_map import SensorMap
    from sspinn.imu.stream import resample
    from sspinn.imu.vendor_readers import read_imu_files, read_treadmill_grf

    folder = shared_data("cmu_treadmill_imu_grf") / "Sub01" / "CSBaseline"
    repo = Path(__file__).resolve().parents[1]
    smap = SensorMap.from_yaml(repo / "configs" / "sensor_maps" / "cmu_treadmill.yaml")
    _, stream = resample(read_imu_files([folder / "OpenSim_Sub01_CSBaseline_Accel.trc.gz"]))
    sig = {seg: (stream.sensors[a.sensor].acc, stream.sensors[a.sensor].gyr) for seg, a in smap.by_segment().items()}
    cal = calibrate(sig, smap.by_segment())
    _, forces = read_treadmill_grf(folder / "OpenSim_Sub01_CSBaseline_GRF.mot.gz")
    result = align_to_grf({s: np.linalg.norm(sig[f"foot_{s}"][1], axis=1) for s in "rl"}, {s: sig[f"tibia_{s}"][0] for s in "rl"},
                          {s: forces[s][:, 1] for s in "rl"}, sum(np.linalg.norm(g, axis=1) for _, g in sig.values()),
                          cal.stride_period_s)
    print(result.describe())
    # the two CMU streams start within a tenth of a second of each other (11 of the 12 trials: −0.07…+0.05 s)
    assert abs(result.lag_s) < 0.1 and result.ratio > 1.1
    assert result.best.activity > 0.9 and result.best.loading > 0.8 and result.best.impact > 0.5
    assert abs(abs(result.runner_up.lag_s) - 1.3) < 0.2 and not result.warnings
    assert abs(result.side_lags["r"] - result.side_lags["l"]) <= 0.05
    # the files start together and last equally long: their clock is kept, and a swap is caught at it
    args = ({s: np.linalg.norm(sig[f"foot_{s}"][1], axis=1) for s in "rl"}, {s: sig[f"tibia_{s}"][0] for s in "rl"})
    activity = sum(np.linalg.norm(g, axis=1) for _, g in sig.values())
    kept = align_to_grf(*args, {s: forces[s][:, 1] for s in "rl"}, activity, cal.stride_period_s, clock_lag_s=0.0)
    assert kept.lag_s == 0.0 and kept.clock == "files" and not kept.warnings and abs(kept.measured_lag_s) <= 0.05
    swapped = align_to_grf(*args, {"r": forces["l"][:, 1], "l": forces["r"][:, 1]}, activity, cal.stride_period_s, clock_lag_s=0.0)
    assert swapped.lag_s == 0.0 and swapped.fit.looks_swapped and swapped.fit.sides_ratio > 1.5
    assert [w for w in swapped.warnings if "look swapped" in w] == list(swapped.warnings) and len(swapped.warnings) == 1
