"""Sensor placement recovered from the IMU signals, against the synthetic data's true placement
and the nominal placement the estimator is told — three methods, no labels read but to score:

1. **joint-centre fits** (thighs and shanks): for each leg the joint centres are fitted in the
   plane (:func:`sspinn.imu.joint_centres.joint_centre`, Seel, Raisch & Schauer 2014): the hip
   from the pelvis and thigh sensors, the knee from the thigh and shank sensors, the ankle from
   the shank and foot sensors. In a segment's frame the proximal joint is the origin and the
   distal joint lies on the −y axis, so the two joint centres seen from the segment's sensor give
   its angle and position (:func:`sspinn.imu.joint_centres.sensor_placement`). No training.
2. **fitted to the estimate** (every sensor; with ``--model``): the model's estimate of each
   recording, then each sensor's position, angle and accelerometer bias fitted to the estimated
   kinematics (:func:`benchmarks.studies.placement_fit.fit_placement`).
3. **fitted to the true kinematics** (every sensor): the same fit to the recording's labels — not a
   method (it reads the labels) but the bound: what the signals say about the placement when the
   kinematics are exact, so what is left is the IMU errors' (soft-tissue artefact, noise).

Printed per gait (walking, running) and segment: the median over the recordings of the position
error √(Δx² + Δy²) (cm) of the nominal placement and of each method, each method's ratio to the
nominal, and the median angle errors (°); the target set for the learned placement is a median
below half the nominal error for the thighs.

With ``--misplacements`` (and ``--model``): every recording again with each sensor deliberately
moved along its segment by 2, 5, 10 or 20 cm or turned by 10, 20 or 30° (random signs; the
misplacement study's :func:`sspinn.estimator.paper_experiments.misplaced`, the moved placement the
truth), and the fit to the estimate of that recording scored against it: how well a placement
that is really wrong is found again.

On recordings without a true placement (real ones) and with ``--model``: the positions fitted to
the estimate (angles kept: ``fit_placement(..., angles=False)``) per recording, and per subject
their spread between its recordings — the same sensors, so the same placement, is all that can be
checked there.

With ``--decompose`` (and ``--model``): what of the estimate limits the fit to it. The fit to the
true segment motion (from the same first sample as the estimate's fit), then with one part of the
estimate's motion put in at a time — each segment origin's acceleration, the segment's angle, its
angular rate, its angular acceleration (:class:`benchmarks.studies.placement_fit.SegmentMotion`) —
and with all of it (the fit to the estimate).

``--pieces SECONDS`` fits consecutive pieces of that length of every recording, each on its own:
how the recovery depends on the length of the recording (``configs/synth/long_walk.yaml`` makes
minute-long walking recordings for it).

Usage: ``python -m benchmarks.studies.placement_recovery --data data/synth_default [--model
results/demo/run/model.pt [--misplacements] [--decompose]] [--pieces SECONDS] [--json PATH]`` (a dataset made by ``python -m predictive synth``,
whose recordings store their true placement, or any other with ``--model``).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

import numpy as np

REPO = Path(__file__).resolve().parents[2]

#: segment → (proximal joint's sensor pair, distal joint's sensor pair), each pair (proximal
#: segment, distal segment) of the joint.
CHAINS = {
    "femur": (("pelvis", "femur"), ("femur", "tibia")),
    "tibia": (("femur", "tibia"), ("tibia", "foot")),
}
#: Rows of the table, in order: a segment name's prefix and its label.
GROUPS = {"pelvis": "pelvis", "femur": "thigh", "tibia": "shank", "foot": "foot"}
#: The parts of the segment motion swapped in by ``--decompose``: SegmentMotion field → label.
PARTS = {"origin_acc": "origin acceleration", "angle": "angle", "rate": "angular rate", "angular_acc": "angular acceleration"}
#: The methods' keys and column heads.
METHODS = {"joint_centres": "joint-centre fits", "estimate": "fitted to the estimate", "labels": "fitted to the true kinematics (bound)"}


def _name(segment: str, side: str) -> str:
    return segment if segment == "pelvis" else f"{segment}_{side}"


def joint_centre_placement(signals: dict[str, Any], nominal: dict[str, np.ndarray], segment: str, side: str,
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
    parser.add_argument("--model", type=Path, help="a trained model (model.pt): also fit the placement to its estimates")
    parser.add_argument("--misplacements", action="store_true",
                        help="with --model: also fit recordings whose sensors were deliberately moved or turned")
    parser.add_argument("--decompose", action="store_true",
                        help="with --model: also fit to the true segment motion with one part of the estimate's put in at a time")
    parser.add_argument("--pieces", type=float, metavar="SECONDS",
                        help="fit consecutive pieces of this many seconds of each recording, each on its own "
                             "(how the recovery depends on the recording's length)")
    parser.add_argument("--json", type=Path, help="also save the results")
    args = parser.parse_args(argv)
    for flag in ("misplacements", "decompose"):
        if getattr(args, flag) and args.model is None:
            parser.error(f"--{flag} needs --model")

    from scipy.signal import butter, sosfiltfilt

    from benchmarks.studies.placement_fit import fit_placement
    from sspinn.data.dataset import SAMPLE_RATE_HZ, Dataset
    from sspinn.estimator.paper_experiments import MISPLACEMENTS, misplaced, misplaced_placement, true_placement
    from sspinn.imu.joint_centres import CUTOFF_HZ
    from sspinn.model.body import BodyParameters
    from sspinn.model.conventions import SEGMENTS

    est = None
    if args.model is not None:
        from sspinn.estimator.sspinnpose import SSPINNpose

        est = SSPINNpose.load(args.model)
    dataset = Dataset.open(args.data)
    sos = butter(2, CUTOFF_HZ, fs=SAMPLE_RATE_HZ, output="sos")
    rows: list[dict[str, Any]] = []
    moved: list[dict[str, Any]] = []
    decomposed: list[dict[str, Any]] = []
    real: list[dict[str, Any]] = []
    index = -1
    for split in dataset.splits:
        for rec in (piece for whole in dataset.load(split) for piece in _pieces(whole, args.pieces)):
            index += 1
            truth = true_placement(rec)
            if truth is None or rec.labels is None:
                if est is not None:
                    fitted = fit_placement(rec, est.predict(rec), angles=False).placement
                    real.append({"recording": rec.name, "subject": rec.subject,
                                 "nominal_m": {s: list(rec.placement.positions[s]) for s in rec.segments},
                                 "fitted_m": {s: list(fitted.positions[s]) for s in rec.segments}})
                continue
            nominal_vec = rec.placement.vector().reshape(len(SEGMENTS), 3)
            nominal = dict(zip(SEGMENTS, nominal_vec))
            body = BodyParameters.from_anthropometry(rec.height, rec.mass)
            signals = {}
            for i, s in enumerate(SEGMENTS):
                omega = sosfiltfilt(sos, rec.imu[:, i, 2])
                signals[s] = (sosfiltfilt(sos, rec.imu[:, i, :2], axis=0), omega, np.gradient(omega) * SAMPLE_RATE_HZ)
            fits = {"labels": fit_placement(rec, rec.labels, body, warmup_s=0.0).placement.vector().reshape(len(SEGMENTS), 3)}
            program = rec.provenance.get("program") if isinstance(rec.provenance, dict) else None
            gait = str(program.get("name", "?")) if isinstance(program, dict) else "?"
            if est is not None:
                estimate = est.predict(rec)
                fits["estimate"] = fit_placement(rec, estimate, body).placement.vector().reshape(len(SEGMENTS), 3)
                if args.decompose:
                    decomposed += _decompose(rec, estimate, fits["estimate"], body, truth, gait)
            if args.misplacements and est is not None:
                for what, (along, angle) in MISPLACEMENTS.items():
                    if not (along or angle):
                        continue
                    target = misplaced_placement(rec, along, angle, seed=index)
                    shifted = misplaced(rec, along, angle, seed=index)
                    fit = fit_placement(shifted, est.predict(shifted), body).placement.vector().reshape(len(SEGMENTS), 3)
                    for k, name in enumerate(SEGMENTS):
                        moved.append({"recording": rec.name, "gait": gait, "sensor": name, "misplacement": what,
                                      **_errors("nominal", nominal_vec[k], target[k]), **_errors("estimate", fit[k], target[k])})
            for k, name in enumerate(SEGMENTS):
                found = {key: value[k] for key, value in fits.items()}
                segment, _, side = name.partition("_")
                if segment in CHAINS:
                    position, angle = joint_centre_placement(signals, nominal, segment, side, float(getattr(body, name).length))
                    found["joint_centres"] = np.array([*position, angle])
                row = {"recording": rec.name, "split": split, "gait": gait, "sensor": name,
                       **_errors("nominal", nominal_vec[k], truth[k])}
                for key, v in found.items():
                    row |= _errors(key, v, truth[k])
                rows.append(row)
    if not rows and not real:
        print(f"{args.data}: no recording stores its true placement (only `python -m predictive synth` data do); "
              "with --model the fitted positions are compared between each subject's recordings", file=sys.stderr)
        return {}
    if real:
        _print_real(real, args.data, args.model)
    summary = _print_truth(rows, args.data, args.model) if rows else {}
    if moved:
        summary["misplaced"] = _print_moved(moved)
    if decomposed:
        summary["decomposed"] = _print_decomposed(decomposed)
    out = {"data": str(args.data), "model": str(args.model) if args.model else None, "summary": summary, "rows": rows,
           "misplaced": moved, "decomposed": decomposed, "real": real}
    if args.json:
        from sspinn.run_folder import atomic_write_text

        atomic_write_text(args.json, json.dumps(out, indent=2))
    return out


def _errors(key: str, found: np.ndarray, target: np.ndarray) -> dict[str, float]:
    """``<key>_cm``: the distance between two [x (m), y (m), angle (rad)] placements' positions,
    cm; ``<key>_angle_deg``: between their angles, °."""
    return {f"{key}_cm": float(100 * np.hypot(*(found[:2] - target[:2]))),
            f"{key}_angle_deg": float(np.degrees(abs(found[2] - target[2])))}


def _print_truth(rows: list[dict[str, Any]], data: Path, model: Path | None) -> dict[str, Any]:
    """The table against the stored truth: per gait and segment group, the median position and
    angle errors of the nominal placement and of each method; returns them."""
    methods = [m for m in METHODS if any(f"{m}_cm" in r for r in rows)]
    print(f"# Sensor placement recovered from the IMU signals, {data} ({len({r['recording'] for r in rows})} recordings"
          + (f"; estimates of {model}" if model else "") + ")\n")
    print("Median position error (cm), its ratio to the nominal's, and the median angle error (°):\n")
    print("| gait | segment | sensors | nominal | " + " | ".join(METHODS[m] for m in methods) + " |")
    print("|---|---|---:|---:|" + "---:|" * len(methods))
    summary: dict[str, Any] = {}
    for gait in sorted({r["gait"] for r in rows}):
        for prefix, label in GROUPS.items():
            sel = [r for r in rows if r["gait"] == gait and r["sensor"].startswith(prefix)]
            if not sel:
                continue
            nom, nom_angle = float(np.median([r["nominal_cm"] for r in sel])), float(np.median([r["nominal_angle_deg"] for r in sel]))
            entry: dict[str, Any] = {"n": len(sel), "nominal_cm": nom, "nominal_angle_deg": nom_angle}
            cells = []
            for m in methods:
                have = [r for r in sel if f"{m}_cm" in r]
                if not have:
                    cells.append("–")
                    continue
                cm, deg = float(np.median([r[f"{m}_cm"] for r in have])), float(np.median([r[f"{m}_angle_deg"] for r in have]))
                entry[m] = {"cm": cm, "ratio": cm / nom, "angle_deg": deg, "below_half": cm < 0.5 * nom}
                cells.append(f"{cm:.2f} ({cm / nom:.2f}×), {deg:.1f}°")
            summary[f"{gait}/{label}"] = entry
            print(f"| {gait} | {label} | {len(sel)} | {nom:.2f}, {nom_angle:.1f}° | " + " | ".join(cells) + " |")
    return summary


def _decompose(rec: Any, estimate: Any, estimate_fit: np.ndarray, body: Any, truth: np.ndarray, gait: str) -> list[dict[str, Any]]:
    """Rows (one per sensor and arm) of the fits to the true segment motion with nothing, one part
    (:data:`PARTS`) or all of the estimate's motion put in (that is ``estimate_fit`` (7, 3), the fit
    to the estimate), scored against ``truth`` ((7, 3))."""
    import dataclasses

    from benchmarks.studies.placement_fit import check_fit_inputs, fit_to_terms, segment_motion
    from sspinn.model.conventions import SEGMENTS

    start = check_fit_inputs(rec, estimate)
    true_motion, estimated = segment_motion(rec.labels, body), segment_motion(estimate, body)
    arms = {"none": true_motion, **{part: dataclasses.replace(true_motion, **{part: getattr(estimated, part)}) for part in PARTS}}
    fits = {arm: fit_to_terms(rec, *(t[start:] for t in motion.terms()), start).placement.vector().reshape(len(SEGMENTS), 3)
            for arm, motion in arms.items()} | {"all": estimate_fit}
    nominal = rec.placement.vector().reshape(len(SEGMENTS), 3)
    rows = []
    for arm, fitted in fits.items():
        for name in rec.segments:
            k = SEGMENTS.index(name)
            rows.append({"recording": rec.name, "gait": gait, "sensor": name, "arm": arm,
                         **_errors("nominal", nominal[k], truth[k]), **_errors("fit", fitted[k], truth[k])})
    return rows


def _print_decomposed(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """Per gait and segment group, the median position error (cm) and its ratio to the nominal's of
    each ``--decompose`` arm; returns them."""
    arms = {"none": "true motion", **{p: f"+ estimated {label}" for p, label in PARTS.items()}, "all": "estimated motion"}

    def cell(sel: list[dict[str, Any]]) -> tuple[str, dict[str, float]]:
        cm, nom = float(np.median([r["fit_cm"] for r in sel])), float(np.median([r["nominal_cm"] for r in sel]))
        return f"{cm:.2f} ({cm / nom:.2f}×)", {"cm": cm, "ratio": cm / nom}

    return _print_grid("What of the estimate limits the fit: the fit to the true segment motion with one part of the estimate's "
                       "put in, median position error cm (ratio to the nominal's):", "segment", rows,
                       [(label, lambda r, p=prefix: r["sensor"].startswith(p)) for prefix, label in GROUPS.items()],
                       [(label, arm, lambda r, a=arm: r["arm"] == a) for arm, label in arms.items()], cell)


def _print_grid(title: str, outer_head: str, rows: list[dict[str, Any]], outer: list[tuple[str, Any]],
                columns: list[tuple[str, str, Any]], cell: Any) -> dict[str, Any]:
    """A Markdown table of ``rows``: a line per gait and ``outer`` (label, predicate), a cell per
    ``columns`` (head, key, predicate) made by ``cell(selected rows)`` → (text, summary entry);
    returns the entries keyed ``gait/outer label/column key``. A line stops at its first empty cell."""
    print(f"\n{title}\n")
    print(f"| gait | {outer_head} | " + " | ".join(head for head, _, _ in columns) + " |")
    print("|---|---|" + "---|" * len(columns))
    summary: dict[str, Any] = {}
    for gait in sorted({r["gait"] for r in rows}):
        for label, in_line in outer:
            cells = []
            for _, key, in_column in columns:
                sel = [r for r in rows if r["gait"] == gait and in_line(r) and in_column(r)]
                if not sel:
                    break
                text, summary[f"{gait}/{label}/{key}"] = cell(sel)
                cells.append(text)
            if cells:
                print(f"| {gait} | {label} | " + " | ".join(cells) + " |")
    return summary


def _pieces(rec: Any, seconds: float | None) -> list[Any]:
    """``rec`` (``seconds`` None), or its consecutive pieces of ``seconds`` (the rest left out),
    each named after its span."""
    import dataclasses

    from sspinn.data.dataset import SAMPLE_RATE_HZ

    if seconds is None:
        return [rec]
    n = int(round(seconds * SAMPLE_RATE_HZ))
    return [dataclasses.replace(rec, name=f"{rec.name}[{a / SAMPLE_RATE_HZ:g}-{(a + n) / SAMPLE_RATE_HZ:g} s]",
                                imu=rec.imu[a:a + n], labels=None if rec.labels is None else rec.labels.slice(slice(a, a + n)))
            for a in range(0, rec.n_samples - n + 1, n)]


def _print_moved(moved: list[dict[str, Any]]) -> dict[str, Any]:
    """Per gait, misplacement and leg segment: the medians of the nominal placement's and of the
    fit's position (cm) and angle (°) errors against the moved placement; returns them."""
    legs = {"femur": "thigh", "tibia": "shank", "foot": "foot"}

    def cell(sel: list[dict[str, Any]]) -> tuple[str, dict[str, float]]:
        med = {key: float(np.median([r[key] for r in sel]))
               for key in ("nominal_cm", "estimate_cm", "nominal_angle_deg", "estimate_angle_deg")}
        return (f"{med['nominal_cm']:.1f} → {med['estimate_cm']:.2f} cm ({med['estimate_cm'] / med['nominal_cm']:.2f}×), "
                f"{med['nominal_angle_deg']:.1f} → {med['estimate_angle_deg']:.1f}°"), med

    return _print_grid("Sensors deliberately moved or turned (every sensor of every recording), the fit to the estimate of the "
                       "moved recording against the moved placement: nominal → fitted, median cm (ratio) and °:", "misplacement",
                       moved, [(what, lambda r, w=what: r["misplacement"] == w) for what in dict.fromkeys(r["misplacement"] for r in moved)],
                       [(label, label, lambda r, p=prefix: r["sensor"].startswith(p)) for prefix, label in legs.items()], cell)


def _print_real(real: list[dict[str, Any]], data: Path, model: Path | None) -> None:
    """Per subject and sensor: the nominal and fitted positions (cm) of each recording, and the
    largest distance between two of its recordings' fitted positions."""
    print(f"# Sensor positions fitted to the estimates of {model} (angles kept), {data} ({len(real)} recordings "
          "without a true placement)\n")
    print("| subject | sensor | nominal x, y (cm) | fitted x, y per recording (cm) | spread (cm) |")
    print("|---|---|---|---|---:|")
    for subject in sorted({r["subject"] for r in real}):
        mine = [r for r in real if r["subject"] == subject]
        for sensor in mine[0]["fitted_m"]:
            points = np.array([r["fitted_m"][sensor] for r in mine if sensor in r["fitted_m"]])
            spread = max((float(np.hypot(*(a - b))) for a in points for b in points), default=0.0)
            nominal = mine[0]["nominal_m"][sensor]
            fitted = "; ".join(f"{100 * x:.1f}, {100 * y:.1f}" for x, y in points)
            print(f"| {subject} | {sensor} | {100 * nominal[0]:.1f}, {100 * nominal[1]:.1f} | {fitted} | {100 * spread:.1f} |")
    print()


if __name__ == "__main__":
    main(sys.argv[1:])
