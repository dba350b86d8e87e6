"""Detection and false-alarm rates of :mod:`sspinn.data.signal_checks` on real data: every
perturbation kind of :mod:`sspinn.testing.perturbations` drawn ``--draws`` times on excerpts of
the imported CMU treadmill trials (``sspinn import`` of ``../shared/data/cmu_treadmill_imu_grf``
into ``--data``, as ``benchmarks/accuracy/bench_cmu_continuous.py`` does), and every rate factor of
``--factors``; prints a Markdown table. A draw counts as detected when the recording is refused
(an error) or a finding is reported.

``--faults`` instead prints the fault → reported-cause table of docs/bad_input.md ("Silent
wrong results"): each fault of :data:`FAULTS` applied to every trial (whole) and to two 20 s
excerpts of each, and what the checks (and the loader's sidecar checks) report: the fault's own
cause, another finding, or nothing.

Usage::

    python -m benchmarks.accuracy.signal_check_rates --data results/cmu/data --draws 200
    python -m benchmarks.accuracy.signal_check_rates --data results/cmu/data --faults
    python -m benchmarks.accuracy.signal_check_rates --data results/cmu/data --effect models/pretrained/model.pt
"""

from __future__ import annotations

import argparse
import warnings
from collections import defaultdict
from pathlib import Path

import numpy as np

from sspinn.data.dataset import DataFormatError, Dataset, Labels, Recording, check_placement_angles
from sspinn.data.signal_checks import label_findings, recording_findings
from sspinn.model.body import IMUPlacement
from sspinn.testing.perturbations import KINDS, KINDS_NOT_CLAIMED, perturb

ROOT = Path(__file__).resolve().parents[2]

#: Length of the excerpts, s (the rate kinds use the whole trial: a 10× speed-up needs 50 s).
EXCERPT_S = 20.0


def detected(rec: Recording, imu: np.ndarray) -> list[str]:
    """The findings (or the error) for ``rec`` with its IMU array replaced by ``imu``."""
    try:
        changed = Recording(name=rec.name, imu=imu, segments=rec.segments, height=rec.height, mass=rec.mass,
                            subject=rec.subject, placement=rec.placement)
    except DataFormatError as exc:
        return [f"error: {exc}"]
    try:
        return recording_findings(changed, rec.name)
    except DataFormatError as exc:
        return [f"error: {exc}"]


def excerpt(rec: Recording, rng: np.random.Generator, seconds: float = EXCERPT_S) -> np.ndarray:
    n = int(seconds * 100)
    start = int(rng.integers(0, max(1, rec.n_samples - n)))
    return rec.imu[start:start + n]


def _changed(rec: Recording, imu: np.ndarray | None = None, **fields) -> Recording:
    """``rec`` (its first ``len(imu)`` samples) with the IMU array and sidecar fields replaced."""
    imu = rec.imu if imu is None else imu
    n = imu.shape[0]
    labels = rec.labels
    speed = fields.pop("speed", None)
    if speed is not None:
        labels = Labels.from_columns({"speed": np.full(n, speed)}, n)
    elif labels is not None and labels.speed is not None:
        labels = Labels.from_columns({"speed": labels.speed[:n]}, n)
    args = {"name": rec.name, "imu": imu, "segments": rec.segments, "height": rec.height, "mass": rec.mass,
            "subject": rec.subject, "placement": rec.placement, "labels": labels} | fields
    return Recording(**args)


def _left_leg_turned(rec: Recording, imu: np.ndarray, rng: np.random.Generator) -> Recording:
    out = imu.copy()
    for s in ("femur_l", "tibia_l", "foot_l"):
        out[:, rec.segments.index(s), 0] *= -1
        out[:, rec.segments.index(s), 2] *= -1
    return _changed(rec, out)


def _angles_in_degrees(rec: Recording, imu: np.ndarray, rng: np.random.Generator) -> Recording:
    """Each sensor mounted at 5–30° (either sign) in its segment's plane, the angle written in degrees."""
    out, angles = imu.copy(), {}
    for i, s in enumerate(rec.segments):
        deg = float(rng.uniform(5, 30) * rng.choice([-1, 1]))
        t = np.radians(deg)
        x, y = imu[:, i, 0], imu[:, i, 1]
        out[:, i, 0], out[:, i, 1] = x * np.cos(t) + y * np.sin(t), y * np.cos(t) - x * np.sin(t)
        angles[s] = deg  # the mistake: degrees where radians belong
    check_placement_angles(angles, f"{rec.name}.json")  # the loader's sidecar check
    return _changed(rec, out, placement=IMUPlacement(positions=dict(rec.placement.positions), angles=angles))


def _speed(factor: float):
    def fault(rec: Recording, imu: np.ndarray, rng: np.random.Generator) -> Recording:
        return _changed(rec, imu, speed=float(np.mean(rec.labels.speed)) * factor)
    return fault


def _placement_x_negated(rec: Recording, imu: np.ndarray, rng: np.random.Generator) -> Recording:
    positions = {s: (-x, y) for s, (x, y) in rec.placement.positions.items()}
    return _changed(rec, imu, placement=IMUPlacement(positions=positions, angles=dict(rec.placement.angles)))


def _scaled(acc: float = 1.0, bias: float = 0.0):
    def fault(rec: Recording, imu: np.ndarray, rng: np.random.Generator) -> Recording:
        out = imu.copy()
        out[:, :, :2] *= acc
        out[:, :, 2] += bias
        return _changed(rec, out)
    return fault


#: The faults of the table: (name, fault(rec, imu excerpt, rng) → changed recording, the words
#: of the finding that names its cause, or "" where no check claims it).
FAULTS = [
    ("untouched", lambda rec, imu, rng: _changed(rec, imu), ""),
    ("left-leg sensors turned 180° about their long axis (acc_x, gyr_z negated on femur_l, tibia_l, foot_l)",
     _left_leg_turned, "swing in phase"),
    ("all accelerometers × 1.5", _scaled(acc=1.5), "accelerometer looks scaled"),
    ("all accelerometers × 1.2", _scaled(acc=1.2), "accelerometer looks scaled"),
    ("gyroscope bias +0.5 rad/s on every sensor", _scaled(bias=0.5), "every gyroscope looks biased"),
    ("sensors mounted at 5–30°, the angles written in degrees", _angles_in_degrees, "in degrees"),
    ("speed label × 10 (7.69 m/s for a 0.77 m/s walk)", _speed(10.0), "speed label looks wrong"),
    ("speed label × 3.6 (km/h written as m/s)", _speed(3.6), "speed label looks wrong"),
    ("speed label × 1.5", _speed(1.5), ""),
    ("mass × 2 (no GRF labels)", lambda rec, imu, rng: _changed(rec, imu, mass=2 * rec.mass), ""),
    ("height 1.50 m for the subject's own", lambda rec, imu, rng: _changed(rec, imu, height=1.5), ""),
    ("placement x negated (sensors in front of the segment axis put behind it)", _placement_x_negated, ""),
]


def fault_table(recs: list[Recording], rng: np.random.Generator) -> None:
    """Print the fault → reported-cause table (module docstring)."""
    print("| fault | recordings | right cause | another finding | nothing |\n|---|---|---|---|---|")
    for name, fault, cause in FAULTS:
        right = other = quiet = 0
        for rec in recs:
            pieces = [rec.imu] + [excerpt(rec, rng) for _ in range(2)]
            for imu in pieces:
                try:
                    changed = fault(rec, imu, rng)
                    findings = recording_findings(changed, rec.name) + label_findings(changed, rec.name)
                except DataFormatError as exc:
                    findings = [f"error: {exc}"]
                if not findings:
                    quiet += 1
                elif cause and any(cause in f for f in findings):
                    right += 1
                else:
                    other += 1
        total = right + other + quiet
        shown = f"{right} ({right / total:.0%})" if cause else "not claimed"
        print(f"| {name} | {total} | {shown} | {other} | {quiet} |", flush=True)


def effect_table(model: Path, recs: list[Recording], rng: np.random.Generator) -> None:
    """The change of ``model``'s mean forward-speed estimate each IMU or sidecar fault of
    :data:`FAULTS` causes on every whole trial (the checks' warnings do not stop the estimate)."""
    import torch

    from sspinn.estimator.sspinnpose import SSPINNpose

    torch.set_num_threads(1)
    est = SSPINNpose.load(model)
    changes: dict[str, list[float]] = defaultdict(list)
    for rec in recs:
        base = float(np.mean(est.predict(rec).u[:, 0]))
        for name, fault, _ in FAULTS[1:]:
            if name.startswith("speed label"):  # labels are no input of the model
                continue
            try:
                changed = fault(rec, rec.imu, rng)
            except DataFormatError:  # refused by the loader: never estimated
                continue
            changes[name].append(float(np.mean(est.predict(changed).u[:, 0])) / base - 1)
    print(f"| fault | mean speed estimate vs untouched ({model}; mean, range over {len(recs)} trials) |\n|---|---|")
    for name, values in changes.items():
        print(f"| {name} | {np.mean(values):+.0%} ({np.min(values):+.0%} … {np.max(values):+.0%}) |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, required=True, help="dataset folder of the imported CMU trials")
    parser.add_argument("--draws", type=int, default=200)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--model", type=Path, default=None,
                        help="also show the estimate checks' findings with this model on the first trial with every "
                        "accelerometer negated, acc_x/acc_y swapped or every gyroscope negated (input checks bypassed)")
    parser.add_argument("--faults", action="store_true", help="print the fault → reported-cause table instead")
    parser.add_argument("--effect", type=Path, default=None, metavar="MODEL",
                        help="print each fault's effect on MODEL's mean speed estimate instead")
    parser.add_argument("--factors", type=float, nargs="*", default=[0.1, 0.2, 0.25, 0.4, 0.6, 1.67, 2.0, 2.5, 3.0, 5.0, 10.0])
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    dataset = Dataset.open(args.data)
    recs = [r for split in ("train", "val", "test") if split in dataset.splits for r in dataset.load(split)]
    recs = list({r.name: r for r in recs}.values())
    rng = np.random.default_rng(args.seed)
    if args.faults:
        fault_table(recs, rng)
        return
    if args.effect is not None:
        effect_table(args.effect, recs, rng)
        return
    false_alarms = [r.name for r in recs if recording_findings(r, r.name) or label_findings(r, r.name)]
    print(f"untouched trials with a finding: {len(false_alarms)} of {len(recs)} {false_alarms or ''}\n")
    quiet = [bool(detected(r, excerpt(r, rng))) for r in recs for _ in range(5)]
    print(f"untouched {EXCERPT_S:g} s excerpts with a finding: {sum(quiet)} of {len(quiet)}\n")
    hits: dict[str, list[bool]] = defaultdict(list)
    misses: dict[str, list[str]] = defaultdict(list)
    for _ in range(args.draws):
        kind = str(rng.choice(KINDS))
        rec = recs[int(rng.integers(len(recs)))]
        imu = rec.imu if kind == "rate" else excerpt(rec, rng)
        changed, what = perturb(imu, rec.segments, kind, rng)
        ok = bool(detected(rec, changed))
        hits[kind].append(ok)
        if not ok:
            misses[kind].append(f"{rec.name}: {what.description}")
    print("| perturbation | draws | detected | rate |\n|---|---|---|---|")
    for kind in KINDS:
        h = hits[kind]
        print(f"| {kind} | {len(h)} | {sum(h)} | {np.mean(h) if h else float('nan'):.0%} |")
    total = [x for h in hits.values() for x in h]
    print(f"| all | {len(total)} | {sum(total)} | {np.mean(total):.1%} |\n")
    for kind, items in misses.items():
        print(f"missed {kind}: " + "; ".join(items[:6]))
    print("\n| not claimed | draws | detected |\n|---|---|---|")
    for kind in KINDS_NOT_CLAIMED:
        n = sum(bool(detected(r, perturb(excerpt(r, rng), r.segments, kind, rng)[0])) for r in recs)
        print(f"| {kind} | {len(recs)} | {n} |")
    print("\n| rate factor (motion × f; recorded at 100/f Hz) | trials detected |\n|---|---|")
    for f in args.factors:
        n = sum(bool(detected(r, perturb(r.imu, r.segments, "rate", rng, factor=f)[0])) for r in recs)
        print(f"| × {f:g} ({100 / f:.4g} Hz) | {n} of {len(recs)} |")
    if args.model is not None:
        estimate_table(args.model, recs[0])


def estimate_table(model: Path, rec: Recording) -> None:
    """The estimate checks on ``rec`` with global mistakes, the input checks bypassed."""
    from sspinn.data.signal_checks import estimate_findings
    from sspinn.estimator.inference import estimate_recording
    from sspinn.estimator.sspinnpose import SSPINNpose
    from sspinn.model.conventions import GRAVITY

    est = SSPINNpose.load(model)
    print(f"\n| {rec.name}, {model} | mean vertical GRF (BW) | mean speed (m/s) | estimate warning |\n|---|---|---|---|")
    for name, scale in (("untouched", [1, 1, 1]), ("every accelerometer negated", [-1, -1, 1]),
                        ("every acc_x/acc_y swapped", None), ("every gyroscope negated", [1, 1, -1])):
        imu = rec.imu[:, :, [1, 0, 2]] if scale is None else rec.imu * scale
        changed = Recording(name=name, imu=imu, segments=rec.segments, height=rec.height, mass=rec.mass, placement=rec.placement)
        e = estimate_recording(est.network_, changed, est.segments_)
        vertical = e.grf[:, 1] + e.grf[:, 3]
        found = estimate_findings(name, vertical, e.u[:, 0], imu, rec.segments, rec.height, rec.mass)
        print(f"| {name} | {vertical.mean() / (rec.mass * GRAVITY):.2f} | {e.u[:, 0].mean():.2f} | "
              f"{'yes' if found else 'no'} |")


if __name__ == "__main__":
    main()
