"""Closed-loop deployment of a periodic gait in the Gymnasium environment.

A gait cycle — from trajectory optimisation (:mod:`predictive.ocp.collocation`) or from the
self-supervised gait generator (:mod:`predictive.generator.gait_generator`) — is only a plan: replayed open
loop, any mismatch (the environment's discrete integration, passive joint moments, initial-state
noise) makes the body fall within a few steps. Both are therefore deployed the same way, by a
**feedforward + periodic time-varying LQR** controller:

    a_k = a_ff[i_k] + K_{i_k} · (z_ref[i_k] − z_k),

with the environment's own action scaling (a = τ / τ_max, clipped to [−1, 1] by the environment)
and i_k the gait phase (sample of the cycle) — by default estimated from the state at every step
(the cycle sample nearest to z_k in the LQR's metric, kept close to i_{k−1} + 1; see
:class:`GaitTracker`), so the controller re-synchronises with the body after a disturbance and
needs no step counter.

* The reference is the cycle resampled on the control grid t_k = k·0.01 s. The cycle is time-scaled
  by N·dt / T (N = round(T / dt) samples) so that it repeats after a whole number of control
  steps; the average speed is kept (the stride length changes by the same < 0.5 %).
* z = observation[:17] = (pelvis_ty, pelvis_tilt, 6 joint angles, 9 speeds): every state except the
  absolute horizontal position, on which the dynamics do not depend (flat ground). The controller
  uses nothing but the observation and its phase, which it returns to the caller as SB3 policies
  return their memory (:mod:`predictive.controller`).
* a_ff: the cycle's joint torques at the middle of each control interval, minus the environment's
  passive joint moments at that reference state (they are added by the environment), divided by
  the environment's torque limits.
* K_i: the discrete-time LQR gains of the environment's step map (100 Hz, its own integrator and
  contact model) linearised around the reference by central finite differences, from the
  periodic Riccati recursion iterated backward over cycles until the gains converge. Its
  weights may depend on the speed (a gain schedule, :class:`TrackerSettings`).
* The start: an episode starts on the cycle at the sample whose start the closed loop on the
  announced model survives best with the pelvis a few cm too high and too low (:func:`start_costs`,
  ``TrackerSettings.start``) — under initial-state noise the start decides most falls.

Why this and not a PD law on the joints: the model is underactuated (pelvis x, y, tilt) and the
trunk is balanced only through the hip torques and the ground; joint-space PD feedback leaves the
trunk orientation and the forward speed uncontrolled. LQR on the full linearised model couples
them, and it costs about a second to compute per gait.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields
from typing import Any

import numpy as np
from scipy.interpolate import CubicSpline

from predictive.controller import episode_starts
from sspinn.model.conventions import N_Q, N_TAU

#: Size of the controlled state z (observation entries 0–16).
N_Z = 2 * N_Q - 1


@dataclass
class GaitReference:
    """One gait cycle on the control grid (N samples, period N·dt).

    Attributes:
        q, u: (N, 9) coordinates and speeds at t_k = k·dt (SI; pelvis_tx = speed·t_k + periodic).
        action: (N, 6) feedforward normalised actions (torque / τ_max, not clipped) held over
            [t_k, t_k + dt).
        speed: average forward speed, m/s.
        dt: control interval, s.
        source: where the cycle came from (free text).
    """

    q: np.ndarray
    u: np.ndarray
    action: np.ndarray
    speed: float
    dt: float
    source: str = ""

    @property
    def n(self) -> int:
        return len(self.q)

    @property
    def period(self) -> float:
        return self.n * self.dt

    @property
    def z(self) -> np.ndarray:
        """(N, 17) controlled states (observation order)."""
        return np.concatenate([self.q[:, 1:], self.u], axis=1)


def resample_cycle(
    time: np.ndarray, q: np.ndarray, tau: np.ndarray, speed: float, duration: float, env: Any, source: str = ""
) -> GaitReference:
    """Resample a periodic cycle onto ``env``'s control grid (see the module docstring).

    Args:
        time: (n,) sample times in [0, duration), s. q: (n, 9) coordinates. tau: (n, 6) total
            joint torques (N·m) that, with the cycle's ground forces, satisfy its dynamics.
        speed: average forward speed (m/s); duration: cycle duration T (s).
        env: a :class:`envs.sagittal_walker.SagittalWalkerEnv` or a wrapper of one (its public
            ``dt``, ``tau_max`` and ``passive_torque``).
    """
    e = _unwrapped(env)
    dt = float(e.dt)
    n = max(int(round(duration / dt)), 4)
    phase = np.append(np.asarray(time, float), duration) / duration  # 0 … 1
    periodic_q = np.asarray(q, float).copy()
    periodic_q[:, 0] -= speed * np.asarray(time, float)
    periodic_q = np.vstack([periodic_q, periodic_q[:1]])
    spline = CubicSpline(phase, periodic_q, bc_type="periodic", axis=0)
    s = np.arange(n) / n
    q_ref = spline(s)
    u_ref = spline(s, 1) / (n * dt)
    t_ref = np.arange(n) * dt
    q_ref[:, 0] += speed * t_ref
    u_ref[:, 0] += speed
    tau_cycle = np.vstack([tau, tau[:1]])
    mid = (np.arange(n) + 0.5) / n
    tau_mid = np.stack([np.interp(mid, phase, tau_cycle[:, j]) for j in range(N_TAU)], axis=1)
    q_mid, u_mid = spline(mid), spline(mid, 1) / (n * dt)
    tau_passive = e.passive_torque(q_mid[:, 3:], u_mid[:, 3:])
    return GaitReference(q_ref, u_ref, (tau_mid - tau_passive) / e.tau_max, float(speed), dt, source)


def _unwrapped(env: Any) -> Any:
    return getattr(env, "unwrapped", env)


def step_map(env: Any, z: np.ndarray, action: np.ndarray) -> np.ndarray:
    """The environment's state transition over one control interval, on the reduced state z (17,):
    ``env.step_state`` (the same physics as ``env.step``, actions clipped) from pelvis_tx = 0."""
    q = np.concatenate([[0.0], z[: N_Q - 1]])
    q, u, _ = _unwrapped(env).step_state(q, z[N_Q - 1 :], action)
    return np.concatenate([q[1:], u])


def linearise(env: Any, ref: GaitReference, eps: float = 1e-6) -> tuple[np.ndarray, np.ndarray]:
    """(A (N, 17, 17), B (N, 17, 6)) of :func:`step_map` at each reference sample by central
    differences (actions are perturbed inside the clipping range)."""
    z_ref = ref.z
    A = np.empty((ref.n, N_Z, N_Z))
    B = np.empty((ref.n, N_Z, N_TAU))
    for i in range(ref.n):
        z, a = z_ref[i], np.clip(ref.action[i], -1 + 2 * eps, 1 - 2 * eps)
        for j in range(N_Z):
            d = np.zeros(N_Z)
            d[j] = eps
            A[i, :, j] = (step_map(env, z + d, a) - step_map(env, z - d, a)) / (2 * eps)
        for j in range(N_TAU):
            d = np.zeros(N_TAU)
            d[j] = eps
            B[i, :, j] = (step_map(env, z, a + d) - step_map(env, z, a - d)) / (2 * eps)
    return A, B


@dataclass(frozen=True)
class LQRWeights:
    """Characteristic deviations of the LQR cost (Bryson's rule: weight = 1 / scale²).

    Attributes:
        height: pelvis_ty, m. tilt: pelvis_tilt, rad. joint: joint angles, rad.
        forward_speed, vertical_speed: m/s. tilt_rate, joint_rate: rad/s.
        action: normalised action (dimensionless, τ / τ_max).
    """

    height: float = 0.02
    tilt: float = 0.05
    joint: float = 0.1
    forward_speed: float = 0.1
    vertical_speed: float = 0.2
    tilt_rate: float = 0.5
    joint_rate: float = 1.0
    action: float = 0.2

    def matrices(self) -> tuple[np.ndarray, np.ndarray]:
        scales = np.array(
            [self.height, self.tilt, *[self.joint] * N_TAU, self.forward_speed, self.vertical_speed, self.tilt_rate,
             *[self.joint_rate] * N_TAU]
        )
        return np.diag(1 / scales**2), np.eye(N_TAU) / self.action**2


def periodic_lqr(A: np.ndarray, B: np.ndarray, Q: np.ndarray, R: np.ndarray, max_cycles: int = 50, tol: float = 1e-6) -> np.ndarray:
    """Gains K (N, 6, 17) of the periodic discrete-time LQR problem: the Riccati recursion
    P_i = Q + A_iᵀ P_{i+1} (A_i − B_i K_i), K_i = (R + B_iᵀ P_{i+1} B_i)⁻¹ B_iᵀ P_{i+1} A_i,
    swept backward over the cycle until the gains change by less than ``tol`` (relative)."""
    n = len(A)
    P = Q.copy()
    K = np.zeros((n, B.shape[2], A.shape[1]))
    for _ in range(max_cycles):
        previous = K.copy()
        for i in reversed(range(n)):
            BtP = B[i].T @ P
            K[i] = np.linalg.solve(R + BtP @ B[i], BtP @ A[i])
            P = Q + A[i].T @ P @ (A[i] - B[i] @ K[i])
            P = 0.5 * (P + P.T)
        if np.abs(K - previous).max() <= tol * max(np.abs(K).max(), 1.0):
            break
    return K


@dataclass(frozen=True)
class WeightsAtSpeed:
    """One point of an LQR gain schedule: the weights used at ``speed`` (m/s)."""

    speed: float
    weights: LQRWeights = field(default_factory=LQRWeights)

    def __post_init__(self) -> None:
        if isinstance(self.weights, dict):
            object.__setattr__(self, "weights", LQRWeights(**self.weights))
        if not (math.isfinite(self.speed) and self.speed > 0):
            raise ValueError(f"lqr schedule: speed must be > 0 m/s, got {self.speed}")


#: Ways a tracker finds its place on the cycle (see :class:`GaitTracker`).
PHASE_MODES = ("state", "clock")

#: Where on its cycle a tracker starts an episode (see :class:`TrackerSettings`).
START_MODES = ("least_sensitive", "cycle_start")


@dataclass
class TrackerSettings:
    """How gait cycles are tracked (``tracker:`` in ``configs/predictive/*.yaml``).

    Attributes:
        lqr: the gain schedule over speed: LQR weights at some speeds (m/s); at a speed between two
            entries every characteristic deviation is interpolated log-linearly in speed, beyond the
            ends the nearest entry holds.
        phase: "state" (the phase is estimated from the observation at every step,
            :meth:`GaitTracker.phase_of`) or "clock" (phase ``start`` at the episode start, then one
            control step per step).
        phase_prior: λ of the "state" estimate: the cost of moving the phase by Δ samples away
            from the previous phase + 1 is λ·Δ² (in units of the LQR-scaled squared state distance).
        start: the cycle sample an episode starts from (the tracker's ``initial_state``):
            "least_sensitive" (default), the sample whose start the tracker's own model survives
            best with the pelvis ``start_height_error`` too high and too low
            (:func:`start_costs`); "cycle_start": sample 0 of the cycle as generated. Why the
            default: a start on a stance sample with the pelvis a few cm too low presses the
            stance foot that far into the ground (the contact's 100 BW/m: 5 BW at 5 cm), one a few
            cm too high drops it; which samples suffer least depends on the gait (flight in
            running, mid-stance in the 1.3 m/s gaits) and is found by simulating the closed loop
            on the announced model. Measured under 10× reset noise (±5 cm on the pelvis height),
            three generators, reset seeds 200–239: falls 0/9/12 of 120 at 1.3/2.2/3.5 m/s from
            sample 0, 0/1/4 from the least sensitive sample (docs/predictive_simulation.md).
        start_height_error: the pelvis height offset (m) of that test, applied + and −.
    """

    lqr: list[WeightsAtSpeed] = field(default_factory=lambda: [WeightsAtSpeed(1.0)])
    phase: str = "state"
    phase_prior: float = 1.0
    start: str = "least_sensitive"
    start_height_error: float = 0.05

    def __post_init__(self) -> None:
        self.lqr = sorted((w if isinstance(w, WeightsAtSpeed) else WeightsAtSpeed(**w) for w in self.lqr),
                          key=lambda w: w.speed)
        if not self.lqr:
            raise ValueError("tracker.lqr: give weights at one speed at least")
        if self.phase not in PHASE_MODES:
            raise ValueError(f"tracker.phase must be one of {PHASE_MODES}, got {self.phase!r}")
        if not (math.isfinite(self.phase_prior) and self.phase_prior >= 0):
            raise ValueError(f"tracker.phase_prior must be >= 0, got {self.phase_prior}")
        if self.start not in START_MODES:
            raise ValueError(f"tracker.start must be one of {START_MODES}, got {self.start!r}")
        if not (math.isfinite(self.start_height_error) and 0 < self.start_height_error < 0.5):
            raise ValueError(f"tracker.start_height_error must be in (0, 0.5) m, got {self.start_height_error}")

    def weights_at(self, speed: float) -> LQRWeights:
        """The scheduled LQR weights at ``speed`` (m/s)."""
        speeds = np.log([w.speed for w in self.lqr])
        names = [f.name for f in fields(LQRWeights)]
        table = np.log([[getattr(w.weights, n) for n in names] for w in self.lqr])
        x = math.log(speed)
        return LQRWeights(**{n: float(np.exp(np.interp(x, speeds, table[:, j]))) for j, n in enumerate(names)})


class GaitTracker:
    """Feedforward + periodic LQR tracking of a :class:`GaitReference` (module docstring), as a
    :class:`predictive.controller.Controller`: ``action, state = tracker.predict(obs, state,
    episode_start)``. The state is the phase (the cycle sample, one per environment); the tracker
    itself holds no memory, so one tracker runs any number of episodes.

    Phase (``phase``):

    * ``"state"``: the sample i of the cycle that minimises ‖W·(z_ref[i] − z)‖² + λ·Δ(i)², where W
      are the LQR's characteristic deviations (Bryson scaling, ``metric``) and Δ(i) the distance
      (samples, around the cycle) between i and the previous phase + 1; at an episode start λ = 0
      (the whole cycle is searched). The phase thus follows the body: a disturbance that delays or
      advances the gait, or an episode that starts elsewhere on the cycle, is re-synchronised at
      once, and between disturbances the estimate advances one sample per step.
    * ``"clock"``: phase ``start`` at the episode start, then one sample per control step.

    Attributes:
        reference: the tracked cycle. gains: (N, 6, 17) LQR gains. metric: (17,) W.
        phase, phase_prior: see above. start: the cycle sample episodes start from
            (:attr:`initial_state`; see :class:`TrackerSettings`).
        build_time_: seconds spent linearising and solving the Riccati recursion.
        info: free-form facts about where the tracker came from (the plan, times, a note).
    """

    def __init__(
        self, reference: GaitReference, gains: np.ndarray, metric: np.ndarray | None = None, phase: str = "state",
        phase_prior: float = 1.0, build_time: float = float("nan"), start: int = 0,
    ) -> None:
        if gains.shape != (reference.n, N_TAU, N_Z):
            raise ValueError(f"gains must have shape ({reference.n}, {N_TAU}, {N_Z}), got {gains.shape}")
        if phase not in PHASE_MODES:
            raise ValueError(f"phase must be one of {PHASE_MODES}, got {phase!r}")
        self.reference = reference
        self.gains = gains
        self.metric = np.sqrt(np.diag(LQRWeights().matrices()[0])) if metric is None else np.asarray(metric, float)
        if self.metric.shape != (N_Z,):
            raise ValueError(f"metric must have shape ({N_Z},), got {self.metric.shape}")
        self.phase = phase
        self.phase_prior = float(phase_prior)
        if not 0 <= int(start) < reference.n:
            raise ValueError(f"start must be a cycle sample in [0, {reference.n}), got {start}")
        self.start = int(start)
        self.build_time_ = build_time
        self.info: dict[str, Any] = {}
        self._z = reference.z
        self._offsets = np.arange(reference.n)

    @classmethod
    def build(
        cls, env: Any, reference: GaitReference, weights: LQRWeights | None = None, phase: str = "state",
        phase_prior: float = 1.0, start: str = "cycle_start", start_height_error: float = 0.05,
    ) -> GaitTracker:
        """Linearise ``env`` around ``reference`` and compute the periodic LQR gains; ``start``
        ("least_sensitive" or "cycle_start") and ``start_height_error`` (m) choose the start
        sample (:class:`TrackerSettings`, :func:`start_costs`)."""
        import time

        if start not in START_MODES:
            raise ValueError(f"start must be one of {START_MODES}, got {start!r}")
        begin = time.perf_counter()
        A, B = linearise(env, reference)
        Q, R = (weights or LQRWeights()).matrices()
        K = periodic_lqr(A, B, Q, R)
        tracker = cls(reference, K, np.sqrt(np.diag(Q)), phase, phase_prior)
        if start == "least_sensitive":
            tracker.start = least_sensitive_start(env, tracker, start_height_error)
        tracker.build_time_ = time.perf_counter() - begin
        return tracker

    @property
    def initial_state(self) -> tuple[np.ndarray, np.ndarray]:
        """(q, u) of the reference at sample :attr:`start`, for ``env.reset(options={"initial_state": ...})``."""
        return self.reference.q[self.start].copy(), self.reference.u[self.start].copy()

    def phase_of(self, z: np.ndarray, previous: int | None) -> int:
        """The phase (cycle sample) at the controlled state ``z`` (17,) after ``previous`` (None:
        an episode start); see the class docstring."""
        n = self.reference.n
        if self.phase == "clock":
            return self.start if previous is None else (previous + 1) % n
        distance = np.square((self._z - z) * self.metric).sum(axis=1)
        if previous is not None and self.phase_prior > 0:
            shift = (self._offsets - (previous + 1) + n // 2) % n - n // 2
            distance = distance + self.phase_prior * np.square(shift)
        return int(np.argmin(distance))

    def predict(
        self, observation: np.ndarray, state: Any = None, episode_start: Any = None, deterministic: bool = True
    ) -> tuple[np.ndarray, np.ndarray]:
        """(action, phases) for an observation (22,) or a batch (n, 22) (SB3's convention; the
        tracker is deterministic). ``state``: the phases returned by the previous call (None: every
        environment starts an episode); ``episode_start``: True where an episode starts."""
        obs = np.asarray(observation, dtype=np.float64)
        batch = np.atleast_2d(obs)
        n_envs = len(batch)
        previous = np.full(n_envs, -1, dtype=np.int64) if state is None else np.array(state, dtype=np.int64).reshape(-1)
        if previous.size != n_envs:
            raise ValueError(f"state has {previous.size} phases for {n_envs} observations")
        previous[episode_starts(episode_start, n_envs)] = -1
        phases = np.empty(n_envs, dtype=np.int64)
        actions = np.empty((n_envs, N_TAU), dtype=np.float32)
        for e in range(n_envs):
            z = batch[e, :N_Z]
            i = self.phase_of(z, None if previous[e] < 0 else int(previous[e]))
            phases[e] = i
            actions[e] = np.clip(self.reference.action[i] + self.gains[i] @ (self._z[i] - z), -1.0, 1.0)
        return (actions if obs.ndim == 2 else actions[0]), phases


def start_costs(env: Any, tracker: GaitTracker, height_error: float = 0.05, every: int = 2) -> np.ndarray:
    """How badly ``tracker`` copes with a start-height error at each sample of its cycle, on the
    announced model (``env.step_state``, no noise, no disturbance).

    For every ``every``-th sample s: two closed-loop runs of one cycle (N steps) from the reference
    state at s with pelvis_ty + ``height_error`` and − ``height_error`` (m), the tracker choosing
    its phase as in an episode. The cost of a run is Σ_k ‖W·(z_ref[i_k] − z_k)‖² (W: the
    tracker's metric, i_k its phase), inf if the run falls (the environment's fall test) or its
    state stops being finite; a sample's cost is the larger of its two runs. Samples not tried
    are inf. Returns (N,) costs.

    Why simulate and not a rule such as "start in flight": which samples are benign depends on the
    gait (measured: flight for the 2.2–3.5 m/s gaits, mid-stance for the 1.3 m/s ones), and the
    closed loop on the announced model is the tracker's own best prediction. Cost: 2·N²/every
    steps of the model (0.4–1.8 s per gait here, contended).
    """
    from envs.task import unhealthy

    e = _unwrapped(env)
    if not (math.isfinite(height_error) and height_error > 0):
        raise ValueError(f"height_error must be > 0 m, got {height_error}")
    if every < 1:
        raise ValueError(f"every must be >= 1, got {every}")
    ref, n = tracker.reference, tracker.reference.n
    z_ref = ref.z
    costs = np.full(n, np.inf)
    for s in range(0, n, every):
        worst = 0.0
        for dy in (height_error, -height_error):
            q, u = ref.q[s].copy(), ref.u[s].copy()
            q[0], q[1] = 0.0, q[1] + dy
            phase: Any = None
            cost = 0.0
            for k in range(n):
                z = np.concatenate([q[1:], u])
                action, phase = tracker.predict(z, phase, episode_start=k == 0)
                cost += float(np.square((z_ref[int(phase[0])] - z) * tracker.metric).sum())
                q, u, _ = e.step_state(q, u, action)
                if not (np.all(np.isfinite(q)) and np.all(np.isfinite(u))) or bool(unhealthy(q, e.standing_height, e.config)):
                    cost = math.inf
                    break
            worst = max(worst, cost)
            if worst == math.inf:
                break
        costs[s] = worst
    return costs


def least_sensitive_start(env: Any, tracker: GaitTracker, height_error: float = 0.05, every: int = 2) -> int:
    """The cycle sample with the least :func:`start_costs` (sample 0 if every start falls)."""
    costs = start_costs(env, tracker, height_error, every)
    return int(np.argmin(costs)) if np.isfinite(costs).any() else 0


__all__ = [
    "PHASE_MODES", "START_MODES", "GaitReference", "GaitTracker", "LQRWeights", "TrackerSettings", "WeightsAtSpeed",
    "least_sensitive_start", "linearise", "periodic_lqr", "resample_cycle", "start_costs", "step_map",
]
