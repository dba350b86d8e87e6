"""N sagittal walkers as one native Gymnasium vector environment, stepped by one compiled call."""

from __future__ import annotations

from typing import Any

import numba
import numpy as np
from gymnasium import spaces
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from envs import task
from envs.config import WalkerConfig, WalkerParameters
from envs.walker_state import WalkerState, episode_setup
from sspinn.model.conventions import N_Q, N_TAU

#: Info keys of a reset (the others come from steps).
_RESET_INFO_KEYS = ("target_speed", "x_position")
#: No sub-environment (read-only).
_NO_ROWS = np.zeros(0, dtype=np.int64)
_NO_ROWS.flags.writeable = False
#: The mask key of every info key.
_MASK = {key: f"_{key}" for key in (*WalkerState.INFO_KEYS, "final_obs", "final_info")}


class SagittalWalkerVectorEnv(WalkerParameters, VectorEnv):
    """``num_envs`` copies of :class:`~envs.sagittal_walker.SagittalWalkerEnv` stepped together on the
    CPU by one compiled numba call per :meth:`step` (``numba.prange`` over the walkers, no Python
    loop over walkers or substeps).

    Same task, physics, disturbances, reward, termination, truncation and initial-state
    distribution as the single environment — not re-implemented: both run the kernels of
    :mod:`envs.kernels` on the arrays of :class:`envs.walker_state.WalkerState`. Sub-environment i
    draws its resets from its own ``numpy.random.Generator``, seeded like Gymnasium's
    ``SyncVectorEnv`` seeds its sub-environments (``reset(seed=s)`` → seeds s, s + 1, ...; a list
    → one seed each; None → fresh entropy the first time). So from the same seeds and actions the
    observations, rewards and flags equal those of ``num_envs`` single environments exactly,
    auto-resets included (``tests/test_vector_env.py``).

    ``gymnasium.make_vec("sspinn/SagittalWalker-v0", num_envs=N, vectorization_mode="vector_entry_point")``
    makes one (keyword arguments as for the single environment, plus ``autoreset_mode``).

    **Auto-reset** (``metadata["autoreset_mode"]``; Gymnasium's default ``NEXT_STEP`` unless
    ``autoreset_mode`` says otherwise):

    * ``NEXT_STEP``: the step that ends an episode returns its last observation; the next
      :meth:`step` resets that sub-environment instead of stepping it (its action is ignored) and
      returns the first observation of the new episode with reward 0 and both flags False.
    * ``SAME_STEP``: a sub-environment that ends is reset within the same step; the returned
      observation is the new episode's first, the last one is in ``info["final_obs"]`` (N, 22)
      and the step's info in ``info["final_info"]`` (rows where ``info["_final_obs"]`` is True).
      :class:`agents.vec_env.WalkerVecEnv` (Stable-Baselines3) uses this mode.
    * ``DISABLED``: nothing is reset; an ended sub-environment keeps stepping with its ending flags
      and reward 0 (as the single environment) until :meth:`reset`.

    Resets draw per sub-environment in a Python loop over the sub-environments being reset only
    (a handful per step; the draws only: one compiled call then writes their states); reset
    ``options`` are those of the single environment (:data:`envs.walker_state.RESET_OPTIONS`;
    ``target_speed`` may be one number or N), plus Gymnasium's ``reset_mask`` (bool (N,)) to reset
    only some sub-environments. Options apply to the episodes that this :meth:`reset` starts;
    auto-resets use the configuration.

    ``info`` of :meth:`step`: the single environment's keys as arrays (N, ...) — ``speed``,
    ``target_speed``, ``x_position``, ``distance``, ``cost_of_transport``, ``grf`` (N, 4), ``torques``
    (N, 6), ``reward_tracking``, ``reward_alive``, ``reward_effort``, ``physics_failure``,
    ``push_force`` — each with its Gymnasium mask ``_key`` (False where a row was reset instead).
    Every array and mask of an ``info`` is new and writable and shares no memory with another key
    or step (the float quantities and the masks are rows of one block each, which costs fewer
    allocations than one array per key).

    Args:
        num_envs: number of walkers N (≥ 1).
        autoreset_mode: an :class:`gymnasium.vector.AutoresetMode` or its value string.
        parallel: True: step the walkers with ``numba.prange`` (threads: ``numba.set_num_threads``
            or ``NUMBA_NUM_THREADS``); False: one after another in one compiled call (the same
            results); None (default): in parallel when numba has more than one thread and there
            are at least two walkers per thread (a parallel region costs more than it gains for
            fewer).
        config, **overrides: the :class:`~envs.config.WalkerConfig` and field overrides, as for
            the single environment.

    The public model parameters are those of the single environment (:class:`~envs.config.WalkerParameters`).
    """

    metadata = {"autoreset_mode": AutoresetMode.NEXT_STEP, "render_modes": []}

    def __init__(
        self,
        num_envs: int = 8,
        *,
        autoreset_mode: AutoresetMode | str = AutoresetMode.NEXT_STEP,
        parallel: bool | None = None,
        config: WalkerConfig | None = None,
        **overrides: Any,
    ) -> None:
        self.num_envs = task.check_int("num_envs", num_envs, 1)
        try:
            mode = AutoresetMode(autoreset_mode)
        except ValueError:
            raise ValueError(f"autoreset_mode must be one of {[m.value for m in AutoresetMode]}, got {autoreset_mode!r}") from None
        self._config = WalkerConfig.resolve(config, **overrides)
        self.autoreset_mode = mode
        self.metadata = {**self.metadata, "autoreset_mode": mode}
        self.parallel = None if parallel is None else bool(parallel)
        self.single_action_space = spaces.Box(-1.0, 1.0, (N_TAU,), dtype=np.float32)
        self.single_observation_space = spaces.Box(-np.inf, np.inf, (task.OBS_SIZE,), dtype=np.float32)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self._walkers = WalkerState(self._config, self.num_envs)
        self._rngs: list[np.random.Generator | None] = [None] * self.num_envs
        self._rng_seeds: list[int | None] = [None] * self.num_envs
        self._autoreset = np.zeros(self.num_envs, dtype=bool)
        self._all = np.ones(self.num_envs, dtype=bool)
        self._actions = np.zeros((self.num_envs, N_TAU))
        self._default_setup = episode_setup(self._config, None, 1)  # auto-resets: the configuration's episodes

    # ------------------------------------------------------------------------------------------
    @property
    def state(self) -> tuple[np.ndarray, np.ndarray]:
        """Copies of the coordinates q (N, 9) and speeds u (N, 9) (SI)."""
        return self._walkers.q.copy(), self._walkers.u.copy()

    def set_state(self, q: np.ndarray, u: np.ndarray) -> None:
        """Overwrite the states (N, 9) each, finite (else ``ValueError``); contact forces are
        recomputed, the episodes' counters stay."""
        q = np.array(q, dtype=np.float64)
        u = np.array(u, dtype=np.float64)
        shape = (self.num_envs, N_Q)
        if q.shape != shape or u.shape != shape:
            raise ValueError(f"q and u must have shape {shape}, got {q.shape} and {u.shape}")
        bad = ~(np.isfinite(q).all(1) & np.isfinite(u).all(1))
        if bad.any():
            raise ValueError(f"q and u must be finite; environment(s) {np.flatnonzero(bad)[:10].tolist()} are not")
        for i in range(self.num_envs):
            self._walkers.set_state(i, q[i], u[i])

    @property
    def target_speed(self) -> np.ndarray:
        """Target speeds of the current episodes, m/s (N,)."""
        return self._walkers.target().copy()

    @property
    def np_random(self) -> tuple[np.random.Generator, ...]:
        """The sub-environments' random generators (created from entropy when not yet seeded)."""
        return tuple(self._generator(i) for i in range(self.num_envs))

    @property
    def np_random_seed(self) -> tuple[int | None, ...]:
        """The seeds of the sub-environments' generators (None before the first reset; the drawn entropy
        where reset without a seed)."""
        return tuple(self._rng_seeds)

    def _generator(self, i: int) -> np.random.Generator:
        rng = self._rngs[i]
        if rng is None:
            rng, seed = seeding.np_random()
            self._rngs[i], self._rng_seeds[i] = rng, seed
        return rng

    # ------------------------------------------------------------------------------------------
    def reset(
        self, *, seed: int | list[int | None] | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Reset all sub-environments, or those of ``options["reset_mask"]``; see the class docstring."""
        options = dict(options or {})
        mask = options.pop("reset_mask", None)
        if mask is None:
            rows = np.arange(self.num_envs)
        else:
            mask = np.asarray(mask)
            if mask.shape != (self.num_envs,) or mask.dtype != np.bool_ or not mask.any():
                raise ValueError(f"options['reset_mask'] must be a bool array of shape ({self.num_envs},) with a True value")
            rows = np.flatnonzero(mask)
        if seed is None:
            seeds: list[int | None] = [None] * self.num_envs
        elif isinstance(seed, (int, np.integer)) and not isinstance(seed, bool):
            seeds = [int(seed) + i for i in range(self.num_envs)]
        else:
            seeds = list(seed)
            if len(seeds) != self.num_envs:
                raise ValueError(f"seed must be None, an int or {self.num_envs} seeds, got {len(seeds)}")
        setup = episode_setup(self._config, options, len(rows))
        for i in rows:
            if seeds[i] is not None:
                self._rngs[i], self._rng_seeds[i] = seeding.np_random(seeds[i])
        self._walkers.reset_rows(rows, [self._generator(i) for i in rows], setup)
        self._autoreset[rows] = False
        info = self._reset_info(rows)
        return self._walkers.obs.copy(), info

    def _reset_info(self, rows: np.ndarray) -> dict[str, Any]:
        mask = np.zeros(self.num_envs, dtype=bool)
        mask[rows] = True
        info: dict[str, Any] = {}
        for key, value in self._reset_values(rows).items():
            full = np.zeros(self.num_envs)
            full[rows] = value
            info[key], info[_MASK[key]] = full, mask.copy()
        return info

    def step(self, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """One control interval (0.01 s) of every sub-environment under ``actions`` (N, 6) in
        [−1, 1] (clipped; a non-finite action is a ``ValueError`` naming the rows). Returns (obs
        (N, 22) float32, reward (N,), terminated (N,), truncated (N,), info)."""
        a = np.asarray(actions, dtype=np.float64)
        if a.shape != (self.num_envs, N_TAU):
            raise ValueError(f"actions must have shape ({self.num_envs}, {N_TAU}), got {a.shape}")
        if not np.isfinite(a).all():
            rows = np.flatnonzero(~np.isfinite(a).all(1))
            raise ValueError(f"actions must be finite; environment(s) {rows[:10].tolist()} got {a[rows[0]].tolist()} "
                             "(first shown): check the policy's output")
        self._actions[:] = a
        w = self._walkers
        mode = self.autoreset_mode
        resetting = self._autoreset.nonzero()[0] if mode == AutoresetMode.NEXT_STEP else _NO_ROWS
        active = self._all if len(resetting) == 0 else ~self._autoreset
        w.step(self._actions, active, self._parallel())
        rewards = w.out[:, 0].copy()
        terminated = w.flags[:, 0].copy()
        truncated = w.flags[:, 1].copy()
        values = w.info_all()
        info = _with_masks(values, active)
        if len(resetting):
            w.reset_rows(resetting, [self._generator(i) for i in resetting], self._default_setup)
            rewards[resetting] = 0.0
            terminated[resetting] = False
            truncated[resetting] = False
            for key, value in self._reset_values(resetting).items():  # the arrays are this step's own
                info[key][resetting] = value
                info[_MASK[key]][resetting] = True
        done = terminated | truncated
        if mode == AutoresetMode.SAME_STEP and done.any():
            rows = done.nonzero()[0]
            final_info = dict(info)
            info["final_obs"], info["_final_obs"] = w.obs.copy(), done.copy()
            info["final_info"], info["_final_info"] = final_info, done.copy()
            w.reset_rows(rows, [self._generator(i) for i in rows], self._default_setup)
            masks = np.empty((len(values), self.num_envs), dtype=bool)  # new masks: final_info keeps its own
            masks[:] = active & ~done
            for key, mask in zip(values, masks):
                info[_MASK[key]] = mask
            for key, value in self._reset_values(rows).items():
                info[key] = info[key].copy()
                info[key][rows] = value
                info[_MASK[key]] |= done
        self._autoreset = done if mode == AutoresetMode.NEXT_STEP else self._autoreset
        return w.obs.copy(), rewards, terminated, truncated, info

    def _reset_values(self, rows: np.ndarray) -> dict[str, np.ndarray]:
        """The reset info values (:data:`_RESET_INFO_KEYS`) of the walkers ``rows`` just reset."""
        w = self._walkers
        return {"target_speed": w.target(rows), "x_position": w.q[rows, 0]}

    def _parallel(self) -> bool:
        if self.parallel is not None:
            return self.parallel
        threads = numba.get_num_threads()
        return threads > 1 and self.num_envs >= 2 * threads

    def close_extras(self, **kwargs: Any) -> None:
        """Nothing to release (no processes, no windows)."""


def _with_masks(values: dict[str, np.ndarray], mask: np.ndarray) -> dict[str, Any]:
    """Gymnasium's vector info: every key with its ``_key`` mask, a copy of ``mask`` (N,) each (rows
    of one block: every mask has its own memory, as if allocated one by one)."""
    masks = np.empty((len(values), len(mask)), dtype=bool)
    masks[:] = mask
    info: dict[str, Any] = {}
    for (key, value), row in zip(values.items(), masks):
        info[key], info[_MASK[key]] = value, row
    return info


__all__ = ["SagittalWalkerVectorEnv"]
