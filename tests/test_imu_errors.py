"""Tests of the IMU error model (sspinn.data.sensor_noise): exactness when off, each term alone with its
expected effect and statistics, the soft-tissue physics against finite differences, determinism
and parameter validation."""

from __future__ import annotations

import math

import numpy as np
import pytest
import yaml

from sspinn.data.sensor_noise import (
    STA_RAMP_S,
    IMUErrorModel,
    activity_envelope,
    band_limited_process,
    bias_drift,
    imu_with_relative_motion,
    measure_imu,
    sample_true_placement,
)
from sspinn.model.body import BodyParameters, IMUPlacement, ParameterError
from sspinn.model.conventions import N_SEGMENTS, SEGMENTS
from sspinn.model.kinematics import imu_kinematics, segment_kinematics, virtual_imu

NONE = IMUErrorModel.none()


def smooth_motion(t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Gait-like analytic q(t) with exact u = q̇ and qdd = q̈ (sums of sinusoids, 1 Hz stride)."""
    mean = np.array([0.0, 0.92, 0.05, 0.2, -0.4, 0.05, 0.2, -0.4, 0.05])
    amp = np.array([0.02, 0.02, 0.05, 0.45, 0.5, 0.25, 0.45, 0.5, 0.25])
    freq = np.array([2.0, 2.0, 2.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0])
    phase = np.array([0.0, 0.3, 0.1, 0.0, 1.2, 2.0, math.pi, math.pi + 1.2, math.pi + 2.0])
    w = 2 * math.pi * freq
    arg = w * t[:, None] + phase
    q = mean + amp * np.sin(arg)
    u = amp * w * np.cos(arg)
    qdd = -amp * w**2 * np.sin(arg)
    q[:, 0] += 1.3 * t  # walking speed
    u[:, 0] += 1.3
    return q, u, qdd


@pytest.fixture(scope="module")
def p() -> np.ndarray:
    return BodyParameters.from_anthropometry(1.75, 70.0).vector()


@pytest.fixture(scope="module")
def nominal() -> IMUPlacement:
    return IMUPlacement.default(1.75)


@pytest.fixture(scope="module")
def gait() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    return smooth_motion(np.arange(1000) / 100.0)


def rotate_t(angle: np.ndarray, vx: np.ndarray, vy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """R(angle)ᵀ·(vx, vy)."""
    c, s = np.cos(angle), np.sin(angle)
    return c * vx + s * vy, -s * vx + c * vy


# ------------------------------------------------------------------------------------ exactness
def test_none_equals_virtual_imu_exactly(gait, p, nominal):
    q, u, qdd = gait
    imu, info = measure_imu(q, u, qdd, p, nominal, NONE, rng=0)
    assert imu.shape == (len(q), N_SEGMENTS, 3)
    assert np.array_equal(imu, virtual_imu(q, u, qdd, nominal, p))
    assert info["true_placement"] is nominal
    for key in ("bias", "drift", "noise", "sta_displacement", "sta_rotation"):
        assert not np.any(info[key]), key


def test_subset_of_segments_keeps_realisations(gait, p, nominal):
    q, u, qdd = gait
    full, _ = measure_imu(q, u, qdd, p, nominal, IMUErrorModel(), rng=3)
    subset = ("tibia_l", "pelvis", "foot_r")
    part, info = measure_imu(q, u, qdd, p, nominal, IMUErrorModel(), rng=3, segments=subset)
    assert part.shape == (len(q), 3, 3) and info["segments"] == subset
    assert np.array_equal(part, full[:, [SEGMENTS.index(s) for s in subset]])


def test_components_add_up_and_terms_are_independent(gait, p, nominal):
    q, u, qdd = gait
    imu, info = measure_imu(q, u, qdd, p, nominal, IMUErrorModel(), rng=5)
    assert np.allclose(imu, info["kinematic"] + info["bias"] + info["drift"] + info["noise"], atol=1e-12)
    # switching the STA off leaves the noise realisation (its own random stream) unchanged
    _, info2 = measure_imu(q, u, qdd, p, nominal, IMUErrorModel().replace(soft_tissue_amplitude=0.0), rng=5)
    assert np.array_equal(info["noise"], info2["noise"]) and np.array_equal(info["bias"], info2["bias"])


# ------------------------------------------------------------------------------------ sensor errors
@pytest.mark.parametrize("fs", [100.0, 400.0])
def test_white_noise_statistics(p, nominal, fs):
    q, u, qdd = smooth_motion(np.arange(4000) / fs)
    model = NONE.replace(acc_noise_density=2e-3, gyr_noise_density=1e-4)
    imu, info = measure_imu(q, u, qdd, p, nominal, model, rng=11, sample_rate_hz=fs)
    err = imu - virtual_imu(q, u, qdd, nominal, p)
    assert np.allclose(err, info["noise"], atol=1e-12)
    acc_std, gyr_std = 2e-3 * math.sqrt(fs), 1e-4 * math.sqrt(fs)  # convention: σ = density·√f_s
    assert err[..., :2].std() == pytest.approx(acc_std, rel=0.03)
    assert err[..., 2].std() == pytest.approx(gyr_std, rel=0.03)
    assert abs(err[..., :2].mean()) < 0.02 * acc_std and abs(err[..., 2].mean()) < 0.02 * gyr_std
    # white: no lag-1 correlation
    x = err[..., 0]
    assert abs(np.mean(x[1:] * x[:-1])) / x.var() < 0.03


def test_constant_bias_statistics(p, nominal):
    q, u, qdd = smooth_motion(np.arange(20) / 100.0)
    ideal = virtual_imu(q, u, qdd, nominal, p)
    model = NONE.replace(acc_bias=0.2, gyr_bias=0.01)
    biases = []
    for seed in range(60):
        imu, info = measure_imu(q, u, qdd, p, nominal, model, rng=seed)
        err = imu - ideal
        assert np.allclose(err, err[0], atol=1e-12)  # constant in time
        assert np.allclose(err[0], info["bias"], atol=1e-12)
        biases.append(info["bias"])
    biases = np.array(biases)  # (60, 7, 3)
    assert biases[..., :2].std() == pytest.approx(0.2, rel=0.12)
    assert biases[..., 2].std() == pytest.approx(0.01, rel=0.15)
    assert abs(biases[..., :2].mean()) < 0.03


def test_bias_random_walk_and_gauss_markov():
    rng = np.random.default_rng(7)
    fs, k = 100.0, np.array([2e-3, 2e-3, 5e-4])
    walk = bias_drift(rng, 5000, k, math.inf, fs, (N_SEGMENTS, 3))
    assert walk.shape == (5000, N_SEGMENTS, 3) and not np.any(walk[0])
    steps = np.diff(walk, axis=0)
    assert steps[..., :2].std() == pytest.approx(2e-3 / math.sqrt(fs), rel=0.03)
    assert steps[..., 2].std() == pytest.approx(5e-4 / math.sqrt(fs), rel=0.03)
    # random walk: variance grows linearly, K²·t (checked across 2000 independent channels at t = 5 s)
    many = bias_drift(rng, 501, 1e-3, math.inf, fs, (2000,))
    assert many[-1].std() == pytest.approx(1e-3 * math.sqrt(5.0), rel=0.06)
    # Gauss–Markov: stationary std K·√(τ/2)
    tau = 0.5
    gm = bias_drift(rng, 20000, 1e-3, tau, fs, (40,))
    assert gm[2000:].std() == pytest.approx(1e-3 * math.sqrt(tau / 2), rel=0.06)
    lag = int(tau * fs)  # autocorrelation e^{-1} after τ
    x = gm[2000:]
    assert np.mean(x[lag:] * x[:-lag]) / x.var() == pytest.approx(math.exp(-1), abs=0.06)


def test_drift_through_measure_imu(gait, p, nominal):
    q, u, qdd = gait
    model = NONE.replace(acc_bias_random_walk=1e-2, gyr_bias_random_walk=1e-3)
    imu, info = measure_imu(q, u, qdd, p, nominal, model, rng=2)
    err = imu - virtual_imu(q, u, qdd, nominal, p)
    assert np.allclose(err, info["drift"], atol=1e-12) and not np.any(err[0])
    steps = np.diff(err, axis=0)
    assert steps[..., :2].std() == pytest.approx(1e-2 * 0.1, rel=0.05)
    assert steps[..., 2].std() == pytest.approx(1e-3 * 0.1, rel=0.05)


# ------------------------------------------------------------------------------------ placement errors
def test_misplacement_changes_acc_not_gyro(gait, p, nominal):
    q, u, qdd = gait
    model = NONE.replace(misplacement=0.03)
    imu, info = measure_imu(q, u, qdd, p, nominal, model, rng=4)
    ideal = virtual_imu(q, u, qdd, nominal, p)
    true = info["true_placement"]
    assert np.array_equal(imu, virtual_imu(q, u, qdd, true, p))
    assert np.array_equal(imu[..., 2], ideal[..., 2])  # gyro unaffected
    assert np.all(np.abs(imu[..., :2] - ideal[..., :2]).max(axis=0) > 1e-3)  # every acc channel changes
    for seg in SEGMENTS:
        assert true.angles[seg] == nominal.angles[seg]
    # statistics of the drawn offsets
    offsets = np.array(
        [sample_true_placement(nominal, model, seed).vector() - nominal.vector() for seed in range(150)]
    ).reshape(150, N_SEGMENTS, 3)
    assert offsets[..., :2].std() == pytest.approx(0.03, rel=0.08)
    assert abs(offsets[..., :2].mean()) < 0.004
    assert not np.any(offsets[..., 2])


def test_misalignment_rotates_acc_by_drawn_angle(gait, p, nominal):
    q, u, qdd = gait
    model = NONE.replace(misalignment=0.1)
    imu, info = measure_imu(q, u, qdd, p, nominal, model, rng=8)
    ideal = virtual_imu(q, u, qdd, nominal, p)
    true = info["true_placement"]
    dphi = np.array([true.angles[s] - nominal.angles[s] for s in SEGMENTS])
    assert np.all(np.abs(dphi) > 0) and all(true.positions[s] == nominal.positions[s] for s in SEGMENTS)
    ax, ay = rotate_t(dphi, ideal[..., 0], ideal[..., 1])
    assert np.allclose(imu[..., 0], ax, atol=1e-10) and np.allclose(imu[..., 1], ay, atol=1e-10)
    assert np.array_equal(imu[..., 2], ideal[..., 2])
    angles = np.array([sample_true_placement(nominal, model, seed).vector()[2::3] for seed in range(150)])
    assert angles.std() == pytest.approx(0.1, rel=0.08)


# ------------------------------------------------------------------------------------ soft-tissue artefact
def test_constant_sta_is_rigid_misplacement(gait, p, nominal):
    q, u, qdd = gait
    rng = np.random.default_rng(1)
    delta = rng.normal(scale=0.02, size=(N_SEGMENTS, 2))
    psi = rng.normal(scale=0.05, size=N_SEGMENTS)
    zero = np.zeros((len(q), N_SEGMENTS, 2))
    out = imu_with_relative_motion(q, u, qdd, p, nominal, delta + zero, zero, zero, psi + zero[..., 0], zero[..., 0])
    shifted = nominal.vector().reshape(N_SEGMENTS, 3).copy()
    shifted[:, :2] += delta
    shifted[:, 2] += psi
    assert np.allclose(out, virtual_imu(q, u, qdd, shifted.ravel(), p), atol=1e-12)


def test_sta_relative_acceleration_matches_finite_differences(p, nominal):
    """Sensor origin P(t) = O + R(θ)(r₀ + δ(t)) differentiated numerically; frame angle θ + φ + ψ(t)."""
    dt = 1e-3
    t = np.arange(-1, 602) * dt
    q, u, qdd = smooth_motion(t)
    # smooth analytic relative motion, different per segment
    k = np.arange(N_SEGMENTS)
    w1, w2 = 2 * math.pi * (2.0 + 0.3 * k), 2 * math.pi * (3.5 + 0.2 * k)
    a1, a2, ar = 0.01, 0.008, 0.05
    arg1, arg2 = w1 * t[:, None] + k, w2 * t[:, None] + 0.5 * k
    delta = np.stack([a1 * np.sin(arg1), a2 * np.cos(arg2)], axis=-1)
    ddelta = np.stack([a1 * w1 * np.cos(arg1), -a2 * w2 * np.sin(arg2)], axis=-1)
    dddelta = np.stack([-a1 * w1**2 * np.sin(arg1), -a2 * w2**2 * np.cos(arg2)], axis=-1)
    psi, dpsi = ar * np.sin(arg2), ar * w2 * np.cos(arg2)
    out = imu_with_relative_motion(q, u, qdd, p, nominal, delta, ddelta, dddelta, psi, dpsi)

    base = nominal.vector().reshape(N_SEGMENTS, 3)
    moving = np.broadcast_to(base, delta.shape[:-1] + (3,)).copy()
    moving[..., :2] += delta
    pos = imu_kinematics(q, u, qdd, moving.reshape(len(t), -1), p)[..., :2]  # exact positions of the moving point
    acc_fd = (pos[2:] - 2 * pos[1:-1] + pos[:-2]) / dt**2
    frame = segment_kinematics(q, u, qdd)[..., 0] + base[:, 2] + psi
    fx, fy = rotate_t(frame[1:-1], acc_fd[..., 0], acc_fd[..., 1] + p[0])
    scale = np.abs(out[1:-1, :, :2]).max()
    assert np.abs(fx - out[1:-1, :, 0]).max() < 1e-4 * scale
    assert np.abs(fy - out[1:-1, :, 1]).max() < 1e-4 * scale
    gyr_fd = (frame[2:] - frame[:-2]) / (2 * dt)
    assert np.allclose(gyr_fd, out[1:-1, :, 2], atol=1e-4 * np.abs(out[..., 2]).max())
    # the relative and Coriolis terms matter here (the check is not vacuous)
    frozen_placement = np.concatenate([moving[..., :2], (base[:, 2] + psi)[..., None]], -1).reshape(len(t), -1)
    frozen = virtual_imu(q, u, qdd, frozen_placement, p)
    assert np.abs(frozen[..., :2] - out[..., :2]).max() > 1e3 * 1e-4 * scale


def test_measure_imu_soft_tissue(p, nominal):
    fs = 1000.0
    q, u, qdd = smooth_motion(np.arange(3000) / fs)
    model = NONE.replace(soft_tissue_amplitude=0.005, soft_tissue_rotation=0.02, soft_tissue_bandwidth=6.0)
    imu, info = measure_imu(q, u, qdd, p, nominal, model, rng=21, sample_rate_hz=fs)
    assert np.array_equal(info["rigid"], virtual_imu(q, u, qdd, nominal, p))
    expected = imu_with_relative_motion(
        q, u, qdd, p, nominal, info["sta_displacement"], info["sta_velocity"], info["sta_acceleration"],
        info["sta_rotation"], info["sta_rotation_rate"],
    )
    assert np.array_equal(imu, expected)
    assert np.allclose(imu[..., 2] - info["rigid"][..., 2], info["sta_rotation_rate"], atol=1e-12)
    # the analytic derivatives are those of the sampled displacement (central differences)
    d, v, a = info["sta_displacement"], info["sta_velocity"], info["sta_acceleration"]
    assert np.abs((d[2:] - d[:-2]) * fs / 2 - v[1:-1]).max() < 1e-3 * np.abs(v).max()
    assert np.abs((d[2:] - 2 * d[1:-1] + d[:-2]) * fs**2 - a[1:-1]).max() < 1e-3 * np.abs(a).max()
    r, dr = info["sta_rotation"], info["sta_rotation_rate"]
    assert np.abs((r[2:] - r[:-2]) * fs / 2 - dr[1:-1]).max() < 1e-3 * np.abs(dr).max()


def test_soft_tissue_statistics_and_band():
    fs, n, low, high, rms = 100.0, 20000, 0.5, 4.0, 0.005
    x, dx, ddx = band_limited_process(np.random.default_rng(3), n, (N_SEGMENTS, 3), rms, low, high, fs)
    assert x.shape == dx.shape == ddx.shape == (n, N_SEGMENTS, 3)
    assert np.sqrt(np.mean(x**2)) == pytest.approx(rms, rel=0.05)
    # flat spectrum on [low, high]: E[ẍ²] = rms²·(2π)⁴·mean(f⁴), E[ẋ²] = rms²·(2π)²·mean(f²)
    f = np.linspace(low, high, 10001)
    assert np.sqrt(np.mean(dx**2)) == pytest.approx(rms * 2 * math.pi * math.sqrt(np.mean(f**2)), rel=0.06)
    assert np.sqrt(np.mean(ddx**2)) == pytest.approx(rms * (2 * math.pi) ** 2 * math.sqrt(np.mean(f**4)), rel=0.06)
    # per-segment scale: a zero factor means no STA on that sensor
    model = NONE.replace(soft_tissue_amplitude=0.01, soft_tissue_segment_scale={"foot_r": 0.0, "foot_l": 0.0})
    q, u, qdd = smooth_motion(np.arange(300) / fs)
    _, info = measure_imu(q, u, qdd, BodyParameters.from_anthropometry().vector(), IMUPlacement.default(), model, 1)
    feet = [SEGMENTS.index("foot_r"), SEGMENTS.index("foot_l")]
    assert not np.any(info["sta_displacement"][:, feet]) and np.all(np.abs(info["sta_displacement"][:, 1]).max(0) > 0)


def test_strap_wobble_rate_band_rest_and_other_draws():
    """The strap wobble: its rotation rate has the RMS asked for, its content lies in its band, the
    displacement is the arm times the rotation, it is off where the body rests and on the sensors a
    zero factor names, and switching it on leaves every other term's realisation as it was."""
    fs = 100.0
    q, u, qdd = smooth_motion(np.arange(6000) / fs)
    p, nominal = BodyParameters.from_anthropometry().vector(), IMUPlacement.default()
    model = NONE.replace(wobble_rate=0.1, wobble_segment_scale={"pelvis": 0.0})
    rest = np.zeros(len(q), dtype=bool)
    rest[:200] = True
    imu, info = measure_imu(q, u, qdd, p, nominal, model, rng=4, rest=rest)
    moving = slice(300, None)
    rate = info["sta_rotation_rate"][moving]
    assert np.sqrt(np.mean(rate[:, 1:] ** 2)) == pytest.approx(0.1, rel=0.1)
    assert not info["sta_rotation_rate"][:, 0].any() and not info["sta_rotation_rate"][:200].any()
    assert np.sqrt(np.mean(info["sta_displacement"][moving, 1:] ** 2)) == pytest.approx(
        0.05 * np.sqrt(np.mean(info["sta_rotation"][moving, 1:] ** 2)), rel=0.1)
    spectrum = np.abs(np.fft.rfft(rate[:, 1:], axis=0)) ** 2
    freq = np.fft.rfftfreq(len(rate), 1 / fs)
    assert spectrum[(freq < 7.5) | (freq > 25.5)].sum() < 0.01 * spectrum.sum()  # leakage only (a piece of a longer process)
    np.testing.assert_allclose(imu[..., 2] - info["rigid"][..., 2], info["sta_rotation_rate"], atol=1e-12)
    # the other terms draw from their own streams: the default model with and without the wobble
    _, plain = measure_imu(q, u, qdd, p, nominal, IMUErrorModel(), rng=4)
    _, both = measure_imu(q, u, qdd, p, nominal, IMUErrorModel().replace(wobble_rate=0.1), rng=4)
    for key in ("bias", "drift", "noise"):
        assert np.array_equal(plain[key], both[key]), key
    assert plain["true_placement"] == both["true_placement"] and not IMUErrorModel().has_wobble
    assert not np.array_equal(plain["sta_rotation_rate"], both["sta_rotation_rate"])


# ------------------------------------------------------------------------------------ reproducibility, API
def test_reproducible_with_same_seed(gait, p, nominal):
    q, u, qdd = gait
    model = IMUErrorModel()
    a, info_a = measure_imu(q, u, qdd, p, nominal, model, rng=np.random.default_rng(99))
    b, info_b = measure_imu(q, u, qdd, p, nominal, model, rng=np.random.default_rng(99))
    c, _ = measure_imu(q, u, qdd, p, nominal, model, rng=99)
    d, _ = measure_imu(q, u, qdd, p, nominal, model, rng=100)
    assert np.array_equal(a, b) and np.array_equal(a, c) and not np.allclose(a, d)
    assert info_a["true_placement"] == info_b["true_placement"]
    # a fixed true placement is honoured (several recordings without re-attaching the sensors)
    fixed = sample_true_placement(nominal, model, 5)
    e, info_e = measure_imu(q, u, qdd, p, nominal, model, rng=99, true_placement=fixed)
    assert info_e["true_placement"] is fixed and np.array_equal(info_e["noise"], info_a["noise"])


def test_default_model_long_recording(p, nominal):
    q, u, qdd = smooth_motion(np.arange(10000) / 100.0)
    imu, info = measure_imu(q, u, qdd, p, nominal, IMUErrorModel(), rng=0)
    assert imu.shape == (10000, N_SEGMENTS, 3) and np.all(np.isfinite(imu))
    err = imu - virtual_imu(q, u, qdd, nominal, p)
    # moderate total error: of the order of 1 m/s² and 0.1 rad/s RMS
    assert 0.2 < np.sqrt(np.mean(err[..., :2] ** 2)) < 5.0
    assert 0.01 < np.sqrt(np.mean(err[..., 2] ** 2)) < 0.5


def test_dict_and_yaml_round_trip(tmp_path):
    model = IMUErrorModel().replace(bias_correlation_time=30.0, soft_tissue_segment_scale=(1, 1, 0.5, 0.2, 1, 0.5, 0.2),
                                    wobble_rate=0.1, wobble_segment_scale={"foot_r": 3.0, "foot_l": 3.0})
    assert IMUErrorModel.from_dict(model.to_dict()) == model
    path = tmp_path / "imu_errors.yaml"
    path.write_text(yaml.safe_dump({"imu_errors": IMUErrorModel().to_dict()}))
    loaded = IMUErrorModel.from_dict(yaml.safe_load(path.read_text())["imu_errors"])
    assert loaded == IMUErrorModel() and math.isinf(loaded.bias_correlation_time)
    assert IMUErrorModel.from_dict({"acc_bias": 0.3}).acc_bias == 0.3
    assert IMUErrorModel.from_dict({"bias_correlation_time": None}).bias_correlation_time == math.inf
    assert IMUErrorModel.from_dict({"misplacement": False}).misplacement == 0.0
    assert IMUErrorModel.none() == IMUErrorModel.from_dict(IMUErrorModel.none().to_dict())
    hash(IMUErrorModel())


@pytest.mark.parametrize(
    "changes",
    [
        {"acc_noise_density": -1e-3},
        {"gyr_bias": -0.1},
        {"misplacement": float("nan")},
        {"misalignment": float("inf")},
        {"soft_tissue_amplitude": -0.01},
        {"acc_bias": True},
        {"acc_bias": "0.1"},
        {"bias_correlation_time": 0.0},
        {"bias_correlation_time": -5.0},
        {"soft_tissue_bandwidth": 0.5},
        {"soft_tissue_low_cutoff": -1.0},
        {"soft_tissue_segment_scale": (1.0, 1.0)},
        {"soft_tissue_segment_scale": (1.0, -1.0, 1, 1, 1, 1, 1)},
        {"soft_tissue_segment_scale": {"tibia": 0.5}},
        {"wobble_rate": -0.1},
        {"wobble_bandwidth": 8.0},
        {"wobble_segment_scale": {"shin": 2.0}},
    ],
)
def test_bad_model_parameters_raise(changes):
    with pytest.raises(ParameterError):  # a ValueError
        IMUErrorModel().replace(**changes)


def test_bad_call_arguments_raise(gait, p, nominal):
    q, u, qdd = gait
    with pytest.raises(ValueError, match="unknown IMU error parameter"):
        IMUErrorModel.from_dict({"acc_noise": 1.0})
    with pytest.raises(ValueError, match="Nyquist"):
        measure_imu(q, u, qdd, p, nominal, IMUErrorModel(soft_tissue_bandwidth=6.0), 0, sample_rate_hz=10.0)
    with pytest.raises(ValueError, match="sample_rate_hz"):
        measure_imu(q, u, qdd, p, nominal, NONE, 0, sample_rate_hz=-100.0)
    with pytest.raises(ValueError, match="shape"):
        measure_imu(q[None], u[None], qdd[None], p, nominal, NONE, 0)
    with pytest.raises(ValueError, match="same shape"):
        measure_imu(q, u[:-1], qdd, p, nominal, NONE, 0)
    with pytest.raises(ValueError, match="unknown"):
        measure_imu(q, u, qdd, p, nominal, NONE, 0, segments=("thigh_r",))
    with pytest.raises(ValueError, match="duplicates"):
        measure_imu(q, u, qdd, p, nominal, NONE, 0, segments=("pelvis", "pelvis"))
    with pytest.raises(ValueError, match="rng"):
        measure_imu(q, u, qdd, p, nominal, NONE, rng="seed")
    with pytest.raises(ValueError, match="too narrow"):
        band_limited_process(np.random.default_rng(0), 10, (1,), 1.0, 1.0, 1.0 + 1e-9, 100.0)
    with pytest.raises(ValueError, match="IMUErrorModel"):
        measure_imu(q, u, qdd, p, nominal, {"acc_bias": 0.1}, 0)


# ------------------------------------------------------------------------------------ rests
def test_the_activity_envelope_is_zero_at_rest_one_away_from_it_and_twice_differentiable():
    fs = 100.0
    rest = np.zeros(1000, dtype=bool)
    rest[:100] = True  # standing, then walking,
    rest[500:540] = True  # a short stop,
    rest[-80:] = True  # and standing again
    e, de, dde = activity_envelope(rest, fs)
    assert np.all(e[rest] == 0.0) and np.all((e >= 0) & (e <= 1))
    ramp = int(STA_RAMP_S * fs)
    far = np.ones(1000, dtype=bool)
    for a, b in ((0, 100), (500, 540), (920, 1000)):
        far[max(0, a - ramp) : b + ramp + 1] = False
    assert far.sum() > 300 and np.all(e[far] == 1.0) and np.all(de[far] == 0.0)
    # the analytic derivatives are those of e (central differences, to their truncation error)
    np.testing.assert_allclose(np.gradient(e, 1 / fs)[1:-1], de[1:-1], atol=0.05)
    np.testing.assert_allclose(np.gradient(de, 1 / fs)[1:-1], dde[1:-1], atol=0.1 * np.abs(dde).max())
    assert np.abs(np.diff(dde)).max() < 0.5 * np.abs(dde).max()  # no jump in ë: C²
    e0, de0, dde0 = activity_envelope(np.zeros(50, dtype=bool), fs)
    assert np.all(e0 == 1.0) and not de0.any() and not dde0.any()
    with pytest.raises(ParameterError, match="rest must be"):
        activity_envelope(np.zeros((3, 2), dtype=bool), fs)


def test_no_soft_tissue_artefact_while_the_body_rests_and_the_same_draws_elsewhere(gait, p, nominal):
    q, u, qdd = gait
    model = IMUErrorModel()
    free, info_free = measure_imu(q, u, qdd, p, nominal, model, rng=7)
    none_rest, _ = measure_imu(q, u, qdd, p, nominal, model, rng=7, rest=np.zeros(len(q), dtype=bool))
    np.testing.assert_array_equal(free, none_rest)  # no rest: the measurement is unchanged
    rest = np.zeros(len(q), dtype=bool)
    rest[:300] = True
    imu, info = measure_imu(q, u, qdd, p, nominal, model, rng=7, rest=rest)
    for key in ("sta_displacement", "sta_velocity", "sta_acceleration", "sta_rotation", "sta_rotation_rate"):
        assert not info[key][:300].any()
    after = 300 + int(STA_RAMP_S * 100) + 1
    np.testing.assert_array_equal(imu[after:], free[after:])  # the same draws once the ramp is over
    np.testing.assert_array_equal(info["kinematic"][:300], info["rigid"][:300])  # the sensor moves with its bone
    with pytest.raises(ParameterError, match="rest: expected shape"):
        measure_imu(q, u, qdd, p, nominal, model, rng=7, rest=rest[:10])
