"""Human gait norms of synthetic recordings: every stance against the human ranges at its own speed.

A synthetic recording changes speed (its program's speeds, the ramps between them, 2 % stride to
stride), so one range for the whole recording would be wrong: :func:`recording_norms` runs the
project's norms check (:func:`sspinn.data.gait_norms.check_gait_norms`: events, taps, per-stance
peak, midstance valley and the stance / double-support / flight shares of the stride the stance
begins) and then judges every stance against :func:`sspinn.data.gait_norms.human_ranges` at the
speed label of its first sample (clipped to the ranges' speeds). A tap (a contact too short to be
a stance) counts as a stance outside the norms. :class:`RecordingNorms` holds the counts, the
share inside and the medians; :func:`outside_norms` lists the recordings with fewer than
:data:`MIN_INSIDE` of their stances inside: ``python -m predictive synth`` prints every recording's
line, warns about those and, with ``--require-norms``, refuses to write such a dataset
(:func:`predictive.synth.pipeline.generate_dataset`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass
from typing import Any, Final

import numpy as np

from sspinn.data.dataset import Recording
from sspinn.data.gait_norms import SPEED_LIMITS, Mode, StanceNorms, check_gait_norms, human_ranges

#: Share of a recording's stances (taps included) that must lie inside every human range.
MIN_INSIDE: Final = 0.95
#: The checks of one stance (names of :attr:`sspinn.data.gait_norms.StanceNorms.checks`).
STANCE_CHECKS: Final = ("peak", "valley", "stance", "double_support", "flight")


@dataclass(frozen=True)
class RecordingNorms:
    """One recording's stances against the human ranges at their own speeds.

    Attributes:
        name: the recording. mode: "walk" or "run".
        stances: complete stances judged (both feet). taps: contacts too short to be stances.
        inside: stances inside every range that applies.
        fraction_inside: inside / (stances + taps), 0–1 (NaN without any contact).
        outside: check name → stances outside that range.
        peak_median_bw, peak_max_bw: median and largest per-stance vertical GRF peak, BW.
        valley_median_bw: median midstance valley, BW (NaN when running).
        stance_median_percent, double_support_median_percent, flight_median_percent: medians over
            the stances' strides, % of the stride.
    """

    name: str
    mode: str
    stances: int
    taps: int
    inside: int
    fraction_inside: float
    outside: dict[str, int]
    peak_median_bw: float
    peak_max_bw: float
    valley_median_bw: float
    stance_median_percent: float
    double_support_median_percent: float
    flight_median_percent: float

    @property
    def passed(self) -> bool:
        """At least :data:`MIN_INSIDE` of the stances (taps included) inside every range."""
        return math.isfinite(self.fraction_inside) and self.fraction_inside >= MIN_INSIDE

    def line(self) -> str:
        """One line for the command line: counts, share inside, medians, the failing checks."""
        out = ", ".join(f"{k} {v}" for k, v in self.outside.items() if v) or "none"
        inside = "–" if not math.isfinite(self.fraction_inside) else f"{100 * self.fraction_inside:.0f} %"
        valley = "" if not math.isfinite(self.valley_median_bw) else f", valley {self.valley_median_bw:.2f}"
        return (
            f"{self.name:<14} {self.mode:<4} {self.stances:3d} stances, {self.taps} taps, {inside} inside "
            f"(>= {100 * MIN_INSIDE:.0f} % {'ok' if self.passed else 'OUT'}); peak median {self.peak_median_bw:.2f} "
            f"max {self.peak_max_bw:.2f} BW{valley}, stance {self.stance_median_percent:.0f} %, double support "
            f"{self.double_support_median_percent:.0f} %, flight {self.flight_median_percent:.0f} %; outside: {out}"
        )

    def as_dict(self) -> dict[str, Any]:
        """JSON-friendly values (NaN → None) plus ``passed`` and the printed ``line``."""
        return {
            **{k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in asdict(self).items()},
            "passed": self.passed,
            "line": self.line(),
        }


def _stance_checks(stance: StanceNorms, speed: float, mode: Mode) -> dict[str, bool | None]:
    """``stance``'s checks against the human ranges at ``speed`` (m/s, clipped to the mode's speeds)."""
    low, high = SPEED_LIMITS[mode]
    r = human_ranges(float(np.clip(speed, low, high)), mode)
    bounds = {"peak": r.peak_bw, "valley": r.valley_bw, "stance": r.stance_percent,
              "double_support": r.double_support_percent, "flight": r.flight_percent}
    values = {"peak": stance.peak_bw, "valley": stance.valley_bw, "stance": stance.stance_percent,
              "double_support": stance.double_support_percent, "flight": stance.flight_percent}
    return {
        name: None if bounds[name] is None or not math.isfinite(values[name])
        else bool(bounds[name][0] <= values[name] <= bounds[name][1])
        for name in STANCE_CHECKS
    }


def _median(values: Sequence[float]) -> float:
    finite = [v for v in values if math.isfinite(v)]
    return float(np.median(finite)) if finite else float("nan")


def recording_norms(rec: Recording, body_weight: float, mode: Mode, rate_hz: float = 100.0) -> RecordingNorms:
    """``rec``'s stances against the human ranges at their own speed labels (module docstring).

    Args:
        rec: a recording with GRF (N) and speed (m/s) labels.
        body_weight: the subject's true body weight, N.
        mode: "walk" or "run".
        rate_hz: sample rate, Hz.

    Raises:
        ValueError: the recording has no GRF or speed labels (one line naming it).
    """
    labels = rec.labels
    if labels is None or labels.grf is None or labels.speed is None:
        raise ValueError(f"{rec.name}: the norms check needs GRF and speed labels")
    vertical = labels.grf[:, [1, 3]] / body_weight
    low, high = SPEED_LIMITS[mode]
    median_speed = float(np.clip(np.median(labels.speed), low, high))
    report = check_gait_norms(vertical, median_speed, mode, rate_hz=rate_hz)
    outside = dict.fromkeys(STANCE_CHECKS, 0)
    inside = 0
    for stance in report.stances:
        k = min(len(labels.speed) - 1, int(round(stance.start_s * rate_hz)))
        checks = _stance_checks(stance, float(labels.speed[k]), mode)
        for name, ok in checks.items():
            outside[name] += ok is False
        inside += all(ok is not False for ok in checks.values())
    outside["taps"] = report.taps
    judged = len(report.stances) + report.taps
    return RecordingNorms(
        name=rec.name,
        mode=mode,
        stances=len(report.stances),
        taps=report.taps,
        inside=inside,
        fraction_inside=inside / judged if judged else float("nan"),
        outside=outside,
        peak_median_bw=_median([s.peak_bw for s in report.stances]),
        peak_max_bw=max((s.peak_bw for s in report.stances), default=float("nan")),
        valley_median_bw=_median([s.valley_bw for s in report.stances]) if mode == "walk" else float("nan"),
        stance_median_percent=report.stance_percent,
        double_support_median_percent=report.double_support_percent,
        flight_median_percent=report.flight_percent,
    )


def outside_norms(norms: Mapping[str, RecordingNorms]) -> list[str]:
    """The names of the recordings with fewer than :data:`MIN_INSIDE` of their stances inside."""
    return [name for name, n in norms.items() if not n.passed]


__all__ = ["MIN_INSIDE", "RecordingNorms", "outside_norms", "recording_norms"]
