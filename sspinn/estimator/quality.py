"""How far to trust an estimate: per-window self-supervised losses on the recording itself, a
threshold calibrated where the truth is known, and the training data's input ranges.

The self-supervised loss terms (:mod:`sspinn.estimator.losses`) need no labels, so they can be
evaluated on any new recording and its estimate, window by window (:func:`window_quality`,
:data:`WINDOW_S` windows that tile the recording):

* ``imu`` — L_IMU: the estimate's virtual IMU signals against the measured ones (the model's
  channel scales);
* ``kane`` — L_K: the equations-of-motion residual of the estimated motion, torques and forces;
* ``stance`` — L_S: a loaded foot of the estimated body neither slides nor floats (contact
  consistency on the body model's own feet);
* ``contact`` — L_GC (paper networks only, ``grf: contact_model``): the separately estimated
  ankles against the forward kinematics;
* ``temporal`` — L_T: the estimated rates and accelerations against the derivatives of the
  estimated coordinates and rates.

Each is unweighted (λ = 1) and dimensionless. The **score** of a window is the mean over the
terms of log10(term / the term's median over the calibration windows) — 0 for a window as
consistent as the typical calibration window, +1 for one whose terms are ten times larger (in
the geometric mean). Without a calibration the terms are written and no score.

**Calibration** (:func:`calibrate`, ``sspinn calibrate-quality``) runs the model over labelled
recordings (by default a dataset's training split: data whose IMU signals the model saw, never
the held-out subjects it is evaluated on), computes each window's error against the labels
(:func:`window_errors`: joint-angle RMSE in degrees and GRF RMSE in %BW, combined as the mean of
each divided by its median over the calibration windows, :data:`ERROR`), and chooses the score
threshold that best separates the windows whose error exceeds the calibration windows' 90th
percentile (the largest F1 score of "score > threshold" as a detector of those windows). It
also stores the ranges of the inputs (:data:`INPUTS`: body height and mass, cadence from the
leg gyroscopes, each window's labelled forward speed) of the recordings the model was trained on
where the calibration data hold them (else of the calibration recordings, and the warnings say
so), with which :func:`input_findings` compares a new recording (its speed: the estimated one of
each window): a threshold calibrated on held-out subjects still judges the inputs against the
training data. The calibration is a small JSON file beside the model (:func:`calibration_path`),
tied to the model file by its SHA-256.
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
from sspinn.data.signal_checks import gait_rhythm
from sspinn.errors import InputWarning, UserError
from sspinn.estimator import calibration_files
from sspinn.estimator.inference import GaitEstimate, network_inputs
from sspinn.estimator.losses import Batch, LossWeights, PhysicsLosses
from sspinn.estimator.network import SSPINNposeNet, decode, output_affine
from sspinn.estimator.zupt import speed_with_rests
from sspinn.model.body import BodyParameters, JointLimits
from sspinn.model.conventions import COORDINATES, GRAVITY
from sspinn.run_folder import atomic_write_text

#: Length of a quality window, s (the last windows absorb the remainder: windows tile the recording).
WINDOW_S = 2.0
#: The loss terms of the score, for each kind of network (``NetworkConfig.grf``).
QUALITY_TERMS: dict[str, tuple[str, ...]] = {
    "direct": ("imu", "kane", "stance", "temporal"),
    "two_point": ("imu", "kane", "stance", "temporal"),
    "contact_model": ("imu", "kane", "stance", "contact", "temporal"),
}
#: The per-window error that calibration predicts: mean of the joint-angle RMSE and the GRF
#: RMSE, each divided by its median over the calibration windows.
ERROR = "relative error: mean of joint-angle RMSE / its median and GRF RMSE / its median"
#: The share of calibration windows counted as large errors (those above this quantile).
ERROR_QUANTILE = 0.9
#: Inputs compared with the calibration data's ranges: name → unit.
INPUTS: dict[str, str] = {"height_m": "m", "mass_kg": "kg", "cadence_steps_min": "steps/min", "speed_m_s": "m/s"}
#: How the warnings name the inputs.
INPUT_LABELS: dict[str, str] = {"height_m": "height", "mass_kg": "mass", "cadence_steps_min": "cadence", "speed_m_s": "estimated speed"}
#: Whose inputs a calibration's ranges span → how the warnings name them.
RANGES_FROM: Final = {"training": "trained", "calibration": "calibrated"}
#: Calibration file format (JSON).
CALIBRATION_FORMAT = "sspinn-quality-calibration"
CALIBRATION_VERSION = 1
#: A term below this is taken as this (log10 of an exact 0).
TERM_FLOOR = 1e-12


class QualityCalibrationError(UserError):
    """A quality calibration file is malformed, or calibration data cannot calibrate."""


#: Fewest calibration windows for a meaningful threshold (``sspinn calibrate-quality`` warns below):
#: with the 10 % largest errors as the positives, 20 windows hold two of them.
MIN_CALIBRATION_WINDOWS: Final = 20


class QualityWarning(InputWarning):
    """An estimate with windows flagged as unreliable, or a recording outside the calibration data."""


@dataclass
class WindowQuality:
    """The quality of one recording's estimate, per window.

    Attributes:
        name: the recording.
        start, stop: (n,) sample indices of each window ([start, stop)).
        terms: unweighted loss term → (n,) value per window (dimensionless, see the module docstring).
        speed: (n,) mean estimated forward speed per window, m/s (0 where the whole body rests,
            as in the estimate: :func:`~sspinn.estimator.inference.estimate_recording`).
        score: (n,) combined score (None without a calibration).
        flagged: (n,) bool, score above the calibrated threshold (None without a calibration).
        rest: (n,) share of each window's samples at which the whole body rests (0–1;
            :func:`~sspinn.estimator.zupt.whole_body_still`), or None when not computed.
    """

    name: str
    start: np.ndarray
    stop: np.ndarray
    terms: dict[str, np.ndarray]
    speed: np.ndarray
    score: np.ndarray | None = None
    flagged: np.ndarray | None = None
    rest: np.ndarray | None = None

    @property
    def n_windows(self) -> int:
        return len(self.start)

    @property
    def flag_rate(self) -> float:
        """Share of flagged windows (NaN without a calibration)."""
        return float("nan") if self.flagged is None else float(np.mean(self.flagged))

    def to_csv(self, path: str | Path) -> Path:
        """Write one row per window (start_s, end_s, the terms, speed, score, flagged), atomically."""
        cols: dict[str, np.ndarray] = {"start_s": self.start / SAMPLE_RATE_HZ, "end_s": self.stop / SAMPLE_RATE_HZ,
                                       **self.terms, "speed_m_s": self.speed}
        if self.rest is not None:
            cols["rest_share"] = self.rest
        if self.score is not None and self.flagged is not None:
            cols |= {"score": self.score, "flagged": self.flagged.astype(float)}
        rows = ["window," + ",".join(cols)]
        for k in range(self.n_windows):
            rows.append(f"{k}," + ",".join(f"{cols[c][k]:.7g}" if c != "flagged" else str(int(cols[c][k])) for c in cols))
        return atomic_write_text(path, "\n".join(rows) + "\n")


def windows(n_samples: int, window_s: float = WINDOW_S) -> tuple[np.ndarray, np.ndarray]:
    """(start, stop) of the windows tiling ``n_samples`` samples: max(1, n // W) windows of
    W = ``window_s`` · 100 Hz samples or a little more (the remainder is spread over them)."""
    n_w = max(1, n_samples // max(1, int(round(window_s * SAMPLE_RATE_HZ))))
    edges = np.round(np.linspace(0, n_samples, n_w + 1)).astype(int)
    return edges[:-1], edges[1:]


def quality_losses(grf: str, joint_limits: str) -> PhysicsLosses:
    """The unweighted losses of a network of kind ``grf`` trained with ``joint_limits``."""
    return PhysicsLosses(LossWeights.unit(), limits=JointLimits.named(joint_limits), grf=grf)


@torch.no_grad()
def window_quality(
    network: SSPINNposeNet, rec: Recording, segments: tuple[str, ...], imu_std: torch.Tensor, joint_limits: str = "paper",
    window_s: float = WINDOW_S,
) -> WindowQuality:
    """The loss terms (:data:`QUALITY_TERMS`) of the model's estimate of ``rec`` on each window
    (the network runs over the whole recording, as for the estimate; the terms are then taken
    window by window, float64). ``imu_std`` is the model's IMU channel scales (its training's),
    ``joint_limits`` its training's (``TrainConfig.joint_limits``). Needs no labels. For a model
    with presence inputs and a recording with a subset of its IMUs, L_IMU compares the IMUs
    the recording has."""
    grf = network.config.grf
    network.eval()
    placement = rec.placement.vector()
    inputs = network_inputs(network, rec, segments, placement)
    rec = inputs.recording
    imu_std = imu_std[[segments.index(s) for s in rec.segments]]
    segments = rec.segments
    raw, _ = network(inputs.x, present=inputs.present)
    raw = raw.detach().cpu().double()
    body = BodyParameters.from_anthropometry(rec.height, rec.mass)
    scale, offset = output_affine(rec.height, rec.mass, body.standing_hip_height, body.gravity, grf)
    scale_t, offset_t = torch.as_tensor(scale)[None], torch.as_tensor(offset)[None]
    losses = quality_losses(grf, joint_limits)
    names = QUALITY_TERMS[grf]
    start, stop = windows(rec.n_samples, window_s)
    terms = {k: np.empty(len(start)) for k in names}
    vx = np.empty(rec.n_samples)

    def t(a: Any) -> torch.Tensor:
        return torch.as_tensor(np.asarray(a), dtype=torch.float64)

    for w, (a, b) in enumerate(zip(start, stop)):
        est = decode(raw[:, a:b], scale_t, offset_t, 1.0 / SAMPLE_RATE_HZ, grf)
        batch = Batch(imu=t(rec.imu[a:b])[None], imu_std=imu_std.double().cpu(), segments=segments, p=t(body.vector())[None],
                      height=t([rec.height]), mass=t([rec.mass]), placement=t(placement)[None], dt=1.0 / SAMPLE_RATE_HZ)
        values = losses.terms(est, batch)
        for k in names:
            terms[k][w] = float(values[k])
        vx[a:b] = est.u[0, :, 0].numpy()
    vx, still = speed_with_rests(vx, rec.imu, SAMPLE_RATE_HZ)  # the speed the estimate reports
    speed = np.array([vx[a:b].mean() for a, b in zip(start, stop)])
    rest = np.array([still[a:b].mean() for a, b in zip(start, stop)])
    return WindowQuality(rec.name, start, stop, terms, speed, rest=rest)


def window_errors(estimate: GaitEstimate, rec: Recording, start: np.ndarray, stop: np.ndarray) -> dict[str, np.ndarray]:
    """Per window, against ``rec``'s labels: ``jae_deg`` (RMSE of the pelvis tilt and joint
    angles, degrees) and ``grfe_pct_bw`` (RMSE of the four GRF components, %BW), each pooled over
    the window's samples and the labelled columns (NaN where the labels have none)."""
    lab = rec.labels
    if lab is None:
        raise QualityCalibrationError(f"{rec.name}: no labels; calibration needs labelled recordings (e.g. a synthetic dataset)")
    out = {"jae_deg": np.full(len(start), np.nan), "grfe_pct_bw": np.full(len(start), np.nan)}
    angles = slice(COORDINATES.index("pelvis_tilt"), None)
    for w, (a, b) in enumerate(zip(start, stop)):
        if lab.q is not None:
            d = estimate.q[a:b, angles] - lab.q[a:b, angles]
            if np.isfinite(d).any():
                out["jae_deg"][w] = math.degrees(float(np.sqrt(np.nanmean(d**2))))
        if lab.grf is not None:
            d = estimate.grf[a:b] - lab.grf[a:b]
            if np.isfinite(d).any():
                out["grfe_pct_bw"][w] = 100 * float(np.sqrt(np.nanmean(d**2))) / (rec.mass * GRAVITY)
    return out


def cadence(rec: Recording) -> float:
    """Steps per minute from the leg gyroscopes' stride period (:func:`sspinn.data.signal_checks.gait_rhythm`);
    NaN for a recording too short or without gait."""
    rhythm = gait_rhythm(rec.imu, rec.segments)
    return float("nan") if rhythm is None else 120.0 / rhythm.period_s


# ------------------------------------------------------------------------------------ calibration
@dataclass
class QualityCalibration:
    """What :func:`calibrate` measured, as stored in the calibration file.

    Attributes:
        model_sha256: SHA-256 of the model file it belongs to.
        grf: the network's kind (which terms are scored, :data:`QUALITY_TERMS`).
        window_s: the window length, s.
        term_median: each term's median over the calibration windows (the score's unit).
        threshold: a window whose score exceeds it is flagged.
        error_median: median JAE (deg) and GRFE (%BW) over the calibration windows.
        error_threshold: the relative error above which a calibration window counts as a large
            error (its :data:`ERROR_QUANTILE` quantile).
        input_ranges: input name (:data:`INPUTS`) → [min, max] over the recordings named by
            ``ranges_from`` (speed: over their windows, labelled; the estimated speed where there
            is no label).
        calibrated_on: names of the calibration recordings.
        source: where they came from (a dataset folder and its splits).
        fit: the calibration windows' detection figures (precision, recall, F1, flag rate).
        ranges_from: whose inputs ``input_ranges`` spans: ``"training"`` (the recordings the
            model was trained on) or ``"calibration"`` (the calibration recordings: the model's
            training recordings were not at hand).
    """

    model_sha256: str
    grf: str
    window_s: float
    term_median: dict[str, float]
    threshold: float
    error_median: dict[str, float]
    error_threshold: float
    input_ranges: dict[str, list[float]]
    calibrated_on: list[str]
    source: str
    fit: dict[str, float] = field(default_factory=dict)
    ranges_from: str = "calibration"

    def score(self, terms: dict[str, np.ndarray]) -> np.ndarray:
        """Mean over the terms of log10(term / its calibration median), per window."""
        logs = [np.log10(np.maximum(terms[k], TERM_FLOOR) / max(self.term_median[k], TERM_FLOOR)) for k in self.term_median]
        return np.mean(logs, axis=0)

    def apply(self, quality: WindowQuality) -> WindowQuality:
        """``quality`` with its score and flags filled in."""
        quality.score = self.score(quality.terms)
        quality.flagged = quality.score > self.threshold
        return quality

    def relative_error(self, errors: dict[str, np.ndarray]) -> np.ndarray:
        """:data:`ERROR` of per-window errors (:func:`window_errors`)."""
        return 0.5 * (errors["jae_deg"] / self.error_median["jae_deg"] + errors["grfe_pct_bw"] / self.error_median["grfe_pct_bw"])

    def to_json(self) -> str:
        return calibration_files.to_json(asdict(self), CALIBRATION_FORMAT, CALIBRATION_VERSION, indent=2)

    @classmethod
    def from_json(cls, text: str, source: str) -> QualityCalibration:
        try:
            cal = cls(**calibration_files.fields_of(text, CALIBRATION_FORMAT, CALIBRATION_VERSION))
            if cal.grf not in QUALITY_TERMS or set(cal.term_median) != set(QUALITY_TERMS[cal.grf]):
                raise ValueError(f"terms {sorted(cal.term_median)} do not fit a {cal.grf!r} network")
            numbers = [cal.window_s, cal.threshold, cal.error_threshold, *cal.term_median.values(), *cal.error_median.values()]
            if not all(isinstance(v, (int, float)) and math.isfinite(v) for v in numbers) or cal.window_s <= 0:
                raise ValueError("a number is missing, not finite or not positive")
            if cal.ranges_from not in RANGES_FROM:
                raise ValueError(f"ranges_from {cal.ranges_from!r} is not one of {list(RANGES_FROM)}")
            for name, bounds in cal.input_ranges.items():
                if name not in INPUTS or len(bounds) != 2:
                    raise ValueError(f"input range {name!r}: {bounds!r}")
            return cal
        except (ValueError, TypeError) as exc:
            raise QualityCalibrationError(
                f"{source}: not a usable quality calibration ({exc}); write one with `sspinn calibrate-quality`") from None


def calibration_path(model_path: str | Path) -> Path:
    """Where a model's calibration lives by default: ``<model>.quality.json`` beside it."""
    return calibration_files.beside(model_path, "quality")


def load_calibration(path: str | Path, model_path: str | Path) -> QualityCalibration:
    """The calibration at ``path``; :class:`QualityCalibrationError` if it is malformed or belongs
    to another model file than ``model_path``."""
    return calibration_files.load_for_model(path, model_path, QualityCalibration.from_json, lambda cal: cal.model_sha256,
                                            QualityCalibrationError, "quality", "sspinn calibrate-quality")


def best_threshold(score: np.ndarray, large: np.ndarray) -> tuple[float, dict[str, float]]:
    """The threshold t of "score > t" with the largest F1 score as a detector of ``large``
    (bool), over the midpoints between sorted scores (ties: the higher t), and its figures."""
    order = np.sort(np.unique(score))
    candidates = np.concatenate([(order[:-1] + order[1:]) / 2, [order[-1]]]) if len(order) > 1 else order
    best, best_f1 = float(order[-1]), -1.0
    for t in candidates:
        flagged = score > t
        tp = float(np.sum(flagged & large))
        f1 = 2 * tp / (flagged.sum() + large.sum()) if flagged.sum() + large.sum() else 0.0
        if f1 >= best_f1:
            best, best_f1 = float(t), f1
    flagged = score > best
    tp = float(np.sum(flagged & large))
    return best, {"f1": best_f1, "precision": tp / max(1, flagged.sum()), "recall": tp / max(1, large.sum()),
                  "flag_rate": float(flagged.mean()), "n_windows": float(len(score))}


def calibrate(
    network: SSPINNposeNet, segments: tuple[str, ...], imu_std: torch.Tensor, joint_limits: str, recordings: Sequence[Recording],
    estimates: Sequence[GaitEstimate], model_path: str | Path, source: str, window_s: float = WINDOW_S,
    training: Sequence[Recording] = (),
) -> tuple[QualityCalibration, list[WindowQuality], list[dict[str, np.ndarray]]]:
    """Calibrate the score threshold on labelled ``recordings`` and the model's ``estimates`` of
    them (module docstring), and the input ranges on the model's ``training`` recordings (on
    ``recordings`` when none are given); also returns every calibration recording's window
    quality (scored) and errors."""
    if not recordings:
        raise QualityCalibrationError(f"{source}: no recordings to calibrate on")
    qualities = [window_quality(network, r, segments, imu_std, joint_limits, window_s) for r in recordings]
    errors = [window_errors(e, r, q.start, q.stop) for e, r, q in zip(estimates, recordings, qualities)]
    jae = np.concatenate([e["jae_deg"] for e in errors])
    grfe = np.concatenate([e["grfe_pct_bw"] for e in errors])
    if not (np.isfinite(jae).all() and np.isfinite(grfe).all()):
        raise QualityCalibrationError(f"{source}: calibration needs joint-angle and GRF labels on every recording")
    grf = network.config.grf
    term_median = {k: float(np.median(np.concatenate([q.terms[k] for q in qualities]))) for k in QUALITY_TERMS[grf]}
    if training:
        ranges = input_ranges(training, [window_quality(network, r, segments, imu_std, joint_limits, window_s)
                                         if r.labels is None or r.labels.speed is None else None for r in training], window_s)
    else:
        ranges = input_ranges(recordings, qualities, window_s)
    cal = QualityCalibration(
        model_sha256=calibration_files.file_sha256(model_path), grf=grf, window_s=window_s, term_median=term_median, threshold=0.0,
        error_median={"jae_deg": float(np.median(jae)), "grfe_pct_bw": float(np.median(grfe))}, error_threshold=0.0,
        input_ranges=ranges, calibrated_on=[r.name for r in recordings], source=source,
        ranges_from="training" if training else "calibration",
    )
    for q in qualities:
        cal.apply(q)
    score = np.concatenate([q.score for q in qualities if q.score is not None])
    rel = cal.relative_error({"jae_deg": jae, "grfe_pct_bw": grfe})
    cal.error_threshold = float(np.quantile(rel, ERROR_QUANTILE))
    cal.threshold, cal.fit = best_threshold(score, rel > cal.error_threshold)
    for q in qualities:
        cal.apply(q)
    return cal, qualities, errors


def input_ranges(recordings: Sequence[Recording], qualities: Sequence[WindowQuality | None],
                 window_s: float = WINDOW_S) -> dict[str, list[float]]:
    """[min, max] of each :data:`INPUTS` over ``recordings``: height, mass, cadence, and the
    labelled speed of each :data:`WINDOW_S` window (the window's estimated speed from its
    ``qualities`` entry where a recording has no speed label; None where it has one)."""
    speeds = []
    for rec, quality in zip(recordings, qualities):
        if rec.labels is not None and rec.labels.speed is not None:
            start, stop = windows(rec.n_samples, window_s)
            speeds.append(np.array([float(np.mean(rec.labels.speed[a:b])) for a, b in zip(start, stop)]))
        elif quality is not None:
            speeds.append(quality.speed)
    ranges = {"height_m": [min(r.height for r in recordings), max(r.height for r in recordings)],
              "mass_kg": [min(r.mass for r in recordings), max(r.mass for r in recordings)]}
    speed = np.concatenate(speeds) if speeds else np.zeros(0)
    speed = speed[np.isfinite(speed)]
    if len(speed):
        ranges["speed_m_s"] = [float(speed.min()), float(speed.max())]
    cadences = np.array([cadence(r) for r in recordings])
    cadences = cadences[np.isfinite(cadences)]
    if len(cadences):
        ranges["cadence_steps_min"] = [float(cadences.min()), float(cadences.max())]
    return ranges


def training_recordings(candidates: Sequence[Recording], trained_on: Sequence[str]) -> list[Recording]:
    """The recordings among ``candidates`` that a model was trained on (its ``trained_on``
    names), or none unless every one of them is there (a partial set would narrow the ranges)."""
    by_name = {r.name: r for r in candidates}
    if not trained_on or any(name not in by_name for name in trained_on):
        return []
    return [by_name[name] for name in dict.fromkeys(trained_on)]


def save_calibration(cal: QualityCalibration, path: str | Path) -> Path:
    """Write the calibration file atomically."""
    return atomic_write_text(path, cal.to_json() + "\n")


# ------------------------------------------------------------------------------------ inputs
def recording_inputs(rec: Recording, quality: WindowQuality) -> dict[str, np.ndarray]:
    """The :data:`INPUTS` of a recording: height, mass and cadence (one value each) and the
    estimated speed of each window."""
    return {"height_m": np.array([rec.height]), "mass_kg": np.array([rec.mass]), "cadence_steps_min": np.array([cadence(rec)]),
            "speed_m_s": quality.speed}


def input_findings(rec: Recording, quality: WindowQuality, cal: QualityCalibration, model: str) -> list[str]:
    """One line naming the recording and each input outside the range stored in the calibration
    (the model's training recordings' or the calibration recordings', ``cal.ranges_from``; none
    if all lie inside); an input the calibration has no range for is not judged."""
    parts = []
    resting = quality.rest >= 0.5 if quality.rest is not None else np.zeros(quality.n_windows, dtype=bool)
    for name, values in recording_inputs(rec, quality).items():
        if name not in cal.input_ranges:
            continue
        lo, hi = cal.input_ranges[name]
        if name == "speed_m_s" and resting.any():  # a rest's speed is 0 by the rest, not an extrapolated one
            values = values[~resting]
            if lo > 0:
                parts.append(f"the whole body rests in {int(resting.sum())} of {quality.n_windows} windows (speed 0 there; the "
                             f"recordings it was {RANGES_FROM[cal.ranges_from]} on never rest, so its angles and forces there "
                             "are extrapolated)")
        finite = values[np.isfinite(values)]
        outside = (finite < lo) | (finite > hi)
        if not outside.any():
            continue
        label, unit = INPUT_LABELS[name], INPUTS[name]
        what = (f"{label} {finite[0]:.3g} {unit}" if len(values) == 1
                else f"{label} {np.median(finite):.3g} {unit} (median; {np.mean(outside):.0%} of windows outside)")
        parts.append(f"{what} outside their range {lo:.3g}–{hi:.3g} {unit}")
    if not parts:
        return []
    return [f"{rec.name}: its inputs lie outside those of the recordings {model} was {RANGES_FROM[cal.ranges_from]} on: " + "; ".join(parts)
            + ": the estimate is an extrapolation; treat it with care"]


def flag_findings(quality: WindowQuality, cal: QualityCalibration, where: str) -> list[str]:
    """One line naming the recording and its share of flagged windows (none if no window is
    flagged); ``where`` names the quality file."""
    if quality.flagged is None or not quality.flagged.any():
        return []
    k = int(quality.flagged.sum())
    return [f"{quality.name}: {k} of {quality.n_windows} windows ({k / quality.n_windows:.0%}) flagged as unreliable "
            f"(quality score above {cal.threshold:.3g}; calibrated on {len(cal.calibrated_on)} labelled recordings, "
            f"where {cal.fit.get('precision', float('nan')):.0%} of the flagged windows had a large error): see {where}"]
