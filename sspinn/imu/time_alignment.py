"""Time alignment of an IMU stream with a force reference recorded on another clock, by
cross-correlating physically linked signals (both on one 100 Hz grid, times counted from the
start of each stream).

Three physically linked pairs, correlated over all lags (:func:`align_to_grf`):

* **activity**: the IMU's summed rate norms against the GRF's left–right load difference
  |F_r − F_l|, both averaged over two strides — one broad peak where the recordings' changes of
  activity (quiet standing, the start or end of walking) coincide;
* **loading**: each foot's vertical GRF against the stillness of that side's foot (or shank)
  sensor, ``−|ω|`` smoothed over 0.09 s (a foot in stance hardly turns), both sides averaged —
  peaks one stride apart (walking is periodic), biased by the shapes by tens of ms (the foot
  still turns just after heel strike);
* **impact**: the norm of the shank's (or foot's) specific-force change per sample (3D jerk,
  sharp at heel strike) against the positive rate of rise of that foot's vertical force — sharp,
  but weaker and also one stride periodic.

Every local maximum of the loading correlation is a **candidate**; each is refined to the
impact peak within :data:`IMPACT_WINDOW_S` and scored by the sum of the three correlations at
the refined lag (the activity correlation only when it peaks above
:data:`ACTIVITY_MIN_CORRELATION` somewhere: otherwise the recording holds no change of activity
and it is noise). The best candidate gives ``lag_s``, with **t_reference = t_imu + lag_s**.
Confidence (:class:`Alignment`): the three correlations at the chosen lag, and the runner-up
candidate (usually one stride away) with the ratio of the scores — close to 1 means the
alignment may be off by whole strides (no change of activity in the recording).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Final

import numpy as np
from scipy.signal import correlate, find_peaks

from sspinn.errors import UserError

#: Smallest overlap of the two signals for a lag to count, s.
MIN_OVERLAP_S: Final = 5.0
#: The activity correlation enters the score only if it peaks at least this high somewhere.
ACTIVITY_MIN_CORRELATION: Final = 0.7
#: Half-width of the impact refinement around each loading candidate, s.
IMPACT_WINDOW_S: Final = 0.15


class AlignmentError(UserError):
    """The two streams cannot be aligned (too short, no overlap, flat signals)."""


@dataclass(frozen=True)
class Candidate:
    """One candidate lag (s) with the correlations of the three pairs there and their sum."""

    lag_s: float
    activity: float
    loading: float
    impact: float
    use_activity: bool = True

    @property
    def score(self) -> float:
        """Sum of the correlations (the activity one only when it is informative)."""
        return (self.activity if self.use_activity else 0.0) + self.loading + self.impact


@dataclass(frozen=True)
class Alignment:
    """The result of :func:`align_to_grf`: ``lag_s`` (t_reference = t_imu + lag_s), the chosen
    candidate, the runner-up (None if there is none), the candidates by score, and the pairs."""

    lag_s: float
    best: Candidate
    runner_up: Candidate | None
    candidates: tuple[Candidate, ...]
    pairs: dict[str, str]
    notes: tuple[str, ...] = ()

    @property
    def ratio(self) -> float:
        """Score of the best candidate / score of the runner-up (inf without a positive runner-up)."""
        r = self.runner_up.score if self.runner_up is not None else 0.0
        return self.best.score / r if r > 0 else float("inf")

    def describe(self) -> str:
        b, r = self.best, self.runner_up
        text = (f"lag {self.lag_s:+.2f} s (t_GRF = t_IMU + lag): correlations activity {b.activity:.3f}, loading "
                f"{b.loading:.3f}, impact {b.impact:.3f} (score {b.score:.3f})")
        if r is not None:
            text += f"; runner-up {r.lag_s:+.2f} s (score {r.score:.3f}, ratio {self.ratio:.3f})"
        return text

    def to_dict(self) -> dict:
        def cand(c: Candidate) -> dict:
            return {"lag_s": round(c.lag_s, 4), "activity": round(c.activity, 4), "loading": round(c.loading, 4),
                    "impact": round(c.impact, 4), "activity_in_score": c.use_activity, "score": round(c.score, 4)}

        return {"lag_s": round(self.lag_s, 4), "convention": "t_reference = t_imu + lag_s", "best": cand(self.best),
                "runner_up": cand(self.runner_up) if self.runner_up else None,
                "ratio": round(self.ratio, 4) if np.isfinite(self.ratio) else None,
                "candidates": [cand(c) for c in self.candidates[:5]], "pairs": self.pairs, "notes": list(self.notes)}


def normalized_xcorr(reference: np.ndarray, signal: np.ndarray, max_lag: int, min_overlap: int) -> tuple[np.ndarray, np.ndarray]:
    """(lags (samples), Pearson correlation over the overlap) of ``signal[i]`` with
    ``reference[i + lag]`` for |lag| ≤ ``max_lag``; NaN where the overlap is below ``min_overlap``."""
    ref, sig = np.asarray(reference, float), np.asarray(signal, float)
    n, m = len(ref), len(sig)
    full = correlate(ref, sig, mode="full", method="fft")  # index k + m - 1: Σ_i ref[i + k]·sig[i]
    cs = np.concatenate([[0.0], np.cumsum(sig)])
    cs2 = np.concatenate([[0.0], np.cumsum(sig**2)])
    cr = np.concatenate([[0.0], np.cumsum(ref)])
    cr2 = np.concatenate([[0.0], np.cumsum(ref**2)])
    lags = np.arange(-max_lag, max_lag + 1)
    a0 = np.maximum(0, -lags)
    a1 = np.minimum(m, n - lags)
    count = a1 - a0
    out = np.full(len(lags), np.nan)
    ok = count >= max(min_overlap, 2)
    a0, a1, lg, c = a0[ok], a1[ok], lags[ok], count[ok].astype(float)
    sxy = full[lg + m - 1]
    sx, sx2 = cs[a1] - cs[a0], cs2[a1] - cs2[a0]
    sy, sy2 = cr[a1 + lg] - cr[a0 + lg], cr2[a1 + lg] - cr2[a0 + lg]
    cov = sxy - sx * sy / c
    var = (sx2 - sx**2 / c) * (sy2 - sy**2 / c)
    out[ok] = np.where(var > 1e-12 * np.maximum(sx2 * sy2, 1e-300), cov / np.sqrt(np.maximum(var, 1e-300)), np.nan)
    return lags, out


def _smooth(x: np.ndarray, n: int) -> np.ndarray:
    n = max(1, int(n))
    return np.convolve(x, np.ones(n) / n, mode="same")


def _zscore(x: np.ndarray, what: str) -> np.ndarray:
    sd = float(np.std(x))
    if not np.isfinite(sd) or sd == 0:
        raise AlignmentError(f"{what} is constant: nothing to align")
    return (x - x.mean()) / sd


def align_to_grf(
    stillness: dict[str, np.ndarray],
    impact: dict[str, np.ndarray],
    grf_vertical: dict[str, np.ndarray],
    activity: np.ndarray,
    stride_period_s: float,
    rate_hz: float = 100.0,
    max_lag_s: float = 30.0,
    names: tuple[str, str] = ("foot", "shank"),
) -> Alignment:
    """Align an IMU stream to force-plate or treadmill GRF (module docstring).

    Args:
        stillness: side (``"r"``/``"l"``) → |ω| (n,) rad/s of that side's foot (or shank) sensor.
        impact: side → specific force (n, 3) m/s² of that side's shank (or foot) sensor, any frame.
        grf_vertical: side → vertical force (m,) N under that foot, on the reference clock.
        activity: (n,) summed |ω| of all sensors, rad/s.
        stride_period_s: the stride period, s.
        rate_hz: the common sample rate, Hz.
        max_lag_s: the largest |lag| searched, s.
        names: the segments of ``stillness`` and ``impact``, for the report.
    """
    sides = [s for s in ("r", "l") if s in stillness and s in grf_vertical]
    if not sides:
        raise AlignmentError("no side with both an IMU and a vertical GRF")
    max_lag, overlap = int(max_lag_s * rate_hz), int(MIN_OVERLAP_S * rate_hz)
    stride = max(int(round(stride_period_s * rate_hz)), 4)
    load = grf_vertical[sides[0]] if len(sides) == 1 else np.abs(grf_vertical["r"] - grf_vertical["l"])
    lags, c_activity = normalized_xcorr(_zscore(_smooth(load, 2 * stride), "the GRF activity envelope"),
                                        _zscore(_smooth(activity, 2 * stride), "the IMU activity envelope"), max_lag, overlap)
    c_loading = sum(normalized_xcorr(_zscore(grf_vertical[s], f"the vertical GRF of side {s}"),
                                     _zscore(-_smooth(stillness[s], round(0.09 * rate_hz)), f"the {names[0]}_{s} rate"),
                                     max_lag, overlap)[1] for s in sides) / len(sides)
    hit = [s for s in sides if s in impact]
    c_impact = np.zeros(len(lags))
    if hit:
        c_impact = sum(normalized_xcorr(
            _zscore(_smooth(np.maximum(np.diff(grf_vertical[s], prepend=grf_vertical[s][0]), 0), 3), f"the vertical GRF rise of side {s}"),
            _zscore(_smooth(np.linalg.norm(np.diff(impact[s], axis=0, prepend=impact[s][:1]), axis=1), 3), f"the {names[1]}_{s} jerk"),
            max_lag, overlap)[1] for s in hit) / len(hit)
    valid = np.isfinite(c_activity) & np.isfinite(c_loading) & np.isfinite(c_impact)
    if not valid.any():
        raise AlignmentError(f"the IMU and GRF signals overlap by less than {MIN_OVERLAP_S:g} s at every lag searched")
    notes = []
    informative = bool(np.nanmax(np.where(valid, c_activity, np.nan)) >= ACTIVITY_MIN_CORRELATION)
    if not informative:
        notes.append(f"the activity envelopes correlate at most {np.nanmax(np.where(valid, c_activity, np.nan)):.2f} (no clear "
                     "change of activity in the recording): not used in the score")
    peaks, _ = find_peaks(np.where(valid, c_loading, -2.0), distance=max(1, stride // 4))
    if len(peaks) == 0:
        peaks = np.array([int(np.argmax(np.where(valid, c_loading, -2.0)))])
    window = int(IMPACT_WINDOW_S * rate_hz)
    candidates = []
    for p in peaks:
        lo, hi = max(0, p - window), min(len(lags), p + window + 1)
        near = np.where(valid[lo:hi], c_impact[lo:hi], -np.inf)
        k = lo + int(np.argmax(near)) if hit and np.isfinite(near).any() else p
        candidates.append(Candidate(lags[k] / rate_hz, float(c_activity[k]), float(c_loading[p]), float(c_impact[k]), informative))
    candidates.sort(key=lambda c: c.score, reverse=True)
    best = candidates[0]
    runner = next((c for c in candidates[1:] if abs(c.lag_s - best.lag_s) > stride / 4 / rate_hz), None)
    if runner is not None and runner.score > 0 and best.score / runner.score < 1.05:
        notes.append(f"the runner-up {runner.lag_s:+.2f} s scores within 5 % of the chosen lag: the alignment may be off by "
                     "whole strides (no change of activity in the recording?)")
    pairs = {"activity": "summed IMU rate norms vs |F_r − F_l| (2-stride means)",
             "loading": f"vertical GRF vs {names[0]} stillness −|ω|",
             "impact": f"{names[1]} jerk |Δacc| vs rise of the vertical GRF" if hit else "none"}
    return Alignment(best.lag_s, best, runner, tuple(candidates), pairs, tuple(notes))


def walking_direction_sign(fx: np.ndarray, fy: np.ndarray, rate_hz: float = 100.0) -> int:
    """+1 if the force plate's x axis points in the walking direction, else −1: in each stance
    (vertical force above 20 % of its 95th percentile, at least 0.2 s) the horizontal force of
    the last 40 % (propulsion) minus that of the first 40 % (braking) is positive along the walking
    direction; the median over stances decides."""
    loaded = fy > 0.2 * np.percentile(fy, 95)
    edges = np.diff(np.concatenate([[0], loaded.astype(np.int8), [0]]))
    diffs = []
    for a, b in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)):
        if b - a < 0.2 * rate_hz:
            continue
        k = int(0.4 * (b - a))
        diffs.append(fx[b - k:b].mean() - fx[a:a + k].mean())
    if not diffs:
        raise AlignmentError("no stance phase in the GRF (vertical force never loaded for 0.2 s)")
    return 1 if float(np.median(diffs)) >= 0 else -1
