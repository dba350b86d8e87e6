"""Small, dependency-free readers for OpenSim files (storage tables ``.mot``/``.sto``).

An OpenSim storage file is a text file (plain, or gzip-compressed ``.gz``) made of

* a free-form header (a title line and ``key=value`` lines such as ``nRows=151`` or
  ``inDegrees=yes``) that ends with a line reading ``endheader``,
* one line of column names (tab separated; the first is usually ``time``),
* one line of numbers per sample, separated by tabs or spaces.

Files written by some tools pad every line with trailing tabs; those are ignored. Values are
returned as they are stored: angles stay in degrees when the header says ``inDegrees=yes`` (see
:func:`read_opensim_header`), translations in m, forces in N, moments in N·m. Coordinate signs are
OpenSim's, which are also sspinn's (see :mod:`sspinn.model.conventions`).

It also reads the few parts of an OpenSim model (``.osim``) and of an external-loads file
(``.xml``) that the sagittal model needs:

* :func:`read_osim_model`: bodies (mass, centre of mass, inertia), joints (parent/child bodies and
  offset frames, CustomJoint transform functions) and gravity, OpenSim 4 format;
* :func:`sagittal_leg_from_osim`: one leg (femur, tibia, foot = talus + calcn + toes) as sspinn
  :class:`~sspinn.model.body.Segment`/:class:`~sspinn.model.body.Foot` objects in sspinn segment frames;
* :func:`read_external_loads`: which force/point/torque columns of a GRF table act on which foot.
"""

from __future__ import annotations

import gzip
import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from sspinn.model.body import Foot, Segment

__all__ = [
    "ExternalLoad",
    "OpenSimFormatError",
    "OsimBody",
    "OsimJoint",
    "OsimModel",
    "SagittalLeg",
    "read_external_loads",
    "read_opensim_header",
    "read_opensim_table",
    "read_osim_model",
    "sagittal_leg_from_osim",
]


class OpenSimFormatError(ValueError):
    """Raised for a storage file that cannot be parsed; the message names the file and line."""


def _lines(path: Path) -> list[str]:
    """The lines of a plain or gzip-compressed (``.gz``) text file."""
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise FileNotFoundError(f"OpenSim table not found: {path}") from None
    if raw[:2] == b"\x1f\x8b":
        try:
            raw = gzip.decompress(raw)
        except (OSError, EOFError) as exc:
            raise OpenSimFormatError(f"{path}: a damaged gzip file ({exc})") from None
    return raw.decode("utf-8", errors="replace").splitlines()


def _endheader_index(path: Path, lines: list[str]) -> int:
    for i, line in enumerate(lines):
        if line.strip().lower() == "endheader":
            return i
    raise OpenSimFormatError(f"{path}: no 'endheader' line found; not an OpenSim storage (.mot/.sto) file")


def read_opensim_header(path: str | Path) -> dict[str, str]:
    """The ``key=value`` entries of the header of an OpenSim storage file.

    Keys and values are stripped strings, e.g. ``{"version": "1", "nRows": "151",
    "inDegrees": "yes"}``; header lines without ``=`` (the title) are skipped.

    Raises:
        FileNotFoundError: the file does not exist.
        OpenSimFormatError: there is no ``endheader`` line.
    """
    path = Path(path)
    lines = _lines(path)
    header: dict[str, str] = {}
    for line in lines[: _endheader_index(path, lines)]:
        if "=" in line:
            key, _, value = line.strip().partition("=")
            header[key.strip()] = value.strip()
    return header


def read_opensim_table(path: str | Path) -> tuple[list[str], np.ndarray]:
    """Read an OpenSim ``.mot``/``.sto`` table.

    Returns:
        ``(column_names, data)``: the names from the line after ``endheader`` (e.g. ``["time",
        "pelvis_tilt", ...]``) and a float64 array of shape (n_rows, n_columns) in the file's
        units (check :func:`read_opensim_header` for ``inDegrees``). ``nan`` entries are kept.

    Raises:
        FileNotFoundError: the file does not exist.
        OpenSimFormatError: no ``endheader`` line, no column-name line, duplicate column names, a
            row with the wrong number of fields or a non-numeric field, or no data rows. The
            message names the file and the (1-based) line.
    """
    path = Path(path)
    lines = _lines(path)
    i = _endheader_index(path, lines) + 1
    while i < len(lines) and not lines[i].strip():
        i += 1
    if i >= len(lines):
        raise OpenSimFormatError(f"{path}: no column-name line after 'endheader'")
    names_line = lines[i].strip()
    names = [n.strip() for n in (names_line.split("\t") if "\t" in names_line else names_line.split())]
    names = [n for n in names if n]
    duplicates = sorted({n for n in names if names.count(n) > 1})
    if duplicates:
        raise OpenSimFormatError(f"{path}, line {i + 1}: duplicate column name(s) {duplicates}")
    rows: list[list[float]] = []
    for lineno, line in enumerate(lines[i + 1 :], start=i + 2):
        fields = line.split()
        if not fields:
            continue
        if len(fields) != len(names):
            raise OpenSimFormatError(
                f"{path}, line {lineno}: expected {len(names)} values (one per column), got {len(fields)}"
            )
        row: list[float] = []
        for f in fields:
            try:
                row.append(float(f))
            except ValueError:
                raise OpenSimFormatError(f"{path}, line {lineno}: non-numeric value {f!r}") from None
        rows.append(row)
    if not rows:
        raise OpenSimFormatError(f"{path}: no data rows after the column names")
    return names, np.asarray(rows, dtype=np.float64)


class OpenSimTable(dict):
    """An OpenSim table as columns by name (:func:`read_opensim_columns`); :meth:`column` names
    the file when a column is missing."""

    path: Path

    def column(self, name: str) -> np.ndarray:
        """The column ``name``; :class:`OpenSimFormatError` naming the file if it has none."""
        try:
            return self[name]
        except KeyError:
            raise OpenSimFormatError(f"{self.path}: no column {name!r}") from None


def read_opensim_columns(path: str | Path) -> OpenSimTable:
    """:func:`read_opensim_table` as a mapping column name → (n_rows,) array."""
    names, data = read_opensim_table(path)
    table = OpenSimTable({n: data[:, k] for k, n in enumerate(names)})
    table.path = Path(path)
    return table


# --------------------------------------------------------------------------------------------
# OpenSim models (.osim)
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class OsimBody:
    """A body of an OpenSim model: mass (kg), centre of mass (m, body frame) and the inertia
    tensor about the centre of mass in the body frame (kg·m², 3×3)."""

    name: str
    mass: float
    com: np.ndarray
    inertia: np.ndarray


@dataclass(frozen=True)
class OsimJoint:
    """A joint: parent/child body names, the joint frame's origin in each body (m) and, for a
    CustomJoint, its ``translation1..3`` TransformAxis functions (axis, coordinate, function)."""

    name: str
    kind: str
    parent: str
    child: str
    parent_offset: np.ndarray
    child_offset: np.ndarray
    translations: tuple[tuple[np.ndarray, str | None, ET.Element | None], ...] = field(default=())
    rotations: tuple[tuple[np.ndarray, str | None, ET.Element | None], ...] = field(default=())
    source: str = "<osim>"

    def translation(self, coordinate_values: dict[str, float] | None = None) -> np.ndarray:
        """Position (m) of the child offset frame in the parent offset frame for the given
        coordinate values (missing coordinates: 0). Zero for Pin and Weld joints."""
        values = coordinate_values or {}
        out = np.zeros(3)
        for axis, coord, func in self.translations:
            x = values.get(coord, 0.0) if coord else 0.0
            out += axis * _eval_function(func, x, f"{self.source}: joint {self.name}")
        return out

    def rotation_angles(self, coordinate_values: dict[str, float] | None = None) -> np.ndarray:
        """Values (rad) of the CustomJoint's rotation functions (one per TransformAxis)."""
        values = coordinate_values or {}
        return np.array(
            [
                _eval_function(func, values.get(coord, 0.0) if coord else 0.0, f"{self.source}: joint {self.name}")
                for _, coord, func in self.rotations
            ]
        )


@dataclass(frozen=True)
class OsimModel:
    """The parts of an OpenSim model used here: bodies, joints (by name), gravity (m/s², 3)."""

    path: str
    bodies: dict[str, OsimBody]
    joints: dict[str, OsimJoint]
    gravity: np.ndarray

    @property
    def mass(self) -> float:
        """Total mass of all bodies, kg."""
        return float(sum(b.mass for b in self.bodies.values()))

    def body(self, name: str) -> OsimBody:
        try:
            return self.bodies[name]
        except KeyError:
            raise OpenSimFormatError(f"{self.path}: no body named {name!r} (bodies: {sorted(self.bodies)})") from None

    def joint(self, name: str) -> OsimJoint:
        try:
            return self.joints[name]
        except KeyError:
            raise OpenSimFormatError(f"{self.path}: no joint named {name!r} (joints: {sorted(self.joints)})") from None


def _xml_root(path: Path, what: str) -> ET.Element:
    """The root element of the XML file ``path`` (``what`` names the kind of file in errors).

    Raises:
        FileNotFoundError: the file does not exist.
        OpenSimFormatError: the file is not valid XML.
    """
    try:
        return ET.parse(path).getroot()
    except FileNotFoundError:
        raise FileNotFoundError(f"{what} not found: {path}") from None
    except ET.ParseError as exc:
        raise OpenSimFormatError(f"{path}: not valid XML ({exc})") from None


def _floats(elem: ET.Element | None, what: str, n: int | None = None) -> np.ndarray:
    if elem is None or elem.text is None:
        raise OpenSimFormatError(f"{what}: missing")
    try:
        values = np.array([float(v) for v in elem.text.split()])
    except ValueError:
        raise OpenSimFormatError(f"{what}: non-numeric value in {elem.text!r}") from None
    if n is not None and values.size != n:
        raise OpenSimFormatError(f"{what}: expected {n} numbers, got {values.size}")
    return values


def _eval_function(func: ET.Element | None, x: float, what: str) -> float:
    """Evaluate an OpenSim Function element (Constant, LinearFunction, SimmSpline,
    PiecewiseLinearFunction, MultiplierFunction) at x."""
    if func is None:
        return 0.0
    tag = func.tag
    if tag == "Constant":
        return float(_floats(func.find("value"), f"{what} Constant", 1)[0])
    if tag == "LinearFunction":
        a, b = _floats(func.find("coefficients"), f"{what} LinearFunction", 2)
        return float(a * x + b)
    if tag in ("SimmSpline", "NaturalCubicSpline", "PiecewiseLinearFunction"):
        xs = _floats(func.find("x"), f"{what} {tag} x")
        ys = _floats(func.find("y"), f"{what} {tag} y", xs.size)
        if tag == "PiecewiseLinearFunction" or xs.size < 3:
            return float(np.interp(x, xs, ys))
        from scipy.interpolate import CubicSpline

        # SimmSpline's end conditions differ slightly from a natural spline; between interior
        # knots the difference is far below a millimetre for the knee tables of gait models.
        return float(CubicSpline(xs, ys, bc_type="natural")(x))
    if tag == "MultiplierFunction":
        inner = func.find("function")
        if inner is None or len(inner) != 1:
            raise OpenSimFormatError(f"{what}: MultiplierFunction without a function")
        scale = float(_floats(func.find("scale"), f"{what} MultiplierFunction scale", 1)[0])
        return scale * _eval_function(inner[0], x, what)
    raise NotImplementedError(f"{what}: OpenSim function type {tag!r} is not supported")


def _transform_axes(joint: ET.Element, prefix: str) -> tuple[tuple[np.ndarray, str | None, ET.Element | None], ...]:
    out = []
    for ta in joint.iter("TransformAxis"):
        if not (ta.get("name") or "").startswith(prefix):
            continue
        axis = _floats(ta.find("axis"), f"joint {joint.get('name')} {ta.get('name')} axis", 3)
        coord_text = (ta.findtext("coordinates") or "").split()
        func = next((c for c in ta if c.tag not in ("coordinates", "axis")), None)
        out.append((axis, coord_text[0] if coord_text else None, func))
    return tuple(out)


def read_osim_model(path: str | Path) -> OsimModel:
    """Read bodies, joints and gravity from an OpenSim 4 model file.

    Joint offset frames must not be rotated (``orientation`` 0 0 0, as in the gait2392 family);
    a rotated one raises :class:`NotImplementedError` naming the joint.
    """
    path = Path(path)
    root = _xml_root(path, "OpenSim model")
    model = root.find("Model")
    if model is None:
        raise OpenSimFormatError(f"{path}: no <Model> element (not an OpenSim model file)")
    bodies: dict[str, OsimBody] = {}
    for b in model.iter("Body"):
        name = b.get("name") or ""
        what = f"{path}: body {name}"
        ixx, iyy, izz, ixy, ixz, iyz = _floats(b.find("inertia"), f"{what} inertia", 6)
        bodies[name] = OsimBody(
            name=name,
            mass=float(_floats(b.find("mass"), f"{what} mass", 1)[0]),
            com=_floats(b.find("mass_center"), f"{what} mass_center", 3),
            inertia=np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]]),
        )
    joints: dict[str, OsimJoint] = {}
    for j in model.iter():
        if not j.tag.endswith("Joint") or j.find("socket_parent_frame") is None:
            continue
        name = j.get("name") or ""
        what = f"{path}: joint {name}"
        frames = {f.get("name"): f for f in j.iter("PhysicalOffsetFrame")}
        ends = []
        for socket in ("socket_parent_frame", "socket_child_frame"):
            frame_name = (j.findtext(socket) or "").strip()
            frame = frames.get(frame_name)
            if frame is None:  # the socket names a body directly
                ends.append((frame_name.rsplit("/", 1)[-1], np.zeros(3)))
                continue
            orientation = _floats(frame.find("orientation"), f"{what} {frame_name} orientation", 3)
            if np.any(np.abs(orientation) > 1e-12):
                raise NotImplementedError(f"{what}: rotated offset frame {frame_name!r} is not supported")
            body = (frame.findtext("socket_parent") or "").strip().rsplit("/", 1)[-1]
            ends.append((body, _floats(frame.find("translation"), f"{what} {frame_name} translation", 3)))
        (parent, p_off), (child, c_off) = ends
        joints[name] = OsimJoint(
            name=name,
            kind=j.tag,
            parent=parent,
            child=child,
            parent_offset=p_off,
            child_offset=c_off,
            translations=_transform_axes(j, "translation"),
            rotations=_transform_axes(j, "rotation"),
            source=str(path),
        )
    gravity_elem = model.find("gravity")
    gravity = np.array([0.0, -9.80665, 0.0]) if gravity_elem is None else _floats(gravity_elem, f"{path} gravity", 3)
    return OsimModel(path=str(path), bodies=bodies, joints=joints, gravity=gravity)


@dataclass(frozen=True)
class SagittalLeg:
    """One OpenSim leg as sspinn segments (see :func:`sagittal_leg_from_osim`).

    Attributes:
        femur, tibia, foot: sspinn segments in sspinn segment frames (origin at the proximal
            joint, y from the distal to the proximal joint; the foot frame is the talus frame).
        hip_in_pelvis: hip joint centre (x, y) in the OpenSim pelvis frame, m.
        femur_offset, tibia_offset: angle (rad, CCW) from the OpenSim body frame to the sspinn
            segment frame; the foot's is 0. So sspinn's global segment angle is OpenSim's plus
            the offset, and ``hip = hip_flexion + femur_offset``,
            ``knee = knee_angle + tibia_offset − femur_offset``,
            ``ankle = ankle_angle − tibia_offset`` (rad).
    """

    femur: Segment
    tibia: Segment
    foot: Foot
    hip_in_pelvis: tuple[float, float]
    femur_offset: float
    tibia_offset: float

    def joint_angles(self, hip: np.ndarray, knee: np.ndarray, ankle: np.ndarray) -> np.ndarray:
        """OpenSim hip_flexion, knee_angle, ankle_angle (rad) → sspinn hip, knee, ankle (..., 3)."""
        return np.stack(
            [hip + self.femur_offset, knee + self.tibia_offset - self.femur_offset, ankle - self.tibia_offset],
            axis=-1,
        )


def _segment_from_body(body: OsimBody, origin: np.ndarray, distal: np.ndarray) -> tuple[Segment, float]:
    """A sspinn Segment for an OpenSim body with proximal joint ``origin`` and distal joint
    ``distal`` (body frame, m); returns it with the frame offset angle δ (rad)."""
    v = distal - origin
    delta = math.atan2(v[0], -v[1])
    c, s = math.cos(delta), math.sin(delta)
    r = body.com - origin
    com = (c * r[0] + s * r[1], -s * r[0] + c * r[1])  # R(−δ)·r
    seg = Segment(
        mass=body.mass,
        inertia=float(body.inertia[2, 2]),
        com=(float(com[0]), float(com[1])),
        length=float(math.hypot(v[0], v[1])),
    )
    return seg, delta


def sagittal_leg_from_osim(model: OsimModel, side: str = "r", knee_angle: float = 0.0) -> SagittalLeg:
    """Convert one leg of a gait2392-family OpenSim model to sspinn segments.

    * femur: origin at the hip joint centre, y towards it from the knee joint centre. The knee
      of these models translates with the knee angle (CustomJoint splines, about 1.4 cm over the
      gait range); sspinn's knee is a pin, so the translation is evaluated once, at
      ``knee_angle`` (rad, OpenSim sign: flexion negative), and otherwise ignored.
    * tibia: origin at the knee, y from the ankle joint centre to the knee.
    * foot: talus + calcn + toes welded at their default pose (subtalar and mtp coordinates 0),
      mass summed, centre of mass and inertia (about z, through the combined centre of mass, by
      the parallel-axis theorem) in the talus frame, origin at the ankle. Its heel is the calcn
      origin and its toe the toes origin (the mtp joint), both in the talus frame.

    Only the sagittal (x, y, z-rotation) parts are used; body inertias are taken about z.
    """
    if side not in ("r", "l"):
        raise ValueError(f"side must be 'r' or 'l', got {side!r}")
    hip = model.joint(f"hip_{side}")
    knee = model.joint(f"knee_{side}")
    ankle = model.joint(f"ankle_{side}")
    subtalar = model.joint(f"subtalar_{side}")
    mtp = model.joint(f"mtp_{side}")
    knee_coord = next((c for _, c, _ in knee.rotations if c), None)
    knee_values = {knee_coord: knee_angle} if knee_coord else {}
    _check_plain_z_rotation(knee, knee_values)

    femur_body = model.body(f"femur_{side}")
    knee_in_femur = knee.parent_offset + knee.translation(knee_values)
    femur, femur_offset = _segment_from_body(femur_body, hip.child_offset, knee_in_femur)

    tibia, tibia_offset = _segment_from_body(model.body(f"tibia_{side}"), knee.child_offset, ankle.parent_offset)

    # foot: positions in the talus frame (offset frames are unrotated, see read_osim_model)
    talus_origin = ankle.child_offset  # ankle centre in the talus frame
    calcn_in_talus = subtalar.parent_offset + subtalar.translation() - subtalar.child_offset
    toes_in_calcn = mtp.parent_offset + mtp.translation() - mtp.child_offset
    parts = [
        (model.body(f"talus_{side}"), np.zeros(3)),
        (model.body(f"calcn_{side}"), calcn_in_talus),
        (model.body(f"toes_{side}"), calcn_in_talus + toes_in_calcn),
    ]
    mass = sum(b.mass for b, _ in parts)
    com = sum(b.mass * (o + b.com) for b, o in parts) / mass
    inertia = sum(b.inertia[2, 2] + b.mass * float(np.sum((o + b.com - com)[:2] ** 2)) for b, o in parts)
    heel = calcn_in_talus - talus_origin
    toe = calcn_in_talus + toes_in_calcn - talus_origin
    foot = Foot(
        mass=float(mass),
        inertia=float(inertia),
        com=(float(com[0] - talus_origin[0]), float(com[1] - talus_origin[1])),
        length=float(math.hypot(toe[0], toe[1])),
        heel=(float(heel[0]), float(heel[1])),
        toe=(float(toe[0]), float(toe[1])),
    )
    return SagittalLeg(
        femur=femur,
        tibia=tibia,
        foot=foot,
        hip_in_pelvis=(float(hip.parent_offset[0]), float(hip.parent_offset[1])),
        femur_offset=femur_offset,
        tibia_offset=tibia_offset,
    )


def _check_plain_z_rotation(joint: OsimJoint, values: dict[str, float]) -> None:
    """Check that a CustomJoint rotates by its coordinate about z only (at ``values``): the
    coordinate-driven axes are z and evaluate to the coordinate, the others to 0."""
    for (axis, coord, _), angle in zip(joint.rotations, joint.rotation_angles(values)):
        expected = values.get(coord, 0.0) if coord and np.allclose(axis, [0, 0, 1]) else 0.0
        if abs(angle - expected) > 1e-9:
            raise NotImplementedError(f"{joint.source}: joint {joint.name} is not a plain rotation about z")


# --------------------------------------------------------------------------------------------
# External loads (.xml)
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class ExternalLoad:
    """One ExternalForce of an OpenSim ExternalLoads file: the body it acts on and the column
    prefixes of its force (N), point (m) and torque (N·m), all expressed in ground here."""

    name: str
    body: str
    force: str
    point: str
    torque: str

    def columns(self, axes: str = "xyz") -> dict[str, list[str]]:
        """Column names, e.g. ``{"force": ["ground_force_vx", ...], "point": [...], "torque": [...]}``."""
        return {k: [getattr(self, k) + a for a in axes] for k in ("force", "point", "torque")}


def read_external_loads(path: str | Path) -> dict[str, ExternalLoad]:
    """ExternalForces of an OpenSim ExternalLoads ``.xml`` by the body they act on (e.g. ``calcn_r``).

    Raises:
        OpenSimFormatError: malformed file, or a force or point not expressed in ground.
    """
    path = Path(path)
    root = _xml_root(path, "OpenSim external loads")
    loads: dict[str, ExternalLoad] = {}
    for ef in root.iter("ExternalForce"):
        name = ef.get("name") or ""
        text = {
            k: (ef.findtext(k) or "").strip()
            for k in (
                "applied_to_body",
                "force_expressed_in_body",
                "point_expressed_in_body",
                "force_identifier",
                "point_identifier",
                "torque_identifier",
            )
        }
        if (ef.findtext("isDisabled") or "false").strip().lower() == "true":
            continue
        for key in ("force_expressed_in_body", "point_expressed_in_body"):
            if text[key] not in ("", "ground"):
                raise OpenSimFormatError(
                    f"{path}: ExternalForce {name}: {key} is {text[key]!r}; only 'ground' is supported"
                )
        if not text["applied_to_body"] or not text["force_identifier"] or not text["point_identifier"]:
            raise OpenSimFormatError(f"{path}: ExternalForce {name}: missing body, force or point identifier")
        loads[text["applied_to_body"]] = ExternalLoad(
            name=name,
            body=text["applied_to_body"],
            force=text["force_identifier"],
            point=text["point_identifier"],
            torque=text["torque_identifier"],
        )
    if not loads:
        raise OpenSimFormatError(f"{path}: no enabled ExternalForce found")
    return loads
