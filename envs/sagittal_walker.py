"""Gymnasium environment: the sagittal 9-DOF sspinn model walking or running at a target speed."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import gymnasium
import numpy as np
from gymnasium import spaces

from envs import task
from sspinn.body import BodyParameters
from sspinn.contact import ContactParameters
from sspinn.conventions import N_Q, N_TAU
from sspinn.simulation import METHODS, advance, contact_into

#: Control interval (s) and physics defaults; the choice is justified in the class docstring.
CONTROL_DT = 0.01
SUBSTEPS = 50
METHOD = "semi_implicit_euler"
SLIP_VELOCITY = 0.2


class SagittalWalkerEnv(gymnasium.Env):
    r"""## Description

    A torque-driven sagittal-plane human model (sspinn: 7 rigid segments — head-arms-trunk,
    thighs, shanks, feet — and 9 degrees of freedom: pelvis x, y and tilt, hip, knee and ankle of
    each leg) must walk or run forward at a target speed. The equations of motion were derived once
    with SymPy (Kane's method) and are evaluated by generated numba code; the feet touch the ground
    through the smooth spring–damper and regularised-Coulomb friction model of
    :mod:`sspinn.contact` (one contact point per foot that rolls from heel to toe with the foot
    angle). The layout follows Gymnasium's MuJoCo ``Walker2d-v5``, with SI units throughout
    (conventions of :mod:`sspinn.conventions`: x forward, y up, angles counter-clockwise seen from
    the subject's right; hip flexion +, **knee flexion −**, ankle dorsiflexion +).

    Register name ``"sspinn/SagittalWalker-v0"`` (``import envs`` registers it; see
    :mod:`envs`).

    ## Action space

    ``Box(-1, 1, (6,), float32)``: normalised joint torques in the order hip_r, knee_r, ankle_r,
    hip_l, knee_l, ankle_l. Actions are clipped to [−1, 1] and multiplied by the joint's maximal
    torque ``max_torque`` (N·m/kg) × body mass (kg), giving N·m; the torque acts on the distal
    segment (+) and the proximal one (−) and is held constant over the control interval (0.01 s).

    Default strength (N·m/kg, symmetric for both directions): hip 3.0, knee 3.0, ankle 3.0 —
    i.e. 210 N·m at 70 kg. Sources and approximations:

    * Knee: meta-analysis of isometric knee strength, Šarabon, Kozinc & Perman (2021), *Front.
      Physiol.* 12:767941: healthy adult men, mid-range knee angle, extension 2.92–3.45 N·m/kg
      (95 % CI); flexion is much weaker (1.15–1.62 N·m/kg), which a symmetric limit ignores.
    * Hip and ankle: set to the same value as a round figure of the order reported for isometric
      hip-extensor and plantar-flexor strength of young adults in dynamometry studies (e.g.
      Anderson, Madigan & Nussbaum 2007, *J Biomech* 40:3105–3113; Hussain & Frey-Law 2016,
      *J Foot Ankle Res*) and of the peak net joint moments of running at moderate speeds
      (≈2–3 N·m/kg). These two values are **approximations that were not checked against the
      tables of those papers**; hip flexors and ankle dorsiflexors are much weaker than the
      symmetric limit, and real strength falls with joint angular velocity (no force–velocity
      relation is modelled). Pass ``max_torque`` to change them.

    ## Observation space

    ``Box(-inf, inf, (22,), float32)``; everything except the absolute horizontal position
    (names in :data:`envs.task.OBSERVATION_NAMES`):

    ===== ========================================== ======
    index observation                                unit
    ===== ========================================== ======
    0     pelvis_ty: hip joint centre height         m
    1     pelvis_tilt: HAT angle (+: leaning back)   rad
    2–4   hip_r, knee_r, ankle_r angles              rad
    5–7   hip_l, knee_l, ankle_l angles              rad
    8     d_pelvis_tx: hip forward velocity          m/s
    9     d_pelvis_ty: hip vertical velocity         m/s
    10    d_pelvis_tilt                              rad/s
    11–13 d_hip_r, d_knee_r, d_ankle_r               rad/s
    14–16 d_hip_l, d_knee_l, d_ankle_l               rad/s
    17–18 grf_x_r, grf_y_r: right ground reaction    BW
    19–20 grf_x_l, grf_y_l: left ground reaction     BW
    21    target speed                               m/s
    ===== ========================================== ======

    Ground reaction forces are in body weights (BW = m·g with g = 9.81 m/s²) and are those of the
    state at the end of the control interval.

    ## Rewards

    Per step (see :class:`envs.task.TaskConfig`)::

        reward = tracking_weight · exp(−((v − v*) / tracking_width)²)     (speed tracking)
                 + alive_bonus · [step does not terminate]                (alive)
                 − effort_weight · Σ_j a_j²                               (effort)

    v is the hip's forward displacement over the step divided by 0.01 s (m/s), v* the target
    speed. Defaults: tracking_weight 1, tracking_width 0.25 m/s, alive_bonus 0.2,
    effort_weight 0.01 (full activation of all six joints costs 0.06 per step). ``info`` holds the
    three unweighted terms.

    ## Starting state

    Standing upright (all angles 0, feet flat, hip at the height where each foot carries half the
    body weight in static contact equilibrium, ≈4 mm penetration), at rest, plus uniform noise in
    [−reset_noise_scale, reset_noise_scale] on every coordinate except pelvis_tx (m or rad) and on
    every speed (m/s or rad/s), drawn from ``self.np_random``. The feet touch the ground at one point
    each, midway between heel and toe, with the body's centre of mass above the ankles: the body is
    not statically balanced and must be controlled from the first step. The target speed is fixed,
    or drawn uniformly from ``target_speed=(low, high)`` at every reset, or given as
    ``reset(options={"target_speed": v})``. ``reset(options={"initial_state": (q, u)})`` starts
    from another state instead of standing (q, u: 9 coordinates and speeds in SI units; pelvis_tx
    is set to 0 and the same noise is added) — e.g. on a gait cycle, for controllers that track one
    (:mod:`predictive.closed_loop`).

    ## Passive joint moments

    The sspinn model has no joint limits, and 3 N·m/kg applied to a 1 kg foot spins it at hundreds
    of rad/s within a few steps. The environment therefore adds a passive moment to every joint
    (:func:`sspinn.passive.passive_torque`, as in the gait2d model family): quadratic soft limits
    ``k·(max(lower − θ, 0)² − max(θ − upper, 0)²)`` with k = ``joint_limit_stiffness`` (10⁴ N·m/rad²;
    the full 210 N·m of a 70 kg body is balanced 0.145 rad beyond a limit) outside the ranges
    (rad) hip [−0.6, 2.0], knee [−2.4, 0.05], ankle [−0.9, 0.6] (``joint_range``), plus viscous
    damping ``−b·θ̇`` with b = ``joint_damping`` (1 N·m·s/rad). They are evaluated at the start of
    every physics substep and are not part of the action or of the reported ``torques``. Setting
    ``joint_limit_stiffness=0, joint_damping=0`` gives the bare model.

    ## Episode end

    * Termination (``terminated``): the hip falls below ``min_height_fraction`` (0.6) of the
      standing hip height (≈0.56 m for the default body), |pelvis_tilt| exceeds ``max_tilt``
      (1.0 rad), or the state becomes non-finite (never observed with the default physics).
    * Truncation (``truncated``): after ``max_episode_steps`` steps (default 1000 = 10 s). The
      environment truncates by itself; it is registered without a ``TimeLimit`` wrapper.
    * After the episode ended, call ``reset()``. As Gymnasium's own environments do (e.g.
      CartPole), a ``step()`` after ``terminated`` or ``truncated`` warns (once per episode),
      still advances the physics, keeps ``terminated``/``truncated`` true and gives reward 0.
    * An action with NaN or inf is a ``ValueError`` naming the action (it would otherwise turn
      into a NaN reward and poison returns); finite actions outside [−1, 1] are clipped.

    ## Physics step (chosen by measurement)

    Control at 100 Hz; each 0.01 s interval is integrated with **semi-implicit (symplectic)
    Euler, 50 substeps of 0.2 ms**, and the forward-simulation friction uses a slip velocity
    **v_s = 0.2 m/s** (instead of the contact module's 0.05 m/s). Reasons, from
    ``python benchmarks/bench_env.py --step-study`` on the 1.75 m / 70 kg body:

    * The friction law −μ·tanh(ẋ/v_s)·F_y is stiff: its damping is μ·F_y/v_s, so the largest stable
      explicit step shrinks ∝ v_s / F_y. Landings with forward speed 1.3 m/s and 2.2, 3.5 and 5.9 BW
      peak vertical force, integrated under a PD controller and compared at the 100 Hz samples with
      RK4 at 10 µs, show semi-implicit Euler reproducing the contact forces (error ≤ 0.06 BW) up to
      dt ≈ 6 ms · v_s[m/s] / F_peak[BW], and chattering (errors of whole BW) above it:
      at v_s = 0.05 m/s the limit is ≈0.12 ms even at 2.2 BW; at v_s = 0.1 m/s ≈0.25, 0.17 and
      0.1 ms; at v_s = 0.2 m/s ≥0.5, 0.33 and 0.2 ms for the three loads. In an exploratory scan
      (open-loop torques, v_s = 0.1 and 0.2 m/s; not repeated by the benchmark) RK4 tolerated at
      most ≈1.5–2× the semi-implicit step at four model evaluations per step, i.e. it costs ≥2×
      more per simulated second.
    * 0.2 ms at v_s = 0.2 m/s keeps that margin up to ≈6 BW peaks (running produces ≈2.5–3 BW)
      with 50 model evaluations per control step; v_s = 0.1 m/s would need 0.1 ms (twice the
      cost) for the same margin. The price of v_s = 0.2 m/s is creep: a loaded foot slides at v_s·artanh(|F_x|/(μ·F_y)),
      ≈5 cm/s at the ≈0.25 friction use of walking's push-off peaks (about 1–2 cm per stance).
    * In those landings the joint angles stay within 1 mrad (and the hip within 0.1 mm) of the
      RK4 reference after 0.25 s, i.e. the first-order integration error is small at 0.2 ms.
    * In 300 random-action episodes (mean length 45 steps) no state became non-finite. Random
      policies do crash into the ground harder than gait loads (median episode peak 5 BW, 99th
      percentile 13.5 BW); beyond ≈6 BW the friction force chatters between substeps (bounded, no
      blow-up) until the impact is over.
    * Cost: ≈1.1–1.6 µs per model evaluation on the 2-core development machine (load-dependent),
      i.e. 55–80 µs of physics per control step (:func:`sspinn.simulation.advance`); a whole ``step``
      took ≈175 µs (5.7 k steps/s against 2.5 k for Walker2d-v5 in the same run, ``benchmarks/bench_env.py``).

    ``substeps``, ``method`` ("semi_implicit_euler" or "rk4") and ``slip_velocity`` can be changed;
    keep dt = 0.01 s / substeps below the limit above for the loads you expect.

    ## Info

    ``step`` returns ``info`` with: ``speed`` (m/s, hip forward speed over the step),
    ``target_speed`` (m/s), ``x_position`` (m, hip), ``distance`` (m, hip displacement since the
    reset), ``cost_of_transport`` (mechanical, dimensionless: Σ over steps and joints of
    |τ_j·Δθ_j| — the joint work of each constant-torque interval — divided by m·g·distance; +inf
    while the hip has not moved at least 1 cm forward), ``grf`` (4, N: Fx_r, Fy_r, Fx_l, Fy_l),
    ``torques`` (6, N·m, actuators only), ``reward_tracking``, ``reward_alive``, ``reward_effort`` (unweighted terms) and
    ``physics_failure`` (True only if the state became non-finite; the previous state is then kept).
    ``reset`` returns ``target_speed`` and ``x_position``.

    ## Arguments

    ``gymnasium.make("sspinn/SagittalWalker-v0", **kwargs)`` or ``SagittalWalkerEnv(**kwargs)``:

    ====================== ============================ ===============================================
    argument               default                      meaning
    ====================== ============================ ===============================================
    height                 1.75                         body height, m (Winter scaling; 0.5–2.5)
    mass                   70.0                         body mass, kg (10–300)
    body                   None                         a BodyParameters or a dict for
                                                        BodyParameters.from_dict (then height/mass
                                                        must stay at their defaults)
    target_speed           1.25                         m/s, or a (low, high) range sampled per episode
    max_torque             None                         N·m/kg: {"hip", "knee", "ankle"} mapping or six
                                                        values; None → 3.0 each
    tracking_weight        1.0                          reward weight of speed tracking
    tracking_width         0.25                         σ of the tracking Gaussian, m/s
    alive_bonus            0.2                          reward per non-terminating step
    effort_weight          0.01                         weight of Σ a²
    min_height_fraction    0.6                          fall threshold, fraction of standing hip height
    max_tilt               1.0                          |pelvis tilt| limit, rad
    joint_range            None                         passive soft-limit ranges {"hip": (lo, hi), ...},
                                                        rad; None → defaults above
    joint_limit_stiffness  10000                        soft-limit stiffness, N·m/rad²
    joint_damping          1.0                          viscous joint damping, N·m·s/rad
    reset_noise_scale      0.005                        initial-state noise half-width (m, rad, /s)
    max_episode_steps      1000                         truncation, control steps (0.01 s each)
    substeps               50                           physics substeps per control step
    method                 "semi_implicit_euler"        integrator ("semi_implicit_euler" or "rk4")
    slip_velocity          0.2                          friction regularisation v_s, m/s
    contact                None                         ContactParameters (stiffness, damping, μ...)
    render_mode            None                         None, "rgb_array" or "human"
    width, height_px       600, 400                     rendered image size, px
    ====================== ============================ ===============================================

    Invalid arguments raise ``ValueError`` (``sspinn.body.ParameterError`` is a subclass) naming the
    argument and the expected units.

    ## Version history

    * v0: first version.
    """

    metadata = {"render_modes": ["human", "rgb_array"], "render_fps": 100}

    def __init__(
        self,
        *,
        height: float = 1.75,
        mass: float = 70.0,
        body: BodyParameters | Mapping[str, Any] | None = None,
        target_speed: float | Sequence[float] = 1.25,
        max_torque: Mapping[str, float] | Sequence[float] | None = None,
        tracking_weight: float = 1.0,
        tracking_width: float = 0.25,
        alive_bonus: float = 0.2,
        effort_weight: float = 0.01,
        min_height_fraction: float = 0.6,
        max_tilt: float = 1.0,
        joint_range: Mapping[str, Sequence[float]] | None = None,
        joint_limit_stiffness: float = task.DEFAULT_LIMIT_STIFFNESS,
        joint_damping: float = task.DEFAULT_JOINT_DAMPING,
        reset_noise_scale: float = 0.005,
        max_episode_steps: int = 1000,
        substeps: int = SUBSTEPS,
        method: str = METHOD,
        slip_velocity: float = SLIP_VELOCITY,
        contact: ContactParameters | None = None,
        render_mode: str | None = None,
        width: int = 600,
        height_px: int = 400,
    ) -> None:
        super().__init__()
        setup = build_setup(
            height=height, mass=mass, body=body, target_speed=target_speed, max_torque=max_torque,
            tracking_weight=tracking_weight, tracking_width=tracking_width, alive_bonus=alive_bonus,
            effort_weight=effort_weight, min_height_fraction=min_height_fraction, max_tilt=max_tilt,
            joint_range=joint_range, joint_limit_stiffness=joint_limit_stiffness, joint_damping=joint_damping,
            reset_noise_scale=reset_noise_scale, max_episode_steps=max_episode_steps,
            substeps=substeps, method=method, slip_velocity=slip_velocity, contact=contact,
        )
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode must be None or one of {self.metadata['render_modes']}, got {render_mode!r}")
        self.render_mode = render_mode
        self.width = task.check_int("width", width, 16)
        self.height_px = task.check_int("height_px", height_px, 16)
        self.setup = setup
        self.body: BodyParameters = setup["body"]
        self.contact: ContactParameters = setup["contact"]
        self.config: task.TaskConfig = setup["config"]
        self._p = self.body.vector()
        self._c = self.contact.vector()
        self._tau_max = setup["tau_max"]
        self._passive = setup["passive"]
        self._method = METHODS.index(setup["method"])
        self._substeps = setup["substeps"]
        self._dt = CONTROL_DT / self._substeps
        self._body_weight = self.body.body_weight
        self._standing = setup["standing_height"]

        self.action_space = spaces.Box(-1.0, 1.0, (N_TAU,), dtype=np.float32)
        self.observation_space = spaces.Box(-np.inf, np.inf, (task.OBS_SIZE,), dtype=np.float32)

        # state (float64, updated in place by the compiled stepper)
        self._q = np.zeros(N_Q)
        self._u = np.zeros(N_Q)
        self._grf = np.zeros(4)
        self._tau = np.zeros(N_TAU)
        self._target = np.zeros(())
        self._x0 = 0.0
        self._work = 0.0
        self._steps = 0
        self._ended = (False, False)  # (terminated, truncated) of the last step, until reset
        self._warned_after_end = False
        self._renderer: Any = None

    # ------------------------------------------------------------------------------------------
    @property
    def dt(self) -> float:
        """Control interval, s."""
        return CONTROL_DT

    @property
    def state(self) -> tuple[np.ndarray, np.ndarray]:
        """Copies of the coordinates q (9,) and speeds u (9,) (SI, :mod:`sspinn.conventions`)."""
        return self._q.copy(), self._u.copy()

    def set_state(self, q: np.ndarray, u: np.ndarray) -> None:
        """Overwrite the state (e.g. to replay or compare); ground forces are recomputed."""
        q = np.asarray(q, dtype=np.float64)
        u = np.asarray(u, dtype=np.float64)
        if q.shape != (N_Q,) or u.shape != (N_Q,) or not (np.isfinite(q).all() and np.isfinite(u).all()):
            raise ValueError(f"q and u must be finite arrays of shape ({N_Q},), got {q.shape} and {u.shape}")
        self._q[:] = q
        self._u[:] = u
        contact_into(self._q, self._u, self._p, self._c, True, self._grf)

    @property
    def target_speed(self) -> float:
        """Target speed of the current episode, m/s."""
        return float(self._target)

    def _obs(self) -> np.ndarray:
        return task.observation(self._q, self._u, self._grf, self._target, self._body_weight).astype(np.float32)

    # ------------------------------------------------------------------------------------------
    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        low, high = self.setup["target_range"]
        if options is not None and "target_speed" in options:
            self._target = np.asarray(task.check_target_speed(options["target_speed"]))
        else:
            self._target = np.asarray(low if low == high else self.np_random.uniform(low, high))
        noise = self.setup["reset_noise_scale"]
        q, u = np.zeros(N_Q), np.zeros(N_Q)
        q[1] = self._standing
        if options is not None and "initial_state" in options:
            q, u = _initial_state(options["initial_state"])
        q[0] = 0.0
        q[1:] += self.np_random.uniform(-noise, noise, N_Q - 1)
        u = u + self.np_random.uniform(-noise, noise, N_Q)
        self.set_state(q, u)
        self._tau[:] = 0.0
        self._x0 = float(self._q[0])
        self._work = 0.0
        self._steps = 0
        self._ended = (False, False)
        self._warned_after_end = False
        if self.render_mode == "human":
            self.render()
        return self._obs(), {"target_speed": float(self._target), "x_position": self._x0}

    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        a = np.asarray(action, dtype=np.float64)
        if a.shape != (N_TAU,):
            raise ValueError(f"action must have shape ({N_TAU},), got {a.shape}")
        if not np.isfinite(a).all():
            raise ValueError(f"action must be finite, got {a.tolist()}: check the policy's output")
        ended_before = self._ended
        if (ended_before[0] or ended_before[1]) and not self._warned_after_end:
            gymnasium.logger.warn(
                "step() called after the episode ended (terminated or truncated); call reset() first: "
                "terminated/truncated stay true and the reward is 0 until then"
            )
            self._warned_after_end = True
        a = np.minimum(np.maximum(a, -1.0), 1.0)
        np.multiply(a, self._tau_max, out=self._tau)
        q_before = self._q.copy()
        u_before = self._u.copy()
        finite = advance(
            self._q, self._u, self._tau, self._passive, self._p, self._c, self._dt, self._substeps, self._method, True,
            self._grf,
        )
        if not finite:  # keep the last finite state; the episode ends
            self.set_state(q_before, u_before)
        self._work += float(np.abs(self._tau * (self._q[3:] - q_before[3:])).sum())
        self._steps += 1
        speed = (self._q[0] - q_before[0]) / CONTROL_DT
        terminated = bool(task.unhealthy(self._q, self._standing, self.config)) or not finite
        total, tracking, alive, effort = task.reward(speed, self._target, a, terminated, self.config)
        truncated = self._steps >= self.setup["max_episode_steps"] and not terminated
        if ended_before[0] or ended_before[1]:  # sticky, as in Gymnasium's environments
            terminated, truncated = ended_before[0] or terminated, ended_before[1] and not terminated
            total = tracking = alive = effort = 0.0
        self._ended = (terminated, truncated)
        distance = float(self._q[0]) - self._x0
        info = {
            "speed": float(speed),
            "target_speed": float(self._target),
            "x_position": float(self._q[0]),
            "distance": distance,
            "cost_of_transport": self._work / (self._body_weight * distance) if distance > 0.01 else float("inf"),
            "grf": self._grf.copy(),
            "torques": self._tau.copy(),
            "reward_tracking": float(tracking),
            "reward_alive": float(alive),
            "reward_effort": float(effort),
            "physics_failure": not finite,
        }
        if self.render_mode == "human":
            self.render()
        return self._obs(), float(total), terminated, truncated, info

    # ------------------------------------------------------------------------------------------
    def render(self) -> np.ndarray | None:
        """An (height_px, width, 3) uint8 frame (``rgb_array``), a window update (``human``), or
        None with a warning when no render mode was chosen."""
        if self.render_mode is None:
            gymnasium.logger.warn(
                "render() called without a render mode; create the environment with render_mode='rgb_array' or 'human'."
            )
            return None
        if self._renderer is None:
            from envs.rendering import PymunkRenderer

            self._renderer = PymunkRenderer(
                self.body, self.contact, width=self.width, height=self.height_px, mode=self.render_mode,
                fps=self.metadata["render_fps"],
            )
        text = (
            f"t = {self._steps * CONTROL_DT:5.2f} s   v = {self._u[0]:5.2f} m/s   "
            f"target = {float(self._target):4.2f} m/s   x = {self._q[0]:5.2f} m"
        )
        return self._renderer.draw(self._q, self._u, self._grf, text)

    def close(self) -> None:
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None


def _initial_state(value: Any) -> tuple[np.ndarray, np.ndarray]:
    """(q, u) copies from ``options["initial_state"]``, with a clear error for bad values."""
    try:
        q, u = (np.array(v, dtype=np.float64) for v in value)
    except (TypeError, ValueError):
        raise ValueError("options['initial_state'] must be a pair (q, u) of 9 numbers each (m, rad, m/s, rad/s)") from None
    if q.shape != (N_Q,) or u.shape != (N_Q,) or not (np.isfinite(q).all() and np.isfinite(u).all()):
        raise ValueError(f"options['initial_state'] must be finite (q, u) of shape ({N_Q},) each, got {q.shape} and {u.shape}")
    return q, u


def build_setup(
    *,
    height: float,
    mass: float,
    body: BodyParameters | Mapping[str, Any] | None,
    target_speed: float | Sequence[float],
    max_torque: Mapping[str, float] | Sequence[float] | None,
    tracking_weight: float,
    tracking_width: float,
    alive_bonus: float,
    effort_weight: float,
    min_height_fraction: float,
    max_tilt: float,
    joint_range: Mapping[str, Sequence[float]] | None,
    joint_limit_stiffness: float,
    joint_damping: float,
    reset_noise_scale: float,
    max_episode_steps: int,
    substeps: int,
    method: str,
    slip_velocity: float,
    contact: ContactParameters | None,
) -> dict[str, Any]:
    """Validate the constructor arguments shared by the single and the batched environment and
    derive everything they need (body, contact, task config, torque limits in N·m, ...)."""
    if body is not None and (height != 1.75 or mass != 70.0):
        raise ValueError("give either body or height/mass, not both (body already fixes height and mass)")
    body_params = task.make_body(body, height, mass)
    contact_params = task.make_contact(slip_velocity, contact)
    config = task.TaskConfig(
        tracking_weight=tracking_weight,
        tracking_width=tracking_width,
        alive_bonus=alive_bonus,
        effort_weight=effort_weight,
        min_height_fraction=min_height_fraction,
        max_tilt=max_tilt,
    )
    if not task._is_real(reset_noise_scale) or not 0 <= reset_noise_scale <= 0.1:
        raise ValueError(f"reset_noise_scale must be a number in [0, 0.1] (m, rad), got {reset_noise_scale!r}")
    _, substeps, method = task.check_physics(CONTROL_DT, substeps, method, METHODS)
    return {
        "body": body_params,
        "contact": contact_params,
        "config": config,
        "tau_max": task.max_torques(max_torque, body_params.segment_mass_total),
        "passive": task.passive_parameters(joint_range, joint_limit_stiffness, joint_damping),
        "target_range": task.target_speed_range(target_speed),
        "reset_noise_scale": float(reset_noise_scale),
        "max_episode_steps": task.check_int("max_episode_steps", max_episode_steps, 1),
        "substeps": substeps,
        "method": method,
        "standing_height": task.standing_height(body_params, contact_params),
    }
