"""How still synthetic quiet standing is, against real sensors on a person standing still.

For the subjects of one split of a synthetic configuration, standing ``--seconds`` each
(:func:`predictive.synth.standing.standing_trajectory`), the IMU signals measured twice from the
same draws: with the soft-tissue artefact off while the body rests (what
:func:`~predictive.synth.standing.standing_recording` does) and with the error model's stationary
artefact left on. Per arm: the standard deviation of ‖acc‖ per sensor (m/s²), the largest
|gyr_z| (°/s), and the share of samples that the whole-body rest detection
(:func:`sspinn.estimator.zupt.whole_body_still`) finds. Beside them, when the shared data are
there (``SSPINN_SHARED_DATA``, folder ``xsens_mt_static_S01``), the same for 11 real Xsens MTw
sensors of a person standing 3.7 s, read by ``sspinn``'s own reader (3D: std of ‖acc‖, largest
‖gyr‖).

Usage: ``python -m benchmarks.studies.standing_signals [--config configs/synth/default.yaml] [--split test]
[--seconds 10]``. A few seconds; no timing.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

from predictive.synth.config import SynthConfig, imu_model
from predictive.synth.standing import standing_trajectory
from predictive.synth.subjects import sample_subjects
from sspinn.data.dataset import SAMPLE_RATE_HZ
from sspinn.data.sensor_noise import measure_imu
from sspinn.data.shared_data import shared_data_dir
from sspinn.estimator.zupt import whole_body_still
from sspinn.imu.stream import standing_statistics
from sspinn.imu.vendor_readers import read_xsens_files
from sspinn.model.body import IMUPlacement


def synthetic_rows(config: SynthConfig, split: str, seconds: float) -> list[str]:
    """One row per arm: the spread of the synthetic standing signals over the split's subjects."""
    subjects = [s for s in sample_subjects(config) if s.split == split]
    arms: dict[str, list[tuple[np.ndarray, np.ndarray, float]]] = {"artefact off at rest (the generator)": [],
                                                                     "stationary artefact left on": []}
    for subject in subjects:
        rng = np.random.default_rng([config.seed, 6, subject.index])
        tr = standing_trajectory(subject.body, seconds, rng)
        state = rng.bit_generator.state
        for arm, rest in zip(arms, (np.ones(len(tr.q), dtype=bool), None)):
            rng.bit_generator.state = state  # the same draws in both arms
            imu, _ = measure_imu(tr.q, tr.u, tr.qdd, subject.body, IMUPlacement.default(subject.height), imu_model(config),
                                 rng, rest=rest)
            spread = np.linalg.norm(imu[:, :, :2], axis=2).std(axis=0)
            rate = np.degrees(np.abs(imu[:, :, 2]).max(axis=0))
            arms[arm].append((spread, rate, float(whole_body_still(imu, SAMPLE_RATE_HZ).mean())))
    rows = []
    for arm, values in arms.items():
        spread = np.concatenate([v[0] for v in values])
        rate = np.concatenate([v[1] for v in values])
        still = [v[2] for v in values]
        rows.append(f"| synthetic, {arm} ({len(values)} subjects × 7 sensors) | {spread.min():.3f}–{spread.max():.3f} | "
                    f"{rate.max():.1f} | {min(still):.0%}–{max(still):.0%} |")
    return rows


def real_row() -> str:
    """The row of the real Xsens static trial, or a note when the shared data are not there."""
    root = shared_data_dir()
    folder = None if root is None else root / "xsens_mt_static_S01"
    if folder is None or not folder.is_dir():
        return "| real Xsens MTw, standing (`xsens_mt_static_S01`) | not found: set SSPINN_SHARED_DATA | | |"
    stream = read_xsens_files(sorted(folder.glob("*.txt")))
    stats = [standing_statistics(s) for s in stream.sensors.values()]
    rates = [math.degrees(float(np.linalg.norm(s.gyr, axis=1).max())) for s in stream.sensors.values()]
    spread = [st.acc_norm_sd_m_s2 for st in stats]
    return (f"| real Xsens MTw, standing 3.7 s ({len(stats)} sensors; 3D ‖acc‖, ‖gyr‖) | {min(spread):.3f}–{max(spread):.3f} | "
            f"{max(rates):.1f} | – |")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--config", type=Path, default=Path("configs/synth/default.yaml"))
    ap.add_argument("--split", default="test", choices=("train", "val", "test"))
    ap.add_argument("--seconds", type=float, default=10.0, help="standing time per subject, s")
    args = ap.parse_args(argv)
    config = SynthConfig.from_yaml(args.config)
    print("| standing | std of ‖acc‖ per sensor, m/s² | largest rate, °/s | whole body found still |")
    print("|---|---|---|---|")
    for row in synthetic_rows(config, args.split, args.seconds):
        print(row)
    print(real_row())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
