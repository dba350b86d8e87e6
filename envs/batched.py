"""N sagittal walkers stepped together as torch tensors (differentiable, CPU or CUDA)."""

from __future__ import annotations

from typing import Any

import gymnasium
import numpy as np
import torch
from gymnasium import spaces
from gymnasium.vector import AutoresetMode
from gymnasium.vector.utils import batch_space

from envs import task
from envs.config import CONTROL_DT, WalkerConfig, WalkerParameters
from sspinn.data.gait_events import CONTACT_THRESHOLD_BW
from sspinn.model import dynamics
from sspinn.model.conventions import N_Q, N_TAU
from sspinn.model.integrators import INTEGRATORS


class BatchedSagittalWalker(WalkerParameters, gymnasium.vector.VectorEnv):
    """``num_envs`` copies of :class:`~envs.sagittal_walker.SagittalWalkerEnv` in one batch of torch
    tensors.

    Same task as the single environment — observation (22 entries, layout
    :data:`envs.task.OBSERVATION_NAMES`), reward, termination, truncation, strength, passive joint
    moments, initial-state distribution and physics step (``substeps`` × semi-implicit Euler at
    ``0.01 s / substeps`` with the forward-simulation contact) — computed by the *same* functions of
    :mod:`envs.task`; the physics is that of :func:`sspinn.model.simulation.step_torch` (generated array code),
    called once per substep because the passive joint moments are re-evaluated at the start of every
    substep, exactly as the single environment's compiled stepper does. From the same state and
    action both environments agree to round-off in float64 (``tests/test_env.py``).

    Everything returned is a torch tensor on ``device`` (observations in ``dtype``, rewards in
    ``dtype``, terminated/truncated as bool), shapes ``(num_envs, ...)``.

    **Gradients**: nothing is detached. If the actions (or a state passed to :meth:`set_state`)
    require grad, observations and rewards are differentiable with respect to them through the
    physics; over many steps the autograd graph grows, so detach the state (``env.q``, ``env.u``) when
    a horizon ends. Auto-reset rows are replaced with :func:`torch.where`, which cuts their gradient.

    **Auto-reset** (``auto_reset=True``, Gymnasium's ``SAME_STEP`` mode): an environment that
    terminates or is truncated is reset inside the same :meth:`step`; the returned observation of that
    row is already the first one of the new episode, the last observation of the finished episode is
    in ``info["final_obs"]`` (all rows; meaningful where ``info["_final_obs"]`` is True), and
    ``info`` quantities (speed, distance, cost of transport, ...) refer to the finished step. With
    ``auto_reset=False`` (``DISABLED``) finished rows keep stepping until :meth:`reset` is called.

    **Speed** (``benchmarks/speed/bench_env.py --batched-only``, float32, random actions; docs/environment.md):
    on an NVIDIA H200 with ``compile="step-graph"``, 11.8 M environment steps/s at N = 65,536 (542×
    the single environment on that machine's CPU) and 1.4 M at N = 4,096, where the replay of 50
    substeps' kernels, not arithmetic, bounds a step; ``compile=True`` 1.4 M, eager 0.14 M at
    65,536. On a 2-core CPU, eager is fastest (≈ 23 k steps/s at N = 4,096 on one thread, about the
    single environment's rate): use the native vector environment there.

    Args:
        num_envs: batch size N.
        device: torch device ("cpu", "cuda", ...).
        dtype: torch.float32 (default, fast) or torch.float64.
        auto_reset: see above.
        seed: seed of the torch generator used for initial states and target speeds.
        compile: run each physics substep through ``torch.compile`` (inductor fuses the generated
            code's elementwise operations into a handful of kernels): False (eager), True
            (inductor's default mode), a ``torch.compile`` mode name, e.g. "reduce-overhead"
            (CUDA graphs: each substep replays one recorded graph), or "step-graph" (CUDA only:
            the compiled substeps of a whole control interval recorded once as one CUDA graph and
            replayed every step). The graph modes are for rollouts without gradients. Worth it on a
            GPU, where the eager substep is bound by kernel launches; the first step compiles
            (about 20 s). Same formulas: results agree with the eager path to round-off.
        config: the task and physics configuration, a :class:`~envs.config.WalkerConfig` (the one
            of the single environment); None → ``WalkerConfig()``.
        **overrides: fields of :class:`~envs.config.WalkerConfig` (height, mass, body, target_speed,
            max_torque, reward weights, ..., substeps, method, slip_velocity, contact), overriding
            those of ``config``; same defaults and units as the single environment.

    The public model parameters (``config``, ``body``, ``contact``, ``tau_max`` in N·m,
    ``passive_parameters``, ``dt``, ``substeps``, ``physics_dt``, ``method``, ...) are those of the
    single environment (:class:`~envs.config.WalkerParameters`, NumPy float64); the state is
    ``q``, ``u`` (N, 9), ``grf`` (N, 4; newtons) and ``target_speed`` (N; m/s), tensors in ``dtype``.

    ``info`` of :meth:`step` (tensors (N,) unless stated): ``speed``, ``target_speed`` (m/s),
    ``x_position``, ``distance`` (m), ``cost_of_transport`` (+inf below 1 cm of forward progress),
    ``grf`` (N, 4) in N, ``torques`` (N, 6) in N·m, ``reward_tracking``, ``reward_alive``,
    ``reward_effort``, ``physics_failure`` (bool).
    """

    metadata = {"autoreset_mode": AutoresetMode.SAME_STEP, "render_modes": []}

    def __init__(
        self,
        num_envs: int = 4096,
        *,
        device: str | torch.device = "cpu",
        dtype: torch.dtype = torch.float32,
        auto_reset: bool = True,
        seed: int | None = None,
        config: WalkerConfig | None = None,
        compile: bool | str = False,
        **overrides: Any,
    ) -> None:
        self.num_envs = task.check_int("num_envs", num_envs, 1)
        if not isinstance(compile, (bool, str)):
            raise ValueError(f"compile must be a bool or a torch.compile mode name, got {compile!r}")
        if dtype not in (torch.float32, torch.float64):
            raise ValueError(f"dtype must be torch.float32 or torch.float64, got {dtype!r}")
        if not isinstance(auto_reset, bool):
            raise ValueError(f"auto_reset must be a bool, got {auto_reset!r}")
        self._config = WalkerConfig.resolve(config, **overrides)
        self.device = torch.device(device)
        self.dtype = dtype
        self.auto_reset = auto_reset
        self.metadata = {
            **self.metadata,
            "autoreset_mode": AutoresetMode.SAME_STEP if auto_reset else AutoresetMode.DISABLED,
        }
        self._body_weight = self.body.body_weight

        def tensor(x: Any) -> torch.Tensor:
            return torch.as_tensor(np.asarray(x, dtype=np.float64), dtype=dtype, device=self.device)

        self._p = tensor(self.body_vector)
        self._c = tensor(self.contact_vector)
        self._tau_max = tensor(self.tau_max)
        passive = self.passive_parameters
        self._lower, self._upper = tensor(passive[:N_TAU]), tensor(passive[N_TAU : 2 * N_TAU])
        self._k, self._b = float(passive[12]), float(passive[13])
        self._graphs = compile == "reduce-overhead"
        self._whole_step_graph = compile == "step-graph"
        if self._whole_step_graph and self.device.type != "cuda":
            raise ValueError(f'compile="step-graph" records a CUDA graph: it needs a CUDA device, got {self.device}')
        self._recorded: tuple[Any, list[torch.Tensor], tuple[torch.Tensor, torch.Tensor]] | None = None
        self._integrate = INTEGRATORS[self.method](self._qdd)
        if compile:
            mode = None if compile in (True, "step-graph") else compile
            self._substep = torch.compile(self._eager_substep, dynamic=False, mode=mode)
        else:
            self._substep = self._eager_substep

        self.single_action_space = spaces.Box(-1.0, 1.0, (N_TAU,), dtype=np.float32)
        self.single_observation_space = spaces.Box(-np.inf, np.inf, (task.OBS_SIZE,), dtype=np.float32)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)

        self._generator = torch.Generator(device=self.device)
        self._generator.manual_seed(int(seed) if seed is not None else int(torch.seed() % 2**63))
        n = self.num_envs
        self.q = torch.zeros(n, N_Q, dtype=dtype, device=self.device)
        self.u = torch.zeros(n, N_Q, dtype=dtype, device=self.device)
        self.grf = torch.zeros(n, 4, dtype=dtype, device=self.device)
        self.target_speed = torch.zeros(n, dtype=dtype, device=self.device)
        self._x0 = torch.zeros(n, dtype=dtype, device=self.device)
        self._work = torch.zeros(n, dtype=dtype, device=self.device)
        self._steps = torch.zeros(n, dtype=torch.int64, device=self.device)
        self._phase = torch.zeros(n, 2, dtype=dtype, device=self.device)  # feet's phase durations, s

    # ------------------------------------------------------------------------------------------
    def _uniform(self, shape: tuple[int, ...], low: float, high: float) -> torch.Tensor:
        r = torch.rand(shape, generator=self._generator, dtype=self.dtype, device=self.device)
        return low + (high - low) * r

    def _initial_states(self, n: int, target: float | torch.Tensor | None) -> tuple[torch.Tensor, ...]:
        """(q, u, target) of n fresh episodes (standing + noise, as the single environment)."""
        noise = self._config.reset_noise_scale
        q = torch.zeros(n, N_Q, dtype=self.dtype, device=self.device)
        q[:, 1] = self.standing_height
        q[:, 1:] += self._uniform((n, N_Q - 1), -noise, noise)
        u = self._uniform((n, N_Q), -noise, noise)
        if target is None:
            low, high = self._config.target_range
            speeds = self._uniform((n,), low, high) if low != high else torch.full((n,), low, dtype=self.dtype, device=self.device)
        else:
            speeds = torch.as_tensor(target, dtype=self.dtype, device=self.device).expand(n).clone()
        return q, u, speeds

    def _contact(self, q: torch.Tensor, u: torch.Tensor) -> torch.Tensor:
        return dynamics.contact_forces(q, u, self._p, self._c)[0]

    def observe(self) -> torch.Tensor:
        """Observation of the current state, (N, 22) in ``dtype``."""
        return task.observation(self.q, self.u, self.grf, self.target_speed, self._body_weight)

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[torch.Tensor, dict[str, Any]]:
        """Reset all environments. ``seed`` reseeds the generator; ``options={"target_speed": v}``
        (a number in m/s, or a tensor (N,)) fixes the target speeds of the new episodes."""
        if seed is not None:
            self._generator.manual_seed(int(seed))
        target = None
        if options is not None and "target_speed" in options:
            target = self._check_target(options["target_speed"], "options['target_speed']")
        self.q, self.u, self.target_speed = self._initial_states(self.num_envs, target)
        self.grf = self._contact(self.q, self.u)
        self._x0 = self.q[:, 0].clone()
        self._work = torch.zeros_like(self._x0)
        self._steps = torch.zeros(self.num_envs, dtype=torch.int64, device=self.device)
        self._phase = torch.zeros(self.num_envs, 2, dtype=self.dtype, device=self.device)
        return self.observe(), {"target_speed": self.target_speed.clone(), "x_position": self._x0.clone()}

    def set_state(self, q: torch.Tensor, u: torch.Tensor, target_speed: torch.Tensor | float | None = None) -> None:
        """Overwrite the states (N, 9) (and optionally the target speeds, m/s); contact forces are
        recomputed, the episode counters are not reset. Non-finite states or target speeds, wrong
        shapes and speeds outside [0, 12] m/s are a ``ValueError`` naming the rows."""
        q = torch.as_tensor(q, dtype=self.dtype, device=self.device)
        u = torch.as_tensor(u, dtype=self.dtype, device=self.device)
        if q.shape != (self.num_envs, N_Q) or u.shape != (self.num_envs, N_Q):
            raise ValueError(f"q and u must have shape ({self.num_envs}, {N_Q}), got {tuple(q.shape)} and {tuple(u.shape)}")
        finite = (torch.isfinite(q).all(-1) & torch.isfinite(u).all(-1)).detach()
        if not bool(finite.all()):
            rows = torch.nonzero(~finite).flatten().tolist()
            raise ValueError(f"q and u must be finite; environment(s) {rows[:10]} are not")
        target = None if target_speed is None else self._check_target(target_speed, "target_speed")
        self.q, self.u = q, u
        if target is not None:
            self.target_speed = torch.as_tensor(target, dtype=self.dtype, device=self.device).expand(self.num_envs).clone()
        self.grf = self._contact(self.q, self.u)

    def _check_target(self, value: Any, name: str) -> torch.Tensor | float:
        """A target speed (m/s) for all rows: a number (checked as the single environment checks
        it) or a tensor of shape () or (N,), finite and in [0, 12] m/s; else ``ValueError``."""
        if not isinstance(value, torch.Tensor):
            try:
                return task.check_target_speed(value)
            except ValueError as exc:
                raise ValueError(f"{name}: {exc}") from None
        if value.shape not in ((), (self.num_envs,)):
            raise ValueError(f"{name} tensor must have shape () or ({self.num_envs},), got {tuple(value.shape)}")
        bad = ~(torch.isfinite(value) & (value >= 0) & (value <= 12.0)).reshape(-1)
        if bool(bad.any()):
            rows = torch.nonzero(bad).flatten().tolist()
            raise ValueError(f"{name} must be finite and in [0, 12] m/s; row(s) {rows[:10]} are not "
                             f"(first: {value.reshape(-1)[rows[0]].item()!r})")
        return value

    # ------------------------------------------------------------------------------------------
    def _eager_substep(self, q: torch.Tensor, u: torch.Tensor, tau: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """One physics substep of ``physics_dt`` seconds: the passive joint moments at the substep's
        start added to the actuator torques ``tau`` (N, 6; N·m), then the integrator's update of
        (q, u) under the forward-simulation contact (as :func:`sspinn.model.simulation.step_torch`,
        without its ground reaction forces at every substep: the step needs them only at its end)."""
        passive = task.passive_torque(q[:, 3:], u[:, 3:], self._lower, self._upper, self._k, self._b)
        return self._integrate(q, u, self.physics_dt, (tau + passive,))

    def _qdd(self, q: torch.Tensor, u: torch.Tensor, tau: torch.Tensor) -> torch.Tensor:
        """q̈ under the torques ``tau`` and the forward-simulation contact."""
        return dynamics.forward_dynamics_with_contact(q, u, tau, self._p, self._c)[0]

    def _physics(self, q: torch.Tensor, u: torch.Tensor, tau: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """(q, u) after one control interval (``substeps`` substeps) under the torques ``tau``."""
        if self._whole_step_graph:
            return self._replay(q, u, tau)
        if not self._graphs:
            return self._substeps(q, u, tau)
        for _ in range(self.substeps):  # a graph's outputs live in its pool until copied out
            torch.compiler.cudagraph_mark_step_begin()
            q, u = (x.clone() for x in self._substep(q, u, tau))
        return q, u

    def _substeps(self, q: torch.Tensor, u: torch.Tensor, tau: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """``substeps`` calls of the (compiled or eager) substep."""
        for _ in range(self.substeps):
            q, u = self._substep(q, u, tau)
        return q, u

    def _replay(self, q: torch.Tensor, u: torch.Tensor, tau: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """``compile="step-graph"``: the control interval as one recorded CUDA graph. Recorded at
        the first step (after two warm-up runs on a side stream, which also compile the substep)
        on static copies of q, u and tau; every step copies its inputs in, replays, and copies the
        outputs out of the graph's memory pool."""
        if torch.is_grad_enabled() and (q.requires_grad or u.requires_grad or tau.requires_grad):
            raise ValueError('compile="step-graph" replays a recorded graph without gradients; use compile=True')
        if self._recorded is None:
            static = [q.detach().clone(), u.detach().clone(), tau.detach().clone()]
            side = torch.cuda.Stream(self.device)
            side.wait_stream(torch.cuda.current_stream(self.device))
            with torch.cuda.stream(side), torch.no_grad():
                for _ in range(2):
                    self._substeps(*static)
            torch.cuda.current_stream(self.device).wait_stream(side)
            graph = torch.cuda.CUDAGraph()
            with torch.cuda.graph(graph), torch.no_grad():
                out = self._substeps(*static)
            self._recorded = (graph, static, out)
        graph, static, out = self._recorded
        for buffer, value in zip(static, (q, u, tau)):
            buffer.copy_(value)
        graph.replay()
        return out[0].clone(), out[1].clone()

    def step(self, actions: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor, torch.Tensor, dict[str, Any]]:
        """Advance all environments by one control interval (0.01 s) under ``actions`` (N, 6) in
        [−1, 1] (clipped; a non-finite action is a ``ValueError``); returns (obs, reward,
        terminated, truncated, info)."""
        a = torch.as_tensor(actions, dtype=self.dtype, device=self.device)
        if a.shape != (self.num_envs, N_TAU):
            raise ValueError(f"actions must have shape ({self.num_envs}, {N_TAU}), got {tuple(a.shape)}")
        finite_actions = torch.isfinite(a).all(-1)
        if not bool(finite_actions.all()):
            rows = torch.nonzero(~finite_actions).flatten().tolist()
            raise ValueError(
                f"actions must be finite; environment(s) {rows[:10]} got {a[rows[0]].tolist()} (first shown): "
                "check the policy's output"
            )
        a = a.clamp(-1.0, 1.0)
        tau = a * self._tau_max
        q0, u0 = self.q, self.u
        q, u = self._physics(q0, u0, tau)
        grf = self._contact(q, u)
        finite = torch.isfinite(q).all(-1) & torch.isfinite(u).all(-1) & torch.isfinite(grf).all(-1)
        if not bool(finite.all()):  # keep the last finite state of failed rows
            q = torch.where(finite[:, None], q, q0)
            u = torch.where(finite[:, None], u, u0)
            grf = torch.where(finite[:, None], grf, self.grf)
        self.q, self.u, self.grf = q, u, grf
        speed = (q[:, 0] - q0[:, 0]) / CONTROL_DT
        self._work = self._work + (tau * (q[:, 3:] - q0[:, 3:])).abs().sum(-1).detach()
        self._steps = self._steps + 1
        terminated = task.unhealthy(q, self.standing_height, self._config) | ~finite
        loaded = grf[:, 1::2].detach() > CONTACT_THRESHOLD_BW * self._body_weight
        self._phase = task.next_phase(self._phase, loaded, CONTROL_DT)
        total, tracking, alive, effort = task.reward(speed, self.target_speed, a, terminated, self._config, grf,
                                                     self._phase)
        truncated = (self._steps >= self._config.max_episode_steps) & ~terminated
        obs = self.observe()
        distance = (q[:, 0] - self._x0).detach()
        cot = torch.where(distance > 0.01, self._work / (self._body_weight * distance.clamp_min(0.01)), torch.inf)
        info: dict[str, Any] = {
            "speed": speed,
            "target_speed": self.target_speed.clone(),
            "x_position": q[:, 0],
            "distance": distance,
            "cost_of_transport": cot,
            "grf": grf,
            "torques": tau,
            "reward_tracking": tracking,
            "reward_alive": alive,
            "reward_effort": effort,
            "physics_failure": ~finite,
        }
        if self.auto_reset:
            done = terminated | truncated
            if bool(done.any()):
                obs = self._reset_done(done, obs, info)
        return obs, total, terminated, truncated, info

    def _reset_done(self, done: torch.Tensor, obs: torch.Tensor, info: dict[str, Any]) -> torch.Tensor:
        """Same-step auto-reset of the rows in ``done``; returns the observations to hand out."""
        info["final_obs"] = obs
        info["_final_obs"] = done
        q_new, u_new, target_new = self._initial_states(self.num_envs, None)
        rows = done[:, None]
        self.q = torch.where(rows, q_new, self.q)
        self.u = torch.where(rows, u_new, self.u)
        self.target_speed = torch.where(done, target_new, self.target_speed)
        self.grf = torch.where(rows, self._contact(self.q, self.u), self.grf)
        self._x0 = torch.where(done, self.q[:, 0], self._x0)
        self._work = torch.where(done, torch.zeros_like(self._work), self._work)
        self._steps = torch.where(done, torch.zeros_like(self._steps), self._steps)
        self._phase = torch.where(rows, torch.zeros_like(self._phase), self._phase)
        return self.observe()

    def close_extras(self, **kwargs: Any) -> None:
        """Nothing to release (no processes, no windows)."""
