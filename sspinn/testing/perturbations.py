"""Wiring and labelling mistakes applied to a good 2D recording, for the tests and measurements of
:mod:`sspinn.data.signal_checks` (``tests/test_signal_checks_property.py``,
``benchmarks/accuracy/signal_check_rates.py``, ``scripts/bad_input_cases.py``).

Each :class:`Perturbation` changes only the IMU array (acc_x, acc_y, gyr_z per segment, 100 Hz)
the way a mistake would, and names what it did. Kinds (:data:`KINDS`):

* ``acc_sign`` — acc_y (or both axes) of one sensor negated, or both axes of every sensor;
* ``gyro_sign`` — gyr_z of one leg sensor negated, or of every sensor;
* ``acc_swap`` — acc_x and acc_y of one sensor swapped;
* ``side_swap`` — one leg segment's columns swapped with the other side's;
* ``rate`` — data recorded at ``100 / factor`` Hz stamped as 100 Hz (the motion runs ``factor``
  times as fast);
* ``dead_gyro`` — gyr_z of one sensor replaced by white noise;
* ``on_table`` — one sensor lying still: gravity in a fixed orientation plus sensor noise;
* ``rate_near`` — a rate mislabel the cadence cannot tell: the motion × 0.4–0.8 or × 1.25–2
  (uniform in log; 60 Hz stamped as 100 Hz is × 1.67);
* ``acc_x_sign`` — acc_x of one sensor negated: what a negated 3D gyroscope, or two swapped
  accelerometer axes (Y/Z), of one sensor become after ``sspinn import``'s calibration (it votes
  gyr_z's sign from the gait and keeps a right-handed frame, so acc_x comes out mirrored);
* ``gyro_scale`` — gyr_z of one shank or foot sensor × 0.5.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import CubicSpline

from sspinn.model.conventions import GRAVITY

KINDS: tuple[str, ...] = ("acc_sign", "gyro_sign", "acc_swap", "side_swap", "rate", "dead_gyro", "on_table", "rate_near",
                          "acc_x_sign", "gyro_scale")
#: Mistakes the checks do not claim to detect (measured by ``benchmarks/accuracy/signal_check_rates.py``):
#: the pelvis's gyr_z negated or scaled (it turns too little for the joint constraints), a
#: thigh's gyr_z × 0.5 (the best-fitting thigh scale spans 0.59–1.49 on the untouched CMU trials,
#: so × 0.5 is caught only where the thigh fits near 1), thigh
#: and shank of one leg swapped (their phases stay within 90° of the expected ones), and all
#: sensors of the two legs swapped (the sagittal signals of the two legs differ only by half a
#: stride).
KINDS_NOT_CLAIMED: tuple[str, ...] = ("pelvis_gyro_sign", "thigh_shank_swap", "all_sides_swap")
#: Rate factors the cadence check detects on walking (steps/s at 100 Hz outside 0.5–3.5).
DETECTABLE_RATE_FACTORS: tuple[float, ...] = (0.1, 0.15, 0.2, 0.25, 2.5, 3.0, 5.0, 10.0)
#: Range of the ``rate_near`` factors (and of their inverses), which the joint constraints judge.
NEAR_RATE_FACTORS: tuple[float, float] = (1.25, 2.0)


@dataclass(frozen=True)
class Perturbation:
    """A mistake: its ``kind``, the ``segment`` it concerns (``"all"`` for every sensor) and a
    description with the numbers."""

    kind: str
    segment: str
    description: str


def perturb(imu: np.ndarray, segments: tuple[str, ...], kind: str, rng: np.random.Generator,
            factor: float | None = None) -> tuple[np.ndarray, Perturbation]:
    """A copy of ``imu`` (T, n, 3) with one mistake of ``kind`` drawn with ``rng`` (``factor``:
    the rate factor of ``kind="rate"``, else drawn from :data:`DETECTABLE_RATE_FACTORS`)."""
    out = imu.copy()
    legs = [s for s in segments if s != "pelvis"]
    one = str(rng.choice(list(segments)))
    i = segments.index(one)
    if kind == "acc_sign":
        choice = int(rng.integers(3))
        if choice == 2:
            out[:, :, :2] *= -1
            return out, Perturbation(kind, "all", "acc_x and acc_y of every sensor negated")
        axes = [1] if choice == 0 else [0, 1]
        out[:, i, axes] *= -1
        return out, Perturbation(kind, one, f"{'acc_y' if choice == 0 else 'acc_x and acc_y'} of {one} negated")
    if kind == "gyro_sign":
        if rng.random() < 0.3:
            out[:, :, 2] *= -1
            return out, Perturbation(kind, "all", "gyr_z of every sensor negated")
        leg = str(rng.choice(legs))
        out[:, segments.index(leg), 2] *= -1
        return out, Perturbation(kind, leg, f"gyr_z of {leg} negated")
    if kind == "acc_swap":
        out[:, i, 0], out[:, i, 1] = imu[:, i, 1], imu[:, i, 0]
        return out, Perturbation(kind, one, f"acc_x and acc_y of {one} swapped")
    if kind == "side_swap":
        kinds = [k for k in ("femur", "tibia", "foot") if f"{k}_r" in segments and f"{k}_l" in segments]
        k = str(rng.choice(kinds))
        r, left = segments.index(f"{k}_r"), segments.index(f"{k}_l")
        out[:, [r, left]] = imu[:, [left, r]]
        return out, Perturbation(kind, f"{k}_r", f"columns of {k}_r and {k}_l swapped")
    if kind in ("rate", "rate_near"):
        if factor is not None:
            f = float(factor)
        elif kind == "rate":
            f = float(rng.choice(DETECTABLE_RATE_FACTORS))
        else:
            f = float(np.exp(rng.choice([-1.0, 1.0]) * rng.uniform(*np.log(NEAR_RATE_FACTORS))))
        n = imu.shape[0]
        t = np.arange(n) / 100.0
        t_new = np.arange(int((n - 1) / f) + 1) * f / 100.0
        out = CubicSpline(t, imu, axis=0)(t_new[t_new <= t[-1]])
        return out, Perturbation(kind, "all", f"recorded at {100 / f:.4g} Hz, stamped as 100 Hz (× {f:.3g})")
    if kind == "dead_gyro":
        sigma = float(rng.uniform(0.02, 1.0))
        out[:, i, 2] = rng.normal(float(rng.uniform(-0.05, 0.05)), sigma, size=imu.shape[0])
        return out, Perturbation(kind, one, f"gyr_z of {one} replaced by white noise (σ {sigma:.3f} rad/s)")
    if kind == "on_table":
        angle = float(rng.uniform(-np.pi, np.pi))
        n = imu.shape[0]
        out[:, i, 0] = GRAVITY * np.sin(angle) + rng.normal(0, 0.02, n)
        out[:, i, 1] = GRAVITY * np.cos(angle) + rng.normal(0, 0.02, n)
        out[:, i, 2] = rng.normal(0, 0.005, n)
        return out, Perturbation(kind, one, f"{one} lying still at {np.degrees(angle):+.0f}°")
    if kind == "acc_x_sign":
        out[:, i, 0] *= -1
        return out, Perturbation(kind, one, f"acc_x of {one} negated")
    if kind == "pelvis_gyro_sign":
        out[:, segments.index("pelvis"), 2] *= -1
        return out, Perturbation(kind, "pelvis", "gyr_z of pelvis negated")
    if kind == "gyro_scale":
        leg = str(rng.choice([s for s in legs if not s.startswith("femur")]))
        out[:, segments.index(leg), 2] *= 0.5
        return out, Perturbation(kind, leg, f"gyr_z of {leg} × 0.5")
    if kind == "thigh_shank_swap":
        side = str(rng.choice(["r", "l"]))
        a, b = segments.index(f"femur_{side}"), segments.index(f"tibia_{side}")
        out[:, [a, b]] = imu[:, [b, a]]
        return out, Perturbation(kind, f"femur_{side}", f"columns of femur_{side} and tibia_{side} swapped")
    if kind == "all_sides_swap":
        for k in ("femur", "tibia", "foot"):
            r, left = segments.index(f"{k}_r"), segments.index(f"{k}_l")
            out[:, [r, left]] = out[:, [left, r]]
        return out, Perturbation(kind, "all", "all leg columns swapped between the sides")
    raise ValueError(f"unknown perturbation kind {kind!r}; known: {KINDS}")
