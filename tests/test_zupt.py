"""The 2D ZUPT Kalman filter (:mod:`sspinn.estimator.zupt`): synthetic cases and real foot IMUs vs motion capture
(:mod:`benchmarks.accuracy.zupt_gaitmap`).

Synthetic walking: a rigid foot sensor whose position and angle follow smooth closed-form stride
profiles (known stride length and speed), with exact specific force and gyro plus noise and a gyro
bias. Real data: gaitmap's example recording in ``../shared/data/gaitmap_foot_imu`` (skipped when
absent); the thresholds are the errors measured by ``benchmarks/accuracy/validate_zupt.py`` with a margin.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

from benchmarks.accuracy.zupt_gaitmap import (
    FEET,
    GaitmapExample,
    StrideSpeeds,
    gaitmap_stride_speeds,
    load_gaitmap_example,
    sagittal_from_gaitmap_frame,
)
from sspinn.estimator.zupt import SagittalZuptKalman, detect_stance, foot_speed, stance_phases
from sspinn.model.conventions import GRAVITY
from tests.conftest import shared_data

FS = 200.0


# ------------------------------------------------------------------------------ synthetic data
def synthetic_walk(
    n_strides: int = 20,
    speed: float = 1.3,
    stride_time: float = 1.1,
    swing_fraction: float = 0.6,
    stand_s: float = 1.0,
    peak_angle: float = 1.0,
    step_height: float = 0.12,
    stance_angle: float = 0.05,
    acc_noise: float = 0.0,
    gyro_noise: float = 0.0,
    gyro_bias: float = 0.0,
    seed: int = 0,
) -> dict[str, np.ndarray]:
    """A foot sensor walking at ``speed`` (m/s): stand, ``n_strides`` strides, stand; sampled at FS.

    Each swing (duration Ts = swing_fraction·stride_time, u = (t − t0)/Ts ∈ [0, 1)) moves the
    sensor forward by L = speed·stride_time along the quintic x = L(10u³ − 15u⁴ + 6u⁵), lifts it by
    y = h·sin⁴(πu) and pitches it by θ = θ_stance − A·2sin³(πu)cos(πu) (toe down first, then up);
    velocity, acceleration and angular rate are zero at both ends. Returns t, acc (T, 2) = R(θ)ᵀ(a +
    (0, g)) + noise, gyr = θ̇ + bias + noise, and the true pos, vel, angle and stance mask.
    """
    length, t_swing = speed * stride_time, swing_fraction * stride_time
    t = np.arange(int(round((2 * stand_s + n_strides * stride_time) * FS))) / FS
    x, vx, ax = np.zeros_like(t), np.zeros_like(t), np.zeros_like(t)
    y, vy, ay = np.zeros_like(t), np.zeros_like(t), np.zeros_like(t)
    angle, rate = np.full_like(t, stance_angle), np.zeros_like(t)
    for k in range(n_strides):
        u = (t - (stand_s + k * stride_time + (1 - swing_fraction) * stride_time)) / t_swing
        x[u >= 1] += length
        sw = (u >= 0) & (u < 1)
        u = u[sw]
        s, c = np.sin(np.pi * u), np.cos(np.pi * u)
        x[sw] += length * (10 * u**3 - 15 * u**4 + 6 * u**5)
        vx[sw] = length / t_swing * (30 * u**2 - 60 * u**3 + 30 * u**4)
        ax[sw] = length / t_swing**2 * (60 * u - 180 * u**2 + 120 * u**3)
        y[sw] = step_height * s**4
        vy[sw] = 4 * np.pi * step_height / t_swing * s**3 * c
        ay[sw] = 4 * np.pi**2 * step_height / t_swing**2 * (3 * s**2 * c**2 - s**4)
        angle[sw] = stance_angle - peak_angle * 2 * s**3 * c
        rate[sw] = -peak_angle * np.pi / t_swing * (6 * s**2 * c**2 - 2 * s**4)
    rng = np.random.default_rng(seed)
    fx, fy = ax, ay + GRAVITY
    ca, sa = np.cos(angle), np.sin(angle)
    acc = np.column_stack((ca * fx + sa * fy, -sa * fx + ca * fy)) + acc_noise * rng.standard_normal((len(t), 2))
    gyr = rate + gyro_bias + gyro_noise * rng.standard_normal(len(t))
    vel = np.column_stack((vx, vy))
    return {
        "t": t,
        "acc": acc,
        "gyr": gyr,
        "pos": np.column_stack((x, y)),
        "vel": vel,
        "angle": angle,
        "stance": np.linalg.norm(vel, axis=1) == 0,
        "speed": np.array(speed),
    }


def stride_speeds(est: SagittalZuptKalman, walk: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Mean forward speed between the midpoints of consecutive true stance phases (the standing
    periods at both ends excluded): estimated and true (m/s)."""
    phases = stance_phases(walk["stance"])[1:-1]
    mids = (phases[:, 0] + phases[:, 1]) // 2
    dt = np.diff(mids) / FS
    return np.diff(est.position_[mids, 0]) / dt, np.diff(walk["pos"][mids, 0]) / dt


# ------------------------------------------------------------------------------ synthetic tests
def test_stationary_sensor_has_zero_velocity() -> None:
    rng = np.random.default_rng(3)
    tilt, n = 0.1, 2000
    acc = GRAVITY * np.array([np.sin(tilt), np.cos(tilt)]) + 0.02 * rng.standard_normal((n, 2))
    gyr = 0.002 * rng.standard_normal(n)
    est = SagittalZuptKalman().estimate(acc, gyr, 100.0)
    assert est.zupts_.all()
    assert np.abs(est.velocity_).max() < 1e-3
    assert np.abs(est.position_).max() < 1e-3
    assert abs(np.median(est.angle_) - tilt) < 0.01
    assert est.velocity_.shape == (n, 2) and est.position_.shape == (n, 2) and est.angle_.shape == (n,)
    # why the default angle process noise is not gaitmap's 0.1 rad² per sample: in 2D the angle then
    # wanders (measured 0.4 rad in 20 s) and the position with it (8 cm)
    loose = SagittalZuptKalman(orientation_error_variance=0.1).estimate(acc, gyr, 100.0)
    assert np.abs(loose.position_).max() > 0.01


def test_detect_stance_by_hand() -> None:
    # 100 Hz, window 0.05 s = 5 samples: quiet runs of 20 and 20 samples count, the 3-sample one not
    gyr = np.r_[np.zeros(20), np.ones(5), np.zeros(3), np.ones(2), np.zeros(20)]
    acc = np.tile([0.0, GRAVITY], (len(gyr), 1))
    stance = detect_stance(acc, gyr, 100.0, gyro_threshold=0.5, acc_threshold=None, window_s=0.05)
    expected = np.r_[np.ones(20), np.zeros(10), np.ones(20)].astype(bool)
    np.testing.assert_array_equal(stance, expected)
    acc[5:8, 0] = 6.0  # |‖f‖ − g| = 1.7 m/s²: breaks the first run into 5 + 12 samples, both ≥ 5
    stance = detect_stance(acc, gyr, 100.0, gyro_threshold=0.5, acc_threshold=1.0, window_s=0.05)
    np.testing.assert_array_equal(stance[:20], np.r_[np.ones(5), np.zeros(3), np.ones(12)].astype(bool))


def test_synthetic_walk_exact_stance_is_nearly_exact() -> None:
    walk = synthetic_walk(n_strides=8)
    est = SagittalZuptKalman().estimate(walk["acc"], walk["gyr"], FS, zupts=walk["stance"])
    got, true = stride_speeds(est, walk)
    np.testing.assert_allclose(true, walk["speed"], rtol=0.01)  # midpoints rounded to samples
    # measured: 0.03 % stride speed, 1 mm/s velocity, 0.015° angle (integration error only)
    np.testing.assert_allclose(got, true, rtol=3e-3)
    assert np.abs(est.velocity_ - walk["vel"]).max() < 0.01
    assert np.degrees(np.abs(est.angle_ - walk["angle"]).max()) < 0.1


def test_synthetic_walk_with_noise_and_gyro_bias() -> None:
    walk = synthetic_walk(n_strides=20, acc_noise=0.05, gyro_noise=0.005, gyro_bias=0.01)
    est = SagittalZuptKalman().estimate(walk["acc"], walk["gyr"], FS)
    assert len(est.zupt_phases_) == 21  # every stance phase found, none in swing
    got, true = stride_speeds(est, walk)
    # measured: −1.0 % mean (the detector counts the first/last few swing samples as stance), 1.6 % max
    assert np.abs(got / true - 1).max() < 0.03
    assert abs(np.mean(got / true) - 1) < 0.02


def test_gyro_bias_preset_recovers_bias_and_angle() -> None:
    walk = synthetic_walk(n_strides=20, acc_noise=0.05, gyro_noise=0.005, gyro_bias=0.02)
    est = SagittalZuptKalman(
        estimate_gyro_bias=True, velocity_error_variance=1e-4, orientation_error_variance=1e-8, n_iterations=3
    ).estimate(walk["acc"], walk["gyr"], FS)
    # measured: bias 0.0199 rad/s, angle error ≤ 0.12° (the defaults, without the bias: 14°)
    assert abs(np.median(est.gyro_bias_) - 0.02) < 0.002
    assert np.degrees(np.abs(est.angle_ - walk["angle"]).max()) < 1.0
    got, true = stride_speeds(est, walk)
    assert np.abs(got / true - 1).max() < 0.03
    assert est.state_std_.shape == (len(walk["t"]), 6)


def test_recording_starting_in_swing() -> None:
    walk = synthetic_walk(n_strides=6)
    first_swing = stance_phases(~walk["stance"])[0]
    cut = (first_swing[0] + first_swing[1]) // 2  # start mid-swing: moving, lifted, pitched
    part = {key: value[cut:] if np.ndim(value) else value for key, value in walk.items()}
    est = SagittalZuptKalman().estimate(part["acc"], part["gyr"], FS)
    assert abs(part["vel"][0, 0]) > 1.0
    got, true = stride_speeds(est, part)
    assert np.abs(got / true - 1).max() < 0.03
    assert np.abs(est.position_[part["stance"], 1]).max() < 0.005  # stance at height 0 (level walking)
    # before the first stance phase the initial velocity is unknown: the estimate there is not usable
    first = est.zupt_phases_[0, 0]
    assert first > 0 and np.abs(est.velocity_[first:] - part["vel"][first:]).max() < 0.05  # measured 0.015


def test_foot_speed_is_horizontal_speed() -> None:
    walk = synthetic_walk(n_strides=3)
    est = SagittalZuptKalman()
    speed = foot_speed(walk["acc"], walk["gyr"], FS, estimator=est)
    assert speed.shape == walk["t"].shape and (speed >= 0).all()
    np.testing.assert_array_equal(speed, np.abs(est.velocity_[:, 0]))
    assert abs(speed.max() - np.abs(walk["vel"][:, 0]).max()) < 0.05 * speed.max()


def test_clone_and_params() -> None:
    est = SagittalZuptKalman(zupt_acc_threshold=None, n_iterations=2)
    twin = est.clone()
    assert twin is not est and twin.get_params() == est.get_params()
    assert twin.get_params()["n_iterations"] == 2


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda a, g, fs: (np.where(np.arange(len(a))[:, None] == 7, np.nan, a), g, fs), "NaN"),
        (lambda a, g, fs: (a, np.where(np.arange(len(g)) == 3, np.inf, g), fs), "NaN"),
        (lambda a, g, fs: (np.column_stack((a, a[:, 0])), g, fs), r"shape \(T, 2\)"),
        (lambda a, g, fs: (a, np.column_stack((g, g)), fs), r"shape \(T,\)"),
        (lambda a, g, fs: (a, g[:-1], fs), "samples"),
        (lambda a, g, fs: (a, g, 0.0), "sample_rate_hz"),
        (lambda a, g, fs: (a, g, -100.0), "sample_rate_hz"),
        (lambda a, g, fs: (a, g, float("nan")), "sample_rate_hz"),
        (lambda a, g, fs: (a, np.degrees(g), fs), "deg/s"),
        (lambda a, g, fs: (a / GRAVITY, g, fs), "like g"),
        (lambda a, g, fs: (a, g + 3.0, fs), "no stance"),
    ],
)
def test_bad_inputs_raise_clear_errors(change: Callable[..., tuple], message: str) -> None:
    walk = synthetic_walk(n_strides=2)
    acc, gyr, fs = change(walk["acc"], walk["gyr"], FS)
    with pytest.raises(ValueError, match=message):
        SagittalZuptKalman().estimate(acc, gyr, fs)


@pytest.mark.parametrize(
    "params",
    [
        {"zupt_variance": -1.0},
        {"velocity_error_variance": 0.0},
        {"zupt_acc_threshold": float("nan")},
        {"n_iterations": 0},
        {"zupt_window_s": -0.1},
        {"initial_angle": float("inf")},
    ],
)
def test_bad_parameters_raise(params: dict[str, float]) -> None:
    walk = synthetic_walk(n_strides=2)
    with pytest.raises(ValueError):
        SagittalZuptKalman(**params).estimate(walk["acc"], walk["gyr"], FS)


def test_gaitmap_frame_plain_mapping_by_hand() -> None:
    acc = np.array([[1.0, 2.0, 3.0], [0.0, 0.0, GRAVITY]])
    gyr = np.array([[10.0, 20.0, 30.0], [0.0, -90.0, 0.0]])
    sig = sagittal_from_gaitmap_frame(acc, gyr, 100.0, align=False)
    np.testing.assert_allclose(sig.acc_xy, [[1.0, 3.0], [0.0, GRAVITY]])
    np.testing.assert_allclose(sig.gyr_z, [-np.radians(20.0), np.radians(90.0)])  # +y (left) = toe down


def test_gaitmap_frame_alignment_undoes_mounting_rotation() -> None:
    walk = synthetic_walk(n_strides=10, acc_noise=0.02, gyro_noise=0.003)
    n = len(walk["t"])
    acc3 = np.column_stack((walk["acc"][:, 0], np.zeros(n), walk["acc"][:, 1]))
    gyr3 = np.column_stack((np.zeros(n), -np.degrees(walk["gyr"]), np.zeros(n)))
    a, b = np.radians(10.0), np.radians(15.0)  # sensor rolled 10° and yawed 15° on the foot
    rx = np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])
    rz = np.array([[np.cos(b), -np.sin(b), 0], [np.sin(b), np.cos(b), 0], [0, 0, 1]])
    mount = rz @ rx  # sensor axes in foot coordinates; a foot-frame vector v reads mountᵀ·v
    sig = sagittal_from_gaitmap_frame(acc3 @ mount, gyr3 @ mount, FS)
    assert abs(abs(sig.heading_deg) - 15.0) < 1.0
    assert np.abs(sig.gyr_z - walk["gyr"]).max() < 0.02 * np.abs(walk["gyr"]).max()
    est = SagittalZuptKalman().estimate(sig.acc_xy, sig.gyr_z, FS)
    got, true = stride_speeds(est, walk)
    assert np.abs(got / true - 1).max() < 0.03
    # without the alignment the forward distance shrinks by about cos(15°)
    raw = sagittal_from_gaitmap_frame(acc3 @ mount, gyr3 @ mount, FS, align=False)
    got_raw, _ = stride_speeds(SagittalZuptKalman().estimate(raw.acc_xy, raw.gyr_z, FS), walk)
    assert np.mean(got_raw / true) < 0.98


# ------------------------------------------------------------------------------ real data
@pytest.fixture(scope="module")
def example() -> GaitmapExample:
    return load_gaitmap_example(shared_data("gaitmap_foot_imu"))


@pytest.fixture(scope="module")
def speeds(example: GaitmapExample) -> tuple[StrideSpeeds, dict[str, SagittalZuptKalman]]:
    return gaitmap_stride_speeds(example)


def test_real_data_shapes_and_time_bases(example: GaitmapExample) -> None:
    assert len(example.strides) == 57
    imu_s = len(example.imu["left"]) / example.imu_rate_hz
    mocap_s = len(example.markers["L_FCC"]) / example.mocap_rate_hz
    assert abs(imu_s - 38.7) < 0.05 and abs(imu_s - mocap_s) < 0.05


def test_real_axis_mapping_from_data(example: GaitmapExample) -> None:
    """z up at rest, toe-down pitch = +gyr_y (push-off), x forward (acceleration after toe-off)."""
    for foot in FEET:
        raw = example.imu[foot]
        rest = np.linalg.norm(raw[:, 3:], axis=1) < 10.0
        assert raw[rest, 2].mean() > 9.0
        strides = [s for s in example.strides if s["foot"] == foot]
        push_off = np.median([raw[int(s["tc"]) - 10 : int(s["tc"]), 4].mean() for s in strides])
        early_swing = np.median([raw[int(s["tc"]) : int(s["tc"]) + 20, 0].mean() for s in strides])
        assert push_off > 200.0  # °/s, measured ≈ +440
        assert early_swing > 3.0  # m/s², measured ≈ +9


def test_real_stance_detection_matches_events(
    example: GaitmapExample, speeds: tuple[StrideSpeeds, dict[str, SagittalZuptKalman]]
) -> None:
    table, fits = speeds
    for stride, turn in zip(example.strides, table.turn_deg):
        zupts = fits[str(stride["foot"])].zupts_
        assert zupts[int(stride["start"])] and zupts[int(stride["end"])], stride  # mid-stance events in stance
        if abs(turn) < 20.0:
            assert not zupts[int(stride["tc"]) + 5 : int(stride["ic"]) - 5].any(), stride  # no ZUPT in swing


def test_real_stride_speed_vs_motion_capture(speeds: tuple[StrideSpeeds, dict[str, SagittalZuptKalman]]) -> None:
    # measured (heel marker): straight strides RMSE 0.060 / 0.055 m/s, mean −0.037 / −0.024,
    # max 0.133 / 0.114 (left / right); all 57 strides RMSE 0.067, max 0.202 (a 166° turn);
    # within-stride speed signals: median RMSE 0.16 m/s
    table, _ = speeds
    assert np.isfinite(table.zupt).all() and len(table.s_id) == 57
    assert abs(np.median(table.mocap) - 1.26) < 0.02  # the README's median speed
    straight = np.abs(table.turn_deg) < 20.0
    assert straight.sum() == 53
    for foot in FEET:
        s = table.summary((table.foot == foot) & straight)
        assert s["rmse"] < 0.08, (foot, s)
        assert abs(s["mean"]) < 0.05, (foot, s)
        assert s["max"] < 0.18, (foot, s)
    assert table.summary()["rmse"] < 0.09
    assert np.median(table.signal_rmse[straight]) < 0.22  # m/s within strides (peak foot speed ≈ 4.4 m/s)


def test_foot_speed_masks_samples_without_nearby_stances() -> None:
    """Samples not enclosed by stances at most max_gap_s apart are NaN (drift is not reported)."""
    walk = synthetic_walk(n_strides=3)
    est = SagittalZuptKalman()
    full = foot_speed(walk["acc"], walk["gyr"], FS, estimator=est, max_gap_s=None)
    assert np.isfinite(full).all()
    strict = foot_speed(walk["acc"], walk["gyr"], FS, estimator=est, max_gap_s=0.0)
    s_last, e_last = est.zupt_phases_[-1]
    assert np.isfinite(strict[s_last:e_last]).all()
    assert np.isnan(strict[: est.zupt_phases_[0, 1]]).all()  # every gap is longer than 0 s
    loose = foot_speed(walk["acc"], walk["gyr"], FS, estimator=est)
    first, last = est.zupt_phases_[0, 0], est.zupt_phases_[-1, 1]
    assert np.isfinite(loose[first:last]).all() and np.isnan(loose[:first]).all() and np.isnan(loose[last:]).all()


def test_training_data_warns_once_naming_every_foot_without_a_stance() -> None:
    """Running recordings often have no ZUPT stance: one warning for the data set names every
    such foot (not one per foot, which buried `make demo`'s output), and their speeds are NaN."""
    import warnings

    from sspinn.estimator.training import prepare
    from sspinn.model.conventions import SEGMENTS
    from sspinn.testing import make_recording

    runs = [make_recording(f"run{k}", rng=np.random.default_rng(k)) for k in range(2)]
    for rec in runs:
        for foot in ("foot_r", "foot_l"):
            rec.imu[:, rec.segments.index(foot), 2] += 3.0  # the gyro never quiet: no stance
    quiet = make_recording("quiet")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        prepared = prepare([*runs, quiet], SEGMENTS)
    messages = [str(w.message) for w in caught if "L_FS" in str(w.message)]
    assert len(messages) == 1, messages
    assert "4 foot IMU(s)" in messages[0]
    for name in ("run0 (foot_r)", "run0 (foot_l)", "run1 (foot_r)", "run1 (foot_l)"):
        assert name in messages[0]
    assert "quiet" not in messages[0]
    assert np.isnan(prepared[0].zupt_speed).all() and np.isnan(prepared[1].zupt_speed).all()
    assert not np.isnan(prepared[2].zupt_speed).all()


def test_whole_body_rest_is_found_only_where_every_sensor_rests():
    from sspinn.estimator.zupt import whole_body_still
    from sspinn.testing import walking_recording

    rec = walking_recording(400)
    imu = rec.imu.copy()
    imu[:100, :, :2] = [0.0, 9.81]  # standing still for 1 s ...
    imu[:100, :, 2] = 0.01
    still = whole_body_still(imu, 100.0)
    assert still[:100].all() and not still[100:].any()
    imu[:100, 3, 2] = 2.0  # ... but one foot moving: not a whole-body rest
    assert not whole_body_still(imu, 100.0).any()
    imu[:30, 3, 2] = 0.01  # every sensor quiet for 0.3 s only: shorter than the window
    assert not whole_body_still(imu, 100.0).any()


def test_the_estimate_reports_no_speed_while_the_body_rests(tmp_path):
    import contextlib
    import io

    from sspinn.estimator.sspinnpose import SSPINNpose
    from sspinn.testing import tiny_run, walking_recording

    _, _, run = tiny_run(tmp_path)
    est = SSPINNpose.load(run / "model.pt")
    rec = walking_recording(400)
    rec.imu[:150, :, :2] = [0.0, 9.81]
    rec.imu[:150, :, 2] = 0.0
    with contextlib.redirect_stderr(io.StringIO()):
        estimate = est.predict(rec)
    assert (estimate.u[:150, 0] == 0).all() and (estimate.q[:150, 0] == 0).all()
    assert (estimate.u[150:, 0] != 0).any()


def test_speed_at_rest_is_zero_in_the_rest_and_continuous_at_its_edges():
    from sspinn.estimator.zupt import REST_EDGE_TAU_S, speed_at_rest

    v = np.full(1000, 0.5)  # the network's constant 0.5 m/s ...
    still = np.zeros(1000, dtype=bool)
    still[300:500] = True  # ... through a 2-s rest
    out = speed_at_rest(v, still, 100.0)
    assert (out[300:500] == 0).all()
    assert abs(out[500]) < 1e-12 and abs(out[299]) < 1e-12  # continuous: the walks start and end at 0
    tau = int(REST_EDGE_TAU_S * 100)
    assert out[500 + tau] == pytest.approx(0.5 * (1 - np.exp(-1)))  # the offset decays with tau
    assert out[0] == pytest.approx(0.5 * (1 - np.exp(-2.99 / REST_EDGE_TAU_S)))  # 2.99 s before the rest
    assert out[-1] == pytest.approx(0.5 * (1 - np.exp(-4.99 / REST_EDGE_TAU_S)))
    assert np.array_equal(speed_at_rest(v, np.zeros(1000, dtype=bool), 100.0), v)  # no rest: unchanged
    edge = still.copy()
    edge[:50] = True  # a rest at the very start has no walk before it
    assert np.isfinite(speed_at_rest(v, edge, 100.0)).all()
    with pytest.raises(ValueError, match="one length"):
        speed_at_rest(v, still[:10], 100.0)


def test_every_batch_of_a_data_set_with_foot_speeds_carries_them() -> None:
    """One batch structure per training run (one compiled graph): a batch drawn only from
    recordings without a stance still has a ZUPT tensor, all NaN (unknown)."""
    import warnings

    import torch

    from sspinn.estimator.training import make_batch, prepare
    from sspinn.model.conventions import SEGMENTS
    from sspinn.testing import make_recording

    run = make_recording("run", rng=np.random.default_rng(0))
    for foot in ("foot_r", "foot_l"):
        run.imu[:, run.segments.index(foot), 2] += 3.0  # no stance
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        data = prepare([run, make_recording("quiet")], SEGMENTS)
        without = prepare([make_recording("plain")], SEGMENTS, zupt=False)
    std = torch.ones(len(SEGMENTS), 3)
    _, only_run = make_batch(data, [0, 0], [0, 5], 64, SEGMENTS, std, torch.device("cpu"))
    assert only_run.zupt_speed is not None and torch.isnan(only_run.zupt_speed).all()
    _, mixed = make_batch(data, [0, 1], [0, 5], 64, SEGMENTS, std, torch.device("cpu"))
    assert torch.isfinite(mixed.zupt_speed[1]).any()
    _, none = make_batch(without, [0], [0], 64, SEGMENTS, std, torch.device("cpu"))
    assert none.zupt_speed is None
