"""An uncertainty on every estimate: Monte Carlo dropout spread, calibrated by conformal prediction.

For each output channel c and sample t the model reports the half-width of a 90 % interval
around its estimate ŷ_ct:

* **Spread σ_ct** — the standard deviation over ``passes`` runs of the network with its dropout
  left on (Monte Carlo dropout; Gal & Ghahramani 2016, "Dropout as a Bayesian approximation",
  ICML), decoded and, for the paper's contact model, passed through the contact model like the
  estimate itself. The network's own dropout (``NetworkConfig.dropout``, between the LSTM
  layers) is what varies, so a model without dropout has no spread and is refused.
* **Calibration k_c** — the spread alone is not a calibrated interval (dropout's spread is
  typically far too narrow). On labelled recordings that were *not* used for training (the
  synthetic data's ``val`` split), k_c is the ``level`` quantile of |ŷ_ct − y_ct| / σ_ct over
  all samples: split conformal prediction with the spread as the normalising scale
  (Lei et al. 2018, "Distribution-free predictive inference for regression", JASA 113:1094,
  the locally weighted variant). Under exchangeability of calibration and new samples, the
  interval ŷ ± k_c·σ covers the truth with probability ≈ ``level``; real recordings of other
  people are not exchangeable with synthetic ones, so the coverage there is a claim to check,
  not a guarantee. :func:`coverage` checks it on a held-out split.

Channels (:data:`CHANNELS`, named as the estimate's CSV columns): the pelvis tilt and the six
joint angles (rad), the six joint torques (N·m), the four GRF components (N), the forward speed
(m/s; the 2-s centred moving mean of the pelvis velocity, compared with the labels' stride speed
averaged the same way) and the pelvis velocity itself (``d_pelvis_tx``, m/s).
No library does normalised split-conformal calibration on a recurrent physics decoder's outputs,
hence the few lines here.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Final

import numpy as np
import torch

from sspinn.data.dataset import SAMPLE_RATE_HZ, Recording
from sspinn.errors import UserError
from sspinn.estimator import calibration_files
from sspinn.estimator.inference import GaitEstimate, network_inputs, physical_outputs
from sspinn.estimator.network import SSPINNposeNet
from sspinn.model.body import BodyParameters
from sspinn.model.conventions import COORDINATES, GRAVITY, GRF, JOINTS
from sspinn.run_folder import atomic_path, atomic_write_text

#: Output channels with an interval: name → (estimate field, column).
CHANNELS: Final[dict[str, tuple[str, int]]] = {
    **{c: ("q", COORDINATES.index(c)) for c in ("pelvis_tilt", *JOINTS)},
    **{f"tau_{j}": ("tau", k) for k, j in enumerate(JOINTS)},
    **{g: ("grf", k) for k, g in enumerate(GRF)},
    "speed": ("speed", 0),
    "d_pelvis_tx": ("u", 0),
}
#: Channel groups of the coverage table.
GROUPS: Final[dict[str, tuple[str, ...]]] = {
    "angles": ("pelvis_tilt", *JOINTS),
    "torques": tuple(f"tau_{j}" for j in JOINTS),
    "GRF": GRF,
    "speed": ("speed",),
    "pelvis velocity": ("d_pelvis_tx",),
}
#: Window of the speed channel's centred moving mean, s.
SPEED_WINDOW_S: Final = 2.0
#: Smallest spread per channel unit (rad, N·m, N, m/s), so that a sample where every pass agrees
#: does not get a zero-width interval.
MIN_SPREAD: Final = 1e-6
#: Samples of LSTM warm-up left out of calibration and coverage (as ``sspinn evaluate``).
SKIP: Final = 50
FORMAT: Final = "sspinn-uncertainty-calibration"
VERSION: Final = 1


class UncertaintyError(UserError):
    """An uncertainty cannot be computed or calibrated as asked (a model without dropout, no
    labels, a malformed or foreign calibration file)."""


def _moving_mean(x: np.ndarray, n: int) -> np.ndarray:
    """Centred moving mean over ``n`` samples (at most the length) along axis -1, the ends
    padded with their nearest value."""
    from scipy.ndimage import uniform_filter1d

    return uniform_filter1d(np.asarray(x, dtype=float), size=min(n, x.shape[-1]), axis=-1, mode="nearest")


def channel_values(fields: dict[str, np.ndarray]) -> np.ndarray:
    """(..., T, n_channels) of :data:`CHANNELS` from decoded outputs ``fields`` (q, u, tau, grf;
    each (..., T, n))."""
    speed = _moving_mean(fields["u"][..., 0], int(round(SPEED_WINDOW_S * SAMPLE_RATE_HZ)))
    cols = [speed if name == "speed" else fields[key][..., col] for name, (key, col) in CHANNELS.items()]
    return np.stack(cols, axis=-1)


def label_values(rec: Recording) -> np.ndarray:
    """(T, n_channels) true values of :data:`CHANNELS` from ``rec``'s labels (NaN where absent)."""
    lab = rec.labels
    if lab is None:
        raise UncertaintyError(f"{rec.name}: no labels; the uncertainty is calibrated and checked on labelled recordings")
    out = np.full((rec.n_samples, len(CHANNELS)), np.nan)
    have = set(lab.columns())
    for k, (name, (key, _)) in enumerate(CHANNELS.items()):
        if key == "speed":
            if "speed" in have:
                out[:, k] = _moving_mean(lab.column("speed"), int(round(SPEED_WINDOW_S * SAMPLE_RATE_HZ)))
        elif name in have:
            out[:, k] = lab.column(name)
    return out


@torch.no_grad()
def spread(network: SSPINNposeNet, rec: Recording, segments: tuple[str, ...], passes: int = 16, seed: int = 0) -> np.ndarray:
    """(T, n_channels) standard deviation of :data:`CHANNELS` over ``passes`` runs of the network
    with its dropout on (the random draws seeded by ``seed``; the global random state is left as it was)."""
    if network.config.dropout <= 0 or network.config.layers < 2:
        raise UncertaintyError("the model has no dropout (NetworkConfig.dropout > 0 with 2 or more LSTM layers): "
                               "Monte Carlo dropout has nothing to vary; train with dropout to get an uncertainty")
    if passes < 2:
        raise UncertaintyError(f"passes must be >= 2, got {passes}")
    inputs = network_inputs(network, rec, segments)
    body = BodyParameters.from_anthropometry(rec.height, rec.mass)
    was_training = network.training
    x = inputs.x.expand(passes, -1, -1)
    present = None if inputs.present is None else inputs.present.expand(passes, -1)
    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(seed)
        network.train()
        try:
            raw, _ = network(x, present=present)
        finally:
            network.train(was_training)
    fields = {k: v.cpu().numpy() for k, v in physical_outputs(raw.cpu(), body, network.config.grf).items()}
    return np.maximum(channel_values(fields).std(axis=0), MIN_SPREAD)


@dataclass
class UncertaintyCalibration:
    """k_c per channel (:data:`CHANNELS`) for a ``level`` interval, and what it was fitted on.

    Attributes:
        model_sha256: the model file it belongs to.
        level: the intervals' nominal coverage (0.9: 90 %).
        passes, seed: Monte Carlo dropout runs and their seed.
        factor: channel → k_c (interval half-width = k_c·σ).
        fitted_on: recording names; n_samples: samples per channel used.
        checked: optional coverage on held-out recordings (:func:`coverage`), as written by
            ``sspinn calibrate-uncertainty --check``.
    """

    model_sha256: str
    level: float
    passes: int
    seed: int
    factor: dict[str, float]
    fitted_on: list[str]
    n_samples: dict[str, int]
    checked: dict[str, Any] = field(default_factory=dict)

    def to_json(self) -> str:
        return calibration_files.to_json(asdict(self), FORMAT, VERSION, indent=1, allow_nan=False)

    @classmethod
    def from_json(cls, text: str, source: str) -> UncertaintyCalibration:
        try:
            cal = cls(**calibration_files.fields_of(text, FORMAT, VERSION))
            if set(cal.factor) != set(CHANNELS):
                raise ValueError(f"channels {sorted(cal.factor)} are not {sorted(CHANNELS)}")
            if not all(isinstance(v, (int, float)) and math.isfinite(v) and v > 0 for v in cal.factor.values()):
                raise ValueError("a factor is missing, not finite or not positive")
            if not 0 < cal.level < 1 or cal.passes < 2:
                raise ValueError(f"level {cal.level!r} or passes {cal.passes!r} out of range")
            return cal
        except (ValueError, TypeError) as exc:
            raise UncertaintyError(f"{source}: not a usable uncertainty calibration ({exc}); write one with "
                                   "`sspinn calibrate-uncertainty`") from None

    def half_width(self, sigma: np.ndarray) -> np.ndarray:
        """(T, n_channels) interval half-widths from spreads σ (same shape)."""
        return sigma * np.array([self.factor[c] for c in CHANNELS])


def _normalised_errors(network: SSPINNposeNet, segments: tuple[str, ...], rec: Recording, estimate: GaitEstimate,
                       passes: int, seed: int) -> np.ndarray:
    """(T − SKIP, n_channels) |ŷ − y| / σ of one labelled recording (NaN where unlabelled)."""
    sigma = spread(network, rec, segments, passes, seed)
    return (np.abs(estimate_channels(estimate) - label_values(rec)) / sigma)[SKIP:]


def calibrate(network: SSPINNposeNet, segments: tuple[str, ...], model_path: str | Path, recordings: Sequence[Recording],
              estimates: Sequence[GaitEstimate], level: float = 0.9, passes: int = 16, seed: int = 0) -> UncertaintyCalibration:
    """k_c from labelled recordings that the model was not trained on and their estimates."""
    if not 0 < level < 1:
        raise UncertaintyError(f"level must be in (0, 1), got {level}")
    errors = np.concatenate([_normalised_errors(network, segments, r, e, passes, seed) for r, e in zip(recordings, estimates)])
    factor, counts = {}, {}
    for k, name in enumerate(CHANNELS):
        values = errors[:, k][np.isfinite(errors[:, k])]
        if values.size < 100:
            raise UncertaintyError(f"channel {name}: only {values.size} labelled samples to calibrate on (need 100); "
                                   "calibrate on recordings with its labels")
        # the conformal quantile: the ceil((n + 1)·level)-th smallest value
        rank = min(values.size - 1, math.ceil((values.size + 1) * level) - 1)
        factor[name] = float(np.partition(values, rank)[rank])
        counts[name] = int(values.size)
    return UncertaintyCalibration(model_sha256=calibration_files.file_sha256(model_path), level=level, passes=passes, seed=seed, factor=factor,
                                  fitted_on=[r.name for r in recordings], n_samples=counts)


def intervals(cal: UncertaintyCalibration, network: SSPINNposeNet, segments: tuple[str, ...], rec: Recording) -> np.ndarray:
    """(T, n_channels) half-widths of the calibrated intervals of ``rec``'s estimate (units of :data:`CHANNELS`)."""
    return cal.half_width(spread(network, rec, segments, cal.passes, cal.seed))


def estimate_channels(estimate: GaitEstimate) -> np.ndarray:
    """(T, n_channels) the estimate's values of :data:`CHANNELS` (the centres of the intervals)."""
    return channel_values({"q": estimate.q, "u": estimate.u, "tau": estimate.tau, "grf": estimate.grf})


def coverage(estimates: Sequence[GaitEstimate], recordings: Sequence[Recording], half_widths: Sequence[np.ndarray],
             programs: Sequence[str], skip: int = SKIP) -> dict[str, dict[str, float]]:
    """Fraction of labelled samples (after ``skip``) inside their interval, per program (and
    "all" with several) and channel group (:data:`GROUPS`)."""
    inside: dict[str, list[np.ndarray]] = {}
    for est, rec, hw, program in zip(estimates, recordings, half_widths, programs):
        err = np.abs(estimate_channels(est) - label_values(rec))[skip:]
        hit = np.where(np.isfinite(err), err <= hw[skip:], np.nan)
        inside.setdefault(program, []).append(hit)
        if len(set(programs)) > 1:
            inside.setdefault("all", []).append(hit)
    names = list(CHANNELS)
    out: dict[str, dict[str, float]] = {}
    for program, hits in inside.items():
        stacked = np.concatenate(hits)
        out[program] = {}
        for group, channels in GROUPS.items():
            cols = stacked[:, [names.index(c) for c in channels]]
            cols = cols[np.isfinite(cols)]
            out[program][group] = float(cols.mean()) if cols.size else float("nan")
    return out


#: Units of :func:`median_half_widths` per channel group, with the scale from the channel's own
#: units (rad, N·m, N, m/s): body weight (BW) = mass·g, BW·BH = mass·g·height.
HALF_WIDTH_UNITS: Final[dict[str, str]] = {"angles": "°", "torques": "%BW·BH", "GRF": "%BW", "speed": "m/s",
                                           "pelvis velocity": "m/s"}


def median_half_widths(recordings: Sequence[Recording], half_widths: Sequence[np.ndarray], programs: Sequence[str],
                       skip: int = SKIP) -> dict[str, dict[str, float]]:
    """Median interval half-width per program (and "all" with several) and channel group, in
    :data:`HALF_WIDTH_UNITS` (degrees, %BW·BH, %BW, m/s), over the samples after ``skip``."""
    names = list(CHANNELS)
    widths: dict[str, dict[str, list[np.ndarray]]] = {}
    for rec, hw, program in zip(recordings, half_widths, programs):
        bw = rec.mass * GRAVITY
        scale = {"angles": 180.0 / math.pi, "torques": 100.0 / (bw * rec.height), "GRF": 100.0 / bw, "speed": 1.0,
                 "pelvis velocity": 1.0}
        for key in {program, "all"} if len(set(programs)) > 1 else {program}:
            for group, channels in GROUPS.items():
                cols = hw[skip:, [names.index(c) for c in channels]] * scale[group]
                widths.setdefault(key, {}).setdefault(group, []).append(cols.ravel())
    return {key: {group: float(np.median(np.concatenate(parts))) for group, parts in groups.items()}
            for key, groups in widths.items()}


def calibration_path(model_path: str | Path) -> Path:
    """Where a model's uncertainty calibration lives by default: ``<model>.uncertainty.json`` beside it."""
    return calibration_files.beside(model_path, "uncertainty")


def load_calibration(path: str | Path, model_path: str | Path) -> UncertaintyCalibration:
    """The calibration at ``path``; :class:`UncertaintyError` if it is malformed or belongs to another model file."""
    return calibration_files.load_for_model(path, model_path, UncertaintyCalibration.from_json, lambda cal: cal.model_sha256,
                                            UncertaintyError, "uncertainty", "sspinn calibrate-uncertainty")


def save_calibration(cal: UncertaintyCalibration, path: str | Path) -> Path:
    """Write the calibration file atomically."""
    return atomic_write_text(path, cal.to_json() + "\n")


def write_intervals(path: str | Path, time: np.ndarray, half_width: np.ndarray, level: float) -> Path:
    """``<rec>_uncertainty.csv``: time and, per channel, the half-width of its ``level``
    interval (columns ``<channel>_pm<level %>``; units of the estimate's columns: rad, N·m, N,
    m/s); atomically, refused if a value is not finite."""
    if not np.isfinite(half_width).all():
        raise UncertaintyError(f"{path}: an interval is not finite; nothing written")
    tag = f"_pm{round(100 * level)}"
    header = ",".join(["time", *(c + tag for c in CHANNELS)])
    path = Path(path)
    with atomic_path(path) as tmp:
        np.savetxt(tmp, np.column_stack([time, half_width]), delimiter=",", header=header, comments="", fmt="%.7g")
    return path
