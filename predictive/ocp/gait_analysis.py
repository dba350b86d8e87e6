"""Plausibility checks of predicted gaits: comparison with Winter's averaged walking data, plots.

Winter's data (the ``winter_walking`` folder of the optional public data, :mod:`sspinn.data.shared_data`: 50 samples per stride from right heel strike,
angles in rad with the sspinn signs, GRF in body weights) is optional: functions that need it
take its folder and raise :class:`FileNotFoundError` with a clear message if it is absent. The
reference type and its loader are :class:`sspinn.data.gait_metrics.ReferenceGait` and
:func:`sspinn.data.gait_metrics.load_winter` (re-exported here).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from predictive.ocp.settings import WALK_RUN_SPEED
from predictive.ocp.solution import CONTACT_THRESHOLD_BW, GaitSolution

# the reference gait and its loader live with the gait metrics (usable by envs and agents too)
from sspinn.data.gait_metrics import ReferenceGait, load_winter  # noqa: F401 (re-exported)
from sspinn.data.gait_norms import SPEED_LIMITS, GaitNormsReport, check_gait_norms
from sspinn.model.drawing import save_figure

#: Compared signals: name → (sspinn column in q (rad) or grf (BW), Winter column).
_ANGLES = {"hip": (3, "hip_flexion_r_angle"), "knee": (4, "knee_angle_r_angle"), "ankle": (5, "ankle_angle_r_angle")}


def normalised_cycle(sol: GaitSolution, n: int = 100, threshold_bw: float = CONTACT_THRESHOLD_BW) -> ReferenceGait:
    """The solution's right-leg signals over one cycle starting at right heel strike (first node
    whose vertical GRF exceeds ``threshold_bw``), resampled to ``n`` samples by periodic linear
    interpolation over the normalised cycle."""
    start = sol.right_heel_strike(threshold_bw)
    frac_nodes = ((np.arange(sol.n_nodes) - start) % sol.n_nodes) / sol.n_nodes
    order = np.argsort(frac_nodes)
    frac = np.arange(n) / n
    grf = sol.grf_bw()

    def resample(y: np.ndarray) -> np.ndarray:
        return np.interp(frac, frac_nodes[order], y[order], period=1.0)

    return ReferenceGait(
        percent=frac * 100.0,
        hip=resample(sol.q[:, 3]),
        knee=resample(sol.q[:, 4]),
        ankle=resample(sol.q[:, 5]),
        grf_x=resample(grf[:, 0]),
        grf_y=resample(grf[:, 1]),
        speed=sol.speed,
        duration=sol.duration,
    )


def solution_norms(sol: GaitSolution, reference: ReferenceGait | None = None, cycles: int = 4) -> GaitNormsReport:
    """The periodic solution against the human gait norms at its speed
    (:func:`sspinn.data.gait_norms.check_gait_norms`; running at or above
    :data:`~predictive.ocp.settings.WALK_RUN_SPEED`, the speed clipped to the norms' speeds): the
    cycle repeated ``cycles`` times on its node grid, the angles' RMSD to ``reference`` (e.g.
    Winter's walking) where given."""
    if not 2 <= cycles <= 20:
        raise ValueError(f"cycles must be 2–20, got {cycles}")
    mode = "run" if sol.speed >= WALK_RUN_SPEED else "walk"
    low, high = SPEED_LIMITS[mode]
    times = np.arange(cycles * sol.n_nodes) * sol.duration / sol.n_nodes
    repeated = sol.resample(times, period=sol.duration, speed=sol.speed)
    return check_gait_norms(repeated, float(np.clip(sol.speed, low, high)), mode, body_weight_n=sol.body_weight,
                            reference=reference)


def compare_with_reference(sol: GaitSolution, ref: ReferenceGait) -> dict[str, float]:
    """RMSD between the solution (aligned at right heel strike, resampled to the reference's
    samples) and a reference cycle: hip, knee, ankle in degrees, vertical and horizontal GRF in
    BW; plus the reference's and the solution's stride durations (s)."""
    sim = normalised_cycle(sol, n=len(ref.percent))
    out = {
        f"rmsd_{name}_deg": float(np.degrees(np.sqrt(np.mean((getattr(sim, name) - getattr(ref, name)) ** 2))))
        for name in ("hip", "knee", "ankle")
    }
    out["rmsd_grf_y_bw"] = float(np.sqrt(np.mean((sim.grf_y - ref.grf_y) ** 2)))
    out["rmsd_grf_x_bw"] = float(np.sqrt(np.mean((sim.grf_x - ref.grf_x) ** 2)))
    out["duration_reference_s"] = ref.duration
    out["duration_solution_s"] = sol.duration
    return out


def plot_gait(
    sol: GaitSolution, path: str | Path, reference: ReferenceGait | None = None, title: str | None = None
) -> Path:
    """Write a PNG: right hip, knee, ankle angles (deg) and right GRF (BW) versus % gait cycle
    (from right heel strike), with the reference (e.g. Winter) dashed when given."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    sim = normalised_cycle(sol, n=200)
    fig, axes = plt.subplots(2, 2, figsize=(10, 7), sharex=True)
    panels = [
        ("hip", "hip flexion (+) [deg]", True),
        ("knee", "knee angle (flexion −) [deg]", True),
        ("ankle", "ankle dorsiflexion (+) [deg]", True),
    ]
    for ax, (name, label, deg) in zip(axes.flat, panels):
        scale = 180.0 / np.pi if deg else 1.0
        ax.plot(sim.percent, getattr(sim, name) * scale, label=f"predicted ({sol.speed:.2f} m/s)")
        if reference is not None:
            ax.plot(reference.percent, getattr(reference, name) * scale, "--", label="reference")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    ax = axes.flat[3]
    ax.plot(sim.percent, sim.grf_y, color="C0", label="predicted F_y")
    ax.plot(sim.percent, sim.grf_x, color="C0", alpha=0.5, label="predicted F_x")
    if reference is not None:
        ax.plot(reference.percent, reference.grf_y, "--", color="C1", label="reference F_y")
        ax.plot(reference.percent, reference.grf_x, "--", color="C1", alpha=0.5, label="reference F_x")
    ax.set_ylabel("right GRF [BW]")
    ax.grid(alpha=0.3)
    for ax in axes[1]:
        ax.set_xlabel("% gait cycle (from right heel strike)")
    axes.flat[0].legend(fontsize=8)
    axes.flat[3].legend(fontsize=8)
    fig.suptitle(title or f"predictive gait, {sol.speed:.2f} m/s, stride {sol.duration:.3f} s, {sol.status}")
    return save_figure(fig, path, dpi=110)
