"""Checks across the sensors of one calibration that no single sensor can make: a sensor mounted
upside down compared with the others, and a sensor map that mixes up the legs. They only warn:
the calibration (:mod:`sspinn.imu.calibration`) finds every sensor's frame from its own data,
so the projected signals do not depend on how a sensor is mounted — but a map that puts a sensor
on the wrong segment gives that segment another segment's (correctly calibrated) signals.

* **Upside down** (:func:`upside_down_warnings`): a sensor has no "up" of its own, so without an
  ``up_axis`` hint it is judged against the other sensors of the recording. Each sensor's axis
  nearest the segment's long axis (``reference_axis``; only sensors mounted along their segment,
  within :data:`ALONG_SEGMENT_DEG`) is compared: a sensor is flagged when at least two others
  have the opposite axis up and they outnumber the sensors with its own axis up (itself included);
  so are the two sensors of a left/right pair (thighs, shanks, feet) whose axes are opposite when
  no majority decides which one is wrong. Sensors mounted at random (no common protocol) may be
  flagged merely for differing from the others; a sensor turned about its long axis (facing the
  skin) is not flagged.
* **Legs mixed up** (:func:`leg_pairing_warnings`): the thigh, shank and foot of one leg swing
  nearly in phase; sensors of the two legs half a stride apart. The phase at the stride frequency
  between two calibrated sagittal rates of one mapped side must lie within 90° of
  :data:`sspinn.data.signal_checks.LEG_PHASE_DEG` (thigh → shank +45°, shank → foot +15°, thigh → foot +65°; measured on
  the twelve CMU treadmill trials: +3…+83°, +4…+22°, +57…+104°, and +41°, +12°, +53° in a
  predicted 1.3 m/s gait; the other leg's sensors: −96…−143°). A sensor map that swaps one
  segment's sensors between the sides, or the thigh and shank of one leg, fails it (as would a
  wrong medio-lateral sign: see the sign margins).
* **Sides swapped** (:func:`side_warnings`): swapping *all* sensors of the two legs passes the
  pairing, but not the pelvis: during a foot's stance the body is pushed medially, towards the
  swing leg, so the pelvis's medio-lateral specific force (calibrated axis z, to the right)
  correlates negatively with the right-minus-left stance (−|ω| of the feet, else the shanks, 0.2 s
  means): −0.48…−0.89 in all twelve CMU trials. Above :data:`SIDE_CORRELATION_WARN` the sides look
  swapped (or the pelvis's medio-lateral sign is wrong). Needs a pelvis sensor and a foot or a
  shank on each side; synthetic data without medio-lateral motion gives a correlation near 0 and
  no verdict.
* **Another sensor fits the pelvis better** (:func:`pelvis_candidate_warnings`): a sensor the map
  ignores (e.g. the torso's) may be the real pelvis sensor, mapped under the other's name. Each
  ignored sensor is calibrated as the pelvis and the hip joint constraints of
  :func:`sspinn.data.signal_checks.joint_fit` (one point, the hip, seen alike from pelvis and
  thigh) are fitted with it and with the mapped pelvis sensor: the sensor nearer the hips, on the
  same rigid segment, fits them better (the spine bends between the trunk and the pelvis). The
  rule has no tuned threshold: an ignored sensor whose pooled hip residual is smaller warns.
  Measured on the twelve CMU trials (torso sensor mapped as the pelvis, the pelvis sensor
  ignored, and the right map): whole trials (the first 60 s) 12 of 12 swapped maps warned, 0 of
  12 right maps (the torso's residual 1.04–1.54× the pelvis's); 20 s excerpts 71 of 72 and 1 of
  72; 10 s excerpts 70 of 72 and 2 of 72, hence judged only on imports of at least
  :data:`PELVIS_CHECK_MIN_S`. Needs the other sensor in the files (``ignore`` in the map) and a
  thigh sensor.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Final

import numpy as np

from sspinn.data.signal_checks import hip_residual_rms, leg_phase_findings
from sspinn.errors import UserError
from sspinn.imu.calibration import Calibration, calibrate, moving_mean
from sspinn.imu.sensor_map import SensorAssignment

#: A sensor counts as mounted along its segment when its reference axis lies within this angle
#: of the segment's long axis, deg.
ALONG_SEGMENT_DEG: Final = 45.0
#: Correlation of the pelvis's medio-lateral force with the right-minus-left stance above which
#: the sides look swapped (real walking: −0.5 to −0.9).
SIDE_CORRELATION_WARN: Final = 0.3
#: Smoothing of the stance and pelvis signals of the side check, s.
SIDE_SMOOTHING_S: Final = 0.2
#: Shortest import on which ignored sensors are compared with the pelvis sensor, s (on 10 s
#: excerpts of the CMU trials the comparison of the right map scattered up to 1.10 in favour
#: of the torso sensor; on 20 s excerpts up to 1.02).
PELVIS_CHECK_MIN_S: Final = 20.0
_KINDS: Final = ("femur", "tibia", "foot")


def check_mounting(signals: dict[str, tuple[np.ndarray, np.ndarray]], cal: Calibration,
                   assignments: dict[str, SensorAssignment], sources: dict[str, str]) -> bool:
    """Run the three checks of the module docstring and add their findings to ``cal.warnings``
    (and the side check's correlation to ``cal.notes``); True if the legs look mixed up (then the
    joint constraints of :func:`sspinn.data.signal_checks.joint_findings` are not judged: several
    joints are broken at once).

    Args:
        signals: segment → (acc (n, 3) m/s², gyr (n, 3) rad/s) in the sensor frame, as calibrated.
        cal: their calibration. assignments: segment → the map's entry (for ``up_axis`` hints).
        sources: segment → the file(s) the sensor was read from, for messages.
    """
    cal.warnings += upside_down_warnings(cal, assignments, sources)
    mixed = leg_pairing_warnings(signals, cal, sources) + side_warnings(signals, cal, sources)
    cal.warnings += mixed
    return bool(mixed)


def _who(cal: Calibration, seg: str) -> str:
    """``'sensor' (segment)`` for messages."""
    return f"{cal.sensors[seg].sensor!r} ({seg})"


def _files(sources: dict[str, str], segments: Iterable[str]) -> str:
    """The files of the ``segments``' sensors, each once, for messages."""
    return ", ".join(dict.fromkeys(sources[s] for s in segments))


def _opposite(axis: str) -> str:
    """``"+X"`` → ``"-X"`` and back."""
    return ("-" if axis[0] == "+" else "+") + axis[1:]


def upside_down_warnings(cal: Calibration, assignments: dict[str, SensorAssignment], sources: dict[str, str]) -> list[str]:
    """Sensors whose long axis points the other way than the other sensors' (module docstring);
    sensors with an ``up_axis`` hint are checked by the calibration instead, and serve here only
    as references."""
    up = {seg: c.reference_axis for seg, c in cal.sensors.items() if abs(c.angle_deg) <= ALONG_SEGMENT_DEG}
    unhinted = [seg for seg in up if assignments[seg].up_axis is None]
    advice = "calibrated accordingly (the projected signals do not depend on the mounting)"
    warnings, flagged = [], set()
    for seg in unhinted:
        opposite = [s for s, a in up.items() if a == _opposite(up[seg])]
        same = [s for s, a in up.items() if a == up[seg] and s != seg]
        if len(opposite) >= 2 and len(opposite) > len(same) + 1:
            flagged.add(seg)
            warnings.append(f"{sources[seg]}, sensor {_who(cal, seg)}: appears mounted upside down: its {up[seg]} axis points up "
                            f"the segment, but {_opposite(up[seg])} does on {len(opposite)} other sensors ({', '.join(opposite)}); "
                            f"{advice}: check the sensor, or give up_axis: \"{up[seg]}\" in the sensor map if it is meant to be so")
    for kind in _KINDS:
        pair = (f"{kind}_r", f"{kind}_l")
        if all(s in unhinted and s not in flagged for s in pair) and up[pair[0]] == _opposite(up[pair[1]]):
            warnings.append(f"{_files(sources, pair)}: sensors {_who(cal, pair[0])} and {_who(cal, pair[1])} are mounted opposite "
                            f"ways up ({up[pair[0]]} and {up[pair[1]]} point up their segments): one of them appears upside down; "
                            f"{advice}: check them, or give their up_axis in the sensor map")
    return warnings


def _walking_mask(cal: Calibration, n: int) -> np.ndarray:
    """(n,) True in the walking spans the calibration used."""
    mask = np.zeros(n, dtype=bool)
    for a, b in cal.walking_runs:
        mask[a:b] = True
    return mask


def leg_pairing_warnings(signals: dict[str, tuple[np.ndarray, np.ndarray]], cal: Calibration,
                         sources: dict[str, str]) -> list[str]:
    """One warning per mapped side whose sensors do not move like the segments of one leg
    (stride-frequency phases of the calibrated sagittal rates; module docstring)."""
    if not cal.walking_runs:
        return []
    rate = {seg: c.project(*signals[seg])[:, 2] for seg, c in cal.sensors.items()}
    period = cal.stride_period_s
    window = min(max(4 * period, 2.0), max(b - a for a, b in cal.walking_runs) / cal.rate_hz)
    warnings = []
    for name, bad in leg_phase_findings(rate, cal.rate_hz, 1 / period, cal.walking_runs, window).items():
        if bad:
            segs = [s for sa, sb, _, _ in bad for s in (sa, sb)]
            pairs = "; ".join(f"{_who(cal, sa)} leads {_who(cal, sb)} by {phase:+.0f}° (one leg: {expected:+.0f}° ± 90°)"
                              for sa, sb, phase, expected in bad)
            warnings.append(f"{_files(sources, segs)}: the {name}-leg sensors do not move like one leg (stride-frequency phase of "
                            f"their sagittal rates: {pairs}): the sensor map may swap sides or segments, or a medio-lateral "
                            "sign is wrong (see the sign margins)")
    return warnings


def side_warnings(signals: dict[str, tuple[np.ndarray, np.ndarray]], cal: Calibration, sources: dict[str, str]) -> list[str]:
    """A warning if the pelvis is pushed towards the stance leg instead of the swing leg: right
    and left swapped in the map (module docstring); the correlation goes to ``cal.notes``."""
    stance = next(([f"{k}_r", f"{k}_l"] for k in ("foot", "tibia") if f"{k}_r" in cal.sensors and f"{k}_l" in cal.sensors), None)
    if "pelvis" not in cal.sensors or stance is None or not cal.walking_runs:
        return []
    n = int(SIDE_SMOOTHING_S * cal.rate_hz)
    still = [-moving_mean(np.linalg.norm(signals[s][1], axis=1), n) for s in stance]
    lateral = moving_mean(signals["pelvis"][0] @ cal.sensors["pelvis"].axis, n)
    mask = _walking_mask(cal, len(lateral))
    corr = float(np.corrcoef(lateral[mask], (still[0] - still[1])[mask])[0, 1])
    cal.notes.append(f"side check: the pelvis's medio-lateral force correlates {corr:+.2f} with the right-minus-left stance "
                     f"of {stance[0]} and {stance[1]} (real walking: −0.5 to −0.9; above {SIDE_CORRELATION_WARN:+.1f} the "
                     "sides look swapped)")
    if not corr > SIDE_CORRELATION_WARN:
        return []
    return [f"{_files(sources, ['pelvis', *stance])}: right and left look swapped in the sensor map (or the pelvis's medio-lateral "
            f"sign is wrong): the pelvis sensor {_who(cal, 'pelvis')} is pushed to the right while {_who(cal, stance[0])} is in "
            f"stance and to the left while {_who(cal, stance[1])} is, towards the stance leg instead of the swing leg "
            f"(correlation {corr:+.2f}; real walking: −0.5 to −0.9)"]


def pelvis_candidate_warnings(candidates: dict[str, tuple[np.ndarray, np.ndarray]],
                              signals: dict[str, tuple[np.ndarray, np.ndarray]], cal: Calibration,
                              assignments: dict[str, SensorAssignment], sources: dict[str, str]) -> list[str]:
    """The ignored sensors that fit the hips better than the mapped pelvis sensor (module docstring).

    Args:
        candidates: sensor name → (acc (n, 3) m/s², gyr (n, 3) rad/s) of the ignored sensors, in
            their own frames, on the grid of ``signals``.
        signals, cal, assignments, sources: as for :func:`check_mounting`.
    """
    thighs = [seg for seg in ("femur_r", "femur_l") if seg in signals]
    if "pelvis" not in signals or not thighs or not candidates or len(signals["pelvis"][0]) < PELVIS_CHECK_MIN_S * cal.rate_hz:
        return []
    segments = ["pelvis", *thighs]
    projected_thighs = [cal.sensors[seg].project(*signals[seg]) for seg in thighs]

    def residual(pelvis: np.ndarray) -> float | None:
        return hip_residual_rms(np.stack([pelvis, *projected_thighs], axis=1), segments)

    mapped = residual(cal.sensors["pelvis"].project(*signals["pelvis"]))
    if mapped is None:
        return []
    found = []
    for name, (acc, gyr) in candidates.items():
        trial = {**signals, "pelvis": (acc, gyr)}
        try:  # the legs are calibrated with it (stride period, standing), as they were for the mapped pelvis
            other = calibrate(trial, {**assignments, "pelvis": SensorAssignment(name, "pelvis")}, cal.rate_hz,
                              standing=cal.standing, source=sources.get("pelvis", "<stream>"))
        except UserError:  # not calibratable as a pelvis (e.g. it does not move with the body)
            continue
        fit = residual(other.sensors["pelvis"].project(acc, gyr))
        if fit is not None and fit < mapped:
            found.append(
                f"{sources.get('pelvis', '<stream>')}: the ignored sensor {name!r} fits the hip joints better than "
                f"{_who(cal, 'pelvis')} (hip constraint residual {fit:.2f} vs {mapped:.2f} m/s² RMS): it may be the pelvis "
                "sensor, mapped under another name; check the sensor map")
    return found
