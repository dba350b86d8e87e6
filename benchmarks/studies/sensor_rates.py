"""How much of each sensor's signal lies above a frequency, per segment: synthetic against real.

For every recording of the chosen splits of one or more datasets (synthetic ones, or real
recordings imported with ``sspinn import``): the RMS of each in-plane channel (acc_x, acc_y in
m/s², gyr_z in rad/s) after a zero-phase 4th-order Butterworth high-pass at ``--above`` Hz,
1 s trimmed at each end (filter transients), averaged per gait (a synthetic recording's program name, else the last
part of the recording's name, e.g. the CMU condition) and per segment (left and right together).
No labels are read: it compares what the sensors carry, e.g. whether synthetic sensors rock on
their straps as much as real ones (docs/results/cmu_treadmill.md, "Strap wobble").

Usage: ``python -m benchmarks.studies.sensor_rates --data data/synth_default results/cmu/data [--splits
train test] [--above 10]``. Seconds; no timing.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from scipy.signal import butter, sosfiltfilt

from sspinn.data.dataset import SAMPLE_RATE_HZ, Dataset, Recording
from sspinn.estimator.trivial_predictors import program_of

#: Segment groups of the table, in order: a segment name's prefix and its label.
GROUPS = {"pelvis": "pelvis", "femur": "thighs", "tibia": "shanks", "foot": "feet"}


def fast_rms(rec: Recording, above_hz: float) -> dict[str, np.ndarray]:
    """Per segment group of ``rec``: the RMS (3,) of [acc_x, acc_y, gyr_z] above ``above_hz``
    (4th-order Butterworth high-pass run forwards and backwards; 1 s left out at each end, a
    quarter of a recording shorter than 4 s)."""
    sos = butter(4, above_hz, "highpass", fs=SAMPLE_RATE_HZ, output="sos")
    n = len(rec.imu)
    if n < SAMPLE_RATE_HZ:
        raise ValueError(f"{rec.name}: {n} samples, fewer than a second's")
    trim = min(int(SAMPLE_RATE_HZ), n // 4)  # a short recording keeps its middle half
    fast = sosfiltfilt(sos, rec.imu, axis=0)[trim:n - trim]
    rms = np.sqrt(np.mean(fast**2, axis=0))  # (n_segments, 3)
    return {label: rms[[k for k, s in enumerate(rec.segments) if s.startswith(prefix)]].mean(axis=0)
            for prefix, label in GROUPS.items() if any(s.startswith(prefix) for s in rec.segments)}


def main(argv: list[str] | None = None) -> dict[str, dict[str, list[float]]]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, nargs="+", required=True, help="dataset folders")
    parser.add_argument("--splits", nargs="+", default=["train", "test"], help="splits read where a dataset has them")
    parser.add_argument("--above", type=float, default=10.0, help="high-pass cut-off, Hz")
    args = parser.parse_args(argv)
    if not 0 < args.above < SAMPLE_RATE_HZ / 2:
        parser.error(f"--above {args.above:g}: must lie between 0 and {SAMPLE_RATE_HZ / 2:g} Hz")
    for folder in args.data:
        if not (folder / "dataset.json").is_file():
            parser.error(f"{folder}: no dataset.json (a folder written by `predictive synth` or `sspinn import`)")
    print(f"RMS above {args.above:g} Hz of acc_x / acc_y (m/s²) and gyr_z (rad/s), mean per gait and segment\n")
    print("| data | gait | recordings | " + " | ".join(GROUPS.values()) + " |")
    print("|---|---|---:|" + "---|" * len(GROUPS))
    out: dict[str, dict[str, list[float]]] = {}
    for folder in args.data:
        dataset = Dataset.open(folder)
        rows: dict[str, list[dict[str, np.ndarray]]] = {}
        for split in (s for s in args.splits if s in dataset.splits):
            for rec in dataset.load(split):
                try:
                    rows.setdefault(program_of(rec, from_name=True), []).append(fast_rms(rec, args.above))
                except ValueError as exc:
                    parser.error(f"{folder}: {exc}")
        for gait, values in sorted(rows.items()):
            means = {label: np.mean([v[label] for v in values if label in v], axis=0)
                     for label in GROUPS.values() if any(label in v for v in values)}
            out[f"{folder}/{gait}"] = {label: m.tolist() for label, m in means.items()}
            cells = [" / ".join(f"{x:.2f}" for x in means[label]) if label in means else "–" for label in GROUPS.values()]
            print(f"| {folder} | {gait} | {len(values)} | " + " | ".join(cells) + " |")
    return out


if __name__ == "__main__":
    main()
