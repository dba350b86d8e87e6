"""Physically exact synthetic gait data with ground truth (the sspinn dataset format v1).

:func:`generate_dataset` makes virtual subjects walk and run, continuously and with
stride-to-stride variability and speed changes, and writes recordings whose labels satisfy the
equations of motion of the sspinn model at every 100 Hz sample. This module runs the pipeline
(the nominal body's template gaits, walking and running as two joblib tasks when ``workers > 1``;
the subjects, one joblib task each; then the dataset and its ``dataset.json``);
each step lives in its own module of :mod:`predictive.synth`.

Method
------
1. **Virtual subjects** (:mod:`predictive.synth.subjects`): height and BMI drawn per subject
   (what the estimator is told); the true segment parameters deviate from the generic Winter
   scaling that the estimator assumes.
2. **Periodic gaits of the true body** (:mod:`predictive.synth.gait_library`): the predictive
   OCP at each program speed on the exact 100 Hz grid, warm-started from a nominal body's
   template gaits.
3. **Stride chain** (:mod:`predictive.synth.chain`, :mod:`predictive.synth.planning`): the
   recording is a chain of single-stride OCPs (:mod:`predictive.ocp.stride_nlp`) on the 100 Hz
   grid, each starting from the fixed last sample of the previous stride, with the periodic gaits
   as initial guesses and terminal targets, per-stride variability of speed, duration and effort
   weights and gradual speed changes. **No recording is thrown away for one stride**: a stride
   that IPOPT cannot solve goes down a ladder of fallbacks
   (:data:`~predictive.synth.chain.FALLBACKS`: warm start, default options, a perturbed guess,
   the nominal duration, half the speed change, the previous speed); if every rung fails the
   recording ends cleanly after its last solved stride. Which rung solved each stride is in the
   recording's provenance (``strides.fallback``, ``fallbacks``, ``ended_early``), the counts in
   ``dataset.json`` (``info.solver.fallbacks``, ``info.events``), and ``predictive synth`` prints
   them; an early end warns (:class:`SynthWarning`). Periodic gaits have a ladder of their own
   (:data:`~predictive.synth.gait_library.PERIODIC_FALLBACKS`).
4. **IMUs** and 5. **labels** (:mod:`predictive.synth.recording`): IMU data measured on the
   ground truth with the true body and an IMU error model; labels q, u, q̈, τ, GRF, w and speed
   from the chain. The generator reports the Kane residual of the labels as written to disk.

Everything is deterministic given ``SynthConfig.seed`` (serial and parallel runs give identical
files); periodic solutions, chains and finished recordings are cached under ``cache_dir`` by a
hash of everything that determines them (:mod:`predictive.synth.cache`), so a second run only
reads files.

Usage::

    from predictive.synth.config import SynthConfig
    from predictive.synth.pipeline import generate_dataset
    config = SynthConfig.from_yaml("configs/synth/default.yaml")
    dataset = generate_dataset(config, "data/synth_default")   # sspinn.data.dataset.Dataset
    print(dataset.info["kane_residual"])                        # BW and BW·H, max and RMS

or ``python -m predictive synth --config configs/synth/default.yaml --out data/synth_default``.
With ``workers > 1`` each subject is a ``joblib`` task on ``config.backend`` (default ``loky``:
fresh worker processes on this machine, each keeping its compiled stride NLPs for its next
subjects; other backends and clusters: :mod:`predictive.synth.joblib_backend`); the progress of
workers on this machine comes through a spawned manager process, so a script calling
:func:`generate_dataset` needs the usual ``if __name__ == "__main__":`` guard. Every random draw
of a subject depends on the seed and the subject's index only (:meth:`SynthConfig.rng`), so the
files do not depend on the backend or the number of workers.
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import threading
import time
import warnings
from collections.abc import Callable, Mapping, Sequence
from contextlib import nullcontext
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Final, Literal

import numpy as np

from predictive.ocp.stride_nlp import StrideSettings, StrideSolverCache
from predictive.synth.cache import CODE_VERSION, GENERATOR_NAME, CacheStats, SynthCache, jsonable
from predictive.synth.chain import ChainError, StrideRecord
from predictive.synth.config import SynthConfig, imu_model
from predictive.synth.gait_library import RUN_SPEED, periodic_library, template_families, template_library
from predictive.synth.joblib_backend import LOCAL_BACKENDS, ProgressRelay, backend_context, check_backend
from predictive.synth.norms import MIN_INSIDE, RecordingNorms, recording_norms
from predictive.synth.norms import outside_norms as outside_norms_names
from predictive.synth.recording import cached_recording, fallback_counts, recording_chain, residual_stats
from predictive.synth.subjects import VirtualSubject, body_deviation, sample_subjects
from sspinn.data.dataset import SPLITS, Dataset, Recording
from sspinn.errors import UserError
from sspinn.run_folder import atomic_write_json


class NormsError(UserError):
    """A generated dataset has recordings outside the human gait norms and was not written
    (:func:`generate_dataset` with ``outside_norms="refuse"``)."""


class SynthWarning(UserWarning):
    """Something in a synthetic dataset did not go as planned (a recording ended early, a stride
    plan was drawn again, a recording was dropped); also listed in ``dataset.json``
    (``info.events``)."""


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
    """All recordings of one subject (see the module docstring): its periodic gaits, then per
    program the chain (:func:`~predictive.synth.recording.recording_chain`) and the recording
    (:func:`~predictive.synth.recording.cached_recording`).

    Args:
        config: the dataset configuration.
        subject: the subject (from :func:`~predictive.synth.subjects.sample_subjects`).
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
    programs = [(subject.index + j) % len(config.programs) for j in range(config.programs_per_subject)]
    speeds_needed = sorted({v for j in programs for v in config.speeds(subject.index, j)})

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
        name = f"{subject.id}_{config.program_names[j]}"
        speeds = config.speeds(subject.index, j)
        if config.shuffle_speeds:
            speeds = [speeds[i] for i in config.rng(3, subject.index, j).permutation(len(speeds))]
        found = recording_chain(config, subject, j, speeds, library, cache, solvers, report, events)
        if found is None:
            continue
        chain, chain_key, attempt = found
        strides.extend(chain.strides)
        if chain.ended_early:
            events.append({"recording": name, "event": "ended_early", "detail": chain.ended_early})
        recordings.append(cached_recording(config, subject, j, speeds, chain, chain_key, attempt, model, cache))
    stats = dataclasses.replace(cache.stats)
    for f in dataclasses.fields(stats):
        setattr(stats, f.name, getattr(stats, f.name) - getattr(stats0, f.name))
    return SubjectOutput(recordings, strides, stats, time.perf_counter() - t0, solvers.build_time - build0, events)


#: The compiled stride NLPs of this worker (process and thread), kept for its next subjects.
_WORKER_SOLVERS: Final = threading.local()


def _worker_solvers(settings: StrideSettings) -> StrideSolverCache:
    """This worker's :class:`StrideSolverCache` for ``settings``: building the stride NLPs takes
    seconds, so a worker that generates several subjects builds each NLP once (as the serial
    path does); one per thread, so that threads never share a CasADi solver."""
    solvers: StrideSolverCache | None = getattr(_WORKER_SOLVERS, "solvers", None)
    if solvers is None or solvers.settings != settings:
        solvers = StrideSolverCache(settings)
        _WORKER_SOLVERS.solvers = solvers
    return solvers


def _subject_job(config: SynthConfig, subject: VirtualSubject, queue: Any) -> tuple[int, SubjectOutput, float]:
    """Worker entry point: one subject, progress → ``queue`` (when not None); returns the
    subject's index, its output and the seconds of data it reported."""
    reported = [0.0]

    def on_progress(stage: str, seconds: float) -> None:
        reported[0] += seconds
        if queue is not None:
            queue.put((stage, seconds))

    solvers = _worker_solvers(config.stride)
    output = generate_subject(config, subject, SynthCache(config.cache_dir), solvers, on_progress)
    return subject.index, output, reported[0]


def generate_dataset(
    config: SynthConfig, out_dir: str | Path, progress: bool = True, cache_dir: str | Path | None = None,
    overwrite: bool = False, outside_norms: Literal["warn", "refuse"] = "warn",
) -> Dataset:
    """Generate (or load from the caches) the dataset of ``config`` into ``out_dir``.

    ``out_dir`` must be empty, absent, or hold an earlier output of this generator: of the same
    configuration and generator version (:meth:`SynthConfig.key`: it is written again, identical),
    or of another one only with ``overwrite`` (else a :class:`FileExistsError` names both: a
    dataset a model was trained on is never replaced silently). The earlier files are removed
    only once the new recordings are ready, so an interrupted run leaves them as they were. The returned dataset's ``info`` holds the configuration, the
    generation time, the Kane residual of the written labels (BW, BW·H), per-recording
    statistics (``norms``: every stance against the human ranges at its speed,
    :func:`predictive.synth.norms.recording_norms`) and the cache hits.

    ``outside_norms``: what to do when a recording has fewer than
    :data:`~predictive.synth.norms.MIN_INSIDE` of its stances inside the human ranges — "warn"
    (a :class:`SynthWarning` and an ``outside_norms`` event; the dataset is written) or "refuse"
    (:class:`NormsError` before anything is written; the solved chains stay cached).
    """
    if outside_norms not in ("warn", "refuse"):
        raise ValueError(f"outside_norms must be 'warn' or 'refuse', got {outside_norms!r}")
    t0 = time.perf_counter()
    if config.workers > 1:
        check_backend(config.backend)  # before the output folder is touched
    out = Path(out_dir)
    _check_out_dir(out, config.key(), overwrite)
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
    backend = backend_context(config.backend, config.backend_options) if config.workers > 1 else nullcontext()
    try:
        with backend:  # checked before any work
            # the nominal-body templates first (shared by all subjects and workers)
            on_progress("template gaits", 0.0)
            if config.workers == 1:
                template_library(config.all_speeds(), config.stride, cache)
                solvers = StrideSolverCache(config.stride)
                outputs = [generate_subject(config, subject, cache, solvers, on_progress) for subject in subjects]
                build_time = solvers.build_time
            else:
                _templates_parallel(config, cache)
                outputs = _generate_parallel(config, subjects, on_progress)
                build_time = sum(o.build_time_s for o in outputs)
    finally:
        if bar is not None:
            bar.close()
    by_split: dict[str, list[Recording]] = {s: [] for s in SPLITS if config.splits.get(s, 0) > 0}
    for subject, output in zip(subjects, outputs):
        by_split[subject.split].extend(output.recordings)
    events = [e for o in outputs for e in o.events]
    norms = dataset_norms(config, subjects, outputs)
    failing = outside_norms_names(norms)
    if failing and outside_norms == "refuse":
        raise NormsError(
            f"{len(failing)} of {len(norms)} recording(s) have fewer than {100 * MIN_INSIDE:.0f} % of their stances inside "
            "the human gait norms: " + "; ".join(norms[n].line() for n in failing)
            + " (nothing written: --require-norms)"
        )
    events += [{"recording": n, "event": "outside_norms", "detail": norms[n].line()} for n in failing]
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
    info: dict[str, Any] = {"generator": GENERATOR_NAME, "config_key": config.key()}
    _remove_earlier_output(out)
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
                "norms": norms[rec.name].as_dict(),
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
    atomic_write_json(
        out / "dataset.json",
        {"format": "sspinn-dataset", "version": 1, "splits": dataset.splits, "info": jsonable(info)},
        non_finite="null",
    )
    return Dataset.open(out)


def dataset_norms(
    config: SynthConfig, subjects: Sequence[VirtualSubject], outputs: Sequence[SubjectOutput]
) -> dict[str, RecordingNorms]:
    """Every recording's stances against the human gait norms at their speeds
    (:func:`predictive.synth.norms.recording_norms`; running when its program's speeds are at or
    above :data:`~predictive.synth.gait_library.RUN_SPEED`), by recording name."""
    out: dict[str, RecordingNorms] = {}
    for subject, output in zip(subjects, outputs):
        for rec in output.recordings:
            speeds = (rec.provenance.get("program") or {}).get("speeds_mps") or [float(np.median(rec.labels.speed))]
            mode = "run" if min(speeds) >= RUN_SPEED else "walk"
            out[rec.name] = recording_norms(rec, subject.body.body_weight, mode)
    return out


def _template_job(speeds: Sequence[float], stride: StrideSettings, cache_dir: str) -> CacheStats:
    """One gait family's template gaits into the cache at ``cache_dir``; the cache's counts."""
    cache = SynthCache(cache_dir)
    template_library(speeds, stride, cache)
    return cache.stats


def _templates_parallel(config: SynthConfig, cache: SynthCache) -> None:
    """The template gaits of walking and of running as two ``joblib`` tasks (on the backend
    entered by the caller), their cache counts added to ``cache``'s: each family's continuation
    holds one core for most of a minute, during which the other core would wait."""
    import joblib

    root = str(Path(config.cache_dir).resolve())
    families = template_families(config.all_speeds())
    parallel = joblib.Parallel(n_jobs=min(config.workers, len(families)), batch_size=1)
    for stats in parallel(joblib.delayed(_template_job)(family, config.stride, root) for family in families):
        cache.stats.add(stats)


def _generate_parallel(
    config: SynthConfig, subjects: Sequence[VirtualSubject], on_progress: Callable[[str, float], None]
) -> list[SubjectOutput]:
    """All subjects, one ``joblib`` task each, ``config.workers`` at a time on the backend
    entered by the caller (:func:`~predictive.synth.joblib_backend.backend_context`); the
    outputs in subject order whatever order the tasks finish in."""
    import joblib

    # workers may run elsewhere (another folder, another machine): an absolute cache folder
    job_config = dataclasses.replace(config, cache_dir=str(Path(config.cache_dir).resolve()))
    results: dict[int, SubjectOutput] = {}
    with contextlib.ExitStack() as stack:
        local = config.backend in LOCAL_BACKENDS
        queue = stack.enter_context(ProgressRelay(on_progress)) if local else None
        parallel = joblib.Parallel(n_jobs=config.workers, return_as="generator_unordered", batch_size=1)
        for index, output, seconds in parallel(joblib.delayed(_subject_job)(job_config, s, queue) for s in subjects):
            results[index] = output
            if not local:
                on_progress(f"{subjects[index].id}: done", seconds)
    return [results[s.index] for s in subjects]


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


def _earlier_output(out: Path) -> dict[str, Any] | None:
    """The index (``dataset.json``) of an earlier output of this generator in ``out``, or None."""
    index = out / "dataset.json"
    try:
        meta = json.loads(index.read_text()) if index.exists() else {}
    except json.JSONDecodeError:
        meta = {}
    return meta if isinstance(meta, dict) and meta.get("info", {}).get("generator") == GENERATOR_NAME else None


def _check_out_dir(out: Path, key: str, overwrite: bool) -> None:
    """Refuse an ``out`` that holds something else than an earlier output of this generator, or
    one of another configuration without ``overwrite`` (:func:`generate_dataset`); create it if absent."""
    if not out.exists():
        out.mkdir(parents=True)
        return
    earlier = _earlier_output(out)
    if earlier is None:
        if any(out.iterdir()):
            raise FileExistsError(f"{out} is not empty and holds no earlier output of {GENERATOR_NAME}; choose another --out")
        return
    if earlier["info"].get("config_key") != key and not overwrite:
        raise FileExistsError(
            f"{out} holds a synthetic dataset of another configuration or generator version (key "
            f"{str(earlier['info'].get('config_key'))[:12]}…, this one {key[:12]}…); replace it with --overwrite (models "
            "trained on it no longer match it then), or choose another --out"
        )


def _remove_earlier_output(out: Path) -> None:
    """Remove the recordings and index of an earlier output of this generator from ``out``."""
    earlier = _earlier_output(out)
    if earlier is None:
        return
    for names in earlier.get("splits", {}).values():
        for n in names:
            for ext in (".csv", ".json"):
                (out / f"{n}{ext}").unlink(missing_ok=True)
    (out / "dataset.json").unlink()


def _progress_bar(enabled: bool, total: float) -> Any:
    if not enabled:
        return None
    from tqdm import tqdm

    return tqdm(total=total, unit="s", unit_scale=False, desc="synthetic data", bar_format=_BAR)


_BAR: Final = "{desc:<34.34} {percentage:3.0f}%|{bar:20}| {n:.0f}/{total:.0f} s of data [{elapsed}<{remaining}]"
