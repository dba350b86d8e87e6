"""Inverse dynamics of real walking recordings with the Kane model, checked against references
computed by others.

Two references (see ``$SSPINN_SHARED_DATA/README.md``):

* **CSU 2D inverse dynamics** (GaitAnalysisToolKit ``leg2d.m``, Winter's method): markers and a
  force plate at 100 Hz, results in ``refresults.mat`` (301×15: angles, angular velocities,
  moments in N·m/kg, joint forces). See :func:`csu_inverse_dynamics`.
* **OpenSim subject01** (Gait10dof18musc): inverse kinematics, ground reaction forces and
  OpenSim's inverse-dynamics moments (N·m). See :func:`opensim_inverse_dynamics`.

Both use :func:`sspinn.model.dynamics.inverse_dynamics`, whose joint torques are generalized forces of
sspinn's angles (:mod:`sspinn.model.conventions`: CCW seen from the right, hip flexion +, knee
flexion −, ankle dorsiflexion +; a torque acts +τ on the distal and −τ on the proximal segment).
The right-leg rows of the Kane residual involve only the pelvis coordinates (hip position and
pelvis tilt, with their derivatives) and the right-leg segments, so right-leg moments need no
trunk or left-leg data: those coordinates are set to zero and the HAT/left-leg parameters are
Winter-scaled placeholders that do not enter the right-leg moments.

Signal processing (both datasets, documented here once):

* low-pass: 2nd-order Butterworth run forward and backward (:func:`scipy.signal.filtfilt`, zero
  lag, 4th-order overall), with the cutoff divided by Winter's dual-pass correction 0.802 so that
  the −3 dB point of the double pass is the nominal cutoff (6 Hz by default) — the design of the
  CSU toolkit's ``myfiltfilt.m``, discretised differently. The same cutoff is applied to kinematics and to the force-plate
  loads (forces and moments about a fixed point, which are linear in the data; the centre of
  pressure is not filtered, being a ratio that is undefined at zero force), to avoid the impact
  artefacts of mismatched filtering (Bisseling & Hof 2006; Kristianslund et al. 2012).
* derivatives: second-order central differences (:func:`numpy.gradient`, one-sided at the ends)
  of the filtered generalized coordinates, applied twice for q̈.
* contact: where the filtered vertical force is below a threshold (20 N) the foot gets no load;
  otherwise the measured force is applied at the foot-fixed point of the model's heel–toe line
  whose position w makes the force's line of action reproduce the measured moment about the
  global origin (:func:`contact_fraction_for_load`). Force plus moment about a point is
  equivalent to the force alone along that line, so the applied load is exact, free moment
  included.

What ``refresults.mat`` really is: porting the toolkit's *older* ``leg2d.m`` (folder
``Octave-Matlab-Codes/2D Inverse Dynamics``, with its ``rtfilter``-based ``myfiltfilt.m``)
reproduces all angle and moment columns to < 1e-6 when it is run with a **4 Hz** cutoff (not the
6 Hz of the toolkit's test script). That version reads each segment's mass fraction and radius
of gyration in the kinematics loop only, so its inverse-dynamics loop uses the **foot's values
(0.0145, 0.475) for the thigh and shank too**. The reference hip and knee moments therefore
carry too little thigh and shank inertia and weight; the ankle moment is unaffected. The
physically meant comparison (Winter's table, 6 Hz) is the default; ``reference_inertia=True``
with ``cutoff=LEG2D_REFERENCE_CUTOFF_HZ`` (:func:`csu_reference_replica`) uses the reference's
own parameters and cutoff, to separate differences of the dynamics from differences of inputs.
The 4 Hz cutoff was identified from the reference *angles* (which involve no dynamics): with our
filter they agree to 0.0003 rad RMS at 4 Hz against 0.009 rad at 6 Hz.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Final

import numpy as np
import scipy.io
from scipy.interpolate import CubicSpline
from scipy.signal import butter, filtfilt

from sspinn.data.measured_loads import CONTACT_THRESHOLD_N, grf_inputs
from sspinn.data.opensim_files import (
    SagittalLeg,
    read_external_loads,
    read_opensim_columns,
    read_opensim_header,
    read_osim_model,
    sagittal_leg_from_osim,
)
from sspinn.data.shared_data import shared_data_folder
from sspinn.model.body import WINTER, BodyParameters, Foot, Segment
from sspinn.model.conventions import GRF, N_Q, SIDES, index
from sspinn.model.dynamics import inverse_dynamics
from sspinn.testing.sensor_mounting import RATE_HZ, Gait

#: Nominal low-pass cutoff for markers, coordinates and forces, Hz.
DEFAULT_CUTOFF_HZ: Final[float] = 6.0
#: Winter's correction of the cutoff of a dual-pass (forward–backward) 2nd-order Butterworth filter.
DUAL_PASS_CORRECTION: Final[float] = 0.802

#: CSU subject mass (kg; subject 7 of the HBM paper, from the toolkit's test script).
CSU_BODY_MASS: Final[float] = 67.2
#: Gravity used by ``leg2d.m``, m/s².
CSU_GRAVITY: Final[float] = 9.81
#: CSU markers, in the column order of ``rawdata.txt``.
CSU_MARKERS: Final[tuple[str, ...]] = ("RSHO", "RGTRO", "RLEK", "RLM", "RHEE", "RMT5")
CSU_JOINTS: Final[tuple[str, ...]] = ("hip_r", "knee_r", "ankle_r")
#: refresults sign relative to sspinn per joint: leg2d's hip flexion, knee flexion and ankle
#: plantarflexion are positive (sspinn: hip flexion +, knee flexion −, ankle dorsiflexion +).
CSU_SIGNS: Final[tuple[float, float, float]] = (1.0, -1.0, -1.0)
#: Cutoff with which refresults.mat was computed (identified from its angles, see module docs), Hz.
LEG2D_REFERENCE_CUTOFF_HZ: Final[float] = 4.0

OPENSIM_JOINTS: Final[dict[str, str]] = {
    "hip_r": "hip_flexion_r",
    "knee_r": "knee_angle_r",
    "ankle_r": "ankle_angle_r",
    "hip_l": "hip_flexion_l",
    "knee_l": "knee_angle_l",
    "ankle_l": "ankle_angle_l",
}
#: OpenSim coordinates that are translations (m); every other coordinate is an angle.
_OPENSIM_TRANSLATIONS: Final[frozenset[str]] = frozenset({"pelvis_tx", "pelvis_ty", "pelvis_tz"})


# --------------------------------------------------------------------------------------------
# Results
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class JointStats:
    """Agreement of one joint moment with its reference: Pearson r and RMSE (N·m/kg)."""

    joint: str
    r: float
    rmse: float


@dataclass(frozen=True)
class Comparison:
    """Our joint moments and a reference, sample by sample.

    Attributes:
        dataset: short name of the reference.
        joints: sspinn joint names of the columns (e.g. ``"knee_r"``).
        time: s, shape (n,).
        ours, reference: joint moments in N·m/kg, shape (n, len(joints)), both in the
            reference's sign convention (``convention``).
        convention: the reference's sign convention, in words.
        angles_ours, angles_reference: optional joint angles (rad), same layout and convention,
            for checking that the sign mapping is right independently of the moments.
    """

    dataset: str
    joints: tuple[str, ...]
    time: np.ndarray
    ours: np.ndarray
    reference: np.ndarray
    convention: str
    angles_ours: np.ndarray | None = field(default=None, repr=False)
    angles_reference: np.ndarray | None = field(default=None, repr=False)

    def stats(self) -> tuple[JointStats, ...]:
        """Pearson r and RMSE per joint over all samples."""
        return tuple(
            JointStats(j, pearson_r(self.ours[:, k], self.reference[:, k]), rmse(self.ours[:, k], self.reference[:, k]))
            for k, j in enumerate(self.joints)
        )

    def stat(self, joint: str) -> JointStats:
        """:meth:`stats` of one joint."""
        return self.stats()[index(joint, self.joints)]


def pearson_r(a: np.ndarray, b: np.ndarray) -> float:
    """Pearson correlation coefficient of two 1-D signals."""
    return float(np.corrcoef(np.asarray(a, float), np.asarray(b, float))[0, 1])


def rmse(a: np.ndarray, b: np.ndarray) -> float:
    """Root-mean-square difference of two signals (in their unit)."""
    return float(np.sqrt(np.mean((np.asarray(a, float) - np.asarray(b, float)) ** 2)))


# --------------------------------------------------------------------------------------------
# Signal processing
# --------------------------------------------------------------------------------------------
def highest_cutoff(fs: float) -> float:
    """The highest cut-off :func:`lowpass` takes at the sampling rate ``fs`` (Hz): its per-pass
    cut-off, ``cutoff / 0.802``, must stay below fs/2."""
    return fs / 2.0 * DUAL_PASS_CORRECTION


def lowpass(x: np.ndarray, fs: float, cutoff: float = DEFAULT_CUTOFF_HZ) -> np.ndarray:
    """Zero-lag low-pass along axis 0: 2nd-order Butterworth, forward and backward, with the
    cutoff ``cutoff / 0.802`` per pass so that the double pass has its −3 dB point at ``cutoff``
    (Hz). ``fs`` is the sampling rate, Hz; ``cutoff`` lies between 0 and :func:`highest_cutoff`."""
    wn = cutoff / DUAL_PASS_CORRECTION / (fs / 2.0)
    if not 0.0 < cutoff < highest_cutoff(fs):
        raise ValueError(f"cutoff {cutoff} Hz (/{DUAL_PASS_CORRECTION} per pass) is not below fs/2 = {fs / 2} Hz")
    b, a = butter(2, wn)
    return filtfilt(b, a, np.asarray(x, dtype=float), axis=0)


def differentiate(x: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """First and second time derivatives along axis 0 by central differences (one-sided at the
    ends); ``dt`` in s."""
    xd = np.gradient(x, dt, axis=0)
    return xd, np.gradient(xd, dt, axis=0)


def fill_gaps(t: np.ndarray, x: np.ndarray, what: str = "signal") -> np.ndarray:
    """Linear interpolation over NaN samples, column by column (constant beyond the ends)."""
    x = np.array(x, dtype=float)
    for k in range(x.shape[1]):
        ok = np.isfinite(x[:, k])
        if ok.sum() < 2:
            raise ValueError(f"{what}: column {k} has fewer than two valid samples")
        x[:, k] = np.interp(t, t[ok], x[ok, k])
    return x


# --------------------------------------------------------------------------------------------
# CSU 2D inverse dynamics (GaitAnalysisToolKit leg2d)
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class CSURecording:
    """The CSU recording: time (s), raw marker positions (m; (n, 2) per marker name, NaN where
    missing), force-plate channels (n, 3) = FP2 [ForX, ForY, MomZ] (N, N, N·m) and the reference
    ``refresults`` (n, 15)."""

    time: np.ndarray
    markers: dict[str, np.ndarray]
    plate: np.ndarray
    reference: np.ndarray
    mass: float = CSU_BODY_MASS


def load_csu(directory: str | Path) -> CSURecording:
    """Read ``rawdata.txt`` (whitespace separated, header line starting with ``%``) and
    ``refresults.mat`` from ``directory``."""
    directory = Path(directory)
    raw_path, ref_path = directory / "rawdata.txt", directory / "refresults.mat"
    for path in (raw_path, ref_path):
        if not path.is_file():
            raise FileNotFoundError(f"CSU data file not found: {path}")
    with raw_path.open() as fh:
        header = fh.readline().lstrip("%").split()
    expected = ["TimeStamp", *[f"{m}.Pos{a}" for m in CSU_MARKERS for a in "XY"], "FP2.ForX", "FP2.ForY", "FP2.MomZ"]
    if header != expected:
        raise ValueError(f"{raw_path}: unexpected columns {header}; expected {expected}")
    data = np.loadtxt(raw_path, comments="%")
    if data.ndim != 2 or data.shape[1] != len(expected):
        raise ValueError(f"{raw_path}: expected {len(expected)} columns, got shape {data.shape}")
    reference = np.asarray(scipy.io.loadmat(ref_path)["refresults"], dtype=float)
    if reference.shape != (data.shape[0], 15):
        raise ValueError(f"{ref_path}: refresults has shape {reference.shape}, expected ({data.shape[0]}, 15)")
    markers = {m: data[:, 1 + 2 * i : 3 + 2 * i] for i, m in enumerate(CSU_MARKERS)}
    return CSURecording(time=data[:, 0], markers=markers, plate=data[:, 13:16], reference=reference)


def _frame_angle_y(proximal: np.ndarray, distal: np.ndarray) -> np.ndarray:
    """Global angle (rad) of a segment frame whose y axis points from ``distal`` to ``proximal``:
    y = (−sin θ, cos θ)."""
    v = proximal - distal
    return np.unwrap(np.arctan2(-v[:, 0], v[:, 1]))


def _foot_angle(heel: np.ndarray, toe: np.ndarray) -> np.ndarray:
    """Global angle (rad) of the foot frame whose x axis points from heel to toe."""
    v = toe - heel
    return np.unwrap(np.arctan2(v[:, 1], v[:, 0]))


def csu_coordinates(markers: dict[str, np.ndarray]) -> np.ndarray:
    """Generalized coordinates (n, 9) from (filtered) CSU markers.

    pelvis_tx/ty = RGTRO (hip joint centre); pelvis_tilt = angle of the frame with y from RGTRO to
    RSHO; femur y from RLEK to RGTRO; tibia y from RLM to RLEK; foot x from RHEE to RMT5 (the
    heel marker is placed at the height of the RMT5 marker, so this is the sole direction). Joint
    angles are differences of these global angles (distal − proximal). Left leg: zeros.
    """
    m = markers
    pelvis = _frame_angle_y(m["RSHO"], m["RGTRO"])
    femur = _frame_angle_y(m["RGTRO"], m["RLEK"])
    tibia = _frame_angle_y(m["RLEK"], m["RLM"])
    foot = _foot_angle(m["RHEE"], m["RMT5"])
    q = np.zeros((pelvis.size, N_Q))
    q[:, 0:2] = m["RGTRO"]
    q[:, 2] = pelvis
    q[:, index("hip_r")] = femur - pelvis
    q[:, index("knee_r")] = tibia - femur
    q[:, index("ankle_r")] = foot - tibia
    return q


def csu_body_parameters(markers: dict[str, np.ndarray], mass: float = CSU_BODY_MASS) -> BodyParameters:
    """Right-leg parameters from marker-derived segment lengths and Winter's table.

    Lengths are time averages of the marker distances RGTRO–RLEK (thigh) and RLEK–RLM (shank).
    Mass = fraction·body mass; centre of mass at the CoM fraction of the length from the
    proximal joint on the segment axis; inertia = m·(radius-of-gyration fraction·length)²
    (:data:`sspinn.model.body.WINTER`, the values ``leg2d.m`` uses). The foot frame (origin at RLM,
    x from RHEE to RMT5) holds the heel and toe at the time-averaged RHEE and RMT5 positions; the
    foot's length for Winter's fractions is the heel–toe distance and its centre of mass lies
    half-way between heel and toe, as in ``leg2d.m``. HAT and left leg: Winter scaling from the
    mass and a height estimated as thigh length / 0.245 (they do not enter right-leg moments).
    """
    m = markers
    thigh = float(np.mean(np.linalg.norm(m["RGTRO"] - m["RLEK"], axis=1)))
    shank = float(np.mean(np.linalg.norm(m["RLEK"] - m["RLM"], axis=1)))
    theta = _foot_angle(m["RHEE"], m["RMT5"])
    c, s = np.cos(theta), np.sin(theta)

    def in_foot(point: np.ndarray) -> np.ndarray:
        r = point - m["RLM"]
        return np.stack([c * r[:, 0] + s * r[:, 1], -s * r[:, 0] + c * r[:, 1]], axis=1).mean(axis=0)

    heel, toe = in_foot(m["RHEE"]), in_foot(m["RMT5"])
    foot_len = float(np.linalg.norm(toe - heel))

    def winter(name: str, length: float) -> tuple[float, float, float]:
        mass_frac, _, com_frac, rog_frac = WINTER[name]
        seg_mass = mass_frac * mass
        return seg_mass, seg_mass * (rog_frac * length) ** 2, com_frac * length

    fm, fi, fc = winter("femur", thigh)
    tm, ti, tc = winter("tibia", shank)
    pm, pi, pc = winter("foot", foot_len)
    foot_com = heel + pc / foot_len * (toe - heel)
    height = thigh / WINTER["femur"][1]
    return BodyParameters.from_anthropometry(height, mass, gravity=CSU_GRAVITY).replace(
        femur_r=Segment(mass=fm, inertia=fi, com=(0.0, -fc), length=thigh),
        tibia_r=Segment(mass=tm, inertia=ti, com=(0.0, -tc), length=shank),
        foot_r=Foot(
            mass=pm,
            inertia=pi,
            com=(float(foot_com[0]), float(foot_com[1])),
            length=float(np.linalg.norm(toe)),
            heel=(float(heel[0]), float(heel[1])),
            toe=(float(toe[0]), float(toe[1])),
        ),
    )


def csu_reference_inertia(p: BodyParameters, mass: float = CSU_BODY_MASS) -> BodyParameters:
    """``p`` with the right thigh and shank given the inertial parameters with which
    ``refresults.mat`` was computed: the foot's Winter fractions (mass 0.0145·body mass, radius
    of gyration 0.475·length; centre of mass and length unchanged). See the module docstring."""
    mass_frac, _, _, rog_frac = WINTER["foot"]
    seg_mass = mass_frac * mass
    return p.replace(
        **{
            name: Segment(
                mass=seg_mass,
                inertia=seg_mass * (rog_frac * seg.length) ** 2,
                com=seg.com,
                length=seg.length,
            )
            for name, seg in (("femur_r", p.femur_r), ("tibia_r", p.tibia_r))
        }
    )


def csu_inverse_dynamics(
    directory: str | Path | None = None,
    cutoff: float = DEFAULT_CUTOFF_HZ,
    threshold: float = CONTACT_THRESHOLD_N,
    reference_inertia: bool = False,
) -> Comparison:
    """Right-leg joint moments of the CSU recording versus ``refresults`` (columns 7–9).

    With ``reference_inertia`` the thigh and shank get the parameters that generated the
    reference (:func:`csu_reference_inertia`) instead of Winter's.

    Processing: marker gaps (at most 4 samples here) are filled linearly, then markers and the
    force-plate channels are low-pass filtered (:func:`lowpass`, same cutoff), q is built with
    :func:`csu_coordinates` and differentiated (:func:`differentiate`).

    Force plate: ``leg2d.m`` applies [ForX, ForY] to the foot "at global origin" together with
    the moment MomZ, i.e. MomZ is the z-moment (CCW) about the global origin of the load on the
    foot. (Check: MomZ/ForY, the centre of pressure on y = 0, moves from the heel marker towards
    the toe marker during each stance.) :func:`grf_inputs` turns this into (F, w).

    Signs (from the conventions, not fitted): ``leg2d.m`` reports the moment that the proximal
    segment exerts on the distal one, CCW positive (as sspinn's τ), multiplied by its column-7
    sign +1 (thigh), −1 (shank), −1 (foot), which makes hip flexion, knee flexion and ankle
    plantarflexion positive. Hence reference = (τ_hip, −τ_knee, −τ_ankle)/mass. Its angles are
    differences of the angles of the marker lines (proximal→distal marker; heel→toe for the
    foot) with the same signs, so reference angles = (hip, −knee, −ankle − π/2): leg2d's foot
    line is sspinn's foot x axis while its shank line is sspinn's tibia −y axis.
    """
    directory = Path(directory) if directory is not None else shared_data_folder("csu_2d_inverse_dynamics")
    rec = load_csu(directory)
    t = rec.time
    dt = float(np.mean(np.diff(t)))
    fs = 1.0 / dt
    markers = {m: lowpass(fill_gaps(t, xy, f"marker {m}"), fs, cutoff) for m, xy in rec.markers.items()}
    plate = lowpass(fill_gaps(t, rec.plate, "force plate"), fs, cutoff)
    q = csu_coordinates(markers)
    u, qdd = differentiate(q, dt)
    p = csu_body_parameters(markers, rec.mass)
    if reference_inertia:
        p = csu_reference_inertia(p, rec.mass)
    grf, w = grf_inputs(q, p, {"r": plate}, threshold)
    tau, _ = inverse_dynamics(q, u, qdd, grf, w, p)
    signs = np.array(CSU_SIGNS)
    legs = [index(j) - 3 for j in CSU_JOINTS]
    ours = tau[:, legs] * signs / rec.mass
    angles = q[:, [index(j) for j in CSU_JOINTS]] * signs
    angles[:, 2] -= np.pi / 2
    return Comparison(
        dataset=f"CSU leg2d, {'reference' if reference_inertia else 'Winter'} inertia, {cutoff:g} Hz",
        joints=CSU_JOINTS,
        time=t,
        ours=ours,
        reference=rec.reference[:, 6:9],
        convention="hip flexion, knee flexion, ankle plantarflexion positive (N·m/kg)",
        angles_ours=angles,
        angles_reference=rec.reference[:, 0:3],
    )


def csu_reference_replica(directory: str | Path | None = None, threshold: float = CONTACT_THRESHOLD_N) -> Comparison:
    """:func:`csu_inverse_dynamics` with the reference's own cutoff (4 Hz) and thigh/shank
    parameters: what remains is the difference of the dynamics and of the differentiation."""
    return csu_inverse_dynamics(directory, LEG2D_REFERENCE_CUTOFF_HZ, threshold, reference_inertia=True)


# --------------------------------------------------------------------------------------------
# OpenSim subject01 (Gait10dof18musc)
# --------------------------------------------------------------------------------------------

def sagittal_coordinates(ik: dict[str, np.ndarray], leg: SagittalLeg, sides: tuple[str, ...] = SIDES) -> np.ndarray:
    """(n, 9) sspinn coordinates in the lab frame from OpenSim IK coordinates (rad, m): the hip
    joint centre from the pelvis origin and tilt, joint angles of ``sides`` with the leg's frame
    offsets (the other side's stay 0)."""
    tilt = ik["pelvis_tilt"]
    hx, hy = leg.hip_in_pelvis
    q = np.zeros((tilt.size, N_Q))
    q[:, 0] = ik["pelvis_tx"] + np.cos(tilt) * hx - np.sin(tilt) * hy
    q[:, 1] = ik["pelvis_ty"] + np.sin(tilt) * hx + np.cos(tilt) * hy
    q[:, 2] = tilt
    for side in sides:
        joints = (f"hip_{side}", f"knee_{side}", f"ankle_{side}")
        q[:, [index(j) for j in joints]] = leg.joint_angles(*(ik[OPENSIM_JOINTS[j]] for j in joints))
    return q


def filtered_ik(ik_path: str | Path, cutoff: float = DEFAULT_CUTOFF_HZ) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """(time (n,) s, coordinate → (n,) values) of the pelvis and leg coordinates of an OpenSim IK
    file: angles in rad (degrees converted when the header says so), translations in m, each
    low-pass filtered (:func:`lowpass`)."""
    ik = read_opensim_columns(ik_path)
    in_degrees = read_opensim_header(ik_path).get("inDegrees", "no").strip().lower() == "yes"
    t = ik.column("time")

    def coord(name: str) -> np.ndarray:
        x = ik.column(name)
        return np.deg2rad(x) if in_degrees and name not in _OPENSIM_TRANSLATIONS else x

    names = ("pelvis_tx", "pelvis_ty", "pelvis_tilt", *(OPENSIM_JOINTS[j] for j in OPENSIM_JOINTS))
    values = lowpass(np.stack([coord(c) for c in names], axis=1), 1.0 / float(np.mean(np.diff(t))), cutoff)
    return t, dict(zip(names, values.T))


def opensim_inverse_dynamics(
    directory: str | Path | None = None,
    cutoff: float = DEFAULT_CUTOFF_HZ,
    threshold: float = CONTACT_THRESHOLD_N,
    sides: tuple[str, ...] = SIDES,
    prefix: str = "subject01_walk",
    model_file: str = "subject01.osim",
) -> Comparison:
    """Leg joint moments of OpenSim's subject01 walk versus OpenSim's inverse dynamics.

    Body: the segments of the scaled model (:func:`sspinn.data.opensim_files.sagittal_leg_from_osim`:
    femur, tibia, foot = talus + calcn + toes; the knee translation is frozen at knee angle 0),
    so that both computations use the same body; total mass (72.6 kg, for N·m/kg) and gravity
    from the model. The HAT is a Winter-scaled placeholder (height = femur length / 0.245).

    Kinematics: IK coordinates (60 Hz, degrees → rad, OpenSim signs = sspinn signs) are low-pass
    filtered (:func:`lowpass`) and mapped to sspinn's q: pelvis_tilt unchanged; the hip joint
    centre (pelvis_tx/ty of sspinn) = pelvis origin + R(pelvis_tilt)·(hip location in the pelvis
    frame); joint angles shifted by the constant frame offsets of
    :class:`~sspinn.data.opensim_files.SagittalLeg` (< 1°, which change no generalized force). Each
    side is computed with its own hip centre (the Kane rows of a leg need only that leg and the
    pelvis coordinates).

    Ground reaction forces (600 Hz; the ``.xml`` says which columns act on ``calcn_r``/``calcn_l``):
    per foot F = (vx, vy) and the moment about the global origin M_O = p_x·F_y − p_y·F_x + T_z
    (p: centre of pressure, T: the torque column), filtered at 600 Hz with the same cutoff, then
    linearly interpolated to the IK times and applied with :func:`grf_inputs`.

    Reference: ``<prefix>_ID.sto`` (N·m, same signs as sspinn), interpolated to the IK times
    (its time stamps differ by < 1 µs). Both divided by the model mass.
    """
    directory = Path(directory) if directory is not None else shared_data_folder("opensim_subject01_walk")
    ik_path = directory / f"{prefix}_IK.mot"
    grf_path = directory / f"{prefix}_grf.mot"
    xml_path = directory / f"{prefix}_grf.xml"
    id_path = directory / f"{prefix}_ID.sto"
    model = read_osim_model(directory / model_file)
    pelvis_joint = model.joint("ground_pelvis")
    if np.any(pelvis_joint.parent_offset != 0) or np.any(pelvis_joint.child_offset != 0):
        raise NotImplementedError(f"{model.path}: ground_pelvis with offset frames is not supported")
    mass = model.mass
    gravity = float(-model.gravity[1])

    t, filtered = filtered_ik(ik_path, cutoff)
    dt = float(np.mean(np.diff(t)))

    grf_table = read_opensim_columns(grf_path)
    t_grf = grf_table.column("time")
    fs_grf = (t_grf.size - 1) / (t_grf[-1] - t_grf[0])
    external = read_external_loads(xml_path)

    reference_table = read_opensim_columns(id_path)
    t_ref = reference_table.column("time")

    ours, reference, joints = [], [], []
    for side in sides:
        leg = sagittal_leg_from_osim(model, side)
        height = leg.femur.length / WINTER["femur"][1]
        p = BodyParameters.from_anthropometry(height, mass, gravity=gravity).replace(
            **{f"femur_{side}": leg.femur, f"tibia_{side}": leg.tibia, f"foot_{side}": leg.foot}
        )
        q = sagittal_coordinates(filtered, leg, (side,))
        leg_joints = (f"hip_{side}", f"knee_{side}", f"ankle_{side}")
        u, qdd = differentiate(q, dt)

        load = external.get(f"calcn_{side}")
        loads = {}
        if load is not None:
            cols = load.columns()
            fx, fy = (grf_table.column(c) for c in cols["force"][:2])
            px, py = (grf_table.column(c) for c in cols["point"][:2])
            tz = grf_table.get(cols["torque"][2], np.zeros_like(fx))
            raw = np.stack([fx, fy, px * fy - py * fx + tz], axis=1)
            smooth = lowpass(raw, fs_grf, cutoff)
            loads[side] = np.stack([np.interp(t, t_grf, smooth[:, k]) for k in range(3)], axis=1)
        grf, w = grf_inputs(q, p, loads, threshold)
        tau, _ = inverse_dynamics(q, u, qdd, grf, w, p)
        for j in leg_joints:
            joints.append(j)
            ours.append(tau[:, index(j) - 3] / mass)
            ref = reference_table.column(f"{OPENSIM_JOINTS[j]}_moment")
            reference.append(np.interp(t, t_ref, ref) / mass)
    return Comparison(
        dataset="OpenSim subject01 ID",
        joints=tuple(joints),
        time=t,
        ours=np.stack(ours, axis=1),
        reference=np.stack(reference, axis=1),
        convention="OpenSim = sspinn: hip flexion +, knee extension +, ankle dorsiflexion + (N·m/kg)",
    )


def measured_stride(directory: str | Path, prefix: str = "subject01_walk", model_file: str = "subject01.osim") -> Gait:
    """One stride of measured walking kinematics — OpenSim's subject01 (``<prefix>_IK.mot``,
    60 Hz, low-passed at 6 Hz, mapped to sspinn's coordinates with the scaled model's right leg:
    :func:`sagittal_coordinates`) — as a periodic stride on the
    100 Hz grid, for :func:`sspinn.testing.sensor_mounting.mounting_trials` on a real gait instead of a predicted one.

    The stride is the span of 0.9–1.4 s whose end state (angles and rates, pelvis height) lies
    nearest its start; the small mismatch is removed linearly over the stride, the forward
    position keeps the stride's mean speed, and periodic cubic splines give q, u and q̈ at 100 Hz.
    The GRF is not needed here and is zero."""
    directory = Path(directory)
    t, ik = filtered_ik(directory / f"{prefix}_IK.mot")
    q = sagittal_coordinates(ik, sagittal_leg_from_osim(read_osim_model(directory / model_file), "r"))
    rate = 1.0 / float(np.mean(np.diff(t)))
    u = np.gradient(q, axis=0) * rate
    best, span = np.inf, (0, 0)
    for i in range(len(q)):
        for j in range(i + int(0.9 * rate), min(len(q), i + int(1.4 * rate) + 1)):
            d = float(np.sum((q[j, 1:] - q[i, 1:]) ** 2) + 0.01 * np.sum((u[j, 1:] - u[i, 1:]) ** 2))
            if d < best:
                best, span = d, (i, j)
    i, j = span
    stride = q[i:j + 1].copy()
    n = j - i
    ramp = np.arange(n + 1)[:, None] / n
    speed = (stride[-1, 0] - stride[0, 0]) / (n / rate)
    stride[:, 0] -= speed * np.arange(n + 1) / rate  # forward position minus the mean progress
    stride -= ramp * (stride[-1] - stride[0])  # close the loop
    spline = CubicSpline(np.arange(n + 1) / rate, stride, axis=0, bc_type="periodic")
    grid = np.arange(int(round(n / rate * RATE_HZ))) / RATE_HZ
    qs, us, qdds = spline(grid), spline(grid, 1), spline(grid, 2)
    qs[:, 0] += speed * grid
    us[:, 0] += speed
    return Gait(qs, us, qdds, np.zeros((len(grid), len(GRF))))
