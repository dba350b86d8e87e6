"""The state of N sagittal walkers as NumPy arrays, and their reset and compiled step: the engine
shared by :class:`~envs.sagittal_walker.SagittalWalkerEnv` (N = 1) and
:class:`~envs.vector.SagittalWalkerVectorEnv` (N walkers).

A reset draws, for each walker being reset and from *that walker's* ``numpy.random.Generator``
(the single environment's ``np_random``; one per sub-environment of the vector environment), in
this order: the target speed (only when the configuration gives a range), one uniform number and
one integer (only with ``reset_state_share`` > 0 and no ``initial_state`` option: whether and from
which row of ``reset_states`` the episode starts), 8 uniform numbers of
coordinate noise, 9 of speed noise, and — only when observation noise is on — one 63-bit key of
the observation-noise generator (:mod:`envs.kernels`). The same seed therefore gives the same
episode in both environments. The Python loop of a reset runs over the walkers being reset only
and makes the draws; one compiled call (:func:`envs.kernels.start_rows`) writes their states;
:meth:`WalkerState.step` is one compiled call for all walkers.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Final

import numpy as np

from envs import kernels as k
from envs import task
from envs.config import CONTROL_DT, WalkerConfig
from envs.disturbances import PUSH_PHASES, Disturbances
from sspinn.data.gait_events import CONTACT_THRESHOLD_BW
from sspinn.model.conventions import N_GRF, N_Q, N_TAU
from sspinn.model.simulation import METHODS, contact_into

#: Placeholders of :func:`envs.kernels.start_rows` for "no given initial state" and "no start states".
_NO_STATE: Final[np.ndarray] = np.zeros(0)
_NO_STARTS: Final[np.ndarray] = np.zeros((0, 2 * N_Q))
_NO_STARTS.flags.writeable = False  # read-only like WalkerConfig.reset_states: one compiled signature

#: Keys accepted in ``reset(options=...)`` by the NumPy environments.
RESET_OPTIONS: Final[tuple[str, ...]] = ("target_speed", "initial_state", "reset_noise_scale", "disturbances")


@dataclass(frozen=True)
class EpisodeSetup:
    """What a reset applies to the walkers it resets (from the configuration and the reset options).

    Attributes:
        target_speed: m/s per reset walker (N_reset,), or None to use the configuration's.
        initial_state: (q, u) SI arrays (9,) each, or None to start standing. The state is one of
            the announced body: when a body disturbance makes the simulated body's standing hip
            height differ, pelvis_ty is shifted by that difference (the feet start as they would
            on the announced body instead of in the ground or in the air).
        noise_scale: half-width of the uniform initial-state noise (m, rad, m/s, rad/s).
        disturbances: the episode's :class:`~envs.disturbances.Disturbances`.
    """

    target_speed: np.ndarray | None
    initial_state: tuple[np.ndarray, np.ndarray] | None
    noise_scale: float
    disturbances: Disturbances


def episode_setup(config: WalkerConfig, options: Mapping[str, Any] | None, n_rows: int) -> EpisodeSetup:
    """Check ``reset`` options (:data:`RESET_OPTIONS`) and combine them with ``config``.

    ``target_speed`` is one number (m/s) or, for ``n_rows`` > 1, a sequence of ``n_rows`` numbers;
    ``initial_state`` a pair (q, u) of 9 finite numbers each; ``reset_noise_scale`` a number in
    [0, 0.1]; ``disturbances`` a mapping of :class:`~envs.disturbances.Disturbances` fields that
    replace the configuration's. Anything else is a ``ValueError`` naming the option.
    """
    options = dict(options or {})
    unknown = sorted(set(options) - set(RESET_OPTIONS))
    if unknown:
        raise ValueError(f"unknown reset option(s) {unknown}; known: {', '.join(RESET_OPTIONS)}")
    target = None
    if "target_speed" in options:
        value = options["target_speed"]
        if isinstance(value, (Sequence, np.ndarray)) and not isinstance(value, str) and np.ndim(value) == 1 and n_rows > 1:
            if len(value) != n_rows:
                raise ValueError(f"options['target_speed'] must be one number or {n_rows} numbers (m/s), got {len(value)}")
            target = np.array([task.check_target_speed(float(v) if task.is_real(v) else v) for v in value])
        else:
            if isinstance(value, np.ndarray) and value.ndim == 0:
                value = float(value)
            target = np.full(n_rows, task.check_target_speed(value))
    initial = _initial_state(options["initial_state"]) if "initial_state" in options else None
    noise = config.reset_noise_scale
    if "reset_noise_scale" in options:
        noise = options["reset_noise_scale"]
        if not task.is_real(noise) or not 0 <= noise <= 0.1:
            raise ValueError(f"options['reset_noise_scale'] must be a number in [0, 0.1] (m, rad, m/s, rad/s), got {noise!r}")
    disturbances = Disturbances.resolve(options.get("disturbances"), base=config.disturbances)
    return EpisodeSetup(target, initial, float(noise), disturbances)


def _initial_state(value: Any) -> tuple[np.ndarray, np.ndarray]:
    """(q, u) copies from ``options["initial_state"]``, with a clear error for bad values."""
    try:
        q, u = (np.array(v, dtype=np.float64) for v in value)
    except (TypeError, ValueError):
        raise ValueError("options['initial_state'] must be a pair (q, u) of 9 numbers each (m, rad, m/s, rad/s)") from None
    if q.shape != (N_Q,) or u.shape != (N_Q,) or not (np.isfinite(q).all() and np.isfinite(u).all()):
        raise ValueError(f"options['initial_state'] must be finite (q, u) of shape ({N_Q},) each, got {q.shape} and {u.shape}")
    return q, u


class WalkerState:
    """N walkers of one :class:`~envs.config.WalkerConfig`: arrays, resets and the compiled step.

    Public arrays (row i = walker i; updated in place, copy what you keep): ``q``, ``u`` (N, 9) SI
    state; ``grf`` (N, 4) contact forces in N; ``tau`` (N, 6) applied actuator torques in N·m;
    ``obs`` (N, 22) float32 observations; ``out`` (N, 8) step quantities (columns ``O_*`` of
    :mod:`envs.kernels`: reward, speed m/s, distance m, cost of transport, tracking, alive and
    effort terms, push force N); ``flags`` (N, 3) terminated, truncated, physics failure.
    """

    #: Keys of :meth:`info` and :meth:`info_all`, in their order.
    INFO_KEYS: Final[tuple[str, ...]] = (
        "speed", "target_speed", "x_position", "distance", "cost_of_transport", "grf", "torques", "reward_tracking",
        "reward_alive", "reward_effort", "physics_failure", "push_force")

    def __init__(self, config: WalkerConfig, n: int) -> None:
        self.config = config
        self.n = n
        body = config.body_parameters
        self.body_weight = body.body_weight
        self.c = config.contact_parameters.vector()
        self.passive = config.passive_parameters.copy()
        self.tau_max = config.tau_max.copy()
        self.fpar = np.zeros(k.N_FPAR)
        self.fpar[[k.P_CONTROL_DT, k.P_PHYSICS_DT]] = CONTROL_DT, config.physics_dt
        self.fpar[[k.P_TRACKING_WEIGHT, k.P_TRACKING_WIDTH, k.P_ALIVE_BONUS, k.P_EFFORT_WEIGHT]] = (
            config.tracking_weight, config.tracking_width, config.alive_bonus, config.effort_weight)
        self.fpar[[k.P_MIN_HEIGHT_FRACTION, k.P_MAX_TILT]] = config.min_height_fraction, config.max_tilt
        self.fpar[[k.P_CONTACT_THRESHOLD, k.P_BODY_WEIGHT]] = CONTACT_THRESHOLD_BW, self.body_weight
        contact = config.contact_parameters
        self.fpar[[k.P_FRICTION, k.P_SLIP_VELOCITY]] = contact.friction, contact.slip_velocity
        self.fpar[[k.P_SLIP_WEIGHT, k.P_IMPACT_WEIGHT, k.P_IMPACT_THRESHOLD]] = (
            config.slip_weight, config.impact_weight, config.impact_threshold)
        self.fpar[[k.P_PHASE_WEIGHT, k.P_MAX_PHASE]] = config.phase_weight, config.max_phase_duration
        self.ipar = np.array([config.substeps, METHODS.index(config.method), config.max_episode_steps], dtype=np.int64)

        self.q = np.zeros((n, N_Q))
        self.u = np.zeros((n, N_Q))
        self.grf = np.zeros((n, N_GRF))
        self.tau = np.zeros((n, N_TAU))
        self.p = np.tile(body.vector(), (n, 1))
        self.fenv = np.zeros((n, k.N_FENV))
        self.ienv = np.zeros((n, k.N_IENV), dtype=np.int64)
        self.strength = np.ones((n, N_TAU))
        self.noise_std = np.zeros((n, task.OBS_SIZE))
        self.history = np.zeros((n, k.HISTORY, task.OBS_SIZE))
        self.obs = np.zeros((n, task.OBS_SIZE), dtype=np.float32)
        self.out = np.zeros((n, k.N_OUT))
        self.flags = np.zeros((n, 3), dtype=bool)
        self.work = np.zeros((n, k.WALKER_WORK_ROWS, N_Q))  # each walker's workspace: a step allocates nothing
        self._episode_cache: dict[str, dict[str, Any]] = {}
        self._last_disturbances: Disturbances | None = None
        self._last_episode: dict[str, Any] = {}

    # ------------------------------------------------------------------------------ episode data
    def _episode_arrays(self, disturbances: Disturbances) -> dict[str, Any]:
        """Per-walker arrays of an episode with ``disturbances`` (cached: the body is rebuilt once; the
        last one is also kept by identity, as auto-resets pass the same frozen object every time)."""
        if disturbances is self._last_disturbances:
            return self._last_episode
        key = repr(disturbances)
        cached = self._episode_cache.get(key)
        if cached is not None:
            self._last_disturbances, self._last_episode = disturbances, cached
            return cached
        config = self.config
        body = disturbances.body(config.body_parameters)
        d = disturbances
        if not d.pushes:
            mode, at = k.PUSH_NONE, 0
        elif d.push_time is not None:
            mode, at = k.PUSH_AT_TIME, int(np.floor(d.push_time / CONTROL_DT + 1e-9))
        else:
            mode, at = k.PUSH_MIDSTANCE_R + PUSH_PHASES[d.push_phase], int(np.ceil(d.push_after / CONTROL_DT - 1e-9))
        arrays = {
            "p": body.vector(),
            "standing": task.standing_height(body, config.contact_parameters),
            "body_weight": body.body_weight,
            "strength": d.strength_scale(),
            "noise_std": d.noise_std(),
            "push_force": d.push_force / 100.0 * self.body_weight,
            "push_mode": mode,
            "push_at": at,
            "push_steps": max(1, int(round(d.push_duration / CONTROL_DT))),
            "delay": d.obs_delay,
        }
        arrays["noisy_obs"] = bool(arrays["noise_std"].any())
        efloat = np.zeros(4)
        efloat[[k.E_STANDING, k.E_BODY_WEIGHT, k.E_PUSH_FORCE, k.E_SHIFT]] = (
            arrays["standing"], arrays["body_weight"], arrays["push_force"], arrays["standing"] - config.standing_height)
        eint = np.zeros(4, dtype=np.int64)
        eint[[k.E_PUSH_MODE, k.E_PUSH_AT, k.E_PUSH_STEPS, k.E_DELAY]] = (
            arrays["push_mode"], arrays["push_at"], arrays["push_steps"], arrays["delay"])
        arrays["efloat"], arrays["eint"] = efloat, eint
        for name in ("p", "strength", "noise_std"):
            arrays[name] = np.ascontiguousarray(arrays[name], dtype=np.float64)
        if len(self._episode_cache) < 64:
            self._episode_cache[key] = arrays
        self._last_disturbances, self._last_episode = disturbances, arrays
        return arrays

    # ------------------------------------------------------------------------------------- reset
    def reset_rows(self, rows: np.ndarray, rngs: Sequence[np.random.Generator], setup: EpisodeSetup) -> None:
        """Start new episodes for the walkers ``rows`` (indices), drawing from ``rngs`` (one generator
        per row, in the order of the module docstring); their observations are then in ``obs``.

        Only the draws run in a Python loop over the rows (each row has its own generator); one
        compiled call (:func:`envs.kernels.start_rows`) then writes the states and episodes."""
        rows = np.asarray(rows, dtype=np.int64)
        m = len(rows)
        episode = self._episode_arrays(setup.disturbances)
        config = self.config
        low, high = config.target_range
        scale = setup.noise_scale
        noisy_obs = episode["noisy_obs"]
        starts = config.reset_states if config.reset_state_share > 0 and setup.initial_state is None else None
        share = config.reset_state_share
        targets = np.empty(m) if setup.target_speed is None else np.asarray(setup.target_speed, dtype=np.float64)
        picks = np.full(m, -1, dtype=np.int64)
        draws = np.empty((m, 2 * N_Q - 1))  # coordinate noise (8) then speed noise (9): one call, the same stream
        keys = np.zeros(m, dtype=np.int64)
        for n, rng in enumerate(rngs):
            if setup.target_speed is None:
                targets[n] = low if low == high else rng.uniform(low, high)
            if starts is not None and rng.uniform() < share:
                picks[n] = rng.integers(len(starts))
            draws[n] = rng.uniform(-scale, scale, 2 * N_Q - 1)
            if noisy_obs:
                keys[n] = rng.integers(0, 2**63 - 1)
        initial = _NO_STATE if setup.initial_state is None else np.concatenate(setup.initial_state)
        k.start_rows(rows, targets, picks, draws, keys, initial, _NO_STARTS if starts is None else starts,
                     episode["efloat"], episode["eint"], episode["p"], episode["strength"], episode["noise_std"],
                     self.q, self.u, self.grf, self.tau, self.p, self.strength, self.noise_std, self.fenv, self.ienv,
                     self.c, self.history, self.fpar, self.obs)

    # -------------------------------------------------------------------------------------- step
    def step(self, actions: np.ndarray, active: np.ndarray, parallel: bool) -> None:
        """One control interval of the walkers where ``active`` (N,) is True under ``actions``
        (N, 6) float64 (finite; clipped to [−1, 1] in the kernel); results in ``obs``, ``out``, ``flags``."""
        kernel = k.step_parallel if parallel else k.step_serial
        kernel(active, actions, self.q, self.u, self.grf, self.tau, self.p, self.fenv, self.ienv, self.strength,
               self.noise_std, self.history, self.c, self.passive, self.tau_max, self.fpar, self.ipar, self.obs,
               self.out, self.flags, self.work)

    def set_state(self, i: int, q: np.ndarray, u: np.ndarray) -> None:
        """Overwrite walker i's state (finite float64 (9,) arrays) and recompute its contact forces
        (the episode's counters stay)."""
        self.q[i] = q
        self.u[i] = u
        contact_into(self.q[i], self.u[i], self.p[i], self.c, True, self.grf[i])

    # ------------------------------------------------------------------------------------ reading
    def target(self, i: int | slice = slice(None)) -> Any:
        """Target speed(s) of the current episodes, m/s."""
        return self.fenv[i, k.F_TARGET]

    def ended(self, i: int) -> bool:
        """Whether walker i's episode has ended (terminated or truncated)."""
        return bool(self.ienv[i, k.I_ENDED])

    def steps(self, i: int | slice = slice(None)) -> Any:
        """Control steps since each walker's reset."""
        return self.ienv[i, k.I_STEPS]

    def info_all(self) -> dict[str, np.ndarray]:
        """:meth:`info` of every walker as new arrays (N, ...) — the same keys, order and values in
        five allocations: the float quantities are rows of one block (each row its own memory)."""
        block = np.empty((k.N_OUT + 2, self.n))
        block[: k.N_OUT] = self.out.T
        block[k.N_OUT] = self.fenv[:, k.F_TARGET]
        block[k.N_OUT + 1] = self.q[:, 0]
        return {
            "speed": block[k.O_SPEED],
            "target_speed": block[k.N_OUT],
            "x_position": block[k.N_OUT + 1],
            "distance": block[k.O_DISTANCE],
            "cost_of_transport": block[k.O_COT],
            "grf": self.grf.copy(),
            "torques": self.tau.copy(),
            "reward_tracking": block[k.O_TRACKING],
            "reward_alive": block[k.O_ALIVE],
            "reward_effort": block[k.O_EFFORT],
            "physics_failure": self.flags[:, 2].copy(),
            "push_force": block[k.O_PUSH],
        }

    def info(self, rows: int | slice | np.ndarray) -> dict[str, Any]:
        """The step quantities of ``rows`` (NumPy arrays, or scalars for one int row): ``speed``
        (m/s), ``target_speed`` (m/s), ``x_position`` (m, hip), ``distance`` (m), ``cost_of_transport``,
        ``grf`` (N), ``torques`` (N·m), ``reward_tracking``, ``reward_alive``, ``reward_effort``,
        ``physics_failure``, ``push_force`` (N, applied during the step)."""
        one = isinstance(rows, (int, np.integer))
        out = self.out[rows]
        values = {
            "speed": out[..., k.O_SPEED],
            "target_speed": self.fenv[rows, k.F_TARGET],
            "x_position": self.q[rows, 0],
            "distance": out[..., k.O_DISTANCE],
            "cost_of_transport": out[..., k.O_COT],
            "grf": self.grf[rows].copy(),
            "torques": self.tau[rows].copy(),
            "reward_tracking": out[..., k.O_TRACKING],
            "reward_alive": out[..., k.O_ALIVE],
            "reward_effort": out[..., k.O_EFFORT],
            "physics_failure": self.flags[rows, 2],
            "push_force": out[..., k.O_PUSH],
        }
        if one:
            return {key: (v if key in ("grf", "torques") else v.item()) for key, v in values.items()}
        return {key: np.array(v) for key, v in values.items()}


__all__ = ["RESET_OPTIONS", "EpisodeSetup", "WalkerState", "episode_setup"]
