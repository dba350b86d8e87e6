"""Turns while walking, found in the pelvis sensor's rate about the vertical.

The sagittal model describes walking along a straight line. In a turn the whole body rotates
about the vertical: the sagittal signals then mix in motion outside the plane, a calibration
that treats those samples as straight walking finds tilted axes, and the estimate there
describes a gait that did not happen. Real recordings hold turns (the end of a walkway, a
corridor's corner); this module finds them so that calibration can leave them out and the user
is told where they are.

The pelvis turns with the body. Its angular rate about gravity's direction (the yaw rate,
ω · ĝ with ĝ the unit specific force while walking, pointing up) oscillates with every step
(the pelvis rotates forward with the swinging leg, a few degrees) and averages to the rate of
change of the walking direction over one stride. So the yaw rate is averaged over one stride
period; a **turn** is a run of samples where that mean exceeds :data:`TURN_RATE_DEG_S`, widened
by half a stride on each side (the averaging spreads a turn's edges by as much), merged with a
neighbouring run closer than a stride, and kept when the heading changes by at least
:data:`MIN_TURN_DEG` over it (∫ ω · ĝ dt).

Written here: it is a moving mean and a threshold on one signal (:func:`numpy.convolve`),
nothing a library would add.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Final

import numpy as np

from sspinn.data.dataset import Recording
from sspinn.data.gait_events import true_runs

#: Stride-averaged yaw rate above which the walker is turning, deg/s. A 90° turn within 6 s
#: exceeds it; straight walking does not: the pelvis's yaw oscillation cancels over a stride, and
#: an uncorrected gyroscope bias is a fraction of a degree per second.
TURN_RATE_DEG_S: Final = 15.0
#: Smallest heading change that counts as a turn, deg (a drift of the walking direction along a
#: corridor stays below it).
MIN_TURN_DEG: Final = 30.0


@dataclass(frozen=True)
class Turn:
    """A turn of the walking direction.

    Attributes:
        start, stop: samples [start, stop) of the turn (widened by half a stride on each side).
        heading_change_deg: ∫ yaw rate over the turn, deg (+ counter-clockwise seen from above:
            a left turn).
        peak_rate_deg_s: the largest stride-averaged |yaw rate| in it, deg/s.
    """

    start: int
    stop: int
    heading_change_deg: float
    peak_rate_deg_s: float

    def describe(self, rate_hz: float, t0_s: float = 0.0) -> str:
        """``12.30–15.10 s (heading +172°, up to 95°/s)``, times from ``t0_s``."""
        return (f"{t0_s + self.start / rate_hz:.2f}–{t0_s + self.stop / rate_hz:.2f} s (heading {self.heading_change_deg:+.0f}°, "
                f"up to {self.peak_rate_deg_s:.0f}°/s)")


def yaw_rate(gyr: np.ndarray, up: np.ndarray) -> np.ndarray:
    """Angular rate about the vertical, rad/s (T,): ``gyr`` (T, 3) rad/s (bias removed) on the
    unit vector ``up`` (3,) of the sensor frame."""
    return gyr @ (up / np.linalg.norm(up))


def detect_turns(gyr: np.ndarray, up: np.ndarray, rate_hz: float, stride_period_s: float) -> list[Turn]:
    """The turns (module docstring) in the pelvis sensor's bias-free angular rate ``gyr`` (T, 3,
    rad/s), with ``up`` (3,) the direction of gravity's reaction in its frame while walking and
    the stride period in s."""
    stride = max(1, int(round(stride_period_s * rate_hz)))
    omega = yaw_rate(gyr, up)
    mean = np.convolve(omega, np.ones(stride) / stride, mode="same")
    fast = np.abs(mean) > np.radians(TURN_RATE_DEG_S)
    merged: list[list[int]] = []
    for a, b in true_runs(fast):
        a, b = max(0, a - stride // 2), min(len(omega), b + stride // 2)
        if merged and a - merged[-1][1] < stride:
            merged[-1][1] = b
        else:
            merged.append([a, b])
    turns = []
    for a, b in merged:
        change = float(np.degrees(np.sum(omega[a:b]) / rate_hz))
        if abs(change) >= MIN_TURN_DEG:
            turns.append(Turn(a, b, change, float(np.degrees(np.max(np.abs(mean[a:b]))))))
    return turns


def turning_mask(rec: Recording) -> np.ndarray:
    """(T,) bool: the samples of an imported recording inside a turn that ``sspinn import`` found
    (its provenance's ``turning_s``: [start, stop, heading change] in s of the IMU files); all
    False for a recording without them (synthetic data: straight walking)."""
    return rec.provenance_mask("turning_s")


def turn_findings(rec: Recording) -> list[str]:
    """One line naming the recording and the turns ``sspinn import`` found in it (times in s of
    the recording), or none."""
    spans = rec.provenance_spans("turning_s")
    if not spans:
        return []
    where = ", ".join(f"{a:.2f}–{b:.2f} s (heading {float(extra[0]):+.0f}°)" for a, b, extra in spans)
    return [f"{rec.name}: turning at {where}: a sagittal model does not describe a turn, so the estimate there is not "
            "one of the gait"]


__all__ = ["MIN_TURN_DEG", "TURN_RATE_DEG_S", "Turn", "detect_turns", "turn_findings", "turning_mask", "yaw_rate"]
