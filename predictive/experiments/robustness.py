"""Robustness of the generator's controllers: falls per generator, speed and reset seed.

``python -m predictive robustness --config configs/predictive/robustness.yaml --out results/robustness``

For every trained generator (several training seeds), speed and reset seed: one forward pass of
the generator (or its configured fine-tune) → a gait tracker (:mod:`predictive.generator.controllers`,
``controller_for(speed, body)``), then one 10 s episode in an environment that may differ from the
one the controller was built for. The disturbances are plain data, so new ones plug in without
code here:

* ``env``: :class:`envs.config.WalkerConfig` overrides of the evaluation environment (e.g.
  ``reset_noise_scale: 0.05``, ten times the default initial-state noise; any other field the
  environment's configuration has, such as its actuator strength ``max_torque``);
* ``reset_options``: passed to every ``env.reset(options=...)`` next to the controller's start
  state.

The controller is always built for the nominal environment (the task's body, default physics).
A success is an episode that is truncated at its end (10 s) without a fall. The trivial baseline
printed beside the table is the same generator's gait replayed open loop (feedforward only, phase
by the clock), which shows how much of the result the feedback earns.
"""

from __future__ import annotations

import dataclasses
import json
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from envs.config import WalkerConfig
from envs.sagittal_walker import SagittalWalkerEnv
from predictive.controller import ControllerSource, run_controller_episode
from predictive.generator.closed_loop import GaitTracker, TrackerSettings
from predictive.generator.controllers import GeneratorControllers
from predictive.synth.cache import jsonable
from sspinn.model.body import BodyParameters
from sspinn.run_folder import RunLock, atomic_write_text
from sspinn.yaml_config import load_config


@dataclass
class RobustnessConfig:
    """``configs/predictive/robustness.yaml`` (section ``robustness``).

    Attributes:
        generators: generator.pt files (e.g. one per training seed).
        speeds: m/s. seeds: reset seeds. height (m), mass (kg): the body.
        env: WalkerConfig overrides of the evaluation environment (plain data).
        reset_options: extra ``env.reset`` options (plain data).
        tracker: gain schedule and phase estimation of the trackers.
        refine_iterations, refine_kane_factor: per-gait fine-tune (0: one forward pass).
        open_loop_baseline: also run the trivial baseline (feedforward only).
    """

    generators: list[str] = field(default_factory=list)
    speeds: list[float] = field(default_factory=lambda: [1.3, 2.2, 3.5])
    seeds: list[int] = field(default_factory=lambda: [0, 1, 2, 3, 4])
    height: float = 1.75
    mass: float = 70.0
    env: dict[str, Any] = field(default_factory=lambda: {"reset_noise_scale": 0.05})
    reset_options: dict[str, Any] = field(default_factory=dict)
    tracker: TrackerSettings = field(default_factory=TrackerSettings)
    refine_iterations: int = 0
    refine_kane_factor: float = 10.0
    open_loop_baseline: bool = True

    def __post_init__(self) -> None:
        if isinstance(self.tracker, dict):
            self.tracker = TrackerSettings(**self.tracker)
        if not self.generators:
            raise ValueError("generators: give at least one generator.pt")
        if not self.speeds or any(not (0 < v <= 12) for v in self.speeds):
            raise ValueError(f"speeds must be a non-empty list of m/s in (0, 12], got {self.speeds}")
        if not self.seeds:
            raise ValueError("seeds must not be empty")
        WalkerConfig.resolve(None, **self.env)  # unknown or invalid environment overrides fail here

    @classmethod
    def from_yaml(cls, path: str | Path, settings: list[str] | None = None) -> RobustnessConfig:
        return load_config(cls, path, "robustness", settings=settings or ())


def evaluation_env(speed: float, body: BodyParameters, env: dict[str, Any] | None = None) -> SagittalWalkerEnv:
    """The environment of the evaluation: ``body`` at ``speed`` with the overrides ``env``."""
    return SagittalWalkerEnv(config=WalkerConfig.resolve(None, body=body, **{**(env or {}), "target_speed": float(speed)}))


def evaluate(
    source: ControllerSource, speeds: list[float], seeds: list[int], body: BodyParameters,
    env: dict[str, Any] | None = None, reset_options: dict[str, Any] | None = None,
) -> list[dict[str, Any]]:
    """One episode per (speed, seed) of ``source.controller_for(speed, body)`` in
    :func:`evaluation_env` with ``reset_options``: rows with speed, seed, fell, steps, distance_m,
    and the time (s) to build the controller."""
    rows = []
    for speed in speeds:
        start = time.perf_counter()
        controller = source.controller_for(speed, body)
        build_s = time.perf_counter() - start
        sim = evaluation_env(speed, body, env)
        for seed in seeds:
            ep = run_controller_episode(controller, sim, seed, reset_options)
            rows.append({"speed": float(speed), "seed": int(seed), "fell": ep.fell, "steps": ep.steps,
                         "distance_m": ep.distance_m, "build_s": build_s})
    return rows


class OpenLoop:
    """The trivial baseline: a tracker's feedforward replayed by the clock from the tracker's start
    sample, no feedback."""

    def __init__(self, source: ControllerSource) -> None:
        self.source = source

    def controller_for(self, speed: float, body: BodyParameters | None = None) -> GaitTracker:
        tracker = self.source.controller_for(speed, body)
        return GaitTracker(tracker.reference, np.zeros_like(tracker.gains), phase="clock", start=tracker.start)


def run_robustness(config: RobustnessConfig, out: str | Path) -> dict[str, Any]:
    """Evaluate every generator; write ``results.json`` and ``report.md`` to ``out`` (owned by this
    run while it runs, :class:`sspinn.run_folder.RunLock`)."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    with RunLock(out):
        return _run_robustness(config, out)


def _run_robustness(config: RobustnessConfig, out: Path) -> dict[str, Any]:
    body = BodyParameters.from_anthropometry(config.height, config.mass)
    results: dict[str, Any] = {"config": jsonable(dataclasses.asdict(config)), "tracked": {}, "open_loop": {}}
    for path in config.generators:
        source = GeneratorControllers.from_file(path, tracker=config.tracker, refine_iterations=config.refine_iterations,
                                                refine_kane_factor=config.refine_kane_factor)
        print(f"[robustness] {path} …", flush=True)
        results["tracked"][path] = evaluate(source, config.speeds, config.seeds, body, config.env, config.reset_options)
        if config.open_loop_baseline:
            results["open_loop"][path] = evaluate(OpenLoop(source), config.speeds, config.seeds, body, config.env,
                                                  config.reset_options)
    atomic_write_text(out / "results.json", json.dumps(results, indent=2))
    atomic_write_text(out / "report.md", report(config, results))
    return results


def report(config: RobustnessConfig, results: dict[str, Any]) -> str:
    """Markdown: successes per generator and speed with every seed's outcome (✓, or the fall time
    in s), and the open-loop baseline's successes."""
    lines = [
        f"Successes (10 s without a fall) per generator and speed; reset seeds {config.seeds}; "
        f"environment overrides {config.env or {}}; reset options {config.reset_options or {}}; "
        f"{'one forward pass' if not config.refine_iterations else f'{config.refine_iterations}-iteration fine-tune'} "
        "+ LQR tracker. Per seed: ✓ or the time of the fall (s).", "",
        "| generator | " + " | ".join(f"{v} m/s" for v in config.speeds) + " | open loop (baseline) |",
        "|---|" + "---|" * (len(config.speeds) + 1),
    ]
    totals = {v: [0, 0] for v in config.speeds}
    for path, rows in results["tracked"].items():
        cells = []
        for v in config.speeds:
            mine = [r for r in rows if r["speed"] == v]
            ok = sum(not r["fell"] for r in mine)
            totals[v][0] += ok
            totals[v][1] += len(mine)
            marks = " ".join("✓" if not r["fell"] else f"{r['steps'] / 100:.1f}" for r in mine)
            cells.append(f"{ok}/{len(mine)} ({marks})")
        base = results["open_loop"].get(path)
        base_txt = "–" if base is None else f"{sum(not r['fell'] for r in base)}/{len(base)}"
        lines.append(f"| {path} | " + " | ".join(cells) + f" | {base_txt} |")
    lines.append("| all | " + " | ".join(f"{ok}/{n}" for ok, n in totals.values()) + " | |")
    return "\n".join(lines) + "\n"



__all__ = ["OpenLoop", "RobustnessConfig", "evaluate", "evaluation_env", "report", "run_robustness"]
