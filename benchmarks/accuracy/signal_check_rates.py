"""Detection and false-alarm rates of :mod:`sspinn.data.signal_checks` on real data: every
perturbation kind of :mod:`sspinn.testing.perturbations` drawn ``--draws`` times on excerpts of
the imported CMU treadmill trials (``sspinn import`` of ``../shared/data/cmu_treadmill_imu_grf``
into ``--data``, as ``benchmarks/accuracy/bench_cmu_continuous.py`` does), and every rate factor of
``--factors``; prints a Markdown table. A draw counts as detected when the recording is refused
(an error) or a finding is reported.

Usage::

    python -m benchmarks.accuracy.signal_check_rates --data results/cmu/data --draws 200
"""

from __future__ import annotations

import argparse
import warnings
from collections import defaultdict
from pathlib import Path

import numpy as np

from sspinn.data.dataset import DataFormatError, Dataset, Recording
from sspinn.data.signal_checks import label_findings, recording_findings
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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, required=True, help="dataset folder of the imported CMU trials")
    parser.add_argument("--draws", type=int, default=200)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--model", type=Path, default=None,
                        help="also show the estimate checks' findings with this model on the first trial with every "
                        "accelerometer negated, acc_x/acc_y swapped or every gyroscope negated (input checks bypassed)")
    parser.add_argument("--factors", type=float, nargs="*", default=[0.1, 0.2, 0.25, 0.4, 0.6, 1.67, 2.0, 2.5, 3.0, 5.0, 10.0])
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    dataset = Dataset.open(args.data)
    recs = [r for split in ("train", "val", "test") if split in dataset.splits for r in dataset.load(split)]
    recs = list({r.name: r for r in recs}.values())
    rng = np.random.default_rng(args.seed)
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
