"""The trajectory type of the project: one motion of the sagittal model sampled in time.

A :class:`Trajectory` holds what every part of the project produces or consumes about a motion:
a predicted gait cycle (``predictive.ocp.solution.GaitSolution``), a synthetic stride chain
(``predictive.synth.chain.ChainResult``) and an estimate (:class:`sspinn.estimator.inference.GaitEstimate`)
are trajectories with a few fields of their own, and a recording's labels give one
(:meth:`sspinn.data.dataset.Labels.trajectory`). Units and signs are those of
:mod:`sspinn.model.conventions` (``docs/conventions.md``); n samples:

* ``time`` (n,): s;
* ``q`` (n, 9): m (pelvis_tx, pelvis_ty), rad (pelvis_tilt and the joints; hip flexion +,
  knee flexion −, ankle dorsiflexion +);
* ``u`` (n, 9) = q̇: m/s, rad/s; ``qdd`` (n, 9) = q̈: m/s², rad/s²;
* ``tau`` (n, 6): joint torques, N·m (hip_r … ankle_l; positive τ_j increases coordinate j);
* ``grf`` (n, 4): ground reaction forces, N, global frame, ``[Fx_r, Fy_r, Fx_l, Fy_l]``;
* ``w`` (n, 2): contact-point fractions (toe 0 … heel 1), right and left.

The **Kane residual of a trajectory** has one definition, :meth:`Trajectory.kane_residual`:
``M(q)·q̈ − f(q, u, τ, F, w)`` (:func:`sspinn.model.dynamics.kane_residual`) scaled by body weight (rows
pelvis_tx, pelvis_ty) and body weight × height (the rotational rows), with the stored GRF and w or
those of a contact model. Whatever differs between the checks of the project (q̈ as a backward
difference of u, torques that include passive moments, a resampled motion) is a different
trajectory, built with :meth:`Trajectory.as_trajectory`, :meth:`Trajectory.resample` or
:meth:`Trajectory.from_contact_model`, not a different residual.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar, Final, Literal

import numpy as np

from sspinn.errors import UserError
from sspinn.model.conventions import COORDINATES, GRF, JOINTS, N_GRF, N_Q, N_TAU
from sspinn.run_folder import atomic_path

if TYPE_CHECKING:  # dynamics (and the contact model's sympy) load on first use, not with the dataset format
    from sspinn.model.body import BodyParameters
    from sspinn.model.contact import ContactParameters

#: Column names of the trajectory's fields (a recording's label columns, an estimate's CSV).
COLUMNS: Final[dict[str, tuple[str, ...]]] = {
    "q": COORDINATES,
    "u": tuple(f"d_{c}" for c in COORDINATES),
    "qdd": tuple(f"dd_{c}" for c in COORDINATES),
    "tau": tuple(f"tau_{j}" for j in JOINTS),
    "grf": GRF,
    "w": ("w_r", "w_l"),
}
#: The fields of a :class:`Trajectory`, in order.
FIELDS: Final[tuple[str, ...]] = ("time", *COLUMNS)

Resampling = Literal["linear", "spline"]


class TrajectoryError(UserError):
    """A trajectory with a field of the wrong shape, non-finite values where they are refused, or
    an unreadable trajectory file; the message names the field (and the file)."""


def residual_scale(body: BodyParameters) -> np.ndarray:
    """(9,) the Kane residual's scale: body weight (N) for pelvis_tx and pelvis_ty, body weight ×
    height (N·m) for the seven rotational rows."""
    bw = body.body_weight
    return np.array([bw, bw] + [bw * body.height] * (N_Q - 2))


def first_non_finite(values: dict[str, Any]) -> tuple[str, int, int] | None:
    """The first of ``values`` (name → array with samples along axis 0) holding NaN or inf, as
    (name, first such sample, number of such values); None if every value is finite."""
    for name, value in values.items():
        arr = np.asarray(value, dtype=float)
        bad = ~np.isfinite(arr.reshape(len(arr), -1)) if arr.ndim else ~np.isfinite(arr.reshape(1, 1))
        if bad.any():
            return name, int(np.argmax(bad.any(axis=1))), int(bad.sum())
    return None


def save_npz(path: str | Path, arrays: dict[str, Any], *, finite: tuple[str, ...], what: str, label: Any = None) -> Path:
    """Write ``arrays`` as the npz file ``path`` atomically (a unique temporary file beside it,
    then a rename: an interrupted writer leaves the old file or none). Refused with
    :class:`TrajectoryError` — ``"<label>: refusing to write <what> with non-finite [names]"`` —
    if an array named in ``finite`` holds NaN or inf. Returns ``path``."""
    path = Path(path)
    bad = [k for k in finite if not np.isfinite(np.asarray(arrays[k], dtype=float)).all()]
    if bad:
        raise TrajectoryError(f"{path if label is None else label}: refusing to write {what} with non-finite {bad}")
    with atomic_path(path) as tmp, open(tmp, "wb") as f:
        np.savez(f, **arrays)
    return path


def _npz_path(path: str | Path) -> Path:
    path = Path(path)
    return path if path.suffix == ".npz" else path.with_name(path.name + ".npz")


@dataclass
class Trajectory:
    """One motion sampled at ``time`` (see the module docstring for the units).

    Attributes:
        time: (n,) sample times, s.
        q, u, qdd: (n, 9) coordinates (m, rad), speeds (m/s, rad/s), accelerations (m/s², rad/s²).
        tau: (n, 6) joint torques, N·m.
        grf: (n, 4) ground reaction forces [Fx_r, Fy_r, Fx_l, Fy_l], N.
        w: (n, 2) contact-point fractions (toe 0 … heel 1), right and left.

    Construction checks the shapes (:class:`TrajectoryError` naming the field); values may be
    non-finite (a failed optimisation or a diverged network is still a result to report):
    :meth:`check_finite` refuses them, and :meth:`save` does.
    """

    time: np.ndarray
    q: np.ndarray
    u: np.ndarray
    qdd: np.ndarray
    tau: np.ndarray
    grf: np.ndarray
    w: np.ndarray

    #: Per-sample fields and the shape of one sample; subclasses add theirs.
    SAMPLE_SHAPES: ClassVar[dict[str, tuple[int, ...]]] = {
        "time": (), "q": (N_Q,), "u": (N_Q,), "qdd": (N_Q,), "tau": (N_TAU,), "grf": (N_GRF,), "w": (2,),
    }

    def __post_init__(self) -> None:
        for name in FIELDS:
            value = getattr(self, name)
            if not (isinstance(value, np.ndarray) and value.dtype.kind == "f"):
                try:
                    setattr(self, name, np.asarray(value, dtype=float))
                except (TypeError, ValueError) as exc:
                    raise TrajectoryError(f"{type(self).__name__}.{name}: not an array of numbers ({exc})") from None
        if self.time.ndim != 1:
            raise TrajectoryError(f"{type(self).__name__}.time: expected shape (n,), got {self.time.shape}")
        n = len(self.time)
        for name, shape in self.SAMPLE_SHAPES.items():
            got = np.shape(getattr(self, name))
            if got != (n, *shape):
                raise TrajectoryError(
                    f"{type(self).__name__}.{name}: expected shape {(n, *shape)} ({n} samples, as time), got {got}"
                )

    # ------------------------------------------------------------------ basics
    @property
    def n_samples(self) -> int:
        return len(self.time)

    def arrays(self) -> dict[str, np.ndarray]:
        """The seven fields of a :class:`Trajectory` by name (the arrays themselves, not copies)."""
        return {name: getattr(self, name) for name in FIELDS}

    def as_trajectory(self, **changes: np.ndarray) -> Trajectory:
        """The plain :class:`Trajectory` of these fields (of a subclass too), with ``changes``
        (e.g. ``qdd=...``) replacing fields; the arrays are shared, not copied."""
        return Trajectory(**{**self.arrays(), **changes})

    def __getitem__(self, index: slice) -> Trajectory:
        """``traj[a:b:c]``: the samples of a slice as a plain :class:`Trajectory` (views)."""
        if not isinstance(index, slice):
            raise TypeError(f"a trajectory is sliced by a slice of samples (traj[a:b]), not by {type(index).__name__}")
        return Trajectory(**{name: value[index] for name, value in self.arrays().items()})

    def window(self, start: float, stop: float) -> Trajectory:
        """The samples with ``start <= time < stop`` (s) as a plain :class:`Trajectory` (views)."""
        i, j = np.searchsorted(self.time, [start, stop], side="left")
        return self[int(i) : int(j)]

    def columns(self) -> dict[str, np.ndarray]:
        """``time`` and one column per coordinate, speed, acceleration, torque, force and contact
        fraction, named as :data:`COLUMNS` (the label columns of a recording)."""
        cols = {"time": self.time}
        for group, names in COLUMNS.items():
            values = getattr(self, group)
            cols |= {c: values[:, i] for i, c in enumerate(names)}
        return cols

    def non_finite(self) -> tuple[str, int, int] | None:
        """The first per-sample field (:attr:`SAMPLE_SHAPES` order) holding NaN or inf, as
        (name, first such sample, count); None if every value is finite."""
        return first_non_finite({name: getattr(self, name) for name in self.SAMPLE_SHAPES})

    def check_finite(self) -> Trajectory:
        """``self`` if every value is finite, else :class:`TrajectoryError` naming the field and
        the first sample."""
        bad = self.non_finite()
        if bad is not None:
            name, k, count = bad
            raise TrajectoryError(f"{type(self).__name__}: {name} is not finite from sample {k} on ({count} values)")
        return self

    # ------------------------------------------------------------------ resampling
    def resample(
        self, times: np.ndarray, *, period: float | None = None, speed: float = 0.0, method: Resampling = "linear"
    ) -> Trajectory:
        """The motion at other ``times`` (s) as a plain :class:`Trajectory`.

        Args:
            times: (m,) the new sample times.
            period: for a cycle, its duration T (s): the samples are one period of a periodic
                motion (``time[-1] − time[0] < T``), times anywhere are mapped into it, and the
                interval from the last sample to ``time[0] + T`` interpolates back to the first.
                None: a non-periodic motion, and ``times`` must lie within ``time[0] … time[-1]``.
            speed: with ``period``, the average forward speed (m/s): pelvis_tx advances
                ``speed·T`` per period and is interpolated as ``pelvis_tx − speed·t``.
            method: ``"linear"``: every field interpolated linearly (exact at the original
                times up to the rounding of ``speed·t``); ``"spline"``: q by a cubic spline
                (periodic with ``period``, else not-a-knot) and u, q̈ its first and second
                derivatives, so that the new samples are kinematically consistent; τ, GRF and w
                linear.
        """
        t = np.asarray(times, dtype=float)
        if t.ndim != 1 or not np.isfinite(t).all():
            raise TrajectoryError(f"resample: times must be a 1-D array of finite values, got shape {t.shape}")
        if method not in ("linear", "spline"):
            raise ValueError(f"resample: method must be 'linear' or 'spline', got {method!r}")
        if self.n_samples < 2 or not (np.diff(self.time) > 0).all():
            raise TrajectoryError(f"{type(self).__name__}.time: resampling needs increasing sample times (at least 2)")
        t0 = self.time[0]
        if period is None:
            if len(t) and (t.min() < t0 or t.max() > self.time[-1]):
                raise TrajectoryError(
                    f"resample: times {t.min():.6g} … {t.max():.6g} s lie outside the trajectory's "
                    f"{t0:.6g} … {self.time[-1]:.6g} s (give period= for a cycle)"
                )
        elif not (period > self.time[-1] - t0):
            raise TrajectoryError(f"resample: period {period} s must exceed the samples' span {self.time[-1] - t0:.6g} s")

        def linear(values: np.ndarray) -> np.ndarray:
            return np.stack([np.interp(t, self.time, values[:, i], period=period) for i in range(values.shape[1])], axis=1)

        q = np.array(self.q, dtype=float)
        if period is not None:
            q[:, 0] -= speed * self.time
        if method == "linear":
            q, u, qdd = linear(q), linear(self.u), linear(self.qdd)
        else:
            from scipy.interpolate import CubicSpline

            if period is None:
                spline = CubicSpline(self.time, q, axis=0)
            else:
                spline = CubicSpline(np.append(self.time, t0 + period), np.vstack([q, q[:1]]), bc_type="periodic", axis=0)
            q, u, qdd = spline(t), spline(t, 1), spline(t, 2)
            if period is not None:
                u[:, 0] += speed
        if period is not None:
            q[:, 0] += speed * t
        return Trajectory(time=t, q=q, u=u, qdd=qdd, tau=linear(self.tau), grf=linear(self.grf), w=linear(self.w))

    # ------------------------------------------------------------------ dynamics
    @classmethod
    def from_contact_model(
        cls,
        time: np.ndarray,
        q: np.ndarray,
        u: np.ndarray,
        qdd: np.ndarray,
        tau: np.ndarray,
        body: BodyParameters,
        contact: ContactParameters | np.ndarray | None = None,
    ) -> Trajectory:
        """A plain :class:`Trajectory` whose GRF and w are the forward-simulation contact model's
        (:func:`sspinn.model.dynamics.contact_forces`; default contact parameters if None) at q, u."""
        from sspinn.model import dynamics

        grf, w = dynamics.contact_forces(q, u, body, contact)
        return Trajectory(time=time, q=q, u=u, qdd=qdd, tau=tau, grf=np.asarray(grf), w=np.asarray(w))

    def kane_residual(self, body: BodyParameters, contact: ContactParameters | np.ndarray | None = None) -> np.ndarray:
        """(n, 9) Kane residual ``M(q)·q̈ − f(q, u, τ, F, w)`` at the samples (NumPy backend,
        :func:`sspinn.model.dynamics.kane_residual`), divided by :func:`residual_scale`: body weights
        for the rows pelvis_tx, pelvis_ty and BW·height for the rotational rows (dimensionless).

        With ``contact`` the GRF and w are recomputed from the forward-simulation contact model
        at q, u (the residual the optimal control problems constrain); without, the stored
        ``grf`` and ``w`` are used."""
        from sspinn.model import dynamics

        if contact is None:
            grf, w = self.grf, self.w
        else:
            grf, w = dynamics.contact_forces(self.q, self.u, body, contact)
        r = dynamics.kane_residual(self.q, self.u, self.qdd, self.tau, grf, w, body)
        return np.asarray(r) / residual_scale(body)

    # ------------------------------------------------------------------ persistence
    def save(self, path: str | Path) -> Path:
        """Write the seven fields as ``<path>.npz`` (``.npz`` appended unless present),
        atomically; refused (:class:`TrajectoryError` naming the fields) if any value is not
        finite. Returns the file's path."""
        path = _npz_path(path)
        return save_npz(path, self.arrays(), finite=FIELDS, what="a trajectory")

    @classmethod
    def load(cls, path: str | Path) -> Trajectory:
        """Read a file written by :meth:`Trajectory.save` (always a plain :class:`Trajectory`;
        the subclasses with a file format of their own override this)."""
        path = _npz_path(path)
        if not path.exists():
            raise FileNotFoundError(f"trajectory file {path} not found")
        try:
            with np.load(path) as data:
                missing = [k for k in FIELDS if k not in data.files]
                if missing:
                    raise TrajectoryError(f"{path}: not a trajectory file (no {missing})")
                arrays = {k: data[k] for k in FIELDS}
        except (ValueError, OSError, EOFError) as exc:
            if isinstance(exc, TrajectoryError):
                raise
            raise TrajectoryError(f"{path}: not a readable trajectory file (.npz from Trajectory.save): {exc}") from None
        try:
            return Trajectory(**arrays).check_finite()
        except TrajectoryError as exc:
            raise TrajectoryError(f"{path}: {exc}") from None
