"""The offline double-support load transfer against the labels: errors before and after, and how
the trailing foot unloads in the labels, the estimate and the transferred estimate.

For every recording of one split of a labelled dataset (a synthetic one, or real recordings imported
with ``sspinn import``): the model's GRF error (GRFE, %BW), joint-torque error (JTE, %BW·BH, where
the labels have torques) and heel-strike timing (ms) as estimated and after
:func:`sspinn.estimator.load_transfer.linear_load_transfer` (``sspinn infer --load-transfer``), and
the trailing foot's mean share of the vertical force in tenths of the double supports
(:func:`~sspinn.estimator.load_transfer.share_profile`) in the labels, the estimate and the
transferred estimate. Means per gait (a synthetic recording's program name, else the last part of
the recording's name, e.g. the CMU condition); the whole recording after ``--skip`` samples.

Usage: ``python -m benchmarks.studies.load_transfer --data data/synth_default --model results/demo/run/model.pt
[--split test] [--skip 100]``. Under a minute on the default dataset; no timing. On real trials the
CMU benchmark scores the same transfer on its own samples (``bench_cmu_continuous.py --load-transfer``).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from sspinn.data.dataset import SAMPLE_RATE_HZ
from sspinn.data.loading import labelled_recordings
from sspinn.errors import UserError
from sspinn.estimator.evaluation import compute_metrics
from sspinn.estimator.load_transfer import linear_load_transfer, share_profile
from sspinn.estimator.sspinnpose import SSPINNpose
from sspinn.estimator.trivial_predictors import program_of
from sspinn.model.body import BodyParameters

REPO = Path(__file__).resolve().parents[2]


def _mean(rows: list[np.ndarray]) -> np.ndarray:
    """Column means over the recordings, NaN where none has a finite value."""
    v = np.array(rows, dtype=float)
    return np.array([c[np.isfinite(c)].mean() if np.isfinite(c).any() else np.nan for c in v.T])


def _fmt(values: np.ndarray, spec: str) -> str:
    return " / ".join("n/a" if not np.isfinite(v) else format(v, spec) for v in values)


def main(argv: list[str] | None = None) -> dict[str, dict[str, list[float]]]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=REPO / "data" / "synth_default")
    parser.add_argument("--model", type=Path, default=REPO / "results" / "demo" / "run" / "model.pt")
    parser.add_argument("--split", default="test")
    parser.add_argument("--skip", type=int, default=100, help="samples of warm-up left out (1 s)")
    args = parser.parse_args(argv)
    try:  # a missing or unreadable folder or model file: one line
        recordings, estimator = labelled_recordings(args.data, args.split, "grf"), SSPINNpose.load(args.model)
    except UserError as exc:
        parser.error(str(exc))
    rows: dict[str, dict[str, list[np.ndarray]]] = {}
    for rec in recordings:
        estimate = estimator.predict(rec)
        body = BodyParameters.from_anthropometry(rec.height, rec.mass)
        shared = linear_load_transfer(estimate, body, SAMPLE_RATE_HZ)
        metrics = [compute_metrics(e, rec, args.skip, physics=False) for e in (estimate, shared)]
        row = rows.setdefault(program_of(rec, from_name=True), {k: [] for k in ("grfe", "jte", "hs", "labels", "estimate", "shared")})
        row["grfe"].append(np.array([m.grfe_pct_bw for m in metrics]))
        row["jte"].append(np.array([m.jte_pct_bwbh for m in metrics]))
        row["hs"].append(np.array([m.hs_timing_ms for m in metrics]))
        assert rec.labels is not None and rec.labels.grf is not None
        for key, grf in (("labels", rec.labels.grf), ("estimate", estimate.grf), ("shared", shared.grf)):
            row[key].append(share_profile(grf[args.skip:], body.body_weight, SAMPLE_RATE_HZ))
    print(f"{args.model} on {args.data} ({args.split}); the double-support load transferred linearly, offline\n")
    print("| gait | recordings | GRFE %BW: estimated / transferred | JTE %BW·BH: the same | heel strike ms: the same |")
    print("|---|---:|---|---|---|")
    out = {}
    for gait, row in sorted(rows.items()):
        grfe, jte, hs = (_mean(row[k]) for k in ("grfe", "jte", "hs"))
        out[gait] = {"grfe": grfe.tolist(), "jte": jte.tolist(), "hs_ms": hs.tolist()}
        print(f"| {gait} | {len(row['grfe'])} | {_fmt(grfe, '.2f')} | {_fmt(jte, '.3f')} | {_fmt(hs, '.0f')} |")
    print("\nThe trailing foot's share of the vertical force in tenths of the double supports (mean over the recordings):\n")
    print("| gait | source | " + " | ".join(f"{k}/10" for k in range(1, 11)) + " |")
    print("|---|---|" + "---:|" * 10)
    for gait, row in sorted(rows.items()):
        for key in ("labels", "estimate", "shared"):
            profile = _mean(row[key])
            out[gait][f"share_{key}"] = profile.tolist()
            print(f"| {gait} | {key} | " + " | ".join("–" if not np.isfinite(v) else f"{v:.2f}" for v in profile) + " |")
    return out


if __name__ == "__main__":
    main()
