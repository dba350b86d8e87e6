"""Recordings that start and end standing: quiet standing, gait initiation, steady walking, gait
termination and quiet standing again, with exact labels.

The walking and running recordings of :mod:`predictive.synth.pipeline` never stand, the standing
recordings of :mod:`predictive.synth.standing` never walk; real recordings usually do both. One
recording of :func:`start_stop_recording` is, at 100 Hz:

1. **Standing** for ``stand_s`` seconds: :func:`~predictive.synth.standing.standing_trajectory`
   (sway, feet flat, the load the equations of motion require shared between the feet), lowered
   to where the contact model carries the body weight (:func:`contact_height`).
2. **Initiation, steady walking, termination**: one stride chain
   (:func:`~predictive.synth.chain.simulate_chain`) that *starts from the last standing sample*
   (backward Euler from that state: the junction is as exact as any other sample of a chain),
   with the stride speeds ramping up (:func:`ramp_speeds`, nominal durations), steady
   strides at the speed (:func:`~predictive.synth.planning.plan_strides`, the configuration's
   stride-to-stride variability), the ramp reversed, and a stretch of :data:`SETTLE_NODES` samples
   at speed 0 whose end tracks the first sample of the closing standing trajectory with the
   terminal weight :data:`SETTLE_WEIGHT` (its own compiled NLPs). The reference gaits include
   standing still as the gait at 0 m/s (``PeriodicReference(..., rest=...)``), so the slow strides
   of the ramps take short steps, and the strides from and to rest have guesses of their own
   (see :func:`~predictive.synth.chain.simulate_chain`). Every stride must solve (on any rung of
   the fallback ladder), else :class:`~predictive.synth.chain.ChainError`.
3. **Standing** again for ``stand_s`` seconds: a second standing trajectory (its own sway),
   lowered as in 1 and moved forward to where the chain stopped; its first sample is the settle stretch's target and is
   left out, the recording goes on with its second.

**Labels.** Every sample satisfies the equations of motion (the Kane residual of the standing
samples is at rounding level, that of the chain at IPOPT's tolerance; both are in the provenance,
``kane_residual``). The one junction that is not exact by construction is the last: the chain ends
*near* the standing state (the settle stretch's terminal term is a penalty, not a constraint), so
its kinematic mismatch ``(q_s − q_N)/h − u_s`` (the backward difference the chain's samples obey
exactly) is measured and written to the provenance (``junction``). At both junctions the ground
reaction forces change model: the standing parts share the required load equally between the
feet, the chain's samples carry the contact model's forces (smoke subjects S01 and S02 at the
first junction: 0.47–0.48 BW per foot against the standing labels' 0.5 and 0.5).

**Speed label**: 0 while standing (the settle stretch too, a plan of speed 0), the stride's average
pelvis speed during the strides (as in every chain), so it steps from 0 to the first ramp speed
at the first stride.

**Running** (a speed at or above :data:`~predictive.synth.gait_library.RUN_SPEED`) starts the way
people start a run: walking first. The reference then holds the subject's walking gait at
:data:`RUN_UP_WALK_MPS` beside its running gait, and the ramp walks its first two strides (the
walking ramp's 0.3 and 0.72 m/s), then gains :data:`RUN_UP_STEP_MPS` per stride through the jog
into the run. Ramped like walking (0.25, 0.6, 0.9 × the running speed) on the running gait alone,
the first stride had to reach 0.75 m/s in a running stride's time from standing: both smoke
subjects stepped back (the pelvis at −0.37 and −0.29 m/s) and hopped (flight phases, 3.7 BW).
Through walking, at 3.0 m/s, both step off at −0.03 m/s as the walking start does, the first two
strides have no flight phase (peaks 1.3–1.8 BW), the strides at 1.32 and 1.92 m/s jog (short
flight phases), the run begins at 2.7 m/s (``python -m benchmarks.studies.start_stop --speed
3.0 --subject 0``, and ``--subject 1``). The stop mirrors it and is less human: braking through
1.92 and 1.32 m/s peaks at 4.7–6.9 BW.

Usage: ``python -m predictive synth-standing --config configs/synth/smoke.yaml --split test
--start-stop 1.2 --out data/start_stop``.
"""

from __future__ import annotations

import dataclasses
import math
import time
from typing import Final

import numpy as np

from predictive.ocp.stride_nlp import StridePlan, StrideSettings, StrideSolverCache
from predictive.synth.cache import CODE_VERSION, GENERATOR_NAME, SynthCache
from predictive.synth.chain import ChainResult, simulate_chain
from predictive.synth.config import SynthConfig, imu_model
from predictive.synth.gait_library import RUN_SPEED, periodic_library, template_library
from predictive.synth.periodic_reference import PeriodicReference, ReferenceStride
from predictive.synth.planning import plan_strides
from predictive.synth.recording import fallback_counts, stride_summary, synthetic_recording
from predictive.synth.standing import SWAY_HZ, SWAY_RAD, standing_trajectory
from predictive.synth.subjects import VirtualSubject
from sspinn.data.dataset import SAMPLE_RATE_HZ, Recording
from sspinn.model.body import BodyParameters
from sspinn.model.contact import ContactParameters
from sspinn.model.dynamics import contact_forces
from sspinn.model.trajectory import COLUMNS, Trajectory

#: Speeds of the strides of gait initiation, fractions of the walking speed (termination: reversed).
RAMP: Final[tuple[float, ...]] = (0.25, 0.6, 0.9)
#: Walking speed of a running start's first strides (m/s): its walking gait joins the reference.
RUN_UP_WALK_MPS: Final = 1.2
#: Speed gained per stride of a running start after its two walking strides, m/s.
RUN_UP_STEP_MPS: Final = 0.6
#: Samples of the standing stretch at the end of the chain that reaches the closing standing state.
SETTLE_NODES: Final = 30
#: Terminal weight of the settle stretch (``StrideSettings.w_terminal``; the strides use the config's).
SETTLE_WEIGHT: Final = 1e4


@dataclasses.dataclass
class StartStopTrajectory:
    """A stand–walk–stand trajectory and what made it.

    Attributes:
        trajectory: every sample (SI units of :mod:`sspinn.model.conventions`), times k·h.
        speed: (T,) speed label, m/s (0 while standing).
        phase: (T,) 0 standing before, 1 walking (the chain, settle stretch included), 2 standing after.
        chain: the solved chain (its strides' statistics).
        junction: the end junction's mismatch: ``kinematic`` max |(q_s − q_N)/h − u_s| (m/s, rad/s),
            ``q`` max |q_N − target q| (m, rad; pelvis_tx aligned), ``u`` max |u_N − target u|.
        time_s: wall-clock seconds of the chain (solver builds included).
    """

    trajectory: Trajectory
    speed: np.ndarray
    phase: np.ndarray
    chain: ChainResult
    junction: dict[str, float]
    time_s: float


def ramp_speeds(speed: float) -> tuple[float, ...]:
    """Speeds (m/s) of the strides that start a gait at ``speed`` from standing (its stop: the same,
    reversed). Walking: the :data:`RAMP` fractions of ``speed``. Running (``speed`` at or above
    :data:`~predictive.synth.gait_library.RUN_SPEED`): two walking strides (the first two
    :data:`RAMP` fractions of :data:`RUN_UP_WALK_MPS`), then :data:`RUN_UP_STEP_MPS` more per stride
    while that stays more than half a step below the last, ``RAMP[-1]`` × ``speed`` (3.0 m/s: 0.3,
    0.72, 1.32, 1.92, 2.7)."""
    if speed < RUN_SPEED:
        return tuple(f * speed for f in RAMP)
    speeds = [f * RUN_UP_WALK_MPS for f in RAMP[:2]]
    last = RAMP[-1] * speed
    while speeds[-1] + RUN_UP_STEP_MPS < last - RUN_UP_STEP_MPS / 2:
        speeds.append(speeds[-1] + RUN_UP_STEP_MPS)
    return (*speeds, last)


def start_stop_plans(
    speed: float, walk_s: float, reference: PeriodicReference, config: SynthConfig, rng: np.random.Generator
) -> list[StridePlan]:
    """The chain's plans: the :func:`ramp_speeds` strides up, steady strides covering ``walk_s``
    seconds at ``speed`` (m/s) with the configuration's variability, the ramp down and the settle
    stretch (speed 0, :data:`SETTLE_NODES` samples)."""
    h = config.stride.h

    def nominal(v: float) -> StridePlan:
        return StridePlan(speed=v, n_nodes=int(round(reference.nominal_duration(v) / h)))

    ramp = ramp_speeds(speed)
    steady = plan_strides([speed], walk_s, reference, config.variability, h, rng)
    return [nominal(v) for v in ramp] + steady + [nominal(v) for v in reversed(ramp)] + [StridePlan(0.0, SETTLE_NODES)]


def start_stop_trajectory(
    config: SynthConfig,
    subject: VirtualSubject,
    speed: float,
    stand_s: float,
    walk_s: float,
    rng: np.random.Generator,
    cache: SynthCache,
    solvers: StrideSolverCache | None = None,
    rest_solvers: StrideSolverCache | None = None,
) -> StartStopTrajectory:
    """``subject`` standing for ``stand_s`` s, walking at ``speed`` (m/s; ``walk_s`` s of steady
    strides between the ramps) and standing again (module docstring). The periodic gaits come
    from ``cache`` (solved if missing, as for the subject's walking recordings); ``solvers`` and
    ``rest_solvers`` (the settle stretch's, :data:`SETTLE_WEIGHT`) may be shared between calls."""
    _check(speed, stand_s, walk_s)
    stride = config.stride
    h = stride.h
    if not math.isclose(h * SAMPLE_RATE_HZ, 1.0):
        raise ValueError(f"the stride step h = {h} s is not the recordings' sample interval 1/{SAMPLE_RATE_HZ} s")
    solvers = solvers if solvers is not None else StrideSolverCache(stride)
    rest_solvers = rest_solvers if rest_solvers is not None else settle_solvers(stride)
    before = standing_trajectory(subject.body, stand_s, rng)
    after = standing_trajectory(subject.body, stand_s, rng)
    for part, k in ((before, -1), (after, 0)):  # where the contact model carries the body at the junction
        part.q[:, 1] += contact_height(part.q[k], subject.body, solvers.contact)
    gaits = [speed] if speed < RUN_SPEED else [RUN_UP_WALK_MPS, speed]  # a run starts walking
    templates = template_library(gaits, stride, cache)
    library = periodic_library(subject.body, gaits, stride, cache, templates)
    rest = ReferenceStride(before.q[-1:], before.u[-1:], before.tau[-1:], before.grf[-1:], before.q[-1], before.u[-1])
    reference = PeriodicReference([library[v][0] for v in gaits], boundary=config.boundary, rest=rest)
    plans = start_stop_plans(speed, walk_s, reference, config, rng)
    last = len(plans) - 1
    target = (after.q[0], after.u[0])
    t0 = time.perf_counter()
    chain = simulate_chain(
        subject.body, plans, reference, solvers, lookahead=0, min_strides=len(plans),
        start=(before.q[-1], before.u[-1]), targets={last - 1: target, last: target}, rest_solvers=rest_solvers,
    )
    elapsed = time.perf_counter() - t0
    after.q[:, 0] += chain.q[-1, 0] - after.q[0, 0]
    q_n, u_n = chain.q[-1], chain.u[-1]
    junction = {
        "kinematic": float(np.abs((after.q[1] - q_n) / h - after.u[1]).max()),
        "q": float(np.abs(q_n - after.q[0]).max()),
        "u": float(np.abs(u_n - after.u[0]).max()),
    }
    parts = (before, chain, after[1:])
    n = [len(p.q) for p in parts]
    arrays = {k: np.concatenate([getattr(p, k) for p in parts]) for k in COLUMNS}
    trajectory = Trajectory(time=np.arange(sum(n)) * h, **arrays)
    speed_label = np.concatenate([np.zeros(n[0]), chain.speed, np.zeros(n[2])])
    phase = np.repeat(np.arange(3), n)
    return StartStopTrajectory(trajectory, speed_label, phase, chain, junction, elapsed)


def contact_height(q: np.ndarray, body: BodyParameters, contact: ContactParameters) -> float:
    """Vertical shift (m, negative: down) of the posture ``q`` (at rest) at which the contact
    model's vertical forces add up to the body weight (bisection to 1e-7 m within ±5 cm).

    The standing trajectories put both soles on y = 0, where the contact model (a softplus
    penetration 3.3 mm wide) carries a fraction of the weight: a chain started there first fell
    into the floor (with the left sole of the 1.2 m/s smoke subject S02 also 11.9 mm up, before
    the standing posture bent the longer leg: 0.24 BW carried at the start, a flight and a 5.0 BW
    landing in the first stride).
    Shifting a standing trajectory vertically leaves its labels exact (the forces do not depend on
    the height)."""
    q = np.asarray(q, dtype=float)

    def excess(dy: float) -> float:
        shifted = q.copy()
        shifted[1] += dy
        grf, _ = contact_forces(shifted, np.zeros_like(q), body, contact)
        return float(np.asarray(grf)[[1, 3]].sum()) - body.body_weight

    lo, hi = -0.05, 0.05  # excess(lo) > 0 (deep in the floor) > excess(hi) (in the air)
    if not excess(lo) > 0 > excess(hi):
        raise ValueError(f"the contact model does not carry the body weight within ±5 cm of the standing posture {q.tolist()}")
    while hi - lo > 1e-7:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if excess(mid) > 0 else (lo, mid)
    return 0.5 * (lo + hi)


def settle_solvers(stride: StrideSettings) -> StrideSolverCache:
    """Compiled NLPs of the settle stretch: ``stride`` with the terminal weight :data:`SETTLE_WEIGHT`
    and without the angle and GRF priors (their targets are walking references; the stretch's
    job is to reach the standing state: with them its end missed it by 0.03 m/s)."""
    return StrideSolverCache(dataclasses.replace(stride, w_terminal=SETTLE_WEIGHT, w_angle_prior=0.0, w_grf_prior=0.0))


def _check(speed: float, stand_s: float, walk_s: float) -> None:
    if not (math.isfinite(speed) and speed > 0):
        raise ValueError(f"speed must be a finite number > 0 m/s, got {speed}")
    if not (math.isfinite(stand_s) and stand_s > 0):
        raise ValueError(f"stand_s must be a finite number > 0 s, got {stand_s}")
    if not (math.isfinite(walk_s) and walk_s >= 0):
        raise ValueError(f"walk_s must be a finite number >= 0 s, got {walk_s}")


def start_stop_recording(
    config: SynthConfig,
    subject: VirtualSubject,
    speed: float,
    stand_s: float = 2.0,
    walk_s: float = 2.0,
    cache: SynthCache | None = None,
    solvers: StrideSolverCache | None = None,
    rest_solvers: StrideSolverCache | None = None,
) -> Recording:
    """``<subject>_startstop``: ``subject`` stands, walks at ``speed`` (m/s) and stands again
    (:func:`start_stop_trajectory`); the sway, the steady strides' variability and the IMU errors
    are drawn from ``[config.seed, 7, subject.index]``, the IMU error model is the configuration's
    (:func:`~predictive.synth.recording.synthetic_recording`; no soft-tissue artefact while
    standing, fading in and out over :data:`~sspinn.data.sensor_noise.STA_RAMP_S` of the
    walk). The periodic gaits are cached in
    ``cache``, the chain is not (about half a minute per recording on one core)."""
    _check(speed, stand_s, walk_s)
    cache = cache if cache is not None else SynthCache(config.cache_dir)
    seed = [config.seed, 7, subject.index]
    rng = np.random.default_rng(seed)
    made = start_stop_trajectory(config, subject, speed, stand_s, walk_s, rng, cache, solvers, rest_solvers)
    chain = made.chain
    bounds = np.flatnonzero(np.diff(made.phase)) + 1
    return synthetic_recording(f"{subject.id}_startstop", subject, made.trajectory, made.speed, imu_model(config), rng, {
        "generator": GENERATOR_NAME,
        "code_version": CODE_VERSION,
        "config_key": config.key(),
        "method": "standing with sway, stride chain from and to rest, standing with sway (predictive.synth.start_stop)",
        "program": {"name": "start_stop", "speeds_mps": [0.0, speed, 0.0], "stand_s": stand_s, "walk_s": walk_s},
        "phases": {"walk_start_sample": int(bounds[0]), "stand_start_sample": int(bounds[1])},
        "strides": {**stride_summary(chain.strides), "iterations": [r.iterations for r in chain.strides]},
        "fallbacks": fallback_counts(chain.strides),
        "junction": made.junction,
        "sway": {"frequencies_hz": list(SWAY_HZ), "scale_rad": SWAY_RAD, "seed": seed},
    }, rest=made.phase != 1)
