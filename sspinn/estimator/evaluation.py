"""Evaluation of estimates against labels: SSPINNpose's metrics and a report with plots.

Metrics (computed over the label columns that are available):

* **JAE** — RMSD of the joint angles incl. pelvis tilt, degrees (pooled over angles and samples);
* **JTE** — RMSD of the joint torques, %BW·BH (body weight × body height);
* **GRFE** — RMSE of the ground reaction forces (horizontal and vertical, both feet), %BW;
* **speed error** — |mean estimated − mean true horizontal speed|, m/s (over the recording);
* **speed tracking** — RMS over consecutive :data:`SPEED_WINDOW_S` windows of (mean estimated −
  mean true horizontal speed), m/s: whether the estimate follows the speed changes of a
  recording (the synthetic programs walk at 0.9, 1.3 and 1.8 m/s in one recording, so every
  recording has the same mean and the mean speed of the training subjects is a near-oracle for
  the speed error above, but not for this one); NaN for a recording shorter than one window;
* **jitter** — mean |d³θ/dt³| of the estimated joint angles, rad/s³ (smoothness; lower is smoother);
* **heel-strike timing** — mean |Δt| between the heel strikes of the estimated and the measured
  vertical GRF of each foot (:mod:`sspinn.data.gait_events`; its 10 % BW threshold on both; events more
  than 0.3 s apart count as missed), ms, and the share of measured heel strikes matched;
* **Kane residual** — RMS of the estimate's own equations-of-motion residual
  (:meth:`sspinn.model.trajectory.Trajectory.kane_residual` with the assumed body: BW for the two
  translational rows, BW·BH for the rotational ones), pooled over rows and samples: how far the
  estimate is from being physically consistent (needs no labels).

Metrics are only ever computed on recordings the model was not trained on, except for the
paper's "averaged" protocol, which by design trains and evaluates on the same unlabelled stride
(and is reported as such).
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import asdict, dataclass, fields
from pathlib import Path
from typing import TYPE_CHECKING, Any, Final

import numpy as np

from sspinn.data.dataset import SAMPLE_RATE_HZ, Labels, Recording
from sspinn.data.gait_events import detect_events, grf_event_timing, normalise_cycles, strides
from sspinn.errors import InputWarning, UserError
from sspinn.estimator.inference import GaitEstimate
from sspinn.model.body import BodyParameters
from sspinn.model.conventions import COORDINATES, GRAVITY, GRF, JOINTS
from sspinn.run_folder import atomic_write_text

if TYPE_CHECKING:
    from sspinn.estimator.sspinnpose import SSPINNpose
    from sspinn.estimator.trivial_predictors import TrivialPredictor
    from sspinn.estimator.uncertainty import UncertaintyCalibration

ANGLES = ("pelvis_tilt", *JOINTS)


class EvaluationError(UserError):
    """The recordings cannot be evaluated as asked (no labels, nothing left after ``skip``)."""


@dataclass
class Metrics:
    """Metrics of one or more estimates (module docstring; units in the names)."""

    jae_deg: float
    jte_pct_bwbh: float
    grfe_pct_bw: float
    speed_error_mps: float
    jitter: float
    n_samples: int
    kane_residual: float = float("nan")
    speed_tracking_mps: float = float("nan")
    hs_timing_ms: float = float("nan")
    hs_matched: float = float("nan")

    def as_dict(self) -> dict[str, float]:
        return asdict(self)



def angle_jitter(angles: np.ndarray, rate_hz: float) -> float:
    """Mean |d³θ/dt³| (rad/s³) of angle time series (T, …) sampled at ``rate_hz``, by third
    differences; NaN for fewer than 4 samples."""
    angles = np.asarray(angles, dtype=float)
    if len(angles) <= 3:
        return float("nan")
    return float(np.mean(np.abs(np.diff(angles, n=3, axis=0)))) * rate_hz**3


#: Window of the speed-tracking metric, s.
SPEED_WINDOW_S = 2.0


def speed_tracking_error(est_speed: np.ndarray, true_speed: np.ndarray, rate_hz: float, window_s: float = SPEED_WINDOW_S) -> float:
    """RMS over consecutive whole ``window_s`` windows of (mean ``est_speed`` − mean
    ``true_speed``), m/s; NaN when not even one window fits."""
    n = int(round(window_s * rate_hz))
    k = len(true_speed) // n
    if k == 0:
        return float("nan")
    diff = np.asarray(est_speed[: k * n], float).reshape(k, n).mean(1) - np.asarray(true_speed[: k * n], float).reshape(k, n).mean(1)
    return float(np.sqrt(np.mean(diff**2)))


def _pooled_rmse(est: np.ndarray, ref: np.ndarray) -> float:
    if est.size == 0:
        return float("nan")
    return float(np.sqrt(np.mean((est - ref) ** 2)))


def compute_metrics(est: GaitEstimate, rec: Recording, skip: int = 0, physics: bool = True) -> Metrics:
    """Metrics of one estimate against its recording's labels, ignoring the first ``skip``
    samples (the LSTM's warm-up); ``physics=False`` leaves the Kane residual out (NaN), e.g. for
    a trivial predictor, which is no motion."""
    if rec.labels is None:
        raise EvaluationError(f"{rec.name}: no labels to evaluate against (use `sspinn infer` for recordings without labels)")
    lab = rec.labels
    sl = slice(skip, None)
    have = set(lab.columns())
    ang = [c for c in ANGLES if c in have]
    jae = np.degrees(_pooled_rmse(est.q[sl][:, [COORDINATES.index(c) for c in ang]], np.stack([lab.column(c)[sl] for c in ang], -1))) if ang else float("nan")
    tq = [j for j in JOINTS if f"tau_{j}" in have]
    bwbh = rec.mass * GRAVITY * rec.height
    jte = 100 * _pooled_rmse(est.tau[sl][:, [JOINTS.index(j) for j in tq]], np.stack([lab.column(f"tau_{j}")[sl] for j in tq], -1)) / bwbh if tq else float("nan")
    gr = [g for g in GRF if g in have]
    bw = rec.mass * GRAVITY
    grfe = 100 * _pooled_rmse(est.grf[sl][:, [GRF.index(g) for g in gr]], np.stack([lab.column(g)[sl] for g in gr], -1)) / bw if gr else float("nan")
    speed = tracking = float("nan")
    if "speed" in have:
        true_speed = lab.column("speed")[sl]
        speed = abs(float(np.mean(est.u[sl, 0])) - float(np.mean(true_speed)))
        tracking = speed_tracking_error(est.u[sl, 0], true_speed, SAMPLE_RATE_HZ)
    angles = est.q[sl][:, 2:]
    jitter = angle_jitter(angles, SAMPLE_RATE_HZ)
    residual = est.kane_residual(BodyParameters.from_anthropometry(rec.height, rec.mass))[sl] if physics else np.empty(0)
    hs_ms, hs_matched = heel_strike_timing(est.grf[sl], lab, sl, bw)
    return Metrics(jae_deg=float(jae), jte_pct_bwbh=float(jte), grfe_pct_bw=float(grfe), speed_error_mps=speed, jitter=jitter,
                   n_samples=len(est.time[sl]), kane_residual=float(np.sqrt(np.mean(residual**2))) if residual.size else float("nan"),
                   hs_timing_ms=hs_ms, hs_matched=hs_matched, speed_tracking_mps=tracking)


#: Largest |Δt| of an estimated heel strike still matched to a measured one, s.
HS_WINDOW_S = 0.3


def heel_strike_timing(grf: np.ndarray, labels: Labels, sl: slice, body_weight: float) -> tuple[float, float]:
    """(mean |Δt| in ms, share of measured heel strikes matched) of the estimated GRF (T, 4)
    against the labels' vertical GRF of each foot that has one (NaN, NaN without)."""
    if labels.grf is None:
        return float("nan"), float("nan")
    t = grf_event_timing(grf, labels.grf[sl], body_weight, SAMPLE_RATE_HZ, "heel_strikes", HS_WINDOW_S)
    return (t.mean_abs_ms, t.matched / t.n_reference) if t.n_reference else (float("nan"), float("nan"))


def mean_metrics(items: list[Metrics]) -> Metrics:
    """Sample-weighted mean of per-recording metrics (NaN-aware)."""
    w = np.array([m.n_samples for m in items], dtype=float)
    out = {}
    for key in (f.name for f in fields(Metrics) if f.name != "n_samples"):
        v = np.array([getattr(m, key) for m in items])
        ok = np.isfinite(v)
        out[key] = float(np.sum(v[ok] * w[ok]) / np.sum(w[ok])) if ok.any() else float("nan")
    return Metrics(**out, n_samples=int(w.sum()))


# ------------------------------------------------------------------------------ report
#: Metric → name of the trivial predictor it is compared with (:mod:`sspinn.estimator.trivial_predictors`).
BASELINE_OF: dict[str, str] = {
    "jae_deg": "mean posture",
    "jte_pct_bwbh": "zero torque",
    "grfe_pct_bw": "constant mean GRF",
    "speed_error_mps": "mean speed",
    "speed_tracking_mps": "mean speed",
}
#: Metrics also compared with the Froude speed (the training data's mean Froude number at the
#: evaluated subject's leg length; :meth:`~sspinn.estimator.trivial_predictors.TrivialPredictor.speed_for`).
FROUDE_METRICS: tuple[str, ...] = ("speed_error_mps", "speed_tracking_mps")
_LABELS = {"jae_deg": "JAE (deg)", "jte_pct_bwbh": "JTE (%BW·BH)", "grfe_pct_bw": "GRFE (%BW)", "speed_error_mps": "speed error (m/s)",
           "speed_tracking_mps": f"speed tracking, {SPEED_WINDOW_S:g}-s means (m/s)"}


def compare_with_baseline(
    estimates: list[GaitEstimate], recordings: list[Recording], baseline: TrivialPredictor, skip: int = 0
) -> dict[str, dict]:
    """Per gait program (and pooled as "all" when there are several): the sample-weighted mean
    metrics of the estimates (``model``) and of the trivial predictor on the same recordings
    (``baseline``), the metrics on which the estimate is **worse** than the baseline
    (``worse_than_baseline``), and the speed metrics of the Froude speed (``froude``, m/s; the
    metrics :data:`FROUDE_METRICS`) with those on which the estimate is worse than it
    (``worse_than_froude``)."""
    from sspinn.estimator.trivial_predictors import program_of

    groups: dict[str, list[tuple[Metrics, Metrics, Metrics]]] = {}
    for est, rec in zip(estimates, recordings):
        triple = (compute_metrics(est, rec, skip), compute_metrics(baseline.predict(rec), rec, skip, physics=False),
                  compute_metrics(baseline.predict(rec, speed="froude"), rec, skip, physics=False))
        groups.setdefault(program_of(rec), []).append(triple)
    if len(groups) > 1:
        groups["all"] = [triple for triples in list(groups.values()) for triple in triples]

    def worse(model: dict[str, float], base: dict[str, float], keys: tuple[str, ...]) -> list[str]:
        return [k for k in keys if np.isfinite(model[k]) and np.isfinite(base[k]) and model[k] >= base[k]]

    out = {}
    for program, triples in groups.items():
        model = mean_metrics([m for m, _, _ in triples]).as_dict()
        base = mean_metrics([b for _, b, _ in triples]).as_dict()
        froude = {k: v for k, v in mean_metrics([f for _, _, f in triples]).as_dict().items() if k in FROUDE_METRICS}
        out[program] = {"recordings": len(triples), "model": model, "baseline": base,
                        "worse_than_baseline": worse(model, base, tuple(BASELINE_OF)),
                        "froude": froude, "worse_than_froude": worse(model, froude, FROUDE_METRICS)}
    return out


#: Most negative vertical GRF label (BW) taken as force-plate noise rather than a sign or unit error.
NEGATIVE_GRF_TOLERANCE_BW = 0.1


def check_evaluable(estimates: list[GaitEstimate], recordings: list[Recording], skip: int) -> None:
    """Raise :class:`EvaluationError` (or NonFiniteEstimateError) unless every estimate is finite
    and every recording has labels, samples left after ``skip`` and no vertical GRF label below
    −:data:`NEGATIVE_GRF_TOLERANCE_BW` (a negated or mis-scaled force channel)."""
    for est in estimates:
        est.check_finite()
    for rec in recordings:
        if rec.labels is None:
            raise EvaluationError(f"{rec.name}: no labels to evaluate against (use `sspinn infer` for recordings without labels)")
        if not 0 <= skip < rec.n_samples:
            raise EvaluationError(f"{rec.name}: --skip {skip} leaves no samples of its {rec.n_samples} to evaluate")
        grf = rec.labels.grf
        if grf is not None:
            body_weight = rec.mass * GRAVITY
            low = float(np.nanmin(grf[:, [1, 3]])) / body_weight
            if low < -NEGATIVE_GRF_TOLERANCE_BW:
                raise EvaluationError(
                    f"{rec.name}: its vertical GRF labels reach {low:.2f} BW; the ground only pushes (allowed noise "
                    f"−{NEGATIVE_GRF_TOLERANCE_BW:g} BW): check the force sign, the units and the body mass"
                )


def baseline_lines(comparison: dict[str, dict], source: str) -> list[str]:
    """Markdown tables of :func:`compare_with_baseline`, one per program: every metric against
    its trivial predictor, then the speed metrics against the Froude speed."""
    lines = ["", f"## Against the trivial predictors ({source})", ""]
    for program, c in comparison.items():
        lines += [f"### {program} ({c['recordings']} recording(s))", "", "| metric | estimate | trivial predictor | ratio | verdict |", "|---|---|---|---|---|"]
        rows = [(k, name, c["baseline"], c["worse_than_baseline"]) for k, name in BASELINE_OF.items()]
        rows += [(k, "Froude speed", c["froude"], c["worse_than_froude"]) for k in FROUDE_METRICS if "froude" in c]
        for k, name, base, worse in rows:
            m, b = c["model"][k], base[k]
            ratio = m / b if np.isfinite(m) and np.isfinite(b) and b > 0 else float("nan")
            verdict = "**WORSE than the baseline**" if k in worse else ("beats it" if np.isfinite(ratio) else "–")
            lines.append(f"| {_LABELS[k]} | {_cell(m, '.3g')} | {_cell(b, '.3g')} ({name}) | {_cell(ratio, '.2f')} | {verdict} |")
        lines.append("")
    lines += ["Froude speed: sqrt(Fr · g · L), Fr the same data's mean Froude number of the program, L the evaluated "
              "subject's leg length (the standing hip height of the body scaled from the height).", ""]
    return lines


def write_report(
    estimates: list[GaitEstimate],
    recordings: list[Recording],
    out: Path,
    title: str,
    skip: int = 0,
    extra: dict | None = None,
    baseline: TrivialPredictor | None = None,
    intervals: Sequence[np.ndarray] | None = None,
    level: float = 0.9,
) -> dict:
    """Metrics table (Markdown + JSON) and PNG plots (stick figures over time, gait-cycle
    normalised angles/torques/GRFs vs reference) for each recording; with ``baseline``, the
    metrics of the trivial predictors on the same recordings per gait program
    (:func:`compare_with_baseline`); with ``intervals`` (per recording, (T, n_channels) half-widths
    of the ``level`` intervals of :mod:`sspinn.estimator.uncertainty`), their coverage of the
    labels per program and the intervals as bands in the plots. Returns the metrics."""
    import json

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from sspinn.model.drawing import draw_stick_figure, save_figure

    check_evaluable(estimates, recordings, skip)  # everything is checked before anything is written
    per = {e.name: compute_metrics(e, r, skip) for e, r in zip(estimates, recordings)}
    mean = mean_metrics(list(per.values()))
    comparison = compare_with_baseline(estimates, recordings, baseline, skip) if baseline is not None else None
    out.mkdir(parents=True, exist_ok=True)
    lines = [f"# {title}", "", "| recording | JAE (deg) | JTE (%BW·BH) | GRFE (%BW) | speed error (m/s) | "
             f"speed tracking ({SPEED_WINDOW_S:g}-s means, m/s) | heel strike (ms, matched) | jitter (rad/s³) | Kane residual (RMS) |",
             "|---|---|---|---|---|---|---|---|---|"]
    for name, m in [*per.items(), ("**mean**", mean)]:
        cells = [_cell(v, f) for v, f in ((m.jae_deg, ".2f"), (m.jte_pct_bwbh, ".2f"), (m.grfe_pct_bw, ".2f"),
                                          (m.speed_error_mps, ".3f"), (m.speed_tracking_mps, ".3f"))]
        cells.append(f"{_cell(m.hs_timing_ms, '.0f')} ({_cell(100 * m.hs_matched, '.0f')} %)")
        cells += [_cell(m.jitter, ".0f"), _cell(m.kane_residual, ".3f")]
        lines.append(f"| {name} | {' | '.join(cells)} |")
    if comparison is not None:
        assert baseline is not None
        lines += baseline_lines(comparison, baseline.source)
    covered = half = None
    if intervals is not None:
        from sspinn.estimator.trivial_predictors import program_of
        from sspinn.estimator.uncertainty import CHANNELS, HALF_WIDTH_UNITS, coverage, median_half_widths

        channel_names = list(CHANNELS)
        programs = [program_of(r) for r in recordings]
        covered = coverage(estimates, recordings, intervals, programs, skip)
        half = median_half_widths(recordings, intervals, programs, skip)
        lines += ["", f"## Coverage of the {100 * level:.0f} % intervals (fraction of labelled samples inside)", "",
                  "| program | " + " | ".join(next(iter(covered.values()))) + " |", "|---|" + "---|" * len(next(iter(covered.values())))]
        lines += [f"| {p} | " + " | ".join(_cell(100 * v, ".1f") + " %" for v in c.values()) + " |" for p, c in covered.items()]
        lines += ["", "Median half-width of the intervals:", "",
                  "| program | " + " | ".join(f"{g} ({HALF_WIDTH_UNITS[g]})" for g in HALF_WIDTH_UNITS) + " |",
                  "|---|" + "---|" * len(HALF_WIDTH_UNITS)]
        lines += [f"| {p} | " + " | ".join(_cell(v, ".3g") for v in h.values()) + " |" for p, h in half.items()]
    for index, (est, rec) in enumerate(zip(estimates, recordings)):
        body = BodyParameters.from_anthropometry(rec.height, rec.mass)
        fig, axes = plt.subplots(2, 3, figsize=(14, 7))
        ax = axes[0, 0]
        for i, k in enumerate(np.linspace(skip, len(est.time) - 1, 8).astype(int)):
            q = est.q[k].copy()
            q[0] = 0.6 * i
            draw_stick_figure(ax, q, body, grf=est.grf[k])
        ax.set_aspect("equal")
        ax.axhline(0, color="0.6")
        ax.set_title("estimated poses (spread out in x) with GRF")
        lab = rec.labels
        grf_ref = lab.column("grf_y_r") if lab is not None and "grf_y_r" in lab.columns() else est.grf[:, 1]
        # heel strikes as raw upward crossings of the contact threshold (no minimum phase: the reference is clean)
        heel_strikes = detect_events(grf_ref[skip:], rec.mass * GRAVITY, SAMPLE_RATE_HZ, min_phase_s=0.0).heel_strikes
        cycles = [(a + skip, b + skip) for a, b in strides(heel_strikes, SAMPLE_RATE_HZ)]
        panels = [("hip_r", "angle"), ("knee_r", "angle"), ("ankle_r", "angle"), ("tau_knee_r", "torque"), ("grf_y_r", "grf")]
        for ax, (col, kind) in zip(axes.flat[1:], panels):
            if kind == "angle":
                e, scale, unit = est.q[:, COORDINATES.index(col)], 180 / np.pi, "deg"
            elif kind == "torque":
                e, scale, unit = est.tau[:, JOINTS.index(col[4:])], 1.0, "N·m"
            else:
                e, scale, unit = est.grf[:, GRF.index(col)], 1 / (rec.mass * GRAVITY), "BW"
            x = np.linspace(0, 100, 101)
            band = intervals[index][:, channel_names.index(col)] if intervals is not None else None
            if cycles:
                ec = normalise_cycles(e, cycles) * scale
                ax.plot(x, ec.mean(0), color="tab:blue", label="sspinn")
                if band is None:  # the spread over cycles
                    ax.fill_between(x, ec.mean(0) - ec.std(0), ec.mean(0) + ec.std(0), color="tab:blue", alpha=0.2)
                else:  # the mean interval over cycles
                    hw = normalise_cycles(band, cycles).mean(0) * scale
                    ax.fill_between(x, ec.mean(0) - hw, ec.mean(0) + hw, color="tab:blue", alpha=0.2,
                                    label=f"{100 * level:.0f} % interval")
                if lab is not None and col in lab.columns():
                    rc = normalise_cycles(lab.column(col), cycles) * scale
                    ax.plot(x, rc.mean(0), color="k", ls="--", label="reference")
                ax.set_xlabel("% gait cycle")
            else:
                ax.plot(est.time, e * scale, color="tab:blue", label="sspinn")
                if band is not None:
                    ax.fill_between(est.time, (e - band) * scale, (e + band) * scale, color="tab:blue", alpha=0.2,
                                    label=f"{100 * level:.0f} % interval")
                if lab is not None and col in lab.columns():
                    ax.plot(est.time, lab.column(col) * scale, color="k", ls="--", label="reference")
                ax.set_xlabel("time (s)")
            ax.set_title(f"{col} ({unit})")
            ax.legend(fontsize=8)
        fig.suptitle(f"{title}: {est.name}")
        save_figure(fig, out / f"{est.name}.png", dpi=90)
        lines.append(f"\n![{est.name}]({est.name}.png)")
    atomic_write_text(out / "report.md", "\n".join(lines) + "\n")
    result = {"title": title, "mean": mean.as_dict(), "recordings": {k: v.as_dict() for k, v in per.items()}, **(extra or {})}
    if covered is not None:
        result["interval_coverage"] = {"level": level, "by_program": covered, "median_half_width": half,
                                       "half_width_units": HALF_WIDTH_UNITS}
    if comparison is not None:
        assert baseline is not None
        result["baseline_source"] = baseline.source
        result["by_program"] = comparison
    # a metric without the labels it needs is NaN: written as null (valid JSON), never as NaN
    atomic_write_text(out / "metrics.json", json.dumps(finite_or_null(result), indent=2, allow_nan=False))
    return result


def _cell(value: float, fmt: str) -> str:
    return format(value, fmt) if np.isfinite(value) else "n/a"


def finite_or_null(value: Any) -> Any:
    """``value`` with every non-finite float replaced by None (JSON null), recursively."""
    if isinstance(value, dict):
        return {k: finite_or_null(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [finite_or_null(v) for v in value]
    if isinstance(value, float) and not np.isfinite(value):
        return None
    return value


#: Spans of an imported recording whose labels do not measure a sagittal estimate (written by
#: ``sspinn import``): turns, and jumps of the lag between the IMU and GRF files.
UNRELIABLE_SPANS: Final = {"turning_s": "turning (a sagittal model does not describe a turn)",
                           "grf_misaligned_s": "GRF labels off in time (a jump of the lag between the files)"}


def unreliable_label_findings(recordings: list[Recording]) -> list[str]:
    """One line per recording with spans of :data:`UNRELIABLE_SPANS`, naming them in the
    recording's own times and what to do: the metrics include them."""
    lines = []
    for rec in recordings:
        parts = [f"{what} at {a:.1f}–{b:.1f} s" for key, what in UNRELIABLE_SPANS.items() for a, b, _ in rec.provenance_spans(key)]
        if parts:
            lines.append(f"{rec.name}: {'; '.join(parts)}: its metrics include these samples; crop them away "
                         "(`sspinn import --start/--end`) for figures of the gait alone")
    return lines


def evaluate(
    estimator: SSPINNpose,
    recordings: list[Recording],
    out: str | Path,
    *,
    reference: list[Recording] | None = None,
    reference_where: str = "the dataset",
    title: str | None = None,
    skip: int = 50,
    uncertainty: UncertaintyCalibration | None = None,
) -> dict:
    """Estimate every recording, score the estimates against the labels and write the report
    (``report.md``, ``metrics.json``, one PNG per recording) to ``out``; returns the metrics.
    With an ``uncertainty`` calibration, the report adds the intervals' coverage and bands.

    The rules of a fair report live here: every estimate is checked before anything is written;
    the trivial predictors are those the model file stores, fitted on the labels of the model's
    own training data; a model file without them (older, or trained on unlabelled recordings)
    says so in a ``NOTE:`` line, and they are fitted on ``reference`` (the labelled training
    split found at ``reference_where``, a folder named in the report), else on the evaluated
    recordings, an oracle the report names as such
    (:func:`~sspinn.estimator.trivial_predictors.reference_predictor`); recordings whose IMU
    signals the model's training saw are named in the title and in a ``NOTE:`` line."""
    out = Path(out)
    title = title or f"{estimator.path_} on {len(recordings)} recording(s)"
    seen = [r.name for r in recordings if r.name in estimator.trained_on_]
    if seen:  # transductive: say so wherever the figures go
        note = (f"the model's self-supervised training saw the IMU signals (never the labels) of {len(seen)} of "
                f"these {len(recordings)} recordings: {', '.join(seen)}")
        title += f" — {note}"
        print(f"NOTE: {note}")
    estimates = [estimator.predict(r) for r in recordings]
    check_evaluable(estimates, recordings, skip)
    for text in unreliable_label_findings(recordings):
        warnings.warn(text, InputWarning, stacklevel=2)
    from sspinn.estimator.trivial_predictors import reference_predictor

    stored = estimator.baselines_
    baseline = reference_predictor(recordings, reference, reference_where, stored)
    if stored is None:
        print(f"NOTE: {estimator.path_} stores no trivial predictors of its training data (a file from before they were "
              f"stored, or a model trained on unlabelled recordings); compared instead with: {baseline.source}")
    widths = None
    if uncertainty is not None:
        from sspinn.estimator.uncertainty import intervals

        widths = [intervals(uncertainty, estimator.network_, estimator.segments_, r) for r in recordings]
    return write_report(estimates, recordings, out, title=title, skip=skip, baseline=baseline,
                        extra={"baselines_stored_in_model": stored is not None}, intervals=widths,
                        level=uncertainty.level if uncertainty is not None else 0.9)
