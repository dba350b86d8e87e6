"""Deterministic episodes of a trained policy and the walking metrics computed from them.

Used by the evaluation callback during training (:mod:`agents.train`) and by ``python -m agents
evaluate``/``record`` (:mod:`agents.evaluate`), so both report the same numbers:

* ``distance`` (m): hip displacement over the episode (``info["distance"]``, 10 s at most);
* ``mean_speed`` (m/s): distance / episode duration;
* ``speed_error`` (m/s): mean speed − target speed;
* ``cost_of_transport``: the environment's mechanical CoT (joint work / (m·g·distance)), inf when
  the hip did not move forward;
* ``fell``: the episode terminated (hip too low, trunk tilted, or a physics failure) instead of
  being truncated at ``max_episode_steps``;
* ``foot_slide`` (m): how far the loaded feet slid over the ground, summed over both feet — a check
  that the policy walks rather than skates on the regularised friction. The environment's friction
  law F_x = −μ·tanh(v/v_s)·F_y gives the sliding speed of a foot from its ground reaction force,
  |v| = v_s·artanh(|F_x| / (μ·F_y)); it is integrated while the foot carries more than 0.1 body weight;
* ``cadence`` (steps/min): foot touchdowns per minute, both feet — a foot touches down when its
  vertical force rises above 0.2 body weight after having fallen below 0.05 body weight (human
  walking at 1.3 m/s: about 110 steps/min; vibrating or shuffling feet give far more or none).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import gymnasium
import numpy as np

#: A policy: observation (22,) float32 → action (6,) in [−1, 1].
PolicyFn = Callable[[np.ndarray], np.ndarray]


@dataclass
class EpisodeResult:
    """Outcome of one episode (SI units) and, when recorded, its time series and frames."""

    seed: int
    target_speed: float
    steps: int
    duration: float
    distance: float
    mean_speed: float
    speed_error: float
    cost_of_transport: float
    fell: bool
    episode_return: float
    foot_slide: float
    touchdowns: int
    traces: dict[str, np.ndarray] = field(default_factory=dict, repr=False)
    frames: list[np.ndarray] = field(default_factory=list, repr=False)

    @property
    def cadence(self) -> float:
        """Foot touchdowns per minute (both feet)."""
        return 60.0 * self.touchdowns / self.duration if self.duration > 0 else 0.0

    def metrics(self) -> dict[str, Any]:
        """JSON-friendly metrics (no traces or frames; inf CoT → None)."""
        cot = self.cost_of_transport
        return {
            "seed": self.seed,
            "target_speed": self.target_speed,
            "steps": self.steps,
            "duration_s": self.duration,
            "distance_m": self.distance,
            "mean_speed_m_s": self.mean_speed,
            "speed_error_m_s": self.speed_error,
            "cost_of_transport": cot if math.isfinite(cot) else None,
            "fell": self.fell,
            "return": self.episode_return,
            "foot_slide_m": self.foot_slide,
            "cadence_steps_per_min": self.cadence,
        }


def run_episode(
    policy: PolicyFn,
    env: gymnasium.Env,
    seed: int,
    target_speed: float | None = None,
    record_traces: bool = False,
    frame_every: int = 0,
    reset_options: dict[str, Any] | None = None,
) -> EpisodeResult:
    """Run one episode of ``policy`` in ``env`` from ``reset(seed=seed)`` until it ends.

    Args:
        policy: deterministic map from observation to action.
        env: a SagittalWalker environment (``render_mode="rgb_array"`` when ``frame_every > 0``).
        seed: reset seed (initial-state noise).
        target_speed: m/s, passed as ``reset(options={"target_speed": ...})``; None keeps the env's.
        record_traces: keep time series of joint angles (rad), actuator torques (N·m) and ground
            reaction forces (N) under ``traces`` (keys ``time``, ``angles``, ``torques``, ``grf``,
            ``speed``, and the full state ``q``, ``u`` after each step).
        frame_every: keep every ``frame_every``-th rendered frame (0: none).
        reset_options: further ``reset`` options (e.g. ``{"initial_state": (q, u)}``).
    """
    options = dict(reset_options or {})
    if target_speed is not None:
        options["target_speed"] = float(target_speed)
    obs, info = env.reset(seed=seed, options=options or None)
    target = float(info["target_speed"])
    unwrapped = env.unwrapped
    dt = float(unwrapped.dt)
    angles: list[np.ndarray] = []
    torques: list[np.ndarray] = []
    grfs: list[np.ndarray] = []
    speeds: list[float] = []
    states: list[np.ndarray] = []
    frames: list[np.ndarray] = []
    if frame_every:
        frames.append(env.render())
    mu, v_s = float(unwrapped.contact.friction), float(unwrapped.contact.slip_velocity)
    body_weight = float(unwrapped.body.body_weight)
    slide = 0.0
    airborne = [False, False]  # per foot: unloaded since its last touchdown
    touchdowns = 0
    total = 0.0
    steps = 0
    terminated = truncated = False
    while not (terminated or truncated):
        obs, reward, terminated, truncated, info = env.step(policy(obs))
        total += float(reward)
        steps += 1
        grf = np.asarray(info["grf"])
        slide += dt * foot_slide_speed(grf, mu, v_s, body_weight)
        for foot, fy in enumerate((grf[1], grf[3])):
            if fy < 0.05 * body_weight:
                airborne[foot] = True
            elif fy > 0.2 * body_weight and airborne[foot]:
                airborne[foot] = False
                touchdowns += 1
        if record_traces:
            q, u = unwrapped.state
            angles.append(q[3:])
            states.append(np.concatenate([q, u]))
            torques.append(np.asarray(info["torques"]))
            grfs.append(np.asarray(info["grf"]))
            speeds.append(float(info["speed"]))
        if frame_every and steps % frame_every == 0:
            frames.append(env.render())
    duration = round(steps * dt, 9)
    distance = float(info["distance"])
    mean_speed = distance / duration
    traces: dict[str, np.ndarray] = {}
    if record_traces:
        traces = {
            "time": dt * np.arange(1, steps + 1),
            "angles": np.asarray(angles),
            "torques": np.asarray(torques),
            "grf": np.asarray(grfs),
            "speed": np.asarray(speeds),
            "q": np.asarray(states)[:, :9],
            "u": np.asarray(states)[:, 9:],
        }
    return EpisodeResult(
        seed=seed,
        target_speed=target,
        steps=steps,
        duration=duration,
        distance=distance,
        mean_speed=mean_speed,
        speed_error=mean_speed - target,
        cost_of_transport=float(info["cost_of_transport"]),
        fell=bool(terminated),
        episode_return=total,
        foot_slide=slide,
        touchdowns=touchdowns,
        traces=traces,
        frames=frames,
    )


def foot_slide_speed(grf: np.ndarray, mu: float, slip_velocity: float, body_weight: float,
                     min_load: float = 0.1) -> float:
    """Sum over both feet of the sliding speed (m/s) implied by the friction law, for feet loaded
    with more than ``min_load`` body weights; ``grf`` is (Fx_r, Fy_r, Fx_l, Fy_l) in N."""
    speed = 0.0
    for fx, fy in ((grf[0], grf[1]), (grf[2], grf[3])):
        if fy > min_load * body_weight:
            speed += slip_velocity * math.atanh(min(abs(fx) / (mu * fy), 1.0 - 1e-9))
    return speed


def summarize(results: list[EpisodeResult]) -> dict[str, Any]:
    """Means over episodes (CoT over the episodes where it is finite) and fall counts."""
    cots = [r.cost_of_transport for r in results if math.isfinite(r.cost_of_transport)]
    return {
        "episodes": len(results),
        "mean_distance_m": float(np.mean([r.distance for r in results])),
        "min_distance_m": float(np.min([r.distance for r in results])),
        "mean_speed_m_s": float(np.mean([r.mean_speed for r in results])),
        "mean_abs_speed_error_m_s": float(np.mean([abs(r.speed_error) for r in results])),
        "mean_cost_of_transport": float(np.mean(cots)) if cots else None,
        "falls": int(sum(r.fell for r in results)),
        "mean_return": float(np.mean([r.episode_return for r in results])),
        "mean_steps": float(np.mean([r.steps for r in results])),
        "mean_foot_slide_m": float(np.mean([r.foot_slide for r in results])),
        "mean_cadence_steps_per_min": float(np.mean([r.cadence for r in results])),
    }
