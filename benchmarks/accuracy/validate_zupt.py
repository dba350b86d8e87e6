"""Validate the 2D ZUPT Kalman filter (:mod:`sspinn.estimator.zupt`) against motion capture on real data
(with :mod:`benchmarks.accuracy.zupt_gaitmap`).

Data: gaitmap's example recording (``../shared/data/gaitmap_foot_imu``): two foot IMUs (204.8 Hz,
gaitmap sensor frame, gyro in deg/s), foot markers (100 Hz, mm) and 57 strides (mid-stance to
mid-stance, in IMU samples); walking there and back with one turn.

Prints (1) the evidence for the sensor-axis mapping, (2) the IMU–mocap time-base check, (3) the
per-stride mean forward speed from ZUPT and from motion capture (heel marker FCC by default,
gaitmap's own reference point) with the error statistics (mean, SD, RMSE, max |·|; m/s) per foot,
over all strides and over the straight ones (foot heading change < 20° over the stride), and
(4) the runtime; writes a figure (ZUPT vs mocap per stride, and a stretch of the speed signals).

Usage::

    python -m benchmarks.accuracy.validate_zupt [--data DIR] [--out results/validation/zupt.png] [--no-align] [--marker FCC]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from benchmarks.accuracy.zupt_gaitmap import (
    FEET,
    GaitmapExample,
    StrideSpeeds,
    foot_marker,
    gaitmap_stride_speeds,
    load_gaitmap_example,
    sagittal_from_gaitmap_frame,
)
from sspinn.estimator.zupt import SagittalZuptKalman
from sspinn.model.drawing import save_figure

MAX_TURN_DEG = 20.0
DEFAULT_DATA = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "gaitmap_foot_imu"


def axis_evidence(example: GaitmapExample) -> str:
    """Facts from the raw data that fix the sagittal axes and signs of gaitmap's sensor frame."""
    lines = ["Sensor axes (raw gaitmap frame; medians over strides):"]
    fs = example.imu_rate_hz
    for foot in FEET:
        raw = example.imu[foot]
        gyr_norm = np.linalg.norm(raw[:, 3:], axis=1)
        rest = gyr_norm < 10.0
        share = (raw[:, 3:] ** 2).sum(axis=0) / (raw[:, 3:] ** 2).sum()
        strides = [s for s in example.strides if s["foot"] == foot]
        push = np.median([raw[int(s["tc"]) - 10 : int(s["tc"]), 4].mean() for s in strides])
        heel = np.median([raw[int(s["ic"]) : int(s["ic"]) + 20, 4].mean() for s in strides])
        early = np.median([raw[int(s["tc"]) : int(s["tc"]) + int(0.1 * fs), 0].mean() for s in strides])
        late = np.median([raw[int(s["ic"]) - int(0.1 * fs) : int(s["ic"]), 0].mean() for s in strides])
        acc_rest = raw[rest, :3].mean(axis=0)
        lines += [
            f"  {foot:5s} acc at rest (x, y, z) = ({acc_rest[0]:5.2f}, {acc_rest[1]:5.2f}, {acc_rest[2]:5.2f}) m/s² "
            "→ z up",
            f"        gyro energy share x/y/z = {share[0]:.2f}/{share[1]:.2f}/{share[2]:.2f}; gyr_y mean 50 ms before "
            f"toe-off {push:+.0f} °/s, 0–100 ms after initial contact {heel:+.0f} °/s (toe lowering) → toe-down = +gyr_y",
            f"        acc_x 0–100 ms after toe-off {early:+.1f} m/s², 100 ms before initial contact {late:+.1f} m/s² "
            "(swing speeds up, then brakes) → x forward",
        ]
    lines.append("  ⇒ sagittal: acc_x = acc_x, acc_y = acc_z, gyr_z = −gyr_y (deg/s → rad/s); y points left.")
    return "\n".join(lines)


def time_base_check(example: GaitmapExample, fits: dict[str, SagittalZuptKalman]) -> str:
    """Durations and the lag maximising the correlation of the ZUPT and heel-marker speeds."""
    imu_s = len(example.imu["left"]) / example.imu_rate_hz
    mocap_s = len(example.markers["L_TOE"]) / example.mocap_rate_hz
    lines = [
        f"Time bases: IMU {imu_s:.2f} s at {example.imu_rate_hz} Hz, mocap {mocap_s:.2f} s at {example.mocap_rate_hz} Hz"
    ]
    t_imu = np.arange(len(example.imu["left"])) / example.imu_rate_hz
    for foot in FEET:
        heel = foot_marker(example, foot, "FCC")
        t_m = np.arange(len(heel)) / example.mocap_rate_hz
        speed_m = np.linalg.norm(np.gradient(heel, axis=0) * example.mocap_rate_hz, axis=1)
        speed_z = np.linalg.norm(fits[foot].velocity_, axis=1)
        sel = (t_m > 1.0) & (t_m < t_imu[-1] - 1.0)
        lags = np.arange(-0.1, 0.1001, 0.0025)
        r = [np.corrcoef(np.interp(t_m[sel] + lag, t_imu, speed_z), speed_m[sel])[0, 1] for lag in lags]
        best = int(np.argmax(r))
        lines.append(
            f"  {foot:5s} best lag {lags[best] * 1000:+.1f} ms (r = {r[best]:.3f}; at 0 ms r = {r[len(lags) // 2]:.3f}) "
            "→ same start, no resampling needed"
        )
    return "\n".join(lines)


def format_table(table: StrideSpeeds) -> str:
    """Per-stride rows and the error summaries."""
    lines = [
        f"{'s_id':>4s} {'foot':5s} {'dur s':>6s} {'ZUPT':>6s} {'mocap':>6s} {'error':>7s} {'turn °':>7s} {'sig RMSE':>8s}"
    ]
    for i in range(len(table.s_id)):
        flag = "" if abs(table.turn_deg[i]) < MAX_TURN_DEG else "  (turn)"
        lines.append(
            f"{table.s_id[i]:4d} {table.foot[i]:5s} {table.duration_s[i]:6.3f} {table.zupt[i]:6.3f} "
            f"{table.mocap[i]:6.3f} {table.error[i]:+7.3f} {table.turn_deg[i]:7.1f} {table.signal_rmse[i]:8.3f}{flag}"
        )
    lines.append("")
    lines.append(f"Per-stride speed error ZUPT − mocap (m/s); straight = |heading change| < {MAX_TURN_DEG:.0f}°")
    lines.append(
        f"{'foot':6s} {'strides':9s} {'n':>3s} {'mean':>7s} {'SD':>6s} {'RMSE':>6s} {'max':>6s} "
        f"{'median mocap':>12s} {'median sig RMSE':>15s}"
    )
    straight = np.abs(table.turn_deg) < MAX_TURN_DEG
    for foot in (*FEET, "both"):
        in_foot = np.ones(len(table.s_id), bool) if foot == "both" else table.foot == foot
        for label, mask in (("all", in_foot), ("straight", in_foot & straight)):
            s = table.summary(mask)
            lines.append(
                f"{foot:6s} {label:9s} {int(s['n']):3d} {s['mean']:+7.3f} {s['sd']:6.3f} {s['rmse']:6.3f} "
                f"{s['max']:6.3f} {np.median(table.mocap[mask]):12.3f} {np.median(table.signal_rmse[mask]):15.3f}"
            )
    return "\n".join(lines)


def plot(table: StrideSpeeds, example: GaitmapExample, fits: dict[str, SagittalZuptKalman], out: Path) -> None:
    """Left: per-stride ZUPT vs mocap speed; right: a 6 s stretch of the foot speed signals."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(12, 4.8), gridspec_kw={"width_ratios": [1, 1.6]})
    ax = axes[0]
    straight = np.abs(table.turn_deg) < MAX_TURN_DEG
    for foot, color in zip(FEET, ("tab:blue", "tab:red")):
        m = table.foot == foot
        ax.scatter(table.mocap[m & straight], table.zupt[m & straight], s=18, color=color, label=f"{foot}")
        ax.scatter(table.mocap[m & ~straight], table.zupt[m & ~straight], s=40, marker="x", color=color)
    lim = [0, max(table.mocap.max(), table.zupt.max()) * 1.05]
    ax.plot(lim, lim, "k--", lw=0.8)
    s = table.summary(straight)
    ax.set_title(
        f"per-stride speed (× = turn)\nstraight: RMSE {s['rmse']:.3f} m/s, bias {s['mean']:+.3f} m/s", fontsize=10
    )
    ax.set_xlabel("motion capture (m/s)")
    ax.set_ylabel("2D ZUPT Kalman (m/s)")
    ax.legend()
    ax = axes[1]
    t_imu = np.arange(len(example.imu["left"])) / example.imu_rate_hz
    for foot, color in zip(FEET, ("tab:blue", "tab:red")):
        heel = foot_marker(example, foot, "FCC")
        t_m = np.arange(len(heel)) / example.mocap_rate_hz
        speed_m = np.linalg.norm(np.gradient(heel[:, :2], axis=0) * example.mocap_rate_hz, axis=1)
        ax.plot(t_imu, np.abs(fits[foot].velocity_[:, 0]), color=color, lw=1.2, label=f"{foot} ZUPT |v_x|")
        ax.plot(t_m, speed_m, color=color, lw=0.8, ls="--", label=f"{foot} heel marker, horizontal")
    ax.set_xlim(8, 14)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("foot speed (m/s)")
    ax.set_title("foot speed signals\n(lateral heel IMU vs heel marker: nearby, not identical points)", fontsize=10)
    ax.legend(fontsize=7, loc="upper right")
    save_figure(fig, out, dpi=120)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA, help="gaitmap_foot_imu folder")
    parser.add_argument("--out", type=Path, default=Path("results/validation/zupt.png"), help="figure (PNG)")
    parser.add_argument("--no-align", action="store_true", help="skip the gravity/heading sensor alignment")
    parser.add_argument(
        "--marker", default="FCC", choices=("FCC", "TOE", "FM5", "centroid"), help="mocap reference point"
    )
    args = parser.parse_args(argv)
    if not (args.data / "imu_sample.csv").exists():
        print(f"data not found: {args.data} (see ../shared/data/README.md)", file=sys.stderr)
        return 1
    example = load_gaitmap_example(args.data)
    print(axis_evidence(example))
    for foot in FEET:
        raw = example.imu[foot]
        sig = sagittal_from_gaitmap_frame(raw[:, :3], raw[:, 3:], example.imu_rate_hz)
        print(f"Alignment {foot}: tilt {sig.tilt_deg:.1f}°, heading {sig.heading_deg:+.1f}°")
    t0 = time.perf_counter()
    table, fits = gaitmap_stride_speeds(example, align=not args.no_align, marker=args.marker)
    first = time.perf_counter() - t0
    t0 = time.perf_counter()
    table, fits = gaitmap_stride_speeds(example, align=not args.no_align, marker=args.marker)
    second = time.perf_counter() - t0
    print(time_base_check(example, fits))
    print()
    print(format_table(table))
    n = len(example.imu["left"])
    t0 = time.perf_counter()
    raw = example.imu["left"]
    sig = sagittal_from_gaitmap_frame(raw[:, :3], raw[:, 3:], example.imu_rate_hz)
    SagittalZuptKalman().estimate(sig.acc_xy, sig.gyr_z, example.imu_rate_hz)
    one = time.perf_counter() - t0
    print(
        f"\nRuntime: one foot ({n} samples) {one * 1000:.0f} ms; both feet + table {second * 1000:.0f} ms "
        f"(first call incl. numba compile/cache load {first:.1f} s)"
    )
    plot(table, example, fits, args.out)
    print(f"figure: {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
