"""Gait quality of a simulated (or measured) walk: left/right asymmetry, foot sliding, impact
peaks, joint angles against Winter's normal walking, cost of transport.

One function, :func:`gait_metrics`, for every part of the project: the environments' episodes
(:mod:`agents.rollout` builds a :class:`~sspinn.model.trajectory.Trajectory` from an episode's 100 Hz
samples), predicted gaits and estimates. Gait events come from the project's one detector,
:func:`sspinn.data.gait_events.detect_events` (vertical GRF above 5 % BW, phases shorter than 50 ms
removed); foot positions and speeds from the model's kinematics (:func:`sspinn.model.kinematics.point_kinematics`).

Definitions (each over the events at or after ``settle_s``; NaN where there are too few events):

* **step** of foot X: from the other foot's heel strike to X's next heel strike, alternating
  feet only (two strikes of the same foot in a row are not a step). Step time (s); step length
  (m): forward distance from the other foot's heel to X's heel at X's heel strike.
* **stance %** of foot X: contact duration from a heel strike to its toe-off, in % of that
  stride (heel strike to X's next heel strike; strides of 0.3–3 s, :func:`sspinn.data.gait_events.strides`).
  Undefined for a foot that never leaves the ground (no strides): the **contact share** — the
  share of the time from ``settle_s`` to the end in contact, % — is defined for every gait and
  shows such a dragging foot (100 %).
* **asymmetry** of a quantity with right/left means R and L: the symmetry index
  SI = 100 · |R − L| / ((R + L) / 2) in % (Robinson, Herzog & Nigg 1987, *J Manipulative Physiol
  Ther* 10:172–176); 0 for a symmetric gait.
* **foot sliding**: ∫ |v_x| dt of the foot's contact point (the foot-fixed point at fraction w of
  the trajectory, where the friction law acts) over each complete contact phase; its mean per step
  (cm) and the total over all contact phases (m).
* **impact peak**: the largest vertical GRF of a foot within 0.1 s after its heel strike (BW), the
  mean over heel strikes; and the largest vertical GRF of the whole trajectory (BW).
* **angle RMSD** to a reference cycle (Winter's normal walking, right leg, :func:`load_winter`):
  each leg's mean cycle from its own heel strikes, time-normalised
  (:func:`sspinn.data.gait_events.normalise_cycles`), against the reference's hip, knee and ankle
  angles (degrees), averaged over the legs that have strides (a normal gait is left/right
  symmetric up to half a cycle, so both legs compare with the same reference).
* **cost of transport** (mechanical, dimensionless): Σ_k Σ_j |τ_j[k] · (θ_j[k+1] − θ_j[k])| /
  (m·g·(x_end − x_start)), with ``tau[k]`` the torque held from ``time[k]`` to ``time[k+1]`` (the
  environment's convention; the environment reports the same quantity in ``info``), over the
  whole trajectory; NaN when the hip moved less than 1 cm forward.
* **cadence**: 60 / mean step time, steps/min.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, fields
from pathlib import Path
from typing import Any, Final

import numpy as np

from sspinn.data.gait_events import CONTACT_THRESHOLD_BW, MIN_PHASE_S, detect_events, normalise_cycles, strides
from sspinn.data.shared_data import shared_data_folder
from sspinn.model import kinematics
from sspinn.model.body import BodyParameters
from sspinn.model.trajectory import Trajectory

#: Window after a heel strike in which the impact peak is taken, s.
IMPACT_WINDOW_S: Final = 0.1
_HEEL = (kinematics.point_index("heel_r"), kinematics.point_index("heel_l"))
_CONTACT = (kinematics.point_index("contact_r"), kinematics.point_index("contact_l"))


@dataclass(frozen=True)
class ReferenceGait:
    """A normalised gait cycle starting at right heel strike (``n`` samples over 0 … 100 %)."""

    percent: np.ndarray  # (n,) % of the cycle
    hip: np.ndarray  # (n,) rad
    knee: np.ndarray  # (n,) rad
    ankle: np.ndarray  # (n,) rad
    grf_x: np.ndarray  # (n,) BW, right foot
    grf_y: np.ndarray  # (n,) BW, right foot
    speed: float  # m/s
    duration: float  # s


def load_winter(data_dir: str | Path | None = None) -> ReferenceGait:
    """Winter's averaged normal walking, right leg (D.A. Winter, *Biomechanics and Motor Control of
    Human Gait*; 1.325 m/s, 50 samples per stride from right heel strike, sspinn signs), from
    ``<data_dir>/winter_walking`` (``data_dir`` defaults to ``$SSPINN_SHARED_DATA``,
    :mod:`sspinn.data.shared_data`); :class:`FileNotFoundError` with a one-line message when that
    optional data is absent."""
    folder = shared_data_folder("winter_walking", data_dir)
    csv, meta_path = folder / "signals.csv", folder / "meta.json"
    if not csv.exists():
        raise FileNotFoundError(f"{csv}: not found (Winter's walking, optional public data)")
    data = np.genfromtxt(csv, delimiter=",", names=True)
    meta = json.loads(meta_path.read_text())
    n = len(data)
    return ReferenceGait(
        percent=np.arange(n) * 100.0 / n,
        hip=data["hip_flexion_r_angle"],
        knee=data["knee_angle_r_angle"],
        ankle=data["ankle_angle_r_angle"],
        grf_x=data["grf_x_r"],
        grf_y=data["grf_y_r"],
        speed=float(meta["speed_mps"]["mean"]),
        duration=float(meta["stride_duration_s"]["mean"]),
    )


def winter_or_none(data_dir: str | Path | None = None) -> ReferenceGait | None:
    """:func:`load_winter`, or None when the optional data is absent."""
    try:
        return load_winter(data_dir)
    except FileNotFoundError:
        return None


@dataclass(frozen=True)
class GaitMetrics:
    """Gait quality of one trajectory (module docstring for the definitions). Right/left pairs end
    in ``_r``/``_l``; NaN where undefined (too few events, no reference).

    Attributes:
        steps_r, steps_l: steps counted per foot (alternating heel strikes).
        heel_strikes_r, heel_strikes_l: heel strikes per foot.
        step_time_r, step_time_l: mean step time, s.
        step_length_r, step_length_l: mean step length, m.
        stance_percent_r, stance_percent_l: mean stance phase, % of the stride.
        contact_share_r, contact_share_l: share of the analysed time in contact, %.
        flight_percent: share of the analysed time with neither foot in contact, % (running's
            flight phase; 0 in walking).
        step_time_asymmetry, step_length_asymmetry, stance_asymmetry, contact_asymmetry: symmetry
            indices, %.
        foot_slide_per_step_cm: mean sliding of the contact point per contact phase, cm.
        foot_slide_m: total sliding over all contact phases, both feet, m.
        peak_impact_bw: mean impact peak (vertical GRF within 0.1 s after heel strike), BW.
        max_vertical_grf_bw: largest vertical GRF of either foot, BW.
        cost_of_transport: mechanical cost of transport (dimensionless).
        cadence_steps_per_min: 60 / mean step time.
        rmsd_hip_deg, rmsd_knee_deg, rmsd_ankle_deg: angle RMSD to the reference, deg (mean over legs).
    """

    steps_r: int
    steps_l: int
    heel_strikes_r: int
    heel_strikes_l: int
    step_time_r: float
    step_time_l: float
    step_length_r: float
    step_length_l: float
    stance_percent_r: float
    stance_percent_l: float
    contact_share_r: float
    contact_share_l: float
    flight_percent: float
    step_time_asymmetry: float
    step_length_asymmetry: float
    stance_asymmetry: float
    contact_asymmetry: float
    foot_slide_per_step_cm: float
    foot_slide_m: float
    peak_impact_bw: float
    max_vertical_grf_bw: float
    cost_of_transport: float
    cadence_steps_per_min: float
    rmsd_hip_deg: float
    rmsd_knee_deg: float
    rmsd_ankle_deg: float

    @classmethod
    def undefined(cls) -> GaitMetrics:
        """The metrics of a trajectory too short for any: no steps, NaN everywhere else."""
        values = {f.name: (0 if f.type in (int, "int") else float("nan")) for f in fields(cls)}
        return cls(**values)

    def as_dict(self) -> dict[str, Any]:
        """JSON-friendly values (NaN and inf → None)."""
        return {k: (v if not isinstance(v, float) or math.isfinite(v) else None) for k, v in asdict(self).items()}


def symmetry_index(right: float, left: float) -> float:
    """100 · |R − L| / ((R + L) / 2), % (NaN if either is NaN or both are 0)."""
    mean = 0.5 * (right + left)
    return float(100.0 * abs(right - left) / mean) if mean != 0 and math.isfinite(mean) else float("nan")


def _mean(values: list[float]) -> float:
    return float(np.mean(values)) if values else float("nan")


def angle_rmsd(q: np.ndarray, leg_strides: list[list[tuple[int, int]]], reference: ReferenceGait | None) -> dict[str, float]:
    """Hip, knee and ankle RMSD (deg) of each leg's mean cycle to a reference cycle, averaged over
    the legs with strides: ``{"hip": …, "knee": …, "ankle": …}``, NaN without a reference or strides.

    Args:
        q: (T, 9) coordinates (:mod:`sspinn.model.conventions`; joints in rad from column 3,
            right hip, knee, ankle, then left).
        leg_strides: the right and the left leg's heel-strike-to-heel-strike cycles (sample
            indices, :func:`sspinn.data.gait_events.strides`).
        reference: the reference cycle (e.g. :func:`load_winter`), or None.
    """
    per_leg: dict[str, list[float]] = {"hip": [], "knee": [], "ankle": []}
    for f, cycles in enumerate(leg_strides):
        if reference is None or not cycles:
            continue
        for j, name in enumerate(("hip", "knee", "ankle")):
            cycle = normalise_cycles(q[:, 3 + 3 * f + j], cycles).mean(axis=0)
            sim = np.interp(reference.percent, np.linspace(0.0, 100.0, len(cycle)), cycle)
            per_leg[name].append(float(np.degrees(np.sqrt(np.mean((sim - getattr(reference, name)) ** 2)))))
    return {name: _mean(values) for name, values in per_leg.items()}


def gait_metrics(
    trajectory: Trajectory,
    body: BodyParameters,
    *,
    reference: ReferenceGait | None = None,
    settle_s: float = 0.0,
    threshold_bw: float = CONTACT_THRESHOLD_BW,
    min_phase_s: float = MIN_PHASE_S,
) -> GaitMetrics:
    """The :class:`GaitMetrics` of a trajectory sampled at a constant rate (fewer than 3 samples:
    :meth:`GaitMetrics.undefined`).

    Args:
        trajectory: the motion (q, u, grf in N, tau in N·m held over each interval, w; ``qdd`` is
            not used).
        body: the body parameters (body weight, segment geometry for the foot positions).
        reference: a reference cycle for the angle RMSD (e.g. :func:`load_winter`); None: NaN.
        settle_s: events before this time (s from the first sample) are ignored (gait initiation).
        threshold_bw, min_phase_s: the contact detector's threshold (BW) and shortest phase (s),
            :func:`sspinn.data.gait_events.detect_events`.
    """
    t = trajectory.time
    if len(t) < 3:
        return GaitMetrics.undefined()
    dt = float(np.median(np.diff(t)))
    rate = 1.0 / dt
    bw = body.body_weight
    grf = trajectory.grf
    zeros = np.zeros_like(trajectory.q)
    points = np.asarray(kinematics.point_kinematics(trajectory.q, trajectory.u, zeros, trajectory.w, body))
    events = [detect_events(grf[:, 2 * f + 1], bw, rate, threshold_bw, min_phase_s) for f in range(2)]
    first = int(np.searchsorted(t - t[0], settle_s - 1e-9))

    # steps: alternating heel strikes
    strikes = sorted((int(h), f) for f in range(2) for h in events[f].heel_strikes if h >= first)
    step_time: list[list[float]] = [[], []]
    step_length: list[list[float]] = [[], []]
    for (a, fa), (b, fb) in zip(strikes[:-1], strikes[1:]):
        if fa != fb:
            step_time[fb].append(float(t[b] - t[a]))
            step_length[fb].append(float(points[b, _HEEL[fb], 0] - points[b, _HEEL[fa], 0]))

    # stance %, foot sliding, impact peaks per foot
    stance: list[list[float]] = [[], []]
    contact_share = [float(100.0 * np.mean(ev.contact[first:])) if first < len(t) else float("nan") for ev in events]
    slide_steps: list[float] = []
    impacts: list[float] = []
    slide_total = 0.0
    window = max(1, int(round(IMPACT_WINDOW_S * rate)))
    for f in range(2):
        ev = events[f]
        heel = ev.heel_strikes[ev.heel_strikes >= first]
        vx = np.abs(points[:, _CONTACT[f], 2])  # columns x, y, vx, vy, ax, ay
        slide_total += float(np.sum(vx[first:][ev.contact[first:]]) * dt)
        for a, b in strides(heel, rate):
            offs = ev.toe_offs[(ev.toe_offs > a) & (ev.toe_offs <= b)]
            if len(offs):
                stance[f].append(100.0 * (offs[0] - a) / (b - a))
        for h in heel:
            impacts.append(float(grf[h : h + window, 2 * f + 1].max() / bw))
            offs = ev.toe_offs[ev.toe_offs > h]
            if len(offs):
                slide_steps.append(float(np.sum(vx[h : offs[0]]) * dt))

    # angle RMSD of each leg's mean cycle, averaged over the legs with strides
    rmsd = angle_rmsd(trajectory.q, [strides(events[f].heel_strikes[events[f].heel_strikes >= first], rate) for f in range(2)],
                      reference)

    # cost of transport over the whole trajectory
    angles = trajectory.q[:, 3:]
    work = float(np.sum(np.abs(trajectory.tau[:-1] * np.diff(angles, axis=0))))
    distance = float(trajectory.q[-1, 0] - trajectory.q[0, 0])
    cot = work / (bw * distance) if distance > 0.01 else float("nan")

    times = step_time[0] + step_time[1]
    means = {name: [_mean(v[0]), _mean(v[1])] for name, v in (("time", step_time), ("length", step_length), ("stance", stance))}
    return GaitMetrics(
        steps_r=len(step_time[0]),
        steps_l=len(step_time[1]),
        heel_strikes_r=int(np.sum(events[0].heel_strikes >= first)),
        heel_strikes_l=int(np.sum(events[1].heel_strikes >= first)),
        step_time_r=means["time"][0],
        step_time_l=means["time"][1],
        step_length_r=means["length"][0],
        step_length_l=means["length"][1],
        stance_percent_r=means["stance"][0],
        stance_percent_l=means["stance"][1],
        contact_share_r=contact_share[0],
        contact_share_l=contact_share[1],
        flight_percent=float(100.0 * np.mean(~(events[0].contact[first:] | events[1].contact[first:])))
        if first < len(t) else float("nan"),
        step_time_asymmetry=symmetry_index(*means["time"]),
        step_length_asymmetry=symmetry_index(*means["length"]),
        stance_asymmetry=symmetry_index(*means["stance"]),
        contact_asymmetry=symmetry_index(*contact_share),
        foot_slide_per_step_cm=100.0 * _mean(slide_steps),
        foot_slide_m=slide_total,
        peak_impact_bw=_mean(impacts),
        max_vertical_grf_bw=float(grf[:, [1, 3]].max() / bw),
        cost_of_transport=cot,
        cadence_steps_per_min=60.0 / _mean(times) if times and _mean(times) > 0 else float("nan"),
        rmsd_hip_deg=rmsd["hip"],
        rmsd_knee_deg=rmsd["knee"],
        rmsd_ankle_deg=rmsd["ankle"],
    )


__all__ = ["IMPACT_WINDOW_S", "GaitMetrics", "ReferenceGait", "angle_rmsd", "gait_metrics", "load_winter",
           "symmetry_index", "winter_or_none"]
