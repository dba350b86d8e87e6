"""Gait events from the vertical ground reaction force: heel strike and toe-off, and how well
an estimate times them.

This is the project's one gait-event module: the estimator's evaluation, the optimal-control
solutions, the controller comparison and the agents' rollouts all detect contact here, with one
threshold. A foot is in contact while its vertical GRF exceeds a threshold (by default 10 % of
body weight, :data:`CONTACT_THRESHOLD_BW`). Heel strike (HS) is the first contact sample, toe-off (TO) the first
sample after contact. Contact and swing phases shorter than ``min_phase_s`` (default 50 ms) are
treated as noise: a morphological closing then opening of the contact mask
(:func:`scipy.ndimage.binary_closing` / ``binary_opening``) removes them, so a force that
chatters around the threshold gives one event, not several. The same rule is applied to the
estimated and to the measured force, so the timing error compares like with like.

The timing error (:func:`event_timing`) pairs every reference event with the nearest estimated
event of the same kind and foot; pairs further apart than ``max_offset_s`` count as missed;
:func:`grf_event_timing` pools both feet of a GRF array. :func:`strides` and
:func:`normalise_cycles` cut a recording into heel-strike-to-heel-strike cycles and time-normalise
them (0–100 %), for the gait-cycle plots and the mean-GRF-profile baseline. :func:`standing_mask`
finds standing (both feet down for half a second or more).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Final

import numpy as np
from scipy.ndimage import binary_closing, binary_opening

#: Contact threshold of the vertical GRF, in body weights. Why 0.1 and not the force plates' usual
#: 20–50 N: the model's smooth spring-damper contact already carries a few percent of body weight
#: while a foot approaches the ground (the 1.3 m/s optimal-control walking solution exceeds
#: 0.05 BW 9 % of the cycle before it exceeds 0.1 BW), and the synthetic labels and the estimates
#: come from that model. The synthetic generator's stride boundaries are defined on it too:
#: changing it changes the generated data (bump ``predictive.synth.cache.CODE_VERSION``).
CONTACT_THRESHOLD_BW: Final = 0.1
#: Shortest contact or swing phase taken as real, s.
MIN_PHASE_S: Final = 0.05


@dataclass(frozen=True)
class GaitEvents:
    """One foot's events as sample indices: ``heel_strikes`` (first contact sample) and
    ``toe_offs`` (first sample after contact); ``contact`` is the cleaned (T,) contact mask."""

    heel_strikes: np.ndarray
    toe_offs: np.ndarray
    contact: np.ndarray


@dataclass(frozen=True)
class EventTiming:
    """Timing of estimated events against reference events of one kind.

    Attributes:
        mean_abs_ms: mean |estimated − reference| over the matched events, ms (NaN if none).
        bias_ms: mean (estimated − reference) over the matched events, ms (positive: late).
        matched: reference events with an estimated event within the search window.
        n_reference: reference events.
        n_estimated: estimated events.
    """

    mean_abs_ms: float
    bias_ms: float
    matched: int
    n_reference: int
    n_estimated: int

    def as_dict(self) -> dict[str, float | int]:
        return {"mean_abs_ms": self.mean_abs_ms, "bias_ms": self.bias_ms, "matched": self.matched,
                "n_reference": self.n_reference, "n_estimated": self.n_estimated}


def contact_mask(vertical: np.ndarray, threshold: float, min_samples: int) -> np.ndarray:
    """(T,) bool: vertical force (N) above ``threshold`` (N), with contact and swing phases
    shorter than ``min_samples`` removed (closing, then opening; the ends are padded with their
    own values so a phase cut by the recording's edge is not shortened)."""
    on = np.asarray(vertical) > threshold
    if min_samples <= 1 or len(on) == 0:
        return on
    pad = min_samples
    padded = np.concatenate([np.repeat(on[:1], pad), on, np.repeat(on[-1:], pad)])
    structure = np.ones(min_samples, dtype=bool)
    cleaned = binary_opening(binary_closing(padded, structure), structure)
    return cleaned[pad:-pad]


def detect_events(vertical: np.ndarray, body_weight: float, rate_hz: float,
                  threshold_bw: float = CONTACT_THRESHOLD_BW, min_phase_s: float = MIN_PHASE_S) -> GaitEvents:
    """Heel strikes and toe-offs of one foot from its vertical GRF (N; body weight in N)."""
    contact = contact_mask(vertical, threshold_bw * body_weight, max(1, round(min_phase_s * rate_hz)))
    change = np.diff(contact.astype(np.int8))
    return GaitEvents(np.flatnonzero(change == 1) + 1, np.flatnonzero(change == -1) + 1, contact)


#: Shortest double support taken as standing, s: in walking both feet are down for 0.1–0.2 s at a time.
MIN_STANDING_S: Final = 0.5


def foot_contacts(grf: np.ndarray, body_weight: float, rate_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """The right and the left foot's (T,) bool contact masks (:func:`detect_events`) of a GRF array
    (T, 4) [x_r, y_r, x_l, y_l] (N)."""
    grf = np.asarray(grf, dtype=float)
    if grf.ndim != 2 or grf.shape[1] != 4:
        raise ValueError(f"grf must be (T, 4) [x_r, y_r, x_l, y_l], got {grf.shape}")
    return detect_events(grf[:, 1], body_weight, rate_hz).contact, detect_events(grf[:, 3], body_weight, rate_hz).contact


def standing_mask(grf: np.ndarray, body_weight: float, rate_hz: float, min_s: float = MIN_STANDING_S) -> np.ndarray:
    """(T,) bool: the samples of standing in a GRF array (T, 4) [x_r, y_r, x_l, y_l] (N) — both feet
    in contact (:func:`foot_contacts`) for at least ``min_s`` seconds at a time."""
    right, left = foot_contacts(grf, body_weight, rate_hz)
    return runs_at_least(right & left, round(min_s * rate_hz))


def true_runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """[start, stop) sample indices of the runs of True in ``mask`` (T,) bool, in order."""
    edges = np.diff(np.concatenate(([0], np.asarray(mask).astype(np.int8), [0])))
    return list(zip(np.flatnonzero(edges == 1).tolist(), np.flatnonzero(edges == -1).tolist()))


def runs_at_least(mask: np.ndarray, min_len: int) -> np.ndarray:
    """``mask`` (T,) bool with its runs of True shorter than ``min_len`` samples cleared."""
    out = np.zeros(len(mask), dtype=bool)
    for start, end in true_runs(mask):
        if end - start >= min_len:
            out[start:end] = True
    return out


#: Foot-IMU heel strikes: the swing's angular-rate peak must reach this fraction of the
#: recording's 95th-percentile rate (the swing peaks are the largest positive rates of a foot in
#: walking) …
SWING_PEAK_FRACTION: Final = 0.5
#: … and the heel strike is the rate's minimum within this long after it, s.
HEEL_STRIKE_SEARCH_S: Final = 0.3


def foot_imu_heel_strikes(gyr_z: np.ndarray, rate_hz: float) -> np.ndarray:
    """Heel strikes (sample indices) of one foot from its IMU's sagittal angular rate (rad/s;
    positive when the toe rises, :mod:`sspinn.model.conventions`), without any force: the
    standard gyroscope rule for foot-worn IMUs (Rampp et al. 2015, IEEE Trans. Biomed. Eng.
    62:1089, "initial contact" of gaitmap's ``RamppEventDetection``) in this frame — after each
    swing's positive rate peak (at least :data:`SWING_PEAK_FRACTION` of the recording's 95th
    percentile, peaks ≥ 0.4 s apart), the rate's minimum within :data:`HEEL_STRIKE_SEARCH_S`:
    the foot stops rotating forward and slaps flat. For walking; a forefoot strike (running)
    has no such minimum at contact."""
    from scipy.signal import find_peaks

    g = np.asarray(gyr_z, dtype=float)
    if g.ndim != 1 or not np.isfinite(g).all():
        raise ValueError("gyr_z must be a finite 1-D array")
    height = SWING_PEAK_FRACTION * max(float(np.percentile(g, 95)), 1e-9)
    peaks, _ = find_peaks(g, height=height, distance=max(1, round(0.4 * rate_hz)))
    window = max(2, round(HEEL_STRIKE_SEARCH_S * rate_hz))
    out = []
    for k, p in enumerate(peaks):
        stop = min(len(g), p + window, peaks[k + 1] if k + 1 < len(peaks) else len(g))
        if stop - p > 1:
            out.append(p + 1 + int(np.argmin(g[p + 1 : stop])))
    return np.array(out, dtype=int)


def contact_onsets(vertical_bw: np.ndarray, threshold_bw: float = CONTACT_THRESHOLD_BW, periodic: bool = False) -> np.ndarray:
    """Sample indices at which a vertical force (in body weights) rises above ``threshold_bw``
    after being at or below it — raw crossings, without :func:`contact_mask`'s cleaning, for
    noise-free signals such as a simulated or optimised gait cycle. ``periodic``: the signal is
    one cycle that wraps around (its first sample follows its last)."""
    loaded = np.asarray(vertical_bw) > threshold_bw
    before = np.roll(loaded, 1) if periodic else np.concatenate([[True], loaded[:-1]])
    return np.flatnonzero(loaded & ~before)


@dataclass(frozen=True)
class PhaseFractions:
    """Shares (0–1) of the samples of two contact masks: ``stance_r``, ``stance_l`` (that foot in
    contact), ``double_support`` (both) and ``flight`` (neither foot in contact)."""

    stance_r: float
    stance_l: float
    double_support: float
    flight: float


def phase_fractions(contact_r: np.ndarray, contact_l: np.ndarray) -> PhaseFractions:
    """The project's one computation of stance / double-support / flight shares from the right and
    left (T,) bool contact masks (any span: a whole recording, or one stride ``mask[a:b]``);
    NaN everywhere for empty masks."""
    r, l = np.asarray(contact_r, dtype=bool), np.asarray(contact_l, dtype=bool)
    if r.shape != l.shape or r.ndim != 1:
        raise ValueError(f"contact masks must be two (T,) arrays of one length, got {r.shape} and {l.shape}")
    if len(r) == 0:
        return PhaseFractions(*(4 * [float("nan")]))
    return PhaseFractions(float(r.mean()), float(l.mean()), float((r & l).mean()), float((~r & ~l).mean()))


def stance_fractions(vertical_r_bw: np.ndarray, vertical_l_bw: np.ndarray, threshold_bw: float = CONTACT_THRESHOLD_BW) -> dict[str, float]:
    """Fractions of the samples with each foot loaded above ``threshold_bw`` (vertical forces in
    body weights, raw crossings): ``stance_r``, ``stance_l``, ``double_support`` and ``flight``
    (neither), :func:`phase_fractions`."""
    fractions = phase_fractions(np.asarray(vertical_r_bw) > threshold_bw, np.asarray(vertical_l_bw) > threshold_bw)
    return {"stance_r": fractions.stance_r, "stance_l": fractions.stance_l,
            "double_support": fractions.double_support, "flight": fractions.flight}


#: A contact shorter than this fraction of the recording's typical contact (:func:`typical_contact_s`)
#: is a **tap**, not a stance. Why 0.4: a stance of one gait varies little from step to step
#: (stride-time CV 1–3 % in healthy walking, Hausdorff et al. 1995, J Appl Physiol 78:349; stance
#: 58–65 % of the stride, Perry 1992), so no real step of a steady walk or run lasts less than
#: half the typical one; a swing foot brushing the ground lasts a few tens of ms (a simulated
#: walker's taps: 60 ms against 0.5 s stances; threshold here 0.2 s). At walking's 0.6–0.7 s stance
#: the threshold is 0.24–0.28 s; at running's 0.2–0.3 s (Cavanagh & Lafortune 1980, J Biomech
#: 13:397) 0.08–0.12 s, so a runner's stances are never taps.
TAP_FRACTION: Final = 0.4


@dataclass(frozen=True)
class FootStances:
    """One foot's contacts split into stances and taps (sample indices).

    Attributes:
        stance: (T,) bool, the contact mask without the taps.
        heel_strikes: first sample of each stance (not one starting at sample 0).
        toe_offs: first sample after each stance (not one running to the end).
        taps: [start, stop) of each tap (a contact shorter than the tap threshold, not cut by the
            recording's edges).
    """

    stance: np.ndarray
    heel_strikes: np.ndarray
    toe_offs: np.ndarray
    taps: tuple[tuple[int, int], ...]


def typical_contact_s(contacts: list[np.ndarray], rate_hz: float) -> float:
    """The time-weighted median duration (s) of the contact runs of the masks (every contact
    sample votes for the length of its run, so a few long stances outweigh many short taps; runs
    cut by the recording's edges count with their visible length); NaN without contact."""
    lengths = [stop - start for mask in contacts for start, stop in true_runs(mask)]
    if not lengths:
        return float("nan")
    weighted = np.repeat(lengths, lengths)
    return float(np.median(weighted)) / rate_hz


def split_taps(contacts: list[np.ndarray], rate_hz: float, tap_fraction: float = TAP_FRACTION) -> list[FootStances]:
    """Each (T,) contact mask (e.g. :attr:`GaitEvents.contact` of each foot) split into stances and
    taps: a run shorter than ``tap_fraction`` × :func:`typical_contact_s` of all the masks together
    is a tap (:data:`TAP_FRACTION`), unless it touches the recording's first or last sample
    (its length is unknown)."""
    if not 0.0 <= tap_fraction < 1.0:
        raise ValueError(f"tap_fraction must be in [0, 1), got {tap_fraction}")
    limit = tap_fraction * typical_contact_s(contacts, rate_hz) * rate_hz
    out = []
    for mask in contacts:
        mask = np.asarray(mask, dtype=bool)
        stance = mask.copy()
        taps = []
        for start, stop in true_runs(mask):
            if start > 0 and stop < len(mask) and stop - start < limit:
                stance[start:stop] = False
                taps.append((start, stop))
        change = np.diff(stance.astype(np.int8))
        out.append(FootStances(stance, np.flatnonzero(change == 1) + 1, np.flatnonzero(change == -1) + 1, tuple(taps)))
    return out


def alternating_steps(heel_strikes_r: np.ndarray, heel_strikes_l: np.ndarray) -> list[tuple[int, int, int]]:
    """Steps (start, end, foot) from two feet's heel strikes (sample indices): consecutive heel
    strikes (in time, both feet) of different feet; ``foot`` (0 right, 1 left) is the foot landing at
    ``end``. Two strikes of one foot in a row (a hop) are no step."""
    strikes = sorted([(int(h), 0) for h in heel_strikes_r] + [(int(h), 1) for h in heel_strikes_l])
    return [(a, b, fb) for (a, fa), (b, fb) in zip(strikes[:-1], strikes[1:]) if fa != fb]


def strides(heel_strikes: np.ndarray, rate_hz: float, min_s: float = 0.3, max_s: float = 3.0) -> list[tuple[int, int]]:
    """(start, end) sample indices of the cycles between consecutive heel strikes that last
    ``min_s``–``max_s`` seconds (longer or shorter ones are missed or spurious events)."""
    return [(int(a), int(b)) for a, b in zip(heel_strikes[:-1], heel_strikes[1:]) if min_s * rate_hz <= b - a <= max_s * rate_hz]


def normalise_cycles(signal: np.ndarray, cycles: list[tuple[int, int]], points: int = 101) -> np.ndarray:
    """(n_cycles, points) of a (T,) signal time-normalised to 0–100 % of each cycle."""
    grid = np.linspace(0, 1, points)
    return np.array([np.interp(grid, np.linspace(0, 1, b - a + 1), signal[a : b + 1]) for a, b in cycles])


def event_timing(estimated: np.ndarray, reference: np.ndarray, rate_hz: float, max_offset_s: float) -> EventTiming:
    """Timing error of ``estimated`` against ``reference`` event sample indices (module docstring)."""
    estimated, reference = np.asarray(estimated), np.asarray(reference)
    if len(estimated) == 0 or len(reference) == 0:
        return EventTiming(float("nan"), float("nan"), 0, len(reference), len(estimated))
    nearest = estimated[np.argmin(np.abs(estimated[None, :] - reference[:, None]), axis=1)]
    offset_s = (nearest - reference) / rate_hz
    ok = np.abs(offset_s) <= max_offset_s
    if not ok.any():
        return EventTiming(float("nan"), float("nan"), 0, len(reference), len(estimated))
    return EventTiming(float(1e3 * np.mean(np.abs(offset_s[ok]))), float(1e3 * np.mean(offset_s[ok])), int(ok.sum()),
                       len(reference), len(estimated))


def grf_event_timing(estimated: np.ndarray, reference: np.ndarray, body_weight: float, rate_hz: float,
                     kind: str = "heel_strikes", max_offset_s: float = 0.3) -> EventTiming:
    """:func:`event_timing` of one kind of event (``heel_strikes`` or ``toe_offs``) from two (T, 4)
    GRF arrays (``grf_x_r, grf_y_r, grf_x_l, grf_y_l``, N), pooled over the feet whose reference
    vertical force is known (a foot of NaN, e.g. a missing label column, is left out): the means
    weighted by each foot's matched events."""
    feet = [f for f in range(2) if np.isfinite(reference[:, 2 * f + 1]).all()]
    timings = [event_timing(getattr(detect_events(estimated[:, 2 * f + 1], body_weight, rate_hz), kind),
                            getattr(detect_events(reference[:, 2 * f + 1], body_weight, rate_hz), kind), rate_hz, max_offset_s)
               for f in feet]
    matched = sum(t.matched for t in timings)

    def weighted(field: str) -> float:
        return float(sum(getattr(t, field) * t.matched for t in timings if t.matched) / matched) if matched else float("nan")

    return EventTiming(weighted("mean_abs_ms"), weighted("bias_ms"), matched, sum(t.n_reference for t in timings),
                       sum(t.n_estimated for t in timings))
