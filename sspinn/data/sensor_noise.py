"""IMU error model: realistic measurements of the virtual IMUs of :mod:`sspinn.model.kinematics`.

Conventions are those of :mod:`sspinn.model.conventions`: SI units, sensor frame s rotated from its
segment frame by the placement angle φ, signals ``[acc_x, acc_y, gyr_z]`` = specific force a − g
in s (m/s²) and the angular rate about z (rad/s). R(α) = [[cos α, −sin α], [sin α, cos α]] and
J = R(90°) = [[0, −1], [1, 0]].

Error terms (each one switched off by a zero; :meth:`IMUErrorModel.none` switches all off)
------------------------------------------------------------------------------------------
1. **Misplacement / misalignment** (drawn once per recording, :func:`sample_true_placement`):
   the true sensor position is the nominal one plus N(0, ``misplacement``²) per segment-frame axis,
   the true sensor angle the nominal one plus N(0, ``misalignment``²). A model that assumes the
   nominal placement then sees the error.
2. **Soft-tissue artefact (STA)**: the sensor moves relative to the bone by a smooth random
   displacement δ(t) (segment frame, m) and rotates by ψ(t) (rad) about its own origin. Both are
   zero-mean, stationary Gaussian processes with a flat spectrum between
   ``soft_tissue_low_cutoff`` and ``soft_tissue_bandwidth`` (Hz) and expected RMS
   ``soft_tissue_amplitude`` (per axis) / ``soft_tissue_rotation``, optionally scaled per segment
   (``soft_tissue_segment_scale``). They are synthesised as a random trigonometric polynomial
   (spectral synthesis on a zero-padded FFT grid, so the recording is not periodic); δ̇, δ̈ and ψ̇
   are the *analytic* derivatives of that polynomial (multiplication by iω, −ω² in the spectrum).
   Movement drives the artefact (muscle contraction and the segment's accelerations move the skin;
   Camomilla et al. 2013 model its rigid component as a function of the joint angles), so where
   the recording says the body rests (``rest``: quiet standing) it is off, and it fades in after a
   rest and out before one over :data:`STA_RAMP_S` (:func:`activity_envelope`, a C² ramp, so the
   derivatives stay analytic). Without that, synthetic quiet standing showed a std of ‖acc‖ of
   1.1–2.0 m/s² and rates up to 40°/s; real Xsens MTw sensors on a person standing still show
   0.017–0.044 m/s² and ≤ 6.5°/s (and the synthetic standing now 0.017–0.019 m/s², ≤ 3.2°/s).
2b. **Strap wobble** (off by default): the sensor also rocks on its strap, faster than the
   movement: a second process of the same kind, flat between ``wobble_low_cutoff`` and
   ``wobble_bandwidth`` (Hz), whose rotation rate ψ̇ has the expected RMS ``wobble_rate`` (rad/s)
   and whose displacement RMS per axis is ``wobble_arm`` × its rotation RMS (a sensor rocking
   about a point of its strap that far away), optionally scaled per segment
   (``wobble_segment_scale``). It adds to δ and ψ above (so to the same relative-motion physics)
   and rests where the body rests. Why: real strapped sensors read rates above 10 Hz that the
   body does not make — on the CMU treadmill trials (slow walking) 0.03 (pelvis) to 0.3 rad/s
   (feet) RMS, 2–4× what the synthetic sensors of faster walkers read, and their content there
   is not coherent with the ground reaction force (docs/results/cmu_treadmill.md, "Strap wobble").
3. **Constant (turn-on) bias**: N(0, ``acc_bias``²) on acc_x, acc_y and N(0, ``gyr_bias``²) on
   gyr_z, per sensor, constant over the recording.
4. **Bias drift**: per channel, b'(t) = −b/τ + K·w(t) with w unit white noise, starting at 0;
   K = ``acc_bias_random_walk`` (m/s²/√s) or ``gyr_bias_random_walk`` (rad/s/√s) and
   τ = ``bias_correlation_time`` (s). τ = ∞ (default) is a pure random walk (per-sample increment
   std K·√Δt, variance K²·t after t seconds); a finite τ is a first-order Gauss–Markov process
   (exact discretisation, steady-state std K·√(τ/2)).
5. **White noise**: per sample N(0, σ²) with σ = density·√f_s (f_s = ``sample_rate_hz``). This is
   the discrete-time equivalent of continuous white noise of two-sided PSD density² sampled at
   Δt = 1/f_s (σ_d = σ_c/√Δt, the convention of the Kalibr IMU noise model and of the gazebo/RotorS
   IMU plugins), e.g. 1.77e-3 m/s²/√Hz → 0.0177 m/s² at 100 Hz.

Physics of the soft-tissue artefact
-----------------------------------
With O(t), θ(t) the segment origin and angle and r₀ the true sensor position (segment frame), the
sensor origin is P(t) = O + R(θ)(r₀ + δ). Using d/dt R(θ) = θ̇·R(θ)·J and J² = −I::

    P̈ = Ö + R(θ)[(θ̈·J − θ̇²·I)(r₀ + δ)] + R(θ)(δ̈ + 2θ̇·J·δ̇)
      = a_seg(r₀ + δ)                     + R(θ)(δ̈ + 2θ̇·J·δ̇),

where a_seg(r) is the acceleration of the *segment-fixed* point r (what :func:`virtual_imu` computes
for a placement r) and the second term holds the relative and Coriolis accelerations. The sensor
frame's angle is θ + φ + ψ, so the specific force in the sensor frame is::

    f_s = R(θ + φ + ψ)ᵀ (P̈ + g·ŷ)
        = virtual_imu(placement [r₀ + δ, φ + ψ]) + R(φ + ψ)ᵀ (δ̈ + 2θ̇·J·δ̇),

and the gyro reads θ̇ + ψ̇. :func:`imu_with_relative_motion` implements exactly this; the tests
check it against finite differences of P(t) and the rigid-body limit (constant δ ≡ misplacement).

Default values and sources
--------------------------
* Noise densities: Bosch Sensortec BMI160 data sheet (BST-BMI160-DS000-07, rev. 0.8, 2015),
  typical output noise density of the accelerometer 180 µg/√Hz (= 1.77e-3 m/s²/√Hz) and of the
  gyroscope 0.007 °/s/√Hz (= 1.22e-4 rad/s/√Hz); a consumer MEMS IMU of the class used in
  wearable gait-analysis sensors.
* Constant bias: the BMI160 data sheet gives typical turn-on offsets of the *raw* chip of ±40 mg
  and ±3 °/s. Wearable systems remove most of that by a factory or static calibration; the
  defaults, 0.1 m/s² (≈ 10 mg) and 0.5 °/s (8.7e-3 rad/s) std, are an engineering estimate of the
  residual, not a data-sheet value.
* Bias drift: engineering estimate from the temperature coefficients of BMI160-class sensors
  (≈ 0.05–0.08 °/s/K and ≈ 0.5–1 mg/K) and a warm-up of a few kelvin against the skin:
  ≈ 0.2 °/s and ≈ 2 mg of drift after one minute, i.e. random-walk densities
  0.0258 °/s/√s (4.5e-4 rad/s/√s) and 2.5e-3 m/s²/√s. (The in-run bias instability of these chips,
  a few °/h, is negligible for gait recordings.)
* Misplacement 0.02 m and misalignment 0.05 rad (≈ 3°): engineering estimates of the uncertainty
  of manually placed and tape-measured sensors; not taken from a specific study.
* Soft-tissue artefact: skin-marker studies report thigh STA up to ~3 cm and shank STA up to
  ~1–2 cm, with frequency content in the band of the movement itself (Peters et al. 2010,
  Gait Posture 31:1–8; Leardini et al. 2005, Gait Posture 21:212–225). A strapped IMU averages
  over a larger skin area, so the defaults are moderate: 5 mm RMS per axis, 0.01 rad RMS rotation,
  flat spectrum 0.5–4 Hz (≈ 1.5 m/s² RMS relative acceleration), the same on every segment unless
  ``soft_tissue_segment_scale`` says otherwise. Higher-frequency wobbling-mass vibration after
  heel strike (10–50 Hz) is not modelled by default; raise ``soft_tissue_bandwidth`` (< f_s/2).

Randomness: every function takes a :class:`numpy.random.Generator` (or an int seed); results are
deterministic for a given generator state. :func:`measure_imu` spawns one independent child stream
per error term and always draws for all seven segments, so switching one term on or off, or
measuring a subset of the segments, leaves the realisations of the other terms unchanged.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Final

import numpy as np
import scipy.fft
import scipy.signal

from sspinn.data.gait_events import true_runs
from sspinn.model.body import IMUPlacement, ParameterError
from sspinn.model.conventions import N_Q, N_SEGMENTS, SEGMENTS
from sspinn.model.kinematics import segment_kinematics, virtual_imu
from sspinn.yaml_config import config_from_mapping

_DEG = math.pi / 180.0
_G0 = 9.80665  # standard gravity for µg → m/s² conversions of data-sheet values

#: Time over which the soft-tissue artefact fades in after a rest and out before one, s (about the
#: anticipatory phase of gait initiation, before the first heel lifts: Brenière & Do 1986).
STA_RAMP_S: Final = 0.3

#: Error components returned by :func:`measure_imu`, in the order of the child random streams.
_STREAMS = ("placement", "soft_tissue", "bias", "drift", "noise", "wobble")  # appended streams keep the earlier ones


#: The per-segment factors of :class:`IMUErrorModel`.
_SEGMENT_SCALES: Final = ("soft_tissue_segment_scale", "wobble_segment_scale")


def _segment_scale(name: str, scale: Any) -> tuple[float, ...]:
    """``scale`` (N_SEGMENTS numbers in SEGMENTS order, or ``{segment: factor}``, missing
    segments 1) as a tuple of finite factors ≥ 0; a :class:`ParameterError` naming ``name``."""
    if isinstance(scale, Mapping):
        unknown = set(scale) - set(SEGMENTS)
        if unknown:
            raise ParameterError(f"IMU error model: {name}: unknown segments {sorted(unknown)}")
        scale = [scale.get(s, 1.0) for s in SEGMENTS]
    try:
        values = tuple(float(v) for v in scale)
    except (TypeError, ValueError):
        raise ParameterError(f"IMU error model: {name} must be {N_SEGMENTS} numbers, got {scale!r}") from None
    if len(values) != N_SEGMENTS or not all(math.isfinite(v) and v >= 0 for v in values):
        raise ParameterError(
            f"IMU error model: {name} must be {N_SEGMENTS} finite numbers >= 0 (SEGMENTS order {SEGMENTS}), got {values!r}"
        )
    return values


@dataclass(frozen=True)
class IMUErrorModel:
    """Parameters of the IMU error model (see the module docstring for the model and sources).

    Every term is off when its parameter is 0 (``False`` is accepted as 0).

    Attributes:
        acc_noise_density: accelerometer white noise, m/s²/√Hz (BMI160: 180 µg/√Hz).
        gyr_noise_density: gyroscope white noise, rad/s/√Hz (BMI160: 0.007 °/s/√Hz).
        acc_bias: std of the constant accelerometer bias per channel, m/s².
        gyr_bias: std of the constant gyroscope bias, rad/s.
        acc_bias_random_walk: accelerometer bias drift density K, m/s²/√s (m/s³/√Hz).
        gyr_bias_random_walk: gyroscope bias drift density K, rad/s/√s (rad/s²/√Hz).
        bias_correlation_time: τ of the bias drift, s; ``math.inf`` = pure random walk.
        misplacement: std of the true sensor position offset per segment-frame axis, m.
        misalignment: std of the true sensor rotation offset about z, rad.
        soft_tissue_amplitude: expected RMS of the STA displacement per axis (segment frame), m.
        soft_tissue_rotation: expected RMS of the STA rotation of the sensor about z, rad.
        soft_tissue_low_cutoff: lower edge of the flat STA spectrum, Hz (≥ 0; DC is never used).
        soft_tissue_bandwidth: upper edge of the flat STA spectrum, Hz (> low cutoff, < f_s/2).
        soft_tissue_segment_scale: factor on both STA amplitudes per segment, SEGMENTS order.
        wobble_rate: expected RMS of the strap wobble's rotation rate, rad/s (0: off).
        wobble_arm: the wobble's displacement RMS per axis over its rotation RMS, m.
        wobble_low_cutoff: lower edge of the flat wobble spectrum, Hz.
        wobble_bandwidth: upper edge of the flat wobble spectrum, Hz (> low cutoff, < f_s/2).
        wobble_segment_scale: factor on the wobble per segment, SEGMENTS order.
    """

    acc_noise_density: float = 180e-6 * _G0
    gyr_noise_density: float = 0.007 * _DEG
    acc_bias: float = 0.1
    gyr_bias: float = 0.5 * _DEG
    acc_bias_random_walk: float = 2.5e-3
    gyr_bias_random_walk: float = 4.5e-4
    bias_correlation_time: float = math.inf
    misplacement: float = 0.02
    misalignment: float = 0.05
    soft_tissue_amplitude: float = 0.005
    soft_tissue_rotation: float = 0.01
    soft_tissue_low_cutoff: float = 0.5
    soft_tissue_bandwidth: float = 4.0
    soft_tissue_segment_scale: tuple[float, ...] = (1.0,) * N_SEGMENTS
    wobble_rate: float = 0.0
    wobble_arm: float = 0.05
    wobble_low_cutoff: float = 8.0
    wobble_bandwidth: float = 25.0
    wobble_segment_scale: tuple[float, ...] = (1.0,) * N_SEGMENTS

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            if f.name in _SEGMENT_SCALES:
                continue
            value = getattr(self, f.name)
            if isinstance(value, bool):
                if value:
                    raise ParameterError(f"IMU error model: {f.name} must be a number (False/0 = off), got True")
                value = 0.0
            if not isinstance(value, (int, float, np.integer, np.floating)):
                raise ParameterError(f"IMU error model: {f.name} must be a number, got {value!r}")
            value = float(value)
            if math.isnan(value) or (math.isinf(value) and f.name != "bias_correlation_time"):
                raise ParameterError(f"IMU error model: {f.name} must be finite, got {value!r}")
            if value < 0:
                raise ParameterError(f"IMU error model: {f.name} must be >= 0 (std, density, frequency), got {value!r}")
            object.__setattr__(self, f.name, value)
        if self.bias_correlation_time <= 0:
            raise ParameterError(
                "IMU error model: bias_correlation_time must be > 0 s (math.inf: random walk), "
                f"got {self.bias_correlation_time!r}"
            )
        for low, high in (("soft_tissue_low_cutoff", "soft_tissue_bandwidth"), ("wobble_low_cutoff", "wobble_bandwidth")):
            if not getattr(self, high) > getattr(self, low):
                raise ParameterError(f"IMU error model: {high} ({getattr(self, high)} Hz) must exceed {low} ({getattr(self, low)} Hz)")
        for name in _SEGMENT_SCALES:
            object.__setattr__(self, name, _segment_scale(name, getattr(self, name)))

    @classmethod
    def none(cls) -> IMUErrorModel:
        """Every error term off: :func:`measure_imu` then returns the ideal virtual IMU."""
        return cls(
            acc_noise_density=0.0,
            gyr_noise_density=0.0,
            acc_bias=0.0,
            gyr_bias=0.0,
            acc_bias_random_walk=0.0,
            gyr_bias_random_walk=0.0,
            misplacement=0.0,
            misalignment=0.0,
            soft_tissue_amplitude=0.0,
            soft_tissue_rotation=0.0,
        )

    def replace(self, **changes: Any) -> IMUErrorModel:
        """A copy with some fields changed (validated again), e.g. ``IMUErrorModel.none().replace(acc_bias=0.1)``."""
        return dataclasses.replace(self, **changes)

    @property
    def has_soft_tissue(self) -> bool:
        """Whether any soft-tissue artefact is generated."""
        return (self.soft_tissue_amplitude > 0 or self.soft_tissue_rotation > 0) and any(
            s > 0 for s in self.soft_tissue_segment_scale
        )

    @property
    def has_wobble(self) -> bool:
        """Whether any strap wobble is generated."""
        return self.wobble_rate > 0 and any(s > 0 for s in self.wobble_segment_scale)

    def wobble_rms(self) -> np.ndarray:
        """(N_SEGMENTS, 3) expected RMS of the wobble's displacement (x, y; m) and rotation (rad):
        the rotation RMS is ``wobble_rate`` over the band's RMS angular frequency (a flat spectrum
        from f₁ to f₂: 2π·√((f₂³ − f₁³) / (3 (f₂ − f₁))))."""
        f1, f2 = self.wobble_low_cutoff, self.wobble_bandwidth
        rotation = self.wobble_rate / (2.0 * math.pi * math.sqrt((f2**3 - f1**3) / (3.0 * (f2 - f1))))
        scale = np.asarray(self.wobble_segment_scale)[:, None]
        return scale * np.array([self.wobble_arm * rotation, self.wobble_arm * rotation, rotation])

    def to_dict(self) -> dict[str, Any]:
        """Plain dict (floats, lists for the segment scales) for YAML; inf stays ``float('inf')``."""
        data = dataclasses.asdict(self)
        for name in _SEGMENT_SCALES:
            data[name] = list(getattr(self, name))
        return data

    @classmethod
    def from_dict(cls, data: Mapping[str, Any] | None, source: str = "<dict>") -> IMUErrorModel:
        """Build from a (possibly partial) dict; missing fields keep their defaults.

        ``bias_correlation_time`` may be ``None`` or ``"inf"`` (random walk); the segment scale may
        be a list in SEGMENTS order or a ``{segment: factor}`` mapping (missing segments: 1).
        """
        if data is None:
            return cls()
        if not isinstance(data, Mapping):
            raise ParameterError(f"{source}: IMU error model must be a mapping, got {type(data).__name__}")
        kwargs = {k: 0.0 if v is False else v for k, v in data.items()}  # False: the term is off
        later: dict[str, Any] = {}  # values the loader's types do not cover, set (and checked) afterwards
        tau = kwargs.get("bias_correlation_time", 0.0)
        if tau is None or str(tau).strip().lower() in ("inf", ".inf", "infinity"):
            kwargs.pop("bias_correlation_time", None)
            later["bias_correlation_time"] = math.inf  # a random walk (the loader takes finite numbers)
        for name in _SEGMENT_SCALES:
            if isinstance(kwargs.get(name), Mapping):
                later[name] = kwargs.pop(name)
        model = config_from_mapping(cls, kwargs, source, what="IMU error parameter", error=ParameterError)
        try:
            return model.replace(**later) if later else model
        except ParameterError as exc:
            raise ParameterError(f"{source}: {exc}") from None


# --------------------------------------------------------------------------------------------
# Random generators and helpers
# --------------------------------------------------------------------------------------------
def _as_generator(rng: np.random.Generator | int | None) -> np.random.Generator:
    if isinstance(rng, np.random.Generator):
        return rng
    if rng is None or (isinstance(rng, (int, np.integer)) and not isinstance(rng, bool)):
        return np.random.default_rng(rng)
    raise ParameterError(f"rng must be a numpy.random.Generator, an int seed or None, got {type(rng).__name__}")


def _check_segments(segments: Sequence[str]) -> tuple[int, ...]:
    segments = tuple(segments)
    if not segments:
        raise ParameterError("segments: at least one segment is needed")
    unknown = [s for s in segments if s not in SEGMENTS]
    if unknown:
        raise ParameterError(f"segments: unknown {unknown}; expected names from {SEGMENTS}")
    if len(set(segments)) != len(segments):
        raise ParameterError(f"segments: duplicates in {segments}")
    return tuple(SEGMENTS.index(s) for s in segments)


def _check_rate(sample_rate_hz: float) -> float:
    if isinstance(sample_rate_hz, bool) or not isinstance(sample_rate_hz, (int, float, np.integer, np.floating)):
        raise ParameterError(f"sample_rate_hz must be a number, got {sample_rate_hz!r}")
    if not (math.isfinite(sample_rate_hz) and sample_rate_hz > 0):
        raise ParameterError(f"sample_rate_hz must be finite and > 0, got {sample_rate_hz!r}")
    return float(sample_rate_hz)


def _placement_array(placement: IMUPlacement | np.ndarray) -> np.ndarray:
    """(7, 3) [x, y, angle] per segment."""
    vec = placement.vector() if isinstance(placement, IMUPlacement) else np.asarray(placement, dtype=np.float64)
    if vec.size != 3 * N_SEGMENTS:
        raise ParameterError(f"IMU placement: expected {3 * N_SEGMENTS} values, got shape {vec.shape}")
    return vec.reshape(N_SEGMENTS, 3)


def band_limited_process(
    rng: np.random.Generator,
    n_samples: int,
    shape: tuple[int, ...],
    rms: float | np.ndarray,
    low_hz: float,
    high_hz: float,
    sample_rate_hz: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Smooth zero-mean Gaussian processes with a flat spectrum in [low_hz, high_hz] and their
    analytic first and second time derivatives.

    Each process is a random trigonometric polynomial Σ_k a_k cos(ω_k t) + b_k sin(ω_k t) over the
    FFT bins f_k of a zero-padded grid (length ≥ 2·n_samples, at least 16 bins in the band) with
    low_hz ≤ f_k ≤ high_hz, 0 < f_k < f_s/2, and a_k, b_k i.i.d. normal, scaled so that the
    expected mean square is ``rms``². The derivatives are exact for that polynomial.

    Args:
        rng: random generator (draws 2·K·prod(shape) normals, K = number of bins in the band).
        n_samples: T, number of samples.
        shape: shape of the independent processes, e.g. (7, 3).
        rms: expected RMS, broadcastable to ``shape`` (units of the process).
        low_hz, high_hz: band edges, Hz (0 ≤ low < high < f_s/2).
        sample_rate_hz: f_s, Hz.

    Returns:
        (x, dx/dt, d²x/dt²), each (T, *shape).
    """
    fs = _check_rate(sample_rate_hz)
    if not 0 <= low_hz < high_hz:
        raise ParameterError(f"band-limited process: need 0 <= low ({low_hz}) < high ({high_hz}) Hz")
    if high_hz >= fs / 2:
        raise ParameterError(
            f"band-limited process: upper frequency {high_hz} Hz must be below the Nyquist frequency {fs / 2} Hz"
        )
    n_samples = int(n_samples)
    if n_samples < 1:
        raise ParameterError(f"band-limited process: n_samples must be >= 1, got {n_samples}")
    min_len = 16 * fs / (high_hz - low_hz)
    if min_len > 2**24:
        raise ParameterError(f"band-limited process: band [{low_hz}, {high_hz}] Hz is too narrow for f_s = {fs} Hz")
    n_fft = scipy.fft.next_fast_len(max(2 * n_samples, math.ceil(min_len), 16), real=True)
    freqs = np.fft.rfftfreq(n_fft, 1.0 / fs)
    band = (freqs >= low_hz) & (freqs <= high_hz) & (freqs > 0) & (freqs < fs / 2)
    n_bins = int(band.sum())
    coef = rng.standard_normal((n_bins, *shape)) + 1j * rng.standard_normal((n_bins, *shape))
    # x[n] = (2/N) Σ_k Re(X_k e^{iω_k n Δt}) has E[x²] = 4K/N² for unit complex normals.
    coef *= np.asarray(rms, dtype=np.float64) * n_fft / (2.0 * math.sqrt(n_bins))
    omega = (2.0 * math.pi * freqs[band]).reshape((n_bins,) + (1,) * len(shape))
    spectrum = np.zeros((freqs.size, *shape), dtype=np.complex128)
    out = []
    for factor in (1.0, 1j * omega, -(omega**2)):
        spectrum[band] = coef * factor
        out.append(scipy.fft.irfft(spectrum, n=n_fft, axis=0)[:n_samples])
    return out[0], out[1], out[2]


def bias_drift(
    rng: np.random.Generator,
    n_samples: int,
    density: np.ndarray | float,
    correlation_time: float,
    sample_rate_hz: float,
    shape: tuple[int, ...] = (),
) -> np.ndarray:
    """Bias drift b(t), (T, *shape), starting at b(0) = 0: a random walk (τ = inf; increments of
    std K·√Δt) or a first-order Gauss–Markov process (db = −b/τ dt + K dW, exact discretisation
    b_k = e^{−Δt/τ} b_{k−1} + K·√(τ(1 − e^{−2Δt/τ})/2)·w_k). K = ``density`` (broadcast to shape)."""
    fs = _check_rate(sample_rate_hz)
    dt = 1.0 / fs
    w = rng.standard_normal((int(n_samples), *shape))
    w[0] = 0.0
    k = np.asarray(density, dtype=np.float64)
    if math.isinf(correlation_time):
        return np.cumsum(w, axis=0) * (k * math.sqrt(dt))
    a = math.exp(-dt / correlation_time)
    gain = k * math.sqrt(correlation_time * (1.0 - a * a) / 2.0)
    return scipy.signal.lfilter([1.0], [1.0, -a], w, axis=0) * gain


# --------------------------------------------------------------------------------------------
# Placement errors and the sensor model with relative motion
# --------------------------------------------------------------------------------------------
def sample_true_placement(
    nominal: IMUPlacement, model: IMUErrorModel, rng: np.random.Generator | int | None
) -> IMUPlacement:
    """The true placement: nominal positions + N(0, misplacement²) per segment-frame axis (m) and
    nominal angles + N(0, misalignment²) (rad), independently for each of the seven sensors.

    Always draws 3 normals per segment (positions first), so the result for a given generator state
    does not depend on which of the two terms is on. With both off it returns ``nominal`` itself.
    """
    rng = _as_generator(rng)
    if not isinstance(nominal, IMUPlacement):
        raise ParameterError(f"nominal must be an IMUPlacement, got {type(nominal).__name__}")
    draws = rng.standard_normal((N_SEGMENTS, 3))
    if model.misplacement == 0 and model.misalignment == 0:
        return nominal
    vec = _placement_array(nominal).copy()
    vec[:, :2] += model.misplacement * draws[:, :2]
    vec[:, 2] += model.misalignment * draws[:, 2]
    return IMUPlacement.from_vector(vec.ravel())


def activity_envelope(
    rest: np.ndarray, sample_rate_hz: float, ramp_s: float = STA_RAMP_S
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The soft-tissue artefact's envelope e(t) and its analytic derivatives ė, ë, each (T,).

    e is 0 on the samples of ``rest`` (T,) bool, 1 farther than ``ramp_s`` from every rest, and in
    between the quintic smoothstep S(x) = 10x³ − 15x⁴ + 6x⁵ of x = (time from the rest's edge) /
    ``ramp_s`` (S' and S'' vanish at both ends, so e is C²). With several rests e is the product of
    one such factor per rest (C² as well); without a rest it is 1 and its derivatives 0.
    """
    fs = _check_rate(sample_rate_hz)
    rest = np.asarray(rest, dtype=bool)
    if rest.ndim != 1:
        raise ParameterError(f"rest must be a (T,) bool array, got shape {rest.shape}")
    if not ramp_s > 0:
        raise ParameterError(f"ramp_s must be > 0 s, got {ramp_s}")
    n = rest.size
    e, de, dde = np.ones(n), np.zeros(n), np.zeros(n)
    t = np.arange(n) / fs
    for start, end in true_runs(rest):
        # time from the rest [start, end) (0 inside it), and its sign of change
        x = np.zeros(n)
        dx = np.zeros(n)
        x[end:] = (t[end:] - t[end - 1]) / ramp_s
        dx[end:] = 1.0 / ramp_s
        x[:start] = (t[start] - t[:start]) / ramp_s
        dx[:start] = -1.0 / ramp_s
        inside = x < 1.0
        xc = np.where(inside, x, 1.0)
        f = xc**3 * (10.0 - 15.0 * xc + 6.0 * xc**2)
        df = np.where(inside, 30.0 * xc**2 * (1.0 - xc) ** 2, 0.0) * dx
        ddf = np.where(inside, 60.0 * xc * (1.0 - xc) * (1.0 - 2.0 * xc), 0.0) * dx**2
        e, de, dde = e * f, de * f + e * df, dde * f + 2.0 * de * df + e * ddf
    return e, de, dde


def imu_with_relative_motion(
    q: np.ndarray,
    u: np.ndarray,
    qdd: np.ndarray,
    p: Any,
    placement: IMUPlacement | np.ndarray,
    displacement: np.ndarray,
    velocity: np.ndarray,
    acceleration: np.ndarray,
    rotation: np.ndarray | None = None,
    rotation_rate: np.ndarray | None = None,
) -> np.ndarray:
    """Sensor signals (..., 7, 3) of IMUs that move relative to their segments.

    The sensor origin sits at ``placement`` position + δ(t) in the segment frame and the sensor
    frame is rotated by ``placement`` angle + ψ(t); see the module docstring for the derivation:
    acc = virtual_imu([r₀ + δ, φ + ψ]) + R(φ + ψ)ᵀ(δ̈ + 2θ̇·J·δ̇), gyr_z = θ̇ + ψ̇.

    Args:
        q, u, qdd: (..., 9) generalized coordinates, speeds, accelerations (SI).
        p: body parameters (41-vector or :class:`~sspinn.model.body.BodyParameters`).
        placement: rigid placement [x, y, φ] per segment (m, rad).
        displacement, velocity, acceleration: δ, δ̇, δ̈ (..., 7, 2) in the segment frame (m, m/s, m/s²).
        rotation, rotation_rate: ψ, ψ̇ (..., 7) (rad, rad/s), or None for no relative rotation.
    """
    q = np.asarray(q, dtype=np.float64)
    base = _placement_array(placement)
    disp = np.asarray(displacement, dtype=np.float64)
    vel = np.asarray(velocity, dtype=np.float64)
    acc = np.asarray(acceleration, dtype=np.float64)
    for name, arr in (("displacement", disp), ("velocity", vel), ("acceleration", acc)):
        if arr.shape[-2:] != (N_SEGMENTS, 2):
            raise ParameterError(f"{name}: expected shape (..., {N_SEGMENTS}, 2), got {arr.shape}")
    shapes = [q.shape[:-1], disp.shape[:-2], vel.shape[:-2], acc.shape[:-2]]
    rot = rate = None
    if rotation is not None:
        rot = np.asarray(rotation, dtype=np.float64)
        rate = np.zeros_like(rot) if rotation_rate is None else np.asarray(rotation_rate, dtype=np.float64)
        for name, arr in (("rotation", rot), ("rotation_rate", rate)):
            if arr.shape[-1:] != (N_SEGMENTS,):
                raise ParameterError(f"{name}: expected shape (..., {N_SEGMENTS}), got {arr.shape}")
        shapes += [rot.shape[:-1], rate.shape[:-1]]
    elif rotation_rate is not None:
        raise ParameterError("rotation_rate given without rotation")
    lead = np.broadcast_shapes(*shapes)
    vec = np.broadcast_to(base, lead + (N_SEGMENTS, 3)).copy()
    vec[..., :2] += disp
    if rot is not None:
        vec[..., 2] += rot
    signals = virtual_imu(q, u, qdd, vec.reshape(lead + (3 * N_SEGMENTS,)), p)
    omega = segment_kinematics(q, u, qdd)[..., 1]
    # relative + Coriolis acceleration in the segment frame: δ̈ + 2θ̇·J·δ̇, J·v = (−v_y, v_x)
    rel_x = acc[..., 0] - 2.0 * omega * vel[..., 1]
    rel_y = acc[..., 1] + 2.0 * omega * vel[..., 0]
    c, s = np.cos(vec[..., 2]), np.sin(vec[..., 2])
    out = np.array(signals, dtype=np.float64, copy=True)
    out[..., 0] += c * rel_x + s * rel_y
    out[..., 1] += -s * rel_x + c * rel_y
    if rate is not None:
        out[..., 2] += rate
    return out


# --------------------------------------------------------------------------------------------
# The measurement
# --------------------------------------------------------------------------------------------
def measure_imu(
    q: np.ndarray,
    u: np.ndarray,
    qdd: np.ndarray,
    p: Any,
    nominal: IMUPlacement,
    model: IMUErrorModel,
    rng: np.random.Generator | int | None,
    sample_rate_hz: float = 100.0,
    segments: Sequence[str] = SEGMENTS,
    true_placement: IMUPlacement | None = None,
    rest: np.ndarray | None = None,
) -> tuple[np.ndarray, dict[str, Any]]:
    """Realistic IMU measurements of a recording: the virtual IMUs plus every error term of ``model``.

    Args:
        q, u, qdd: (T, 9) ground-truth generalized coordinates, speeds and accelerations sampled at
            ``sample_rate_hz`` (SI units, :mod:`sspinn.model.conventions`).
        p: true body parameters (41-vector or :class:`~sspinn.model.body.BodyParameters`).
        nominal: the placement the user believes in (e.g. ``IMUPlacement.default(height)``).
        model: the error model; :meth:`IMUErrorModel.none` gives exactly ``virtual_imu(q, u, qdd, nominal, p)``.
        rng: generator or int seed; the same state gives the same measurement.
        sample_rate_hz: f_s of the samples, Hz (sets the noise std, drift increments and STA time base).
        segments: sensors to return, names from SEGMENTS, in the output order.
        true_placement: use this placement instead of drawing one (e.g. to share the sensor
            placement between several recordings made without re-attaching the sensors); its stream is still consumed.
        rest: (T,) bool, the samples where the body rests (quiet standing), or None for none: the
            soft-tissue artefact is off there and ramps in and out (:func:`activity_envelope`);
            the random draws are the same with and without it.

    Returns:
        ``(imu, info)``: ``imu`` (T, n_seg, 3) [acc_x (m/s²), acc_y (m/s²), gyr_z (rad/s)], and
        ``info`` with

        * ``true_placement``: the :class:`IMUPlacement` used (all seven sensors),
        * ``rigid`` (T, n_seg, 3): virtual IMU at the true placement without STA,
        * ``kinematic`` (T, n_seg, 3): the sensor's true specific force and rate, with STA,
        * ``bias`` (n_seg, 3), ``drift`` (T, n_seg, 3), ``noise`` (T, n_seg, 3): sensor errors,
          so that ``imu == kinematic + bias + drift + noise``,
        * ``sta_displacement``, ``sta_velocity``, ``sta_acceleration`` (T, n_seg, 2): δ, δ̇, δ̈ in the
          segment frame (m, m/s, m/s²); ``sta_rotation``, ``sta_rotation_rate`` (T, n_seg): ψ, ψ̇
          (the soft-tissue artefact and the strap wobble together),
        * ``segments``, ``sample_rate_hz``.
    """
    if not isinstance(model, IMUErrorModel):
        raise ParameterError(f"model must be an IMUErrorModel, got {type(model).__name__}")
    if not isinstance(nominal, IMUPlacement):
        raise ParameterError(f"nominal must be an IMUPlacement, got {type(nominal).__name__}")
    if true_placement is not None and not isinstance(true_placement, IMUPlacement):
        raise ParameterError(f"true_placement must be an IMUPlacement or None, got {type(true_placement).__name__}")
    fs = _check_rate(sample_rate_hz)
    rows = np.array(_check_segments(segments))
    q, u, qdd = (np.asarray(x, dtype=np.float64) for x in (q, u, qdd))
    for name, x in (("q", q), ("u", u), ("qdd", qdd)):
        if x.ndim != 2 or x.shape[1] != N_Q:
            raise ParameterError(f"{name}: expected shape (T, {N_Q}) sampled at sample_rate_hz, got {x.shape}")
    if not q.shape == u.shape == qdd.shape:
        raise ParameterError(f"q, u, qdd must have the same shape, got {q.shape}, {u.shape}, {qdd.shape}")
    n = q.shape[0]
    for on, name in ((model.has_soft_tissue, "soft_tissue_bandwidth"), (model.has_wobble, "wobble_bandwidth")):
        if on and getattr(model, name) >= fs / 2:
            raise ParameterError(f"{name} {getattr(model, name)} Hz must be below the Nyquist frequency {fs / 2} Hz")
    if rest is not None and np.shape(rest) != (n,):
        raise ParameterError(f"rest: expected shape ({n},) like q, got {np.shape(rest)}")
    streams = dict(zip(_STREAMS, _as_generator(rng).spawn(len(_STREAMS))))

    # 1. placement errors (drawn once per recording)
    drawn = sample_true_placement(nominal, model, streams["placement"])
    placement = drawn if true_placement is None else true_placement
    rigid = np.asarray(virtual_imu(q, u, qdd, placement.vector(), p), dtype=np.float64)

    # 2. soft-tissue artefact and strap wobble: relative motion of each sensor with respect to its bone
    relative = np.zeros((3, n, N_SEGMENTS, 3))  # (x, ẋ, ẍ) of [δ_x, δ_y, ψ]
    bands = []
    if model.has_soft_tissue:
        scale = np.asarray(model.soft_tissue_segment_scale)[:, None]
        rms = scale * np.array([model.soft_tissue_amplitude, model.soft_tissue_amplitude, model.soft_tissue_rotation])
        bands.append((streams["soft_tissue"], rms, model.soft_tissue_low_cutoff, model.soft_tissue_bandwidth))
    if model.has_wobble:
        bands.append((streams["wobble"], model.wobble_rms(), model.wobble_low_cutoff, model.wobble_bandwidth))
    for stream, rms, low, high in bands:
        relative += np.asarray(band_limited_process(stream, n, (N_SEGMENTS, 3), rms, low, high, fs))
    if bands and rest is not None:
        x, dx, ddx = relative
        e, de, dde = (v[:, None, None] for v in activity_envelope(rest, fs))
        relative = np.asarray((e * x, e * dx + de * x, e * ddx + 2.0 * de * dx + dde * x))
    x, dx, ddx = relative
    disp, vel, acc, rot, rot_rate = x[..., :2], dx[..., :2], ddx[..., :2], x[..., 2], dx[..., 2]
    kinematic = imu_with_relative_motion(q, u, qdd, p, placement, disp, vel, acc, rot, rot_rate) if bands else rigid

    # 3.–5. sensor errors, per channel [acc_x, acc_y, gyr_z]
    def per_channel(acc_value: float, gyr_value: float) -> np.ndarray:
        return np.array([acc_value, acc_value, gyr_value])

    bias_std = per_channel(model.acc_bias, model.gyr_bias)
    bias = bias_std * streams["bias"].standard_normal((N_SEGMENTS, 3)) if bias_std.any() else np.zeros((N_SEGMENTS, 3))
    drift_k = per_channel(model.acc_bias_random_walk, model.gyr_bias_random_walk)
    if drift_k.any():
        drift = bias_drift(streams["drift"], n, drift_k, model.bias_correlation_time, fs, (N_SEGMENTS, 3))
    else:
        drift = np.zeros((n, N_SEGMENTS, 3))
    noise_std = per_channel(model.acc_noise_density, model.gyr_noise_density) * math.sqrt(fs)
    if noise_std.any():
        noise = noise_std * streams["noise"].standard_normal((n, N_SEGMENTS, 3))
    else:
        noise = np.zeros((n, N_SEGMENTS, 3))

    measured = kinematic + bias + drift + noise
    info: dict[str, Any] = {
        "true_placement": placement,
        "rigid": rigid[:, rows],
        "kinematic": kinematic[:, rows],
        "bias": bias[rows],
        "drift": drift[:, rows],
        "noise": noise[:, rows],
        "sta_displacement": disp[:, rows],
        "sta_velocity": vel[:, rows],
        "sta_acceleration": acc[:, rows],
        "sta_rotation": rot[:, rows],
        "sta_rotation_rate": rot_rate[:, rows],
        "segments": tuple(segments),
        "sample_rate_hz": fs,
    }
    return measured[:, rows], info


__all__ = [
    "STA_RAMP_S",
    "IMUErrorModel",
    "activity_envelope",
    "band_limited_process",
    "bias_drift",
    "imu_with_relative_motion",
    "measure_imu",
    "sample_true_placement",
]
