"""The compiled step of the NumPy walker environments: one control interval of N walkers in one
numba call, used by both :class:`~envs.sagittal_walker.SagittalWalkerEnv` (N = 1, serial) and
:class:`~envs.vector.SagittalWalkerVectorEnv` (N walkers, ``numba.prange`` over them).

Both environments therefore share every line of the step: actuator torques (clipping, strength),
the push of :class:`envs.disturbances.Disturbances`, the physics (:func:`sspinn.model.simulation.advance_forced`,
50 semi-implicit Euler substeps by default), the reward and termination formulas of
:mod:`envs.task` (compiled from the same Python functions the torch environment evaluates),
truncation, the sticky flags after an episode's end, observation delay and noise, and the info
quantities. :class:`envs.walker_state.WalkerState` owns the arrays and calls these kernels.

Arrays (N walkers; "row i" is walker i):

* ``q``, ``u`` (N, 9), ``grf`` (N, 4), ``tau`` (N, 6): state (SI), contact forces (N) and applied
  actuator torques (N·m) of the last interval.
* ``p`` (N, 41): body parameters of each simulated body (:meth:`sspinn.model.body.BodyParameters.vector`).
* ``fenv`` (N, :data:`N_FENV`) float64 per-walker scalars, columns ``F_*``; ``ienv`` (N,
  :data:`N_IENV`) int64 per-walker integers, columns ``I_*``.
* ``strength`` (N, 6): torque factors; ``noise_std`` (N, 22): observation-noise std per entry.
* ``history`` (N, :data:`HISTORY`, 22): ring of the last noise-free observations (for the delay).
* shared: ``c`` (7,) contact, ``passive`` (14,), ``tau_max`` (6,) N·m, ``fpar`` (:data:`N_FPAR`,)
  and ``ipar`` (:data:`N_IPAR`,) task and physics constants, columns ``P_*``.
* outputs: ``obs`` (N, 22) float32, ``out`` (N, :data:`N_OUT`) float64 columns ``O_*``, ``flags``
  (N, 3) bool: terminated, truncated, physics failure.
* ``work`` (N, :data:`WALKER_WORK_ROWS`, 9) float64: each walker's workspace (the physics'
  :func:`~sspinn.model.simulation.advance_forced_into` rows, then the state before the step and the
  external force), so that a step allocates nothing.

Observation noise uses a counter-based generator (SplitMix64 finaliser as the hash, Box–Muller for
the normal draws): draw k of walker i is a pure function of (key_i, k), so results do not depend on
how ``prange`` distributes walkers over threads. NumPy's Generators cannot be used per walker inside
one compiled parallel loop, and numba's own ``np.random`` keeps one stream per *thread*, which would
make a walker's noise depend on the thread schedule; hence the hand-written generator.
"""

from __future__ import annotations

import math
import os
from typing import Final

import numba
import numpy as np

from envs import task
from sspinn.model.conventions import N_Q, N_TAU
from sspinn.model.simulation import WORK_ROWS, advance_forced_into, contact_into

# ---------------------------------------------------------------------------------- array layouts
#: ``fenv`` columns: target speed (m/s), hip x at reset (m), joint work so far (J), standing hip
#: height of the simulated body (m), its body weight (N), push force (N, + forward), horizontal
#: contact force of the right and left foot at the previous control step (N), current phase
#: duration of the right and left foot (s; + in contact, − in the air, :func:`envs.task.next_phase`).
(F_TARGET, F_X0, F_WORK, F_STANDING, F_BODY_WEIGHT, F_PUSH_FORCE, F_FX_PREV_R, F_FX_PREV_L, F_PHASE_R,
 F_PHASE_L) = range(10)
N_FENV: Final[int] = 10
#: ``ienv`` columns: control steps since reset; ended flags of the episode (1 terminated, 2
#: truncated); push mode (:data:`PUSH_NONE`, ...); push start step (time mode) or earliest step
#: (phase modes); push intervals left; push running (0/1); observation delay (steps); noise key.
I_STEPS, I_ENDED, I_PUSH_MODE, I_PUSH_AT, I_PUSH_LEFT, I_PUSH_ON, I_DELAY, I_NOISE_KEY = range(8)
N_IENV: Final[int] = 8
#: Push modes: none, at a time, at mid-stance of the right / left foot.
PUSH_NONE, PUSH_AT_TIME, PUSH_MIDSTANCE_R, PUSH_MIDSTANCE_L = range(4)
#: ``fpar`` columns: control interval (s), physics substep (s), tracking weight, tracking width
#: (m/s), alive bonus, effort weight, min height fraction, max tilt (rad), contact threshold (BW),
#: nominal body weight (N, the unit of the observed contact forces), friction μ, slip velocity
#: (m/s), slip weight, impact weight, impact threshold (BW) of the shaping penalty, phase weight and
#: longest phase (s) of the phase penalty.
(P_CONTROL_DT, P_PHYSICS_DT, P_TRACKING_WEIGHT, P_TRACKING_WIDTH, P_ALIVE_BONUS, P_EFFORT_WEIGHT,
 P_MIN_HEIGHT_FRACTION, P_MAX_TILT, P_CONTACT_THRESHOLD, P_BODY_WEIGHT, P_FRICTION, P_SLIP_VELOCITY,
 P_SLIP_WEIGHT, P_IMPACT_WEIGHT, P_IMPACT_THRESHOLD, P_PHASE_WEIGHT, P_MAX_PHASE) = range(17)
N_FPAR: Final[int] = 17
#: ``ipar`` columns: substeps, integrator index (:data:`sspinn.model.simulation.METHODS`), episode length.
Q_SUBSTEPS, Q_METHOD, Q_MAX_STEPS = range(3)
N_IPAR: Final[int] = 3
#: ``out`` columns: reward, hip speed over the step (m/s), distance since reset (m), mechanical cost
#: of transport, tracking term, alive term, effort term, push force applied during the step (N).
O_REWARD, O_SPEED, O_DISTANCE, O_COT, O_TRACKING, O_ALIVE, O_EFFORT, O_PUSH = range(8)
N_OUT: Final[int] = 8
#: Rows of a walker's workspace: the physics' (:data:`sspinn.model.simulation.WORK_ROWS`), then
#: q before the step, u before the step, the external generalized force.
W_Q_BEFORE, W_U_BEFORE, W_FORCE = WORK_ROWS, WORK_ROWS + 1, WORK_ROWS + 2
WALKER_WORK_ROWS: Final[int] = WORK_ROWS + 3
#: Length of the observation history ring (largest delay + 1).
HISTORY: Final[int] = 51
OBS_SIZE: Final[int] = task.OBS_SIZE

def _choose_threading_layer() -> str:
    """numba's threading layer for :func:`step_parallel`, unless the user chose one
    (``NUMBA_THREADING_LAYER``): GNU OpenMP when its threads wait passively
    (``OMP_WAIT_POLICY=passive``, see :func:`envs.openmp.prefer_passive_openmp`), else numba's own
    ``workqueue``.

    Measured on the 2-core development machine, :class:`~envs.vector.SagittalWalkerVectorEnv`
    with random actions, µs per vector step:

    ======================================  ========  ==========  ==================================
    layer                                   N = 64    N = 512     N = 8 / 64 beside a busy process
    ======================================  ========  ==========  ==================================
    workqueue                               1,315     7,681       402 / 1,707
    OpenMP, default wait policy (spinning)  843       6,519       438 / 3,009
    OpenMP, ``OMP_WAIT_POLICY=passive``     895       6,537       239 / 1,674
    ======================================  ========  ==========  ==================================

    (one thread: 1,699 and 13,154). workqueue's parallel region costs 70–80 µs even when empty
    (OpenMP: 1.5 µs spinning, 45 µs passive), so passive OpenMP is the fastest alone and as good
    as workqueue beside other work, where spinning OpenMP loses. The policy is a process-wide
    setting read once, when libgomp loads, and it would also slow torch's multi-threaded
    operations; so the environment does not set it on import, and a process that did not ask for
    it gets workqueue.
    """
    if numba.config.THREADING_LAYER != "default":
        return str(numba.config.THREADING_LAYER)
    if os.environ.get("OMP_WAIT_POLICY", "").lower() == "passive":  # OpenMP first where numba has it
        numba.config.THREADING_LAYER_PRIORITY = ["omp", "tbb", "workqueue"]
        return "omp"
    numba.config.THREADING_LAYER = "workqueue"
    return "workqueue"


#: The threading layer asked for at import (:func:`_choose_threading_layer`; "omp": OpenMP where
#: numba finds it, else its next layer). ``numba.threading_layer()`` names the one in use after
#: the first parallel call.
PARALLEL_LAYER: Final[str] = _choose_threading_layer()

_tracking_term = numba.njit(cache=True)(task.tracking_term)
_step_reward = numba.njit(cache=True)(task.step_reward)
_fell = numba.njit(cache=True)(task.fell)
_foot_slip = numba.njit(cache=True)(task.foot_slip)
_shaping_penalty = numba.njit(cache=True)(task.shaping_penalty)
_next_phase = numba.njit(cache=True)(task.next_phase)
_phase_penalty = numba.njit(cache=True)(task.phase_penalty)

_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_MIX1 = np.uint64(0xBF58476D1CE4E5B9)
_MIX2 = np.uint64(0x94D049BB133111EB)


# ------------------------------------------------------------------------------- random numbers
@numba.njit(cache=True)
def _mix(z):  # pragma: no cover - compiled
    """SplitMix64 finaliser: a bijective 64-bit hash."""
    z = z + _GOLDEN
    z = (z ^ (z >> np.uint64(30))) * _MIX1
    z = (z ^ (z >> np.uint64(27))) * _MIX2
    return z ^ (z >> np.uint64(31))


@numba.njit(cache=True)
def uniform(key, counter):  # pragma: no cover - compiled
    """Uniform number in (0, 1) for (key, counter) (uint64 key, non-negative integer counter)."""
    z = _mix(key ^ _mix(np.uint64(counter)))
    return (float(z >> np.uint64(11)) + 0.5) * (1.0 / 9007199254740992.0)


@numba.njit(cache=True)
def normal(key, counter):  # pragma: no cover - compiled
    """Standard normal number for (key, counter), Box–Muller on two uniforms."""
    u1 = uniform(key, 2 * counter)
    u2 = uniform(key, 2 * counter + 1)
    return math.sqrt(-2.0 * math.log(u1)) * math.cos(2.0 * math.pi * u2)


# ---------------------------------------------------------------------------------- observation
@numba.njit(cache=True)
def _record(i, q, u, grf, fenv, ienv, history, fpar):  # pragma: no cover - compiled
    """Store walker i's noise-free observation (layout :data:`envs.task.OBSERVATION_NAMES`) in its
    history ring at step ``ienv[i, I_STEPS]``."""
    h = history[i, ienv[i, I_STEPS] % HISTORY]
    bw = fpar[P_BODY_WEIGHT]
    for j in range(N_Q - 1):
        h[j] = q[i, j + 1]
    for j in range(N_Q):
        h[N_Q - 1 + j] = u[i, j]
    for j in range(4):
        h[2 * N_Q - 1 + j] = grf[i, j] / bw
    h[OBS_SIZE - 1] = fenv[i, F_TARGET]


@numba.njit(cache=True)
def _emit(i, ienv, noise_std, history, obs):  # pragma: no cover - compiled
    """obs[i] ← the recorded observation of ``obs_delay`` steps ago, plus noise drawn for this step."""
    t = ienv[i, I_STEPS]
    seen = history[i, (t - ienv[i, I_DELAY] + HISTORY) % HISTORY]
    key = np.uint64(ienv[i, I_NOISE_KEY])
    for j in range(OBS_SIZE):
        value = seen[j]
        if noise_std[i, j] > 0.0:
            value += noise_std[i, j] * normal(key, t * OBS_SIZE + j)
        obs[i, j] = value


@numba.njit(cache=True)
def _reset_walker(i, q, u, grf, p, c, fenv, ienv, noise_std, history, fpar, obs):  # pragma: no cover - compiled
    """Start walker i's episode from its (q, u): contact forces, counters, history, observation."""
    contact_into(q[i], u[i], p[i], c, True, grf[i])
    fenv[i, F_X0] = q[i, 0]
    fenv[i, F_WORK] = 0.0
    fenv[i, F_FX_PREV_R] = grf[i, 0]
    fenv[i, F_FX_PREV_L] = grf[i, 2]
    ienv[i, I_STEPS] = 0
    ienv[i, I_ENDED] = 0
    ienv[i, I_PUSH_ON] = 0
    fenv[i, F_PHASE_R] = 0.0
    fenv[i, F_PHASE_L] = 0.0
    _record(i, q, u, grf, fenv, ienv, history, fpar)
    for k in range(1, HISTORY):  # the first observation until a delay's worth of steps has passed
        history[i, k, :] = history[i, 0, :]
    _emit(i, ienv, noise_std, history, obs)


#: ``efloat`` columns of :func:`start_rows` (an episode's float constants): standing hip height of
#: the simulated body (m), its body weight (N), push force (N), shift of a given initial state's
#: pelvis_ty (m: simulated minus announced standing height).
E_STANDING, E_BODY_WEIGHT, E_PUSH_FORCE, E_SHIFT = range(4)
#: ``eint`` columns of :func:`start_rows`: push mode, push start step, push intervals, observation delay.
E_PUSH_MODE, E_PUSH_AT, E_PUSH_STEPS, E_DELAY = range(4)


@numba.njit(cache=True)
def start_rows(rows, targets, picks, draws, keys, initial, starts, efloat, eint, ep_p, ep_strength, ep_noise_std,
               q, u, grf, tau, p, strength, noise_std, fenv, ienv, c, history, fpar, obs):  # pragma: no cover - compiled
    """Start the episodes of the walkers ``rows`` (indices) from the draws made for them in Python.

    Row n of the draws belongs to walker ``rows[n]``: ``targets`` (m/s), ``picks`` (row of
    ``starts`` (K, 18) to start from, or −1), ``draws`` (8 coordinate then 9 speed noise values),
    ``keys`` (observation-noise keys). ``initial`` is a given initial state (q, u) (18,), or empty.
    The episode's constants are ``efloat`` (``E_STANDING`` ...), ``eint`` (``E_PUSH_MODE`` ...)
    and the body ``ep_p``, torque factors ``ep_strength`` and observation-noise std ``ep_noise_std``.
    The state is built as in Python (the same floating-point operations in the same order), then
    :func:`_reset_walker` computes contact forces, counters, history and the first observation."""
    for n in range(rows.shape[0]):
        i = rows[n]
        if initial.shape[0] > 0:
            for j in range(N_Q):
                q[i, j] = initial[j]
                u[i, j] = initial[N_Q + j]
            q[i, 1] += efloat[E_SHIFT]
        elif picks[n] >= 0:
            for j in range(N_Q):
                q[i, j] = starts[picks[n], j]
                u[i, j] = starts[picks[n], N_Q + j]
        else:
            for j in range(N_Q):
                q[i, j] = 0.0
                u[i, j] = 0.0
            q[i, 1] = efloat[E_STANDING]
        q[i, 0] = 0.0
        for j in range(1, N_Q):
            q[i, j] += draws[n, j - 1]
        for j in range(N_Q):
            u[i, j] += draws[n, N_Q - 1 + j]
        p[i, :] = ep_p
        strength[i, :] = ep_strength
        noise_std[i, :] = ep_noise_std
        tau[i, :] = 0.0
        fenv[i, F_TARGET] = targets[n]
        fenv[i, F_STANDING] = efloat[E_STANDING]
        fenv[i, F_BODY_WEIGHT] = efloat[E_BODY_WEIGHT]
        fenv[i, F_PUSH_FORCE] = efloat[E_PUSH_FORCE]
        ienv[i, I_PUSH_MODE] = eint[E_PUSH_MODE]
        ienv[i, I_PUSH_AT] = eint[E_PUSH_AT]
        ienv[i, I_PUSH_LEFT] = eint[E_PUSH_STEPS]
        ienv[i, I_DELAY] = eint[E_DELAY]
        ienv[i, I_NOISE_KEY] = keys[n]
        _reset_walker(i, q, u, grf, p, c, fenv, ienv, noise_std, history, fpar, obs)


# ----------------------------------------------------------------------------------------- step
@numba.njit(cache=True)
def _push_now(i, grf, fenv, ienv, fpar):  # pragma: no cover - compiled
    """Whether walker i's push acts during the coming control interval (and count it)."""
    mode = ienv[i, I_PUSH_MODE]
    if mode == PUSH_NONE or ienv[i, I_PUSH_LEFT] <= 0:
        return False
    if ienv[i, I_PUSH_ON] == 0:
        if ienv[i, I_STEPS] < ienv[i, I_PUSH_AT]:
            return False
        if mode != PUSH_AT_TIME:  # mid-stance: single support, braking → propulsive horizontal force
            foot = mode - PUSH_MIDSTANCE_R
            other = 1 - foot
            threshold = fpar[P_CONTACT_THRESHOLD] * fenv[i, F_BODY_WEIGHT]
            single = grf[i, 2 * foot + 1] > threshold and grf[i, 2 * other + 1] <= threshold
            if not (single and fenv[i, F_FX_PREV_R + foot] < 0.0 and grf[i, 2 * foot] >= 0.0):
                return False
        ienv[i, I_PUSH_ON] = 1
    ienv[i, I_PUSH_LEFT] -= 1
    return True


@numba.njit(cache=True)
def _step_walker(i, actions, q, u, grf, tau, p, fenv, ienv, strength, noise_std, history, c, passive, tau_max,
                 fpar, ipar, obs, out, flags, work):  # pragma: no cover - compiled
    """One control interval of walker i (module docstring); writes obs[i], out[i], flags[i]."""
    effort = 0.0
    for j in range(N_TAU):
        a = min(max(actions[i, j], -1.0), 1.0)
        effort += a * a
        tau[i, j] = a * tau_max[j] * strength[i, j]
    q_before = work[i, W_Q_BEFORE]
    u_before = work[i, W_U_BEFORE]
    force = work[i, W_FORCE]
    for j in range(N_Q):
        q_before[j] = q[i, j]
        u_before[j] = u[i, j]
        force[j] = 0.0
    if _push_now(i, grf, fenv, ienv, fpar):
        force[0] = fenv[i, F_PUSH_FORCE]
    fenv[i, F_FX_PREV_R] = grf[i, 0]
    fenv[i, F_FX_PREV_L] = grf[i, 2]
    finite = advance_forced_into(q[i], u[i], tau[i], force, passive, p[i], c, fpar[P_PHYSICS_DT], ipar[Q_SUBSTEPS],
                                 ipar[Q_METHOD], True, grf[i], work[i])
    if not finite:  # keep the last finite state; the episode ends
        q[i, :] = q_before
        u[i, :] = u_before
        contact_into(q[i], u[i], p[i], c, True, grf[i])
    work = 0.0
    for j in range(N_TAU):
        work += abs(tau[i, j] * (q[i, 3 + j] - q_before[3 + j]))
    fenv[i, F_WORK] += work
    ienv[i, I_STEPS] += 1
    speed = (q[i, 0] - q_before[0]) / fpar[P_CONTROL_DT]
    terminated = _fell(q[i, 1], q[i, 2], fpar[P_MIN_HEIGHT_FRACTION] * fenv[i, F_STANDING], fpar[P_MAX_TILT]) or not finite
    tracking = _tracking_term(speed, fenv[i, F_TARGET], fpar[P_TRACKING_WIDTH])
    total, alive = _step_reward(tracking, effort, terminated, fpar[P_TRACKING_WEIGHT], fpar[P_ALIVE_BONUS],
                                fpar[P_EFFORT_WEIGHT])
    if fpar[P_SLIP_WEIGHT] != 0.0 or fpar[P_IMPACT_WEIGHT] != 0.0:
        total -= _shaping_penalty(grf[i, 0], grf[i, 1], grf[i, 2], grf[i, 3], fpar[P_BODY_WEIGHT], fpar[P_FRICTION],
                                  fpar[P_SLIP_VELOCITY], fpar[P_SLIP_WEIGHT], fpar[P_IMPACT_WEIGHT],
                                  fpar[P_IMPACT_THRESHOLD])
    threshold = fpar[P_CONTACT_THRESHOLD] * fenv[i, F_BODY_WEIGHT]
    fenv[i, F_PHASE_R] = _next_phase(fenv[i, F_PHASE_R], grf[i, 1] > threshold, fpar[P_CONTROL_DT])
    fenv[i, F_PHASE_L] = _next_phase(fenv[i, F_PHASE_L], grf[i, 3] > threshold, fpar[P_CONTROL_DT])
    if fpar[P_PHASE_WEIGHT] != 0.0:
        total -= _phase_penalty(fenv[i, F_PHASE_R], fenv[i, F_PHASE_L], fpar[P_MAX_PHASE], fpar[P_PHASE_WEIGHT])
    truncated = ienv[i, I_STEPS] >= ipar[Q_MAX_STEPS] and not terminated
    ended = ienv[i, I_ENDED]
    if ended != 0:  # stepped after the end: the flags stay as they were, no reward
        terminated = (ended & 1) != 0
        truncated = (ended & 2) != 0
        total = tracking = alive = effort = 0.0
    ienv[i, I_ENDED] = (1 if terminated else 0) + (2 if truncated else 0)
    distance = q[i, 0] - fenv[i, F_X0]
    out[i, O_REWARD] = total
    out[i, O_SPEED] = speed
    out[i, O_DISTANCE] = distance
    out[i, O_COT] = fenv[i, F_WORK] / (fenv[i, F_BODY_WEIGHT] * distance) if distance > 0.01 else np.inf
    out[i, O_TRACKING] = tracking
    out[i, O_ALIVE] = alive
    out[i, O_EFFORT] = effort
    out[i, O_PUSH] = force[0]
    flags[i, 0] = terminated
    flags[i, 1] = truncated
    flags[i, 2] = not finite
    _record(i, q, u, grf, fenv, ienv, history, fpar)
    _emit(i, ienv, noise_std, history, obs)


@numba.njit(cache=True)
def step_serial(active, actions, q, u, grf, tau, p, fenv, ienv, strength, noise_std, history, c, passive, tau_max,
                fpar, ipar, obs, out, flags, work):  # pragma: no cover - compiled
    """:func:`_step_walker` for every walker where ``active`` (N,) is True, one after another."""
    for i in range(q.shape[0]):
        if active[i]:
            _step_walker(i, actions, q, u, grf, tau, p, fenv, ienv, strength, noise_std, history, c, passive,
                         tau_max, fpar, ipar, obs, out, flags, work)


@numba.njit(cache=True, parallel=True)
def step_parallel(active, actions, q, u, grf, tau, p, fenv, ienv, strength, noise_std, history, c, passive, tau_max,
                  fpar, ipar, obs, out, flags, work):  # pragma: no cover - compiled
    """:func:`_step_walker` for every walker where ``active`` (N,) is True, in parallel (``prange``)."""
    for i in numba.prange(q.shape[0]):
        if active[i]:
            _step_walker(i, actions, q, u, grf, tau, p, fenv, ienv, strength, noise_std, history, c, passive,
                         tau_max, fpar, ipar, obs, out, flags, work)


@numba.njit(cache=True, parallel=True)
def physics_parallel(q, u, tau, passive, p, c, dt, substeps, method, grf, work):  # pragma: no cover - compiled
    """Only the physics of one control interval for every row, in parallel: the roofline of
    :func:`step_parallel` (``benchmarks/speed/bench_env.py``; ``work`` as there). Returns the number of
    non-finite rows."""
    failures = 0
    force = np.zeros(N_Q)
    for i in numba.prange(q.shape[0]):
        if not advance_forced_into(q[i], u[i], tau[i], force, passive, p[i], c, dt, substeps, method, True, grf[i],
                                   work[i]):
            failures += 1
    return failures


__all__ = [
    "HISTORY", "N_FENV", "N_FPAR", "N_IENV", "N_IPAR", "N_OUT", "WALKER_WORK_ROWS", "normal", "physics_parallel", "start_rows",
    "step_parallel", "step_serial", "uniform",
]
