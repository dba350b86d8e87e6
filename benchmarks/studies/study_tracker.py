"""Measured choice of the gait trackers' LQR weights and phase estimation, per speed.

For each speed: each generator's gait (one forward pass) is linearised once; then candidate
tracker settings are scored by falls, summed over the generators, over study reset seeds
(disjoint from the seeds 0–4 of the final check) under 10× reset noise (``--noise``), ties broken
by the mean episode length. The search is a coordinate descent over the characteristic deviations
of :class:`predictive.generator.closed_loop.LQRWeights` (each × or ÷ ``--factor`` in turn, kept
when it has fewer falls), after a comparison of phase estimators at the start weights. It prints
every scored candidate and the chosen schedule as YAML for ``tracker.lqr``.

Usage: ``python -m benchmarks.studies.study_tracker --generators runs/generator_s0/generator.pt [...]
[--speeds 1.3 2.2 3.5] [--seeds 100-119] [--passes 2] [--out results/tracker_study.json]``.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np


def _seeds(text: str) -> list[int]:
    lo, _, hi = text.partition("-")
    return list(range(int(lo), int(hi) + 1)) if hi else [int(lo)]


class Case:
    """One generator's gait at one speed, linearised once, scored for any tracker settings."""

    def __init__(self, generator: Path, speed: float, noise: float) -> None:
        from predictive.experiments.robustness import evaluation_env
        from predictive.generator.closed_loop import linearise, resample_cycle
        from predictive.generator.gait_generator import GaitGenerator
        from sspinn.model.body import BodyParameters

        trained = GaitGenerator.load(generator)
        body = BodyParameters.from_anthropometry()
        self.env = evaluation_env(speed, body, {"reset_noise_scale": noise})
        gait = trained.predict(speed, body)
        self.ref = resample_cycle(gait.time, gait.q, gait.tau, gait.speed, gait.duration, self.env)
        self.A, self.B = linearise(self.env, self.ref)

    def episodes(self, weights: Any, phase: str, prior: float, seeds: list[int]) -> Iterator[int]:
        """Episode lengths (control steps; < max_episode_steps: a fall) over ``seeds``."""
        from predictive.controller import run_controller_episode
        from predictive.generator.closed_loop import GaitTracker, periodic_lqr

        Q, R = weights.matrices()
        tracker = GaitTracker(self.ref, periodic_lqr(self.A, self.B, Q, R), np.sqrt(np.diag(Q)), phase, prior)
        for seed in seeds:
            ep = run_controller_episode(tracker, self.env, seed)
            yield ep.steps if not ep.fell else -ep.steps


def score(cases: list[Case], weights: Any, phase: str, prior: float, seeds: list[int], limit: int | None = None) -> tuple[int, float]:
    """(falls, mean episode length) over every case and seed; stops counting once ``limit`` falls
    are exceeded (then every episode not run counts as a fall)."""
    falls, steps, total = 0, [], len(cases) * len(seeds)
    for case in cases:
        for n in case.episodes(weights, phase, prior, seeds):
            falls += n < 0
            steps.append(abs(n))
            if limit is not None and falls > limit:
                return falls + total - len(steps), float(np.mean(steps))
    return falls, float(np.mean(steps))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--generators", type=Path, nargs="+", required=True, help="generator.pt files (falls are summed)")
    parser.add_argument("--speeds", type=float, nargs="+", default=[1.3, 2.2, 3.5])
    parser.add_argument("--seeds", type=_seeds, default=_seeds("100-119"), help="study reset seeds, e.g. 100-119")
    parser.add_argument("--noise", type=float, default=0.05, help="reset_noise_scale of the evaluation environment")
    parser.add_argument("--phases", nargs="+", default=["clock", "state:0", "state:1", "state:10"],
                        help="phase estimators compared first: clock or state:<phase_prior>")
    parser.add_argument("--passes", type=int, default=2, help="coordinate-descent passes over the weights")
    parser.add_argument("--factor", type=float, default=3.0, help="multiplicative step of a weight")
    parser.add_argument("--start", default="joint_rate=3", help="start weights, name=value,...")
    parser.add_argument("--start-from", type=Path, default=None,
                        help="a robustness config: start each speed from its tracker's scheduled weights instead")
    parser.add_argument("--out", type=Path, default=Path("results/tracker_study.json"))
    args = parser.parse_args(argv)

    from predictive.experiments.robustness import RobustnessConfig
    from predictive.generator.closed_loop import LQRWeights

    given = LQRWeights(**{k: float(v) for k, v in (p.split("=") for p in args.start.split(",") if p)})
    schedule = RobustnessConfig.from_yaml(args.start_from).tracker if args.start_from else None
    names = [f.name for f in dataclasses.fields(LQRWeights)]
    log: list[dict] = []
    chosen = {}
    t0 = time.perf_counter()
    n_episodes = len(args.generators) * len(args.seeds)
    for speed in args.speeds:
        cases = [Case(g, speed, args.noise) for g in args.generators]
        start_weights = schedule.weights_at(speed) if schedule else given

        def trial(kind: str, weights: Any, phase: str, prior: float, limit: int | None = None) -> tuple[int, float]:
            result = score(cases, weights, phase, prior, args.seeds, limit)  # noqa: B023 (used in this iteration only)
            log.append({"speed": speed, "kind": kind, "phase": phase, "phase_prior": prior,  # noqa: B023
                        "weights": dataclasses.asdict(weights), "falls": result[0], "mean_steps": result[1]})
            print(f"{speed:4.1f} m/s {kind:<8} {phase}:{prior:<5g} falls {result[0]:2d}/{n_episodes} "  # noqa: B023
                  f"mean steps {result[1]:6.0f}  {dataclasses.asdict(weights)}", flush=True)
            return result

        best_phase, best = ("clock", 1.0), None
        for text in args.phases:
            phase, _, prior_text = text.partition(":")
            prior = float(prior_text or 1.0)
            result = trial("phase", start_weights, phase, prior)
            if best is None or (result[0], -result[1]) < (best[0], -best[1]):
                best_phase, best = (phase, prior), result
        phase, prior = best_phase
        weights = start_weights
        for _ in range(args.passes):
            improved = False
            for name in names:
                for step in (args.factor, 1 / args.factor):
                    candidate = dataclasses.replace(weights, **{name: getattr(weights, name) * step})
                    result = trial("weights", candidate, phase, prior, limit=best[0])
                    if (result[0], -result[1]) < (best[0], -best[1]):
                        weights, best, improved = candidate, result, True
                        break
            if not improved:
                break
        chosen[speed] = {"phase": phase, "phase_prior": prior, "weights": dataclasses.asdict(weights),
                         "falls": best[0], "mean_steps": best[1]}
    wall = time.perf_counter() - t0
    print(f"\nchosen per speed ({len(args.generators)} generator(s), study seeds {args.seeds[0]}–{args.seeds[-1]}, "
          f"reset noise {args.noise}); {wall:.0f} s")
    print("tracker:\n  lqr:")
    for speed, c in chosen.items():
        w = ", ".join(f"{k}: {v:.4g}" for k, v in c["weights"].items())
        print(f"    - speed: {speed}\n      weights: {{{w}}}   # {c['falls']}/{n_episodes} falls, {c['phase']}:{c['phase_prior']:g}")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({"args": {k: str(v) for k, v in vars(args).items()}, "log": log,
                                    "chosen": {str(k): v for k, v in chosen.items()}, "wall_s": wall}, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
