"""Where the gait trackers start their episodes: falls per disturbance condition, start mode,
generator and speed.

Start modes (:class:`predictive.generator.closed_loop.TrackerSettings` ``start``): "cycle_start"
(sample 0 of the generated cycle) and "least_sensitive" (the sample whose start survives a pelvis
height error of ± ``start_height_error`` best on the announced model). Conditions: the comparison's
``conditions`` (``configs/predictive/compare.yaml``: 10× reset noise, pushes ±15 % BW at mid-stance,
segment masses and lengths ±5 %, observation noise), each an ``env.reset`` option set, plus
"nominal" (the default reset noise). Every controller is built for the nominal environment by
``controller_for(speed, body)`` with the robustness configuration's tracker, and evaluated by
:func:`predictive.experiments.robustness.evaluate` on reset seeds that no choice used.

Usage: ``python -m benchmarks.studies.tracker_start --generators runs/generator_s0/generator.pt ...
[--config configs/predictive/robustness.yaml] [--conditions configs/predictive/compare.yaml]
[--seeds 300-339] [--speeds 1.3 2.2 3.5] [--out results/tracker_start.json]``.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from pathlib import Path

MODES = ("cycle_start", "least_sensitive")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--generators", type=Path, nargs="+", required=True)
    parser.add_argument("--config", type=Path, default=Path("configs/predictive/robustness.yaml"))
    parser.add_argument("--conditions", type=Path, default=Path("configs/predictive/compare.yaml"))
    parser.add_argument("--seeds", default="300-339", help="reset seeds, first-last")
    parser.add_argument("--speeds", type=float, nargs="+", default=None, help="m/s (default: the config's)")
    parser.add_argument("--only", nargs="*", default=None, help="condition names to run (default: all)")
    parser.add_argument("--out", type=Path, default=Path("results/tracker_start.json"))
    args = parser.parse_args(argv)

    from predictive.experiments.controller_comparison import ComparisonConfig
    from predictive.experiments.robustness import RobustnessConfig, evaluate
    from predictive.generator.controllers import GeneratorControllers
    from sspinn.model.body import BodyParameters

    config = RobustnessConfig.from_yaml(args.config, [f"generators=[{','.join(map(str, args.generators))}]"])
    conditions = {"nominal": {}, **ComparisonConfig.from_yaml(args.conditions).conditions}
    if args.only:
        conditions = {k: v for k, v in conditions.items() if k in args.only}
    speeds = args.speeds or config.speeds
    lo, _, hi = args.seeds.partition("-")
    seeds = list(range(int(lo), int(hi or lo) + 1))
    body = BodyParameters.from_anthropometry(config.height, config.mass)
    falls: dict[str, dict[str, dict[str, dict[float, int]]]] = {}
    for mode in MODES:
        tracker = dataclasses.replace(config.tracker, start=mode)
        for path in args.generators:
            source = GeneratorControllers.from_file(path, tracker=tracker)
            for name, options in conditions.items():
                rows = evaluate(source, speeds, seeds, body, {}, options)
                per = {v: sum(r["fell"] for r in rows if r["speed"] == v) for v in speeds}
                falls.setdefault(name, {}).setdefault(mode, {})[str(path)] = per
                print(f"{mode:<16} {name:<16} {path}: falls {per} of {len(seeds)}", flush=True)
    n = len(seeds) * len(args.generators)
    print(f"\nFalls out of {n} episodes per cell ({len(args.generators)} generators × reset seeds "
          f"{seeds[0]}–{seeds[-1]}); cycle start → least sensitive start:\n")
    print("| condition | " + " | ".join(f"{v} m/s" for v in speeds) + " |")
    print("|---|" + "---|" * len(speeds))
    for name, per_mode in falls.items():
        cells = []
        for v in speeds:
            a, b = (sum(p[v] for p in per_mode[m].values()) for m in MODES)
            cells.append(f"{a} → {b}")
        print(f"| {name} | " + " | ".join(cells) + " |")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({"seeds": seeds, "speeds": speeds, "falls": falls}, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
