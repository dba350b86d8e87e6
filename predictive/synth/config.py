"""Configuration of a synthetic dataset: :class:`SynthConfig` and its parts (YAML).

``configs/synth/*.yaml`` hold a (partial) mapping of the :class:`SynthConfig` fields; nested
sections configure the subjects' height and BMI (:class:`SubjectDistribution`), the deviations
of their true segment parameters (:class:`BodyVariation`), the stride-to-stride variability
(:class:`Variability`) and the stride OCPs (:class:`~predictive.ocp.stride_nlp.StrideSettings`).
:meth:`SynthConfig.key` hashes everything that determines the dataset's content; every random
draw comes from a stream of :attr:`SynthConfig.seed` (:meth:`SynthConfig.rng`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from predictive.ocp.stride_nlp import StrideSettings
from predictive.synth.cache import CODE_VERSION, jsonable, stable_hash
from predictive.synth.periodic_reference import DEFAULT_BOUNDARY
from sspinn.data.dataset import SPLITS
from sspinn.data.sensor_noise import IMUErrorModel
from sspinn.yaml_config import config_from_mapping, load_config


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
    (fractions; see :mod:`predictive.synth.subjects`). All zero: the true body is the generic one."""

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
    """Configuration of :func:`~predictive.synth.pipeline.generate_dataset` (YAML: :meth:`from_yaml`).

    Attributes:
        name: dataset name (prefix of the recording names).
        seed: master seed; everything random derives from it.
        n_subjects: number of virtual subjects.
        splits: subjects per split (train/val/test; must add up to ``n_subjects``).
        programs: speed programs, m/s; a recording runs through one program's speeds in order.
        program_names: one name per program (used in recording names).
        programs_per_subject: recordings per subject: subject i gets programs i, i+1, … (cyclic).
        paces: the subjects' own paces, factors on a program's speeds: subject i walks or runs
            every program at ``paces[(i // len(programs)) % len(paces)]`` × its speeds (rounded
            to 0.01 m/s; :meth:`speeds`), so that held-out subjects do not all share the training
            subjects' speeds and the training subjects' mean speed is no oracle. ``(1.0,)``:
            every subject at the program's speeds.
        shuffle_speeds: visit a program's speeds in a random order per recording.
        duration_s: minimal duration of a recording, s (whole strides are kept).
        subjects: height and BMI distribution.
        body_variation: deviations of the true segment parameters.
        variability: stride-to-stride variability.
        stride: settings of the stride OCPs.
        lookahead: strides solved beyond the kept one in each horizon.
        boundary: stride boundary relative to the right contact onset, fraction of the cycle.
        imu_errors: "default" (:class:`~sspinn.data.sensor_noise.IMUErrorModel` defaults), "none" or a
            mapping of IMUErrorModel fields.
        cache_dir: folder of the caches.
        workers: subjects generated at a time; 1: one after the other in this process, more:
            tasks of one subject each on the joblib backend ``backend`` (each worker process
            keeps its compiled stride NLPs for its next subjects).
        backend: the joblib backend when ``workers > 1``: ``"loky"`` (processes on this
            machine), any other of joblib's (``"multiprocessing"``, ``"threading"``), or one that
            the calling code registers (``"dask"`` with a ``dask.distributed`` client, ``"ray"``
            after ``ray.util.joblib.register_ray()``); see :mod:`predictive.synth.joblib_backend`.
        backend_options: keyword arguments of that backend (``joblib.parallel_config``), e.g.
            ``{scheduler_host: "tcp://scheduler:8786"}`` for ``dask``.
    """

    name: str = "synth"
    seed: int = 0
    n_subjects: int = 6
    splits: Mapping[str, int] = field(default_factory=lambda: {"train": 4, "val": 1, "test": 1})
    programs: tuple[tuple[float, ...], ...] = ((0.9, 1.3, 1.8), (2.5, 3.0, 3.5))
    program_names: tuple[str, ...] = ("walk", "run")
    programs_per_subject: int = 1
    paces: tuple[float, ...] = (1.0,)
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
    backend: str = "loky"
    backend_options: Mapping[str, Any] = field(default_factory=dict)

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
        if not self.paces or any(not 0.5 <= p <= 2.0 for p in self.paces):
            raise ValueError(f"paces must be non-empty factors in [0.5, 2] on the program speeds, got {self.paces}")
        if not self.duration_s > 0:
            raise ValueError(f"duration_s must be > 0, got {self.duration_s}")
        if self.workers < 1:
            raise ValueError(f"workers must be >= 1, got {self.workers}")
        if not self.backend:
            raise ValueError("backend must name a joblib backend (e.g. loky), got an empty string")
        imu_model(self)  # validates the IMU error settings

    # ------------------------------------------------------------------ (de)serialisation
    @classmethod
    def from_dict(cls, data: Mapping[str, Any], source: str = "<dict>") -> SynthConfig:
        """Build from a (partial) mapping as in ``configs/synth/*.yaml`` (:mod:`sspinn.yaml_config`:
        unknown keys at any level, wrong types and bad values are one-line errors naming ``source``)."""
        return config_from_mapping(cls, dict(data), source, what="setting")

    @classmethod
    def from_yaml(cls, path: str | Path, **overrides: Any) -> SynthConfig:
        """Read ``path`` (a mapping of the fields); ``overrides`` (not None) replace top-level fields."""
        return load_config(cls, path, overrides=overrides, what="setting")

    def to_dict(self) -> dict[str, Any]:
        """JSON-native dict (tuples as lists)."""
        return jsonable(dataclasses.asdict(self))

    def key(self) -> str:
        """Hash of everything that determines the dataset's content (not where and how it is
        computed: cache_dir, workers, backend, backend_options)."""
        data = self.to_dict()
        for name in ("cache_dir", "workers", "backend", "backend_options"):
            data.pop(name)
        return stable_hash({"config": data, "code": CODE_VERSION})

    def pace(self, subject: int) -> float:
        """The pace factor of subject index ``subject`` (see :attr:`paces`)."""
        return self.paces[(subject // len(self.programs)) % len(self.paces)]

    def speeds(self, subject: int, program: int) -> list[float]:
        """The target speeds (m/s) of program ``program`` for subject index ``subject``: the
        program's speeds × the subject's pace, rounded to 0.01 m/s, in the program's order."""
        return _paced(self.programs[program], self.pace(subject))

    def all_speeds(self) -> list[float]:
        """Every target speed of the dataset (all programs at all paces), sorted, m/s."""
        return sorted({v for program in self.programs for pace in self.paces for v in _paced(program, pace)})

    def rng(self, *stream: int) -> np.random.Generator:
        """An independent generator for a named stream of :attr:`seed` (streams: 0 splits,
        (1, subject) body, (2, subject, program, attempt) stride plan, (3, subject, program)
        speed order)."""
        return np.random.default_rng([self.seed, *stream])


def _paced(speeds: tuple[float, ...], pace: float) -> list[float]:
    """``speeds`` (m/s) × ``pace``, rounded to 0.01 m/s (the cache keys of the periodic gaits
    hold the speed, so equal speeds must be equal floats)."""
    return [float(round(v * pace, 2)) for v in speeds]


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

