"""The result of a predictive gait simulation, its persistence and its physical checks.

A :class:`GaitSolution` is a :class:`sspinn.model.trajectory.Trajectory` (time, q, u, q̈, τ, GRF, w;
units and signs of :mod:`sspinn.model.conventions`) sampled at the collocation nodes of one whole gait
cycle, ``time[k] = k·T/n`` (``k = 0 … n−1``; node ``n`` would be node 0 of the next cycle), with
the problem's speed, duration, body and solver statistics.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from sspinn.data.gait_events import CONTACT_THRESHOLD_BW, contact_onsets, stance_fractions
from sspinn.errors import UserError
from sspinn.model import conventions
from sspinn.model.body import BodyParameters
from sspinn.model.contact import ContactParameters
from sspinn.model.conventions import COORDINATES, GRAVITY, GRF, JOINTS, N_Q
from sspinn.model.trajectory import FIELDS, Trajectory, TrajectoryError, save_npz
from sspinn.run_folder import atomic_write_json

#: Permutations that swap the right and left leg in q (and u, q̈), τ and the GRF vector
#: (:data:`sspinn.model.conventions.MIRROR_Q` ..., as index arrays).
MIRROR_Q = np.array(conventions.MIRROR_Q)
MIRROR_TAU = np.array(conventions.MIRROR_TAU)
MIRROR_GRF = np.array(conventions.MIRROR_GRF)

#: The arrays of the npz file: the trajectory's fields and the normalising torques.
_ARRAYS = (*FIELDS, "tau_max")
#: What the commands that write one gait (``python -m predictive solve``, ``generate``) put beside
#: their ``--out`` path: the solution (:meth:`GaitSolution.save`), its summary and its plot.
SOLUTION_OUTPUTS: tuple[str, ...] = (".npz", ".json", "_summary.json", ".png")


def mirror_states(x: Any) -> Any:
    """Swap right and left legs in a column vector (CasADi) or in the rows of a (9, …) or (6, …)
    array: q, u, q̈ (9 rows) or τ (6 rows)."""
    n = x.shape[0]
    perm = MIRROR_Q if n == N_Q else MIRROR_TAU
    if isinstance(x, np.ndarray):
        return x[perm]
    import casadi as ca

    return ca.vertcat(*[x[int(i)] for i in perm])


@dataclass(kw_only=True)
class GaitSolution(Trajectory):
    """One periodic gait cycle predicted by :func:`predictive.solve_predictive`: a
    :class:`~sspinn.model.trajectory.Trajectory` at the nodes (time from 0, q, u, q̈, τ, GRF, w; built
    with keywords) and

    Attributes:
        speed: average forward speed, m/s.
        duration: stride (cycle) duration T, s.
        body_parameters: the body used, as :meth:`BodyParameters.to_dict` (see :attr:`body`).
        status: IPOPT return status (``Solve_Succeeded`` when solved).
        iterations: IPOPT iterations.
        solve_time: wall-clock time of the IPOPT call, s.
        build_time: time to create the solver (symbolic setup and code), s.
        objective: final objective value (dimensionless).
        settings: the :class:`~predictive.ocp.collocation.OCPSettings` as a dict.
        contact: the contact parameters as a dict.
        tau_max: (6,) normalising torques, N·m.
        starts: for a multi-start (:meth:`~predictive.ocp.collocation.PredictiveGaitProblem.solve_multistart`)
            one dict per start (amplitude, IPOPT options, status, objective, iterations,
            chosen); empty for a single IPOPT run.
    """

    speed: float
    duration: float
    body_parameters: dict[str, Any]
    status: str = "unknown"
    iterations: int = -1
    solve_time: float = float("nan")
    build_time: float = float("nan")
    objective: float = float("nan")
    settings: dict[str, Any] = field(default_factory=dict)
    contact: dict[str, Any] = field(default_factory=dict)
    tau_max: np.ndarray = field(default_factory=lambda: np.ones(len(JOINTS)))
    starts: list[dict[str, Any]] = field(default_factory=list)

    # ------------------------------------------------------------------ derived quantities
    @property
    def success(self) -> bool:
        return self.status == "Solve_Succeeded"

    @property
    def start_rank(self) -> tuple[bool, float]:
        """Sort key of a multi-start: successful solutions first, then the lowest objective."""
        return (not self.success, self.objective)

    @property
    def stride_length(self) -> float:
        """Distance travelled per cycle, m (speed × duration)."""
        return self.speed * self.duration

    @property
    def n_nodes(self) -> int:
        return self.n_samples

    @property
    def body(self) -> BodyParameters:
        """The body parameters the solution was computed with."""
        return BodyParameters.from_dict(self.body_parameters, source="GaitSolution.body_parameters")

    @property
    def contact_parameters(self) -> ContactParameters:
        return ContactParameters(**self.contact) if self.contact else ContactParameters()

    @property
    def body_weight(self) -> float:
        return self.body.body_weight

    def grf_bw(self) -> np.ndarray:
        """(n, 4) GRF in body weights."""
        return self.grf / self.body_weight

    def stance_fractions(self, threshold_bw: float = CONTACT_THRESHOLD_BW) -> dict[str, float]:
        """Fractions of the cycle (at the nodes) with a foot loaded above ``threshold_bw``:
        ``stance_r``, ``stance_l``, ``double_support`` and ``flight`` (no foot loaded;
        :func:`sspinn.data.gait_events.stance_fractions`)."""
        grf = self.grf_bw()
        return stance_fractions(grf[:, 1], grf[:, 3], threshold_bw)

    def right_heel_strike(self, threshold_bw: float = CONTACT_THRESHOLD_BW) -> int:
        """Index of the node at which the right vertical GRF rises above ``threshold_bw``
        (first loaded node after an unloaded one, the cycle wrapping around; 0 if the foot never
        leaves the ground; :func:`sspinn.data.gait_events.contact_onsets`)."""
        onsets = contact_onsets(self.grf_bw()[:, 1], threshold_bw, periodic=True)
        return int(onsets[0]) if len(onsets) else 0

    # ------------------------------------------------------------------ residual checks
    def node_residual(self) -> np.ndarray:
        """(n, 9) Kane residual at the nodes (:meth:`~sspinn.model.trajectory.Trajectory.kane_residual`:
        NumPy backend, BW for the two translational rows and BW·H for the rotational rows) with
        q̈ recomputed from the stored speeds as the backward difference (u_k − u_{k−1})/h that the
        collocation uses, and GRF recomputed from the contact model."""
        h = self.duration / self.n_nodes
        qdd = (self.u - np.roll(self.u, 1, axis=0)) / h
        return self.as_trajectory(qdd=qdd).kane_residual(self.body, self.contact_parameters)

    def resampled_residual(self, rate_hz: float = 100.0) -> tuple[np.ndarray, np.ndarray]:
        """Kane residual (scaled as in :meth:`node_residual`, GRF from the contact model) of the
        motion resampled at ``rate_hz``: q by a periodic cubic spline through the nodes, u and q̈
        its derivatives, τ linearly interpolated (:meth:`~sspinn.model.trajectory.Trajectory.resample`
        with ``method="spline"``). Returns (times in s, residual (m, 9)). This measures how well a
        smooth curve through the nodes obeys the dynamics between the nodes (discretisation
        error of the first-order collocation), not the constraint satisfaction."""
        t = np.arange(0.0, self.duration, 1.0 / rate_hz)
        smooth = self.resample(t, period=self.duration, speed=self.speed, method="spline")
        return t, smooth.kane_residual(self.body, self.contact_parameters)

    def summary(self) -> dict[str, Any]:
        """Key numbers: status, iterations, times, duration, stride length, residuals, stance. The
        build time and the objective only where the solution has them (a solver's, not a
        generated gait's: NaN there, which JSON cannot hold)."""
        res = np.abs(self.node_residual())
        _, res_100 = self.resampled_residual()
        optional = {"build_time_s": round(self.build_time, 3), "objective": self.objective}
        return {
            "status": self.status,
            "iterations": self.iterations,
            "solve_time_s": round(self.solve_time, 3),
            **{key: value for key, value in optional.items() if math.isfinite(value)},
            "speed_mps": self.speed,
            "duration_s": self.duration,
            "stride_length_m": self.stride_length,
            "node_residual_max_trans_bw": float(res[:, :2].max()),
            "node_residual_max_rot_bwh": float(res[:, 2:].max()),
            "resampled_100hz_residual_rms": float(np.sqrt(np.mean(res_100**2))),
            "resampled_100hz_residual_max": float(np.abs(res_100).max()),
            "peak_grf_y_bw": float(self.grf_bw()[:, [1, 3]].max()),
            **self.stance_fractions(),
        }

    # ------------------------------------------------------------------ persistence
    def save(self, path: str | Path) -> Path:
        """Write ``<path>.npz`` (arrays) and ``<path>.json`` (scalars, settings, summary of
        names and units). ``path`` may carry either suffix or none. Returns the npz path."""
        base = _base(path)
        arrays = {k: getattr(self, k) for k in _ARRAYS}
        save_npz(_with_ext(base, ".npz"), arrays, finite=_ARRAYS, what="a gait solution", label=base)
        meta = {
            "speed": self.speed,
            "duration": self.duration,
            "stride_length": self.stride_length,
            "body_parameters": self.body_parameters,
            "status": self.status,
            "iterations": self.iterations,
            "solve_time": self.solve_time,
            "build_time": self.build_time,
            "objective": self.objective,
            "settings": self.settings,
            "contact": self.contact,
            "starts": self.starts,
            "columns": {
                "q": list(COORDINATES),
                "u": list(COORDINATES),
                "qdd": list(COORDINATES),
                "tau": list(JOINTS),
                "grf": list(GRF),
                "w": ["w_r", "w_l"],
            },
            "units": {
                "time": "s",
                "q": "m, rad",
                "u": "m/s, rad/s",
                "qdd": "m/s^2, rad/s^2",
                "tau": "N*m",
                "grf": "N",
                "w": "1 (toe 0 ... heel 1)",
                "gravity": GRAVITY,
            },
        }
        # NaN (no build time or objective, e.g. a generated gait) is not JSON: written as null
        atomic_write_json(_with_ext(base, ".json"), meta, default=_json_default, non_finite="null")
        return _with_ext(base, ".npz")

    @classmethod
    def load(cls, path: str | Path) -> GaitSolution:
        """Read a solution written by :meth:`save`."""
        base = _base(path)
        npz_path, json_path = _with_ext(base, ".npz"), _with_ext(base, ".json")
        for p in (npz_path, json_path):
            if not p.exists():
                raise FileNotFoundError(f"gait solution file {p} not found (save() writes .npz + .json)")
        try:
            meta = json.loads(json_path.read_text())
            with np.load(npz_path) as data:
                arrays = {k: data[k] for k in _ARRAYS}
        except (ValueError, KeyError, OSError, EOFError) as exc:  # bad JSON, missing arrays, not an npz
            raise UserError(f"{base}: not a readable gait solution (.npz + .json from save()): {exc}") from None
        missing = [k for k in ("speed", "duration", "body_parameters", "status") if not isinstance(meta, dict) or k not in meta]
        if missing:
            raise UserError(f"{json_path}: not a gait solution's metadata (missing {missing})")
        fields = (
            "speed",
            "duration",
            "body_parameters",
            "status",
            "iterations",
            "solve_time",
            "build_time",
            "objective",
            "settings",
            "contact",
        )
        values = {k: meta[k] for k in fields}
        values.update({k: float("nan") for k in ("build_time", "objective") if values[k] is None})  # null: none
        try:
            return cls(**arrays, **values, starts=meta.get("starts", []))
        except TrajectoryError as exc:  # arrays of the wrong shapes
            raise TrajectoryError(f"{base}: not a readable gait solution: {exc}") from None


def _base(path: str | Path) -> Path:
    """The path without a .npz/.json suffix (other dots, as in ``walk_1.3``, are kept)."""
    path = Path(path)
    return path.with_suffix("") if path.suffix in (".npz", ".json") else path


def _with_ext(base: Path, ext: str) -> Path:
    return base.with_name(base.name + ext)


def _json_default(obj: Any) -> Any:
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, tuple):
        return list(obj)
    raise TypeError(f"not JSON serialisable: {type(obj).__name__}")
