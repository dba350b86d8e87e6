"""Comparison of a gait solution (e.g. IMU tracking) with the labels of an averaged stride.

The metrics are SSPINNpose's (:func:`sspinn.estimator.evaluation.compute_metrics`, pooled over the
available label columns and samples): joint-angle RMSD (deg), joint-moment RMSD (%BW·BH),
GRF RMSE (%BW, horizontal and vertical pooled) and speed error (m/s); added here are the
per-joint values and the Pearson correlation of the joint moments. They are reported next to
the optimal-control (OCP) figures that the SSPINNpose paper quotes for Dorschky et al. (2019) on
the same kind of data (:data:`PAPER_OCP`).

Time alignment: the solution's node times t_k = k·T/N are the data's times (the tracked data
start at right heel strike at t = 0 and node 0 was tracked to the data's first sample), so by
default the solution is compared at the label times without any shift (``align="data"``). The
heel strike of the model (first node whose right vertical GRF exceeds
:data:`~sspinn.data.gait_events.CONTACT_THRESHOLD_BW`) and of the labels (same threshold) are reported
as a check; ``align="heel_strike"`` instead shifts the solution in time so that the two coincide.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np

from predictive.ocp.solution import GaitSolution
from predictive.ocp.tracking import TrackingResult
from predictive.ocp.tracking_data import signals_from_solution, stride_duration
from sspinn.data.dataset import SAMPLE_RATE_HZ, Labels, Recording
from sspinn.data.gait_events import CONTACT_THRESHOLD_BW, contact_onsets
from sspinn.estimator.evaluation import compute_metrics
from sspinn.estimator.inference import GaitEstimate
from sspinn.model.body import IMUPlacement
from sspinn.model.conventions import COORDINATES, GRAVITY, GRF, IMU_CHANNELS, JOINTS, SEGMENTS, imu_columns
from sspinn.model.drawing import save_figure
from sspinn.run_folder import atomic_write_json

#: Optimal-control baseline (IMU tracking, Dorschky et al. 2019, J Biomech 95:109278) as quoted in
#: the SSPINNpose paper for the averaged strides: joint angles RMSD (deg), joint moments RMSD
#: (%BW·BH), GRF RMSE (%BW), speed error (m/s), computation time (min per gait cycle).
PAPER_OCP: dict[str, float] = {
    "angle_rmsd_deg": 6.3,
    "moment_rmsd_pct_bwbh": 2.6,
    "grf_rmse_pct_bw": 17.9,
    "speed_error_mps": 0.25,
    "time_min": 50.0,
}

Align = Literal["data", "heel_strike"]


@dataclass
class LabelComparison:
    """Errors of a solution against an averaged stride's labels (see the module docstring).

    Per-joint dicts are keyed by ``hip``, ``knee``, ``ankle`` (right leg, the labelled one).
    ``angle_bias_deg`` is the mean of estimate − label and ``angle_rmsd_without_bias_deg`` the
    RMSD after removing it (a diagnostic: constant offsets come from segment/sensor frame
    definitions that differ between the model and the labels' pipeline).
    """

    angle_rmsd_deg: float
    moment_rmsd_pct_bwbh: float
    grf_rmse_pct_bw: float
    speed_error_mps: float
    speed_estimated_mps: float
    speed_reference_mps: float
    solve_time_s: float
    angle_rmsd_per_joint_deg: dict[str, float] = field(default_factory=dict)
    angle_bias_deg: dict[str, float] = field(default_factory=dict)
    angle_rmsd_without_bias_deg: dict[str, float] = field(default_factory=dict)
    moment_rmsd_per_joint_pct_bwbh: dict[str, float] = field(default_factory=dict)
    moment_correlation: dict[str, float] = field(default_factory=dict)
    grf_rmse_per_component_pct_bw: dict[str, float] = field(default_factory=dict)
    heel_strike_model_pct: float = float("nan")
    heel_strike_labels_pct: float = float("nan")
    shift_applied_pct: float = 0.0
    solve_time_detail: str = ""

    @property
    def mean_moment_correlation(self) -> float:
        return float(np.mean(list(self.moment_correlation.values()))) if self.moment_correlation else float("nan")

    def as_dict(self) -> dict[str, Any]:
        return {**asdict(self), "mean_moment_correlation": self.mean_moment_correlation}

    def table(self) -> str:
        """Markdown table: this solution next to the paper's OCP figures."""
        p = PAPER_OCP
        rows = [
            ("joint angles RMSD (deg)", f"{self.angle_rmsd_deg:.1f}", f"{p['angle_rmsd_deg']:.1f}",
             _per_joint(self.angle_rmsd_per_joint_deg, "{:.1f}")),
            ("  without constant offset (deg)", f"{_mean(self.angle_rmsd_without_bias_deg):.1f}", "–",
             "offsets " + _per_joint(self.angle_bias_deg, "{:+.1f}")),
            ("joint moments RMSD (%BW·BH)", f"{self.moment_rmsd_pct_bwbh:.2f}", f"{p['moment_rmsd_pct_bwbh']:.1f}",
             _per_joint(self.moment_rmsd_per_joint_pct_bwbh, "{:.2f}")),
            ("joint moments correlation r", f"{self.mean_moment_correlation:.2f}", "–",
             _per_joint(self.moment_correlation, "{:.2f}")),
            ("GRF RMSE (%BW)", f"{self.grf_rmse_pct_bw:.1f}", f"{p['grf_rmse_pct_bw']:.1f}",
             _per_joint(self.grf_rmse_per_component_pct_bw, "{:.1f}")),
            ("speed error (m/s)", f"{self.speed_error_mps:.3f}", f"{p['speed_error_mps']:.2f}",
             f"estimated {self.speed_estimated_mps:.3f}, recorded {self.speed_reference_mps:.3f}"),
            ("solve time (min)", f"{self.solve_time_s / 60:.2f}", f"{p['time_min']:.0f}", self.solve_time_detail),
        ]
        lines = ["| metric | this OCP | paper OCP (Dorschky 2019) | details |", "|---|---|---|---|"]
        lines += [f"| {a} | {b} | {c} | {d} |" for a, b, c, d in rows]
        return "\n".join(lines)


def _mean(values: dict[str, float]) -> float:
    return float(np.mean(list(values.values()))) if values else float("nan")


def _per_joint(values: dict[str, float], fmt: str) -> str:
    return ", ".join(f"{k} {fmt.format(v)}" for k, v in values.items())


def solution_at_times(sol: GaitSolution, times: np.ndarray, shift: float = 0.0, name: str = "ocp") -> GaitEstimate:
    """The solution as a :class:`~sspinn.estimator.inference.GaitEstimate` at ``times`` (s), by periodic
    linear interpolation of the node values; the sample at time t is the solution at t + shift
    (s). pelvis_tx continues by v·t."""
    times = np.asarray(times, dtype=float)
    at = sol.resample(times + shift, period=sol.duration, speed=sol.speed)
    return GaitEstimate(**{**at.arrays(), "time": times}, name=name)


def recording_from_solution(sol: GaitSolution, placement: IMUPlacement, name: str = "synthetic") -> Recording:
    """A synthetic averaged stride from a solution: its virtual IMU signals (every sagittal
    channel, :func:`~predictive.ocp.tracking_data.signals_from_solution`) and its labels
    (angles, torques, GRFs, speed) at :data:`~sspinn.data.dataset.SAMPLE_RATE_HZ`, by periodic
    linear interpolation of the nodes (exact at nodes on that grid). Its stride starts where the
    solution does (start it at right heel strike with
    :func:`~predictive.ocp.imu_tracking.roll_cycle` to mimic an averaged stride)."""
    names = imu_columns()
    signals = signals_from_solution(sol, names, placement)
    t = np.arange(int(round(sol.duration * SAMPLE_RATE_HZ))) / SAMPLE_RATE_HZ
    imu = np.stack([np.interp(t, sol.time, s.target, period=sol.duration) for s in signals], -1)
    est = solution_at_times(sol, t)
    columns = {c: est.q[:, i] for i, c in enumerate(COORDINATES)}
    columns |= {f"tau_{j}": est.tau[:, i] for i, j in enumerate(JOINTS)}
    columns |= {g: est.grf[:, i] for i, g in enumerate(GRF)}
    columns["speed"] = np.full(len(t), sol.speed)
    return Recording(
        name=name, imu=imu.reshape(len(t), len(SEGMENTS), len(IMU_CHANNELS)), segments=SEGMENTS,
        height=sol.body.height, mass=sol.body.mass, placement=placement,
        labels=Labels.from_columns(columns, len(t)), provenance={"stride_duration_s": sol.duration},
    )


def _heel_strike_pct(fy_bw: np.ndarray) -> float:
    """% of the cycle at which a periodic vertical GRF (BW, sampled uniformly over one cycle)
    first rises above the contact threshold after being below it
    (:func:`sspinn.data.gait_events.contact_onsets`)."""
    onsets = contact_onsets(fy_bw, CONTACT_THRESHOLD_BW, periodic=True)
    return float(100.0 * onsets[0] / len(fy_bw)) if len(onsets) else float("nan")


def compare_with_labels(
    sol: GaitSolution,
    recording: Recording,
    align: Align = "data",
    solve_time_s: float | None = None,
    solve_time_detail: str = "",
) -> LabelComparison:
    """Errors of ``sol`` against ``recording``'s labels over its first stride (see the module
    docstring for the alignment). Moments are normalised by BW·BH and GRFs by BW of the
    recording's (assumed) mass and height; ``solve_time_s`` (s) defaults to ``sol.solve_time``
    (IPOPT only) and ``solve_time_detail`` says what it includes."""
    if recording.labels is None:
        raise ValueError(f"{recording.name}: no labels to compare with")
    T = stride_duration(recording)
    keep = recording.time < T - 1e-9
    rec = _first_stride(recording, keep)
    lab = rec.labels
    assert lab is not None
    have = set(lab.columns())
    bw = rec.mass * GRAVITY
    hs_labels = _heel_strike_pct(lab.column("grf_y_r") / bw) if "grf_y_r" in have else float("nan")
    hs_model = 100.0 * sol.right_heel_strike() / sol.n_nodes
    shift = 0.0
    if align == "heel_strike":
        d = (hs_model - hs_labels + 50.0) % 100.0 - 50.0
        shift = d / 100.0 * sol.duration
    elif align != "data":
        raise ValueError(f"align must be 'data' or 'heel_strike', got {align!r}")
    est = solution_at_times(sol, rec.time, shift=shift)
    metrics = compute_metrics(est, rec)
    bwbh = bw * rec.height
    angles, bias, unbiased, moments, corr, grf = {}, {}, {}, {}, {}, {}
    for j in ("hip", "knee", "ankle"):
        joint = f"{j}_r"
        if joint in have:
            e = est.q[:, COORDINATES.index(joint)] - lab.column(joint)
            angles[j] = float(np.degrees(np.sqrt(np.mean(e**2))))
            bias[j] = float(np.degrees(np.mean(e)))
            unbiased[j] = float(np.degrees(np.std(e)))
        if f"tau_{joint}" in have:
            ref = lab.column(f"tau_{joint}")
            sim = est.tau[:, JOINTS.index(joint)]
            moments[j] = float(100 * np.sqrt(np.mean((sim - ref) ** 2)) / bwbh)
            corr[j] = float(np.corrcoef(sim, ref)[0, 1])
    for g in GRF:
        if g in have:
            grf[g] = float(100 * np.sqrt(np.mean((est.grf[:, GRF.index(g)] - lab.column(g)) ** 2)) / bw)
    v_ref = float(np.mean(lab.column("speed"))) if "speed" in have else float("nan")
    return LabelComparison(
        angle_rmsd_deg=metrics.jae_deg,
        moment_rmsd_pct_bwbh=metrics.jte_pct_bwbh,
        grf_rmse_pct_bw=metrics.grfe_pct_bw,
        speed_error_mps=abs(sol.speed - v_ref),
        speed_estimated_mps=sol.speed,
        speed_reference_mps=v_ref,
        solve_time_s=float(sol.solve_time if solve_time_s is None else solve_time_s),
        angle_rmsd_per_joint_deg=angles,
        angle_bias_deg=bias,
        angle_rmsd_without_bias_deg=unbiased,
        moment_rmsd_per_joint_pct_bwbh=moments,
        moment_correlation=corr,
        grf_rmse_per_component_pct_bw=grf,
        heel_strike_model_pct=hs_model,
        heel_strike_labels_pct=hs_labels,
        shift_applied_pct=100.0 * shift / sol.duration,
        solve_time_detail=solve_time_detail or "IPOPT only",
    )


def _first_stride(recording: Recording, keep: np.ndarray) -> Recording:
    return Recording(
        name=recording.name, imu=recording.imu[keep], segments=recording.segments, height=recording.height,
        mass=recording.mass, subject=recording.subject, placement=recording.placement,
        labels=recording.labels.slice(slice(0, int(keep.sum()))) if recording.labels is not None else None,
        provenance=dict(recording.provenance),
    )


def plot_against_labels(
    sol: GaitSolution,
    recording: Recording,
    path: str | Path,
    tracking: TrackingResult | None = None,
    title: str | None = None,
) -> Path:
    """PNG: right hip/knee/ankle angles (deg), moments (%BW·BH) and GRF (BW) of the solution
    (solid) and the labels (dashed) over % gait cycle from right heel strike; with a tracking
    result also the normalised RMSE of every tracked signal."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    T = stride_duration(recording)
    keep = recording.time < T - 1e-9
    rec = _first_stride(recording, keep)
    lab = rec.labels
    fine = np.linspace(0.0, T, 201)[:-1]
    est = solution_at_times(sol, fine)
    pct_sim, pct_lab = 100 * fine / T, 100 * rec.time / T
    bw = rec.mass * GRAVITY
    bwbh = bw * rec.height
    fig, axes = plt.subplots(3, 3, figsize=(13, 9), sharex=True)
    for col, j in enumerate(("hip", "knee", "ankle")):
        joint = f"{j}_r"
        sign = "flexion −" if j == "knee" else ("dorsiflexion +" if j == "ankle" else "flexion +")
        ax = axes[0, col]
        ax.plot(pct_sim, np.degrees(est.q[:, COORDINATES.index(joint)]), label="IMU tracking OCP")
        if lab is not None and joint in lab.columns():
            ax.plot(pct_lab, np.degrees(lab.column(joint)), "k--", label="labels")
        ax.set_title(f"{joint} angle ({sign}) [deg]")
        ax = axes[1, col]
        ax.plot(pct_sim, 100 * est.tau[:, JOINTS.index(joint)] / bwbh)
        if lab is not None and f"tau_{joint}" in lab.columns():
            ax.plot(pct_lab, 100 * lab.column(f"tau_{joint}") / bwbh, "k--")
        ax.set_title(f"{joint} moment [%BW·BH]")
    for col, g in enumerate(("grf_x_r", "grf_y_r")):
        ax = axes[2, col]
        ax.plot(pct_sim, est.grf[:, GRF.index(g)] / bw)
        if lab is not None and g in lab.columns():
            ax.plot(pct_lab, lab.column(g) / bw, "k--")
        ax.set_title(f"{g} [BW]")
        ax.set_xlabel("% gait cycle (from right heel strike)")
    ax = axes[2, 2]
    ax.remove()
    ax = fig.add_subplot(3, 3, 9)
    if tracking is not None:
        res = tracking.residuals()
        ax.barh(range(len(res)), [r["rmse_normalised"] for r in res.values()])
        ax.set_yticks(range(len(res)), list(res), fontsize=6)
        ax.set_title("tracked signals: RMSE / σ")
    else:
        ax.axis("off")
    for ax in axes.flat[:8]:
        ax.grid(alpha=0.3)
    axes[0, 0].legend(fontsize=8)
    fig.suptitle(title or f"{rec.name}: speed {sol.speed:.2f} m/s (recorded {_speed(rec):.2f}), {sol.status}")
    return save_figure(fig, path, dpi=100)


def _speed(rec: Recording) -> float:
    if rec.labels is not None and "speed" in rec.labels.columns():
        return float(np.mean(rec.labels.column("speed")))
    return float("nan")


def write_comparison(comparison: LabelComparison, path: str | Path, extra: dict[str, Any] | None = None) -> Path:
    """Write the comparison (and the paper's figures) as JSON, atomically (a metric that could not
    be computed, NaN, is written as ``null``)."""
    return atomic_write_json(path, {**comparison.as_dict(), "paper_ocp": PAPER_OCP, **(extra or {})}, non_finite="null")
