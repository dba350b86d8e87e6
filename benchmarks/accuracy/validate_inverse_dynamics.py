"""Compare sspinn's inverse dynamics of real walking data with two independent references.

Prints Pearson r and RMSE (N·m/kg) per joint for the CSU 2D inverse-dynamics test data
(GaitAnalysisToolKit leg2d; once with Winter's segment parameters at 6 Hz, once with the cutoff
and thigh/shank parameters that actually generated its reference file) and OpenSim's subject01
inverse dynamics (both legs), and writes a plot of the moment time series. Method and sign conventions: :mod:`benchmarks.accuracy.inverse_dynamics`.

Usage::

    python -m benchmarks.accuracy.validate_inverse_dynamics [--data DIR] [--out results/validation/inverse_dynamics.png]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from benchmarks.accuracy.inverse_dynamics import (
    CONTACT_THRESHOLD_N,
    DEFAULT_CUTOFF_HZ,
    Comparison,
    csu_inverse_dynamics,
    csu_reference_replica,
    opensim_inverse_dynamics,
)
from sspinn.data.shared_data import shared_data_dir
from sspinn.model.drawing import save_figure


def format_table(comparisons: list[Comparison]) -> str:
    """A plain-text table: dataset, joint, r, RMSE (N·m/kg), reference range (N·m/kg)."""
    lines = [f"{'dataset':<36s} {'joint':<8s} {'r':>7s} {'RMSE':>7s} {'ref p2p':>8s}   (moments in N·m/kg)"]
    for comp in comparisons:
        for k, stats in enumerate(comp.stats()):
            ref = comp.reference[:, k]
            lines.append(
                f"{comp.dataset:<36s} {stats.joint:<8s} {stats.r:7.4f} {stats.rmse:7.4f} {ref.max() - ref.min():8.3f}"
            )
    return "\n".join(lines)


def plot(comparisons: list[Comparison], out: Path) -> None:
    """One row per dataset and leg, one column per joint: ours (solid) and reference (dashed)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = [(comp, comp.joints[i : i + 3]) for comp in comparisons for i in range(0, len(comp.joints), 3)]
    fig, axes = plt.subplots(len(rows), 3, figsize=(12, 2.8 * len(rows)), squeeze=False)
    for (comp, joints), ax_row in zip(rows, axes):
        for joint, ax in zip(joints, ax_row):
            k = comp.joints.index(joint)
            stats = comp.stats()[k]
            ax.plot(comp.time, comp.reference[:, k], "k--", lw=1.2, label="reference")
            ax.plot(comp.time, comp.ours[:, k], "C0", lw=1.2, label="sspinn")
            ax.set_title(f"{joint}: r = {stats.r:.3f}, RMSE = {stats.rmse:.3f} N·m/kg", fontsize=9)
            ax.set_xlabel("time (s)")
            ax.grid(alpha=0.3)
        ax_row[0].set_ylabel(f"{comp.dataset}\nmoment (N·m/kg)", fontsize=8)
        ax_row[0].legend(fontsize=8)
        ax_row[1].annotate(comp.convention, (0.5, -0.3), xycoords="axes fraction", ha="center", fontsize=7)
    save_figure(fig, out, dpi=120)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=shared_data_dir(),
                        help="folder holding csu_2d_inverse_dynamics/ and opensim_subject01_walk/ (default: $SSPINN_SHARED_DATA)")
    parser.add_argument("--out", type=Path, default=Path("results/validation/inverse_dynamics.png"), help="PNG path")
    parser.add_argument("--cutoff", type=float, default=DEFAULT_CUTOFF_HZ, help="low-pass cutoff, Hz")
    parser.add_argument("--threshold", type=float, default=CONTACT_THRESHOLD_N, help="contact threshold, N")
    args = parser.parse_args(argv)

    if args.data is None:
        print("no data folder: pass --data or set SSPINN_SHARED_DATA", file=sys.stderr)
        return 1
    csu_dir = args.data / "csu_2d_inverse_dynamics"
    osim_dir = args.data / "opensim_subject01_walk"
    missing = [str(d) for d in (csu_dir, osim_dir) if not d.is_dir()]
    if missing:
        print(f"data not found: {', '.join(missing)} (optional public data, not shipped)", file=sys.stderr)
        return 1
    comparisons = [
        csu_inverse_dynamics(csu_dir, cutoff=args.cutoff, threshold=args.threshold),
        csu_reference_replica(csu_dir, threshold=args.threshold),
        opensim_inverse_dynamics(osim_dir, cutoff=args.cutoff, threshold=args.threshold),
    ]
    print(f"low-pass {args.cutoff} Hz (markers/coordinates and forces), contact threshold {args.threshold} N")
    print("CSU 'reference inertia, 4 Hz': the cutoff and thigh/shank parameters that generated refresults.mat")
    print("(diagnostic; see benchmarks.accuracy.inverse_dynamics)")
    print(format_table(comparisons))
    plot(comparisons, args.out)
    print(f"plot written to {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
