"""Margins of the joint-constraint checks of :mod:`sspinn.data.signal_checks` (:func:`joint_stats`):
the best-fitting time-base factor, the gains with one sensor's acc_x or gyr_z negated and the
best-fitting gyroscope scale per sensor, on untouched recordings (the twelve CMU trials imported
with ``sspinn import``, whole and as 20 s excerpts every 10 s; the predicted recordings of
``--synth`` folders; the averaged real stride; a predicted walk of the test fixtures; the
semi-real running) and with one mistake applied to 20 s excerpts (a rate × 0.4–0.8 or
× 1.25–2, gyr_z × 0.5, acc_x negated). Prints the ranges that the thresholds' docstrings quote.

Usage::

    python -m benchmarks.accuracy.joint_check_margins --synth CLONE1/data/synth_default CLONE2/data/synth_default
"""

from __future__ import annotations

import argparse
import contextlib
import io
import os
import tempfile
import warnings
from collections import defaultdict
from pathlib import Path

import numpy as np

from sspinn.data.csv_readers import read_averaged_stride
from sspinn.data.dataset import Recording
from sspinn.data.signal_checks import JOINT_RATE_OK, joint_stats
from sspinn.imu import pipeline
from sspinn.model.conventions import SEGMENTS
from sspinn.testing.perturbations import perturb
from sspinn.testing.sensor_mounting import read_gait_csv, synthetic_walk

ROOT = Path(__file__).resolve().parents[2]

SHARED = Path(os.environ.get("SSPINN_SHARED_DATA") or ROOT.parent / "shared" / "data")
SUBJECTS = {"Sub01": (1.81, 66.7), "Sub02": (1.65, 56.0), "Sub03": (1.87, 78.6), "Sub04": (1.67, 70.5),
            "Sub05": (1.90, 81.6), "Sub06": (1.64, 69.7)}
EXCERPT = 2000  # samples (20 s)


def cmu(folder: Path) -> dict[str, tuple[np.ndarray, tuple[str, ...]]]:
    out = {}
    pipeline.plot_calibration = lambda path, *a, **k: Path(path)
    for subject, (height, mass) in SUBJECTS.items():
        for condition in ("CSBaseline", "CSStiffKnee"):
            src = SHARED / "cmu_treadmill_imu_grf" / subject / condition
            with contextlib.redirect_stdout(io.StringIO()), warnings.catch_warnings():
                warnings.simplefilter("ignore")
                rec = pipeline.import_imu([src / f"OpenSim_{subject}_{condition}_Accel.trc.gz"],
                                          ROOT / "configs" / "sensor_maps" / "cmu_treadmill.yaml", height, mass, folder,
                                          name=f"{subject}_{condition}").recording
            out[rec.name] = (rec.imu, tuple(rec.segments))
    return out


def others(synth: list[Path]) -> dict[str, tuple[np.ndarray, tuple[str, ...]]]:
    out = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for root in synth:
            for csv in sorted(root.glob("*.csv")):
                rec = Recording.load(csv)
                out[f"{root.parent.parent.name}:{csv.stem}"] = (rec.imu, tuple(rec.segments))
        stride = read_averaged_stride(SHARED / "dorschky_P03_walking", periods=10)
        out["averaged stride × 10"] = (stride.imu, tuple(stride.segments))
        gait = read_gait_csv(ROOT / "tests" / "fixtures" / "predicted_walk_1.3.csv")
        out["predicted walk"] = (synthetic_walk(gait.q, gait.u, gait.qdd, strides=20, standing_s=2.0), tuple(SEGMENTS))
        from benchmarks.accuracy.semi_real_running import hamner_running_recording

        run = hamner_running_recording(SHARED / "opensim_hamner_run")
        out["semi-real running"] = (run.imu, tuple(run.segments))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--synth", type=Path, nargs="*", default=[], help="folders of predicted recordings")
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    real = cmu(Path(tempfile.mkdtemp(prefix="joint_margins_")))
    sets = {"CMU": {**real, **{f"{k}@{s // 100}s": (imu[s:s + EXCERPT], segs) for k, (imu, segs) in real.items()
                               for s in range(0, imu.shape[0] - EXCERPT + 1, 1000)}},
            "other": others(args.synth)}
    for label, recs in sets.items():
        factor, gain, mirror, negated, scale = [], [], [], [], defaultdict(list)
        for imu, segs in recs.values():
            st = joint_stats(imu, segs)
            factor.append(st.factor)
            gain.append(st.factor_gain)
            mirror += list(st.mirror.values())
            negated += list(st.negated.values())
            for s, v in st.scale.items():
                if v is not None:
                    scale[s.split("_")[0]].append(v[0])
        lo, hi = JOINT_RATE_OK
        outside = [g for f, g in zip(factor, gain) if not lo <= f <= hi]
        print(f"untouched {label} ({len(recs)} recordings): factor {min(factor):.3f}–{max(factor):.3f} (outside "
              f"{lo:g}–{hi:g}: {len(outside)}, residual gain there ≤ {max(outside, default=float('nan')):.3f}), acc_x-negated gain "
              f"≤ {max(mirror):.2f}, gyr_z-negated gain ≤ {max(negated):.2f}, gyro scale "
              + ", ".join(f"{k} {min(v):.2f}–{max(v):.2f}" for k, v in scale.items()))
    for label, recs in (("CMU", real), ("other", sets["other"])):
        ratio, rate_gain, mirror, scale = [], [], defaultdict(list), defaultdict(list)
        for imu, segs in recs.values():
            start = int(rng.integers(0, max(1, imu.shape[0] - EXCERPT)))
            near, what = perturb(imu, segs, "rate_near", rng)
            f = float(what.description.split("× ")[-1].rstrip(")"))
            st = joint_stats(near[:EXCERPT], segs, per_sensor=False)
            ratio.append(st.factor / f)
            rate_gain.append((f, st.factor, st.factor_gain))
            ex = imu[start:start + EXCERPT]
            for j, s in enumerate(segs):
                half = ex.copy()
                half[:, j, 2] *= 0.5
                v = joint_stats(half, segs).scale.get(s)
                if v is not None:
                    scale[s.split("_")[0]].append(v[0])
                flipped = ex.copy()
                flipped[:, j, 0] *= -1
                mirror[s.split("_")[0]].append(joint_stats(flipped, segs).mirror[s])
        lo, hi = JOINT_RATE_OK
        caught = [g for _, est, g in rate_gain if not lo <= est <= hi]
        print(f"mistakes {label}: rate × {min(f for f, _, _ in rate_gain):.2f}–{max(f for f, _, _ in rate_gain):.2f} outside "
              f"{lo:g}–{hi:g} in {len(caught)} of {len(rate_gain)}, residual gain there {min(caught, default=float('nan')):.3f}–"
              f"{max(caught, default=float('nan')):.3f}" + (f" (below 1.05: {sum(g < 1.05 for g in caught)})" if caught else ""))
        print(f"mistakes {label}: rate estimate / true factor {min(ratio):.2f}–{max(ratio):.2f}; gyr_z × 0.5: estimate "
              + ", ".join(f"{k} ≥ {min(v):.2f}" for k, v in scale.items()) + "; acc_x negated: gain "
              + ", ".join(f"{k} ≥ {min(v):.2f}" for k, v in mirror.items()))


if __name__ == "__main__":
    main()
