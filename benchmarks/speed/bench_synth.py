"""Synthetic-data generation: strides/s of the stride chains with shared solvers against one solver
built per stride, in the same run, with the profile of each and a check that the labels agree.

The stride chains (:func:`predictive.synth.recording.recording_chain`) solve one NLP per stride.
The pipeline builds a handful of parametric NLPs (one per node-count bucket, the body as a
parameter: :class:`predictive.ocp.stride_nlp.StrideSolverCache`) and reuses them for every stride
of every subject; the baseline builds the stride's NLP and IPOPT solver anew for every stride, as
a pipeline without that reuse does (``StrideSolverCache(reuse=False)``). Both arms start from the same
periodic gaits (solved once, before the timing, into a cache that both copy) and solve the same
NLPs with the same IPOPT options, so their labels must agree to IPOPT's round-off.

Reported per arm: wall time of the chains (s), strides, strides/s, solver builds (count and s),
IPOPT (s, iterations per stride) and the rest (chain bookkeeping, the IMU signals, the recording);
the ratio of strides/s; the largest difference between the arms' recorded labels (q, GRF). The
rest of a cold ``python -m predictive synth`` — the periodic gaits, about a third of the smoke
configuration's time — is the same in both arms and not timed here.

Usage: ``python -m benchmarks.speed.bench_synth [--config configs/synth/default.yaml] [--subjects 2]
[--json PATH]``; ``--quick``: the smoke configuration, one subject. One thread (the solvers are
single-threaded; run it alone: the timings are contended otherwise).
"""

from __future__ import annotations

import argparse
import json
import platform
import shutil
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

REPO = Path(__file__).resolve().parents[2]


def run_arm(config: Any, subjects: list[Any], cache_root: Path, per_stride: bool) -> dict[str, Any]:
    """Generate the subjects' recordings with the periodic gaits in ``cache_root`` (chains solved),
    building every stride's solver anew with ``per_stride`` (the baseline) or sharing them."""
    from predictive.ocp.stride_nlp import StrideSolverCache
    from predictive.synth.cache import SynthCache
    from predictive.synth.pipeline import generate_subject

    solvers = StrideSolverCache(config.stride, reuse=not per_stride)
    cache = SynthCache(cache_root)
    t0 = time.perf_counter()
    outputs = [generate_subject(config, s, cache, solvers) for s in subjects]
    wall = time.perf_counter() - t0
    strides = [r for o in outputs for r in o.strides]
    ipopt = sum(r.solve_time for r in strides)
    return {
        "wall_s": wall, "strides": len(strides), "strides_per_s": len(strides) / wall, "builds": solvers.builds,
        "build_s": solvers.build_time, "ipopt_s": ipopt, "other_s": wall - solvers.build_time - ipopt,
        "iterations_per_stride": float(np.mean([r.iterations for r in strides])) if strides else float("nan"),
        "recordings": [rec for o in outputs for rec in o.recordings],
    }


def label_difference(a: list[Any], b: list[Any]) -> float:
    """Largest |difference| of the labels' coordinates (m, rad) and GRF (N) between two arms."""
    worst = 0.0
    for ra, rb in zip(a, b):
        for name in ("q", "grf"):
            xa, xb = getattr(ra.labels, name), getattr(rb.labels, name)
            worst = max(worst, float(np.max(np.abs(np.asarray(xa) - np.asarray(xb)))))
    return worst


def main(argv: list[str] | None = None) -> dict[str, Any]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--config", type=Path, default=REPO / "configs" / "synth" / "default.yaml")
    parser.add_argument("--subjects", type=int, default=2, help="the first N subjects of the configuration")
    parser.add_argument("--quick", action="store_true", help="the smoke configuration, one subject")
    parser.add_argument("--json", type=Path, help="also save the results")
    args = parser.parse_args(argv)
    if args.quick:
        args.config, args.subjects = REPO / "configs" / "synth" / "smoke.yaml", 1

    from predictive.synth.cache import SynthCache
    from predictive.synth.config import SynthConfig
    from predictive.synth.pipeline import generate_subject
    from predictive.synth.subjects import sample_subjects

    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        config = SynthConfig.from_yaml(args.config, workers=1)
        subjects = sample_subjects(config)[: args.subjects]
        t0 = time.perf_counter()
        for s in subjects:  # the periodic gaits both arms start from (and a first solve of every chain)
            generate_subject(config, s, SynthCache(root / "periodic_only"))
        periodic_s = time.perf_counter() - t0
        for kind in ("chains", "recordings"):
            shutil.rmtree(root / "periodic_only" / kind, ignore_errors=True)
        results: dict[str, Any] = {}
        for name, per_stride in (("one solver per stride", True), ("shared solvers", False)):
            shutil.copytree(root / "periodic_only", root / name)
            results[name] = run_arm(config, subjects, root / name, per_stride)
    before, after = results["one solver per stride"], results["shared solvers"]
    difference = label_difference(before["recordings"], after["recordings"])
    print(f"# Stride chains of {len(subjects)} subject(s) of {args.config.name} ({platform.machine()}, one thread; "
          f"the first pass, periodic gaits included, took {periodic_s:.1f} s)\n")
    print("| arm | wall s | strides | strides/s | solver builds | build s | IPOPT s | it./stride | other s |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for name, r in results.items():
        print(f"| {name} | {r['wall_s']:.1f} | {r['strides']} | {r['strides_per_s']:.3f} | {r['builds']} | {r['build_s']:.1f} | "
              f"{r['ipopt_s']:.1f} | {r['iterations_per_stride']:.0f} | {r['other_s']:.1f} |")
    ratio = after["strides_per_s"] / before["strides_per_s"]
    print(f"\nshared solvers / one solver per stride: {ratio:.2f}× the strides/s; labels differ by at most "
          f"{difference:.2e} (m, rad, N)")
    out = {"config": str(args.config), "subjects": len(subjects), "periodic_s": periodic_s, "ratio": ratio,
           "label_difference": difference,
           "arms": {n: {k: v for k, v in r.items() if k != "recordings"} for n, r in results.items()}}
    if args.json:
        args.json.write_text(json.dumps(out, indent=2))
    return out


if __name__ == "__main__":
    main(sys.argv[1:])
