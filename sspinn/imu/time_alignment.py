"""Time alignment of an IMU stream with a force reference (treadmill or force-plate GRF), by
cross-correlating physically linked signals (both on one 100 Hz grid, times counted from the
start of each stream), with **t_reference = t_imu + lag_s**.

Three physically linked pairs (:func:`align_to_grf`):

* **activity**: the IMU's summed rate norms against the GRF's left–right load difference
  |F_r − F_l|, both averaged over two strides — one broad peak where the recordings' changes of
  activity (quiet standing, the start or end of walking) coincide; it is the same with the
  force channels' sides exchanged;
* **loading**: each foot's vertical GRF against the stillness of that side's foot (or shank)
  sensor, ``−|ω|`` smoothed over 0.09 s (a foot in stance hardly turns), both sides averaged —
  peaks one stride apart (walking is periodic), biased by the shapes by up to ≈ 0.14 s (the foot
  still turns just after heel strike);
* **impact**: the norm of the shank's (or foot's) specific-force change per sample (3D jerk,
  sharp at heel strike) against the positive rate of rise of that foot's vertical force — sharp,
  but weaker and also one stride periodic.

**The clock.** Where the two files share a clock — they start together and last equally long
(:func:`files_share_clock`), or the user says so — that clock's lag (``clock_lag_s``) is kept
unless the evidence against it is decisive: a candidate beyond the lag window scores at least
:data:`CLOCK_OVERRULE_RATIO` times the best fit inside it, or both feet's own lags lie further
than :data:`CLOCK_TOLERANCE_S` from the clock on the same side. The correlations' own biases
(tens of ms, different per foot) then do not move the labels. ``Alignment.clock`` says which
was used: ``"files"`` / ``"given"`` (the shared clock kept), ``"overruled"`` (a warning says
why) or ``"search"`` (no shared clock).

**The lag window.** Every fit is the best within ±:data:`LAG_WINDOW_STRIDES` of a stride around
a centre (the clock's lag; without a clock, each candidate: a local maximum of the loading
correlation): the loading peak there, refined to the impact peak within
:data:`IMPACT_WINDOW_S`, scored by the sum of the three correlations (the activity one only
when it peaks above :data:`ACTIVITY_MIN_CORRELATION` somewhere: otherwise the recording holds
no change of activity and it is noise). Why a quarter of a stride: with the sides swapped, each
foot's force matches the other foot's IMU half a stride later (the left foot does half a stride
after the right what the right did), so the swapped assignment has a good fit half a stride
from the true lag. A window of ±¼ stride holds the true lag or its half-stride alias, never both
(the border aside), so **both assignments are scored at every candidate lag** in the same window
and compared fairly: the exchanged assignment fitting better (its loading + impact correlations
above the labelled ones' at their best lags in the window, :data:`SWAPPED_SIDES_RATIO`; by
:data:`BORDER_SIDES_RATIO` where its best lies on the window's border, :data:`BORDER_SAMPLES`,
and may be the flank of a peak beyond it) is the "sides look swapped" warning. A wider window lets the half-stride alias of a swap win (what an
unbounded search did: a lag of half a stride that makes swapped sides line up), a narrower one
cuts into the correlations' own biases (up to 0.14 s of the loading peak, 0.07 s of the
impact peak on the CMU trials, against a quarter stride of 0.26–0.34 s there).

Without a shared clock the centre is the best candidate over all lags; the runner-up (a
candidate at least a quarter stride away) with the ratio of the scores — below
:data:`AMBIGUOUS_RATIO` a **warning** names both lags (no change of activity in the recording:
the lag is known only up to whole strides). Then a swap also hides as half a stride of lag: the
exchanged assignment's best candidate over all lags scoring more than the labelled one's (by
:data:`SWAPPED_SIDES_RATIO`, whole scores) is warned as "sides swapped, or the lag off by half a
stride".

**Per foot** (``per_foot=True``; force plates on separate clocks): each foot's own lag (its
loading peak in the window, refined to its own impact peak) labels that foot's force;
``side_lags`` holds them always. Without it, feet further apart than
:data:`SIDE_LAG_TOLERANCE_S` are the **channels offset** warning.

**Lag jumps**: the lag of every :data:`LOCAL_WINDOW_S` window of the IMU stream (every
:data:`LOCAL_STEP_S`; loading and impact pairs within the lag window around the lag used)
against their median — windows further from it than :data:`LAG_JUMP_TOLERANCE_S` mean that one
file's clock jumps (samples dropped or inserted without their time stamps): the labels there are
off. The spans are returned (``lag_jumps``) so that they can be left out; a jump by a whole
number of strides cannot be seen this way.

The thresholds were set on CMU subjects Sub01–Sub04 only (Sub05 and Sub06 held out);
``benchmarks/accuracy/alignment_checks.py`` measures every warning's false alarms and detections on the
twelve CMU trials, as recorded and edited (docs/results/alignment.md).
"""

from __future__ import annotations

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
#: Half-width of the impact refinement around each loading peak, s.
IMPACT_WINDOW_S: Final = 0.15
#: Half-width of the lag window around a centre, in strides (module docstring: the half-stride
#: alias of swapped sides lies outside it).
LAG_WINDOW_STRIDES: Final = 0.25
#: Without a shared clock, a lag whose score is less than this many times the runner-up's (a
#: candidate at least a quarter stride away) is ambiguous: a warning naming both lags.
AMBIGUOUS_RATIO: Final = 1.05
#: Each foot's own lag further from the other foot's than this is a warning (force channels
#: offset in time), s. CMU Sub01–Sub04 as recorded: at most 0.03 s apart; with the left channel
#: 0.15 s late: 0.13–0.18 s (benchmarks/accuracy/alignment_checks.py).
SIDE_LAG_TOLERANCE_S: Final = 0.08
#: The exchanged assignment's (loading + impact) fit over the labelled one's above which the
#: sides look swapped: "fits better" (1.0) at the best lags in the lag window. CMU Sub01–Sub04 in
#: the window around the files' clock: 0.14–0.46 as recorded, 2.2–7.2 with the sides exchanged.
SWAPPED_SIDES_RATIO: Final = 1.0
#: A fit this close to its window's border (samples) may be the flank of a peak beyond it ...
BORDER_SAMPLES: Final = 2
#: ... so there the exchanged sides must fit this many times better than the labelled ones to
#: look swapped. CMU Sub01–Sub04 (benchmarks/accuracy/alignment_checks.py): as recorded or with one
#: channel 0.15 s late, fits on the border reached 1.06 (Sub02 CSStiffKnee, left late); the
#: sides exchanged with the truth 0.2 stride from the clock, 1.94 on the border (the others
#: inside the window, 1.12–1.94); 0.25 stride away (on the border itself), 0.97–1.56.
BORDER_SIDES_RATIO: Final = 1.12
#: Without a shared clock: the exchanged assignment's best whole score over all lags, over the
#: labelled one's, above which "sides swapped, or the lag off by half a stride" is warned (the
#: activity pair and the gait's asymmetries decide there; the old side check's bar, kept: CMU
#: as recorded 0.77–0.95 in eleven trials, 1.02 in Sub05 CSBaseline).
SWAPPED_GLOBAL_RATIO: Final = 1.03
#: A candidate beyond the lag window must score this many times the best fit in the window to
#: overrule a shared clock. CMU Sub01–Sub04: at most 0.95 (benchmarks/accuracy/alignment_checks.py).
CLOCK_OVERRULE_RATIO: Final = 1.25
#: ... and must overlap the IMU stream over at least this share of the clock's overlap (CMU
#: Sub05 CSStiffKnee with a GRF clock jump: a lag of −92 s sharing 20 of its 112 s fitted better).
OVERRULE_MIN_OVERLAP: Final = 0.5
#: Both feet's own lags further than this from a shared clock's lag, on the same side, overrule
#: it, s. CMU Sub01–Sub04: within 0.04 s of it.
CLOCK_TOLERANCE_S: Final = 0.1
#: Files whose first samples and durations agree within this share a clock, s.
SAME_CLOCK_TOLERANCE_S: Final = 0.02
#: Length and spacing of the windows of the lag-jump check, s.
LOCAL_WINDOW_S: Final = 10.0
LOCAL_STEP_S: Final = 2.5
#: A window whose own lag is further than this from the windows' median lag is a lag jump, s. The
#: twelve CMU trials: within 0.07 s of their median everywhere but in Sub06 CSStiffKnee, whose GRF
#: runs 0.16–0.17 s later from about 50 s on (its heel strikes against the shank's impacts: 30 ms
#: after them until 52.8 s, 120–150 ms before them from 53.1 s).
LAG_JUMP_TOLERANCE_S: Final = 0.1
#: How the lag was chosen (``Alignment.clock``).
CLOCK_SOURCES: Final = {"files": "the files' shared clock (same start and duration)", "given": "the shared clock (--same-clock)",
                        "overruled": "measured (the shared clock overruled)", "search": "measured (no shared clock)"}


class AlignmentError(UserError):
    """The two streams cannot be aligned (too short, no overlap, flat signals)."""


def files_share_clock(imu_start_s: float, imu_end_s: float, grf_start_s: float, grf_end_s: float,
                      tolerance_s: float = SAME_CLOCK_TOLERANCE_S) -> bool:
    """True if the IMU and GRF files start and end within ``tolerance_s`` of each other (times in
    each file's own seconds): the sign of one clock (or of files cropped together)."""
    return abs(imu_start_s - grf_start_s) <= tolerance_s and abs(imu_end_s - grf_end_s) <= tolerance_s


@dataclass(frozen=True)
class Candidate:
    """One lag (s) with the correlations of the three pairs there and their sum; ``sides``:
    ``"labelled"`` or ``"exchanged"`` (each foot's IMU against the other foot's force);
    ``at_border``: its lag lies on its window's border (a peak beyond the window)."""

    lag_s: float
    activity: float
    loading: float
    impact: float
    use_activity: bool = True
    sides: str = "labelled"
    at_border: bool = False

    @property
    def score(self) -> float:
        """Sum of the correlations (the activity one only when it is informative)."""
        return (self.activity if self.use_activity else 0.0) + self.loading + self.impact

    @property
    def events(self) -> float:
        """Loading + impact correlations: the part of the score that tells the feet apart."""
        return self.loading + self.impact


@dataclass(frozen=True)
class WindowFit:
    """Both side assignments' best fits within the lag window around ``centre_s`` (s);
    ``exchanged`` is None with one side."""

    centre_s: float
    labelled: Candidate
    exchanged: Candidate | None

    @property
    def looks_swapped(self) -> bool:
        """The exchanged sides fit better (:data:`SWAPPED_SIDES_RATIO`; on the window's border
        :data:`BORDER_SIDES_RATIO`)."""
        if self.exchanged is None:
            return False
        return self.sides_ratio > (BORDER_SIDES_RATIO if self.exchanged.at_border else SWAPPED_SIDES_RATIO)

    @property
    def sides_ratio(self) -> float:
        """Exchanged over labelled (loading + impact) fit; NaN with one side."""
        if self.exchanged is None:
            return float("nan")
        return self.exchanged.events / self.labelled.events if self.labelled.events > 0 else float("inf")


@dataclass(frozen=True)
class Alignment:
    """The result of :func:`align_to_grf`: ``lag_s`` (t_reference = t_imu + lag_s; with
    ``per_foot`` each foot's force is labelled with its own lag, ``label_lags``), ``best`` (the
    correlations at ``lag_s``), the runner-up beyond the window (None if there is none), the
    candidates by score, the pairs, notes, each foot's own lag (s), the warnings (one line each),
    the exchanged sides' score, the lag jumps ((start, stop) IMU samples where the lag differs
    from the chosen one, and by how much, s); ``clock`` (:data:`CLOCK_SOURCES`), the clock's lag
    (s, None without one), the lag measured in the window around it (s), the window's
    half-width (s), the fit of both side assignments at the lag used (``fit``) and at every
    candidate (``window_fits``)."""

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
    clock: str = "search"
    clock_lag_s: float | None = None
    measured_lag_s: float | None = None
    window_s: float = 0.0
    per_foot: bool = False
    fit: WindowFit | None = None
    window_fits: tuple[WindowFit, ...] = ()

    @property
    def ratio(self) -> float:
        """Score at the lag used / score of the runner-up (inf without a positive runner-up)."""
        r = self.runner_up.score if self.runner_up is not None else 0.0
        return self.best.score / r if r > 0 else float("inf")

    @property
    def label_lags(self) -> dict[str, float]:
        """The lag each foot's force is labelled with, s: its own with ``per_foot``, else ``lag_s``."""
        if self.per_foot and self.side_lags:
            return dict(self.side_lags)
        return {s: self.lag_s for s in ("r", "l")}

    def describe(self) -> str:
        b, r = self.best, self.runner_up
        text = (f"lag {self.lag_s:+.2f} s (t_GRF = t_IMU + lag; {CLOCK_SOURCES[self.clock]}): correlations activity "
                f"{b.activity:.3f}, loading {b.loading:.3f}, impact {b.impact:.3f} (score {b.score:.3f})")
        if self.measured_lag_s is not None and self.clock in ("files", "given"):
            text += f"; measured {self.measured_lag_s:+.2f} s within ±{self.window_s:.2f} s"
        if r is not None and self.clock in ("files", "given") and self.fit is not None:
            inside = max(self.fit.labelled.score, self.fit.exchanged.score if self.fit.exchanged else -np.inf)
            text += (f"; best beyond the window {r.lag_s:+.2f} s (score {r.score:.3f}, {r.score / inside:.2f} × the window's best; "
                     f"{CLOCK_OVERRULE_RATIO:g} would overrule the clock)")
        elif r is not None:
            text += f"; runner-up {r.lag_s:+.2f} s (score {r.score:.3f}, ratio {self.ratio:.3f})"
        if len(self.side_lags) == 2:
            used = " (used per foot)" if self.per_foot else ""
            text += f"; per foot r {self.side_lags['r']:+.2f} s, l {self.side_lags['l']:+.2f} s{used}"
        if self.fit is not None and self.fit.exchanged is not None:
            text += f"; sides exchanged / labelled {self.fit.sides_ratio:.3f}"
        return text

    def to_dict(self) -> dict:
        def cand(c: Candidate) -> dict:
            return {"lag_s": round(c.lag_s, 4), "activity": round(c.activity, 4), "loading": round(c.loading, 4),
                    "impact": round(c.impact, 4), "activity_in_score": c.use_activity, "score": round(c.score, 4), "sides": c.sides}

        def window(f: WindowFit) -> dict:
            return {"centre_s": round(f.centre_s, 4), "labelled": cand(f.labelled),
                    "exchanged": cand(f.exchanged) if f.exchanged else None,
                    "sides_ratio": round(f.sides_ratio, 4) if np.isfinite(f.sides_ratio) else None}

        return {"lag_s": round(self.lag_s, 4), "convention": "t_reference = t_imu + lag_s", "clock": self.clock,
                "clock_meaning": CLOCK_SOURCES[self.clock],
                "clock_lag_s": None if self.clock_lag_s is None else round(self.clock_lag_s, 4),
                "measured_lag_s": None if self.measured_lag_s is None else round(self.measured_lag_s, 4),
                "window_s": round(self.window_s, 4), "align": "per-foot" if self.per_foot else "common",
                "label_lags_s": {s: round(v, 4) for s, v in self.label_lags.items()}, "best": cand(self.best),
                "runner_up": cand(self.runner_up) if self.runner_up else None,
                "ratio": round(self.ratio, 4) if np.isfinite(self.ratio) else None,
                "side_lags_s": {s: round(v, 4) for s, v in self.side_lags.items()},
                "swapped_sides_score": None if self.swapped_sides_score is None else round(self.swapped_sides_score, 4),
                "fit": window(self.fit) if self.fit else None, "window_fits": [window(f) for f in self.window_fits[:8]],
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


@dataclass(frozen=True)
class _Curves:
    """One side assignment's loading and impact correlations over the lags, per side and averaged."""

    sides: str
    loading_by_side: dict[str, np.ndarray]
    impact_by_side: dict[str, np.ndarray]

    def loading(self) -> np.ndarray:
        return sum(self.loading_by_side.values()) / len(self.loading_by_side)

    def impact(self, n: int) -> np.ndarray:
        return sum(self.impact_by_side.values()) / len(self.impact_by_side) if self.impact_by_side else np.zeros(n)


def _curves(stillness: dict[str, np.ndarray], impact: dict[str, np.ndarray], grf_vertical: dict[str, np.ndarray],
            names: tuple[str, str], rate_hz: float, max_lag: int, overlap: int, sides: str) -> _Curves:
    loading_pairs, impact_pairs = event_signals(stillness, impact, grf_vertical, rate_hz)
    return _Curves(sides,
                   {s: normalized_xcorr(_zscore(ref, f"the vertical GRF of side {s}"), _zscore(imu, f"the {names[0]}_{s} rate"),
                                        max_lag, overlap)[1] for s, (ref, imu) in loading_pairs.items()},
                   {s: normalized_xcorr(_zscore(ref, f"the vertical GRF rise of side {s}"), _zscore(imu, f"the {names[1]}_{s} jerk"),
                                        max_lag, overlap)[1] for s, (ref, imu) in impact_pairs.items()})


class _Scorer:
    """Fits within index ranges of the lag axis (the module docstring's window fit)."""

    def __init__(self, lags: np.ndarray, activity: np.ndarray, valid: np.ndarray, informative: bool, refine: int, rate_hz: float):
        self.lags, self.activity, self.valid, self.informative = lags, activity, valid, informative
        self.refine, self.rate_hz = refine, rate_hz

    def fit(self, loading: np.ndarray, impact: np.ndarray | None, lo: int, hi: int, sides: str) -> Candidate | None:
        """The loading peak in ``[lo, hi)`` refined to the impact peak within the refinement
        half-width (inside the range), as a candidate; None where no lag there is valid."""
        lo, hi = max(0, lo), min(len(self.lags), hi)
        ok = self.valid[lo:hi]
        if hi <= lo or not ok.any():
            return None
        p = lo + int(np.argmax(np.where(ok, loading[lo:hi], -np.inf)))
        k = p
        if impact is not None:
            a, b = max(lo, p - self.refine), min(hi, p + self.refine + 1)
            near = np.where(self.valid[a:b], impact[a:b], -np.inf)
            k = a + int(np.argmax(near)) if np.isfinite(near).any() else p
        border = min(k - lo, hi - 1 - k) <= BORDER_SAMPLES
        return Candidate(self.lags[k] / self.rate_hz, float(self.activity[k]), float(loading[p]),
                         float(impact[k]) if impact is not None else 0.0, self.informative, sides, border)

    def at(self, loading: np.ndarray, impact: np.ndarray | None, k: int, sides: str) -> Candidate:
        """The correlations at lag index ``k`` itself."""
        return Candidate(self.lags[k] / self.rate_hz, float(self.activity[k]), float(loading[k]),
                         float(impact[k]) if impact is not None else 0.0, self.informative, sides)


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
    clock_lag_s: float | None = None,
    clock_source: str = "files",
    per_foot: bool = False,
) -> Alignment:
    """Align an IMU stream to force-plate or treadmill GRF (module docstring).

    Args:
        stillness: side (``"r"``/``"l"``) → |ω| (n,) rad/s of that side's foot (or shank) sensor.
        impact: side → specific force (n, 3) m/s² of that side's shank (or foot) sensor, any frame.
        grf_vertical: side → vertical force (m,) N under that foot, on the reference clock.
        activity: (n,) summed |ω| of all sensors, rad/s.
        stride_period_s: the stride period, s.
        rate_hz: the common sample rate, Hz.
        max_lag_s: the largest |lag| searched for candidates, s (a shared clock's lag is always
            searched).
        names: the segments of ``stillness`` and ``impact``, for the report.
        check_sides: with both sides, also fit the exchanged sides and warn when they fit better.
        clock_lag_s: the lag a shared clock implies (s), kept unless the evidence against it is
            decisive; None: no shared clock.
        clock_source: ``"files"`` (same start and duration) or ``"given"`` (the user says so).
        per_foot: label each foot's force with its own lag (force plates on separate clocks).
    """
    sides = [s for s in ("r", "l") if s in stillness and s in grf_vertical]
    if not sides:
        raise AlignmentError("no side with both an IMU and a vertical GRF")
    if clock_source not in ("files", "given"):
        raise ValueError(f"clock_source must be 'files' or 'given', got {clock_source!r}")
    if clock_lag_s is not None:
        max_lag_s = max(max_lag_s, abs(clock_lag_s) + stride_period_s)
    max_lag, overlap = int(max_lag_s * rate_hz), int(MIN_OVERLAP_S * rate_hz)
    stride = max(int(round(stride_period_s * rate_hz)), 4)
    half = max(1, int(round(LAG_WINDOW_STRIDES * stride)))
    load = grf_vertical[sides[0]] if len(sides) == 1 else np.abs(grf_vertical["r"] - grf_vertical["l"])
    lags, c_activity = normalized_xcorr(_zscore(_smooth(load, 2 * stride), "the GRF activity envelope"),
                                        _zscore(_smooth(activity, 2 * stride), "the IMU activity envelope"), max_lag, overlap)
    labelled = _curves(stillness, impact, grf_vertical, names, rate_hz, max_lag, overlap, "labelled")
    both = check_sides and len(sides) == 2
    exchanged = (_curves(stillness, impact, {"r": grf_vertical["l"], "l": grf_vertical["r"]}, names, rate_hz, max_lag, overlap,
                         "exchanged") if both else None)
    has_impact = bool(labelled.impact_by_side)
    c_loading, c_impact = labelled.loading(), labelled.impact(len(lags))
    valid = np.isfinite(c_activity) & np.isfinite(c_loading) & np.isfinite(c_impact)
    if not valid.any():
        raise AlignmentError(f"the IMU and GRF signals overlap by less than {MIN_OVERLAP_S:g} s at every lag searched")
    notes = []
    informative = bool(np.nanmax(np.where(valid, c_activity, np.nan)) >= ACTIVITY_MIN_CORRELATION)
    if not informative:
        notes.append(f"the activity envelopes correlate at most {np.nanmax(np.where(valid, c_activity, np.nan)):.2f} (no clear "
                     "change of activity in the recording): not used in the score")
    scorer = _Scorer(lags, c_activity, valid, informative, int(IMPACT_WINDOW_S * rate_hz), rate_hz)
    imp = c_impact if has_impact else None
    x_loading = exchanged.loading() if exchanged else None
    x_impact = exchanged.impact(len(lags)) if exchanged and has_impact else None

    def window_fit(k: int) -> WindowFit:
        lab = scorer.fit(c_loading, imp, k - half, k + half + 1, "labelled") or scorer.at(c_loading, imp, k, "labelled")
        exc = None if x_loading is None else scorer.fit(x_loading, x_impact, k - half, k + half + 1, "exchanged")
        return WindowFit(lags[k] / rate_hz, lab, exc)

    # candidates over all lags: local maxima of the loading correlation, each fitted in its window
    peaks, _ = find_peaks(np.where(valid, c_loading, -2.0), distance=max(1, stride // 4))
    if len(peaks) == 0:
        peaks = np.array([int(np.argmax(np.where(valid, c_loading, -2.0)))])
    fits = sorted((window_fit(int(p)) for p in peaks), key=lambda f: f.labelled.score, reverse=True)
    candidates = tuple(f.labelled for f in fits)
    warnings: list[str] = []
    clock, measured = "search", None

    def own_lags(k: int) -> dict[str, float]:  # each foot's own lag in the window around lag index k
        out = {}
        for s in sides:
            one = scorer.fit(labelled.loading_by_side[s], labelled.impact_by_side.get(s), k - half, k + half + 1, "labelled")
            out[s] = one.lag_s if one is not None else lags[k] / rate_hz
        return out

    def index(lag_s: float) -> int:
        return int(np.clip(int(round(lag_s * rate_hz)) + max_lag, 0, len(lags) - 1))

    if clock_lag_s is not None:
        k_clock = index(clock_lag_s)
        at_clock = window_fit(k_clock)
        measured = at_clock.labelled.lag_s
        inside = max(at_clock.labelled.score, at_clock.exchanged.score if at_clock.exchanged else -np.inf)
        n_imu, n_grf = len(activity), len(next(iter(grf_vertical.values())))

        def overlap(lag: float) -> int:  # samples the two streams share at this lag
            k = int(round(lag * rate_hz))
            return max(0, min(n_imu, n_grf - k) - max(0, -k))

        # a candidate on a much shorter overlap is not evidence against the clock (short overlaps fit by chance)
        outside = next((f for f in fits if abs(f.labelled.lag_s - clock_lag_s) > half / rate_hz
                        and overlap(f.labelled.lag_s) >= OVERRULE_MIN_OVERLAP * overlap(clock_lag_s)), None)
        feet = own_lags(k_clock)
        off = [v - clock_lag_s for v in feet.values()]
        interior = all(abs(v) < (half - BORDER_SAMPLES) / rate_hz for v in off)  # a peak, not the window's border
        swapped_here = at_clock.looks_swapped  # then the labelled fit means nothing
        if outside is not None and inside > 0 and outside.labelled.score >= CLOCK_OVERRULE_RATIO * inside:
            clock, k_used = "overruled", index(outside.labelled.lag_s)
            warnings.append(
                f"the lag {outside.labelled.lag_s:+.2f} s fits the GRF to the IMUs {outside.labelled.score / inside:.2f} times "
                f"better (score {outside.labelled.score:.3f}) than any lag within ±{half / rate_hz:.2f} s of the files' shared "
                f"clock ({clock_lag_s:+.2f} s, score {inside:.3f}; overruled from {CLOCK_OVERRULE_RATIO:g}): used it; check "
                "that the files were recorded together")
        elif (len(off) == 2 and interior and not swapped_here and min(abs(v) for v in off) > CLOCK_TOLERANCE_S
              and off[0] * off[1] > 0):
            clock, k_used = "overruled", k_clock
            warnings.append(
                f"both feet's stances align away from the files' shared clock ({clock_lag_s:+.2f} s): right "
                f"{feet['r']:+.2f} s, left {feet['l']:+.2f} s (more than {CLOCK_TOLERANCE_S:g} s): used the measured "
                f"{measured:+.2f} s; check that the files were recorded together")
        else:
            clock, k_used = clock_source, k_clock
            notes.append(f"the shared clock's lag {clock_lag_s:+.3f} s is kept (measured {measured:+.2f} s within "
                         f"±{half / rate_hz:.2f} s, per foot " + ", ".join(f"{s} {v:+.2f} s" for s, v in feet.items())
                         + "; the correlations' shape biases are not applied)")
        fit = window_fit(k_used)
        if clock == "overruled":  # the fit beyond the window, or the one measured in the clock's window
            best = fit.labelled
        else:
            best = scorer.at(c_loading, imp, k_used, "labelled")
        # the runner-up: the best beyond the window, or (the clock overruled by it) the clock's window
        runner_c = at_clock.labelled if clock == "overruled" and k_used != k_clock else (outside.labelled if outside else None)
    else:
        fit = fits[0]
        best = fit.labelled
        k_used = index(best.lag_s)
        runner_c = next((c for c in candidates[1:] if abs(c.lag_s - best.lag_s) > stride / 4 / rate_hz), None)
        if runner_c is not None and runner_c.score > 0 and best.score / runner_c.score < AMBIGUOUS_RATIO:
            warnings.append(
                f"the time alignment is ambiguous: lags {best.lag_s:+.2f} s (score {best.score:.3f}, used) and "
                f"{runner_c.lag_s:+.2f} s (score {runner_c.score:.3f}) score within a ratio of {best.score / runner_c.score:.3f} "
                f"(below {AMBIGUOUS_RATIO}): the GRF labels may be off by whole strides; import a part with quiet standing or "
                "the start or end of walking, give --same-clock if the files share a clock, or check the lag")
    lag_s = best.lag_s
    side_lags = own_lags(k_used)  # for "overruled" by the feet: the window around the clock, as measured
    swapped = fit.looks_swapped  # then the labelled sides' own lags and local lags mean nothing
    if swapped:
        notes.append("the sides look swapped: the checks of the channels' offset and of lag jumps were skipped (they "
                     "assume the sides as labelled)" + ("; both feet labelled with the common lag" if per_foot else ""))
    elif per_foot:
        notes.append("per-foot alignment: each foot's force labelled with its own lag (" +
                     ", ".join(f"{s} {v:+.2f} s" for s, v in side_lags.items()) + f"; common lag {lag_s:+.2f} s)")
    elif len(side_lags) == 2 and abs(side_lags["r"] - side_lags["l"]) > SIDE_LAG_TOLERANCE_S + 1e-9:
        warnings.append(
            f"the right and left force channels look offset in time: the right foot's stance aligns at lag {side_lags['r']:+.2f} s, "
            f"the left at {side_lags['l']:+.2f} s (more than {SIDE_LAG_TOLERANCE_S:g} s apart); the labels use {lag_s:+.2f} s "
            "for both: check the GRF file's channels, or import with --align per-foot if the plates run on separate clocks")
    loading_pairs, impact_pairs = event_signals(stillness, impact, grf_vertical, rate_hz)
    jumps = ([] if swapped else
             lag_jumps([*loading_pairs.values(), *impact_pairs.values()], int(round(lag_s * rate_hz)), stride, rate_hz, half))
    for a, b, d in jumps:
        warnings.append(
            f"the lag between the IMU and the GRF jumps: from {a / rate_hz:.1f} to {b / rate_hz:.1f} s (IMU time) the GRF fits "
            f"{d:+.2f} s away from the lag used ({lag_s:+.2f} s), more than {LAG_JUMP_TOLERANCE_S:g} s: one file's clock jumps "
            "(samples dropped or inserted); the GRF labels there are off (kept; listed as grf_misaligned_s): crop the "
            "recording (--start/--end) or fix the files")
    swapped_score = None
    if fit.exchanged is not None:
        ex = fit.exchanged
        text = (f"with the force channels' sides exchanged the best fit within ±{half / rate_hz:.2f} s of {fit.centre_s:+.2f} s is "
                f"at {ex.lag_s:+.2f} s (loading {ex.loading:.3f}, impact {ex.impact:.3f}: each {names[0]}'s stillness against the "
                f"other foot's force), as labelled at {fit.labelled.lag_s:+.2f} s (loading {fit.labelled.loading:.3f}, impact "
                f"{fit.labelled.impact:.3f}); ratio {fit.sides_ratio:.3f}")
        swapped_score = ex.score
        if swapped:
            bar = BORDER_SIDES_RATIO if ex.at_border else SWAPPED_SIDES_RATIO
            warnings.append(f"right and left look swapped between the GRF file and the IMUs: {text} (above {bar:g}); "
                            "check the GRF file's r/l columns and the sensor map's sides")
        else:
            notes.append(f"side check: {text}")
        if clock == "search" and x_loading is not None:
            x_peaks, _ = find_peaks(np.where(valid, x_loading, -2.0), distance=max(1, stride // 4))
            x_best = max((scorer.fit(x_loading, x_impact, int(p) - half, int(p) + half + 1, "exchanged") for p in x_peaks),
                         key=lambda c: c.score if c is not None else -np.inf, default=None)
            if (x_best is not None and not swapped and best.score > 0
                    and x_best.score > SWAPPED_GLOBAL_RATIO * best.score):
                warnings.append(
                    f"right and left may be swapped between the GRF file and the IMUs, or the lag off by half a stride: with the "
                    f"sides exchanged the alignment scores {x_best.score:.3f} at {x_best.lag_s:+.2f} s, as labelled {best.score:.3f} "
                    f"at {lag_s:+.2f} s (ratio {x_best.score / best.score:.3f}, above {SWAPPED_GLOBAL_RATIO:g}); without a shared "
                    "clock the two cannot be told apart: check the GRF file's r/l columns, or give --same-clock")
    pairs = {"activity": "summed IMU rate norms vs |F_r − F_l| (2-stride means)",
             "loading": f"vertical GRF vs {names[0]} stillness −|ω|",
             "impact": f"{names[1]} jerk |Δacc| vs rise of the vertical GRF" if has_impact else "none"}
    return Alignment(lag_s, best, runner_c, candidates, pairs, tuple(notes), side_lags, tuple(warnings), swapped_score,
                     tuple(jumps), clock, clock_lag_s, measured, half / rate_hz, per_foot and not swapped, fit,
                     tuple(fits))


def imu_signals(signals: dict[str, tuple[np.ndarray, np.ndarray]]) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray], np.ndarray,
                                                                            tuple[str, str]] | None:
    """The IMU arguments of :func:`align_to_grf` from calibrated segments' sensor-frame signals
    (segment → (acc (n, 3) m/s², gyr (n, 3) rad/s)): (stillness |ω| of the feet, else the shanks;
    impact specific force of the shanks, else the feet; the summed rate norms; their segment
    names), or None without a foot or shank sensor."""
    feet = {s[-1]: s for s in signals if s.startswith("foot")}
    shanks = {s[-1]: s for s in signals if s.startswith("tibia")}
    still, hit = (feet or shanks), (shanks or feet)
    if not still:
        return None
    activity = sum(np.linalg.norm(g, axis=1) for _, g in signals.values())
    return ({s: np.linalg.norm(signals[seg][1], axis=1) for s, seg in still.items()}, {s: signals[seg][0] for s, seg in hit.items()},
            activity, ("foot" if feet else "shank", "shank" if shanks else "foot"))


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
              rate_hz: float = 100.0, half: int | None = None) -> list[tuple[int, int, float]]:
    """The spans (start, stop IMU samples, offset s) whose lag differs from the others' (module
    docstring, "lag jumps"), from the (GRF, IMU) signal ``pairs`` of :func:`event_signals`;
    ``lag`` is the chosen lag, ``stride`` the stride period and ``half`` the half-width of the
    local search (default: the lag window, :data:`LAG_WINDOW_STRIDES` of a stride), in samples."""
    if not pairs:
        return []
    n = min(len(imu) for _, imu in pairs)
    half = max(1, int(round(LAG_WINDOW_STRIDES * stride))) if half is None else max(1, half)
    window, step = int(LOCAL_WINDOW_S * rate_hz), int(LOCAL_STEP_S * rate_hz)
    if n < window + step + max(0, half - lag):
        return []
    starts = np.arange(max(0, half - lag), n - window + 1, step)  # from the first window the GRF covers at every shift
    shifts = np.arange(lag - half, lag + half + 1)
    local = np.full(len(starts), np.nan)
    for w, a in enumerate(starts):
        # the window x = imu[a:a + window] against ref[a + shift:...]: normalized_xcorr's lag a + shift,
        # NaN where ref does not hold the whole window
        reach = int(max(abs(a + shifts[0]), abs(a + shifts[-1])))
        score = sum(normalized_xcorr(ref, imu[a:a + window], reach, window)[1][a + shifts + reach] for ref, imu in pairs)
        if np.isfinite(score).all():  # a window the GRF covers at only some shifts would peak on its edge
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
