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
* the gait quality of :func:`sspinn.data.gait_metrics.gait_metrics` (``gait``), computed from the
  episode's 100 Hz samples after the first :data:`GAIT_SETTLE_S` s (gait initiation from standing):
  left/right asymmetry of step time, step length and stance % (symmetry index, %), foot sliding
  per step (cm; ``foot_slide_m`` the total), impact peak (BW), hip/knee/ankle angle RMSD to Winter's
  normal walking (deg, mean over the legs with strides, when a reference is given:
  :func:`sspinn.data.gait_metrics.winter_or_none`),
  cadence (steps/min; human walking at 1.3 m/s: about 110), flight (% of the time), double support
  (% of the stride), taps (contacts too short to be stances, per step), distance per step (m) and
  the mechanical cost of transport;
* :func:`walking_target_misses`: the walking targets
  (:data:`sspinn.data.gait_metrics.WALKING_TARGETS`) the episodes miss.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Protocol

import gymnasium
import numpy as np

from sspinn.data.gait_metrics import WALKING_TARGETS, GaitMetrics, ReferenceGait, gait_metrics
from sspinn.model.dynamics import contact_forces
from sspinn.model.trajectory import Trajectory

#: A policy: observation (22,) float32 → action (6,) in [−1, 1].
PolicyFn = Callable[[np.ndarray], np.ndarray]


class Predictor(Protocol):
    """A policy with memory, in SB3's convention (e.g. :class:`agents.checkpoints.LoadedAgent`)."""

    def predict(self, observation: np.ndarray, state: Any = None, episode_start: Any = None,
                deterministic: bool = True) -> tuple[np.ndarray, Any]: ...
#: Gait events before this time (s after reset) are left out of the gait metrics: gait initiation.
GAIT_SETTLE_S = 1.0


@dataclass
class EpisodeResult:
    """Outcome of one episode (SI units), its motion as the project's
    :class:`~sspinn.model.trajectory.Trajectory` (``trajectory``: the reset state first, then the
    state after each step; ``tau[k]`` the actuator torque held from sample k to k + 1) and, when
    recorded, its frames."""

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
    gait: GaitMetrics
    trajectory: Trajectory | None = field(default=None, repr=False)
    frames: list[np.ndarray] = field(default_factory=list, repr=False)

    @property
    def foot_slide(self) -> float:
        """Total sliding of the feet's contact points, m (:attr:`gait`)."""
        return self.gait.foot_slide_m

    @property
    def cadence(self) -> float:
        """Steps per minute (:attr:`gait`; NaN without steps)."""
        return self.gait.cadence_steps_per_min

    def metrics(self) -> dict[str, Any]:
        """JSON-friendly metrics (no traces or frames; inf/NaN → None), the gait metrics included."""
        cot = self.cost_of_transport
        gait = self.gait.as_dict()
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
            "foot_slide_m": gait["foot_slide_m"],
            "cadence_steps_per_min": gait["cadence_steps_per_min"],
            **{k: v for k, v in gait.items() if k not in ("foot_slide_m", "cadence_steps_per_min", "cost_of_transport")},
        }


def run_episode(
    policy: PolicyFn | Predictor,
    env: gymnasium.Env,
    seed: int,
    target_speed: float | None = None,
    frame_every: int = 0,
    reset_options: dict[str, Any] | None = None,
    reference: ReferenceGait | None = None,
) -> EpisodeResult:
    """Run one episode of ``policy`` in ``env`` from ``reset(seed=seed)`` until it ends.

    Args:
        policy: deterministic map from observation to action, or an object with SB3's
            ``predict(observation, state, episode_start)``, whose state starts with this episode.
        env: a SagittalWalker environment (``render_mode="rgb_array"`` when ``frame_every > 0``).
        seed: reset seed (initial-state noise).
        target_speed: m/s, passed as ``reset(options={"target_speed": ...})``; None keeps the env's.
        frame_every: keep every ``frame_every``-th rendered frame (0: none).
        reset_options: further ``reset`` options (e.g. ``{"initial_state": (q, u)}``; by default
            the policy's ``initial_state`` attribute where it has one that is not None).
        reference: reference cycle for the gait metrics' angle RMSD (e.g. Winter's walking).
    """
    options = dict(reset_options or {})
    initial = getattr(policy, "initial_state", None)
    if initial is not None:  # a policy that starts on its own reference (agents.checkpoints.LoadedAgent)
        options.setdefault("initial_state", initial)
    if target_speed is not None:
        options["target_speed"] = float(target_speed)
    obs, info = env.reset(seed=seed, options=options or None)
    target = float(info["target_speed"])
    unwrapped = env.unwrapped
    dt = float(unwrapped.dt)
    frames: list[np.ndarray] = []
    if frame_every:
        frames.append(env.render())
    q0, u0 = unwrapped.state
    samples_q, samples_u, samples_grf, samples_tau = [q0], [u0], [], []
    total = 0.0
    steps = 0
    terminated = truncated = False
    predict = getattr(policy, "predict", None)
    state, start = None, True
    while not (terminated or truncated):
        if predict is not None:
            action, state = predict(obs, state, episode_start=start)
            start = False
        else:
            action = policy(obs)  # type: ignore[operator]
        obs, reward, terminated, truncated, info = env.step(action)
        total += float(reward)
        steps += 1
        q, u = unwrapped.state
        samples_q.append(q)
        samples_u.append(u)
        samples_grf.append(np.asarray(info["grf"]))
        samples_tau.append(np.asarray(info["torques"]))
        if frame_every and steps % frame_every == 0:
            frames.append(env.render())
    duration = round(steps * dt, 9)
    distance = float(info["distance"])
    mean_speed = distance / duration
    trajectory = _trajectory(unwrapped, samples_q, samples_u, samples_grf, samples_tau)
    gait = gait_metrics(trajectory, unwrapped.body,
                        reference=reference, settle_s=GAIT_SETTLE_S)
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
        gait=gait,
        trajectory=trajectory,
        frames=frames,
    )


def _trajectory(env: Any, q: list[np.ndarray], u: list[np.ndarray], grf: list[np.ndarray],
                tau: list[np.ndarray]) -> Trajectory:
    """The episode as a :class:`~sspinn.model.trajectory.Trajectory` at the 100 Hz samples (reset state
    first): the environment's contact forces after each step (the contact model's at the reset
    state), contact fractions of the contact model, ``tau[k]`` the actuator torque held from sample
    k to k + 1 (zero at the last sample)."""
    q_arr, u_arr = np.asarray(q), np.asarray(u)
    forces, w = contact_forces(q_arr, u_arr, env.body, env.contact)
    forces = np.asarray(forces)
    forces[1:] = np.asarray(grf).reshape(-1, 4)
    torques = np.vstack([np.asarray(tau).reshape(-1, 6), np.zeros((1, 6))])
    time = env.dt * np.arange(len(q_arr))
    return Trajectory(time=time, q=q_arr, u=u_arr, qdd=np.zeros_like(q_arr), tau=torques, grf=forces, w=np.asarray(w))


#: Gait metrics averaged by :func:`summarize` (``mean_<name>``; over the episodes where defined).
SUMMARY_GAIT_KEYS: tuple[str, ...] = (
    "step_time_asymmetry", "step_length_asymmetry", "stance_asymmetry", "contact_asymmetry", "foot_slide_per_step_cm",
    "peak_impact_bw", "flight_percent", "double_support_percent", "taps_per_step", "distance_per_step_m",
    "max_vertical_grf_bw", "rmsd_hip_deg", "rmsd_knee_deg", "rmsd_ankle_deg",
)


def walking_target_misses(results: list[EpisodeResult]) -> list[str]:
    """The walking targets (:data:`sspinn.data.gait_metrics.WALKING_TARGETS`, one definition) the
    episodes miss: the falls over all episodes, then every other target per episode as ``"seed s:
    …"``; empty when every target is met."""
    falls = sum(r.fell for r in results)
    out = [f"falls {falls} / {len(results)} > {WALKING_TARGETS.max_falls}"] if falls > WALKING_TARGETS.max_falls else []
    for r in results:
        out += [f"seed {r.seed}: {miss}" for miss in WALKING_TARGETS.misses(r.gait, distance_m=r.distance, duration_s=r.duration)]
    return out


def _finite_mean(values: list[float]) -> float | None:
    finite = [v for v in values if v is not None and math.isfinite(v)]
    return float(np.mean(finite)) if finite else None


def summarize(results: list[EpisodeResult]) -> dict[str, Any]:
    """Means over episodes (CoT and gait metrics over the episodes where they are finite) and fall counts."""
    cots = [r.cost_of_transport for r in results if math.isfinite(r.cost_of_transport)]
    gait = {f"mean_{key}": _finite_mean([getattr(r.gait, key) for r in results]) for key in SUMMARY_GAIT_KEYS}
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
        "mean_cadence_steps_per_min": _finite_mean([r.cadence for r in results]),
        **gait,
    }
