"""Time alignment of an IMU stream with a force reference recorded on another clock, by
cross-correlating physically linked signals (both on one 100 Hz grid, times counted from the
start of each stream).

Three physically linked pairs, from coarse to fine (:func:`align_to_grf`):

1. **activity** (which stride): the IMU's summed rate norms against the GRF's left–right load
   difference |F_r − F_l|, both averaged over two strides; one clear peak when the recording
   holds a change of activity (quiet standing, the start or end of walking). Trusted when its
   correlation is at least :data:`COARSE_MIN_CORRELATION` and its ratio to the runner-up at
   least :data:`COARSE_MIN_RATIO`; otherwise the next stage searches all lags.
2. **loading** (within the stride): each foot's vertical GRF against the stillness of that
   side's foot (or shank) sensor, ``−|ω|`` smoothed over 0.09 s (a foot in stance hardly turns),
   both sides averaged; searched within half a stride of stage 1. Walking is periodic, so this
   correlation has nearly equal peaks one stride apart (ratio ≈ 1.02); and it is biased by the
   shapes (the foot still turns just after heel strike): tens of ms.
3. **impact** (to the sample): the norm of the shank's (or foot's) specific-force change per
   sample (3D jerk, sharp at heel strike) against the positive rate of rise of that foot's
   vertical force, searched within :data:`IMPACT_WINDOW_S` of stage 2.

Returned (:class:`Alignment`): the lag ``lag_s`` of the last stage with
**t_reference = t_imu + lag_s**, and per stage the lag, the peak correlation and the best
correlation at a lag more than a quarter stride away (the runner-up) with their ratio.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Final

import numpy as np
from scipy.signal import correlate, find_peaks

from sspinn.errors import UserError

#: Smallest overlap of the two signals for a lag to count, s.
MIN_OVERLAP_S: Final = 5.0
#: The activity stage is trusted from this correlation and this ratio to its runner-up.
COARSE_MIN_CORRELATION: Final = 0.7
COARSE_MIN_RATIO: Final = 2.0
#: Half-width of the impact stage's search around the loading stage's lag, s.
IMPACT_WINDOW_S: Final = 0.15


class AlignmentError(UserError):
    """The two streams cannot be aligned (too short, no overlap, flat signals)."""


@dataclass(frozen=True)
class Stage:
    """One stage of :func:`align_to_grf`: its best lag (s), peak correlation, runner-up (a lag
    more than a quarter stride away, NaN if none in the searched range) and what it compared."""

    name: str
    lag_s: float
    correlation: float
    runner_up_lag_s: float
    runner_up_correlation: float
    pair: str
    searched: str

    @property
    def ratio(self) -> float:
        """Peak / runner-up correlation (NaN without a runner-up)."""
        r = self.runner_up_correlation
        return self.correlation / r if np.isfinite(r) and r > 0 else float("nan")


@dataclass(frozen=True)
class Alignment:
    """The result of :func:`align_to_grf`: ``lag_s`` (t_reference = t_imu + lag_s) and the stages."""

    lag_s: float
    stages: tuple[Stage, ...]
    notes: tuple[str, ...] = ()

    def stage(self, name: str) -> Stage:
        return next(s for s in self.stages if s.name == name)

    def describe(self) -> str:
        parts = [f"{s.name} {s.lag_s:+.2f} s (r = {s.correlation:.3f}"
                 + (f", runner-up {s.runner_up_correlation:.3f} at {s.runner_up_lag_s:+.2f} s, ratio {s.ratio:.3f})"
                    if np.isfinite(s.runner_up_correlation) else ")") for s in self.stages]
        return f"lag {self.lag_s:+.2f} s (t_GRF = t_IMU + lag); " + "; ".join(parts)

    def to_dict(self) -> dict:
        def num(v: float) -> float | None:
            return round(float(v), 4) if np.isfinite(v) else None

        return {"lag_s": num(self.lag_s), "convention": "t_reference = t_imu + lag_s", "notes": list(self.notes),
                "stages": [{"name": s.name, "lag_s": num(s.lag_s), "correlation": num(s.correlation),
                            "runner_up_lag_s": num(s.runner_up_lag_s), "runner_up_correlation": num(s.runner_up_correlation),
                            "ratio": num(s.ratio), "pair": s.pair, "searched": s.searched} for s in self.stages]}


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


def _stage(name: str, lags: np.ndarray, c: np.ndarray, allowed: np.ndarray, exclusion: int, rate_hz: float, pair: str,
           searched: str) -> Stage:
    """The best lag of ``c`` among ``allowed`` lags and the best local maximum (of all lags) more
    than ``exclusion`` samples from it."""
    values = np.where(allowed, np.nan_to_num(c, nan=-np.inf), -np.inf)
    if not np.isfinite(values).any():
        raise AlignmentError(f"{name} stage: the signals do not overlap by {MIN_OVERLAP_S:g} s at any lag searched")
    k = int(np.argmax(values))
    peaks, _ = find_peaks(np.nan_to_num(c, nan=-2.0))
    others = [p for p in peaks if abs(int(lags[p]) - int(lags[k])) > exclusion and np.isfinite(c[p])]
    j = max(others, key=lambda p: c[p]) if others else None
    return Stage(name, lags[k] / rate_hz, float(c[k]), lags[j] / rate_hz if j is not None else float("nan"),
                 float(c[j]) if j is not None else float("nan"), pair, searched)


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
    stride = max(int(round(stride_period_s * rate_hz)), 2)
    notes = []
    load = grf_vertical[sides[0]] if len(sides) == 1 else np.abs(grf_vertical["r"] - grf_vertical["l"])
    lags, c = normalized_xcorr(_zscore(_smooth(load, 2 * stride), "the GRF activity envelope"),
                               _zscore(_smooth(activity, 2 * stride), "the IMU activity envelope"), max_lag, overlap)
    everywhere = np.ones(len(lags), dtype=bool)
    coarse = _stage("activity", lags, c, everywhere, stride // 2, rate_hz, "summed IMU rate norms vs |F_r − F_l| (2-stride means)",
                    f"±{max_lag_s:g} s")
    trusted = coarse.correlation >= COARSE_MIN_CORRELATION and not coarse.ratio < COARSE_MIN_RATIO
    if not trusted:
        notes.append(f"activity stage not trusted (r = {coarse.correlation:.2f}, ratio {coarse.ratio:.2f}): the loading stage "
                     "searched all lags, so the lag may be off by whole strides")
    fine = sum(normalized_xcorr(_zscore(grf_vertical[s], f"the vertical GRF of side {s}"),
                                _zscore(-_smooth(stillness[s], round(0.09 * rate_hz)), f"the {names[0]}_{s} rate"),
                                max_lag, overlap)[1] for s in sides) / len(sides)
    centre = int(round(coarse.lag_s * rate_hz))
    window = np.abs(lags - centre) <= stride // 2 if trusted else everywhere
    loading = _stage("loading", lags, fine, window, stride // 4, rate_hz, f"vertical GRF vs {names[0]} stillness −|ω|",
                     f"±{stride / 2 / rate_hz:.2f} s around the activity lag" if trusted else f"±{max_lag_s:g} s")
    stages = [coarse, loading]
    impact_sides = [s for s in sides if s in impact]
    if impact_sides:
        jerk = sum(normalized_xcorr(_zscore(_smooth(np.maximum(np.diff(grf_vertical[s], prepend=grf_vertical[s][0]), 0), 3),
                                            f"the vertical GRF rise of side {s}"),
                                    _zscore(_smooth(np.linalg.norm(np.diff(impact[s], axis=0, prepend=impact[s][:1]), axis=1), 3),
                                            f"the {names[1]}_{s} jerk"), max_lag, overlap)[1] for s in impact_sides) / len(impact_sides)
        near = np.abs(lags - int(round(loading.lag_s * rate_hz))) <= int(IMPACT_WINDOW_S * rate_hz)
        stages.append(_stage("impact", lags, jerk, near, stride // 4, rate_hz,
                             f"{names[1]} jerk |Δacc| vs rise of the vertical GRF", f"±{IMPACT_WINDOW_S:g} s around the loading lag"))
    return Alignment(stages[-1].lag_s, tuple(stages), tuple(notes))


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
