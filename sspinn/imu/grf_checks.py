"""Checks of a treadmill GRF file against the subject and the IMU recording (the lag itself is
checked by :mod:`sspinn.imu.time_alignment`: ambiguous, channels offset in time, sides swapped).

Assumed: the force is measured continuously under both feet (an instrumented treadmill), in
newtons, lab y up. Walking on it, the vertical forces of the two feet sum to body weight on
average (the body's vertical momentum is periodic), and at least one foot is always loaded
(walking has no flight phase).

* :func:`check_vertical_force` — the mean of the summed vertical force over the file against body
  weight (:func:`sspinn.data.signal_checks.mean_vertical_force_findings`, the check GRF labels
  get too): negative (the vertical axis points down) or far from it (another unit) is an error
  naming the file, the columns and the likely unit; somewhat off is a warning (a wrong mass, a
  missing plate, time off the treadmill).
* :func:`unloaded_share_warning` — the share of the samples with the subject on the treadmill
  (from the first to the last in which the feet carry half the body weight together) in which
  both feet are unloaded (below :data:`UNLOADED_BW` body weights): above
  :data:`UNLOADED_SHARE_WARN`, a warning (running has flight phases; in walking it means lost
  contact with the plates, swapped or mis-scaled channels). It is computed on the GRF file
  alone: a stretch of lost contact also misleads the time alignment.
"""

from __future__ import annotations

from pathlib import Path
from typing import Final

import numpy as np

from sspinn.data.signal_checks import ImpossibleSignalError, mean_vertical_force_findings
from sspinn.errors import DataFormatError
from sspinn.model.conventions import GRAVITY

#: A foot is unloaded below this vertical force, body weights (the gait-event threshold).
UNLOADED_BW: Final = 0.05
#: Largest share of the samples on the treadmill with both feet unloaded before a warning. The
#: twelve CMU trials: at most 0.01 % (Sub05's files begin with 1.9 s and 5.0 s before the
#: subject steps on: outside the span).
UNLOADED_SHARE_WARN: Final = 0.10


class GRFFileError(DataFormatError):
    """A GRF file that does not fit the subject (sign or unit of the vertical force); the message
    names the file and the columns."""


def check_vertical_force(path: str | Path, forces: dict[str, np.ndarray], columns: dict[str, tuple[str, str]],
                         mass: float) -> list[str]:
    """Warnings about the mean summed vertical force of ``forces`` (side → (n, 2) horizontal,
    vertical, N, as :func:`sspinn.imu.vendor_readers.read_treadmill_grf_columns` gives them, with
    ``columns`` their names) for a subject of ``mass`` kg; raises :class:`GRFFileError` (module
    docstring; the one check of the mean force, :func:`sspinn.data.signal_checks.mean_vertical_force_findings`,
    that GRF labels get too)."""
    mean = float(np.mean(sum(f[:, 1] for f in forces.values())))
    what = f"{path}: the vertical forces ({' + '.join(c[1] for c in columns.values())}) over the file"
    try:
        return mean_vertical_force_findings(what, mean, mass, strict=True)
    except ImpossibleSignalError as exc:
        raise GRFFileError(str(exc)) from None


def unloaded_share_warning(path: str | Path, vertical_r: np.ndarray, vertical_l: np.ndarray, mass: float) -> str | None:
    """A warning when both feet are unloaded in more than :data:`UNLOADED_SHARE_WARN` of the
    samples between the first and the last in which the two feet together carry half the body
    weight (the subject on the treadmill), else None. Vertical forces in N (one per sample),
    ``mass`` kg."""
    weight = mass * GRAVITY
    on = np.flatnonzero(vertical_r + vertical_l > 0.5 * weight)
    if len(on) < 2:
        return None  # nobody on the treadmill: the mean-force check speaks
    threshold = UNLOADED_BW * weight
    span = slice(on[0], on[-1] + 1)
    both = (vertical_r[span] < threshold) & (vertical_l[span] < threshold)
    share = float(both.mean())
    if share <= UNLOADED_SHARE_WARN:
        return None
    return (f"{path}: both feet carry less than {UNLOADED_BW:.0%} of body weight ({threshold:.0f} N) in {share:.0%} of the "
            f"{len(both)} samples with the subject on the treadmill (more than {UNLOADED_SHARE_WARN:.0%}; walking has no flight "
            "phase): lost contact with the plates, swapped or mis-scaled channels, or a running trial")
