"""One synthetic recording: its stride chain (plans, redraws, cache) and the sspinn Recording.

:func:`recording_chain` plans the strides of one program (:func:`~predictive.synth.planning.plan_strides`)
and solves them as a chain (:func:`~predictive.synth.chain.simulate_chain`); a stride that fails
goes down the chain's fallback ladder, and if every rung fails the recording ends cleanly after
its last solved stride. **No recording is thrown away for one stride**: only a recording whose
*first* stride cannot be solved gets a new stride plan (at most :data:`CHAIN_ATTEMPTS`), and then
it is dropped. Which rung solved each stride is in the recording's provenance
(``strides.fallback``, ``fallbacks``, ``ended_early``).

:func:`cached_recording` turns a chain into a :class:`~sspinn.data.dataset.Recording`:

* **IMUs**: :func:`sspinn.data.sensor_noise.measure_imu` on the ground truth with the true body (noise,
  biases, drift, misplacement, soft-tissue artefact; the nominal placement
  ``IMUPlacement.default(height)`` is what the recording tells the estimator).
* **Labels** (:meth:`~sspinn.data.dataset.Labels.from_trajectory` of the chain): q, u (the
  collocation u), q̈ (backward differences of u), τ, GRF and w (the contact model at the
  samples), speed (the stride's average pelvis speed, exact by construction).
  :func:`residual_stats` is the Kane residual of the labels as stored.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping, Sequence
from typing import Any, Final

import numpy as np

from predictive.ocp.solution import GaitSolution
from predictive.ocp.stride_nlp import StridePlan, StrideSolverCache
from predictive.synth.cache import CODE_VERSION, GENERATOR_NAME, SynthCache, jsonable, stable_hash
from predictive.synth.chain import FALLBACKS, ChainError, ChainResult, StrideRecord, simulate_chain
from predictive.synth.config import SynthConfig
from predictive.synth.periodic_reference import PeriodicReference
from predictive.synth.planning import plan_strides
from predictive.synth.subjects import VirtualSubject
from sspinn.data.dataset import Labels, Recording
from sspinn.data.gait_events import stance_fractions
from sspinn.data.sensor_noise import IMUErrorModel, measure_imu
from sspinn.errors import DataFormatError
from sspinn.model.body import BodyParameters, IMUPlacement
from sspinn.model.conventions import SEGMENTS
from sspinn.model.trajectory import Trajectory

#: Stride plans tried per recording before giving up.
CHAIN_ATTEMPTS: Final = 3


def recording_chain(
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
    :func:`~predictive.synth.chain.simulate_chain`; if every rung fails, the recording ends
    cleanly after its last solved stride. Only when its *first* stride cannot be solved is the
    recording's stride plan drawn again from the next random stream (at most
    :data:`CHAIN_ATTEMPTS` times); after that the recording is dropped. Each of these events is
    appended to ``events``. Returns (chain, cache key, attempt), or None if dropped."""
    stride_cfg = config.stride
    name = f"{subject.id}_{config.program_names[program]}"
    reference = PeriodicReference([library[v][0] for v in sorted(set(speeds))], boundary=config.boundary)
    error: ChainError | None = None
    for attempt in range(CHAIN_ATTEMPTS):
        rng = config.rng(2, subject.index, program, attempt)
        plans = plan_strides(speeds, config.duration_s, reference, config.variability, stride_cfg.h, rng)
        key = stable_hash(
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


def cached_recording(
    config: SynthConfig,
    subject: VirtualSubject,
    j: int,
    speeds: list[float],
    chain: ChainResult,
    chain_key: str,
    attempt: int,
    model: IMUErrorModel,
    cache: SynthCache,
) -> Recording:
    """The (cached) recording of ``subject``'s program ``j`` from its solved ``chain`` (cache key
    ``chain_key``, stride plan ``attempt``): IMU data measured on the ground truth with the true
    body and IMU error ``model``, the chain's labels, the provenance (program,
    strides and their fallback rungs, gait statistics, ground truth) and the Kane residual of the
    labels as stored (:func:`residual_stats`)."""
    name = f"{subject.id}_{config.program_names[j]}"
    nominal_placement = IMUPlacement.default(subject.height)
    imu_seed = [config.seed, 4, subject.index, j]
    rec_key = stable_hash(
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

    def make() -> Recording:
        return synthetic_recording(name, subject, chain, chain.speed, model, np.random.default_rng(imu_seed), {
            "generator": GENERATOR_NAME,
            "code_version": CODE_VERSION,
            "config_key": config.key(),
            # the text of the recordings already cached (CODE_VERSION 3); the chain is now
            # predictive.synth.chain with the stride NLP of predictive.ocp.stride_nlp
            "method": "chain of single-stride backward-Euler OCPs at h = 0.01 s (predictive.stride_chain)",
            "program": {"name": config.program_names[j], "speeds_mps": speeds, "pace": config.pace(subject.index)},
            "plan_attempt": attempt,
            "strides": stride_summary(chain.strides),
            "fallbacks": fallback_counts(chain.strides),
            "ended_early": chain.ended_early,
            "gait": gait_stats(chain, subject.body),
            "state_before_first_sample": {"q": chain.q_prev.tolist(), "u": chain.u_prev.tolist()},
        })

    return cache.recording(rec_key, name, make)


def synthetic_recording(name: str, subject: VirtualSubject, trajectory: Trajectory, speed: np.ndarray,
                        model: IMUErrorModel, rng: np.random.Generator, provenance: dict[str, Any],
                        rest: np.ndarray | None = None) -> Recording:
    """``subject``'s recording ``name`` of ``trajectory``: IMU signals measured on it with the true
    body and IMU error ``model`` (draws from ``rng``; the estimator is told the nominal placement;
    no soft-tissue artefact on the samples of ``rest``, (T,) bool, where the body stands still),
    its labels with the per-sample ``speed`` (m/s), and ``provenance`` followed by the ground truth
    (body, IMU placement), the error model and the labels' Kane residual (:func:`residual_stats`)."""
    nominal = IMUPlacement.default(subject.height)
    imu, info = measure_imu(trajectory.q, trajectory.u, trajectory.qdd, subject.body, nominal, model, rng, rest=rest)
    true_placement: IMUPlacement = info["true_placement"]
    rec = Recording(
        name=name, imu=imu, segments=SEGMENTS, height=subject.height, mass=subject.mass, subject=subject.id,
        placement=nominal, labels=Labels.from_trajectory(trajectory, speed=speed),
        provenance={
            **provenance,
            "ground_truth": {"body": jsonable(subject.body.to_dict()), "imu_placement": true_placement.to_dict()},
            "imu_error_model": jsonable(model.to_dict()),
        },
    )
    rec.provenance["kane_residual"] = residual_stats(rec, subject.body)
    return rec


def stride_summary(strides: Sequence[StrideRecord]) -> dict[str, list]:
    """The provenance's ``strides``: each kept stride's speed and planned speed (m/s), samples and
    fallback rung."""
    return {
        "speed_mps": [r.speed for r in strides],
        "planned_speed_mps": [r.planned_speed for r in strides],
        "n_samples": [r.n_nodes for r in strides],
        "fallback": [r.fallback for r in strides],
    }


def fallback_counts(strides: Sequence[StrideRecord]) -> dict[str, int]:
    """Strides per rung of :data:`~predictive.synth.chain.FALLBACKS` (every rung listed)."""
    return {rung: sum(r.fallback == rung for r in strides) for rung in FALLBACKS}


def residual_stats(rec: Recording, body: BodyParameters) -> dict[str, float]:
    """Kane residual of a recording's labels with the true body: max and RMS of the translational
    rows (BW) and of the rotational rows (BW·H), and the sample count."""
    if rec.labels is None:
        raise DataFormatError(f"{rec.name}: no labels (the Kane residual needs q, u, qdd, tau, grf and w)")
    try:
        trajectory = rec.labels.trajectory(rec.time)
    except DataFormatError as exc:
        raise DataFormatError(f"{rec.name}: {exc}") from None
    r = trajectory.kane_residual(body)
    return {
        "max_trans_bw": float(np.abs(r[:, :2]).max()),
        "rms_trans_bw": float(np.sqrt(np.mean(r[:, :2] ** 2))),
        "max_rot_bwh": float(np.abs(r[:, 2:]).max()),
        "rms_rot_bwh": float(np.sqrt(np.mean(r[:, 2:] ** 2))),
        "samples": int(r.shape[0]),
    }


def gait_stats(chain: ChainResult, body: BodyParameters) -> dict[str, float]:
    """Stance fractions per foot, double support, flight and the peak vertical GRF (BW) of a
    chain, written into every synthetic recording's provenance (contact above
    :data:`sspinn.data.gait_events.CONTACT_THRESHOLD_BW`)."""
    fy = chain.grf[:, [1, 3]] / body.body_weight
    return {**stance_fractions(fy[:, 0], fy[:, 1]), "peak_grf_y_bw": float(fy.max())}
