"""Tracking gait simulations: the predictive collocation problem plus tracking terms.

Two modes, both built on :class:`~predictive.ocp.collocation.PredictiveGaitProblem` (same grid,
backward-Euler collocation, implicit dynamics, contact model, bounds and effort; see its module
docstring) by overriding its objective:

* :func:`solve_tracking` — track any named signals (kinematics, GRFs, torques, IMU channels;
  :data:`SIGNAL_KINDS`) given at the nodes, e.g. an averaged real stride's joint angles and GRFs.
* :func:`~predictive.ocp.imu_tracking.solve_imu_tracking` — the label-free optimal-control
  baseline of SSPINNpose (Dorschky et al. 2019, J Biomech 95:109278): track the sagittal signals
  (acc_x, acc_y, gyr_z) of the IMUs of an averaged stride with virtual IMUs
  (:func:`sspinn.model.kinematics.virtual_imu`), speed free; outputs angles, torques, GRFs and speed.

Tracked signals come from recordings or solutions via :mod:`predictive.ocp.tracking_data`.

Formulation (in addition to :mod:`predictive.ocp.collocation`):

* **Full gait cycle**, periodic (node ``N`` = node 0 moved forward by ``v·T``), no left/right
  symmetry (the tracked data are one stride and may be one-sided). The duration ``T`` is fixed
  to the data's stride duration; the average speed ``v`` is fixed or free (a decision variable
  within ``speed_bounds``; for IMU tracking it is only tied to the data through the periodicity
  of the foot placements, since accelerometers do not see a constant velocity).
* **Time alignment.** Node ``k`` is at ``t_k = k·T/N``; data given over one stride starting at
  ``t = 0`` (e.g. right heel strike) are resampled to these times by periodic linear
  interpolation, so node 0 is the data's first sample.
* **Objective** (dimensionless)::

      J = (1/S) Σ_s w_s · mean_k ((y_s(x_k) − d_sk) / σ_sk)²
          + effort_weight · mean_k Σ_j |τ_kj/τmax_j|^e + w_acc · mean_k Σ_i (q̈_ki·T²/(4π²))²

  over the S tracked signals ``y_s`` (simulated at node k from q, u, q̈, τ and the contact GRF),
  their data ``d_sk`` and normalising scales ``σ_sk``: by default the standard deviation of the
  data over the cycle (floored, :data:`MIN_SCALES`), or a given scalar / per-node value (e.g.
  the across-trial standard deviation, as Dorschky et al. normalised by the intertrial variance).
  The effort and regularisation terms are those of the predictive problem.
* **Virtual IMUs** use the node's q, u and q̈, where u_k and q̈_k are backward differences: the
  simulated accelerometer lags the node time by ≈ h (one node interval) and the gyroscope by
  ≈ h/2; with 100 nodes per stride this is ≈ 1 % of the cycle and is not corrected.

Signal names (units SI; signs of :mod:`sspinn.model.conventions`): the coordinates except pelvis_tx
(``hip_r`` …, rad; ``pelvis_ty``, m), speeds ``d_<coordinate>`` (``d_pelvis_tx`` is the forward
velocity), accelerations ``dd_<coordinate>``, torques ``tau_<joint>`` (N·m), GRFs ``grf_x_r`` …
(N) and IMU channels ``<segment>_acc_x|acc_y|gyr_z`` (m/s², rad/s) — the column names of
:class:`sspinn.data.dataset.Recording` labels and IMU data.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import casadi as ca
import numpy as np

from predictive.ocp.collocation import (
    GaitCycle,
    NodeExpressions,
    OCPError,
    OCPSettings,
    PredictiveGaitProblem,
)
from predictive.ocp.settings import Effort
from predictive.ocp.solution import GaitSolution
from sspinn.model import dynamics as dyn
from sspinn.model import kinematics
from sspinn.model.body import BodyParameters, IMUPlacement, JointLimits
from sspinn.model.contact import ContactParameters
from sspinn.model.conventions import COORDINATES, GRF, IMU_CHANNELS, JOINTS, N_GRF, N_Q, N_TAU, SEGMENTS, imu_columns
from sspinn.model.trajectory import save_npz
from sspinn.run_folder import atomic_write_json

#: Lower bounds of the default normalising scales (the data's standard deviation over the cycle),
#: per signal kind, SI units: a nearly constant signal is not weighted without limit.
MIN_SCALES: dict[str, float] = {
    "angle": math.radians(1.0),
    "position": 0.005,
    "speed": 0.05,
    "acceleration": 0.5,
    "torque": 1.0,
    "grf": 10.0,
    "acc": 0.1,
    "gyr": 0.05,
}


def _signal_table() -> dict[str, tuple[str, str, int]]:
    """name → (source, kind, index): source one of q, u, a, tau, grf, imu (index into the
    flattened (7, 3) virtual-IMU matrix)."""
    table: dict[str, tuple[str, str, int]] = {}
    for i, c in enumerate(COORDINATES):
        if c != "pelvis_tx":
            table[c] = ("q", "position" if c == "pelvis_ty" else "angle", i)
        table[f"d_{c}"] = ("u", "speed", i)
        table[f"dd_{c}"] = ("a", "acceleration", i)
    for j, name in enumerate(JOINTS):
        table[f"tau_{name}"] = ("tau", "torque", j)
    for g, name in enumerate(GRF):
        table[name] = ("grf", "grf", g)
    for i, name in enumerate(imu_columns()):
        table[name] = ("imu", name.rsplit("_", 2)[-2], i)
    return table


#: Every trackable signal: name → (source, kind, index); see the module docstring.
SIGNAL_KINDS: dict[str, tuple[str, str, int]] = _signal_table()


@dataclass(frozen=True)
class TrackedSignal:
    """One tracked signal at the collocation nodes.

    Attributes:
        name: a key of :data:`SIGNAL_KINDS` (e.g. ``"hip_r"``, ``"grf_y_r"``, ``"tibia_r_gyr_z"``).
        target: (n_nodes,) data at the node times t_k = k·T/n, SI units.
        scale: normalising scale σ (same unit as the target, > 0): a scalar or (n_nodes,).
        weight: weight w_s of the signal in the objective (≥ 0).
    """

    name: str
    target: np.ndarray
    scale: float | np.ndarray
    weight: float = 1.0

    def __post_init__(self) -> None:
        if self.name not in SIGNAL_KINDS:
            raise ValueError(f"unknown tracked signal {self.name!r}; expected one of {', '.join(SIGNAL_KINDS)}")
        target = np.asarray(self.target, dtype=float)
        scale = np.broadcast_to(np.asarray(self.scale, dtype=float), target.shape)
        if target.ndim != 1 or not np.all(np.isfinite(target)):
            raise ValueError(f"{self.name}: target must be a finite 1-D array, got shape {target.shape}")
        if not (np.all(np.isfinite(scale)) and np.all(scale > 0)):
            raise ValueError(f"{self.name}: scale must be finite and > 0")
        if not (math.isfinite(self.weight) and self.weight >= 0):
            raise ValueError(f"{self.name}: weight must be finite and >= 0, got {self.weight}")
        object.__setattr__(self, "target", target)
        object.__setattr__(self, "scale", np.array(scale))

    @property
    def kind(self) -> str:
        return SIGNAL_KINDS[self.name][1]


def default_scale(name: str, target: np.ndarray) -> float:
    """The default normalising scale: the target's standard deviation over the cycle, floored at
    :data:`MIN_SCALES` of the signal's kind."""
    return float(max(np.std(target), MIN_SCALES[SIGNAL_KINDS[name][1]]))


def signal_function(names: Sequence[str], body: BodyParameters, placement: IMUPlacement | None = None) -> ca.Function:
    """CasADi function (q (9), u (9), q̈ (9), τ (6), grf (4)) → the named signals (S,), SI units.

    ``placement`` is needed only for IMU channels. Evaluated symbolically in the NLP and
    numerically (``.map``) to report the tracked signals of a solution.
    """
    q, u, a = (ca.SX.sym(n, N_Q) for n in ("q", "u", "a"))
    tau, grf = ca.SX.sym("tau", N_TAU), ca.SX.sym("grf", N_GRF)
    sources: dict[str, Any] = {"q": q, "u": u, "a": a, "tau": tau, "grf": grf}
    if any(SIGNAL_KINDS[n][0] == "imu" for n in names):
        if placement is None:
            raise ValueError("IMU signals need an IMU placement")
        imu = kinematics.virtual_imu(q, u, a, placement, body)  # (7, 3): [acc_x, acc_y, gyr_z] per segment
        sources["imu"] = ca.vertcat(*[imu[s, c] for s in range(len(SEGMENTS)) for c in range(len(IMU_CHANNELS))])
    out = [sources[SIGNAL_KINDS[n][0]][SIGNAL_KINDS[n][2]] for n in names]
    return ca.Function("signals", [q, u, a, tau, grf], [ca.vertcat(*out)], ["q", "u", "a", "tau", "grf"], ["y"])


@dataclass(frozen=True)
class TrackingSettings(OCPSettings):
    """:class:`OCPSettings` of a tracking problem (stored with the solution).

    Attributes (in addition to :class:`OCPSettings`; ``gait_cycle`` must be "full"):
        effort_weight: weight of the torque effort term (dimensionless; the tracking term is a
            mean normalised squared error, ≈ 1 when the errors are one scale σ).
        effort: "squared" here (the tracking problems' effort; the human priors of the
            predictive problem are not part of a tracking objective: the data take their place).
    """

    gait_cycle: GaitCycle = "full"
    effort: Effort = field(default="squared", kw_only=True)
    effort_weight: float = 1.0

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.gait_cycle != "full":
            raise ValueError(f"tracking needs gait_cycle='full' (no symmetry assumed), got {self.gait_cycle!r}")
        if not (math.isfinite(self.effort_weight) and self.effort_weight >= 0):
            raise ValueError(f"effort_weight must be finite and >= 0, got {self.effort_weight}")


class TrackingGaitProblem(PredictiveGaitProblem):
    """The predictive collocation NLP with the tracking term of the module docstring added.

    Build once; :meth:`solve` (inherited) runs IPOPT and returns a :class:`GaitSolution`;
    :meth:`result` adds the simulated and target signals.
    """

    def __init__(
        self,
        settings: TrackingSettings,
        signals: Sequence[TrackedSignal],
        body: BodyParameters | None = None,
        contact: ContactParameters | None = None,
        joint_limits: JointLimits | None = None,
        placement: IMUPlacement | None = None,
    ) -> None:
        if not isinstance(settings, TrackingSettings):
            raise TypeError("TrackingGaitProblem needs TrackingSettings")
        if not signals:
            raise ValueError("no signals to track")
        names = [s.name for s in signals]
        if len(set(names)) != len(names):
            raise ValueError(f"tracked signals must be unique, got {names}")
        for sig in signals:
            if sig.target.shape != (settings.n_nodes,):
                raise ValueError(f"{sig.name}: target has {sig.target.shape[0]} values, expected n_nodes = {settings.n_nodes}")
        body = body if body is not None else BodyParameters.from_anthropometry(1.75, 70.0)
        self.signals = tuple(signals)
        self.placement = placement
        self.signal_fun = signal_function(names, body, placement)
        self.targets = np.stack([s.target for s in self.signals], axis=1)  # (n, S)
        self.scales = np.stack([s.scale for s in self.signals], axis=1)  # (n, S)
        self.weights = np.array([s.weight for s in self.signals])
        super().__init__(settings, body, contact, joint_limits)

    def guess_from_signals(self) -> np.ndarray | None:
        """Initial guess (scaled decision vector) from the tracked data when every coordinate but
        pelvis_tx is tracked (kinematics tracking; pelvis_tx = v·t), else None: standard practice
        for tracking problems, start from the data rather than from a gait model. u and q̈ are the
        backward differences of the data (as the collocation defines them) and the torques their
        **inverse dynamics** (least squares of the Kane residual with the contact model's GRF).
        With zero torques, or another gait's, IPOPT ended in local optima 5–9× worse than the
        data's own optimum under 1e-9 guess perturbations (scripts/check_robustness.py)."""
        names = [sig.name for sig in self.signals]
        coords = [c for c in COORDINATES if c != "pelvis_tx"]
        if not all(c in names for c in coords):
            return None
        s = self.settings
        n, T = s.n_nodes, s.stride_duration
        h = T / n
        t = np.arange(n) * h
        q = np.empty((n, N_Q))
        q[:, 0] = s.speed * t
        for i, c in enumerate(COORDINATES[1:], start=1):
            q[:, i] = self.targets[:, names.index(c)]
        u, a = self.cycle_differences(q, T, n)
        grf, w = dyn.contact_forces(q, u, self.body, self.contact)
        r0 = np.asarray(dyn.kane_residual(q, u, a, np.zeros((n, N_TAU)), grf, w, self.body))
        B = np.stack(
            [np.asarray(dyn.kane_residual(q, u, a, np.tile(np.eye(N_TAU)[j], (n, 1)), grf, w, self.body)) - r0 for j in range(N_TAU)],
            axis=-1,
        )  # (n, 9, 6): the residual is affine in τ
        tau = np.stack([np.linalg.lstsq(B[k], -r0[k], rcond=None)[0] for k in range(n)])
        return self._pack_guess(t, q, T, n, tau)

    def _tracking_term(self, x: NodeExpressions) -> Any:
        """(1/S) Σ_s w_s · mean_k ((y_sk − d_sk)/σ_sk)² (dimensionless)."""
        n, n_signals = self.targets.shape
        total = 0
        for k in range(n):
            y = self.signal_fun(x.q[k], x.u[k], x.a[k], x.tau[k], x.grf[k])
            err = (y - ca.DM(self.targets[k])) / ca.DM(self.scales[k])
            total += ca.dot(ca.DM(self.weights), err**2)
        return total / (n * n_signals)

    def _objective(self, x: NodeExpressions) -> Any:
        effort, reg = self._effort_terms(x)
        s = self.settings
        return self._tracking_term(x) + s.effort_weight * effort + s.w_acc * reg  # type: ignore[attr-defined]

    def solve_with_speed_continuation(
        self,
        guess: GaitSolution | None = None,
        *,
        speed: float | None = None,
        ipopt_options: Mapping[str, Any] | None = None,
        verbose: bool = False,
        raise_on_failure: bool = True,
    ) -> GaitSolution:
        """For a free-speed problem: solve first with the speed fixed to the initial guess
        ``speed`` (m/s; default ``settings.speed``), then with the speed free from that solution.
        Without the first step, IPOPT sometimes drifted from a walking guess to standing (speed 0,
        a poor local optimum) on the real IMU data. Both steps use the problem's one solver, so
        a multi-start over initial speeds builds the NLP once. The returned solution's
        iterations and times are the sums of both steps."""
        kw: dict[str, Any] = {"ipopt_options": ipopt_options, "verbose": verbose}
        v0 = self.settings.speed if speed is None else float(speed)
        first = self.solve(guess, raise_on_failure=False, fixed_speed=v0, **kw)
        second = self.solve(self.guess_from_solution(first, speed=first.speed), raise_on_failure=raise_on_failure, **kw)
        return dataclasses.replace(
            second,
            iterations=first.iterations + second.iterations,
            solve_time=first.solve_time + second.solve_time,
            build_time=first.build_time + second.build_time,
        )

    def simulated(self, sol: GaitSolution) -> np.ndarray:
        """(n, S) the tracked signals of a solution of this problem, SI units."""
        fun = self.signal_fun.map(sol.n_nodes)
        y = fun(sol.q.T, sol.u.T, sol.qdd.T, sol.tau.T, sol.grf.T)
        return np.asarray(y).T

    def result(self, sol: GaitSolution) -> TrackingResult:
        """The solution with its tracked signals."""
        return TrackingResult(
            solution=sol,
            names=tuple(s.name for s in self.signals),
            target=self.targets.copy(),
            simulated=self.simulated(sol),
            scale=self.scales.copy(),
            weight=self.weights.copy(),
        )


@dataclass
class TrackingResult:
    """A tracking solution and its tracked signals at the nodes (SI units).

    Attributes:
        solution: the gait (angles, torques, GRFs, speed) over one cycle.
        names: tracked signal names (S).
        target, simulated, scale: (n, S) data, simulation and normalising scale.
        weight: (S,) weights.
        info: how it was obtained (e.g. starts and times of :func:`solve_imu_tracking`).
    """

    solution: GaitSolution
    names: tuple[str, ...]
    target: np.ndarray
    simulated: np.ndarray
    scale: np.ndarray
    weight: np.ndarray
    info: dict[str, Any] = field(default_factory=dict)

    def residuals(self) -> dict[str, dict[str, float]]:
        """Per signal: ``rmse`` (signal units), ``rmse_normalised`` (RMS of error/σ) and the
        data's standard deviation ``data_std`` over the cycle."""
        err = self.simulated - self.target
        return {
            name: {
                "rmse": float(np.sqrt(np.mean(err[:, i] ** 2))),
                "rmse_normalised": float(np.sqrt(np.mean((err[:, i] / self.scale[:, i]) ** 2))),
                "data_std": float(np.std(self.target[:, i])),
            }
            for i, name in enumerate(self.names)
        }

    def save(self, path: str | Path) -> Path:
        """Write the solution (``<path>.npz/.json``, see :meth:`GaitSolution.save`), the tracked
        signals to ``<path>_tracked.npz`` and the residuals and info to ``<path>_tracked.json``;
        returns the solution's npz path."""
        npz = self.solution.save(path)
        tracked = {"names": np.array(self.names), "target": self.target, "simulated": self.simulated,
                   "scale": self.scale, "weight": self.weight}
        save_npz(npz.with_name(npz.name[: -len(".npz")] + "_tracked.npz"), tracked,
                 finite=("target", "simulated", "scale", "weight"), what="tracked signals")
        summary = {"residuals": self.residuals(), "info": self.info}
        atomic_write_json(npz.with_name(npz.name[: -len(".npz")] + "_tracked.json"), summary, default=str, non_finite="null")
        return npz


# ---------------------------------------------------------------------------------------------
# Solvers
# ---------------------------------------------------------------------------------------------
def track_starts(
    signals: Sequence[TrackedSignal],
    duration: float,
    speed: float,
    body: BodyParameters | None = None,
    *,
    guesses: Sequence[GaitSolution | None | Callable[[], GaitSolution | None]] = (None,),
    start_speeds: Sequence[float] | None = None,
    stop: Callable[[Sequence[TrackingResult]], bool] | None = None,
    free_speed: bool = False,
    speed_continuation: bool = True,
    effort_weight: float = 1.0,
    placement: IMUPlacement | None = None,
    contact: ContactParameters | None = None,
    joint_limits: JointLimits | None = None,
    ipopt_options: Mapping[str, Any] | None = None,
    verbose: bool = False,
    raise_on_failure: bool = False,
    **settings: Any,
) -> list[TrackingResult]:
    """One tracking solve per start, all on one NLP and one IPOPT solver (built once: only the
    initial guess and the bounds differ between starts); the arguments are those of
    :func:`solve_tracking`, plus:

    Args:
        guesses: one initial guess per start (None: the default guess of :func:`solve_tracking`),
            or a function of none returning it, called only when that start runs.
        start_speeds: with ``free_speed``, each start's initial speed, m/s (the fixed speed of
            the first step of the speed continuation and the speed its guess is resampled to);
            default ``speed`` for every start. The NLP's scaling uses ``speed``.
        stop: called with the results so far after each start; True ends the multi-start there
            (the starts left are not run; their guesses are not made).
        raise_on_failure: raise when a start fails (default False: its result is returned).

    Returns:
        The results of the starts run, in the order of ``guesses``.
    """
    n_nodes = len(signals[0].target) if signals else 0
    cfg = TrackingSettings(
        speed=float(speed),
        n_nodes=n_nodes,
        duration=float(duration),
        free_speed=free_speed,
        effort_weight=effort_weight,
        **settings,
    )
    speeds = [float(speed)] * len(guesses) if start_speeds is None else [float(v) for v in start_speeds]
    if len(speeds) != len(guesses):
        raise ValueError(f"{len(speeds)} start speeds for {len(guesses)} guesses")
    if start_speeds is not None and not free_speed:
        raise ValueError("start_speeds needs free_speed (a fixed speed is the same for every start)")
    problem = TrackingGaitProblem(cfg, signals, body, contact, joint_limits, placement)
    problem.prepare(ipopt_options, verbose)  # before the first guess: it may still be on its way
    kw: dict[str, Any] = {"ipopt_options": ipopt_options, "verbose": verbose, "raise_on_failure": raise_on_failure}
    results: list[TrackingResult] = []
    for start, v0 in zip(guesses, speeds):
        if callable(start):
            start = start()
        g = start if start is not None else problem.guess_from_signals()
        if free_speed and speed_continuation:
            sol = problem.solve_with_speed_continuation(g, speed=v0, **kw)
        else:
            sol = problem.solve(problem.guess_from_solution(g, speed=v0) if isinstance(g, GaitSolution) else g, **kw)
        results.append(problem.result(sol))
        if stop is not None and stop(results):
            break
    return results


def solve_tracking(
    signals: Sequence[TrackedSignal],
    duration: float,
    speed: float,
    body: BodyParameters | None = None,
    *,
    free_speed: bool = False,
    speed_continuation: bool = True,
    effort_weight: float = 1.0,
    guess: GaitSolution | Sequence[GaitSolution | None] | None = None,
    placement: IMUPlacement | None = None,
    contact: ContactParameters | None = None,
    joint_limits: JointLimits | None = None,
    ipopt_options: Mapping[str, Any] | None = None,
    verbose: bool = False,
    raise_on_failure: bool = True,
    **settings: Any,
) -> TrackingResult:
    """Track ``signals`` (each given at ``n`` nodes over one cycle) over a full periodic cycle.

    Args:
        signals: the tracked signals (:func:`~predictive.ocp.tracking_data.signals_from_recording`); their length is the number
            of collocation nodes.
        duration: stride duration T, s (fixed).
        speed: average speed, m/s: fixed, or the initial guess when ``free_speed``.
        body: body parameters (default 1.75 m, 70 kg).
        free_speed: optimise the speed within ``speed_bounds`` (a setting, default 0–10 m/s).
        speed_continuation: with ``free_speed``, solve first at the fixed initial speed and then
            free it (:meth:`TrackingGaitProblem.solve_with_speed_continuation`).
        effort_weight: weight of the torque effort (see the module docstring).
        guess: initial guess: a :class:`GaitSolution`, or None for the default — the tracked
            data themselves when every coordinate but pelvis_tx is tracked
            (:meth:`TrackingGaitProblem.guess_from_signals`: the data's kinematics and their
            inverse-dynamics torques), else the data-free generic guess at ``speed``. A list: a multi-start, one solve from each (None: the default), the
            successful one with the lowest objective returned; all are listed in
            ``result.info["starts"]`` (:func:`track_starts`: one NLP for all starts).
        placement: IMU placement (needed for IMU channels).
        **settings: further :class:`TrackingSettings` fields (``w_acc``, ``speed_bounds``, …).

    Raises:
        predictive.ocp.collocation.OCPError: IPOPT failed and ``raise_on_failure``.
    """
    multi = isinstance(guess, (list, tuple))
    starts = list(guess) if isinstance(guess, (list, tuple)) else [guess]
    results = track_starts(
        signals,
        duration,
        speed,
        body,
        guesses=starts,
        free_speed=free_speed,
        speed_continuation=speed_continuation,
        effort_weight=effort_weight,
        placement=placement,
        contact=contact,
        joint_limits=joint_limits,
        ipopt_options=ipopt_options,
        verbose=verbose,
        raise_on_failure=raise_on_failure and not multi,
        **settings,
    )
    best = min(results, key=lambda r: r.solution.start_rank)
    if multi:
        if raise_on_failure and not best.solution.success:
            message = f"no start of the tracking problem succeeded (best status {best.solution.status})"
            raise OCPError(best.solution.status, message, best.solution)
        best.info["starts"] = [
            {"status": r.solution.status, "objective": r.solution.objective, "chosen": r is best} for r in results
        ]
    return best
