"""Stand–walk–stand recordings (:mod:`predictive.synth.start_stop`): what one costs and how it moves.

For one subject of a synthetic configuration: the chain's strides (speed, samples, IPOPT
iterations, attempts, fallback rung, solve time, the smallest forward pelvis speed and the range
of the total vertical GRF in BW), the Kane residual per part (standing, chain, standing), the end
junction's mismatch, the standing parts' speed label, pelvis speed and foot loads, and the time.

Usage: ``python -m benchmarks.studies.start_stop [--config configs/synth/smoke.yaml] [--subject 0]
[--speed 1.2] [--stand 2] [--walk 2] [--cache DIR]`` (the periodic gaits are cached in ``--cache``,
default the configuration's cache folder). One thread; the timings are contended beside other work.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from predictive.synth.cache import SynthCache
from predictive.synth.config import SynthConfig
from predictive.synth.start_stop import start_stop_trajectory
from predictive.synth.subjects import sample_subjects


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--config", type=Path, default=Path("configs/synth/smoke.yaml"))
    ap.add_argument("--subject", type=int, default=0, help="index of the subject in the configuration")
    ap.add_argument("--speed", type=float, default=1.2, help="walking (or running) speed, m/s")
    ap.add_argument("--stand", type=float, default=2.0, help="seconds of standing at each end")
    ap.add_argument("--walk", type=float, default=2.0, help="seconds of steady strides")
    ap.add_argument("--cache", type=Path, help="cache folder of the periodic gaits (default: the configuration's)")
    args = ap.parse_args(argv)
    config = SynthConfig.from_yaml(args.config, **({"cache_dir": str(args.cache)} if args.cache else {}))
    subjects = sample_subjects(config)
    if not 0 <= args.subject < len(subjects):
        print(f"error: --subject must be 0 … {len(subjects) - 1}, got {args.subject}", file=sys.stderr)
        return 2
    subject = subjects[args.subject]
    bw = subject.body.body_weight
    t0 = time.perf_counter()
    rng = np.random.default_rng([config.seed, 7, subject.index])
    made = start_stop_trajectory(config, subject, args.speed, args.stand, args.walk, rng, SynthCache(config.cache_dir))
    total = time.perf_counter() - t0
    tr, phase = made.trajectory, made.phase
    print(f"{subject.id} at {args.speed} m/s: {len(tr.q)} samples, {total:.1f} s in all ({made.time_s:.1f} s the chain)")
    walk = phase == 1
    vx, fy = tr.u[walk, 0], (tr.grf[walk, 1] + tr.grf[walk, 3]) / bw
    start = 0
    print("stride  speed  samples  iterations  attempts  rung     solve_s  min_vx  Fy_BW")
    for r in made.chain.strides:
        sl = slice(start, start + r.n_nodes)
        start += r.n_nodes
        print(f"{r.index:6d}  {r.speed:5.2f}  {r.n_nodes:7d}  {r.iterations:10d}  {r.attempts:8d}  {r.fallback:7s}  "
              f"{r.solve_time:7.2f}  {vx[sl].min():6.2f}  {fy[sl].min():.2f}–{fy[sl].max():.2f}")
    r = np.abs(tr.kane_residual(subject.body))
    print("max Kane residual (BW, BW·H): standing " + ", then ".join(f"{r[phase == p].max():.1e}" for p in range(3)))
    print("end junction: " + ", ".join(f"{k} {v:.1e}" for k, v in made.junction.items()))
    load = tr.grf[:, [1, 3]] / bw
    for p, name in ((0, "before"), (2, "after")):
        sel = phase == p
        print(f"standing {name}: speed label max {made.speed[sel].max():.3f} m/s, |pelvis speed| max "
              f"{np.abs(tr.u[sel, 0]).max():.3f} m/s, smaller foot load min {load[sel].min():.3f} BW")
    return 0


if __name__ == "__main__":
    sys.exit(main())
