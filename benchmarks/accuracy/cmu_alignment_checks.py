"""The GRF time alignment and its checks on every CMU treadmill trial (``../shared/data/
cmu_treadmill_imu_grf``), as ``sspinn import`` runs them: the lag, its three correlations, the
runner-up and the score ratio (ambiguous below ``AMBIGUOUS_RATIO``), each foot's own lag, the
score with the force channels' sides exchanged over the labelled one (swapped above
``SWAPPED_SIDES_RATIO``), the mean vertical force over body weight and the warnings. Optionally
on the first seconds only, or with the GRF edited (sides exchanged, the left channel delayed):
the figures quoted in ``docs/imu_import.md`` and in the thresholds' docstrings
(:mod:`sspinn.imu.time_alignment`, :mod:`sspinn.imu.grf_checks`).

Usage::

    python -m benchmarks.accuracy.cmu_alignment_checks [--end 10] [--edit none|swapped|left-late] [--data DIR]   # ~1 min
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path

import numpy as np

from sspinn.imu.calibration import calibrate
from sspinn.imu.sensor_map import SensorMap
from sspinn.imu.stream import resample
from sspinn.imu.time_alignment import align_to_grf
from sspinn.imu.vendor_readers import read_imu_files, read_treadmill_grf
from sspinn.model.conventions import GRAVITY

REPO = Path(__file__).resolve().parents[2]
#: The left channel's delay of ``--edit left-late``, s.
LATE_S = 0.15
#: Short names of the alignment's warnings, for the table.
WARNING_LABELS = {"ambiguous": "ambiguous lag", "offset in time": "channels offset", "look swapped": "sides swapped",
                  "lag between the IMU and the GRF jumps": "lag jump"}


def edit_forces(vertical: dict[str, np.ndarray], edit: str) -> dict[str, np.ndarray]:
    """The vertical forces per side as recorded, with the sides exchanged, or the left one delayed by :data:`LATE_S`."""
    if edit == "swapped":
        return {"r": vertical["l"], "l": vertical["r"]}
    if edit == "left-late":
        k = int(round(LATE_S * 100))
        return {"r": vertical["r"], "l": np.concatenate([np.full(k, vertical["l"][0]), vertical["l"][:-k]])}
    return vertical


def main(argv: list[str] | None = None) -> list[str]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=REPO.parent / "shared" / "data" / "cmu_treadmill_imu_grf")
    parser.add_argument("--end", type=float, default=None, help="use the first seconds of the IMU files only")
    parser.add_argument("--edit", choices=("none", "swapped", "left-late"), default="none")
    args = parser.parse_args(argv)
    if not (args.data / "subjects.csv").exists():
        parser.error(f"{args.data}: the CMU treadmill data is not there (see ../shared/data/README.md); give --data")
    smap = SensorMap.from_yaml(REPO / "configs" / "sensor_maps" / "cmu_treadmill.yaml")
    with open(args.data / "subjects.csv", newline="") as fh:
        subjects = {row["subject"]: float(row["mass_kg"]) for row in csv.DictReader(fh)}
    lines = ["| trial | lag (s) | activity | loading | impact | runner-up (s) | score ratio | per foot r / l (s) | "
             "exchanged / labelled | mean F / BW | warnings |", "|---|---:|---:|---:|---:|---:|---:|---|---:|---:|---|"]
    print("\n".join(lines), flush=True)
    for subject, mass in sorted(subjects.items()):
        for condition in ("CSBaseline", "CSStiffKnee"):
            folder = args.data / subject / condition
            stream = read_imu_files([folder / f"OpenSim_{subject}_{condition}_Accel.trc.gz"])
            if args.end is not None:
                stream = stream.crop(None, args.end)
            grid, stream = resample(stream)
            signals = {seg: (stream.sensors[a.sensor].acc, stream.sensors[a.sensor].gyr) for seg, a in smap.by_segment().items()}
            cal = calibrate(signals, smap.by_segment())
            t_grf, forces = read_treadmill_grf(folder / f"OpenSim_{subject}_{condition}_GRF.mot.gz")
            vertical = edit_forces({s: f[:, 1] for s, f in forces.items()}, args.edit)
            result = align_to_grf({s: np.linalg.norm(signals[f"foot_{s}"][1], axis=1) for s in "rl"},
                                  {s: signals[f"tibia_{s}"][0] for s in "rl"}, vertical,
                                  sum(np.linalg.norm(g, axis=1) for _, g in signals.values()), cal.stride_period_s,
                                  max_lag_s=max(t_grf[-1] - t_grf[0], grid[-1] - grid[0]) + 1.0)
            b, r = result.best, result.runner_up
            activity = f"{b.activity:.3f}" + ("" if b.use_activity else " (not scored)")
            kinds = [next(label for key, label in WARNING_LABELS.items() if key in w) for w in result.warnings]
            line = (f"| {subject} {condition} | {result.lag_s:+.2f} | {activity} | {b.loading:.3f} | {b.impact:.3f} | "
                    f"{r.lag_s:+.2f} | {result.ratio:.3f} | {result.side_lags['r']:+.2f} / {result.side_lags['l']:+.2f} | "
                    f"{result.swapped_sides_score / b.score:.3f} | {(forces['r'][:, 1] + forces['l'][:, 1]).mean() / (mass * GRAVITY):.3f} | "
                    f"{'; '.join(kinds) or '–'} |")
            print(line, flush=True)
            lines.append(line)
    return lines


if __name__ == "__main__":
    main()
