"""Thigh and shank sensor placement from the IMU signals alone, by joint-centre fits, against the
synthetic data's true placement and the nominal placement the estimator is told.

For each leg the joint centres are fitted in the plane (:func:`sspinn.imu.joint_centres.joint_centre`,
Seel, Raisch & Schauer 2014): the hip from the pelvis and thigh sensors, the knee from the thigh
and shank sensors, the ankle from the shank and foot sensors. In a segment's frame the proximal
joint is the origin and the distal joint lies on the −y axis, so the two joint centres seen from
the segment's sensor give its angle and position (:func:`sspinn.imu.joint_centres.sensor_placement`).
No training, no labels: the truth is only read to score.

Printed per gait (walking, running) and segment: the median over the recordings of the position
error √(Δx² + Δy²) (cm) of the nominal placement and of the fitted one, their ratio, and the
median angle error (°); the target set for the learned placement is a median below half the nominal error
for the thighs.

Usage: ``python benchmarks/placement_joint_centres.py --data data/synth_default [--json PATH]``
(a dataset made by ``python -m predictive synth``, whose recordings store their true placement).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

import numpy as np

REPO = Path(__file__).resolve().parents[1]

#: segment → (proximal joint's sensor pair, distal joint's sensor pair), each pair (proximal
#: segment, distal segment) of the joint.
CHAINS = {
    "femur": (("pelvis", "femur"), ("femur", "tibia")),
    "tibia": (("femur", "tibia"), ("tibia", "foot")),
}


def _name(segment: str, side: str) -> str:
    return segment if segment == "pelvis" else f"{segment}_{side}"


def fitted_placement(signals: dict[str, Any], nominal: dict[str, np.ndarray], segment: str, side: str,
                     length_m: float) -> tuple[np.ndarray, float]:
    """(x, y) position (m) and angle (rad) of ``segment``'s sensor in its segment frame from the
    joint centres of its two joints; ``nominal`` (segment → [x, y, θ]) gives the fits' start."""
    from sspinn.imu.joint_centres import joint_centre, sensor_placement

    def guess(seg: str, joint_y: float) -> np.ndarray:  # a joint at (0, joint_y) of seg's frame, seen from its sensor
        x, y, _ = nominal[seg]
        return np.array([-x, joint_y - y])

    (pa, pb), (da, db) = CHAINS[segment]
    seg, a_prox, b_dist = _name(segment, side), _name(pa, side), _name(db, side)
    prox_guess_a = np.array([-nominal[a_prox][0], -nominal[a_prox][1]]) if pa == "pelvis" else guess(a_prox, -length_m)
    proximal = joint_centre(signals[a_prox], signals[seg], prox_guess_a, guess(seg, 0.0))
    distal = joint_centre(signals[seg], signals[b_dist], guess(seg, -length_m), -np.asarray(nominal[b_dist][:2]))
    return sensor_placement(proximal.r_b, distal.r_a)


def main(argv: list[str] | None = None) -> dict[str, Any]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=REPO / "data" / "synth_default", help="synthetic dataset folder")
    parser.add_argument("--json", type=Path, help="also save the results")
    args = parser.parse_args(argv)

    from scipy.signal import butter, sosfiltfilt

    from sspinn.data.dataset import SAMPLE_RATE_HZ, Dataset
    from sspinn.estimator.paper_experiments import true_placement
    from sspinn.imu.joint_centres import CUTOFF_HZ
    from sspinn.model.body import BodyParameters
    from sspinn.model.conventions import SEGMENTS

    dataset = Dataset.open(args.data)
    sos = butter(2, CUTOFF_HZ, fs=SAMPLE_RATE_HZ, output="sos")
    rows: list[dict[str, Any]] = []
    for split in dataset.splits:
        for rec in dataset.load(split):
            truth = true_placement(rec)
            if truth is None:
                continue
            nominal_vec = rec.placement.vector().reshape(len(SEGMENTS), 3)
            nominal = dict(zip(SEGMENTS, nominal_vec))
            body = BodyParameters.from_anthropometry(rec.height, rec.mass)
            signals = {}
            for i, s in enumerate(SEGMENTS):
                omega = sosfiltfilt(sos, rec.imu[:, i, 2])
                signals[s] = (sosfiltfilt(sos, rec.imu[:, i, :2], axis=0), omega, np.gradient(omega) * SAMPLE_RATE_HZ)
            program = rec.provenance.get("program") if isinstance(rec.provenance, dict) else None
            gait = str(program.get("name", "?")) if isinstance(program, dict) else "?"
            for segment in CHAINS:
                for side in "rl":
                    name = _name(segment, side)
                    k = SEGMENTS.index(name)
                    length = float(getattr(body, name).length)
                    position, angle = fitted_placement(signals, nominal, segment, side, length)
                    rows.append({
                        "recording": rec.name, "gait": gait, "sensor": name,
                        "nominal_cm": float(100 * np.hypot(*(nominal_vec[k, :2] - truth[k, :2]))),
                        "fitted_cm": float(100 * np.hypot(*(position - truth[k, :2]))),
                        "nominal_angle_deg": float(np.degrees(abs(nominal_vec[k, 2] - truth[k, 2]))),
                        "fitted_angle_deg": float(np.degrees(abs(angle - truth[k, 2]))),
                    })
    if not rows:
        print(f"{args.data}: no recording stores its true placement (only `python -m predictive synth` data do)", file=sys.stderr)
        return {}
    print(f"# Sensor placement from joint-centre fits, {args.data} ({len({r['recording'] for r in rows})} recordings)\n")
    print("| gait | segment | sensors | nominal: median position error (cm) | fitted (cm) | fitted / nominal | "
          "angle error, nominal / fitted (°, median) | below half the nominal? |")
    print("|---|---|---:|---:|---:|---:|---:|---|")
    summary: dict[str, Any] = {}
    for gait in sorted({r["gait"] for r in rows}):
        for segment in CHAINS:
            sel = [r for r in rows if r["gait"] == gait and r["sensor"].startswith(segment)]
            nom = float(np.median([r["nominal_cm"] for r in sel]))
            fit = float(np.median([r["fitted_cm"] for r in sel]))
            ang = (float(np.median([r["nominal_angle_deg"] for r in sel])), float(np.median([r["fitted_angle_deg"] for r in sel])))
            summary[f"{gait}/{segment}"] = {"n": len(sel), "nominal_cm": nom, "fitted_cm": fit, "angle_deg": ang}
            print(f"| {gait} | {segment} | {len(sel)} | {nom:.2f} | {fit:.2f} | {fit / nom:.2f} | {ang[0]:.1f} / {ang[1]:.1f} | "
                  f"{'yes' if fit < 0.5 * nom else 'no'} |")
    out = {"data": str(args.data), "summary": summary, "rows": rows}
    if args.json:
        args.json.write_text(json.dumps(out, indent=2))
    return out


if __name__ == "__main__":
    main(sys.argv[1:])
