"""Gymnasium environment: the sagittal 9-DOF sspinn model walking or running at a target speed."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import gymnasium
import numpy as np
from gymnasium import spaces

from envs import task
from envs.config import CONTROL_DT, WalkerConfig, WalkerParameters
from envs.walker_state import WalkerState, episode_setup
from sspinn.model.conventions import N_Q, N_TAU
from sspinn.model.simulation import METHODS, advance


class SagittalWalkerEnv(WalkerParameters, gymnasium.Env):
    r"""## Description

    A torque-driven sagittal-plane human model (sspinn: 7 rigid segments — head-arms-trunk,
    thighs, shanks, feet — and 9 degrees of freedom: pelvis x, y and tilt, hip, knee and ankle of
    each leg) must walk or run forward at a target speed. The equations of motion were derived once
    with SymPy (Kane's method) and are evaluated by generated numba code; the feet touch the ground
    through the smooth spring–damper and regularised-Coulomb friction model of
    :mod:`sspinn.model.contact` (one contact point per foot that rolls from heel to toe with the foot
    angle). The layout follows Gymnasium's MuJoCo ``Walker2d-v5``, with SI units throughout
    (conventions of :mod:`sspinn.model.conventions`: x forward, y up, angles counter-clockwise seen from
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

    Per step (see :class:`envs.config.WalkerConfig`)::

        reward = tracking_weight · exp(−((v − v*) / tracking_width)²)     (speed tracking)
                 + alive_bonus · [step does not terminate]                (alive)
                 − effort_weight · Σ_j a_j²                               (effort)

    v is the hip's forward displacement over the step divided by 0.01 s (m/s), v* the target
    speed. Defaults: tracking_weight 1, tracking_width 0.25 m/s, alive_bonus 0.2,
    effort_weight 0.01 (full activation of all six joints costs 0.06 per step). ``info`` holds the
    three unweighted terms. Optional gait shaping (off by default, :class:`envs.config.WalkerConfig`):
    ``− slip_weight · Σ_feet v_slip − impact_weight · Σ_feet max(F_y/BW − impact_threshold, 0)²``
    from the contact forces at the end of the step (v_slip: the sliding speed of a loaded foot that
    the friction law implies, m/s; F_y in BW), and ``− phase_weight`` for each foot whose current
    contact or air phase has lasted longer than ``max_phase_duration`` s (hopping, dragging).

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
    (:mod:`predictive.generator.closed_loop`); the state is one of the announced body, so under a
    body disturbance pelvis_ty is shifted by the difference of the standing hip heights. ``reset(options={"reset_noise_scale": s})`` changes
    the noise half-width for that episode; ``reset(options={"disturbances": {...}})`` its
    disturbances (below). Other option keys are a ``ValueError``. The random draws of a reset are
    listed in :mod:`envs.walker_state`.

    ## Disturbances

    The same disturbance tests for every controller, as the ``disturbances`` field of the
    configuration (every episode) or the ``disturbances`` reset option (that episode; the given
    fields replace the configuration's). Fields and units (:class:`envs.disturbances.Disturbances`):

    * ``push_force`` (% body weight, + forward), ``push_duration`` (s, whole control steps),
      ``push_time`` (s after reset) or ``push_phase`` (``"midstance_r"``/``"midstance_l"``: the first
      mid-stance of that foot — single support and its horizontal contact force turning from braking
      to propulsive — at or after ``push_after`` s): a horizontal force on the pelvis at the hip
      joint centre, once per episode. ``info["push_force"]`` is the force (N) applied during the step.
    * ``obs_noise``: {"height": m, "angle": rad, "linear_velocity": m/s, "angular_velocity": rad/s,
      "grf": BW} standard deviations of Gaussian observation noise; ``obs_delay``: control steps by
      which the observation lags the state.
    * ``strength_change``: % change of the actuator torques (one number or six).
    * ``mass_change``, ``length_change``: % change of the simulated body's segment masses and
      lengths (one number, or per segment / segment type). The announced model (``body``,
      ``body_vector``, ``tau_max``, ``step_state``) stays nominal: a controller does not know.

    ``SagittalWalkerEnv(disturbances={"push_force": 15, "push_duration": 0.1, "push_phase":
    "midstance_r"})`` pushes forward with 15 % BW for 0.1 s at the first right mid-stance after 1 s.

    ## Passive joint moments

    The sspinn model has no joint limits, and 3 N·m/kg applied to a 1 kg foot spins it at hundreds
    of rad/s within a few steps. The environment therefore adds a passive moment to every joint
    (:func:`sspinn.model.passive.passive_torque`, as in the gait2d model family): quadratic soft limits
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
    * Truncation (``truncated``): after ``max_episode_steps`` steps (default 1000 = 10 s), unless
      that step terminates. The environment truncates by itself (also when made without
      ``gymnasium.make``); it is registered with ``max_episode_steps=1000``, so ``gymnasium.make``
      adds Gymnasium's ``TimeLimit`` wrapper at the same step. ``gymnasium.make(ID,
      max_episode_steps=K)`` only sets that wrapper's limit: for an episode longer than 1000 steps
      also give the environment's own, ``config=WalkerConfig(max_episode_steps=K)`` (as
      :func:`agents.train.make_env` does).
    * After the episode ended, call ``reset()``. As Gymnasium's own environments do (e.g.
      CartPole), a ``step()`` after ``terminated`` or ``truncated`` warns (once per episode),
      still advances the physics, returns the same (``terminated``, ``truncated``) pair as the
      step that ended the episode and gives reward 0.
    * An action with NaN or inf is a ``ValueError`` naming the action (it would otherwise turn
      into a NaN reward and poison returns); finite actions outside [−1, 1] are clipped.

    ## Physics step (chosen by measurement)

    Control at 100 Hz; each 0.01 s interval is integrated with **semi-implicit (symplectic)
    Euler, 50 substeps of 0.2 ms**, and the forward-simulation friction uses a slip velocity
    **v_s = 0.2 m/s** (instead of the contact module's 0.05 m/s). Reasons, from
    ``python -m benchmarks.speed.bench_env --step-study`` on the 1.75 m / 70 kg body:

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
      i.e. 55–80 µs of physics per control step (:func:`sspinn.model.simulation.advance`); a whole ``step``
      took ≈175 µs (5.7 k steps/s against 2.5 k for Walker2d-v5 in the same run, ``benchmarks/speed/bench_env.py``).

    ``substeps``, ``method`` ("semi_implicit_euler" or "rk4") and ``slip_velocity`` can be changed;
    keep dt = 0.01 s / substeps below the limit above for the loads you expect.

    ## Info

    ``step`` returns ``info`` with: ``speed`` (m/s, hip forward speed over the step),
    ``target_speed`` (m/s), ``x_position`` (m, hip), ``distance`` (m, hip displacement since the
    reset), ``cost_of_transport`` (mechanical, dimensionless: Σ over steps and joints of
    |τ_j·Δθ_j| — the joint work of each constant-torque interval — divided by m·g·distance; +inf
    while the hip has not moved at least 1 cm forward), ``grf`` (4, N: Fx_r, Fy_r, Fx_l, Fy_l),
    ``torques`` (6, N·m, actuators only), ``reward_tracking``, ``reward_alive``, ``reward_effort`` (unweighted terms),
    ``physics_failure`` (True only if the state became non-finite; the previous state is then kept)
    and ``push_force`` (N, the push applied during the step, 0 without).
    ``reset`` returns ``target_speed`` and ``x_position``.

    ## Arguments

    ``gymnasium.make("sspinn/SagittalWalker-v0", **kwargs)`` or ``SagittalWalkerEnv(**kwargs)``.
    The task and physics arguments are the fields of one frozen dataclass,
    :class:`envs.config.WalkerConfig` (validated on construction; shared with
    :class:`envs.batched.BatchedSagittalWalker`): pass one as ``config=WalkerConfig(...)`` and/or its
    fields as keywords, which override the ``config``'s (``SagittalWalkerEnv(config=cfg, target_speed=1.3)``).
    ``render_mode``, ``width`` and ``height_px`` belong to this environment only.

    ====================== ============================ ===============================================
    argument               default                      meaning
    ====================== ============================ ===============================================
    config                 None                         a WalkerConfig; None → WalkerConfig()
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
    slip_weight            0.0                          weight of the loaded feet's sliding speed, per m/s
    impact_weight          0.0                          weight of max(F_y/BW − impact_threshold, 0)² per foot
    impact_threshold       1.5                          BW
    phase_weight           0.0                          per foot in a contact/air phase > max_phase_duration
    max_phase_duration     1.0                          s
    min_height_fraction    0.6                          fall threshold, fraction of standing hip height
    max_tilt               1.0                          |pelvis tilt| limit, rad
    joint_range            None                         passive soft-limit ranges {"hip": (lo, hi), ...},
                                                        rad; None → defaults above
    joint_limit_stiffness  10000                        soft-limit stiffness, N·m/rad²
    joint_damping          1.0                          viscous joint damping, N·m·s/rad
    reset_noise_scale      0.005                        initial-state noise half-width (m, rad, /s)
    reset_states           None                         (K, 18) start states (q, u) for a share of episodes
    reset_state_share      0.0                          share of episodes starting at a random row of them
    max_episode_steps      1000                         truncation, control steps (0.01 s each)
    substeps               50                           physics substeps per control step
    method                 "semi_implicit_euler"        integrator ("semi_implicit_euler" or "rk4")
    slip_velocity          0.2                          friction regularisation v_s, m/s
    contact                None                         ContactParameters (stiffness, damping, μ...)
    disturbances           none                         Disturbances or a mapping of its fields (above)
    render_mode            None                         None, "rgb_array" or "human"
    width, height_px       600, 400                     rendered image size, px
    ====================== ============================ ===============================================

    Invalid arguments raise ``ValueError`` (``sspinn.model.body.ParameterError`` is a subclass) naming the
    argument and the expected units; an unknown keyword is a ``TypeError`` listing the fields.

    ## Public model (for controllers)

    Read-only members (:class:`envs.config.WalkerParameters`; arrays are float64 copies) that give a
    model-based controller the environment's exact step without reading private state:

    * ``config``: the :class:`~envs.config.WalkerConfig`.
    * ``body`` (:class:`sspinn.model.body.BodyParameters`), ``contact``
      (:class:`sspinn.model.contact.ContactParameters`, forward-simulation friction) and their packed
      vectors ``body_vector`` (41,) and ``contact_vector`` (7,), the ``p`` and ``c`` arguments of
      :mod:`sspinn.model.simulation` and :mod:`sspinn.model.dynamics`.
    * ``tau_max``: (6,) maximal actuator torque per joint, N·m (torque = clipped action × tau_max).
    * ``passive_parameters``: (14,) packed passive-moment parameters [lower (6, rad), upper (6, rad),
      stiffness (N·m/rad²), damping (N·m·s/rad)]; ``passive_torque(angles, rates)``: those moments
      in N·m.
    * ``dt`` (control interval, 0.01 s), ``substeps``, ``physics_dt`` (s, = dt / substeps),
      ``method`` (integrator name), ``standing_height`` (m, hip height of the starting pose).
    * ``step_state(q, u, action) -> (q, u, grf)``: one control step from any state, exactly as
      ``step`` computes it (same action checks and clipping, torques, passive moments, integrator),
      without changing the environment. ``state`` / ``set_state(q, u)`` read and write the
      environment's own state; ``target_speed`` is the current episode's target, m/s.

    ## Version history

    * v0: first version.
    """

    metadata = {"render_modes": ["human", "rgb_array"], "render_fps": 100}

    def __init__(
        self,
        *,
        config: WalkerConfig | None = None,
        render_mode: str | None = None,
        width: int = 600,
        height_px: int = 400,
        **overrides: Any,
    ) -> None:
        super().__init__()
        self._config = WalkerConfig.resolve(config, **overrides)
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode must be None or one of {self.metadata['render_modes']}, got {render_mode!r}")
        self.render_mode = render_mode
        self.width = task.check_int("width", width, 16)
        self.height_px = task.check_int("height_px", height_px, 16)
        # packed parameters of the nominal model (float64 copies; step_state)
        self._p = self.body_vector
        self._c = self.contact_vector
        self._tau_max = self.tau_max
        self._passive = self.passive_parameters
        self._method_index = METHODS.index(self.method)

        self.action_space = spaces.Box(-1.0, 1.0, (N_TAU,), dtype=np.float32)
        self.observation_space = spaces.Box(-np.inf, np.inf, (task.OBS_SIZE,), dtype=np.float32)

        # the walker (one row of the engine shared with the vector environment)
        self._walker = WalkerState(self._config, 1)
        self._active = np.ones(1, dtype=bool)
        self._actions = np.zeros((1, N_TAU))
        self._warned_after_end = False
        self._renderer: Any = None

    # ------------------------------------------------------------------------------------------
    @property
    def state(self) -> tuple[np.ndarray, np.ndarray]:
        """Copies of the coordinates q (9,) and speeds u (9,) (SI, :mod:`sspinn.model.conventions`)."""
        return self._walker.q[0].copy(), self._walker.u[0].copy()

    def set_state(self, q: np.ndarray, u: np.ndarray) -> None:
        """Overwrite the state (e.g. to replay or compare); ground forces are recomputed."""
        q, u = _state_copies(q, u)
        self._walker.set_state(0, q, u)

    @property
    def target_speed(self) -> float:
        """Target speed of the current episode, m/s."""
        return float(self._walker.target(0))

    def step_state(self, q: np.ndarray, u: np.ndarray, action: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Advance the state (q, u) by one control interval under ``action`` exactly as :meth:`step`
        does (same checks and clipping of the action, torques, passive moments, integrator and
        substeps), without touching the environment's own state, episode or random generator.
        This is the announced (nominal) model: disturbances (push, strength change, body mismatch)
        are not in it, so with them it differs from :meth:`step` by design.

        Args:
            q, u: coordinates (9,) and speeds (9,), SI units (:mod:`sspinn.model.conventions`), finite.
            action: (6,) normalised torques; clipped to [−1, 1], non-finite values are a ``ValueError``.

        Returns:
            New arrays (q, u, grf): the state after :attr:`dt` and the ground reaction forces (4,) in
            N at that state. Non-finite where the physics failed (:meth:`step` then keeps the old
            state and terminates the episode).
        """
        q, u = _state_copies(q, u)
        grf = np.empty(4)
        self._advance(q, u, self._action(action) * self._tau_max, grf)
        return q, u, grf

    def _action(self, action: np.ndarray) -> np.ndarray:
        """The action as float64 (6,) clipped to [−1, 1]; a wrong shape or a non-finite value raises."""
        if np.iscomplexobj(action):
            raise ValueError(f"action must be real, got the complex {np.asarray(action).tolist()}: check the policy's output")
        a = np.asarray(action, dtype=np.float64)
        if a.shape != (N_TAU,):
            raise ValueError(f"action must have shape ({N_TAU},), got {a.shape}")
        if not np.isfinite(a).all():
            raise ValueError(f"action must be finite, got {a.tolist()}: check the policy's output")
        return np.minimum(np.maximum(a, -1.0), 1.0)

    def _advance(self, q: np.ndarray, u: np.ndarray, tau: np.ndarray, grf: np.ndarray) -> bool:
        """The compiled physics of the nominal model for one control interval, in place on q, u
        and grf; True if finite."""
        return advance(
            q, u, tau, self._passive, self._p, self._c, self.physics_dt, self.substeps, self._method_index, True, grf
        )

    # ------------------------------------------------------------------------------------------
    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[np.ndarray, dict[str, Any]]:
        if options is not None and not isinstance(options, Mapping):
            raise TypeError(f"reset(options=...) must be a dict of reset options (target_speed, initial_state, "
                            f"reset_noise_scale, disturbances) or None, got the {type(options).__name__} {options!r}")
        super().reset(seed=seed)
        setup = episode_setup(self._config, options, 1)
        self._walker.reset_rows(np.zeros(1, dtype=np.int64), [self.np_random], setup)
        self._warned_after_end = False
        if self.render_mode == "human":
            self.render()
        return self._walker.obs[0].copy(), {"target_speed": self.target_speed, "x_position": float(self._walker.q[0, 0])}

    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        self._actions[0] = self._action(action)
        if self._walker.ended(0) and not self._warned_after_end:
            gymnasium.logger.warn(
                "step() called after the episode ended (terminated or truncated); call reset() first: "
                "terminated/truncated stay as they were and the reward is 0 until then"
            )
            self._warned_after_end = True
        self._walker.step(self._actions, self._active, parallel=False)
        terminated, truncated = (bool(f) for f in self._walker.flags[0, :2])
        reward = float(self._walker.out[0, 0])
        info = self._walker.info(0)
        if self.render_mode == "human":
            self.render()
        return self._walker.obs[0].copy(), reward, terminated, truncated, info

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
        w = self._walker
        q, u = w.q[0], w.u[0]
        text = (
            f"t = {int(w.steps(0)) * CONTROL_DT:5.2f} s   v = {u[0]:5.2f} m/s   "
            f"target = {self.target_speed:4.2f} m/s   x = {q[0]:5.2f} m"
        )
        return self._renderer.draw(q, u, w.grf[0], text)

    def close(self) -> None:
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None


def _state_copies(q: Any, u: Any) -> tuple[np.ndarray, np.ndarray]:
    """float64 copies of a state (q, u), each finite with shape (9,), else a ``ValueError``."""
    q = np.array(q, dtype=np.float64)
    u = np.array(u, dtype=np.float64)
    if q.shape != (N_Q,) or u.shape != (N_Q,) or not (np.isfinite(q).all() and np.isfinite(u).all()):
        raise ValueError(f"q and u must be finite arrays of shape ({N_Q},), got {q.shape} and {u.shape}")
    return q, u
