"""Human gait norms as a check: does a (simulated, synthetic or measured) walk or run load the
ground, share its stride between stance, double support and flight, and step at the cadence people
do at that speed?

:func:`check_gait_norms` takes either the vertical ground reaction forces alone — an (N, 2) array
``[F_y right, F_y left]`` in body weights (or (N, 4) ``[F_x_r, F_y_r, F_x_l, F_y_l]``) and its
sample rate — or a :class:`~sspinn.model.trajectory.Trajectory` with the body weight (its joint
angles then also give the hip/knee/ankle RMSD to Winter's walking), and returns a
:class:`GaitNormsReport`: per stance the vertical-GRF peak(s) and midstance valley, the stance,
double-support and flight share of the stride that stance begins, each against the human range at
that speed (pass/fail per stance and the fraction of stances inside all ranges), and the gait's
cadence and angle RMSD.

Events come from the project's detector (:func:`sspinn.data.gait_events.detect_events`: vertical
GRF above 0.1 BW, phases shorter than 50 ms removed); contacts shorter than
:data:`sspinn.data.gait_events.TAP_FRACTION` of the typical contact are **taps**, not stances
(:func:`sspinn.data.gait_events.split_taps`), counted and failed (people do not tap); steps are
alternating heel strikes of real stances (:func:`sspinn.data.gait_events.alternating_steps`); the
stance / double-support / flight shares are :func:`sspinn.data.gait_events.phase_fractions` of a
stride (heel strike to the same foot's next heel strike): double support and stance from the
stance masks (taps removed), flight from the contact masks (no foot above the threshold, taps
included).

Human ranges (:func:`human_ranges`; speeds outside the tabulated ones take the nearest row):

* **Walking**, vertical GRF peak (the larger of the two peaks of a stance), BW: 0.95–1.25 at
  0.8 m/s, 1.0–1.35 at 1.3 m/s, 1.1–1.6 at 1.8 m/s, linear in between. People load ≈ 1.0–1.1 BW
  below 1.2 m/s, 1.1–1.2 at 1.3–1.5 m/s and up to ≈ 1.4–1.5 near 2 m/s (Nilsson & Thorstensson
  1989, *Acta Physiol Scand* 136:217–227; Keller et al. 1996, *Clin Biomech* 11:253–259). The
  midstance valley 0.6–0.9 BW (Winter 1991, *The Biomechanics and Motor Control of Human Gait*,
  2nd ed.: 0.7–0.8 BW at natural cadence). Stance 58–65 % of the stride, double support 15–25 %
  of the stride (two periods of ≈ 10 %), flight ≤ 1 % (walking has none; Perry 1992, *Gait
  Analysis*; Winter 1991). Cadence, steps/min: 80–110 at 0.8 m/s, 95–125 at 1.3 m/s, 110–140 at
  1.8 m/s (bands around the speed–cadence means of Öberg, Karsznia & Öberg 1993, *J Rehabil Res
  Dev* 30:210–223). Angle RMSD to Winter's walking (1.325 m/s) ≤ 6 / 8 / 6° (hip / knee / ankle),
  checked at 1.0–1.6 m/s only (the angles change with speed).
* **Running** (tabulated for 2.5–4.5 m/s): vertical GRF peak 2.2–3.0 BW (Cavanagh & Lafortune
  1980, *J Biomech* 13:397–406: ≈ 2.8 BW at 4.5 m/s; Keller et al. 1996: 2.0–2.9 BW at 3–6 m/s;
  Nilsson & Thorstensson 1989), flight 20–40 % of the stride, hence stance (100 − flight) / 2 =
  30–40 % of the stride (Novacheck 1998, *Gait Posture* 7:77–95), cadence 150–190 steps/min
  (Heiderscheit et al. 2011, *Med Sci Sports Exerc* 43:296–302: preferred 160–175 at 2.9–3.3 m/s).
  No double support (0 %: a run's feet are never down together), no valley check.

The gait passes (:attr:`GaitNormsReport.passed`) when every gait-level check that applies passes:
the medians over the stances of the peak, valley, stance, double-support and flight shares inside
their ranges, the cadence inside its range, no taps, and the angle RMSDs within their limits.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import Any, Final, Literal

import numpy as np

from sspinn.data.gait_events import (
    CONTACT_THRESHOLD_BW,
    MIN_PHASE_S,
    TAP_FRACTION,
    alternating_steps,
    detect_events,
    phase_fractions,
    split_taps,
    strides,
)
from sspinn.data.gait_metrics import ReferenceGait, angle_rmsd
from sspinn.model.trajectory import Trajectory

Mode = Literal["walk", "run"]
#: Accepted speeds per mode, m/s (outside: a one-line error, the ranges do not apply).
SPEED_LIMITS: Final = {"walk": (0.5, 2.2), "run": (2.0, 6.0)}
#: Largest accepted sample rate, Hz.
MAX_RATE_HZ: Final = 100_000.0
#: Walking rows of :func:`human_ranges`: speed (m/s) → (peak low, peak high) BW and cadence (low, high).
WALK_PEAK_BW: Final = {0.8: (0.95, 1.25), 1.3: (1.0, 1.35), 1.8: (1.1, 1.6)}
WALK_CADENCE: Final = {0.8: (80.0, 110.0), 1.3: (95.0, 125.0), 1.8: (110.0, 140.0)}
#: Speeds at which the angle RMSD to Winter's walking (1.325 m/s) is checked, m/s.
RMSD_SPEEDS: Final = (1.0, 1.6)


@dataclass(frozen=True)
class HumanRanges:
    """Human ranges of one gait at one speed (module docstring for the sources). Each range is a
    (low, high) pair; None where the quantity is not checked.

    Attributes:
        mode: "walk" or "run". speed_m_s: the speed the ranges are for, m/s.
        peak_bw: vertical GRF peak of a stance, BW.
        valley_bw: midstance valley of the vertical GRF, BW (walking only).
        stance_percent: stance, % of the stride.
        double_support_percent: double support, % of the stride.
        flight_percent: flight (no foot loaded), % of the stride.
        cadence_steps_per_min: steps per minute.
        rmsd_max_deg: (hip, knee, ankle) largest RMSD to Winter's walking, deg (walking near 1.3 m/s only).
    """

    mode: str
    speed_m_s: float
    peak_bw: tuple[float, float]
    valley_bw: tuple[float, float] | None
    stance_percent: tuple[float, float]
    double_support_percent: tuple[float, float]
    flight_percent: tuple[float, float]
    cadence_steps_per_min: tuple[float, float]
    rmsd_max_deg: tuple[float, float, float] | None


def _interp_row(table: dict[float, tuple[float, float]], speed: float) -> tuple[float, float]:
    speeds = sorted(table)
    return (float(np.interp(speed, speeds, [table[s][0] for s in speeds])),
            float(np.interp(speed, speeds, [table[s][1] for s in speeds])))


def human_ranges(speed_m_s: float, mode: Mode = "walk") -> HumanRanges:
    """The human ranges at ``speed_m_s`` (m/s) for walking or running (module docstring);
    :class:`ValueError` for an unknown mode or a speed outside :data:`SPEED_LIMITS`."""
    if mode not in SPEED_LIMITS:
        raise ValueError(f"mode must be 'walk' or 'run', got {mode!r}")
    low, high = SPEED_LIMITS[mode]
    if not (math.isfinite(speed_m_s) and low <= speed_m_s <= high):
        raise ValueError(f"speed {speed_m_s} m/s is outside the {mode} norms' range {low}–{high} m/s")
    if mode == "walk":
        rmsd = (6.0, 8.0, 6.0) if RMSD_SPEEDS[0] <= speed_m_s <= RMSD_SPEEDS[1] else None
        return HumanRanges("walk", float(speed_m_s), _interp_row(WALK_PEAK_BW, speed_m_s), (0.6, 0.9), (58.0, 65.0),
                           (15.0, 25.0), (0.0, 1.0), _interp_row(WALK_CADENCE, speed_m_s), rmsd)
    return HumanRanges("run", float(speed_m_s), (2.2, 3.0), None, (30.0, 40.0), (0.0, 1.0), (20.0, 40.0), (150.0, 190.0), None)


def _inside(value: float, bounds: tuple[float, float] | None) -> bool | None:
    if bounds is None or not math.isfinite(value):
        return None
    return bool(bounds[0] <= value <= bounds[1])


@dataclass(frozen=True)
class StanceNorms:
    """One stance (heel strike to toe-off of one foot) against the human ranges.

    Attributes:
        foot: "r" or "l". start_s: heel strike, s from the first sample. duration_s: stance, s.
        peak_bw: largest vertical GRF of the stance, BW.
        first_peak_bw, second_peak_bw: largest vertical GRF in the first and the second half, BW.
        valley_bw: smallest vertical GRF between those two peaks, BW (the midstance valley).
        stance_percent, double_support_percent, flight_percent: shares of the stride this stance
            begins (to the same foot's next heel strike), %; NaN when that stride is not complete.
        checks: name → inside its range (True/False), None where not checked or undefined.
        passed: every check that applies passes.
    """

    foot: str
    start_s: float
    duration_s: float
    peak_bw: float
    first_peak_bw: float
    second_peak_bw: float
    valley_bw: float
    stance_percent: float
    double_support_percent: float
    flight_percent: float
    checks: dict[str, bool | None] = field(default_factory=dict)
    passed: bool = False


@dataclass(frozen=True)
class GaitNormsReport:
    """A gait against the human ranges at its speed (module docstring).

    Attributes:
        ranges: the :class:`HumanRanges` applied.
        stances: the complete stances, in time order.
        taps: contacts too short to be stances (both feet).
        steps: alternating steps between stances.
        fraction_inside: share of the stances whose every check passes (0–1; NaN without stances).
        peak_bw, valley_bw: medians over the stances, BW.
        stance_percent, double_support_percent, flight_percent: medians over the stances' strides, %.
        flight_time_percent: share of the analysed time with no foot loaded, %.
        cadence_steps_per_min: 60 / mean step time.
        rmsd_hip_deg, rmsd_knee_deg, rmsd_ankle_deg: RMSD of the mean cycles' angles to the
            reference (deg, mean over legs); NaN for a GRF array or without a reference.
        checks: gait-level check name → inside its range, None where not checked or undefined.
        passed: every gait-level check that applies passes (and there is at least one stance).
    """

    ranges: HumanRanges
    stances: tuple[StanceNorms, ...]
    taps: int
    steps: int
    fraction_inside: float
    peak_bw: float
    valley_bw: float
    stance_percent: float
    double_support_percent: float
    flight_percent: float
    flight_time_percent: float
    cadence_steps_per_min: float
    rmsd_hip_deg: float
    rmsd_knee_deg: float
    rmsd_ankle_deg: float
    checks: dict[str, bool | None]
    passed: bool

    def as_dict(self) -> dict[str, Any]:
        """JSON-friendly values (NaN → None)."""

        def clean(v: Any) -> Any:
            if isinstance(v, float):
                return v if math.isfinite(v) else None
            if isinstance(v, dict):
                return {k: clean(x) for k, x in v.items()}
            if isinstance(v, (list, tuple)):
                return [clean(x) for x in v]
            return v

        return clean(asdict(self))

    def summary(self) -> str:
        """One line: the medians, the ranges and the verdicts."""
        r = self.ranges

        def part(name: str, value: float, bounds: tuple[float, ...] | None, fmt: str = ".2f") -> str:
            verdict = self.checks.get(name)
            mark = "" if verdict is None else (" ok" if verdict else " OUT")
            rng = "" if bounds is None else f" [{bounds[0]:g}–{bounds[1]:g}]"
            shown = "–" if not math.isfinite(value) else format(value, fmt)
            return f"{name} {shown}{rng}{mark}"

        parts = [part("peak", self.peak_bw, r.peak_bw)] + ([part("valley", self.valley_bw, r.valley_bw)] if r.valley_bw else []) + [
                 part("stance", self.stance_percent, r.stance_percent, ".1f"),
                 part("double_support", self.double_support_percent, r.double_support_percent, ".1f"),
                 part("flight", self.flight_percent, r.flight_percent, ".1f"),
                 part("cadence", self.cadence_steps_per_min, r.cadence_steps_per_min, ".0f"),
                 f"taps {self.taps}"]
        if math.isfinite(self.rmsd_knee_deg):
            parts.append(f"RMSD hip/knee/ankle {self.rmsd_hip_deg:.1f}/{self.rmsd_knee_deg:.1f}/{self.rmsd_ankle_deg:.1f} deg")
        inside = "–" if not math.isfinite(self.fraction_inside) else f"{100 * self.fraction_inside:.0f} %"
        return (f"{r.mode} {r.speed_m_s:g} m/s: {len(self.stances)} stances, {inside} inside; " + ", ".join(parts)
                + f" -> {'PASS' if self.passed else 'FAIL'}")


def _median(values: list[float]) -> float:
    finite = [v for v in values if math.isfinite(v)]
    return float(np.median(finite)) if finite else float("nan")


def _vertical_bw(data: Trajectory | np.ndarray, rate_hz: float | None, body_weight_n: float | None) -> tuple[np.ndarray, float]:
    """(T, 2) vertical forces in BW and the sample rate (Hz) of the input (one-line errors)."""
    if isinstance(data, Trajectory):
        if body_weight_n is None or not (math.isfinite(body_weight_n) and body_weight_n > 0):
            raise ValueError(f"a Trajectory needs body_weight_n > 0 (N), got {body_weight_n}")
        if len(data.time) < 3:
            raise ValueError(f"the trajectory has {len(data.time)} samples; at least 3 are needed")
        return np.asarray(data.grf, dtype=float)[:, [1, 3]] / body_weight_n, 1.0 / float(np.median(np.diff(data.time)))
    array = np.asarray(data, dtype=float)
    if array.ndim != 2 or array.shape[1] not in (2, 4):
        raise ValueError(f"vertical GRF must be (N, 2) [F_y_r, F_y_l] or (N, 4) [F_x_r, F_y_r, F_x_l, F_y_l] in BW, got shape {array.shape}")
    if array.shape[1] == 4:
        array = array[:, [1, 3]]
    if not np.isfinite(array).all():
        bad = int(np.flatnonzero(~np.isfinite(array).all(axis=1))[0])
        raise ValueError(f"vertical GRF: non-finite value at row {bad}")
    if rate_hz is None or not (math.isfinite(rate_hz) and 0 < rate_hz <= MAX_RATE_HZ):
        raise ValueError(f"rate_hz must be in (0, {MAX_RATE_HZ:g}] Hz for a GRF array, got {rate_hz}")
    return array, float(rate_hz)


def check_gait_norms(
    data: Trajectory | np.ndarray,
    speed_m_s: float,
    mode: Mode = "walk",
    *,
    rate_hz: float | None = None,
    body_weight_n: float | None = None,
    reference: ReferenceGait | None = None,
    settle_s: float = 0.0,
    tap_fraction: float = TAP_FRACTION,
) -> GaitNormsReport:
    """A gait against the human ranges at ``speed_m_s`` (module docstring).

    Args:
        data: the vertical GRF, (N, 2) ``[F_y_r, F_y_l]`` or (N, 4) ``[F_x_r, F_y_r, F_x_l,
            F_y_l]`` in body weights, sampled at ``rate_hz``; or a
            :class:`~sspinn.model.trajectory.Trajectory` (GRF in N, ``body_weight_n`` required;
            its joint angles give the RMSD to ``reference``).
        speed_m_s: the gait's speed, m/s (selects the ranges, :func:`human_ranges`).
        mode: "walk" or "run".
        rate_hz: sample rate of a GRF array, Hz (a Trajectory's comes from its time).
        body_weight_n: body weight, N (a Trajectory only).
        reference: reference angles for the RMSD (:func:`sspinn.data.gait_metrics.winter_or_none`);
            None: no RMSD.
        settle_s: stances starting before this time (s from the first sample) are left out.
        tap_fraction: tap threshold, a fraction of the typical contact
            (:data:`sspinn.data.gait_events.TAP_FRACTION`).

    Raises:
        ValueError: a one-line message for a bad shape, a non-finite force, a bad rate, body
            weight, mode or speed.
    """
    ranges = human_ranges(speed_m_s, mode)
    vertical, rate = _vertical_bw(data, rate_hz, body_weight_n)
    n = len(vertical)
    contacts = [detect_events(vertical[:, f], 1.0, rate, CONTACT_THRESHOLD_BW, MIN_PHASE_S).contact for f in range(2)]
    feet = split_taps(contacts, rate, tap_fraction)
    first = min(n, max(0, int(math.ceil(settle_s * rate - 1e-9))))
    heel_strikes = [ft.heel_strikes[ft.heel_strikes >= first] for ft in feet]
    foot_strides = [dict(strides(h, rate)) for h in heel_strikes]

    stances: list[StanceNorms] = []
    for f, ft in enumerate(feet):
        for hs in heel_strikes[f]:
            offs = ft.toe_offs[ft.toe_offs > hs]
            if not len(offs):
                continue
            to = int(offs[0])
            force = vertical[hs:to, f]
            half = max(1, len(force) // 2)
            i1 = int(np.argmax(force[:half]))
            i2 = half + int(np.argmax(force[half:])) if len(force) > half else i1
            valley = float(force[i1 : i2 + 1].min())
            end = foot_strides[f].get(int(hs))
            if end is not None:
                st = phase_fractions(feet[0].stance[hs:end], feet[1].stance[hs:end])
                fl = phase_fractions(contacts[0][hs:end], contacts[1][hs:end])
                shares = (100.0 * (to - hs) / (end - hs), 100.0 * st.double_support, 100.0 * fl.flight)
            else:
                shares = (float("nan"),) * 3
            checks = {"peak": _inside(float(force.max()), ranges.peak_bw), "valley": _inside(valley, ranges.valley_bw),
                      "stance": _inside(shares[0], ranges.stance_percent),
                      "double_support": _inside(shares[1], ranges.double_support_percent),
                      "flight": _inside(shares[2], ranges.flight_percent)}
            stances.append(StanceNorms("rl"[f], float(hs / rate), float((to - hs) / rate), float(force.max()),
                                       float(force[i1]), float(force[i2]), valley, *shares, checks=checks,
                                       passed=all(v is not False for v in checks.values())))
    stances.sort(key=lambda s: s.start_s)

    steps = alternating_steps(*heel_strikes)
    step_times = [(b - a) / rate for a, b, _ in steps]
    cadence = 60.0 / float(np.mean(step_times)) if step_times and np.mean(step_times) > 0 else float("nan")
    taps = sum(1 for ft in feet for start, _ in ft.taps if start >= first)
    flight_time = 100.0 * phase_fractions(contacts[0][first:], contacts[1][first:]).flight if first < n else float("nan")
    rmsd = {"hip": float("nan"), "knee": float("nan"), "ankle": float("nan")}
    if isinstance(data, Trajectory) and reference is not None:
        rmsd = angle_rmsd(np.asarray(data.q), [list(s.items()) for s in foot_strides], reference)

    medians = {name: _median([getattr(s, attr) for s in stances]) for name, attr in
               (("peak", "peak_bw"), ("valley", "valley_bw"), ("stance", "stance_percent"),
                ("double_support", "double_support_percent"), ("flight", "flight_percent"))}
    def gait_check(value: float, bounds: tuple[float, float] | None) -> bool | None:
        """None where not checked; False where undefined (too few stances or steps to show it)."""
        return None if bounds is None else bool(_inside(value, bounds))

    checks: dict[str, bool | None] = {
        "peak": gait_check(medians["peak"], ranges.peak_bw),
        "valley": gait_check(medians["valley"], ranges.valley_bw),
        "stance": gait_check(medians["stance"], ranges.stance_percent),
        "double_support": gait_check(medians["double_support"], ranges.double_support_percent),
        "flight": gait_check(medians["flight"], ranges.flight_percent),
        "cadence": gait_check(cadence, ranges.cadence_steps_per_min),
        "taps": taps == 0,
    }
    if ranges.rmsd_max_deg is not None and isinstance(data, Trajectory) and reference is not None:
        for name, limit in zip(("hip", "knee", "ankle"), ranges.rmsd_max_deg):
            checks[f"rmsd_{name}"] = gait_check(rmsd[name], (0.0, limit))
    return GaitNormsReport(
        ranges=ranges,
        stances=tuple(stances),
        taps=taps,
        steps=len(steps),
        fraction_inside=float(np.mean([s.passed for s in stances])) if stances else float("nan"),
        peak_bw=medians["peak"],
        valley_bw=medians["valley"],
        stance_percent=medians["stance"],
        double_support_percent=medians["double_support"],
        flight_percent=medians["flight"],
        flight_time_percent=flight_time,
        cadence_steps_per_min=cadence,
        rmsd_hip_deg=rmsd["hip"],
        rmsd_knee_deg=rmsd["knee"],
        rmsd_ankle_deg=rmsd["ankle"],
        checks=checks,
        passed=bool(stances) and all(v is not False for v in checks.values()),
    )


__all__ = ["GaitNormsReport", "HumanRanges", "StanceNorms", "check_gait_norms", "human_ranges"]
