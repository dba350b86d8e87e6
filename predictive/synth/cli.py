"""The ``synth`` sub-command of ``python -m predictive``: physically exact synthetic gait data.

``python -m predictive synth --config configs/synth/default.yaml --out data/synth_default``

Generates the dataset of :mod:`predictive.synth.pipeline` (progress bar on stderr), then prints its
size, the generation time, the solver statistics and the Kane residual of the written labels.
A second run with the same configuration reads everything from the cache. ``--workers N``
generates N subjects at a time as joblib tasks (``--backend``, default ``loky``: processes on
this machine).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import Any

from sspinn.errors import bounded
from sspinn.yaml_config import shipped_path

#: Sub-command name.
COMMAND = "synth"
#: Most worker processes (one subject each).
MAX_WORKERS = 256
#: Largest seed (numpy's legacy seeding takes 32-bit seeds).
MAX_SEED = 2**32 - 1


def add_parser(sub: Any) -> argparse.ArgumentParser:
    """Register the ``synth`` sub-command on an ``argparse`` sub-parsers object."""
    p = sub.add_parser(COMMAND, help="generate a physically exact synthetic dataset (sspinn format v1)")
    p.add_argument("--config", type=Path, default=shipped_path("configs/synth/default.yaml"),
                   help="SynthConfig YAML (default: the project's configs/synth/default.yaml)")
    p.add_argument("--out", type=Path, required=True, help="output dataset folder")
    p.add_argument("--cache-dir", type=Path, default=None, help="cache folder (default: the config's cache_dir)")
    p.add_argument("--workers", type=bounded(int, 1, MAX_WORKERS), default=None,
                   help=f"subjects at a time (1: in this process; 1–{MAX_WORKERS}; default: the config's)")
    p.add_argument(
        "--backend",
        default=None,
        help="joblib backend of the workers (default: the config's, loky: processes on this machine; "
        "dask and ray need their own setup, see predictive.synth.joblib_backend)",
    )
    p.add_argument("--seed", type=bounded(int, 0, MAX_SEED), default=None, help=f"override the config's seed (0–{MAX_SEED})")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--require-norms", action="store_true",
                   help="refuse (write nothing) if a recording has fewer than 95 %% of its stances inside the human "
                   "gait norms (default: write it, print every recording against the norms and warn)")
    p.add_argument("--overwrite", action="store_true",
                   help="replace a dataset of another configuration in --out (the same configuration is written again anyway)")
    return p


def run(args: argparse.Namespace) -> int:
    """Run the sub-command; returns the exit code."""
    from predictive.synth.config import SynthConfig
    from predictive.synth.norms import MIN_INSIDE
    from predictive.synth.pipeline import generate_dataset

    config = SynthConfig.from_yaml(args.config, workers=args.workers, seed=args.seed, backend=args.backend)
    t0 = time.perf_counter()
    dataset = generate_dataset(config, args.out, progress=not args.no_progress, cache_dir=args.cache_dir,
                               overwrite=args.overwrite,
                               outside_norms="refuse" if args.require_norms else "warn")
    elapsed = time.perf_counter() - t0
    info = dataset.info
    size = sum(p.stat().st_size for p in Path(args.out).iterdir() if p.is_file())
    res = info["kane_residual"]
    solver = info["solver"]
    cache = info["cache"]
    print(f"dataset       {args.out}  ({size / 1e6:.1f} MB)")
    for split, names in dataset.splits.items():
        subjects = sorted({info["recordings"][n]["subject"] for n in names})
        print(f"  {split:<5}       {len(names)} recording(s), subjects {', '.join(subjects)}")
    print(
        f"data          {info['n_recordings']} recordings, {info['total_duration_s']:.1f} s, {res['samples']} samples at 100 Hz"
    )
    print(f"time          {elapsed:.1f} s (solver build {solver['build_time_s']:.1f} s)")
    if solver["strides_solved"]:
        print(
            f"strides       {solver['strides_solved']} solved, {solver['solve_time_per_stride_s']:.2f} s and "
            f"{solver['iterations_mean']:.0f} IPOPT iterations per stride, {solver['retried_strides']} retried"
        )
    used = {rung: n for rung, n in solver["fallbacks"].items() if n and rung != "warm"}
    if used:
        print(f"fallbacks     {', '.join(f'{n} stride(s) solved on {rung!r}' for rung, n in used.items())}")
    else:
        print("fallbacks     none needed (every stride solved on its first rung, 'warm')")
    for event in info["events"]:
        print(f"WARNING       {event['recording']}: {event['event'].replace('_', ' ')}: {event['detail']}")
    print(
        f"cache         periodic {cache['periodic_hits']} hit / {cache['periodic_solved']} solved, chains "
        f"{cache['chain_hits']} / {cache['chain_solved']}, recordings {cache['recording_hits']} / {cache['recording_made']}"
    )
    print(f"human gait norms (every stance against the ranges at its speed, sspinn.data.gait_norms; "
          f">= {100 * MIN_INSIDE:.0f} % of the stances inside per recording):")
    for rec in info["recordings"].values():
        print(f"  {rec['norms']['line']}")
    print(
        f"Kane residual max {res['max_trans_bw']:.2e} BW, {res['max_rot_bwh']:.2e} BW·H; "
        f"RMS {res['rms_trans_bw']:.2e} BW, {res['rms_rot_bwh']:.2e} BW·H (labels as written)"
    )
    return 0
