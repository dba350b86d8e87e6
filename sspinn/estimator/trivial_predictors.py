"""Trivial predictors: what every accuracy figure must beat.

An estimator's error means little without what a predictor that ignores the IMU data scores on
the same recordings. :class:`TrivialPredictor` predicts, for every sample,

* **zero torque** at every joint (JTE baseline),
* the **mean posture** (the mean of each angle and pelvis tilt, rad; JAE baseline),
* a **constant mean GRF** per GRF column, in body weights, times the recording's body weight
  (GRFE baseline),
* the **mean speed**, m/s (speed-error baseline),

with the means taken over the labelled *reference* recordings — the training data's labels, the
fair choice — per gait program (``walk``/``run``, from the recordings' provenance) when the
reference has recordings of that program, else over all of them. Beside the mean speed,
:meth:`TrivialPredictor.predict` with ``speed="froude"`` gives the **Froude speed**
``sqrt(Fr · g · L)``: the reference recordings' mean Froude number Fr (dimensionless, per
program) at the evaluated recording's own leg length L (m, :func:`leg_length`) — what a
predictor that knows only the subject's height says, since people of similar build walk at
similar Froude numbers.

A model file stores the predictor fitted on its training recordings (:meth:`TrivialPredictor.to_dict`,
plain numbers and strings; :mod:`sspinn.estimator.model_store`), so evaluation compares with the
model's own training data wherever the evaluated recordings come from. Without it, the training
split found next to the evaluated data is used; when no labelled training data exist,
:meth:`TrivialPredictor.fit` on the evaluated recordings themselves gives an *oracle* baseline
(it knows the test means; harder to beat), and says so in ``source``. :func:`reference_predictor`
picks between the three and labels the result by what it was fitted on (reference data that hold
the evaluated recordings are an oracle too).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from sspinn.data.dataset import SAMPLE_RATE_HZ, Recording
from sspinn.data.gait_events import detect_events, normalise_cycles, strides
from sspinn.estimator.inference import GaitEstimate
from sspinn.model.body import BodyParameters
from sspinn.model.conventions import COORDINATES, GRAVITY, GRF, N_Q, N_TAU

#: Program name of recordings whose provenance names none.
ALL: str = "all"


def program_of(rec: Recording, from_name: bool = False) -> str:
    """The recording's gait program (``provenance['program']['name']``, e.g. "walk", "run"),
    else :data:`ALL` — or, with ``from_name``, the last ``_``-separated part of the recording's
    name (an imported trial's condition, e.g. "CSBaseline" of "Sub05_CSBaseline")."""
    program = rec.provenance.get("program") if isinstance(rec.provenance, dict) else None
    name = program.get("name") if isinstance(program, dict) else None
    if name:
        return str(name)
    return rec.name.rsplit("_", 1)[-1] if from_name else ALL


def leg_length(rec: Recording) -> float:
    """Leg length (m) of the body the estimator assumes for ``rec``: the standing hip height
    (femur + tibia + ankle height) of :meth:`~sspinn.model.body.BodyParameters.from_anthropometry`
    at the recording's height and mass (Winter's proportions: 0.53 × height)."""
    return BodyParameters.from_anthropometry(rec.height, rec.mass).standing_hip_height


@dataclass(frozen=True)
class ProgramMeans:
    """Means of one program's reference labels: ``q`` (9,) coordinate means (m, rad; only the
    angles and pelvis tilt are used), ``grf_bw`` (4,) mean GRF in body weights, ``speed`` (m/s),
    the number of samples they come from, and ``froude``: the mean Froude number
    (dimensionless), ``(mean of v / sqrt(g · L))²`` over the speed samples with L each
    recording's :func:`leg_length` — the Froude number of the mean dimensionless speed, so that
    on legs of one length the Froude speed is the mean speed exactly (a mean of v²/(g·L) would
    add the speed's variance); NaN without speed labels."""

    q: np.ndarray
    grf_bw: np.ndarray
    speed: float
    n_samples: int
    froude: float = float("nan")

    def froude_speed(self, leg: float) -> float:
        """``sqrt(froude · g · leg)``, m/s, for a leg length ``leg`` (m)."""
        return math.sqrt(self.froude * GRAVITY * leg)


#: What ``speed`` of :meth:`TrivialPredictor.predict` accepts.
SPEED_BASELINES: tuple[str, ...] = ("mean", "froude")


@dataclass(frozen=True)
class TrivialPredictor:
    """Per-program label means (see the module docstring); ``source`` says where they come from,
    ``fitted_on`` names the recordings whose labels they are (to tell a fair baseline from an
    oracle)."""

    means: dict[str, ProgramMeans]
    source: str
    fitted_on: tuple[str, ...] = ()

    @classmethod
    def fit(cls, recordings: Sequence[Recording], source: str) -> TrivialPredictor:
        """Means of the labels of ``recordings`` per program (and over all, key :data:`ALL`).

        A recording needs at least one of the labels q, GRF and speed (e.g. an imported real
        recording with GRF and treadmill speed but no angles); a group no recording has gets a
        zero mean, which no metric uses (a metric needs the label it compares with).

        Raises:
            ValueError: no recording has any of the labels q, GRF and speed.
        """
        groups: dict[str, list[Recording]] = {}
        used: list[str] = []
        for rec in recordings:
            lab = rec.labels
            if lab is None or (lab.q is None and lab.grf is None and lab.speed is None):
                continue
            used.append(rec.name)
            groups.setdefault(program_of(rec), []).append(rec)
            if program_of(rec) != ALL:
                groups.setdefault(ALL, []).append(rec)
        if not groups:
            raise ValueError(f"{source}: no recording with the labels q, grf or speed to fit a trivial predictor on")
        means = {}
        for program, recs in groups.items():
            q = [r.labels.q for r in recs if r.labels.q is not None]
            grf = [r.labels.grf / (r.mass * GRAVITY) for r in recs if r.labels.grf is not None]
            speed = [r.labels.speed for r in recs if r.labels.speed is not None]
            dimensionless = [r.labels.speed / math.sqrt(GRAVITY * leg_length(r)) for r in recs if r.labels.speed is not None]
            means[program] = ProgramMeans(
                np.concatenate(q).mean(0) if q else np.zeros(N_Q),
                np.concatenate(grf).mean(0) if grf else np.zeros(len(GRF)),
                float(np.concatenate(speed).mean()) if speed else 0.0,
                sum(r.n_samples for r in recs),
                float(np.concatenate(dimensionless).mean()) ** 2 if dimensionless else float("nan"),
            )
        return cls(means, source, tuple(used))

    def means_for(self, rec: Recording) -> ProgramMeans:
        """The means used for ``rec``: its program's, else those over all reference recordings."""
        return self.means.get(program_of(rec), self.means[ALL] if ALL in self.means else next(iter(self.means.values())))

    def speed_for(self, rec: Recording, speed: str = "mean") -> float:
        """The constant speed (m/s) predicted for ``rec``: the program's mean speed
        (``"mean"``), or its Froude speed at the recording's :func:`leg_length` (``"froude"``;
        NaN when the reference had no speed labels)."""
        m = self.means_for(rec)
        if speed == "mean":
            return m.speed
        if speed == "froude":
            return m.froude_speed(leg_length(rec)) if math.isfinite(m.froude) else float("nan")
        raise ValueError(f"speed must be one of {SPEED_BASELINES}, got {speed!r}")

    def predict(self, rec: Recording, speed: str = "mean") -> GaitEstimate:
        """The trivial estimate of ``rec`` (same samples; constant in time), at the speed
        :meth:`speed_for` gives (``"mean"`` or ``"froude"``)."""
        m = self.means_for(rec)
        v = self.speed_for(rec, speed)
        T = rec.n_samples
        q = np.tile(m.q, (T, 1))
        q[:, COORDINATES.index("pelvis_tx")] = v * np.arange(T) / SAMPLE_RATE_HZ
        u = np.zeros((T, N_Q))
        u[:, 0] = v
        grf = np.tile(m.grf_bw * rec.mass * GRAVITY, (T, 1))
        assert grf.shape[1] == len(GRF)
        return GaitEstimate(
            name=f"{rec.name} (trivial)",
            time=np.arange(T) / SAMPLE_RATE_HZ,
            q=q,
            u=u,
            qdd=np.zeros((T, N_Q)),
            tau=np.zeros((T, N_TAU)),
            grf=grf,
            w=np.zeros((T, 2)),
        )

    def to_dict(self) -> dict[str, Any]:
        """The predictor as plain data (str, int, float, lists, dicts) for a model file:
        ``{"source", "fitted_on", "programs": {program: {"q", "grf_bw", "speed", "froude",
        "n_samples"}}}`` in the units of :class:`ProgramMeans`."""
        return {
            "source": self.source,
            "fitted_on": list(self.fitted_on),
            "programs": {
                program: {"q": [float(x) for x in m.q], "grf_bw": [float(x) for x in m.grf_bw], "speed": float(m.speed),
                          "froude": float(m.froude), "n_samples": int(m.n_samples)}
                for program, m in self.means.items()
            },
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> TrivialPredictor:
        """The inverse of :meth:`to_dict`. Raises ValueError naming the first malformed entry."""
        try:
            programs = data["programs"]
            means = {}
            for program, m in programs.items():
                q = np.asarray(m["q"], dtype=float)
                grf_bw = np.asarray(m["grf_bw"], dtype=float)
                if q.shape != (N_Q,) or grf_bw.shape != (len(GRF),):
                    raise ValueError(f"program {program!r}: q has shape {q.shape} (expected ({N_Q},)), "
                                     f"grf_bw {grf_bw.shape} (expected ({len(GRF)},))")
                means[str(program)] = ProgramMeans(q, grf_bw, float(m["speed"]), int(m["n_samples"]), float(m["froude"]))
            if not means:
                raise ValueError("no program")
            return cls(means, str(data["source"]), tuple(str(n) for n in data["fitted_on"]))
        except (KeyError, TypeError, AttributeError) as exc:
            raise ValueError(f"malformed trivial-predictor entry ({type(exc).__name__}: {exc})") from None


@dataclass(frozen=True)
class GRFProfilePredictor:
    """The reference recordings' mean GRF **profile** over the gait cycle, placed at a recording's
    *measured* heel strikes: a template predictor with oracle timing.

    Per foot, every stride of the reference recordings (heel strike to heel strike of that foot,
    :func:`sspinn.data.gait_events.detect_events` on the measured vertical GRF; strides of 0.3–3 s) is
    time-normalised to 101 points and divided by body weight; ``profile`` (2 feet, 101, 2: x, y)
    is their mean. :meth:`predict_grf` stretches it between the recording's own measured heel
    strikes — it ignores the IMU data but is told when each stride starts and ends, so its error
    is what the *shape* of an average stride leaves, a harder baseline than the constant mean GRF
    (:class:`TrivialPredictor`). Samples outside a complete stride get the constant mean
    (``mean_bw`` (4,), body weights). Fitted on labelled GRFs only.
    """

    profile: np.ndarray
    mean_bw: np.ndarray
    strides: int
    source: str

    @classmethod
    def fit(cls, recordings: Sequence[Recording], source: str) -> GRFProfilePredictor:
        """Mean stride profile of the recordings' GRF labels.

        Raises:
            ValueError: no recording has GRF labels with a complete stride on both feet.
        """
        cycles: list[list[np.ndarray]] = [[], []]
        means = []
        for rec in recordings:
            if rec.labels is None or rec.labels.grf is None:
                continue
            grf_bw = rec.labels.grf / (rec.mass * GRAVITY)
            means.append(grf_bw)
            for foot, cuts in enumerate(_strides(rec)):
                if cuts:
                    cycles[foot].append(np.stack([normalise_cycles(grf_bw[:, 2 * foot + k], cuts) for k in range(2)], axis=-1))
        if not cycles[0] or not cycles[1]:
            raise ValueError(f"{source}: no complete stride on both feet in the GRF labels to fit a GRF profile on")
        profile = np.stack([np.concatenate(c).mean(axis=0) for c in cycles])
        return cls(profile, np.concatenate(means).mean(0), min(sum(len(x) for x in c) for c in cycles), source)

    def predict_grf(self, rec: Recording, heel_strikes: Sequence[np.ndarray] | None = None) -> np.ndarray:
        """(T, 4) GRF (N) of ``rec``: the profile between its measured heel strikes, or between
        ``heel_strikes`` (right, left: sample indices) found otherwise, e.g. from the foot IMUs
        (:func:`~sspinn.data.gait_events.foot_imu_heel_strikes`: a baseline without oracle timing)."""
        if heel_strikes is None and (rec.labels is None or rec.labels.grf is None):
            raise ValueError(f"{rec.name}: the GRF profile is placed at the measured heel strikes; the recording has no GRF labels")
        bw = rec.mass * GRAVITY
        out = np.tile(self.mean_bw, (rec.n_samples, 1))
        cuts_per_foot = _strides(rec) if heel_strikes is None else [strides(np.asarray(h), SAMPLE_RATE_HZ) for h in heel_strikes]
        for foot, cuts in enumerate(cuts_per_foot):
            for s, e in cuts:
                grid = np.linspace(0, 1, e - s + 1)
                out[s : e + 1, 2 * foot : 2 * foot + 2] = np.column_stack(
                    [np.interp(grid, np.linspace(0, 1, 101), self.profile[foot, :, k]) for k in range(2)])
        return out * bw


#: ``TrivialPredictor.source`` when it was fitted on the very recordings it is compared on.
ORACLE_SOURCE: str = "oracle: fitted on the evaluated recordings"
#: ``TrivialPredictor.source`` of the predictor a training run fits on its training recordings
#: and stores in the model file.
TRAINING_SOURCE: str = "means of the model's training data"


def training_predictor(recordings: Sequence[Recording]) -> TrivialPredictor | None:
    """The predictor a training run stores in its model file: fitted on the labels of its
    training ``recordings`` (:data:`TRAINING_SOURCE`; training itself never reads them); None
    when none of them has labels."""
    try:
        return TrivialPredictor.fit(recordings, TRAINING_SOURCE)
    except ValueError:
        return None


def _oracle_label(names: set[str], reference: set[str], what: str) -> str | None:
    """The label of a predictor fitted on the recordings ``reference`` (``what``, e.g. "the
    training split of d") compared on the recordings ``names``: None when ``reference`` holds
    none of them (a fair baseline), else an oracle label saying how many it holds."""
    held = names & reference
    if not held:
        return None
    if held == reference:  # nothing in the reference but evaluated recordings
        return ORACLE_SOURCE if held == names else f"{ORACLE_SOURCE} ({len(held)} of the {len(names)}: {what})"
    return f"means of {what}, which holds {len(held)} of the {len(names)} evaluated recordings (in part an oracle)"


def reference_predictor(
    evaluated: Sequence[Recording], training: Sequence[Recording] | None, where: str, stored: TrivialPredictor | None = None,
) -> TrivialPredictor:
    """The trivial predictor an evaluation is compared with, labelled by what it was fitted on.

    ``stored`` (the model file's, fitted on the model's training data) when given; else fitted on
    ``training`` (the labelled training split found at ``where``) when it has labels, else on
    ``evaluated``. Recordings are matched by name (names are unique in a dataset folder):
    reference data that *are* the evaluated recordings (a dataset imported with split "all", the
    training split evaluated, a model trained on the recordings evaluated) give
    :data:`ORACLE_SOURCE`, never "training data"; reference data that hold some of them say how
    many.
    """
    names = {r.name for r in evaluated}
    if stored is not None:
        label = _oracle_label(names, set(stored.fitted_on), "the model's training data")
        return stored if label is None else TrivialPredictor(stored.means, label, stored.fitted_on)
    fallback = ""
    if training:
        what = f"the training split of {where}"
        label = _oracle_label(names, {r.name for r in training}, what) or f"means of {what}"
        try:
            return TrivialPredictor.fit(training, label)
        except ValueError:
            fallback = f" ({what} has no labels)"
    return TrivialPredictor.fit(evaluated, ORACLE_SOURCE + fallback)


def _strides(rec: Recording) -> list[list[tuple[int, int]]]:
    """Per foot (right, left): (start, end) sample indices of the strides of the measured GRF."""
    assert rec.labels is not None and rec.labels.grf is not None
    return [strides(detect_events(rec.labels.grf[:, 2 * foot + 1], rec.mass * GRAVITY, SAMPLE_RATE_HZ).heel_strikes, SAMPLE_RATE_HZ)
            for foot in range(2)]
