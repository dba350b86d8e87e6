"""Data-free textbook gait knowledge: typical stride durations and joint-angle shapes.

:func:`typical_stride_duration` fixes (or initialises) the stride duration of the predictive OCP
and of the self-supervised gait generator; :func:`generic_gait` is the OCP's data-free initial
guess (:meth:`~predictive.ocp.collocation.PredictiveGaitProblem.generic_guess`, one amplitude per
start of the multi-start) and the generator's warm-up target. Neither uses recorded data.
"""

from __future__ import annotations

import numpy as np

from sspinn.model.body import BodyParameters
from sspinn.model.conventions import N_Q


def typical_stride_duration(speed: float) -> float:
    """A typical adult stride (gait-cycle) duration in s at ``speed`` in m/s: the line through
    1.14 s at 1.3 m/s (Winter's normal walking: 1.14 s at 1.325 m/s) and 0.70 s at 3.5 m/s
    (running at ≈170 steps/min), ``1.4 − 0.2·v``, clipped to [0.6, 1.4] s (1.4 s: standing)."""
    return float(np.clip(1.4 - 0.2 * speed, 0.6, 1.4))


def generic_gait(
    speed: float, duration: float, time: np.ndarray, body: BodyParameters, amplitude: float = 1.0
) -> np.ndarray:
    """Data-free textbook gait coordinates q (n, 9) at ``time`` (s) for a cycle of ``duration``.

    pelvis_tx = v·t, hip joint centre at a constant height, upright trunk; per leg (left half a
    cycle later), with s = t/T from the leg's heel strike and a stance fraction σ (0.6 walking,
    0.35 running, switched at 2 m/s): hip = h0 + A·cos(2πs), the knee flexed by a Gaussian bump
    in mid-swing (and a smaller one in early stance), the ankle briefly plantarflexed around
    toe-off. For ``speed == 0`` it is quiet standing. Used as the initial guess of the OCP and
    as the warm-up target of the self-supervised gait generator. ``amplitude`` scales the joint
    excursions (hip swing, knee bumps, ankle push-off): the starts of a multi-start
    (:data:`~predictive.ocp.collocation.DEFAULT_STARTS`) differ in it.
    """
    t = np.asarray(time, dtype=float)
    T = float(duration)
    leg = body.femur_r.length + body.tibia_r.length - body.foot_r.toe[1]
    running = speed >= 2.0
    stance = 0.35 if running else 0.6
    hip_amp, knee_stance, knee_swing, ankle_push = (0.45, 0.4, 1.6, 0.3) if running else (0.35, 0.15, 1.0, 0.3)
    if not speed > 0:
        hip_amp = knee_stance = knee_swing = ankle_push = 0.0
    hip_amp, knee_stance, knee_swing, ankle_push = (
        amplitude * a for a in (hip_amp, knee_stance, knee_swing, ankle_push)
    )
    q = np.zeros((len(t), N_Q))
    q[:, 0] = speed * t
    q[:, 1] = (0.92 if running else 0.97) * leg
    q[:, 2] = -0.05 if running else 0.0

    def bump(phase: np.ndarray, centre: float, width: float) -> np.ndarray:
        d = (phase - centre + 0.5) % 1.0 - 0.5
        return np.exp(-((d / width) ** 2))

    for first, offset in ((3, 0.0), (6, 0.5)):
        ph = (t / T + offset) % 1.0
        swing_mid = stance + 0.4 * (1 - stance)
        q[:, first] = 0.1 + hip_amp * np.cos(2 * np.pi * ph)
        q[:, first + 1] = -0.05 - knee_stance * bump(ph, 0.15, 0.1) - knee_swing * bump(ph, swing_mid, 0.15)
        q[:, first + 2] = 0.05 - ankle_push * bump(ph, stance, 0.08)
    return q
