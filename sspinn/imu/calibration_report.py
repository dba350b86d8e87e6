"""The calibration report of an IMU import: a Markdown table per sensor (axis found, residual
out-of-plane angular-rate energy, in-plane angle, how the sign was decided), the time alignment
with the GRF, the gaps and notes, and a matplotlib figure of the calibrated signals."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from sspinn.imu.calibration import SIGN_MARGIN_WARN, Calibration
from sspinn.imu.time_alignment import CLOCK_SOURCES, Alignment
from sspinn.model.drawing import save_figure


def _cell(text: str) -> str:
    """Text for a Markdown table cell (pipes escaped)."""
    return text.replace("|", "\\|")


def _vec(v: np.ndarray) -> str:
    return "(" + ", ".join(f"{x:+.3f}" for x in v) + ")"


def calibration_markdown(title: str, calibration: Calibration, alignment: Alignment | None = None,
                         context: dict[str, Any] | None = None, notes: list[str] | None = None) -> str:
    """The report as Markdown: ``context`` (key → value lines: files, map, subject…), the
    warnings, the per-sensor table, the alignment and the notes."""
    cal = calibration
    lines = [f"# IMU calibration: {title}", ""]
    for key, value in (context or {}).items():
        lines.append(f"- **{key}**: {value}")
    standing = (f"{cal.standing[0] / cal.rate_hz:.2f}–{cal.standing[1] / cal.rate_hz:.2f} s" if cal.standing else
                "none found (in-plane angles from the typical walking orientation; see docs/imu_import.md)")
    lines += [f"- **quiet standing**: {standing}", f"- **walking used**: {cal.walking_s:.1f} s, stride period {cal.stride_period_s:.2f} s", ""]
    if cal.warnings:
        lines += ["## Warnings", ""] + [f"- **{w}**" for w in cal.warnings] + [""]
    lines += [
        "## Sensors", "",
        "Axis: the segment's medio-lateral axis (to the subject's right) in the sensor frame. Out-of-plane: share of the "
        "angular-rate energy outside that axis while walking. Check: angle between the axis and an independent estimate "
        "(legs: the unconstrained principal axis; pelvis: the step-symmetric rotation axis). φ: in-plane angle of the "
        "sensor axis nearest the segment's long axis, counter-clockwise seen from the right. Sign margin below "
        f"{SIGN_MARGIN_WARN} is flagged.", "",
        "| sensor | segment | axis (sensor frame) | out-of-plane | check (deg) | φ (deg) | ref. axis | sign | margin | \\|acc\\| standing (m/s²) |",
        "|---|---|---|---:|---:|---:|---|---|---:|---:|",
    ]
    for seg, c in cal.sensors.items():
        flag = " **(uncertain)**" if c.sign_margin < SIGN_MARGIN_WARN else ""
        acc = "–" if c.standing_acc_norm is None else f"{c.standing_acc_norm:.2f}"
        if c.acc_gain != 1.0:
            acc += f" (≠ g: accelerometer scaled by {c.acc_gain:.3f})"
        lines.append(f"| {c.sensor} | {seg} | {_vec(c.axis)} | {c.out_of_plane_fraction:.1%} | {c.axis_check_deg:.1f} | "
                     f"{c.angle_deg:+.1f} | {c.reference_axis} | {c.sign_method}{flag} | {c.sign_margin:.2f} | {acc} |")
    lines += ["", "Sign votes (positive supports the axis as reported): " + "; ".join(
        f"{seg}: " + ", ".join(f"{k} {v:+.2f}" for k, v in c.sign_votes.items()) for seg, c in cal.sensors.items()), ""]
    lines += ["Methods: " + "; ".join(sorted({f"axis — {c.axis_method}" for c in cal.sensors.values()}
                                            | {f"angle — {c.angle_method}" for c in cal.sensors.values()})), ""]
    if alignment is not None:
        lines += ["## Time alignment with the GRF", "", f"**Lag from: {CLOCK_SOURCES[alignment.clock]}**"
                  + (" — each foot labelled with its own lag (--align per-foot)." if alignment.per_foot else "."), "",
                  alignment.describe(), "",
                  f"Candidates (peaks of the loading correlation, each fitted within ±{alignment.window_s:.2f} s — a quarter "
                  "stride — refined to the impact peak; the score sums the correlations; exchanged: the best fit in the same "
                  "window with the force channels' sides exchanged, loading + impact over the labelled sides'):", "",
                  "| lag (s) | activity | loading | impact | score | exchanged / labelled |", "|---:|---:|---:|---:|---:|---:|"]
        for f in alignment.window_fits[:4]:
            c = f.labelled
            activity = f"{c.activity:.3f}" + ("" if c.use_activity else " (not scored)")
            exchanged = f"{f.sides_ratio:.3f}" if np.isfinite(f.sides_ratio) else "–"
            lines.append(f"| {c.lag_s:+.2f} | {activity} | {c.loading:.3f} | {c.impact:.3f} | {c.score:.3f} | {exchanged} |")
        lines += ["", "Pairs: " + "; ".join(f"{k}: {_cell(v)}" for k, v in alignment.pairs.items()), ""]
        lines += [f"- {n}" for n in alignment.notes] + ([""] if alignment.notes else [])
    all_notes = list(cal.notes) + list(notes or [])
    if all_notes:
        lines += ["## Notes", ""] + [f"- {n}" for n in all_notes] + [""]
    return "\n".join(lines)


def plot_calibration(path: str | Path, title: str, calibration: Calibration, projected: dict[str, np.ndarray],
                     raw_gyr: dict[str, np.ndarray], seconds: float = 6.0) -> Path:
    """A figure, one row per sensor, of ``seconds`` of walking: the calibrated ``gyr_z`` with the
    out-of-plane rate norm (left) and ``acc_x``, ``acc_y`` (right). ``projected``: segment → (n, 3);
    ``raw_gyr``: segment → (n, 3) in the sensor frame."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cal = calibration
    start = cal.standing[1] + int(2 * cal.rate_hz) if cal.standing else int(2 * cal.rate_hz)
    n = len(next(iter(projected.values())))
    start = min(start, max(0, n - int(seconds * cal.rate_hz)))
    window = slice(start, min(n, start + int(seconds * cal.rate_hz)))
    t = np.arange(n)[window] / cal.rate_hz
    segs = list(cal.sensors)
    fig, axes = plt.subplots(len(segs), 2, figsize=(11, 1.7 * len(segs) + 0.8), sharex=True, squeeze=False)
    for row, seg in enumerate(segs):
        c = cal.sensors[seg]
        g = raw_gyr[seg][window] - c.gyro_bias
        out = np.linalg.norm(g - np.outer(g @ c.axis, c.axis), axis=1)
        ax = axes[row, 0]
        ax.plot(t, projected[seg][window, 2], lw=1, label="gyr_z")
        ax.plot(t, out, lw=1, color="0.6", label="out-of-plane |ω|")
        ax.set_ylabel(f"{seg}\nrad/s", fontsize=8)
        ax.text(0.01, 0.95, f"{c.sensor}: out-of-plane {c.out_of_plane_fraction:.0%}, φ {c.angle_deg:+.1f}°",
                transform=ax.transAxes, fontsize=7, va="top")
        ax = axes[row, 1]
        ax.plot(t, projected[seg][window, 0], lw=1, label="acc_x")
        ax.plot(t, projected[seg][window, 1], lw=1, label="acc_y")
        ax.set_ylabel("m/s²", fontsize=8)
        if row == 0:
            axes[0, 0].legend(fontsize=7, loc="upper right")
            axes[0, 1].legend(fontsize=7, loc="upper right")
    for ax in axes[-1]:
        ax.set_xlabel("time (s)")
    fig.suptitle(f"calibrated sagittal signals: {title}", fontsize=10)
    return save_figure(fig, path)
