"""Physically exact synthetic gait data with ground truth (the sspinn dataset format v1).

:func:`generate_dataset` makes virtual subjects walk and run, continuously and with
stride-to-stride variability and speed changes, and writes recordings whose labels satisfy the
equations of motion of the sspinn model at every 100 Hz sample.

Method
------
1. **Virtual subjects** (:func:`sample_subjects`). Height ~ N(1.75 m, 0.08 m) and BMI ~
   N(23, 2.5) kg/m² (clipped, :class:`SubjectDistribution`); the recordings carry this height and
   mass, which is all the estimator is told. The subject's **true** segment parameters deviate
   from the generic Winter scaling that the estimator assumes (:func:`perturb_body`,
   :class:`BodyVariation`): segment masses ×(1 ± 10 %) per segment type, renormalised to the body
   mass (so the scale reading stays exact); moments of inertia follow the new mass and length and
   get a further ×(1 ± 10 %); thigh and shank lengths ×(1 ± 5 %) and the foot geometry (heel, toe,
   CoM) ×(1 ± 5 %); CoM shifted along the segment by ± 3 % and across it by ± 1 % of the segment
   length; and every leg quantity an extra ± 2 % per side (left/right asymmetry). All are uniform
   deviations (half-widths given); combined, a leg segment's mass deviates by up to about ± 20 %
   (HAT ± 6 %) and, through mass × length² × its own factor, its inertia by up to about ± 45 %
   (extremes of 2,000 draws; the per-parameter deviations of every subject are in ``dataset.json``,
   ``info.subjects.<id>.body_deviation``). These spreads are design choices of the order of the
   differences between published anthropometric tables (e.g. thigh mass 10.0 % of body mass in
   Dempster/Winter but 14.2 % in de Leva 1996, J Biomech 29:1223–1230; CoM positions differing
   by a few % of the segment length) and of the prediction errors of such tables for
   individuals that the body-segment-parameter literature reports (reviewed by Pearsall & Reid
   1994, Sports Med 18:126–140); they are not fitted to a particular study.
2. **Periodic gaits of the true body** (:func:`periodic_library`): :func:`predictive.solve_predictive`
   (symmetric half cycle) at each program speed, on the exact 100 Hz grid (stride duration
   :func:`predictive.typical_stride_duration` scaled by √(leg length / 0.93 m), rounded to
   0.02 s), warm-started from the same speed's solution of a nominal 1.75 m, 70 kg body
   (a template library solved once by continuation from 1.3 and 3.5 m/s), which keeps every
   subject in the same gait family (a generic guess at 0.9 m/s converges to a hopping gait).
3. **Stride chain** (:mod:`predictive.ocp.stride_nlp`): the recording is a chain of single-stride
   OCPs on the 100 Hz grid, each starting from the fixed last sample of the previous stride, with
   the periodic gaits as initial guesses and terminal targets. Variability: each stride's speed
   is the program's target ×(1 + 2 % N(0, 1)), its duration the reference duration at that speed
   ×(1 + 2 % N(0, 1)) (stride-time CVs of healthy adults are of the order of 2 %; Hausdorff et al.
   1995, J Appl Physiol 78:349–358), and its per-joint effort weights are log-normal (σ = 0.2).
   Speed changes: the program's speeds are held for equal shares of the recording, and the
   target moves to the next one by at most 0.25 m/s per stride. **No recording is thrown away
   for one stride**: a stride that IPOPT cannot solve goes down a ladder of fallbacks
   (:data:`~predictive.ocp.stride_nlp.FALLBACKS`: warm start, default options, a perturbed guess,
   the nominal duration, half the speed change, the previous speed); if every rung fails the
   recording ends cleanly after its last solved stride. Which rung solved each stride is in the
   recording's provenance (``strides.fallback``, ``fallbacks``, ``ended_early``), the counts in
   ``dataset.json`` (``info.solver.fallbacks``, ``info.events``), and ``predictive synth`` prints
   them; an early end warns (:class:`SynthWarning`). Periodic gaits have a ladder of their own
   (:data:`PERIODIC_FALLBACKS`).
4. **IMUs**: :func:`sspinn.imu_errors.measure_imu` on the ground truth with the true body (noise,
   biases, drift, misplacement, soft-tissue artefact; the nominal placement
   ``IMUPlacement.default(height)`` is what the recording tells the estimator).
5. **Labels**: q, u (the collocation u), q̈ (backward differences of u), τ, GRF and w (the
   contact model at the samples), speed (the stride's average pelvis speed, exact by
   construction). The generator reports the Kane residual of the labels as written to disk.

Everything is deterministic given ``SynthConfig.seed`` (serial and parallel runs give identical
files); periodic solutions, chains and finished recordings are cached under ``cache_dir`` by a
hash of everything that determines them, so a second run only reads files.

Usage::

    from predictive.synth.pipeline import SynthConfig, generate_dataset
    config = SynthConfig.from_yaml("configs/synth/default.yaml")
    dataset = generate_dataset(config, "data/synth_default")   # sspinn.dataset.Dataset
    print(dataset.info["kane_residual"])                        # BW and BW·H, max and RMS

or ``python -m predictive synth --config configs/synth/default.yaml --out data/synth_default``.
With ``workers > 1`` the subjects are generated in spawned processes, so a script calling
:func:`generate_dataset` needs the usual ``if __name__ == "__main__":`` guard.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import shutil
import time
import warnings
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Final

import numpy as np
import yaml

from predictive.ocp.collocation import OCPError, solve_predictive, typical_stride_duration
from predictive.ocp.solution import GaitSolution
from predictive.ocp.stride_nlp import (
    DEFAULT_BOUNDARY,
    FALLBACKS,
    WARM_START_IPOPT,
    ChainError,
    ChainResult,
    PeriodicReference,
    StridePlan,
    StrideRecord,
    StrideSettings,
    StrideSolverCache,
    node_residual,
    simulate_chain,
)
from sspinn.body import BodyParameters, Foot, IMUPlacement, Segment
from sspinn.conventions import COORDINATES, GRF, JOINTS, N_TAU, SEGMENTS, SIDES
from sspinn.dataset import SPLITS, Dataset, Labels, Recording
from sspinn.imu_errors import IMUErrorModel, measure_imu


class SynthWarning(UserWarning):
    """Something in a synthetic dataset did not go as planned (a recording ended early, a stride
    plan was drawn again, a recording was dropped); also listed in ``dataset.json``
    (``info.events``)."""


#: Bump when the generator's output for the same configuration changes (invalidates the caches).
CODE_VERSION: Final = 3

#: Speeds at or above this are solved as running (template continuation from 3.5 m/s), m/s.
RUN_SPEED: Final = 2.0
#: Stride plans tried per recording before giving up.
CHAIN_ATTEMPTS: Final = 3
#: Template speeds solved from the generic guess; the others by continuation from them, m/s.
ANCHORS: Final[tuple[float, float]] = (1.3, 3.5)
#: Standing hip height (femur + tibia + ankle height) of the 1.75 m Winter body, m (stride-duration scaling).
REFERENCE_LEG_LENGTH: Final = 0.9275


# =============================================================================================
# Configuration
# =============================================================================================
@dataclass(frozen=True)
class SubjectDistribution:
    """Distribution of the virtual subjects' height (m) and BMI (kg/m²): normal, clipped."""

    height_mean: float = 1.75
    height_sd: float = 0.08
    height_range: tuple[float, float] = (1.55, 1.95)
    bmi_mean: float = 23.0
    bmi_sd: float = 2.5
    bmi_range: tuple[float, float] = (18.5, 30.0)


@dataclass(frozen=True)
class BodyVariation:
    """Half-widths of the uniform deviations of the true segment parameters from Winter's scaling
    (fractions; see the module docstring). All zero: the true body is the generic one."""

    mass: float = 0.10
    inertia: float = 0.10
    length: float = 0.05
    foot: float = 0.05
    com_along: float = 0.03
    com_across: float = 0.01
    asymmetry: float = 0.02

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if not 0 <= v < 0.5:
                raise ValueError(f"body_variation.{f.name} must be in [0, 0.5), got {v}")


@dataclass(frozen=True)
class Variability:
    """Stride-to-stride variability and speed changes.

    Attributes:
        speed_cv: relative std of a stride's speed around the program's target.
        duration_cv: relative std of a stride's duration around the reference duration.
        effort_log_sd: std of the log of the per-joint effort weights.
        max_speed_change: largest change of the target speed from one stride to the next, m/s.
        clip: normal draws are clipped to ± clip standard deviations.
    """

    speed_cv: float = 0.02
    duration_cv: float = 0.02
    effort_log_sd: float = 0.2
    max_speed_change: float = 0.25
    clip: float = 2.5


@dataclass(frozen=True)
class SynthConfig:
    """Configuration of :func:`generate_dataset` (YAML: :meth:`from_yaml`).

    Attributes:
        name: dataset name (prefix of the recording names).
        seed: master seed; everything random derives from it.
        n_subjects: number of virtual subjects.
        splits: subjects per split (train/val/test; must add up to ``n_subjects``).
        programs: speed programs, m/s; a recording runs through one program's speeds in order.
        program_names: one name per program (used in recording names).
        programs_per_subject: recordings per subject: subject i gets programs i, i+1, … (cyclic).
        shuffle_speeds: visit a program's speeds in a random order per recording.
        duration_s: minimal duration of a recording, s (whole strides are kept).
        subjects: height and BMI distribution.
        body_variation: deviations of the true segment parameters.
        variability: stride-to-stride variability.
        stride: settings of the stride OCPs.
        lookahead: strides solved beyond the kept one in each horizon.
        boundary: stride boundary relative to the right contact onset, fraction of the cycle.
        imu_errors: "default" (:class:`~sspinn.imu_errors.IMUErrorModel` defaults), "none" or a
            mapping of IMUErrorModel fields.
        cache_dir: folder of the caches.
        workers: parallel processes (one subject each); 1: in this process.
    """

    name: str = "synth"
    seed: int = 0
    n_subjects: int = 6
    splits: Mapping[str, int] = field(default_factory=lambda: {"train": 4, "val": 1, "test": 1})
    programs: tuple[tuple[float, ...], ...] = ((0.9, 1.3, 1.8), (2.5, 3.0, 3.5))
    program_names: tuple[str, ...] = ("walk", "run")
    programs_per_subject: int = 1
    shuffle_speeds: bool = False
    duration_s: float = 20.0
    subjects: SubjectDistribution = field(default_factory=SubjectDistribution)
    body_variation: BodyVariation = field(default_factory=BodyVariation)
    variability: Variability = field(default_factory=Variability)
    stride: StrideSettings = field(default_factory=StrideSettings)
    lookahead: int = 0
    boundary: float = DEFAULT_BOUNDARY
    imu_errors: str | Mapping[str, Any] = "default"
    cache_dir: str = "results/cache/synth"
    workers: int = 1

    def __post_init__(self) -> None:
        if self.n_subjects < 1:
            raise ValueError(f"n_subjects must be >= 1, got {self.n_subjects}")
        unknown = set(self.splits) - set(SPLITS)
        if unknown:
            raise ValueError(f"unknown split(s) {sorted(unknown)}; allowed: {SPLITS}")
        if sum(self.splits.values()) != self.n_subjects or min(self.splits.values()) < 0:
            raise ValueError(f"splits {dict(self.splits)} must be >= 0 and add up to n_subjects = {self.n_subjects}")
        if not self.programs or any(not p or min(p) <= 0 for p in self.programs):
            raise ValueError(f"programs must be non-empty lists of speeds > 0 m/s, got {self.programs}")
        if len(self.program_names) != len(self.programs) or len(set(self.program_names)) != len(self.programs):
            raise ValueError(f"program_names must name each program once, got {self.program_names}")
        if not 1 <= self.programs_per_subject <= len(self.programs):
            raise ValueError(
                f"programs_per_subject must be in 1..{len(self.programs)}, got {self.programs_per_subject}"
            )
        if not self.duration_s > 0:
            raise ValueError(f"duration_s must be > 0, got {self.duration_s}")
        if self.workers < 1:
            raise ValueError(f"workers must be >= 1, got {self.workers}")
        imu_model(self)  # validates the IMU error settings

    # ------------------------------------------------------------------ (de)serialisation
    @classmethod
    def from_dict(cls, data: Mapping[str, Any], source: str = "<dict>") -> SynthConfig:
        """Build from a (partial) mapping as in ``configs/synth/*.yaml``; unknown keys are errors."""
        nested = {
            "subjects": SubjectDistribution,
            "body_variation": BodyVariation,
            "variability": Variability,
            "stride": StrideSettings,
        }
        allowed = {f.name for f in dataclasses.fields(cls)}
        unknown = set(data) - allowed
        if unknown:
            raise ValueError(f"{source}: unknown setting(s) {sorted(unknown)}; allowed: {sorted(allowed)}")
        kwargs: dict[str, Any] = {}
        for key, value in data.items():
            if key in nested:
                sub_allowed = {f.name for f in dataclasses.fields(nested[key])}
                bad = set(value or {}) - sub_allowed
                if bad:
                    raise ValueError(
                        f"{source}: unknown {key} setting(s) {sorted(bad)}; allowed: {sorted(sub_allowed)}"
                    )
                kwargs[key] = nested[key](**{k: _tuples(v) for k, v in (value or {}).items()})
            elif key in ("programs", "program_names"):
                kwargs[key] = _tuples(value)
            else:
                kwargs[key] = value
        try:
            return cls(**kwargs)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"{source}: {exc}") from None

    @classmethod
    def from_yaml(cls, path: str | Path, **overrides: Any) -> SynthConfig:
        """Read ``path`` (a mapping of the fields); ``overrides`` replace top-level fields."""
        path = Path(path)
        data = yaml.safe_load(path.read_text()) or {}
        if not isinstance(data, dict):
            raise ValueError(f"{path}: expected a mapping of settings, got {type(data).__name__}")
        data.update({k: v for k, v in overrides.items() if v is not None})
        return cls.from_dict(data, source=str(path))

    def to_dict(self) -> dict[str, Any]:
        """JSON-native dict (tuples as lists)."""
        return _jsonable(dataclasses.asdict(self))

    def key(self) -> str:
        """Hash of everything that determines the dataset's content (not cache_dir, workers)."""
        data = self.to_dict()
        data.pop("cache_dir")
        data.pop("workers")
        return _hash({"config": data, "code": CODE_VERSION})


def imu_model(config: SynthConfig) -> IMUErrorModel:
    """The IMU error model of ``config.imu_errors``."""
    spec = config.imu_errors
    if spec == "default":
        return IMUErrorModel()
    if spec == "none":
        return IMUErrorModel.none()
    if isinstance(spec, Mapping):
        return IMUErrorModel.from_dict(spec, source="imu_errors")
    raise ValueError(f"imu_errors must be 'default', 'none' or a mapping of IMUErrorModel fields, got {spec!r}")


# =============================================================================================
# Subjects
# =============================================================================================
@dataclass(frozen=True)
class VirtualSubject:
    """A virtual subject: what the estimator is told (height m, mass kg) and the true body."""

    id: str
    index: int
    split: str
    height: float
    mass: float
    body: BodyParameters

    @property
    def nominal_body(self) -> BodyParameters:
        """The generic Winter-scaled body the estimator assumes."""
        return BodyParameters.from_anthropometry(self.height, self.mass)


def _rng(config: SynthConfig, *stream: int) -> np.random.Generator:
    """An independent generator for a named stream of ``config.seed``."""
    return np.random.default_rng([config.seed, *stream])


def sample_subjects(config: SynthConfig) -> list[VirtualSubject]:
    """The virtual subjects of ``config`` with their splits (deterministic by seed).

    The splits are stratified by each subject's first program (subject i starts with program
    i mod P): the subjects of each program are shuffled and interleaved (programs in a random
    order), and the test, val and train splits take their shares from that sequence in turn, so
    every split of two or more subjects holds every program when it can.
    """
    d = config.subjects
    rng = _rng(config, 0)
    n_prog = len(config.programs)
    groups = [list(rng.permutation(np.arange(p, config.n_subjects, n_prog))) for p in rng.permutation(n_prog)]
    order = [int(g[k]) for k in range(max(len(g) for g in groups)) for g in groups if k < len(g)]
    split_of: dict[int, str] = {}
    start = 0
    for split in ("test", "val", "train"):
        for i in order[start : start + config.splits.get(split, 0)]:
            split_of[i] = split
        start += config.splits.get(split, 0)
    subjects = []
    for i in range(config.n_subjects):
        rng = _rng(config, 1, i)
        height = float(np.clip(rng.normal(d.height_mean, d.height_sd), *d.height_range))
        bmi = float(np.clip(rng.normal(d.bmi_mean, d.bmi_sd), *d.bmi_range))
        height, mass = round(height, 3), round(bmi * height**2, 2)
        body = perturb_body(height, mass, config.body_variation, rng)
        subjects.append(VirtualSubject(f"{config.name}_S{i + 1:02d}", i, split_of[i], height, mass, body))
    return subjects


def perturb_body(height: float, mass: float, variation: BodyVariation, rng: np.random.Generator) -> BodyParameters:
    """True body parameters: the Winter scaling of ``height`` (m) and ``mass`` (kg) with random
    deviations of the half-widths in ``variation`` (see the module docstring); the segment masses
    add up to ``mass`` exactly."""
    nominal = BodyParameters.from_anthropometry(height, mass)
    v = variation

    def u(half_width: float, size: int | None = None) -> Any:
        return rng.uniform(-half_width, half_width, size)

    kinds = ("pelvis", "femur", "tibia", "foot")
    f_mass = {k: 1 + u(v.mass) for k in kinds}
    f_inertia = {k: 1 + u(v.inertia) for k in kinds}
    f_length = {"pelvis": 1.0, "femur": 1 + u(v.length), "tibia": 1 + u(v.length), "foot": 1 + u(v.foot)}
    along = {k: u(v.com_along) for k in kinds}
    across = {k: u(v.com_across) for k in kinds}
    side = {(k, s): 1 + u(v.asymmetry) for k in kinds[1:] for s in SIDES}
    raw_mass = {"pelvis": nominal.pelvis.mass * f_mass["pelvis"]}
    for s in SIDES:
        for k in kinds[1:]:
            raw_mass[f"{k}_{s}"] = getattr(nominal, f"{k}_{s}").mass * f_mass[k] * side[(k, s)]
    scale = mass / sum(raw_mass.values())
    segments: dict[str, Segment] = {}
    for name in SEGMENTS:
        kind = name.split("_")[0]
        seg = getattr(nominal, name)
        fl = f_length[kind] * (side[(kind, name[-1])] if kind != "pelvis" else 1.0)
        new_mass = raw_mass[name] * scale
        inertia = seg.inertia * (new_mass / seg.mass) * fl**2 * f_inertia[kind]
        length = seg.length * fl
        if isinstance(seg, Foot):
            com = (seg.com[0] * fl + across[kind] * length, seg.com[1] * fl + along[kind] * length)
            heel = (seg.heel[0] * fl, seg.heel[1] * fl)
            toe = (seg.toe[0] * fl, seg.toe[1] * fl)
            segments[name] = Foot(mass=new_mass, inertia=inertia, com=com, length=length, heel=heel, toe=toe)
        else:
            sign = 1.0 if kind == "pelvis" else -1.0
            com = (seg.com[0] + across[kind] * length, seg.com[1] * fl + sign * along[kind] * length)
            segments[name] = Segment(mass=new_mass, inertia=inertia, com=com, length=length)
    return nominal.replace(**segments)


def body_deviation(true: BodyParameters, nominal: BodyParameters) -> dict[str, float]:
    """Relative deviation (true/nominal − 1) of each nonzero body parameter, for reports."""
    from sspinn.body import PARAMETERS

    t, n = true.vector(), nominal.vector()
    return {name: float(a / b - 1) for name, a, b in zip(PARAMETERS, t, n) if abs(b) > 1e-12}


# =============================================================================================
# Caching
# =============================================================================================
def _jsonable(obj: Any) -> Any:
    """Tuples → lists, numpy → Python, inf → "inf" (strict JSON)."""
    if isinstance(obj, Mapping):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return [_jsonable(v) for v in obj.tolist()]
    if isinstance(obj, np.generic):
        obj = obj.item()
    if isinstance(obj, float) and not math.isfinite(obj):
        return str(obj)
    return obj


def _tuples(obj: Any) -> Any:
    """Lists → tuples (recursively), for frozen dataclass fields read from YAML."""
    if isinstance(obj, list):
        return tuple(_tuples(v) for v in obj)
    return obj


def _hash(obj: Any) -> str:
    text = json.dumps(_jsonable(obj), sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:20]


@dataclass
class CacheStats:
    """Hits and misses of the caches during one generation."""

    periodic_hits: int = 0
    periodic_solved: int = 0
    chain_hits: int = 0
    chain_solved: int = 0
    recording_hits: int = 0
    recording_made: int = 0

    def add(self, other: CacheStats) -> None:
        for f in dataclasses.fields(self):
            setattr(self, f.name, getattr(self, f.name) + getattr(other, f.name))


class SynthCache:
    """Files under ``root``: ``periodic/<key>.npz|json`` (GaitSolution), ``chains/<key>.npz``
    (ChainResult), ``recordings/<key>/<name>.csv|json`` (Recording)."""

    def __init__(self, root: str | Path) -> None:
        self.root = Path(root)
        self.stats = CacheStats()

    def periodic(self, key: str, solve: Callable[[], GaitSolution]) -> GaitSolution:
        path = self.root / "periodic" / key
        if path.with_name(key + ".npz").exists() and path.with_name(key + ".json").exists():
            self.stats.periodic_hits += 1
            return GaitSolution.load(path)
        sol = solve()
        sol.save(path)
        self.stats.periodic_solved += 1
        return sol

    def chain(self, key: str, solve: Callable[[], ChainResult]) -> ChainResult:
        path = self.root / "chains" / f"{key}.npz"
        if path.exists():
            self.stats.chain_hits += 1
            return ChainResult.load(path)
        result = solve()
        result.save(path)
        self.stats.chain_solved += 1
        return result

    def recording(self, key: str, name: str, make: Callable[[], Recording]) -> Recording:
        folder = self.root / "recordings" / key
        if (folder / f"{name}.csv").exists() and (folder / f"{name}.json").exists():
            self.stats.recording_hits += 1
            return Recording.load(folder / f"{name}.csv")
        rec = make()
        tmp = folder.with_name(key + ".tmp")
        shutil.rmtree(tmp, ignore_errors=True)
        rec.save(tmp)
        shutil.rmtree(folder, ignore_errors=True)
        tmp.replace(folder)
        self.stats.recording_made += 1
        # what the dataset gets is exactly what a cache hit would return (CSV precision)
        return Recording.load(folder / f"{name}.csv")


# =============================================================================================
# Periodic gaits
# =============================================================================================
def periodic_duration(speed: float, body: BodyParameters, h: float) -> float:
    """Stride duration of the periodic reference at ``speed`` (m/s) for ``body``, s: the typical
    duration × √(standing hip height / 0.9275 m), rounded to a multiple of 2h (whole half cycles)."""
    leg = body.standing_hip_height
    T = typical_stride_duration(speed) * math.sqrt(leg / REFERENCE_LEG_LENGTH)
    return round(T / (2 * h)) * 2 * h


def _solve_periodic(
    speed: float,
    body: BodyParameters,
    stride: StrideSettings,
    guess: GaitSolution | None,
    ipopt_options: Mapping[str, Any] | None = None,
) -> GaitSolution:
    T = periodic_duration(speed, body, stride.h)
    n_half = round(T / (2 * stride.h))
    settings = stride.ocp_settings(speed, n_half, T).to_dict()
    for k in ("speed", "n_nodes", "duration", "effort", "gait_cycle", "free_duration"):
        settings.pop(k)
    settings = {k: tuple(v) if isinstance(v, list) else v for k, v in settings.items()}
    return solve_predictive(
        speed, body, n_nodes=n_half, duration=T, guess=guess, ipopt_options=ipopt_options, **settings
    )


def _periodic_key(speed: float, body: BodyParameters, stride: StrideSettings, guess_key: str | None) -> str:
    T = periodic_duration(speed, body, stride.h)
    settings = stride.ocp_settings(speed, round(T / (2 * stride.h)), T).to_dict()
    return _hash({"code": CODE_VERSION, "body": body.vector(), "ocp": settings, "guess": guess_key})


def _continuation_order(speeds: Sequence[float]) -> list[tuple[float, float | None]]:
    """(speed, speed of its guess or None for the generic guess): each gait family (walking
    below RUN_SPEED, running above) starts at its anchor and proceeds to the nearest solved speed."""
    order: list[tuple[float, float | None]] = []
    for anchor, family in (
        (ANCHORS[0], [v for v in speeds if v < RUN_SPEED]),
        (ANCHORS[1], [v for v in speeds if v >= RUN_SPEED]),
    ):
        if not family:
            continue
        solved = [anchor]
        order.append((anchor, None))
        for v in sorted(set(family) - {anchor}, key=lambda x: (abs(x - anchor), x)):
            nearest = min(solved, key=lambda s: (abs(s - v), s))
            order.append((v, nearest))
            solved.append(v)
    return order


def template_library(
    speeds: Sequence[float], stride: StrideSettings, cache: SynthCache
) -> dict[float, tuple[GaitSolution, str]]:
    """Periodic gaits of the nominal 1.75 m, 70 kg body at ``speeds`` (plus the anchors), solved by
    continuation (see :func:`_continuation_order`); returns speed → (solution, cache key)."""
    body = BodyParameters.from_anthropometry(1.75, 70.0)
    out: dict[float, tuple[GaitSolution, str]] = {}
    for speed, guess_speed in _continuation_order(speeds):
        guess, guess_key = (None, None) if guess_speed is None else out[guess_speed]
        key = _periodic_key(speed, body, stride, guess_key)
        try:
            sol = cache.periodic(key, lambda s=speed, g=guess: _solve_periodic_ladder(s, body, stride, g))
        except OCPError as exc:
            if guess_speed is None:
                raise OCPError(exc.status, f"template gait at {speed} m/s (an anchor): {exc}") from exc
            # continuation in two smaller steps: through the midpoint of the speeds
            mid = round(0.5 * (speed + guess_speed), 6)
            mid_key = _periodic_key(mid, body, stride, guess_key)
            try:
                mid_sol = cache.periodic(mid_key, lambda g=guess, m=mid: _solve_periodic_ladder(m, body, stride, g))
                key = _periodic_key(speed, body, stride, mid_key)
                sol = cache.periodic(key, lambda s=speed, g=mid_sol: _solve_periodic_ladder(s, body, stride, g))
            except OCPError as exc2:
                raise OCPError(
                    exc2.status,
                    f"template gait at {speed} m/s could not be reached by continuation from {guess_speed} m/s, "
                    f"directly or through {mid} m/s ({exc2}); remove {speed} m/s from the programs",
                ) from exc2
        out[speed] = (sol, key)
    return out


#: Fallbacks of a periodic gait, in order: (use the continuation guess, IPOPT options). A failed
#: warm start is retried with IPOPT's defaults, then from the data-free guess, which is a
#: multi-start (:data:`predictive.ocp.collocation.DEFAULT_STARTS`: other amplitudes, a monotone barrier).
PERIODIC_FALLBACKS: Final[tuple[tuple[bool, Mapping[str, Any] | None], ...]] = (
    (True, WARM_START_IPOPT),
    (True, None),
    (False, None),
)


def _solve_periodic_ladder(
    speed: float, body: BodyParameters, stride: StrideSettings, guess: GaitSolution | None, warm_start: bool = False
) -> GaitSolution:
    """:func:`_solve_periodic` down :data:`PERIODIC_FALLBACKS` (rungs with the guess are skipped
    when there is none, the warm-start rung unless ``warm_start``: the guess is the same speed's
    solution of a similar body); raises the last :class:`OCPError` if every rung fails."""
    error: OCPError | None = None
    for use_guess, options in PERIODIC_FALLBACKS:
        if (use_guess and guess is None) or (options is WARM_START_IPOPT and not warm_start):
            continue
        try:
            return _solve_periodic(speed, body, stride, guess if use_guess else None, options)
        except OCPError as exc:
            error = exc
    assert error is not None
    raise error


def periodic_library(
    body: BodyParameters,
    speeds: Sequence[float],
    stride: StrideSettings,
    cache: SynthCache,
    templates: Mapping[float, tuple[GaitSolution, str]],
    events: list[dict[str, str]] | None = None,
    name: str = "",
) -> dict[float, tuple[GaitSolution, str]]:
    """Periodic gaits of ``body`` at ``speeds`` (m/s), each warm-started from the template at the
    same speed with IPOPT's warm-start options (:data:`~predictive.ocp.stride_nlp.WARM_START_IPOPT`:
    faster, and it stays in the template's gait), falling back down :data:`PERIODIC_FALLBACKS`.
    If every rung fails, the nominal body's template serves as that speed's reference (it is only
    the chain's initial guess and terminal target: the labels still come from stride OCPs of the
    true body) and an event ``periodic_from_template`` naming ``name`` is appended to ``events``.
    Returns speed → (solution, cache key)."""
    out: dict[float, tuple[GaitSolution, str]] = {}
    for speed in speeds:
        guess, guess_key = templates[speed]
        key = _periodic_key(speed, body, stride, guess_key)
        try:
            solution = cache.periodic(key, lambda s=speed, g=guess: _solve_periodic_ladder(s, body, stride, g, True))
        except OCPError as exc:
            if events is not None:
                detail = f"periodic gait at {speed} m/s failed on every rung ({exc}); the nominal template is the reference"
                events.append({"recording": name, "event": "periodic_from_template", "detail": detail})
            out[speed] = (guess, guess_key)
            continue
        out[speed] = (solution, key)
    return out


# =============================================================================================
# Recordings
# =============================================================================================
def plan_strides(
    speeds: Sequence[float],
    duration_s: float,
    reference: PeriodicReference,
    variability: Variability,
    h: float,
    rng: np.random.Generator,
) -> list[StridePlan]:
    """Strides covering at least ``duration_s`` seconds: the target speed runs through ``speeds``
    (equal shares of the duration, ramps of at most ``max_speed_change`` per stride), with the
    per-stride variability of ``variability`` (see the module docstring)."""
    var = variability
    share = duration_s / len(speeds)
    plans: list[StridePlan] = []
    t, v_sched = 0.0, float(speeds[0])
    while t < duration_s - 1e-9:
        target = float(speeds[min(int(t / share), len(speeds) - 1)])
        v_sched = float(np.clip(target, v_sched - var.max_speed_change, v_sched + var.max_speed_change))
        z = np.clip(rng.standard_normal(2 + N_TAU), -var.clip, var.clip)
        v = v_sched * (1 + var.speed_cv * z[0])
        n = int(round(reference.nominal_duration(v) * (1 + var.duration_cv * z[1]) / h))
        weights = tuple(float(w) for w in np.exp(var.effort_log_sd * z[2:]))
        plans.append(StridePlan(speed=float(v), n_nodes=n, effort_weights=weights))
        t += n * h
    return plans


def label_columns(chain: ChainResult) -> dict[str, np.ndarray]:
    """The label columns (sspinn dataset names) of a chain."""
    cols: dict[str, np.ndarray] = {}
    for i, c in enumerate(COORDINATES):
        cols[c] = chain.q[:, i]
        cols[f"d_{c}"] = chain.u[:, i]
        cols[f"dd_{c}"] = chain.qdd[:, i]
    for j, name in enumerate(JOINTS):
        cols[f"tau_{name}"] = chain.tau[:, j]
    for i, name in enumerate(GRF):
        cols[name] = chain.grf[:, i]
    cols["w_r"], cols["w_l"] = chain.w[:, 0], chain.w[:, 1]
    cols["speed"] = chain.speed
    return cols


def residual_stats(rec: Recording, body: BodyParameters) -> dict[str, float]:
    """Kane residual of a recording's labels with the true body: max and RMS of the translational
    rows (BW) and of the rotational rows (BW·H), and the sample count."""
    lab = rec.labels
    if lab is None or any(getattr(lab, g) is None for g in ("q", "u", "qdd", "tau", "grf", "w")):
        raise ValueError(f"{rec.name}: the Kane residual needs the labels q, u, qdd, tau, grf and w")
    r = node_residual(lab.q, lab.u, lab.qdd, lab.tau, body, grf=lab.grf, w=lab.w)
    return {
        "max_trans_bw": float(np.abs(r[:, :2]).max()),
        "rms_trans_bw": float(np.sqrt(np.mean(r[:, :2] ** 2))),
        "max_rot_bwh": float(np.abs(r[:, 2:]).max()),
        "rms_rot_bwh": float(np.sqrt(np.mean(r[:, 2:] ** 2))),
        "samples": int(r.shape[0]),
    }


def _gait_stats(chain: ChainResult, body: BodyParameters) -> dict[str, float]:
    fy = chain.grf[:, [1, 3]] / body.body_weight > 0.1
    return {
        "stance_r": float(fy[:, 0].mean()),
        "stance_l": float(fy[:, 1].mean()),
        "double_support": float((fy[:, 0] & fy[:, 1]).mean()),
        "flight": float((~fy[:, 0] & ~fy[:, 1]).mean()),
        "peak_grf_y_bw": float(chain.grf[:, [1, 3]].max() / body.body_weight),
    }


@dataclass
class SubjectOutput:
    """The recordings of one subject and how they were made; ``events`` lists what did not go as
    planned (``{"recording", "event", "detail"}``; events: ``periodic_from_template``,
    ``plan_redrawn``, ``ended_early``, ``dropped``)."""

    recordings: list[Recording]
    strides: list[StrideRecord]
    cache: CacheStats
    time_s: float
    build_time_s: float
    events: list[dict[str, str]] = field(default_factory=list)


def generate_subject(
    config: SynthConfig,
    subject: VirtualSubject,
    cache: SynthCache | None = None,
    solvers: StrideSolverCache | None = None,
    on_progress: Callable[[str, float], None] | None = None,
) -> SubjectOutput:
    """All recordings of one subject (see the module docstring).

    Args:
        config: the dataset configuration.
        subject: the subject (from :func:`sample_subjects`).
        cache: file caches (default: ``config.cache_dir``).
        solvers: compiled stride NLPs to share between subjects.
        on_progress: called with (stage description, seconds of data just finished).
    """
    t0 = time.perf_counter()
    cache = cache if cache is not None else SynthCache(config.cache_dir)
    solvers = solvers if solvers is not None else StrideSolverCache(config.stride)
    build0 = solvers.build_time
    stats0 = dataclasses.replace(cache.stats)
    stride_cfg = config.stride
    model = imu_model(config)
    nominal_placement = IMUPlacement.default(subject.height)
    programs = [(subject.index + j) % len(config.programs) for j in range(config.programs_per_subject)]
    speeds_needed = sorted({v for j in programs for v in config.programs[j]})

    def report(stage: str, seconds: float = 0.0) -> None:
        if on_progress is not None:
            on_progress(stage, seconds)

    report(f"{subject.id}: periodic gaits")
    templates = template_library(speeds_needed, stride_cfg, cache)
    events: list[dict[str, str]] = []
    library = periodic_library(subject.body, speeds_needed, stride_cfg, cache, templates, events, subject.id)
    recordings: list[Recording] = []
    strides: list[StrideRecord] = []
    for j in programs:
        program_name = config.program_names[j]
        name = f"{subject.id}_{program_name}"
        speeds = list(config.programs[j])
        if config.shuffle_speeds:
            speeds = [speeds[i] for i in _rng(config, 3, subject.index, j).permutation(len(speeds))]
        found = _recording_chain(config, subject, j, speeds, library, cache, solvers, report, events)
        if found is None:
            continue
        chain, chain_key, attempt = found
        strides.extend(chain.strides)
        if chain.ended_early:
            events.append({"recording": name, "event": "ended_early", "detail": chain.ended_early})
        imu_seed = [config.seed, 4, subject.index, j]
        rec_key = _hash(
            {
                "chain": chain_key,
                "imu": model.to_dict(),
                "imu_seed": imu_seed,
                "placement": nominal_placement.vector(),
                "name": name,
                "subject": [subject.id, subject.height, subject.mass],
                "code": CODE_VERSION,
            }
        )

        def make(
            chain: ChainResult = chain,
            name: str = name,
            speeds: list[float] = speeds,
            j: int = j,
            imu_seed: list[int] = imu_seed,
            attempt: int = attempt,
        ) -> Recording:
            imu, info = measure_imu(
                chain.q, chain.u, chain.qdd, subject.body, nominal_placement, model, np.random.default_rng(imu_seed)
            )
            true_placement: IMUPlacement = info["true_placement"]
            rec = Recording(
                name=name,
                imu=imu,
                segments=SEGMENTS,
                height=subject.height,
                mass=subject.mass,
                subject=subject.id,
                placement=nominal_placement,
                labels=Labels.from_columns(label_columns(chain), chain.n_samples),
                provenance={
                    "generator": "predictive.synth.pipeline",
                    "code_version": CODE_VERSION,
                    "config_key": config.key(),
                    "method": "chain of single-stride backward-Euler OCPs at h = 0.01 s (predictive.ocp.stride_nlp)",
                    "program": {"name": config.program_names[j], "speeds_mps": speeds},
                    "plan_attempt": attempt,
                    "strides": {
                        "speed_mps": [r.speed for r in chain.strides],
                        "planned_speed_mps": [r.planned_speed for r in chain.strides],
                        "n_samples": [r.n_nodes for r in chain.strides],
                        "fallback": [r.fallback for r in chain.strides],
                    },
                    "fallbacks": fallback_counts(chain.strides),
                    "ended_early": chain.ended_early,
                    "gait": _gait_stats(chain, subject.body),
                    "state_before_first_sample": {"q": chain.q_prev.tolist(), "u": chain.u_prev.tolist()},
                    "ground_truth": {
                        "body": _jsonable(subject.body.to_dict()),
                        "imu_placement": _jsonable(
                            {
                                s: {"position_m": true_placement.positions[s], "angle_rad": true_placement.angles[s]}
                                for s in SEGMENTS
                            }
                        ),
                    },
                    "imu_error_model": _jsonable(model.to_dict()),
                },
            )
            rec.provenance["kane_residual"] = residual_stats(rec, subject.body)
            return rec

        recordings.append(cache.recording(rec_key, name, make))
    stats = dataclasses.replace(cache.stats)
    for f in dataclasses.fields(stats):
        setattr(stats, f.name, getattr(stats, f.name) - getattr(stats0, f.name))
    return SubjectOutput(recordings, strides, stats, time.perf_counter() - t0, solvers.build_time - build0, events)


def _recording_chain(
    config: SynthConfig,
    subject: VirtualSubject,
    program: int,
    speeds: Sequence[float],
    library: Mapping[float, tuple[GaitSolution, str]],
    cache: SynthCache,
    solvers: StrideSolverCache,
    report: Callable[[str, float], None],
    events: list[dict[str, str]],
) -> tuple[ChainResult, str, int] | None:
    """The (cached) chain of one recording.

    A stride that fails goes down the fallback ladder of
    :func:`~predictive.ocp.stride_nlp.simulate_chain`; if every rung fails, the recording ends
    cleanly after its last solved stride. Only when its *first* stride cannot be solved is the
    recording's stride plan drawn again from the next random stream (at most
    :data:`CHAIN_ATTEMPTS` times); after that the recording is dropped. Each of these events is
    appended to ``events``. Returns (chain, cache key, attempt), or None if dropped."""
    stride_cfg = config.stride
    name = f"{subject.id}_{config.program_names[program]}"
    reference = PeriodicReference([library[v][0] for v in sorted(set(speeds))], boundary=config.boundary)
    error: ChainError | None = None
    for attempt in range(CHAIN_ATTEMPTS):
        rng = _rng(config, 2, subject.index, program, attempt)
        plans = plan_strides(speeds, config.duration_s, reference, config.variability, stride_cfg.h, rng)
        key = _hash(
            {
                "code": CODE_VERSION,
                "body": subject.body.vector(),
                "plans": [dataclasses.astuple(p) for p in plans],
                "stride": stride_cfg.to_dict(),
                "lookahead": config.lookahead,
                "boundary": config.boundary,
                "periodic": [library[v][1] for v in sorted(set(speeds))],
            }
        )
        done = [0.0]

        def on_stride(r: StrideRecord, n: int = len(plans), done: list[float] = done) -> None:
            seconds = min(r.n_nodes * stride_cfg.h, max(config.duration_s - done[0], 0.0))
            done[0] += seconds
            report(f"{name}: stride {r.index + 1}/{n}", seconds)

        def solve(plans: list[StridePlan] = plans) -> ChainResult:
            return simulate_chain(
                subject.body, plans, reference, solvers, lookahead=config.lookahead, on_stride=on_stride
            )

        hits = cache.stats.chain_hits
        try:
            chain = cache.chain(key, solve)
        except ChainError as exc:
            error = exc
            events.append({"recording": name, "event": "plan_redrawn", "detail": str(exc)})
            report(f"{name}: new stride plan after: {exc}", -done[0])
            continue
        if cache.stats.chain_hits > hits:
            report(f"{name}: cached", config.duration_s)
        return chain, key, attempt
    detail = f"no stride plan could be started in {CHAIN_ATTEMPTS} attempts; last error: {error}"
    events.append({"recording": name, "event": "dropped", "detail": detail})
    return None


def fallback_counts(strides: Sequence[StrideRecord]) -> dict[str, int]:
    """Strides per rung of :data:`~predictive.ocp.stride_nlp.FALLBACKS` (every rung listed)."""
    return {rung: sum(r.fallback == rung for r in strides) for rung in FALLBACKS}


def _worker_groups(n_subjects: int, workers: int) -> list[list[int]]:
    """Subjects per worker in snake order (0, 1, …, w−1, w−1, …, 0, 0, …), which balances the
    alternating walking and running programs."""
    groups: list[list[int]] = [[] for _ in range(workers)]
    for i in range(n_subjects):
        lap, pos = divmod(i, workers)
        groups[pos if lap % 2 == 0 else workers - 1 - pos].append(i)
    return [g for g in groups if g]


def _group_job(config: SynthConfig, indices: list[int], queue: Any) -> list[SubjectOutput]:
    """Worker entry point: the subjects ``indices`` with one solver cache; progress → ``queue``."""
    subjects = sample_subjects(config)
    cache = SynthCache(config.cache_dir)
    solvers = StrideSolverCache(config.stride)
    return [
        generate_subject(config, subjects[i], cache, solvers, lambda stage, sec: queue.put((stage, sec)))
        for i in indices
    ]


# =============================================================================================
# Datasets
# =============================================================================================
def generate_dataset(
    config: SynthConfig, out_dir: str | Path, progress: bool = True, cache_dir: str | Path | None = None
) -> Dataset:
    """Generate (or load from the caches) the dataset of ``config`` into ``out_dir``.

    ``out_dir`` must be empty, absent, or hold an earlier output of this generator (whose
    recordings are replaced). The returned dataset's ``info`` holds the configuration, the
    generation time, the Kane residual of the written labels (BW, BW·H), per-recording
    statistics and the cache hits.
    """
    t0 = time.perf_counter()
    out = Path(out_dir)
    _prepare_out_dir(out)
    if cache_dir is not None:
        config = dataclasses.replace(config, cache_dir=str(cache_dir))
    subjects = sample_subjects(config)
    n_rec = config.programs_per_subject * len(subjects)
    bar = _progress_bar(progress, total=round(n_rec * config.duration_s, 2))

    def on_progress(stage: str, seconds: float) -> None:
        if bar is not None:
            bar.set_description(stage, refresh=False)
            bar.update(round(seconds, 2))

    outputs: list[SubjectOutput] = []
    build_time = 0.0
    cache = SynthCache(config.cache_dir)
    try:
        # the nominal-body templates first (shared by all subjects and workers)
        on_progress("template gaits", 0.0)
        template_library(sorted({v for p in config.programs for v in p}), config.stride, cache)
        if config.workers == 1:
            solvers = StrideSolverCache(config.stride)
            outputs = [generate_subject(config, subject, cache, solvers, on_progress) for subject in subjects]
            build_time = solvers.build_time
        else:
            outputs = _generate_parallel(config, on_progress)
            build_time = sum(o.build_time_s for o in outputs)
    finally:
        if bar is not None:
            bar.close()
    by_split: dict[str, list[Recording]] = {s: [] for s in SPLITS if config.splits.get(s, 0) > 0}
    for subject, output in zip(subjects, outputs):
        by_split[subject.split].extend(output.recordings)
    events = [e for o in outputs for e in o.events]
    for e in events:
        warnings.warn(f"{e['recording']}: {e['event'].replace('_', ' ')}: {e['detail']}", SynthWarning, stacklevel=2)
    empty = [split for split, recs in by_split.items() if not recs]
    if empty:
        raise ChainError(
            f"split(s) {empty} have no recording left: every recording of their subjects was dropped "
            f"({'; '.join(e['detail'] for e in events if e['event'] == 'dropped')})"
        )
    cache_stats = dataclasses.replace(cache.stats)  # everything when serial, the templates when parallel
    if config.workers > 1:
        for o in outputs:
            cache_stats.add(o.cache)
    info: dict[str, Any] = {"generator": "predictive.synth.pipeline", "config_key": config.key()}
    dataset = Dataset.write(out, by_split, info)
    # the residual of the labels as written (CSV precision), with each subject's true body
    body_of = {s.id: s.body for s in subjects}
    per_rec: dict[str, Any] = {}
    residuals: list[dict[str, float]] = []
    for split in dataset.splits:
        for rec in dataset.load(split):
            res = residual_stats(rec, body_of[rec.subject])
            residuals.append(res)
            per_rec[rec.name] = {
                "subject": rec.subject,
                "split": split,
                "duration_s": rec.duration,
                "program": rec.provenance.get("program"),
                "gait": rec.provenance.get("gait"),
                "kane_residual": res,
            }
    strides = [r for o in outputs for r in o.strides]
    info.update(
        {
            "code_version": CODE_VERSION,
            "config": config.to_dict(),
            "generation_time_s": round(time.perf_counter() - t0, 2),
            "n_recordings": len(per_rec),
            "total_duration_s": round(sum(v["duration_s"] for v in per_rec.values()), 2),
            "subjects": {
                s.id: {
                    "split": s.split,
                    "height_m": s.height,
                    "mass_kg": s.mass,
                    "body_deviation": body_deviation(s.body, s.nominal_body),
                }
                for s in subjects
            },
            "kane_residual": _combine_residuals(residuals),
            "solver": {
                "strides_solved": len(strides) if cache_stats.chain_solved else 0,
                "iterations_mean": float(np.mean([r.iterations for r in strides])) if strides else None,
                "solve_time_s": round(sum(r.solve_time for r in strides), 2),
                "solve_time_per_stride_s": round(float(np.mean([r.solve_time for r in strides])), 3)
                if strides
                else None,
                "retried_strides": int(sum(r.attempts > 1 for r in strides)),
                "fallbacks": fallback_counts(strides),
                "build_time_s": round(build_time, 2),
            },
            "cache": dataclasses.asdict(cache_stats),
            "events": events,
            "recordings": per_rec,
        }
    )
    (out / "dataset.json").write_text(
        json.dumps(
            {"format": "sspinn-dataset", "version": 1, "splits": dataset.splits, "info": _jsonable(info)}, indent=2
        )
    )
    return Dataset.open(out)


def _generate_parallel(config: SynthConfig, on_progress: Callable[[str, float], None]) -> list[SubjectOutput]:
    """All subjects with ``config.workers`` processes (spawned; one solver cache each)."""
    import multiprocessing as mp

    groups = _worker_groups(config.n_subjects, config.workers)
    ctx = mp.get_context("spawn")
    results: dict[int, SubjectOutput] = {}
    with ctx.Manager() as manager, ProcessPoolExecutor(max_workers=len(groups), mp_context=ctx) as pool:
        queue = manager.Queue()
        futures = {pool.submit(_group_job, config, g, queue): g for g in groups}
        pending = set(futures)
        while pending:
            done, pending = wait(pending, timeout=0.5, return_when=FIRST_COMPLETED)
            while not queue.empty():
                on_progress(*queue.get())
            for fut in done:
                results.update(zip(futures[fut], fut.result()))
        while not queue.empty():
            on_progress(*queue.get())
    return [results[i] for i in range(config.n_subjects)]


def _combine_residuals(stats: Sequence[Mapping[str, float]]) -> dict[str, float]:
    """Max and RMS over all samples of several recordings."""
    n = np.array([s["samples"] for s in stats], dtype=float)
    if not len(n):
        return {}
    return {
        "max_trans_bw": max(s["max_trans_bw"] for s in stats),
        "rms_trans_bw": float(np.sqrt(np.sum(n * np.array([s["rms_trans_bw"] ** 2 for s in stats])) / n.sum())),
        "max_rot_bwh": max(s["max_rot_bwh"] for s in stats),
        "rms_rot_bwh": float(np.sqrt(np.sum(n * np.array([s["rms_rot_bwh"] ** 2 for s in stats])) / n.sum())),
        "samples": int(n.sum()),
    }


def _prepare_out_dir(out: Path) -> None:
    """Remove an earlier output of this generator from ``out``; refuse other non-empty folders."""
    if not out.exists():
        out.mkdir(parents=True)
        return
    index = out / "dataset.json"
    if index.exists():
        try:
            meta = json.loads(index.read_text())
        except json.JSONDecodeError:
            meta = {}
        if meta.get("info", {}).get("generator") == "predictive.synth.pipeline":
            for names in meta.get("splits", {}).values():
                for n in names:
                    for ext in (".csv", ".json"):
                        (out / f"{n}{ext}").unlink(missing_ok=True)
            index.unlink()
    if any(out.iterdir()):
        raise FileExistsError(
            f"{out} is not empty and holds no earlier output of predictive.synth.pipeline; choose another --out"
        )


def _progress_bar(enabled: bool, total: float) -> Any:
    if not enabled:
        return None
    from tqdm import tqdm

    return tqdm(total=total, unit="s", unit_scale=False, desc="synthetic data", bar_format=_BAR)


_BAR: Final = "{desc:<34.34} {percentage:3.0f}%|{bar:20}| {n:.0f}/{total:.0f} s of data [{elapsed}<{remaining}]"
