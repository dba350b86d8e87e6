"""Semi-real running check: human running kinematics with *virtual* IMUs.

The estimator is trained and tested on synthetic gait from sspinn's own optimal control problems.
This module gives it **human** running kinematics instead, with the same kind of IMU signals: the
OpenSim inverse kinematics of treadmill running (Hamner et al. 2010, opensim-models, subject02,
1.83 m, 65.9 kg, about 10 s at 60 Hz) with its measured ground reaction forces, turned into a
sspinn :class:`~sspinn.data.dataset.Recording` whose IMU signals are the project's virtual IMUs plus
its IMU error model. It is **semi-real**: the kinematics and forces are measured, the IMUs are not.

Data: ``$SSPINN_SHARED_DATA/opensim_hamner_run`` (``subject02_running_ik.mot``,
``subject02_running_grf.mot`` + ``External_Loads.xml``, ``subject02_scaled.osim``; see
``$SSPINN_SHARED_DATA/README.md``). The recording is built by :func:`hamner_running` as follows.

1. **Kinematics → sspinn coordinates.** The IK's sagittal coordinates (degrees → rad; OpenSim's
   signs are sspinn's: hip flexion +, knee flexion −, ankle dorsiflexion +, see
   :mod:`sspinn.model.conventions`) are low-pass filtered at their 60 Hz
   (:func:`~benchmarks.accuracy.inverse_dynamics.lowpass`, zero-lag Butterworth, cutoff ``cutoff``)
   and mapped as :func:`~benchmarks.accuracy.inverse_dynamics.opensim_inverse_dynamics` maps the
   walking subject01: ``pelvis_tilt`` unchanged (sspinn's HAT segment carries the pelvis IMU;
   ``lumbar_extension`` and the arms are dropped, i.e. the trunk is rigid with the pelvis); the
   hip joint centre (sspinn's ``pelvis_tx/ty``) = pelvis origin + R(pelvis_tilt)·(the model's hip
   location in the pelvis frame, right side); hip, knee and ankle angles of both legs shifted by
   the constant frame offsets of :func:`~sspinn.data.opensim_files.sagittal_leg_from_osim`
   (femur −0.65°, tibia 0°). The out-of-plane coordinates (pelvis list/rotation, hip
   adduction/rotation) are ignored: this is the sagittal projection of a 3-D motion.
2. **Treadmill → overground** (Galilean invariance): the whole lab scene moves forward at the belt
   speed, ``pelvis_tx = belt speed · t + the IK's own hip x`` (which drifts by a few cm), and the
   ground reaction loads move with it (their moment about the origin gains ``v·t·F_y``).
3. **Belt speed** (:func:`estimate_belt_speed`), from the IK and the GRF together: with the
   OpenSim model's own sagittal legs, the horizontal velocity of the foot-fixed point that
   coincides with the centre of pressure, ``v_ankle,x − ω_foot·(y_CoP − y_ankle)``, averaged
   over the middle half of every stance (the foot rolls but does not slip on the belt there); the
   belt speed is minus the median over all stances of both feet (≈ 4.05 m/s; the stances agree to
   a few cm/s).
4. **100 Hz**: every filtered 60 Hz signal is interpolated with a cubic spline onto a 100 Hz grid;
   q is built there and differentiated by central differences
   (:func:`~benchmarks.accuracy.inverse_dynamics.differentiate`), then :data:`TRIM_S` at each end
   are cut off (the filters' and differences' edge effects).
5. **Body and height of the ground**: the Winter-scaled sspinn body for 1.83 m and the model's
   mass (:meth:`~sspinn.model.body.BodyParameters.from_anthropometry`) — the body the estimator assumes,
   so that body-model mismatch is not part of this check. Its legs are as long as the OpenSim
   model's (0.898 vs 0.896 m hip–ankle) but its feet differ (heel and toe 7.1 cm below the ankle;
   OpenSim's calcaneus origin is 4.7 cm below it), so the whole scene is shifted vertically
   (+2.7 cm) such that the lower of heel and toe of the loaded foot is, in the median over all
   stance samples, at the ground (y = 0); the shift is in the provenance.
6. **GRF labels** (N, global frame, x forward, y up): per foot from the columns the
   ``External_Loads.xml`` assigns to ``calcn_r`` (``ground_force_*``) and ``calcn_l``
   (``1_ground_force_*``), filtered with the same cutoff as the kinematics (forces and the moment
   about the origin; see :mod:`benchmarks.accuracy.inverse_dynamics`), zero where the vertical force
   is below :data:`~sspinn.data.measured_loads.CONTACT_THRESHOLD_N`; ``w`` puts the
   contact point where the force's line of action crosses the model's heel–toe line
   (:func:`~sspinn.data.measured_loads.grf_inputs`).
7. **Torque labels**: inverse dynamics with sspinn's Kane model
   (:func:`sspinn.model.dynamics.inverse_dynamics`) of these q, q̇, q̈ and GRF with the Winter body. The
   three pelvis rows do not vanish (the measured forces move a 3-D body with arms and a moving
   trunk, the model is a rigid sagittal HAT); their size is reported (:attr:`SemiRealRunning.residual`),
   and it is the Kane residual of the labels: 0.53 BW RMS horizontally, 0.18 BW vertically,
   0.07 BW·H in rotation. Most of it is the HAT: the pelvis tilts ±6° at step frequency, and a
   rigid HAT with its centre of mass 0.32 m above the hip swings its 45 kg with it (the HAT
   alone needs 0.59 BW RMS horizontally), which the human's trunk and arms do not do.
8. **IMUs**: :func:`sspinn.data.sensor_noise.measure_imu` of the seven segments with the true (Winter)
   body, the nominal placement ``IMUPlacement.default(1.83)`` (what the recording tells the
   estimator) and the error model (default :class:`~sspinn.data.sensor_noise.IMUErrorModel`, seeded).
9. **Speed label**: the pelvis (hip centre) speed averaged over each right-foot stride
   (touchdown to touchdown), held over the stride; before the first and after the last complete
   stride, the nearest stride's value.

The provenance says all this and carries ``{"program": {"name": "run"}}``, so
:func:`sspinn.estimator.trivial_predictors.program_of` groups the recording with running.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Final

import numpy as np
from scipy.interpolate import CubicSpline

from benchmarks.accuracy.inverse_dynamics import (
    CONTACT_THRESHOLD_N,
    OPENSIM_JOINTS,
    differentiate,
    grf_inputs,
    lowpass,
    sagittal_coordinates,
)
from sspinn.data.dataset import SAMPLE_RATE_HZ, Labels, Recording
from sspinn.data.opensim_files import (
    OpenSimFormatError,
    SagittalLeg,
    read_external_loads,
    read_opensim_columns,
    read_opensim_header,
    read_osim_model,
    sagittal_leg_from_osim,
)
from sspinn.data.sensor_noise import IMUErrorModel, measure_imu
from sspinn.data.shared_data import shared_data_folder
from sspinn.model.body import BodyParameters, IMUPlacement
from sspinn.model.conventions import SEGMENTS, SIDES, index
from sspinn.model.dynamics import inverse_dynamics
from sspinn.model.kinematics import point_index, point_kinematics
from sspinn.model.trajectory import Trajectory

#: Folder of the recording under ``$SSPINN_SHARED_DATA``.
DATA_FOLDER: Final = "opensim_hamner_run"
IK_FILE: Final = "subject02_running_ik.mot"
GRF_FILE: Final = "subject02_running_grf.mot"
LOADS_FILE: Final = "External_Loads.xml"
MODEL_FILE: Final = "subject02_scaled.osim"
#: Subject height, m (``$SSPINN_SHARED_DATA/README.md``; the .osim file has no height). The mass is
#: the scaled model's total (65.9 kg).
HAMNER_HEIGHT_M: Final = 1.83
#: Low-pass cutoff of the kinematics and the loads, Hz (running: faster than walking's 6 Hz).
DEFAULT_RUN_CUTOFF_HZ: Final = 12.0
#: Seconds cut from each end of the 100 Hz recording (filter and difference edge effects).
TRIM_S: Final = 0.5
#: Recording name and subject id.
RECORDING_NAME: Final = "hamner_subject02_run"
SUBJECT_ID: Final = "hamner_subject02"

_TRANSLATIONS: Final = frozenset({"pelvis_tx", "pelvis_ty", "pelvis_tz"})
_IK_COORDINATES: Final = ("pelvis_tx", "pelvis_ty", "pelvis_tilt", *OPENSIM_JOINTS.values())


def default_hamner_dir() -> Path:
    """``opensim_hamner_run`` in the optional public data (``$SSPINN_SHARED_DATA``,
    :func:`~sspinn.data.shared_data.shared_data_folder`); :class:`FileNotFoundError` when absent."""
    return shared_data_folder(DATA_FOLDER)


# --------------------------------------------------------------------------------------------
# Reading
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class HamnerFiles:
    """The raw sagittal data of the Hamner run.

    Attributes:
        t_ik: (n,) IK times, s (60 Hz). ik: IK coordinate → (n,) values (rad for angles, m).
        t_grf: (m,) GRF times, s. loads: side → (m, 3) [F_x, F_y, M_O] on that foot in the lab
            (N, N, N·m; M_O about the lab origin, CCW seen from the right, free torque included).
        cop: side → (m, 2) centre of pressure (x, y) in the lab, m (0 where there is no force).
        leg: the model's sagittal leg (both legs of the scaled model are identical).
        mass: the model's total mass, kg. ground_y: the lab height of the belt (median y of the
            centre of pressure under load), m. directory: the data folder.
    """

    t_ik: np.ndarray
    ik: dict[str, np.ndarray]
    t_grf: np.ndarray
    loads: dict[str, np.ndarray]
    cop: dict[str, np.ndarray]
    leg: SagittalLeg
    mass: float
    ground_y: float
    directory: Path



def read_hamner_files(directory: str | Path | None = None) -> HamnerFiles:
    """Read the IK, GRF, external-loads and model files of the Hamner run (see the module docs)."""
    directory = Path(directory) if directory is not None else default_hamner_dir()
    if not directory.is_dir():
        raise FileNotFoundError(f"Hamner running data not found: {directory} (the opensim_hamner_run folder)")
    ik_path, grf_path = directory / IK_FILE, directory / GRF_FILE
    model = read_osim_model(directory / MODEL_FILE)
    if np.any(model.joint("ground_pelvis").parent_offset != 0) or np.any(model.joint("ground_pelvis").child_offset != 0):
        raise NotImplementedError(f"{model.path}: ground_pelvis with offset frames is not supported")
    legs = {s: sagittal_leg_from_osim(model, s) for s in SIDES}
    if legs["r"] != legs["l"]:  # pragma: no cover - the scaled model is symmetric
        raise NotImplementedError(f"{model.path}: asymmetric legs are not supported")

    table = read_opensim_columns(ik_path)
    in_degrees = read_opensim_header(ik_path).get("inDegrees", "no").strip().lower() == "yes"
    ik = {}
    for c in _IK_COORDINATES:
        x = table.column(c)
        ik[c] = np.deg2rad(x) if in_degrees and c not in _TRANSLATIONS else x

    grf = read_opensim_columns(grf_path)
    external = read_external_loads(directory / LOADS_FILE)
    loads, cop = {}, {}
    for side in SIDES:
        load = external.get(f"calcn_{side}")
        if load is None:
            raise OpenSimFormatError(f"{directory / LOADS_FILE}: no ExternalForce applied to calcn_{side}")
        cols = load.columns()
        fx, fy = (grf.column(c) for c in cols["force"][:2])
        px, py = (grf.column(c) for c in cols["point"][:2])
        tz = grf.get(cols["torque"][2], np.zeros_like(fx))
        loads[side] = np.stack([fx, fy, px * fy - py * fx + tz], axis=1)
        cop[side] = np.stack([px, py], axis=1)
    on = np.concatenate([cop[s][loads[s][:, 1] > CONTACT_THRESHOLD_N, 1] for s in SIDES])
    return HamnerFiles(
        t_ik=table.column("time"),
        ik=ik,
        t_grf=grf.column("time"),
        loads=loads,
        cop=cop,
        leg=legs["r"],
        mass=model.mass,
        ground_y=float(np.median(on)) if on.size else 0.0,
        directory=directory,
    )


# --------------------------------------------------------------------------------------------
# Kinematics
# --------------------------------------------------------------------------------------------
def stance_intervals(vertical: np.ndarray, threshold: float = CONTACT_THRESHOLD_N) -> list[tuple[int, int]]:
    """Complete stances ``[start, end)`` (sample indices) where ``vertical`` (N) exceeds
    ``threshold``; a stance cut by the start or the end of the signal is left out."""
    on = np.asarray(vertical) > threshold
    edges = np.diff(on.astype(np.int8))
    starts = np.flatnonzero(edges == 1) + 1
    ends = np.flatnonzero(edges == -1) + 1
    return [(int(a), int(ends[ends > a][0])) for a in starts if np.any(ends > a)]


@dataclass(frozen=True)
class BeltSpeed:
    """The belt speed (m/s) and the per-stance estimates it is the median of (side, start time s,
    m/s), see :func:`estimate_belt_speed`."""

    speed: float
    per_stance: tuple[tuple[str, float, float], ...]

    @property
    def spread(self) -> float:
        """Standard deviation of the per-stance estimates, m/s."""
        return float(np.std([v for _, _, v in self.per_stance]))


def estimate_belt_speed(files: HamnerFiles, cutoff: float = DEFAULT_RUN_CUTOFF_HZ) -> BeltSpeed:
    """Belt speed from the IK and the GRF (module docs, step 3).

    At the IK's rate, with the OpenSim model's sagittal legs: during the middle half of every
    complete stance (vertical force above the contact threshold) the foot-fixed point at the
    centre of pressure is at rest on the belt, so its horizontal velocity
    ``v_ankle,x − ω_foot·(y_CoP − y_ankle)`` (y_CoP: the belt's height) is minus the belt speed. Returns the median over
    all stances of both feet."""
    t = files.t_ik
    dt = float(np.mean(np.diff(t)))
    fs = 1.0 / dt
    ik = {c: lowpass(x, fs, cutoff) for c, x in files.ik.items()}
    q = sagittal_coordinates(ik, files.leg)
    u, qdd = differentiate(q, dt)
    leg = files.leg
    body = BodyParameters.from_anthropometry(HAMNER_HEIGHT_M, files.mass).replace(
        **{f"{seg}_{s}": getattr(leg, seg) for s in SIDES for seg in ("femur", "tibia", "foot")}
    )
    pk = point_kinematics(q, u, qdd, np.full((t.size, 2), 0.5), body)
    fs_grf = (files.t_grf.size - 1) / (files.t_grf[-1] - files.t_grf[0])
    estimates = []
    for side in SIDES:
        vertical = np.interp(t, files.t_grf, lowpass(files.loads[side][:, 1], fs_grf, cutoff))
        cop_y = files.ground_y
        ankle = pk[:, point_index(f"ankle_{side}")]
        omega = u[:, 2] + sum(u[:, index(f"{j}_{side}")] for j in ("hip", "knee", "ankle"))
        v_point = ankle[:, 2] - omega * (cop_y - ankle[:, 1])
        for a, b in stance_intervals(vertical):
            n = b - a
            if n < 4:
                continue
            mid = slice(a + n // 4, b - n // 4)
            estimates.append((side, float(t[a]), float(-v_point[mid].mean())))
    if not estimates:
        raise ValueError(f"{files.directory}: no complete stance found in the GRF; cannot estimate the belt speed")
    estimates.sort(key=lambda e: e[1])
    return BeltSpeed(speed=float(np.median([v for _, _, v in estimates])), per_stance=tuple(estimates))


# --------------------------------------------------------------------------------------------
# The recording
# --------------------------------------------------------------------------------------------
@dataclass
class SemiRealRunning:
    """The semi-real running recording and what was found on the way (for the sanity report).

    Attributes:
        recording: the sspinn recording (IMUs with errors, labels, provenance).
        body: the true body the IMUs and torques were computed with (Winter, 1.83 m, 65.9 kg).
        belt: the belt-speed estimate.
        stances: side → complete stances ``[start, end)`` in recording samples (100 Hz).
        residual: Kane residual of the labels (pelvis rows): max and RMS, BW and BW·H.
        vertical_offset: height added to the lab scene so that the model's feet meet the ground, m.
        ideal_imu: (T, 7, 3) the virtual IMUs without errors (same segments as the recording).
    """

    recording: Recording
    body: BodyParameters
    belt: BeltSpeed
    stances: dict[str, list[tuple[int, int]]]
    residual: dict[str, float]
    vertical_offset: float
    ideal_imu: np.ndarray = field(repr=False)

    def summary(self) -> dict[str, Any]:
        """Sanity numbers: duration, belt speed, stride frequency, contact timing, angle ranges
        (degrees), residual and IMU peaks (see ``benchmarks/accuracy/make_semi_real_running.py``)."""
        rec = self.recording
        assert rec.labels is not None and rec.labels.q is not None and rec.labels.grf is not None
        fs = SAMPLE_RATE_HZ
        out: dict[str, Any] = {"duration_s": rec.duration, "n_samples": rec.n_samples}
        out["belt_speed_mps"] = self.belt.speed
        out["belt_speed_spread_mps"] = self.belt.spread
        out["belt_speed_stances"] = len(self.belt.per_stance)
        contact: dict[str, Any] = {}
        for side in SIDES:
            st = self.stances[side]
            touchdowns = np.array([a for a, _ in st])
            stride = np.diff(touchdowns) / fs
            contact[side] = {
                "stances": len(st),
                "stance_s": float(np.median([(b - a) / fs for a, b in st])),
                "stride_s": float(np.median(stride)) if stride.size else float("nan"),
            }
        grf_on = rec.labels.grf[:, 1::2] > CONTACT_THRESHOLD_N
        stride_s = float(np.median([contact[s]["stride_s"] for s in SIDES]))
        out["stride_frequency_hz"] = 1.0 / stride_s
        out["cadence_steps_per_min"] = 120.0 / stride_s
        out["stride_length_m"] = self.belt.speed * stride_s
        out["contact"] = contact
        out["duty_factor"] = float(np.mean(grf_on))
        out["flight_fraction"] = float(np.mean(~grf_on.any(axis=1)))
        out["double_support_fraction"] = float(np.mean(grf_on.all(axis=1)))
        bw = self.body.body_weight
        out["peak_grf_y_bw"] = float(rec.labels.grf[:, 1::2].max() / bw)
        out["grf_x_bw_range"] = [float(rec.labels.grf[:, 0::2].min() / bw), float(rec.labels.grf[:, 0::2].max() / bw)]
        out["mean_grf_y_bw"] = float(rec.labels.grf[:, 1::2].sum(axis=1).mean() / bw)
        q = rec.labels.q
        out["angles_deg"] = {
            c: [float(np.degrees(q[:, index(c)].min())), float(np.degrees(q[:, index(c)].max()))]
            for c in ("pelvis_tilt", "hip_r", "knee_r", "ankle_r", "hip_l", "knee_l", "ankle_l")
        }
        out["hip_height_m"] = [float(q[:, 1].min()), float(q[:, 1].max())]
        out["kane_residual"] = self.residual
        imu = {}
        for k, seg in enumerate(rec.segments):
            acc = np.linalg.norm(self.ideal_imu[:, k, :2], axis=1)
            imu[seg] = {
                "acc_norm_max_mps2": float(acc.max()),
                "acc_norm_median_mps2": float(np.median(acc)),
                "gyr_abs_max_rad_s": float(np.abs(self.ideal_imu[:, k, 2]).max()),
            }
        out["ideal_imu"] = imu
        return out


def _spline(t: np.ndarray, x: np.ndarray, t_new: np.ndarray) -> np.ndarray:
    return CubicSpline(t, x, axis=0)(t_new)


def _stride_speed(x: np.ndarray, touchdowns: list[int]) -> np.ndarray:
    """(T,) average speed of ``x`` (m) over each stride ``touchdowns[i] … touchdowns[i+1]``, held
    over the stride; the nearest stride's value before the first and after the last one."""
    dt = 1.0 / SAMPLE_RATE_HZ
    n = x.size
    if len(touchdowns) < 2:
        return np.full(n, (x[-1] - x[0]) / ((n - 1) * dt))
    speed = np.empty(n)
    for i, (a, b) in enumerate(zip(touchdowns[:-1], touchdowns[1:])):
        v = (x[b] - x[a]) / ((b - a) * dt)
        lo = 0 if i == 0 else a
        hi = n if i == len(touchdowns) - 2 else b
        speed[lo:hi] = v
    return speed


def _jsonable(obj: Any) -> Any:
    """Tuples → lists, numpy → Python, inf → "inf" (strict JSON)."""
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _jsonable(obj.tolist())
    if isinstance(obj, np.generic):
        obj = obj.item()
    if isinstance(obj, float) and not math.isfinite(obj):
        return str(obj)
    return obj


def hamner_running(
    data_dir: str | Path | None = None,
    seed: int = 0,
    error_model: IMUErrorModel | None = None,
    cutoff: float = DEFAULT_RUN_CUTOFF_HZ,
    trim_s: float = TRIM_S,
    name: str = RECORDING_NAME,
) -> SemiRealRunning:
    """The semi-real running recording of the Hamner run and its diagnostics (module docs).

    Args:
        data_dir: the ``opensim_hamner_run`` folder (default: :func:`default_hamner_dir`).
        seed: seed of the IMU error model's random draws (same seed → identical recording).
        error_model: IMU error model (default :class:`~sspinn.data.sensor_noise.IMUErrorModel`;
            :meth:`~sspinn.data.sensor_noise.IMUErrorModel.none` gives the ideal virtual IMUs).
        cutoff: low-pass cutoff of kinematics and loads, Hz.
        trim_s: seconds cut from each end.
        name: recording name.
    """
    model = IMUErrorModel() if error_model is None else error_model
    files = read_hamner_files(data_dir)
    belt = estimate_belt_speed(files, cutoff)
    v = belt.speed

    # filter at the source rates, then cubic splines onto one 100 Hz grid
    fs_ik = 1.0 / float(np.mean(np.diff(files.t_ik)))
    fs_grf = (files.t_grf.size - 1) / (files.t_grf[-1] - files.t_grf[0])
    start = max(files.t_ik[0], files.t_grf[0])
    stop = min(files.t_ik[-1], files.t_grf[-1])
    dt = 1.0 / SAMPLE_RATE_HZ
    t_lab = start + dt * np.arange(int(math.floor((stop - start) / dt + 1e-9)) + 1)
    ik = {c: _spline(files.t_ik, lowpass(x, fs_ik, cutoff), t_lab) for c, x in files.ik.items()}
    loads = {s: _spline(files.t_grf, lowpass(x, fs_grf, cutoff), t_lab) for s, x in files.loads.items()}

    # treadmill → overground: the lab scene moves forward at v (t = 0 at the recording's start)
    t0 = t_lab[0] + trim_s
    shift_x = v * (t_lab - t0)
    q = sagittal_coordinates(ik, files.leg)
    q[:, 0] += shift_x
    for s in SIDES:
        loads[s][:, 2] += shift_x * loads[s][:, 1]

    # the sspinn body; the scene is lifted so that the loaded foot's sole meets the ground
    body = BodyParameters.from_anthropometry(HAMNER_HEIGHT_M, files.mass)
    zeros = np.zeros_like(q)
    pk = point_kinematics(q, zeros, zeros, np.full((q.shape[0], 2), 0.5), body)
    soles = []
    for s in SIDES:
        on = loads[s][:, 1] > CONTACT_THRESHOLD_N
        soles.append(np.minimum(pk[on, point_index(f"heel_{s}"), 1], pk[on, point_index(f"toe_{s}"), 1]))
    offset = -float(np.median(np.concatenate(soles)))
    q[:, 1] += offset
    for s in SIDES:
        loads[s][:, 2] -= offset * loads[s][:, 0]

    u, qdd = differentiate(q, dt)
    keep = slice(int(round(trim_s / dt)), q.shape[0] - int(round(trim_s / dt)))
    q, u, qdd = q[keep], u[keep], qdd[keep]
    loads = {s: x[keep] for s, x in loads.items()}
    n = q.shape[0]
    time = np.arange(n) * dt

    grf, w = grf_inputs(q, body, loads)
    tau, _ = inverse_dynamics(q, u, qdd, grf, w, body)
    trajectory = Trajectory(time=time, q=q, u=u, qdd=qdd, tau=np.asarray(tau), grf=grf, w=w)
    r = trajectory.kane_residual(body)
    residual = {
        "max_trans_bw": float(np.abs(r[:, :2]).max()),
        "rms_trans_bw": float(np.sqrt(np.mean(r[:, :2] ** 2))),
        "rms_x_bw": float(np.sqrt(np.mean(r[:, 0] ** 2))),
        "rms_y_bw": float(np.sqrt(np.mean(r[:, 1] ** 2))),
        "max_rot_bwh": float(np.abs(r[:, 2:]).max()),
        "rms_rot_bwh": float(np.sqrt(np.mean(r[:, 2:] ** 2))),
        "samples": int(n),
    }

    stances = {s: stance_intervals(grf[:, 2 * k + 1]) for k, s in enumerate(SIDES)}
    speed = _stride_speed(q[:, 0], [a for a, _ in stances["r"]])

    nominal = IMUPlacement.default(HAMNER_HEIGHT_M)
    imu, info = measure_imu(q, u, qdd, body, nominal, model, seed, sample_rate_hz=SAMPLE_RATE_HZ)
    ideal, _ = measure_imu(q, u, qdd, body, nominal, IMUErrorModel.none(), 0, sample_rate_hz=SAMPLE_RATE_HZ)
    true_placement: IMUPlacement = info["true_placement"]

    provenance = {
        "kind": "semi-real",
        "description": (
            "semi-real running: human kinematics (OpenSim inverse kinematics of treadmill running, Hamner "
            "subject02) and measured ground reaction forces; the IMU signals are virtual (sspinn's model) "
            "with sspinn's IMU error model, NOT measured IMUs"
        ),
        "program": {"name": "run", "speeds_mps": [v]},
        "source": {
            "folder": str(files.directory),
            "files": [IK_FILE, GRF_FILE, LOADS_FILE, MODEL_FILE],
            "origin": "opensim-org/opensim-models, Hamner running pipeline, subject02 (see the data folder's README.md)",
            "original_rate_hz": fs_ik,
            "start_s": float(t0),
        },
        "method": "benchmarks.accuracy.semi_real_running.hamner_running (see its module docstring)",
        "treadmill": {
            "belt_speed_mps": v,
            "belt_speed_method": (
                "median over stances (both feet) of minus the mean horizontal velocity, over the middle half "
                "of the stance, of the foot-fixed point at the centre of pressure (IK with the OpenSim model's "
                "sagittal legs)"
            ),
            "belt_speed_spread_mps": belt.spread,
            "stances_used": len(belt.per_stance),
            "overground": "pelvis_tx = belt speed * t + the IK's hip x; loads moved with the scene",
        },
        "filter": {"lowpass_cutoff_hz": cutoff, "design": "2nd-order Butterworth, forward-backward, /0.802",
                   "resampling": "cubic spline 60 Hz -> 100 Hz after filtering", "trim_s": trim_s},
        "vertical_offset_m": offset,
        "labels": {
            "q, u, qdd": "IK (sagittal projection; lumbar, arms and out-of-plane motion dropped), differentiated",
            "grf": f"measured, filtered, zero below {CONTACT_THRESHOLD_N} N vertical",
            "tau": "inverse dynamics with sspinn's Kane model and the Winter body (not measured)",
            "w": "where the measured force's line of action crosses the model's heel-toe line",
            "speed": "hip speed averaged over each right stride",
        },
        "kane_residual": residual,
        "imu_seed": seed,
        "imu_error_model": _jsonable(model.to_dict()),
        "ground_truth": {
            "body": _jsonable(body.to_dict()),
            "imu_placement": true_placement.to_dict(),
        },
    }
    recording = Recording(
        name=name,
        imu=imu,
        segments=SEGMENTS,
        height=HAMNER_HEIGHT_M,
        mass=files.mass,
        subject=SUBJECT_ID,
        placement=nominal,
        labels=Labels.from_trajectory(trajectory, speed=speed),
        provenance=provenance,
    )
    return SemiRealRunning(
        recording=recording,
        body=body,
        belt=belt,
        stances=stances,
        residual=residual,
        vertical_offset=offset,
        ideal_imu=ideal,
    )


def hamner_running_recording(
    data_dir: str | Path | None = None,
    seed: int = 0,
    error_model: IMUErrorModel | None = None,
    cutoff: float = DEFAULT_RUN_CUTOFF_HZ,
) -> Recording:
    """The :class:`~sspinn.data.dataset.Recording` of :func:`hamner_running`."""
    return hamner_running(data_dir, seed=seed, error_model=error_model, cutoff=cutoff).recording


__all__ = [
    "BeltSpeed",
    "HamnerFiles",
    "SemiRealRunning",
    "default_hamner_dir",
    "estimate_belt_speed",
    "hamner_running",
    "hamner_running_recording",
    "read_hamner_files",
    "sagittal_coordinates",
    "stance_intervals",
]
