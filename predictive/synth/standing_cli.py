"""The ``synth-standing`` sub-command of ``python -m predictive``: quiet-standing recordings, with
exact labels, of a synthetic configuration's subjects.

``python -m predictive synth-standing --config configs/synth/default.yaml --split test --out data/standing``
writes a dataset (split ``test``) with one ``<subject>_stand`` recording per subject of
``--split``: the same virtual subjects as the walking and running data (the same true bodies and
IMU error model), standing still with postural sway (:mod:`predictive.synth.standing`). Then, e.g.,
``sspinn evaluate --model results/demo/run/model.pt --data data/standing --split test --out
results/standing`` tells what a model estimates for a person who stands (the speed label is 0).

``--with data/synth_default`` (a dataset of the same configuration) writes that dataset's
recordings too, with every subject's standing recording in the subject's own split: training data
that stands as well as walks and runs (``--duration`` sets the standing share).

``--start-stop 1.2`` writes ``<subject>_startstop`` recordings instead: each subject stands for
``--duration`` seconds, starts walking, walks ``--walk`` seconds at 1.2 m/s between the speed
ramps, stops and stands again for ``--duration`` seconds (:mod:`predictive.synth.start_stop`;
the periodic gaits come from the configuration's cache folder and are solved if missing).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any

from predictive.ocp.limits import MAX_SPEED
from sspinn.data.dataset import SPLITS
from sspinn.errors import bounded
from sspinn.run_folder import OVERWRITE_HELP
from sspinn.yaml_config import shipped_path

#: Sub-command name.
COMMAND = "synth-standing"
#: Longest standing (each end) and steady-walking span of one recording, s.
MAX_SECONDS = 600.0


def add_parser(sub: Any) -> argparse.ArgumentParser:
    """Register the ``synth-standing`` sub-command on an ``argparse`` sub-parsers object."""
    ap = sub.add_parser(COMMAND, help="write quiet-standing (or stand-walk-stand) recordings of a synthetic configuration's subjects")
    ap.add_argument("--config", type=Path, default=shipped_path("configs/synth/default.yaml"), help="synthetic data configuration")
    ap.add_argument("--split", choices=SPLITS, default="test", help="whose subjects stand (default test)")
    ap.add_argument("--duration", type=bounded(float, 0.0, MAX_SECONDS), default=10.0,
                    help=f"seconds of standing per subject (> 0, at most {MAX_SECONDS:g}; default 10)")
    ap.add_argument("--with", dest="base", type=Path, help="a dataset of the same configuration whose recordings to write too "
                    "(each subject's standing recording then goes to the subject's split; --split is ignored)")
    ap.add_argument("--start-stop", dest="start_stop", type=bounded(float, 0.0, MAX_SPEED), metavar="SPEED",
                    help="write stand-walk-stand recordings at this walking speed (m/s) instead of standing ones")
    ap.add_argument("--walk", type=bounded(float, 0.0, MAX_SECONDS), default=2.0,
                    help=f"with --start-stop: seconds of steady walking (0–{MAX_SECONDS:g}; default 2)")
    ap.add_argument("--out", type=Path, required=True, help="dataset folder to write")
    ap.add_argument("--overwrite", action="store_true", help=OVERWRITE_HELP)
    return ap


def run(args: argparse.Namespace) -> int:
    """Run the sub-command; returns the exit code."""
    from predictive.ocp.collocation import OCPError
    from predictive.ocp.stride_nlp import StrideSolverCache
    from predictive.synth.cache import SynthCache
    from predictive.synth.chain import ChainError
    from predictive.synth.config import SynthConfig, imu_model
    from predictive.synth.standing import standing_recording
    from predictive.synth.start_stop import settle_solvers, start_stop_recording
    from predictive.synth.subjects import sample_subjects
    from sspinn.data.dataset import Dataset
    from sspinn.run_folder import output_target

    if not args.duration > 0:
        print(f"error: --duration must be > 0 s, got {args.duration}", file=sys.stderr)
        return 2
    if args.start_stop is not None and not (math.isfinite(args.start_stop) and args.start_stop > 0):
        print(f"error: --start-stop must be a speed > 0 m/s, got {args.start_stop}", file=sys.stderr)
        return 2
    if not (math.isfinite(args.walk) and args.walk >= 0):
        print(f"error: --walk must be >= 0 s, got {args.walk}", file=sys.stderr)
        return 2
    try:
        config = SynthConfig.from_yaml(args.config)
    except (OSError, ValueError) as exc:
        print(f"error: {args.config}: {exc}", file=sys.stderr)
        return 2
    info = {"kind": "synthetic quiet standing", "generator": "python -m predictive synth-standing", "config": str(args.config),
            "duration_s": args.duration}
    if args.start_stop is not None:
        info.update({"kind": "synthetic standing, walking and standing again", "speed_mps": args.start_stop,
                     "walk_s": args.walk})
    if args.base is not None:
        try:
            base = Dataset.open(args.base)
        except (OSError, ValueError) as exc:
            print(f"error: --with {args.base}: {exc}", file=sys.stderr)
            return 2
        if base.info.get("config_key") != config.key():
            print(f"error: --with {args.base} was not generated from {args.config} (another config_key in its dataset.json)",
                  file=sys.stderr)
            return 2
        splits = {split: base.load(split) for split in base.splits}
        subjects = [s for s in sample_subjects(config) if s.split in splits]
        info.update({"with": str(args.base), "config_key": config.key()})
    else:
        splits = {"test": []}
        subjects = [s for s in sample_subjects(config) if s.split == args.split]
        info["split_of_subjects"] = args.split
    if not subjects:
        print(f"error: {args.config} has no subject in split {args.split!r}", file=sys.stderr)
        return 2
    out = output_target(args.out, lambda p: (p / "dataset.json").exists(), args.overwrite, "a dataset")
    if args.start_stop is None:
        recordings = [standing_recording(s, args.duration, config.seed, imu_model(config)) for s in subjects]
    else:
        cache, solvers = SynthCache(config.cache_dir), StrideSolverCache(config.stride)
        rest_solvers = settle_solvers(config.stride)
        try:
            recordings = [start_stop_recording(config, s, args.start_stop, args.duration, args.walk, cache, solvers, rest_solvers)
                          for s in subjects]
        except (ChainError, OCPError) as exc:
            print(f"error: {exc}", file=sys.stderr)
            return 1
    for subject, rec in zip(subjects, recordings):
        splits[subject.split if args.base is not None else "test"].append(rec)
    Dataset.write(out, splits, info=info)
    for rec in recordings:
        res = rec.provenance["kane_residual"]
        junction = f", end junction {rec.provenance['junction']['kinematic']:.1e} m/s" if "junction" in rec.provenance else ""
        print(f"{rec.name}: {rec.n_samples} samples, Kane residual max {res['max_trans_bw']:.1e} BW, {res['max_rot_bwh']:.1e} BW·H"
              f"{junction}")
    print(f"→ {out}")
    return 0
