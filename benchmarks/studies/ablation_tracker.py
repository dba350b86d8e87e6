"""What the tracker's parts contribute: falls under 10× reset noise per generator, speed and tracker
variant, on reset seeds that neither the tracker study nor the final check used.

Variants, from the cycle's sample 0: the clock phase with one set of LQR weights (the defaults of
:class:`predictive.generator.closed_loop.LQRWeights`); the state-based phase with those weights;
the clock with the configured gain schedule; the state-based phase with the gain schedule; then
the configured tracker (the same from its configured start sample, ``tracker.start``). Every generator's controller is made by ``controller_for(speed)`` and evaluated by
:func:`predictive.experiments.robustness.evaluate`.

Usage: ``python -m benchmarks.studies.ablation_tracker --generators runs/generator_s0/generator.pt ...
[--config configs/predictive/robustness.yaml] [--seeds 200-239] [--out results/ablation_tracker.json]``.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from pathlib import Path


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--generators", type=Path, nargs="+", required=True)
    parser.add_argument("--config", type=Path, default=Path("configs/predictive/robustness.yaml"))
    parser.add_argument("--seeds", default="200-239", help="reset seeds, first-last")
    parser.add_argument("--out", type=Path, default=Path("results/ablation_tracker.json"))
    args = parser.parse_args(argv)

    from predictive.experiments.robustness import RobustnessConfig, evaluate
    from predictive.generator.closed_loop import TrackerSettings
    from predictive.generator.controllers import GeneratorControllers
    from sspinn.model.body import BodyParameters

    config = RobustnessConfig.from_yaml(args.config)
    lo, _, hi = args.seeds.partition("-")
    seeds = list(range(int(lo), int(hi or lo) + 1))
    body = BodyParameters.from_anthropometry(config.height, config.mass)
    first = "cycle_start"  # the parts below start at the cycle's sample 0; the last row adds the start choice
    variants = {
        "clock, default weights": TrackerSettings(phase="clock", start=first),
        "state phase, default weights": TrackerSettings(phase="state", phase_prior=config.tracker.phase_prior, start=first),
        "clock, gain schedule": TrackerSettings(lqr=config.tracker.lqr, phase="clock", start=first),
        "state phase + gain schedule": dataclasses.replace(config.tracker, start=first),
        "configured tracker": config.tracker,
    }
    falls: dict[str, dict[str, dict[float, int]]] = {}
    for name, tracker in variants.items():
        for path in args.generators:
            rows = evaluate(GeneratorControllers.from_file(path, tracker=tracker), config.speeds, seeds, body, config.env,
                            config.reset_options)
            falls.setdefault(name, {})[str(path)] = {v: sum(r["fell"] for r in rows if r["speed"] == v) for v in config.speeds}
            print(f"{name:<30} {path}: falls {falls[name][str(path)]} of {len(seeds)}", flush=True)
    n = len(seeds) * len(args.generators)
    print(f"\nFalls out of {n} episodes ({len(args.generators)} generators × reset seeds {seeds[0]}–{seeds[-1]}), "
          f"environment overrides {config.env}:\n")
    print("| tracker | " + " | ".join(f"{v} m/s" for v in config.speeds) + " | success |")
    print("|---|" + "---|" * (len(config.speeds) + 1))
    for name, per in falls.items():
        totals = [sum(p[v] for p in per.values()) for v in config.speeds]
        success = 1 - sum(totals) / (n * len(config.speeds))
        print(f"| {name} | " + " | ".join(f"{t}/{n}" for t in totals) + f" | {success:.1%} |")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({"seeds": seeds, "falls": falls}, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
