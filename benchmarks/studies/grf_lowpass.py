"""The estimated GRF smoothed offline, against the labels, and how fast the labelled forces change.

For every recording of one split of a labelled dataset (a synthetic one, or real recordings imported
with ``sspinn import``): the model's GRF error (GRFE, %BW, both feet, horizontal and vertical) and
heel-strike timing (ms, :func:`sspinn.estimator.evaluation.heel_strike_timing`) as estimated and
after a zero-phase low-pass at each ``--cutoffs`` frequency (second-order Butterworth, forwards and
backwards with the double pass's −3 dB point at the cut-off,
:func:`benchmarks.accuracy.inverse_dynamics.lowpass`: offline only; the same filter as
``bench_cmu_continuous.py --grf-lowpass``), and the share
of the labels' vertical GRF RMS above each cut-off (Welch spectrum, the mean left out): how much of
the force a low-pass would take away from the truth itself; the same share of the pelvis sensor's
specific force, and at each cut-off its coherence with the total vertical force (:func:`pelvis_coherence`): whether what the sensors
carry at that frequency is the force's. Means per gait (a synthetic recording's
program name, else the last part of the recording's name, e.g. the CMU condition).

Why: on the real CMU treadmill trials a low-pass lowers the GRF error of every arm, on the synthetic
test subjects it raises it (docs/results/cmu_treadmill.md, "Offline smoothing of the estimated GRF").

Usage: ``python -m benchmarks.studies.grf_lowpass --data data/synth_default --model results/demo/run/model.pt
[--split test] [--cutoffs 20 10 6] [--skip 100]``. Under a minute on the default dataset; no timing.
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

import numpy as np
from scipy.signal import coherence, welch

from benchmarks.accuracy.inverse_dynamics import highest_cutoff, lowpass
from sspinn.data.dataset import SAMPLE_RATE_HZ, Recording
from sspinn.data.loading import labelled_recordings
from sspinn.errors import UserError
from sspinn.estimator.evaluation import compute_metrics
from sspinn.estimator.sspinnpose import SSPINNpose
from sspinn.estimator.trivial_predictors import program_of

REPO = Path(__file__).resolve().parents[2]


def rms_share_above(signals: np.ndarray, cutoff_hz: float) -> float:
    """Share of the RMS of ``signals`` ((T,) or (T, k), summed over the columns; the mean left out:
    Welch) above ``cutoff_hz``."""
    freq, power = welch(signals, fs=SAMPLE_RATE_HZ, nperseg=min(256, len(signals)), axis=0)
    power = power.reshape(len(freq), -1).sum(axis=1)
    return float(np.sqrt(power[freq > cutoff_hz].sum() / power[freq > 0].sum()))


def share_above(rec: Recording, cutoff_hz: float) -> float:
    """Share of the RMS of ``rec``'s labelled vertical GRF (the feet whose force is finite and not
    constant) above ``cutoff_hz``; NaN when no foot has such a force."""
    assert rec.labels is not None and rec.labels.grf is not None
    vertical = rec.labels.grf[:, [1, 3]]
    vertical = vertical[:, [k for k in range(2) if np.isfinite(vertical[:, k]).all() and np.ptp(vertical[:, k]) > 0]]
    return rms_share_above(vertical, cutoff_hz) if vertical.shape[1] else float("nan")


def pelvis_force(rec: Recording) -> tuple[np.ndarray, np.ndarray] | None:
    """The magnitude of the pelvis sensor's in-plane specific force (T,) and ``rec``'s labelled
    total vertical GRF (T,), or None without a pelvis sensor or with a non-finite force."""
    assert rec.labels is not None and rec.labels.grf is not None
    total = rec.labels.grf[:, [1, 3]].sum(axis=1)
    if "pelvis" not in rec.segments or not np.isfinite(total).all():
        return None
    return np.linalg.norm(rec.imu[:, rec.segments.index("pelvis"), :2], axis=1), total


def pelvis_coherence(both: tuple[np.ndarray, np.ndarray] | None, freqs_hz: list[float]) -> list[float]:
    """Magnitude-squared coherence (Welch) at each of ``freqs_hz`` between the two signals of
    :func:`pelvis_force` (``both``): near 1 where the sensor's content at that frequency is the
    force's (the pelvis moves with the centre of mass, whose acceleration is the total force over
    the mass), low where the sensor carries something else (its own wobble, noise). NaN without
    them (``both`` None)."""
    if both is None:
        return [float("nan")] * len(freqs_hz)
    freq, coh = coherence(*both, fs=SAMPLE_RATE_HZ, nperseg=min(256, len(both[1])))
    return [float(coh[np.argmin(abs(freq - f))]) for f in freqs_hz]


def _mean(values: list[list[float]]) -> np.ndarray:
    """Column means over the recordings, NaN where none has a finite value."""
    v = np.array(values, dtype=float)
    return np.array([c[np.isfinite(c)].mean() if np.isfinite(c).any() else np.nan for c in v.T])


def main(argv: list[str] | None = None) -> dict[str, dict[str, list[float]]]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=REPO / "data" / "synth_default")
    parser.add_argument("--model", type=Path, default=REPO / "results" / "demo" / "run" / "model.pt")
    parser.add_argument("--split", default="test")
    parser.add_argument("--cutoffs", nargs="+", type=float, default=[20.0, 10.0, 6.0])
    parser.add_argument("--skip", type=int, default=100, help="samples of warm-up left out (1 s)")
    args = parser.parse_args(argv)
    highest = highest_cutoff(SAMPLE_RATE_HZ)
    bad = [f for f in args.cutoffs if not 0 < f < highest]
    if bad:
        parser.error(f"--cutoffs {bad[0]:g}: a cut-off must lie between 0 and {highest:g} Hz (the double pass's −3 dB point)")
    try:  # a missing or unreadable folder or model file: one line
        recordings, estimator = labelled_recordings(args.data, args.split, "grf"), SSPINNpose.load(args.model)
    except UserError as exc:
        parser.error(str(exc))
    rows: dict[str, dict[str, list[list[float]]]] = {}
    for rec in recordings:
        estimate = estimator.predict(rec)
        row = rows.setdefault(program_of(rec, from_name=True), {"grfe": [], "hs": [], "share": [], "pelvis_share": [], "coherence": []})
        arms = [estimate] + [dataclasses.replace(estimate, grf=lowpass(estimate.grf, SAMPLE_RATE_HZ, f)) for f in args.cutoffs]
        metrics = [compute_metrics(e, rec, args.skip, physics=False) for e in arms]
        row["grfe"].append([m.grfe_pct_bw for m in metrics])
        row["hs"].append([m.hs_timing_ms for m in metrics])
        row["share"].append([share_above(rec, f) for f in args.cutoffs])
        both = pelvis_force(rec)
        row["pelvis_share"].append([float("nan") if both is None else rms_share_above(both[0], f) for f in args.cutoffs])
        row["coherence"].append(pelvis_coherence(both, args.cutoffs))
    cut = " / ".join(f"{f:g}" for f in args.cutoffs)
    print(f"{args.model} on {args.data} ({args.split}); GRF low-passed offline at {cut} Hz\n")
    print(f"| gait | recordings | GRFE %BW: estimated, then at {cut} Hz | heel strike ms: the same | labels' vertical GRF RMS above {cut} Hz "
          f"| the pelvis sensor's RMS above them | its coherence with the total vertical GRF at {cut} Hz |")
    print("|---|---:|---|---|---|---|---|")
    out = {}
    for gait, row in sorted(rows.items()):
        grfe, hs, share, pelvis, coh = (_mean(row[k]) for k in ("grfe", "hs", "share", "pelvis_share", "coherence"))
        out[gait] = {"grfe": grfe.tolist(), "hs_ms": hs.tolist(), "share_above": share.tolist(),
                     "pelvis_share_above": pelvis.tolist(), "pelvis_coherence": coh.tolist()}
        print(f"| {gait} | {len(row['grfe'])} | " + " / ".join(f"{v:.2f}" for v in grfe) + " | " + " / ".join(f"{v:.0f}" for v in hs)
              + "".join(" | " + " / ".join("n/a" if np.isnan(v) else f"{100 * v:.1f} %" for v in shares) for shares in (share, pelvis))
              + " | " + " / ".join("n/a" if np.isnan(v) else f"{v:.2f}" for v in coh) + " |")
    return out


if __name__ == "__main__":
    main()
