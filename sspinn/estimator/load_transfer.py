"""Offline redistribution of an estimate's vertical ground reaction force between the feet in
double support: the load moves from the trailing to the leading foot at a constant rate.

While both feet are on the ground the equations of motion fix the total force, not how it is
shared: inverse dynamics from kinematics alone must add an assumption there, and the methods that
estimate forces from inertial motion capture do (Karatsidis et al. 2017, Sensors 17(1):75: the total
from the equations of motion, the share from a smooth transition assumption). The network decides
the share by itself; trained on synthetic gaits it learned theirs, in which the trailing foot
unloads early. Real walkers unload it at a nearly constant rate: in the twelve CMU treadmill trials
(six subjects, normal and stiff-knee walking) the trailing foot's mean share of the vertical force,
in tenths of the double support, falls 0.85, 0.74, 0.64, 0.56, 0.50, 0.43, 0.35, 0.28, 0.20, 0.13
(trial means; each trial within 0.11 of them), while ``make demo``'s model estimates 0.85, 0.74,
0.64, 0.52, 0.43, 0.34, 0.26, 0.20, 0.16, 0.11 for the same trials.

:func:`linear_load_transfer` keeps each double support's total vertical force, its first and last
sample and everything outside double support, and sets the trailing foot's share to a straight line
between its values at the first and the last sample (no parameter: the edges are where the
contact threshold is crossed, so gait events do not move). The joint torques follow the new forces
(their change is the inverse dynamics of the change of force, so the equations of motion of the
joints hold as they did); the pelvis's rotational row of the Kane residual changes, as the network
had balanced it with its own share. Where torques are known that consistency costs accuracy (the
synthetic test walkers' and the real averaged stride's torque errors rise 6–7 %: the network's
torques match its own share better). It needs the end of each double support, so it is offline
(:func:`~sspinn.estimator.inference.estimate_recording`'s ``load_transfer``), not for the stream.
The horizontal forces are left as estimated (in double support they brake and propel, so a share of
their total means nothing). The quality signal and the uncertainty intervals of ``sspinn infer`` stay
those of the network's own estimate (the intervals were calibrated on it, not on the transferred one). What it does, measured: docs/results/cmu_treadmill.md ("Load transfer in
double support").
"""

from __future__ import annotations

import dataclasses
from typing import Final, TypeVar

import numpy as np

from sspinn.data.gait_events import MIN_STANDING_S, foot_contacts, true_runs
from sspinn.model import dynamics
from sspinn.model.body import BodyParameters
from sspinn.model.trajectory import Trajectory

T = TypeVar("T", bound=Trajectory)

#: Shortest double support redistributed, samples: a line needs a sample between its two ends.
MIN_DOUBLE_SUPPORT_SAMPLES: Final = 3


def double_supports(grf: np.ndarray, body_weight: float, rate_hz: float) -> list[tuple[int, int, int]]:
    """``(start, stop, trailing)`` of every double support in a GRF (T, 4) ``[Fx_r, Fy_r, Fx_l, Fy_l]``
    (N): both feet in contact (:func:`~sspinn.data.gait_events.foot_contacts`) in samples
    [start, stop), entered from single support on foot ``trailing`` (0 right, 1 left). Those cut by
    the recording's edges, entered from flight or from both feet, shorter than
    :data:`MIN_DOUBLE_SUPPORT_SAMPLES` or as long as standing (:data:`~sspinn.data.gait_events.MIN_STANDING_S`)
    are left out."""
    right, left = foot_contacts(grf, body_weight, rate_hz)
    out = []
    for start, stop in true_runs(right & left):
        if start == 0 or stop >= len(grf) or not MIN_DOUBLE_SUPPORT_SAMPLES <= stop - start < MIN_STANDING_S * rate_hz:
            continue
        if right[start - 1] != left[start - 1]:
            out.append((start, stop, 0 if right[start - 1] else 1))
    return out


def linear_load_transfer(estimate: T, body: BodyParameters, rate_hz: float) -> T:
    """``estimate`` with the vertical GRF of every double support (:func:`double_supports`) shared
    so that the trailing foot's share falls linearly from its first to its last sample, and the
    joint torques changed by the inverse dynamics of the change of force (a new trajectory; the
    input is not modified). See the module docstring for why and what it leaves alone."""
    grf = np.array(estimate.grf, dtype=float)
    for start, stop, trailing in double_supports(grf, body.body_weight, rate_hz):
        trail, lead = (1, 3) if trailing == 0 else (3, 1)
        total = grf[start:stop, 1] + grf[start:stop, 3]
        first, last = grf[start, trail] / total[0], grf[stop - 1, trail] / total[-1]
        share = np.linspace(first, last, stop - start)
        grf[start:stop, trail] = share * total
        grf[start:stop, lead] = (1.0 - share) * total
    rows = np.flatnonzero((grf != estimate.grf).any(axis=1))
    tau = np.array(estimate.tau, dtype=float)
    if len(rows):
        p = body.vector()
        q, u, qdd, w = (np.asarray(x)[rows] for x in (estimate.q, estimate.u, estimate.qdd, estimate.w))
        before, _ = dynamics.inverse_dynamics(q, u, qdd, np.asarray(estimate.grf)[rows], w, p)
        after, _ = dynamics.inverse_dynamics(q, u, qdd, grf[rows], w, p)
        tau[rows] += np.asarray(after) - np.asarray(before)
    return dataclasses.replace(estimate, grf=grf, tau=tau)


def share_profile(grf: np.ndarray, body_weight: float, rate_hz: float, bins: int = 10) -> np.ndarray:
    """(bins,) the trailing foot's mean share of the vertical force in each ``bins``-th of the
    double supports (:func:`double_supports`) of a GRF (T, 4) (N), NaN where none falls; rows that
    are not finite count as no contact."""
    grf = np.where(np.isfinite(grf).all(axis=1, keepdims=True), grf, 0.0)
    sums, counts = np.zeros(bins), np.zeros(bins)
    for start, stop, trailing in double_supports(grf, body_weight, rate_hz):
        share = grf[start:stop, 1 if trailing == 0 else 3] / (grf[start:stop, 1] + grf[start:stop, 3])
        k = np.minimum(((np.arange(stop - start) + 0.5) / (stop - start) * bins).astype(int), bins - 1)
        np.add.at(sums, k, share)
        np.add.at(counts, k, 1)
    with np.errstate(invalid="ignore"):
        return sums / counts
