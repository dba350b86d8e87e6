"""Gait events from the vertical ground reaction force: heel strike and toe-off, and how well
an estimate times them.

A foot is in contact while its vertical GRF exceeds a threshold (by default 5 % of body weight,
:data:`CONTACT_THRESHOLD_BW`). Heel strike (HS) is the first contact sample, toe-off (TO) the first
sample after contact. Contact and swing phases shorter than ``min_phase_s`` (default 50 ms) are
treated as noise: a morphological closing then opening of the contact mask
(:func:`scipy.ndimage.binary_closing` / ``binary_opening``) removes them, so a force that
chatters around the threshold gives one event, not several. The same rule is applied to the
estimated and to the measured force, so the timing error compares like with like.

The timing error (:func:`event_timing`) pairs every reference event with the nearest estimated
event of the same kind and foot; pairs further apart than ``max_offset_s`` count as missed.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Final

import numpy as np
from scipy.ndimage import binary_closing, binary_opening

#: Contact threshold of the vertical GRF, in body weights.
CONTACT_THRESHOLD_BW: Final = 0.05
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
