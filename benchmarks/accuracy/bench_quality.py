"""Does the per-window quality score know when an estimate is wrong? Held-out synthetic subjects
and real treadmill trials.

1. **Calibrate** (:func:`sspinn.estimator.quality.calibrate`, what ``sspinn calibrate-quality``
   does) on the ``--calibrate-on`` splits of a labelled dataset (default: ``train``), writing
   ``<out>/quality.json``.
2. **Held-out subjects** (``--evaluate-on``, default ``test``; never used in step 1): per gait
   program (the recording name's ``walk``/``run``), the Spearman rank correlation of each
   window's score with its errors (joint-angle RMSE, GRF RMSE, their relative mean), pooled over
   the windows, and *within recordings* (score and error minus their recording's mean: whether
   the score finds a recording's bad windows, not only its bad subjects); the flag rate, the
   share of flagged windows whose error is large (above the calibration's 90th percentile;
   precision) against the share among all windows (what flagging at random gives), and the share
   of large errors flagged (recall).
3. **Real trials** (``--cmu-source``, skipped when absent): the CMU treadmill trials
   (``../shared/data/cmu_treadmill_imu_grf``, imported as in ``bench_cmu_continuous.py``, cached
   in ``<out>/cmu_data``): flag rate per trial and condition, the input-range warnings, and, as
   these trials have measured GRF, the Spearman correlation of the score with each window's GRF
   RMSE.

Usage: ``python -m benchmarks.accuracy.bench_quality --model results/demo/run/model.pt --data
data/synth_default [--out results/quality] [--cmu-source ../shared/data/cmu_treadmill_imu_grf]``.
Writes ``<out>/quality_report.json`` and prints the tables. No timing is measured.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import runpy
import sys
import warnings
from pathlib import Path

import numpy as np
import torch
from scipy.stats import spearmanr

from sspinn.data.dataset import Dataset, Recording
from sspinn.data.loading import dataset_recordings
from sspinn.estimator.quality import (
    ERROR_QUANTILE,
    QualityCalibration,
    WindowQuality,
    calibrate,
    input_findings,
    save_calibration,
    training_recordings,
    window_errors,
)
from sspinn.estimator.sspinnpose import SSPINNpose
from sspinn.model.conventions import GRAVITY

REPO = Path(__file__).resolve().parents[2]
SHARED = Path(os.environ.get("SSPINN_SHARED_DATA") or REPO.parent / "shared" / "data")


def program(name: str) -> str:
    """``walk``/``run`` from a synthetic recording's name, else the part after the subject."""
    for p in ("walk", "run"):
        if name.endswith(f"_{p}"):
            return p
    return name.split("_", 1)[-1]


def _rho(a: np.ndarray, b: np.ndarray) -> float:
    ok = np.isfinite(a) & np.isfinite(b)
    return float(spearmanr(a[ok], b[ok])[0]) if ok.sum() >= 3 else float("nan")


def _within(values: np.ndarray, groups: np.ndarray) -> np.ndarray:
    out = values.astype(float).copy()
    for g in np.unique(groups):
        out[groups == g] -= np.mean(values[groups == g])
    return out


def held_out(est: SSPINNpose, cal: QualityCalibration, recs: list[Recording]) -> dict:
    """Step 2 of the module docstring, per program."""
    rows = []
    for rec in recs:
        q = cal.apply(est.quality(rec))
        err = window_errors(est.predict(rec), rec, q.start, q.stop)
        rel = cal.relative_error(err)
        for w in range(q.n_windows):
            rows.append((program(rec.name), rec.name, q.score[w], bool(q.flagged[w]), err["jae_deg"][w], err["grfe_pct_bw"][w], rel[w],
                         {k: v[w] for k, v in q.terms.items()}))
    out = {}
    for prog in sorted({r[0] for r in rows}):
        sel = [r for r in rows if r[0] == prog]
        names = np.array([r[1] for r in sel])
        score, flagged = np.array([r[2] for r in sel]), np.array([r[3] for r in sel])
        jae, grfe, rel = (np.array([r[k] for r in sel]) for k in (4, 5, 6))
        large = rel > cal.error_threshold
        out[prog] = {
            "recordings": len(set(names)), "windows": len(sel),
            "spearman_relative_error": _rho(score, rel), "spearman_jae": _rho(score, jae), "spearman_grfe": _rho(score, grfe),
            "spearman_within_recordings": _rho(_within(score, names), _within(rel, names)),
            "spearman_relative_error_by_term": {k: _rho(np.array([r[7][k] for r in sel]), rel) for k in sel[0][7]},
            "flag_rate": float(flagged.mean()), "large_error_rate": float(large.mean()),
            "precision": float(large[flagged].mean()) if flagged.any() else float("nan"),
            "recall": float(flagged[large].mean()) if large.any() else float("nan"),
            "median_jae_deg": float(np.median(jae)), "median_grfe_pct_bw": float(np.median(grfe)),
            "median_jae_deg_flagged": float(np.median(jae[flagged])) if flagged.any() else float("nan"),
            "median_jae_deg_unflagged": float(np.median(jae[~flagged])) if (~flagged).any() else float("nan"),
        }
    return out


def corrupted(est: SSPINNpose, cal: QualityCalibration, recs: list[Recording]) -> dict:
    """Share of flagged windows and median score of the held-out recordings, clean and corrupted:
    white noise of 1 m/s² and 0.1 rad/s added to every channel (about half the synthetic
    recordings' own IMU errors, :class:`~sspinn.estimator.losses.IMUNoise`), and the right
    foot's gyroscope negated (a sensor mounted upside down)."""
    rng = np.random.default_rng(0)
    out = {}
    for kind in ("clean", "white noise", "foot_r gyro negated"):
        flags, scores = [], []
        for rec in recs:
            imu = rec.imu.copy()
            if kind == "white noise":
                imu += rng.normal(size=imu.shape) * np.array([1.0, 1.0, 0.1])
            elif kind == "foot_r gyro negated":
                imu[:, rec.segments.index("foot_r"), 2] *= -1
            q = cal.apply(est.quality(dataclasses.replace(rec, imu=imu)))
            flags.append(q.flagged)
            scores.append(q.score)
        out[kind] = {"flag_rate": float(np.concatenate(flags).mean()), "median_score": float(np.median(np.concatenate(scores)))}
    return out


def cmu(est: SSPINNpose, cal: QualityCalibration, source: Path, out: Path, model: str) -> dict:
    """Step 3 of the module docstring."""
    bench = runpy.run_path(str(REPO / "benchmarks" / "accuracy" / "bench_cmu_continuous.py"), run_name="bench_cmu_continuous")
    protocol = bench["Protocol"](source)
    data = out / "cmu_data"
    bench["import_trials"](protocol, data, protocol.train_subjects, protocol.test_subjects)
    dataset = Dataset.open(data)
    recs = dataset.load("train") + dataset.load("test")
    trials, scores, grf_errors = {}, [], []
    for rec in recs:
        q: WindowQuality = cal.apply(est.quality(rec))
        estimate = est.predict(rec)
        findings = input_findings(rec, q, cal, model)
        assert rec.labels is not None and rec.labels.grf is not None
        err = np.array([100 * float(np.sqrt(np.mean((estimate.grf[a:b] - rec.labels.grf[a:b]) ** 2))) / (rec.mass * GRAVITY)
                        for a, b in zip(q.start, q.stop)])
        scores.append(q.score)
        grf_errors.append(err)
        trials[rec.name] = {"windows": q.n_windows, "flag_rate": q.flag_rate, "median_score": float(np.median(q.score)),
                            "median_grfe_pct_bw": float(np.median(err)), "spearman_grfe": _rho(q.score, err),
                            "outside_training_inputs": findings}
    by_condition = {}
    for condition in protocol.conditions:
        names = [n for n in trials if n.endswith(f"_{condition}")]
        by_condition[condition] = {"trials": len(names), "flag_rate": float(np.mean([trials[n]["flag_rate"] for n in names]))}
    all_scores, all_err = np.concatenate(scores), np.concatenate(grf_errors)
    return {"trials": trials, "by_condition": by_condition, "flag_rate": float(np.mean([t["flag_rate"] for t in trials.values()])),
            "spearman_grfe_pooled": _rho(all_scores, all_err),
            "spearman_grfe_within_trials": _rho(_within(all_scores, np.repeat(np.arange(len(scores)), [len(s) for s in scores])),
                                                _within(all_err, np.repeat(np.arange(len(scores)), [len(s) for s in scores])))}


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", type=Path, default=REPO / "results/demo/run/model.pt")
    parser.add_argument("--data", type=Path, default=REPO / "data/synth_default", help="labelled dataset folder")
    parser.add_argument("--calibrate-on", nargs="+", default=["train"], help="splits to calibrate on")
    parser.add_argument("--evaluate-on", nargs="+", default=["test"], help="held-out splits to evaluate on")
    parser.add_argument("--cmu-source", type=Path, default=SHARED / "cmu_treadmill_imu_grf")
    parser.add_argument("--out", type=Path, default=REPO / "results/quality")
    parser.add_argument("--threads", type=int, default=1)
    args = parser.parse_args(argv)
    if set(args.calibrate_on) & set(args.evaluate_on):
        parser.error("--calibrate-on and --evaluate-on share a split: calibrate on data that is not evaluated")
    torch.set_num_threads(args.threads)
    warnings.simplefilter("ignore")  # the signal checks' warnings about the inputs are not this benchmark's subject
    est = SSPINNpose.load(args.model)
    dataset = Dataset.open(args.data)
    calib = [r for s in args.calibrate_on for r in dataset.load(s)]
    cal, _, _ = calibrate(est.network_, est.segments_, est.imu_std_, est.config_.joint_limits, calib,
                          [est.predict(r) for r in calib], args.model, f"{args.data} ({', '.join(args.calibrate_on)})",
                          training=training_recordings(dataset_recordings(args.data), est.trained_on_))
    save_calibration(cal, args.out / "quality.json")
    test = [r for s in args.evaluate_on for r in dataset.load(s)]
    result = {"model": str(args.model), "data": str(args.data), "calibrated_on": args.calibrate_on, "evaluated_on": args.evaluate_on,
              "window_s": cal.window_s, "threshold": cal.threshold, "error_threshold": cal.error_threshold,
              "calibration_fit": cal.fit, "input_ranges": cal.input_ranges, "input_ranges_from": cal.ranges_from, "held_out": held_out(est, cal, test),
              "corrupted": corrupted(est, cal, test)}
    print(f"calibrated on {', '.join(args.calibrate_on)} ({len(calib)} recordings, {int(cal.fit['n_windows'])} windows of "
          f"{cal.window_s:g} s): threshold {cal.threshold:.3f}; large error = relative error > {cal.error_threshold:.3f} "
          f"(its {ERROR_QUANTILE:.0%} quantile); there it flags {cal.fit['flag_rate']:.0%} (precision {cal.fit['precision']:.0%}, "
          f"recall {cal.fit['recall']:.0%})")
    print(f"\nheld-out ({', '.join(args.evaluate_on)}):")
    print("| program | windows | ρ(score, rel. error) | ρ JAE | ρ GRFE | ρ within recordings | flagged | large errors (random-flag precision) | precision | recall |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for prog, m in result["held_out"].items():
        print(f"| {prog} | {m['windows']} | {m['spearman_relative_error']:+.2f} | {m['spearman_jae']:+.2f} | {m['spearman_grfe']:+.2f} | "
              f"{m['spearman_within_recordings']:+.2f} | {m['flag_rate']:.0%} | {m['large_error_rate']:.0%} | "
              f"{m['precision']:.0%} | {m['recall']:.0%} |")
    for prog, m in result["held_out"].items():
        print(f"{prog}: ρ(term, rel. error) " + ", ".join(f"{k} {v:+.2f}" for k, v in m["spearman_relative_error_by_term"].items()))
    print("\ncorrupted held-out recordings: " + "; ".join(
        f"{kind}: {m['flag_rate']:.0%} flagged, median score {m['median_score']:+.2f}" for kind, m in result["corrupted"].items()))
    if args.cmu_source.exists():
        result["cmu"] = cmu(est, cal, args.cmu_source, args.out, str(args.model))
        c = result["cmu"]
        print(f"\nreal CMU treadmill trials: flag rate {c['flag_rate']:.0%} ("
              + ", ".join(f"{k} {v['flag_rate']:.0%}" for k, v in c["by_condition"].items())
              + f"); ρ(score, GRF RMSE) pooled {c['spearman_grfe_pooled']:+.2f}, within trials {c['spearman_grfe_within_trials']:+.2f}")
        print(f"| trial | windows | flagged | median score | median GRF RMSE %BW | ρ(score, GRFE) | outside the {cal.ranges_from} inputs |")
        print("|---|---:|---:|---:|---:|---:|---|")
        for name, t in c["trials"].items():
            note = t["outside_training_inputs"][0].split(" on: ", 1)[-1].split(": the estimate")[0] if t["outside_training_inputs"] else "—"
            print(f"| {name} | {t['windows']} | {t['flag_rate']:.0%} | {t['median_score']:+.2f} | {t['median_grfe_pct_bw']:.1f} | "
                  f"{t['spearman_grfe']:+.2f} | {note} |")
    else:
        print(f"\n{args.cmu_source}: not there; the real-trial flag rate is skipped (see ../shared/data/README.md)")
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "quality_report.json").write_text(json.dumps(result, indent=2, default=float))
    return result


if __name__ == "__main__":
    main(sys.argv[1:])
