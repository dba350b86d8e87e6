"""Predictive simulation: the full comparison, and the time to a controller for a *new* speed.

1. Runs the comparison harness (:mod:`predictive.experiments.controller_comparison`) from a
   config — the table of self-supervised generator vs SB3 agents vs OCP on the same environment
   and metrics — and prints it (the report with plots goes to ``--out``).
2. **Time to a controller for a new speed** (speeds no method was built for): the self-supervised
   generator (one forward pass + LQR + the tracker's start choice; and with its brief fine-tune) against the named baseline
   "re-solving the OCP (IPOPT, 100 nodes per half cycle) + LQR", measured in the same run, each
   with its closed-loop result (distance in 10 s, falls) on the first seed. Re-training an RL
   agent for a new speed is not run here; its cost is the agent's training time in the table
   (time to first success and to the checkpoint used).

Usage: ``python -m benchmarks.accuracy.bench_predictive [--config configs/predictive/compare.yaml]
[--out results/compare] [--new-speeds 0.9 2.2 3.0] [--skip-table]``.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--config", type=Path, default=Path("configs/predictive/compare.yaml"))
    parser.add_argument("--out", type=Path, default=Path("results/compare"))
    parser.add_argument("--new-speeds", type=float, nargs="*", default=[0.9, 2.2, 3.0])
    parser.add_argument("--new-bodies", nargs="*", default=["1.6:55", "1.9:90"],
                        help="height:mass pairs (m:kg) for the generator at the config's first speed")
    parser.add_argument("--skip-table", action="store_true", help="only the new-speed timing")
    args = parser.parse_args(argv)

    from predictive.experiments.controller_comparison import (
        ComparisonConfig,
        MethodSpec,
        evaluate_controller,
        generator_controller,
        make_env,
        ocp_controller,
        run_comparison,
    )

    config = ComparisonConfig.from_yaml(args.config)
    if not args.skip_table:
        cells = run_comparison(config, args.out)
        print((args.out / "report.md").read_text())
        del cells
    generators = [m for m in config.methods if m.kind == "generator"]
    if not generators:
        print("no generator in the config: nothing to time for new speeds")
        return 0
    model = generators[0].model
    variants = {
        "generator (forward pass + LQR + start choice)": MethodSpec("g", "generator", model, refine_iterations=0),
        "generator + fine-tune (+ LQR)": MethodSpec("g+", "generator", model, refine_iterations=200, refine_kane_factor=10.0),
        "baseline: OCP re-solve (+ LQR)": MethodSpec("ocp", "ocp", n_nodes=100),
    }
    rows = []
    for speed in args.new_speeds:
        env = make_env(config, speed)
        for label, spec in variants.items():
            start = time.perf_counter()
            build = generator_controller if spec.kind == "generator" else ocp_controller
            ctrl = build(spec, config, speed, env)
            wall = time.perf_counter() - start
            distance, fell = float("nan"), None
            if ctrl.controller is not None:
                eps, _, _ = evaluate_controller(ctrl, env, speed, config.seeds[:1], None)
                distance, fell = eps[0]["distance_m"], eps[0]["fell"]
            rows.append({"speed": speed, "method": label, "time_s": wall, "distance_m": distance, "fell": fell})
        env.close()
    print("\nTime to a controller for a new speed (one seed in closed loop; ratio = baseline time / time):")
    print(f"{'speed':>6}  {'method':<34} {'time (s)':>9} {'ratio':>7} {'distance 10 s (m)':>18}  fell")
    for speed in args.new_speeds:
        base = next(r["time_s"] for r in rows if r["speed"] == speed and r["method"].startswith("baseline"))
        for r in (r for r in rows if r["speed"] == speed):
            print(f"{speed:6.2f}  {r['method']:<34} {r['time_s']:9.2f} {base / r['time_s']:7.1f}× {r['distance_m']:18.2f}  {r['fell']}")
    body_rows = []
    for pair in args.new_bodies:
        height, mass = (float(x) for x in pair.split(":"))
        cfg_b = ComparisonConfig(**{**config.__dict__, "height": height, "mass": mass})
        speed = config.speeds[0]
        env = make_env(cfg_b, speed)
        for label, spec in list(variants.items())[:2]:
            ctrl = generator_controller(spec, cfg_b, speed, env)
            eps, _, _ = evaluate_controller(ctrl, env, speed, config.seeds, None)
            body_rows.append({"height": height, "mass": mass, "speed": speed, "method": label,
                              "time_s": ctrl.per_speed_time_s, "falls": int(sum(e["fell"] for e in eps)), "episodes": len(eps),
                              "mean_distance_m": float(np.mean([e["distance_m"] for e in eps]))})
        env.close()
    print("\nOther bodies (the generator was trained on 1.6–1.9 m, 55–90 kg):")
    for r in body_rows:
        print(f"{r['height']:.2f} m {r['mass']:.0f} kg {r['speed']} m/s  {r['method']:<34} {r['time_s']:7.2f} s  "
              f"falls {r['falls']}/{r['episodes']}  distance {r['mean_distance_m']:.2f} m")
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "new_speed_timing.json").write_text(json.dumps({"speeds": rows, "bodies": body_rows}, indent=2, default=float))
    print(f"median time, generator forward pass: {np.median([r['time_s'] for r in rows if r['method'].startswith('generator (')]):.2f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
