"""Controller sources: a controller for a new speed or body is one call.

``GeneratorControllers.from_file("runs/generator/generator.pt").controller_for(speed=2.2, body=body)``
generates the gait cycle (one forward pass of the self-supervised generator, optionally a brief
fine-tune), resamples it onto the environment's control grid and builds its LQR tracker
(:class:`predictive.generator.closed_loop.GaitTracker`, the gain schedule and phase estimation of
:class:`~predictive.generator.closed_loop.TrackerSettings`). :class:`OCPControllers` does the same
with a predictive OCP solution. Both follow :class:`predictive.controller.ControllerSource`.

The environment the controller is built for (its physics, contact model, actuator strength and
default body) is a :class:`envs.config.WalkerConfig` (``env_config``; default: the environment's
defaults); evaluation may then run the controller in another one (mismatch studies).
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from envs.config import WalkerConfig
from envs.sagittal_walker import SagittalWalkerEnv
from predictive.generator.closed_loop import GaitTracker, TrackerSettings, resample_cycle
from predictive.generator.gait_generator import GaitGenerator
from predictive.ocp.solution import GaitSolution
from sspinn.model.body import BodyParameters


def model_env(env_config: WalkerConfig | None, speed: float, body: BodyParameters | None = None) -> SagittalWalkerEnv:
    """The environment a controller is built for: ``env_config`` (None: defaults) at ``speed``
    (m/s), with ``body`` replacing its body when given."""
    base = env_config or WalkerConfig()
    overrides: dict[str, Any] = {"target_speed": float(speed)}
    if body is not None:
        defaults = WalkerConfig()
        overrides.update(body=body, height=defaults.height, mass=defaults.mass)
    return SagittalWalkerEnv(config=dataclasses.replace(base, **overrides))


def track(solution: GaitSolution, env: SagittalWalkerEnv, settings: TrackerSettings, plan_time_s: float, note: str) -> GaitTracker:
    """The LQR tracker of a gait cycle in ``env`` with the scheduled weights at its speed; its
    ``info`` holds the plan, the times (s) to obtain it and to build the tracker, and ``note``."""
    start = time.perf_counter()
    ref = resample_cycle(solution.time, solution.q, solution.tau, solution.speed, solution.duration, env)
    tracker = GaitTracker.build(env, ref, settings.weights_at(solution.speed), settings.phase, settings.phase_prior,
                                settings.start, settings.start_height_error)
    tracker.info.update(plan=solution, plan_time_s=plan_time_s, lqr_time_s=time.perf_counter() - start, note=note)
    return tracker


@dataclass
class GeneratorControllers:
    """Gait trackers of a trained self-supervised gait generator.

    Attributes:
        generator: the trained generator (:meth:`GaitGenerator.load`).
        tracker: gain schedule and phase estimation. refine_iterations: per-gait L-BFGS fine-tune
            (0: one forward pass) with the Kane weight × ``refine_kane_factor``.
        env_config: the environment the controllers are built for (None: defaults).
    """

    generator: GaitGenerator
    tracker: TrackerSettings = field(default_factory=TrackerSettings)
    refine_iterations: int = 0
    refine_kane_factor: float = 10.0
    env_config: WalkerConfig | None = None

    @classmethod
    def from_file(cls, path: str | Path, **kwargs: Any) -> GeneratorControllers:
        """The controllers of the generator saved at ``path`` (other fields as keywords)."""
        return cls(GaitGenerator.load(path), **kwargs)

    @property
    def training_time_s(self) -> float:
        """The generator's training wall time (s; NaN if unknown)."""
        return self.generator.training_wall_s_

    def controller_for(self, speed: float, body: BodyParameters | None = None) -> GaitTracker:
        env = model_env(self.env_config, speed, body)
        start = time.perf_counter()
        solution = self.generator.predict(speed, env.body, refine_iterations=self.refine_iterations,
                                          refine_kane_factor=self.refine_kane_factor)
        note = f"kane rms {solution.settings['kane_rms_bw']:.3g} BW"
        return track(solution, env, self.tracker, time.perf_counter() - start, note)


@dataclass
class OCPControllers:
    """Gait trackers of predictive OCP solutions (:func:`predictive.ocp.collocation.solve_predictive`
    with the environment's contact model); ``controller_for`` raises
    :class:`predictive.ocp.collocation.OCPError` when IPOPT fails.

    Attributes:
        n_nodes: collocation nodes per half cycle. tracker, env_config: as :class:`GeneratorControllers`.
    """

    n_nodes: int = 100
    tracker: TrackerSettings = field(default_factory=TrackerSettings)
    env_config: WalkerConfig | None = None

    def controller_for(self, speed: float, body: BodyParameters | None = None) -> GaitTracker:
        from predictive.ocp.collocation import solve_predictive

        env = model_env(self.env_config, speed, body)
        start = time.perf_counter()
        solution = solve_predictive(speed, env.body, contact=env.contact, n_nodes=self.n_nodes)
        return track(solution, env, self.tracker, time.perf_counter() - start, f"IPOPT {solution.iterations} it.")


__all__ = ["GeneratorControllers", "OCPControllers", "model_env", "track"]
