"""Validate the sagittal sensor calibration (:mod:`sspinn.imu.calibration`) on synthetic 3D
sensors with random mountings (:mod:`sspinn.validation.sensor_mounting`).

The gait is one predicted stride at 1.3 m/s (``tests/fixtures/predicted_walk_1.3.csv``); ``--solve``
recomputes it with :func:`predictive.solve_predictive` (about 30 s) and rewrites that file. For
each of ``--trials`` random mountings of all seven sensors, the script calibrates with a 2 s
quiet-standing phase and without one (walking only, in-plane angle from the typical walking
orientation) and prints the median and maximum axis and in-plane angle errors per segment;
``--out`` writes a figure of the error distributions.

Usage::

    python scripts/validate_sensor_calibration.py [--trials 50] [--seed 0] [--solve] [--out results/validation/sensor_calibration.png]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from sspinn.model.drawing import save_figure
from sspinn.validation.sensor_mounting import Gait, OutOfPlane, mounting_trials, read_gait_csv, summary, write_gait_csv

GAIT = Path(__file__).resolve().parents[1] / "tests" / "fixtures" / "predicted_walk_1.3.csv"


def solve_gait(path: Path) -> None:
    from predictive import solve_predictive

    sol = solve_predictive(1.3, rate_hz=100)
    write_gait_csv(path, Gait(sol.q, sol.u, sol.qdd, sol.grf))
    print(f"solved 1.3 m/s ({sol.status}, stride {sol.duration:.2f} s, {len(sol.q)} samples) → {path}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=50)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--strides", type=int, default=50, help="strides of walking per synthetic recording (50 ≈ 57 s, a CMU trial)")
    parser.add_argument("--gait", type=Path, default=GAIT)
    parser.add_argument("--solve", action="store_true", help="recompute the gait with predictive.solve_predictive")
    parser.add_argument("--out", type=Path, default=None, help="figure of the error distributions (.png)")
    args = parser.parse_args(argv)
    if args.solve or not args.gait.exists():
        solve_gait(args.gait)
    q, u, qdd, _ = read_gait_csv(args.gait)
    oop = OutOfPlane()
    print(f"gait {args.gait} ({len(q)} samples per stride, {args.strides} strides); {args.trials} random mountings × 7 sensors; "
          f"out-of-plane: {oop}")
    results = {}
    for label, standing in (("with 2 s quiet standing", 2.0), ("walking only", 0.0)):
        t0 = time.perf_counter()
        res = mounting_trials(q, u, qdd, trials=args.trials, seed=args.seed, standing_s=standing, strides=args.strides, oop=oop)
        results[label] = res
        print(f"\n### {label} ({time.perf_counter() - t0:.1f} s)\n")
        print("| sensors | axis error median (deg) | axis error max | in-plane angle error median (deg) | max | wrong signs |")
        print("|---|---:|---:|---:|---:|---:|")
        for name, ax_med, ax_max, an_med, an_max, wrong in summary(res):
            print(f"| {name} | {ax_med:.2f} | {ax_max:.2f} | {an_med:.2f} | {an_max:.2f} | {wrong} |")
    if args.out:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, axes = plt.subplots(1, 2, figsize=(10, 3.5))
        for label, res in results.items():
            axes[0].hist(np.minimum(res["axis"], 10), bins=40, alpha=0.6, label=label)
            axes[1].hist(np.clip(res["angle"], -20, 20), bins=40, alpha=0.6, label=label)
        axes[0].set_xlabel("axis error (deg, clipped at 10)")
        axes[1].set_xlabel("in-plane angle error (deg, clipped at ±20)")
        for ax in axes:
            ax.axvline(2.0, color="k", lw=0.8, ls="--")
            ax.legend(fontsize=8)
        axes[1].axvline(-2.0, color="k", lw=0.8, ls="--")
        fig.suptitle(f"sensor calibration on {args.trials} random mountings × 7 sensors (synthetic 1.3 m/s gait)")
        save_figure(fig, args.out, dpi=120)
        print(f"\nfigure → {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
