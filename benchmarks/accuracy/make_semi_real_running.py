"""Write the semi-real running check as a sspinn dataset: human running kinematics (OpenSim IK of
Hamner's treadmill running, subject02) with measured GRFs and *virtual* IMUs (sspinn's model and
IMU error model). See :mod:`benchmarks.accuracy.semi_real_running` for the method.

The dataset folder holds one recording, ``hamner_subject02_run``, listed in the ``test`` split of
its ``dataset.json``, so that any model can be evaluated on it::

    python -m benchmarks.accuracy.make_semi_real_running --out data/hamner_run [--seed 0]
    sspinn evaluate --model runs/<run>/model.pt --data data/hamner_run --split test --out runs/<run>/hamner

Prints the sanity checks (duration, belt speed, stride frequency, contact timing from the GRF,
joint-angle ranges, the Kane residual of the labels, IMU peaks) and writes them to
``<out>/sanity.json``. Needs ``../shared/data/opensim_hamner_run`` (or ``--data``).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from benchmarks.accuracy.semi_real_running import (
    DEFAULT_RUN_CUTOFF_HZ,
    hamner_running,
)
from sspinn.data.dataset import Dataset
from sspinn.data.sensor_noise import IMUErrorModel

ROOT = Path(__file__).resolve().parents[2]

#: Typical sagittal joint-angle ranges of running at 3–5 m/s, degrees, sspinn signs (hip flexion
#: +, knee flexion −, ankle dorsiflexion +); approximate ranges from the running literature
#: (e.g. Novacheck 1998, Gait Posture 7:77–95; Hamner & Delp 2013, J Biomech 46:780–787).
TYPICAL_RANGES_DEG = {
    "pelvis_tilt": "about ±5° around a small anterior tilt",
    "hip": "≈ −30 … −10 (extension at toe-off) to ≈ +40 … +55 (flexion in late swing)",
    "knee": "≈ −10 … −20 (stance, most extended) to ≈ −90 … −130 (swing)",
    "ankle": "≈ −20 … −30 (plantarflexion at toe-off) to ≈ +20 … +30 (dorsiflexion, mid-stance)",
}


def _fmt_range(lo: float, hi: float) -> str:
    return f"{lo:7.1f} … {hi:6.1f}"


def print_summary(s: dict) -> None:
    print(f"duration: {s['duration_s']:.2f} s ({s['n_samples']} samples at 100 Hz)")
    print(
        f"belt speed: {s['belt_speed_mps']:.3f} m/s (SD over {s['belt_speed_stances']} stances "
        f"{s['belt_speed_spread_mps']:.3f} m/s)"
    )
    print(
        f"stride: {1 / s['stride_frequency_hz']:.3f} s = {s['stride_frequency_hz']:.3f} Hz "
        f"({s['cadence_steps_per_min']:.0f} steps/min), stride length {s['stride_length_m']:.2f} m"
    )
    for side, c in s["contact"].items():
        print(f"  foot {side}: {c['stances']} complete stances, stance {c['stance_s']:.3f} s, stride {c['stride_s']:.3f} s")
    print(
        f"contact (vertical GRF > 20 N): duty factor {s['duty_factor']:.3f} per foot-sample, flight "
        f"{s['flight_fraction']:.3f}, double support {s['double_support_fraction']:.3f} of the time"
    )
    print(
        f"GRF: peak vertical {s['peak_grf_y_bw']:.2f} BW, horizontal {s['grf_x_bw_range'][0]:.2f} … "
        f"{s['grf_x_bw_range'][1]:.2f} BW, mean total vertical {s['mean_grf_y_bw']:.3f} BW"
    )
    print("joint angles, degrees (min … max) | typical running:")
    for name, (lo, hi) in s["angles_deg"].items():
        kind = name.split("_")[0] if name != "pelvis_tilt" else name
        print(f"  {name:<11} {_fmt_range(lo, hi)}  | {TYPICAL_RANGES_DEG[kind]}")
    print(f"hip height: {s['hip_height_m'][0]:.3f} … {s['hip_height_m'][1]:.3f} m")
    r = s["kane_residual"]
    print(
        f"Kane residual of the labels (pelvis rows; leg rows are 0 by inverse dynamics): horizontal RMS "
        f"{r['rms_x_bw']:.3f} BW, vertical RMS {r['rms_y_bw']:.3f} BW, max {r['max_trans_bw']:.2f} BW; "
        f"rotation RMS {r['rms_rot_bwh']:.3f} BW·H, max {r['max_rot_bwh']:.2f} BW·H"
    )
    print("ideal virtual IMUs (no errors): |acc| max / median (m/s²), |gyr_z| max (rad/s)")
    for seg, v in s["ideal_imu"].items():
        print(f"  {seg:<8} {v['acc_norm_max_mps2']:6.1f} / {v['acc_norm_median_mps2']:5.1f}   {v['gyr_abs_max_rad_s']:5.1f}")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=Path, required=True, help="dataset folder to write (created)")
    ap.add_argument("--seed", type=int, default=0, help="seed of the IMU error model (default 0)")
    ap.add_argument("--data", type=Path, default=None, help="the opensim_hamner_run folder (default: in $SSPINN_SHARED_DATA)")
    ap.add_argument("--cutoff", type=float, default=DEFAULT_RUN_CUTOFF_HZ, help="low-pass cutoff, Hz")
    ap.add_argument("--no-imu-errors", action="store_true", help="ideal virtual IMUs (IMUErrorModel.none())")
    args = ap.parse_args(argv)

    model = IMUErrorModel.none() if args.no_imu_errors else IMUErrorModel()
    try:
        result = hamner_running(args.data, seed=args.seed, error_model=model, cutoff=args.cutoff)
    except FileNotFoundError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    rec = result.recording
    Dataset.write(
        args.out,
        {"test": [rec]},
        info={
            "kind": "semi-real",
            "description": rec.provenance["description"],
            "generator": "benchmarks/accuracy/make_semi_real_running.py",
            "seed": args.seed,
            "imu_errors": "none" if args.no_imu_errors else "default",
        },
    )
    summary = result.summary()
    (args.out / "sanity.json").write_text(json.dumps(summary, indent=2))
    print(f"{rec.name}: {rec.n_samples} samples, IMUs {list(rec.segments)}, labels {rec.labels.available() if rec.labels else []}")
    print_summary(summary)
    print(f"wrote {args.out / (rec.name + '.csv')} (+ .json), {args.out / 'dataset.json'} (split test), {args.out / 'sanity.json'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
