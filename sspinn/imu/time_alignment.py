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
candidate (usually one stride away) with the ratio of the scores — below
:data:`AMBIGUOUS_RATIO` a **warning** names both lags (the alignment may be off by whole strides:
no change of activity in the recording).

Three more checks of the force file against the IMUs, each a warning naming the lags:

* **channels offset**: each foot's own lag (its loading peak within half a stride of the chosen
  lag, refined to its impact peak) — further apart than :data:`SIDE_LAG_TOLERANCE_S`, the right
  and left channels are offset in time;
* **sides swapped**: the alignment is repeated with the force channels' sides exchanged (each
  foot's stillness against the other foot's force); scoring more than
  :data:`SWAPPED_SIDES_RATIO` times the labelled sides' score, the sides look swapped (in the GRF
  file or in the sensor map). A symmetric gait looks alike swapped and half a stride later: what
  tells them apart is the activity pair (a change of activity pins the lag) and asymmetries of
  the gait, so without a change of activity the check is weak.
* **lag jumps**: the lag of every :data:`LOCAL_WINDOW_S` window of the IMU stream (every
  :data:`LOCAL_STEP_S`; loading and impact pairs within half a stride of the chosen lag) against
  their median — windows further from it than :data:`LAG_JUMP_TOLERANCE_S` mean that one file's
  clock jumps (samples dropped or inserted without their time stamps): the labels there are off.
  The spans are returned (``lag_jumps``) so that they can be left out; a jump by a whole number of
  strides cannot be seen this way.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Final

import numpy as np
from scipy.signal import correlate, find_peaks

from sspinn.data.gait_events import true_runs
from sspinn.errors import UserError

#: Smallest overlap of the two signals for a lag to count, s.
MIN_OVERLAP_S: Final = 5.0
#: The activity correlation enters the score only if it peaks at least this high somewhere.
ACTIVITY_MIN_CORRELATION: Final = 0.7
#: Half-width of the impact refinement around each loading candidate, s.
IMPACT_WINDOW_S: Final = 0.15
#: A lag whose score is less than this many times the runner-up's (a candidate at least a
#: quarter stride away) is ambiguous: a warning naming both lags. The twelve CMU trials score
#: 1.02–1.36 (two below it, both Sub05).
AMBIGUOUS_RATIO: Final = 1.05
#: Each foot's own lag (its loading peak within half a stride of the chosen lag, refined to its
#: impact peak) further from the other foot's than this is a warning (force channels offset in
#: time), s. The twelve CMU trials (whole, and their first 10 s and 20 s): 0.00–0.05 s apart;
#: with the left channel delayed by 0.15 s: 0.10–0.18 s.
SIDE_LAG_TOLERANCE_S: Final = 0.08
#: Aligned with the force channels' sides exchanged, a score more than this many times the
#: labelled sides' is a warning (sides swapped between the GRF file and the IMUs). The twelve
#: CMU trials, exchanged / labelled score — as recorded: 0.77–0.95 in eleven and 1.02 in Sub05
#: CSBaseline (first 10 s: at most 0.99; 20 s: 1.01); sides exchanged on purpose: 1.06–1.31 in
#: eleven (first 10 s: 1.05–1.27; 20 s: 1.04–1.25) and 0.98 in Sub05 CSBaseline, whose lag is
#: ambiguous (not caught).
SWAPPED_SIDES_RATIO: Final = 1.03
#: Length and spacing of the windows of the lag-jump check, s.
LOCAL_WINDOW_S: Final = 10.0
LOCAL_STEP_S: Final = 2.5
#: A window whose own lag is further than this from the windows' median lag is a lag jump, s. The
#: twelve CMU trials: within 0.07 s of their median everywhere but in Sub06 CSStiffKnee, whose GRF
#: runs 0.16–0.17 s later from about 50 s on (its heel strikes against the shank's impacts: 30 ms
#: after them until 52.8 s, 120–150 ms before them from 53.1 s).
LAG_JUMP_TOLERANCE_S: Final = 0.1


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
    candidate, the runner-up (None if there is none), the candidates by score, the pairs, notes,
    each foot's own lag (s), the warnings (ambiguous lag, channels offset, sides swapped, lag
    jumps; one line each), the score with the force channels' sides exchanged (None if not
    checked) and the lag jumps: (start, stop) IMU samples where the lag differs from the chosen
    one, and by how much (s)."""

    lag_s: float
    best: Candidate
    runner_up: Candidate | None
    candidates: tuple[Candidate, ...]
    pairs: dict[str, str]
    notes: tuple[str, ...] = ()
    side_lags: dict[str, float] = field(default_factory=dict)
    warnings: tuple[str, ...] = ()
    swapped_sides_score: float | None = None
    lag_jumps: tuple[tuple[int, int, float], ...] = ()

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
        if len(self.side_lags) == 2:
            text += f"; per foot r {self.side_lags['r']:+.2f} s, l {self.side_lags['l']:+.2f} s"
        return text

    def to_dict(self) -> dict:
        def cand(c: Candidate) -> dict:
            return {"lag_s": round(c.lag_s, 4), "activity": round(c.activity, 4), "loading": round(c.loading, 4),
                    "impact": round(c.impact, 4), "activity_in_score": c.use_activity, "score": round(c.score, 4)}

        return {"lag_s": round(self.lag_s, 4), "convention": "t_reference = t_imu + lag_s", "best": cand(self.best),
                "runner_up": cand(self.runner_up) if self.runner_up else None,
                "ratio": round(self.ratio, 4) if np.isfinite(self.ratio) else None,
                "side_lags_s": {s: round(v, 4) for s, v in self.side_lags.items()},
                "swapped_sides_score": None if self.swapped_sides_score is None else round(self.swapped_sides_score, 4),
                "lag_jumps": [[a, b, round(d, 3)] for a, b, d in self.lag_jumps],
                "candidates": [cand(c) for c in self.candidates[:5]], "pairs": self.pairs, "notes": list(self.notes),
                "warnings": list(self.warnings)}


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
    check_sides: bool = True,
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
        check_sides: with both sides, also align with the force channels' sides exchanged and
            warn when that scores more than :data:`SWAPPED_SIDES_RATIO` times higher.
    """
    sides = [s for s in ("r", "l") if s in stillness and s in grf_vertical]
    if not sides:
        raise AlignmentError("no side with both an IMU and a vertical GRF")
    max_lag, overlap = int(max_lag_s * rate_hz), int(MIN_OVERLAP_S * rate_hz)
    stride = max(int(round(stride_period_s * rate_hz)), 4)
    load = grf_vertical[sides[0]] if len(sides) == 1 else np.abs(grf_vertical["r"] - grf_vertical["l"])
    lags, c_activity = normalized_xcorr(_zscore(_smooth(load, 2 * stride), "the GRF activity envelope"),
                                        _zscore(_smooth(activity, 2 * stride), "the IMU activity envelope"), max_lag, overlap)
    loading_pairs, impact_pairs = event_signals(stillness, impact, grf_vertical, rate_hz)
    loading_by_side = {s: normalized_xcorr(_zscore(ref, f"the vertical GRF of side {s}"),
                                           _zscore(imu, f"the {names[0]}_{s} rate"), max_lag, overlap)[1]
                       for s, (ref, imu) in loading_pairs.items()}
    c_loading = sum(loading_by_side.values()) / len(sides)
    hit = list(impact_pairs)
    impact_by_side = {s: normalized_xcorr(_zscore(ref, f"the vertical GRF rise of side {s}"),
                                          _zscore(imu, f"the {names[1]}_{s} jerk"), max_lag, overlap)[1]
                      for s, (ref, imu) in impact_pairs.items()}
    c_impact = sum(impact_by_side.values()) / len(hit) if hit else np.zeros(len(lags))
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
    k_best = int(np.flatnonzero(lags == int(round(best.lag_s * rate_hz)))[0])
    side_lags = {}
    for s in sides:  # each foot's own lag within half a stride of the chosen one (loading peak, refined to its impact peak)
        lo, hi = max(0, k_best - stride // 2), min(len(lags), k_best + stride // 2 + 1)
        p = lo + int(np.argmax(np.where(valid[lo:hi], loading_by_side[s][lo:hi], -np.inf)))
        k = p
        if s in impact_by_side:
            a, b = max(0, p - window), min(len(lags), p + window + 1)
            near = np.where(valid[a:b], impact_by_side[s][a:b], -np.inf)
            k = a + int(np.argmax(near)) if np.isfinite(near).any() else p
        side_lags[s] = float(lags[k] / rate_hz)
    runner = next((c for c in candidates[1:] if abs(c.lag_s - best.lag_s) > stride / 4 / rate_hz), None)
    warnings = []
    if runner is not None and runner.score > 0 and best.score / runner.score < AMBIGUOUS_RATIO:
        warnings.append(
            f"the time alignment is ambiguous: lags {best.lag_s:+.2f} s (score {best.score:.3f}, used) and {runner.lag_s:+.2f} s "
            f"(score {runner.score:.3f}) score within a ratio of {best.score / runner.score:.3f} (below {AMBIGUOUS_RATIO}): the GRF "
            "labels may be off by whole strides; import a part with quiet standing or the start or end of walking, or check the lag")
    if len(side_lags) == 2 and abs(side_lags["r"] - side_lags["l"]) > SIDE_LAG_TOLERANCE_S + 1e-9:
        warnings.append(
            f"the right and left force channels look offset in time: the right foot's stance aligns at lag {side_lags['r']:+.2f} s, "
            f"the left at {side_lags['l']:+.2f} s (more than {SIDE_LAG_TOLERANCE_S:g} s apart); the labels use {best.lag_s:+.2f} s "
            "for both: check the GRF file's channels")
    jumps = (lag_jumps([*loading_pairs.values(), *impact_pairs.values()], k_best - max_lag, stride, rate_hz)
             if check_sides else [])  # not again for the exchanged sides
    for a, b, d in jumps:
        warnings.append(
            f"the lag between the IMU and the GRF jumps: from {a / rate_hz:.1f} to {b / rate_hz:.1f} s (IMU time) the GRF fits "
            f"{d:+.2f} s away from the lag used ({best.lag_s:+.2f} s), more than {LAG_JUMP_TOLERANCE_S:g} s: one file's clock jumps "
            "(samples dropped or inserted); the GRF labels there are off (kept; listed as grf_misaligned_s): crop the "
            "recording (--start/--end) or fix the files")
    pairs = {"activity": "summed IMU rate norms vs |F_r − F_l| (2-stride means)",
             "loading": f"vertical GRF vs {names[0]} stillness −|ω|",
             "impact": f"{names[1]} jerk |Δacc| vs rise of the vertical GRF" if hit else "none"}
    result = Alignment(best.lag_s, best, runner, tuple(candidates), pairs, tuple(notes), side_lags, tuple(warnings),
                       lag_jumps=tuple(jumps))
    if not check_sides or len(sides) < 2:
        return result
    swapped = align_to_grf(stillness, impact, {"r": grf_vertical["l"], "l": grf_vertical["r"]}, activity, stride_period_s,
                           rate_hz, max_lag_s, names, check_sides=False)
    ratio = swapped.best.score / best.score if best.score > 0 else float("inf")
    text = (f"with the force channels' sides exchanged the alignment scores {swapped.best.score:.3f} at lag {swapped.lag_s:+.2f} s "
            f"(loading {swapped.best.loading:.3f}: each {names[0]}'s stillness against the other foot's force), as labelled "
            f"{best.score:.3f} at {best.lag_s:+.2f} s (loading {best.loading:.3f}); ratio {ratio:.3f}")
    if ratio > SWAPPED_SIDES_RATIO:
        warnings.append(f"right and left look swapped between the GRF file and the IMUs: {text} (above {SWAPPED_SIDES_RATIO}); "
                        "check the GRF file's r/l columns and the sensor map's sides")
    else:
        notes.append(f"side check: {text}")
    return dataclasses.replace(result, notes=tuple(notes), warnings=tuple(warnings), swapped_sides_score=swapped.best.score)


def event_signals(stillness: dict[str, np.ndarray], impact: dict[str, np.ndarray], grf_vertical: dict[str, np.ndarray],
                  rate_hz: float = 100.0) -> tuple[dict[str, tuple[np.ndarray, np.ndarray]], dict[str, tuple[np.ndarray, np.ndarray]]]:
    """The (GRF, IMU) signal pairs the alignment correlates, per side with both (arguments as in
    :func:`align_to_grf`): "loading", the vertical force against the foot's stillness −|ω|
    (smoothed over 0.09 s); "impact", the force's rise against the impact sensor's jerk |Δacc|
    (smoothed over 3 samples), for the sides with an impact sensor."""
    sides = [s for s in ("r", "l") if s in stillness and s in grf_vertical]
    loading = {s: (grf_vertical[s], -_smooth(stillness[s], round(0.09 * rate_hz))) for s in sides}
    hits = {s: (_smooth(np.maximum(np.diff(grf_vertical[s], prepend=grf_vertical[s][0]), 0), 3),
                _smooth(np.linalg.norm(np.diff(impact[s], axis=0, prepend=impact[s][:1]), axis=1), 3))
            for s in sides if s in impact}
    return loading, hits


def lag_jumps(pairs: Sequence[tuple[np.ndarray, np.ndarray]], lag: int, stride: int,
              rate_hz: float = 100.0) -> list[tuple[int, int, float]]:
    """The spans (start, stop IMU samples, offset s) whose lag differs from the others' (module
    docstring, "lag jumps"), from the (GRF, IMU) signal ``pairs`` of :func:`event_signals`;
    ``lag`` is the chosen lag and ``stride`` the stride period, in samples."""
    if not pairs:
        return []
    n = min(len(imu) for _, imu in pairs)
    window, step, half = int(LOCAL_WINDOW_S * rate_hz), int(LOCAL_STEP_S * rate_hz), max(1, stride // 2)
    if n < window + step:
        return []
    starts = np.arange(0, n - window + 1, step)
    shifts = np.arange(lag - half, lag + half + 1)
    local = np.full(len(starts), np.nan)
    for w, a in enumerate(starts):
        # the window x = imu[a:a + window] against ref[a + shift:...]: normalized_xcorr's lag a + shift,
        # NaN where ref does not hold the whole window
        reach = int(max(abs(a + shifts[0]), abs(a + shifts[-1])))
        score = sum(normalized_xcorr(ref, imu[a:a + window], reach, window)[1][a + shifts + reach] for ref, imu in pairs)
        if np.isfinite(score).any():
            local[w] = shifts[int(np.nanargmax(score))]
    if not np.isfinite(local).any():
        return []
    offset = (local - np.nanmedian(local)) / rate_hz
    off = np.abs(np.nan_to_num(offset)) > LAG_JUMP_TOLERANCE_S
    spans = []
    for i, j in true_runs(off):
        a = 0 if i == 0 else int(starts[i] + window // 2 - step // 2)
        b = n if j == len(starts) else int(starts[j - 1] + window // 2 + step // 2)
        spans.append((a, b, float(np.median(offset[i:j]))))
    return spans


def walking_direction_sign(fx: np.ndarray, fy: np.ndarray, rate_hz: float = 100.0) -> int:
    """+1 if the force plate's x axis points in the walking direction, else −1: in each stance
    (vertical force above 20 % of its 95th percentile, at least 0.2 s) the horizontal force of
    the last 40 % (propulsion) minus that of the first 40 % (braking) is positive along the walking
    direction; the median over stances decides."""
    loaded = fy > 0.2 * np.percentile(fy, 95)
    diffs = []
    for a, b in true_runs(loaded):
        if b - a < 0.2 * rate_hz:
            continue
        k = int(0.4 * (b - a))
        diffs.append(fx[b - k:b].mean() - fx[a:a + k].mean())
    if not diffs:
        raise AlignmentError("no stance phase in the GRF (vertical force never loaded for 0.2 s)")
    return 1 if float(np.median(diffs)) >= 0 else -1
