"""Sensor → segment maps: which vendor sensor sits on which segment of the sagittal model, in YAML.

Format (``configs/sensor_maps/*.yaml``)::

    sensors:
      pelvis_imu_offset_imu: pelvis            # short form: the segment
      femur_r_imu_offset_imu: thigh_r          # thigh = femur, shank = tibia (aliases)
      toes_r_imu_offset_imu:                   # long form
        segment: foot_r
        position: forefoot                     # "default", "forefoot" or position_m: [x, y]
        right_axis: "+Y"                       # optional hints, see below
    ignore: [torso_imu_offset_imu]             # sensors in the files that are not used

Segments are those of :data:`sspinn.model.conventions.SEGMENTS` with sides (``pelvis`` is the HAT
segment), or the aliases ``thigh_<side>``, ``shank_<side>``. A forefoot/shoe sensor is a foot
IMU with its own placement: ``position: forefoot`` puts it at :data:`FOREFOOT_POSITION_M`
(scaled by height / 1.75 m), ``position_m`` gives it in metres in the segment frame.

Optional per-sensor hints (a sensor axis ``"+X"``…``"-Z"`` or a 3-vector in the sensor frame):

* ``right_axis`` — roughly the direction of the subject's right in the sensor frame (a sensor
  on the lateral side of a right-leg segment with its Z axis pointing away from the skin:
  ``"+Z"``; the same on the left leg: ``"-Z"``). It fixes the sign of the calibrated
  medio-lateral axis (the axis itself still comes from the data); without it the sign is voted
  from the gait (:mod:`sspinn.imu.calibration`).
* ``up_axis`` — the sensor axis that points up the segment (proximally) as mounted by the lab's
  protocol. Calibration checks it: gravity on that axis during standing (or on average while
  walking) must be positive, else the sensor is mounted upside down (an error naming it).

Every sensor of the files must be mapped or ignored, every mapped sensor must be in the files
and a segment may carry one sensor; errors are one line naming the map file and the sensor.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Final

import numpy as np
import yaml

from sspinn.errors import UserError
from sspinn.model.body import IMUPlacement
from sspinn.model.conventions import SEGMENTS

#: Aliases of the segment names (without side).
SEGMENT_ALIASES: Final[dict[str, str]] = {"thigh": "femur", "shank": "tibia", "hat": "pelvis"}
#: Assumed position (m, foot frame, for a 1.75 m subject) of a sensor on the forefoot/shoe upper,
#: over the metatarsals: 14 cm in front of the ankle, 3 cm below it (the sole is ≈ 7 cm below).
FOREFOOT_POSITION_M: Final = (0.14, -0.03)
_AXES: Final = {f"{sign}{axis}": np.eye(3)[i] * (1.0 if sign == "+" else -1.0) for i, axis in enumerate("XYZ") for sign in "+-"}


class SensorMapError(UserError):
    """A sensor map that does not fit the model or the files; the message names the map and the sensor."""


@dataclass(frozen=True)
class SensorAssignment:
    """One mapped sensor.

    Attributes:
        sensor: its name in the files; segment: the model segment (``SEGMENTS``).
        position: ``"default"`` (the project's default IMU position), ``"forefoot"`` or an
            (x, y) position in m in the segment frame.
        right_axis, up_axis: hints as unit 3-vectors in the sensor frame, or None (module docstring).
    """

    sensor: str
    segment: str
    position: str | tuple[float, float] = "default"
    right_axis: np.ndarray | None = None
    up_axis: np.ndarray | None = None

    @property
    def kind(self) -> str:
        """``pelvis``, ``femur``, ``tibia`` or ``foot``."""
        return self.segment.split("_")[0]


@dataclass(frozen=True)
class SensorMap:
    """Sensor → segment assignments (see the module docstring)."""

    assignments: dict[str, SensorAssignment]
    ignore: tuple[str, ...] = ()
    source: str = "<sensor map>"
    description: str = ""
    extra: dict[str, Any] = field(default_factory=dict)

    @property
    def segments(self) -> tuple[str, ...]:
        """The mapped segments in :data:`SEGMENTS` order."""
        mapped = {a.segment for a in self.assignments.values()}
        return tuple(s for s in SEGMENTS if s in mapped)

    def by_segment(self) -> dict[str, SensorAssignment]:
        """Segment → assignment, in :data:`SEGMENTS` order."""
        table = {a.segment: a for a in self.assignments.values()}
        return {s: table[s] for s in self.segments}

    @classmethod
    def from_yaml(cls, path: str | Path) -> SensorMap:
        path = Path(path)
        if not path.exists():
            raise SensorMapError(f"{path}: sensor map not found")
        try:
            data = yaml.safe_load(path.read_text(encoding="utf-8"))
        except yaml.YAMLError as exc:
            raise SensorMapError(f"{path}: not valid YAML ({str(exc).splitlines()[0]})") from None
        return cls.from_dict(data, source=str(path))

    @classmethod
    def from_dict(cls, data: Any, source: str = "<sensor map>") -> SensorMap:
        if not isinstance(data, dict) or not isinstance(data.get("sensors"), dict) or not data["sensors"]:
            raise SensorMapError(f"{source}: expected a mapping with a non-empty 'sensors:' section (sensor name → segment)")
        unknown = set(data) - {"sensors", "ignore", "description", "format"}
        if unknown:
            raise SensorMapError(f"{source}: unknown key(s) {sorted(unknown)}; allowed: sensors, ignore, description, format")
        ignore = data.get("ignore") or []
        if not isinstance(ignore, list) or not all(isinstance(x, str) for x in ignore):
            raise SensorMapError(f"{source}: 'ignore' must be a list of sensor names, got {ignore!r}")
        assignments: dict[str, SensorAssignment] = {}
        used: dict[str, str] = {}
        for sensor, entry in data["sensors"].items():
            a = _assignment(source, str(sensor), entry)
            if a.segment in used:
                raise SensorMapError(f"{source}: sensors {used[a.segment]!r} and {sensor!r} both on segment {a.segment!r}; "
                                     "the model takes one IMU per segment (ignore one of them)")
            if sensor in ignore:
                raise SensorMapError(f"{source}: sensor {sensor!r} is both mapped and ignored")
            used[a.segment] = str(sensor)
            assignments[str(sensor)] = a
        return cls(assignments, tuple(ignore), source, str(data.get("description", "")), {"format": data.get("format")})

    def check_sensors(self, available: list[str], files: str) -> None:
        """Raise :class:`SensorMapError` if a mapped sensor is not in the files or a sensor of the
        files is neither mapped nor ignored."""
        missing = [s for s in self.assignments if s not in available]
        if missing:
            segment = self.assignments[missing[0]].segment
            raise SensorMapError(f"{self.source}: sensor {missing[0]!r} (mapped to {segment}) is not in {files}; the files have "
                                 f"{available}: fix the name, or remove it from the map to import without a {segment} IMU")
        unmapped = [s for s in available if s not in self.assignments and s not in self.ignore]
        if unmapped:
            raise SensorMapError(f"{self.source}: sensor {unmapped[0]!r} of {files} is not in the map; map it to a segment "
                                 f"or list it under 'ignore:' (unmapped: {unmapped})")

    def placement(self, height: float) -> IMUPlacement:
        """The nominal placement: the project's default scaled to ``height`` (m), with the
        forefoot or explicit positions of the map; angles 0 (calibrated signals are in the
        segment frame)."""
        base = IMUPlacement.default(height)
        positions = dict(base.positions)
        for a in self.assignments.values():
            if a.position == "forefoot":
                positions[a.segment] = (FOREFOOT_POSITION_M[0] * height / 1.75, FOREFOOT_POSITION_M[1] * height / 1.75)
            elif isinstance(a.position, tuple):
                positions[a.segment] = a.position
        return IMUPlacement(positions=positions)


def _segment(source: str, sensor: str, name: Any) -> str:
    if not isinstance(name, str):
        raise SensorMapError(f"{source}: sensor {sensor!r}: segment must be a name such as femur_r, got {name!r}")
    kind, _, side = name.partition("_")
    canonical = f"{SEGMENT_ALIASES.get(kind, kind)}{'_' + side if side else ''}"
    if canonical not in SEGMENTS:
        raise SensorMapError(f"{source}: sensor {sensor!r}: unknown segment {name!r}; use one of {list(SEGMENTS)} "
                             f"(aliases thigh_<r|l>, shank_<r|l>)")
    return canonical


def _axis(source: str, sensor: str, key: str, value: Any) -> np.ndarray | None:
    if value is None:
        return None
    if isinstance(value, str) and value.strip().upper() in _AXES:
        return _AXES[value.strip().upper()].copy()
    try:
        vec = np.asarray(value, dtype=float).reshape(3)
    except (TypeError, ValueError):
        vec = None
    if vec is None or not np.isfinite(vec).all() or np.linalg.norm(vec) == 0:
        raise SensorMapError(f"{source}: sensor {sensor!r}: {key} must be a sensor axis such as '+Z' or '-X' or a non-zero "
                             f"3-vector, got {value!r}")
    return vec / np.linalg.norm(vec)


def _assignment(source: str, sensor: str, entry: Any) -> SensorAssignment:
    if isinstance(entry, str):
        return SensorAssignment(sensor, _segment(source, sensor, entry))
    if not isinstance(entry, dict) or "segment" not in entry:
        raise SensorMapError(f"{source}: sensor {sensor!r}: expected a segment name or a mapping with 'segment:', got {entry!r}")
    unknown = set(entry) - {"segment", "position", "position_m", "right_axis", "up_axis"}
    if unknown:
        raise SensorMapError(f"{source}: sensor {sensor!r}: unknown key(s) {sorted(unknown)}; allowed: segment, position, "
                             "position_m, right_axis, up_axis")
    segment = _segment(source, sensor, entry["segment"])
    position: str | tuple[float, float] = "default"
    if "position_m" in entry:
        xy = entry["position_m"]
        if (not isinstance(xy, list) or len(xy) != 2 or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in xy)
                or not all(np.isfinite(xy))):
            raise SensorMapError(f"{source}: sensor {sensor!r}: position_m must be [x, y] in metres (segment frame), got {xy!r}")
        if max(abs(v) for v in xy) > 1.0:
            raise SensorMapError(f"{source}: sensor {sensor!r}: position_m {xy} is more than 1 m from the joint: give metres, not cm")
        position = (float(xy[0]), float(xy[1]))
    elif "position" in entry:
        position = entry["position"]
        if position not in ("default", "forefoot"):
            raise SensorMapError(f"{source}: sensor {sensor!r}: position must be 'default' or 'forefoot' (or give position_m), got {position!r}")
        if position == "forefoot" and not segment.startswith("foot"):
            raise SensorMapError(f"{source}: sensor {sensor!r}: position 'forefoot' needs a foot segment, not {segment!r}")
    return SensorAssignment(sensor, segment, position, _axis(source, sensor, "right_axis", entry.get("right_axis")),
                            _axis(source, sensor, "up_axis", entry.get("up_axis")))
