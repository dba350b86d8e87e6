"""Validate the sagittal sensor calibration (:mod:`sspinn.imu.calibration`) on synthetic 3D
sensors with random mountings (:mod:`sspinn.testing.sensor_mounting`).

The gait is one predicted stride at 1.3 m/s (``tests/fixtures/predicted_walk_1.3.csv``); ``--solve``
recomputes it with :func:`predictive.solve_predictive` (about 30 s) and rewrites that file. For
each of ``--trials`` random mountings of all seven sensors, the script calibrates with a 2 s
quiet-standing phase and without one (walking only, in-plane angles from joint centres and foot
rests, and from the typical walking orientations) and prints the median and maximum axis and
in-plane angle errors per segment; ``--out`` writes a figure of the error distributions.
``--cmu`` adds the real check: on each CMU treadmill trial with quiet standing, both walking-only
methods against the standing calibration. ``--measured`` uses a measured stride instead of the
predicted one (OpenSim's subject01 walk, :func:`benchmarks.accuracy.inverse_dynamics.measured_stride`:
real kinematics, whose feet rest flat in mid-stance as the predicted gait's never do).
``--estimate MODEL`` adds a fourth condition: walking only, the feet's in-plane angles then fitted
to the kinematics MODEL estimates from the calibrated signals (:func:`feet_from_estimate`); with
``--estimate-data DIR`` (a dataset of imported recordings, e.g. the CMU benchmark's
``results/cmu/data``, calibrated with standing) it prints how far the same fit turns each foot
from that recording's own calibration.

Usage::

    python -m benchmarks.accuracy.validate_sensor_calibration [--trials 50] [--seed 0] [--solve] [--out results/validation/sensor_calibration.png] [--cmu] [--measured]
        [--estimate results/demo/run/model.pt [--estimate-data results/cmu/data]]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from benchmarks.accuracy.inverse_dynamics import measured_stride
from sspinn.data.dataset import Recording
from sspinn.model.conventions import SEGMENTS
from sspinn.model.drawing import save_figure
from sspinn.testing.sensor_mounting import (
    Gait,
    OutOfPlane,
    mounting_trials,
    read_gait_csv,
    summary,
    write_gait_csv,
)

if TYPE_CHECKING:
    from sspinn.estimator.sspinnpose import SSPINNpose

GAIT = Path(__file__).resolve().parents[2] / "tests" / "fixtures" / "predicted_walk_1.3.csv"
CMU = Path(__file__).resolve().parents[3] / "shared" / "data" / "cmu_treadmill_imu_grf"
OPENSIM_WALK = Path(__file__).resolve().parents[3] / "shared" / "data" / "opensim_subject01_walk"


def solve_gait(path: Path) -> None:
    from predictive import solve_predictive

    sol = solve_predictive(1.3, rate_hz=100)
    write_gait_csv(path, Gait(sol.q, sol.u, sol.qdd, sol.grf))
    print(f"solved 1.3 m/s ({sol.status}, stride {sol.duration:.2f} s, {len(sol.q)} samples) → {path}")


def cmu_walking_only(data: Path) -> None:
    """On every CMU treadmill trial with quiet standing: the in-plane angle of each sensor
    calibrated from the walking alone (both methods) against the standing calibration, degrees."""
    import csv

    from sspinn.imu.calibration import calibrate
    from sspinn.imu.sensor_map import SensorMap
    from sspinn.imu.stream import resample
    from sspinn.imu.vendor_readers import read_imu_files

    if not (data / "subjects.csv").exists():
        print(f"\n{data}: the CMU treadmill data is not there; skipped")
        return
    smap = SensorMap.from_yaml(Path(__file__).resolve().parents[2] / "configs" / "sensor_maps" / "cmu_treadmill.yaml")
    with open(data / "subjects.csv", newline="") as fh:
        subjects = sorted(row["subject"] for row in csv.DictReader(fh))
    errors: dict[tuple[str, str, str], list[float]] = {}
    for subject in subjects:
        for condition in ("CSBaseline", "CSStiffKnee"):
            _, stream = resample(read_imu_files([data / subject / condition / f"OpenSim_{subject}_{condition}_Accel.trc.gz"]))
            signals = {seg: (stream.sensors[a.sensor].acc, stream.sensors[a.sensor].gyr) for seg, a in smap.by_segment().items()}
            reference = calibrate(signals, smap.by_segment())
            if reference.standing is None:
                continue
            for method in ("joints", "typical"):
                walking = calibrate(signals, smap.by_segment(), standing=None, walking_angles=method)
                for seg, ref in reference.sensors.items():
                    y, z = walking.sensors[seg].rotation[1], ref.rotation[2]
                    error = np.degrees(np.arctan2(np.cross(ref.rotation[1], y) @ z, ref.rotation[1] @ y))
                    errors.setdefault((method, condition, seg.split("_")[0]), []).append(float(error))
    print("\n### Real CMU trials with quiet standing: walking-only in-plane angle − standing calibration's (deg)\n")
    print("| segment | condition | joint centres / foot rests: median \\|e\\| | max | mean | typical orientations: median \\|e\\| | max | mean |")
    print("|---|---|---:|---:|---:|---:|---:|---:|")
    for kind in ("pelvis", "femur", "tibia", "foot"):
        for condition in ("CSBaseline", "CSStiffKnee"):
            cells = []
            for method in ("joints", "typical"):
                e = np.array(errors.get((method, condition, kind), [np.nan]))
                cells += [f"{np.median(np.abs(e)):.1f}", f"{np.max(np.abs(e)):.1f}", f"{np.mean(e):+.1f}"]
            print(f"| {kind} | {condition} | " + " | ".join(cells) + " |")


def feet_from_estimate(estimator: SSPINNpose, recording: Recording, iterations: int = 4) -> dict[str, float]:
    """In-plane corrections (rad) of the foot sensors of ``recording``, fitted to the kinematics
    ``estimator`` (a loaded :class:`~sspinn.estimator.sspinnpose.SSPINNpose`) estimates from it (:func:`benchmarks.studies.placement_fit.fit_placement`, positions,
    angles and biases): the fitted angle turns the foot's signals and the estimate is made again,
    ``iterations`` times (each round leaves about a fifth of the previous correction). The
    network is used as trained: adapted to the recording first, it learns to explain the turned
    signals and the fit then finds nothing (docs/imu_import.md)."""
    from benchmarks.studies.placement_fit import fit_placement

    nominal = recording.placement.vector().reshape(len(SEGMENTS), 3)[:, 2]
    feet = [s for s in recording.segments if s.startswith("foot")]
    total = dict.fromkeys(feet, 0.0)
    imu = recording.imu.copy()
    for _ in range(iterations):
        turned = Recording(recording.name, imu, recording.segments, recording.height, recording.mass, placement=recording.placement)
        fit = fit_placement(turned, estimator.predict(turned))
        angles = fit.placement.vector().reshape(len(SEGMENTS), 3)[:, 2] - nominal
        for seg in feet:
            j, turn = recording.segments.index(seg), angles[SEGMENTS.index(seg)]
            c, s = np.cos(turn), np.sin(turn)
            imu[:, j, :2] = imu[:, j, :2] @ np.array([[c, s], [-s, c]])  # rows turned by R(turn)
            total[seg] += float(turn)
    return total


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=50)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--strides", type=int, default=50, help="strides of walking per synthetic recording (50 ≈ 57 s, a CMU trial)")
    parser.add_argument("--gait", type=Path, default=GAIT)
    parser.add_argument("--solve", action="store_true", help="recompute the gait with predictive.solve_predictive")
    parser.add_argument("--out", type=Path, default=None, help="figure of the error distributions (.png)")
    parser.add_argument("--cmu", type=Path, nargs="?", const=CMU, default=None,
                        help="also compare walking-only with standing calibration on the real CMU trials (default folder: "
                             "../shared/data/cmu_treadmill_imu_grf)")
    parser.add_argument("--measured", type=Path, nargs="?", const=OPENSIM_WALK, default=None,
                        help="a measured stride instead of --gait: OpenSim's subject01 walk (default folder: "
                             "../shared/data/opensim_subject01_walk)")
    parser.add_argument("--estimate", type=Path, default=None, metavar="MODEL",
                        help="also: walking only, the feet's in-plane angles fitted to MODEL's estimate (feet_from_estimate)")
    parser.add_argument("--estimate-data", type=Path, default=None, metavar="DIR",
                        help="with --estimate: imported recordings whose feet the same fit turns from their own calibration")
    args = parser.parse_args(argv)
    if args.estimate_data is not None and args.estimate is None:
        parser.error("--estimate-data needs --estimate MODEL")
    for path, what in ((args.estimate, "model file"), (args.estimate_data, "dataset folder")):
        if path is not None and not path.exists():
            parser.error(f"{path}: no such {what}")
    if args.measured is not None:
        if not (args.measured / "subject01_walk_IK.mot").exists():
            parser.error(f"{args.measured}: no subject01_walk_IK.mot (see ../shared/data/README.md)")
        q, u, qdd, _ = measured_stride(args.measured)
        args.gait = args.measured / "subject01_walk_IK.mot"
    else:
        if args.solve or not args.gait.exists():
            solve_gait(args.gait)
        q, u, qdd, _ = read_gait_csv(args.gait)
    oop = OutOfPlane()
    print(f"gait {args.gait} ({len(q)} samples per stride, {args.strides} strides); {args.trials} random mountings × 7 sensors; "
          f"out-of-plane: {oop}")
    results = {}
    conditions = [("with 2 s quiet standing", 2.0, "joints", None), ("walking only: joint centres and foot rests", 0.0, "joints", None),
                  ("walking only: typical walking orientations", 0.0, "typical", None)]
    if args.estimate is not None:
        from sspinn.estimator.sspinnpose import SSPINNpose
        from sspinn.model.body import IMUPlacement

        estimator = SSPINNpose.load(args.estimate)

        def refine(imu: np.ndarray) -> dict[str, float]:  # the 1.75 m, 70 kg body of the synthetic gait
            rec = Recording("synthetic", imu, tuple(SEGMENTS), 1.75, 70.0, placement=IMUPlacement.default(1.75))
            return feet_from_estimate(estimator, rec)

        conditions.append(("walking only: joint centres, feet fitted to the estimate", 0.0, "joints", refine))
    for label, standing, method, refinement in conditions:
        t0 = time.perf_counter()
        res = mounting_trials(q, u, qdd, trials=args.trials, seed=args.seed, standing_s=standing, strides=args.strides, oop=oop,
                              walking_angles=method, refine=refinement)
        results[label] = res
        print(f"\n### {label} ({time.perf_counter() - t0:.1f} s)\n")
        print("| sensors | axis error median (deg) | axis error max | in-plane angle error median (deg) | max | wrong signs |")
        print("|---|---:|---:|---:|---:|---:|")
        for name, ax_med, ax_max, an_med, an_max, wrong in summary(res):
            print(f"| {name} | {ax_med:.2f} | {ax_max:.2f} | {an_med:.2f} | {an_max:.2f} | {wrong} |")
    if args.cmu is not None:
        cmu_walking_only(args.cmu)
    if args.estimate is not None and args.estimate_data is not None:
        from sspinn.data.dataset import Dataset

        print(f"\n### Feet fitted to the estimate of {args.estimate}: turned from each recording's own calibration (deg)\n")
        print("| recording | foot_r | foot_l |\n|---|---:|---:|")
        data = Dataset.open(args.estimate_data)
        for split in data.splits:
            for rec in data.load(split):
                turns = feet_from_estimate(estimator, rec)
                print(f"| {rec.name} | " + " | ".join(f"{np.degrees(turns.get(f, np.nan)):+.1f}" for f in ("foot_r", "foot_l")) + " |")
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
        gait = "measured stride, OpenSim subject01" if args.measured is not None else "synthetic 1.3 m/s gait"
        fig.suptitle(f"sensor calibration on {args.trials} random mountings × 7 sensors ({gait})")
        save_figure(fig, args.out, dpi=120)
        print(f"\nfigure → {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
