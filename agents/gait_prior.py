"""A reward for staying on a reference gait's state manifold, added to the environment's reward
during training.

Why: speed tracking, effort, slip, impact and phase penalties alone leave PPO in gaits that
score well and look nothing like walking — one leg held forward while the other does all the
stepping, or hopping on one leg (docs/agents.md). A motion-imitation term (Peng et al. 2018,
*DeepMimic*, ACM TOG 37:143) fixes this but usually needs a phase clock in the observation, which
is a hidden step counter the policy depends on. This term needs none: at every step it rewards the
distance to the **nearest** sample of one full reference stride, in pelvis tilt, both legs' six
joint angles and their seven speeds,

    r_prior = w · exp(−d),   d = min_k sqrt(mean_j ((s_j − s_ref[k]_j) / σ_j)²),

with σ_j = ``angle_scale`` (rad) for angles and ``speed_scale`` (rad/s) for speeds: the exponential
of the RMS normalised distance, not of its square — a Gaussian kernel tight enough to tell a frozen
leg from a walking one is flat zero where an untrained policy starts (measured: a PPO walker
hopping on one leg, d ≈ 2.2 at σ = 0.2 rad, 3 rad/s, got no gradient from exp(−d²)). The reference
stride contains both legs (the right leg's stance is the left leg's swing), so holding one leg
still, hopping on one leg or dragging a foot is far from every reference sample, while walking
through the stride at any pace stays near it; the speed-tracking reward still sets the pace. The
reference is any :class:`sspinn.model.trajectory.Trajectory` file of one full stride, e.g. a
periodic optimal-control gait (``python -m predictive solve --speed 1.3 --cycle full --rate-hz
100 --out configs/agents/gaits/walk_1.3``).

An optional second term balances the feet: with c̄_R, c̄_L exponential moving averages (time
constant ``symmetry_time`` s) of each foot being loaded (vertical GRF above
:data:`sspinn.data.gait_events.CONTACT_THRESHOLD_BW`), starting at 1 (standing),

    r_sym = w_sym · (1 − |c̄_R − c̄_L|).

Why: a policy can sit near the stride in most coordinates with one leg crouched and barely
stepping (measured: a PPO walker at 0.6 M steps, right foot loaded 10 % of the time, left 61 %),
where the nearest-sample distance changes little; a normal gait loads both feet equally over a
stride (stance asymmetry ≤ 10 %), hopping loads one foot only.

A third optional term asks for a left/right symmetric gait at the reference's cadence: with T the
reference stride's duration and θ_R, θ_L the three joint angles of each leg,

    r_mirror = w_mirror · exp(−d_half) · (1 − exp(−d_same)),
    d_half = sqrt(mean((θ_L(t) − θ_R(t − T/2))² ∪ (θ_R(t) − θ_L(t − T/2))²) / σ_angle²),
    d_same = sqrt(mean((θ_L(t) − θ_R(t))²) / σ_angle²),

from the second half stride of an episode on (0 before). The second factor rules out legs moving
in step with each other (measured: with exp(−d_half) alone PPO learned to shuffle both legs in
phase at twice the cadence, which is its own mirror half a stride later). Every term is a bonus in [0, w], never a
penalty: with penalties the sum per step could turn negative, and PPO then learned to fall at
once (measured: every evaluation episode fell within 0.4 s after 0.4 M steps). Why: balanced loading still allowed a
gallop (measured at 0.4 M steps: loaded shares within 5–16 % but step times 180 % asymmetric, one
foot landing right after the other); a symmetric gait is its own mirror image half a stride later.

With ``start_share`` > 0 (configuration), that share of the training episodes starts at a random
sample of the reference stride instead of standing (reference state initialisation, Peng et al.
2018; the environment's ``reset_states``), so the policy meets the walking states from the first
update on; evaluations always start standing.

**Clock mode** (``clock``: the configuration's ``prior.clock``). The nearest-sample distance lets a
policy visit the stride's states in any order and at any pace; measured: PPO with all three terms
walked without falls but shuffled at 423 steps/min with step times 167 % asymmetric, each leg
sitting near *some* sample. With the clock, the policy sees where in the reference stride it
should be and the prior compares with that sample only (motion imitation, Peng et al. 2018):
the phase index k advances one sample per control step, modulo the stride's K samples, and the
observation gets two entries, sin(2πk/K) and cos(2πk/K) (:data:`CLOCK_NAMES`);

    r_prior = w · exp(−d_k),   d_k = sqrt(mean_j ((s_j − s_ref[k]_j) / σ_j)²).

An episode's clock starts at the sample nearest its first observation (:meth:`GaitPrior.start_phase`):
a reference start resumes the stride where it began, a standing start at the same sample every time.
A clock agent's evaluation episodes start on the stride's first sample (with the environment's
reset noise; :attr:`agents.checkpoints.LoadedAgent.initial_state`), as the generator's and the
optimal-control trackers of the comparison start on their own cycles: imitation policies learn
the stride, not the way into it from standing (measured: with half the training episodes
standing, PPO learned to hop from standing on one leg and never reached the stride, clock
reward 0.27 of its maximum after 0.8 M steps).
The clock is the policy's memory of the episode: a saved agent carries it as the ``state`` of
``predict(observation, state, episode_start)`` (:class:`agents.checkpoints.LoadedAgent`), so it
restarts with every episode. A symmetric reference stride then asks for a symmetric gait at the
reference's cadence; the speed-tracking reward still sets the pace.

**Feedforward** (``feedforward``, clock mode only): the policy's action is added to the reference
stride's own actuator torques at the clock's sample, a_k = clip(π(o_k) + a_ref[k], −1, 1), with

    a_ref[k] = (τ̄_k − τ_passive(q̄_k, u̇̄_k)) / τ_max,

τ̄, q̄, u̇̄ the reference's joint torques, angles and speeds averaged over the control interval
k … k + 1 and τ_passive, τ_max the environment's passive joint moments and actuator strength
(:meth:`GaitPrior.with_feedforward`). The policy learns the feedback around the stride (residual
policy learning: Silver et al. 2018, arXiv:1812.06298; Johannink et al. 2019, ICRA) — the
structure of the generator's and the optimal-control trackers, feedforward plus feedback, with
the feedback learned by PPO instead of an LQR. Why: with imitation rewards alone PPO found its own
gaits, far from the stride (clock reward 0.1–0.27 of its maximum after 0.5 M steps, walking and
running); the feedforward alone, open loop, falls after 0.5–0.9 s.

**Mirrored half strides** (``mirror_policy``, clock mode only): in the second half of the clock's
stride (k ≥ K/2) the policy sees the left/right mirror image of the observation (legs and their
contact forces swapped) with the clock at k − K/2, and its action is mirrored back (hip, knee and
ankle torques of the legs swapped): one policy for "the leg in stance" and "the leg in swing",
so the controller treats the legs alike by construction. The clock entries then run once per
half stride, sin(2π(k mod K/2)/(K/2)), cos(…). Needs a reference stride whose second half is the
mirror image of its first (the shipped ones are, to 1e-3 rad) and an even K. Why: with the clock and the
feedforward alone, walking policies of three training seeds reached step-time asymmetries of
0.7–48 % and step-length asymmetries up to 28 % (one leg stepping 0.83 m, the other 0.62 m). The
mirror trick is the phase-based form of mirror-symmetric policies (Yu, Turk & Liu 2018, ACM TOG
37:144, which enforce symmetry with a loss instead; see also Abdolhosseini et al. 2019, "On
learning symmetric locomotion", MIG).

The terms are a wrapper of the training environments only (:class:`GaitPriorReward`, an SB3
``VecEnvWrapper`` applied inside ``VecNormalize``): episodes and the environment's own rewards and
metrics are unchanged (in clock mode the observations gain the two clock entries), so evaluations, ``agents evaluate`` and the controller
comparison judge the agent on the environment's task alone. The reward added at each step is in
the ``info`` key ``reward_prior``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Final

import numpy as np
from gymnasium import spaces
from stable_baselines3.common.vec_env import VecEnv, VecEnvWrapper
from stable_baselines3.common.vec_env.base_vec_env import VecEnvStepReturn

from agents.builders import make_env
from agents.config import AgentConfig, GaitPriorConfig
from envs.config import CONTROL_DT
from envs.task import OBS_INDEX, OBSERVATION_NAMES
from sspinn.data.gait_events import CONTACT_THRESHOLD_BW
from sspinn.errors import UserError
from sspinn.model.conventions import COORDINATES, MIRROR_Q, MIRROR_TAU, mirror_index
from sspinn.model.trajectory import Trajectory
from sspinn.yaml_config import shipped_path

#: Names of the observation entries the clock mode appends (after the environment's 22).
CLOCK_NAMES: Final[tuple[str, ...]] = ("clock_sin", "clock_cos")
#: Coordinates compared: pelvis tilt and the six joint angles (indices into q), with their speeds.
PRIOR_COORDINATES: Final[tuple[str, ...]] = COORDINATES[2:]
_Q_COLUMNS: Final = tuple(COORDINATES.index(name) for name in PRIOR_COORDINATES)
_LOAD_COLUMNS: Final = (OBS_INDEX["grf_y_r"], OBS_INDEX["grf_y_l"])  # vertical GRF, BW
_JOINT_COLUMNS: Final = tuple(OBS_INDEX[name] for name in COORDINATES[3:])  # hip, knee, ankle right, then left
#: Left/right mirror permutations: of q (9), of an observation (22) and of an action (6).
_Q_MIRROR: Final = list(MIRROR_Q)
_OBS_MIRROR: Final = list(mirror_index(OBSERVATION_NAMES))
_ACTION_MIRROR: Final = list(MIRROR_TAU)
_OBS_COLUMNS: Final = tuple(OBS_INDEX[name] for name in PRIOR_COORDINATES) + tuple(
    OBS_INDEX[f"d_{name}"] for name in PRIOR_COORDINATES)


@dataclass(frozen=True)
class GaitPrior:
    """One reference stride and the scales of the distance to it.

    Attributes:
        trajectory: the reference stride (one full cycle).
        scales: (14,) σ of each column of :attr:`states` (rad, then rad/s).
        weight: w, reward per step at zero distance (the environment's tracking term is at most
            ``tracking_weight``, 1 by default).
        source: the reference file, for messages.
        symmetry_weight: w_sym of the foot-balance term (0: none).
        symmetry_time: its averaging time constant, s.
        mirror_weight: w_mirror of the half-stride mirror term (0: none).
        clock: compare with the sample of the episode's clock instead of the nearest one, and
            append the clock to the observation (module docstring).
        feedforward: (K, 6) the reference's normalised actuator torques a_ref added to the
            policy's actions (clock mode; :meth:`with_feedforward`), or None.
        mirror_policy: mirror observations and actions in the second half stride (clock mode).
    """

    trajectory: Trajectory
    scales: np.ndarray
    weight: float
    source: str
    symmetry_weight: float = 0.0
    symmetry_time: float = 1.0
    mirror_weight: float = 0.0
    clock: bool = False
    feedforward: np.ndarray | None = None
    mirror_policy: bool = False

    @classmethod
    def from_config(cls, config: GaitPriorConfig, env: Any = None) -> GaitPrior | None:
        """The prior of an agent configuration's ``prior`` section, or None without a reference
        stride; with ``config.feedforward``, its feedforward for ``env`` (the training environment:
        its ``tau_max`` and ``passive_torque``), which is then required."""
        if config.gait is None:
            return None
        prior = cls.from_file(config.gait, config.weight, config.angle_scale, config.speed_scale,
                              config.symmetry_weight, config.symmetry_time, config.mirror_weight, config.clock)
        if config.mirror_policy:
            if not config.clock:
                raise UserError(f"{prior.source}: prior.mirror_policy needs prior.clock: true (it mirrors by the clock's half stride)")
            prior = prior.with_mirror_policy()
        if config.feedforward:
            if not config.clock:
                raise UserError(f"{prior.source}: prior.feedforward needs prior.clock: true (it is added at the clock's sample)")
            if env is None:
                raise ValueError("a feedforward prior needs the environment (tau_max, passive_torque)")
            prior = prior.with_feedforward(env.unwrapped.tau_max, env.unwrapped.passive_torque)
        return prior

    def with_mirror_policy(self) -> GaitPrior:
        """This prior with mirrored half strides (module docstring); a UserError if the reference
        stride is not its own mirror image half a stride later or K is odd."""
        t, k = self.trajectory, self.trajectory.n_samples
        mirrored = t.q[:, _Q_MIRROR]
        error = float(np.abs(np.roll(mirrored, -(k // 2), axis=0)[:, 1:] - t.q[:, 1:]).max())
        if k % 2 or error > 1e-3:
            raise UserError(f"{self.source}: prior.mirror_policy needs a stride of an even number of samples whose second "
                            f"half mirrors its first ({k} samples, largest mirror difference {error:.3g} rad)")
        return replace(self, mirror_policy=True)

    def with_feedforward(self, tau_max: np.ndarray, passive_torque: Callable[[np.ndarray, np.ndarray], np.ndarray]) -> GaitPrior:
        """This prior with a_ref (module docstring) for an environment of actuator strength
        ``tau_max`` (6,) N·m and passive joint moments ``passive_torque(angles, rates)`` N·m.
        Hand-written because the reference is already on the control grid: the generator's
        tracker (:mod:`predictive.generator.closed_loop`) resamples other cycles onto it first."""
        t = self.trajectory
        mid = [0.5 * (x + np.roll(x, -1, axis=0)) for x in (t.tau, t.q, t.u)]  # interval k … k + 1, periodic
        actions = (mid[0] - passive_torque(mid[1][:, 3:], mid[2][:, 3:])) / np.asarray(tau_max)
        return replace(self, feedforward=np.asarray(actions, dtype=np.float64))

    def act(self, policy_actions: np.ndarray, phase: np.ndarray) -> np.ndarray:
        """The environment's actions (N, 6) from the policy's at clock samples ``phase`` (N,):
        mirrored back in the second half stride (with ``mirror_policy``), plus a_ref, clipped to
        [−1, 1] (the policy's unchanged without either)."""
        phase = np.asarray(phase) % self.period_steps
        actions = np.asarray(policy_actions)
        if self.mirror_policy:
            second = phase >= self.period_steps // 2
            actions = np.where(second[:, None], actions[:, _ACTION_MIRROR], actions)
        if self.feedforward is None:
            return actions
        return np.clip(actions + self.feedforward[phase], -1.0, 1.0).astype(np.float32)

    @classmethod
    def from_file(cls, path: str | Path, weight: float, angle_scale: float, speed_scale: float,
                  symmetry_weight: float = 0.0, symmetry_time: float = 1.0, mirror_weight: float = 0.0,
                  clock: bool = False) -> GaitPrior:
        """Read a :class:`~sspinn.model.trajectory.Trajectory` file (``.npz``; a relative path is
        looked up in the working directory, then in the repository); its samples are the reference."""
        file = Path(path)
        if not file.is_absolute() and not file.exists() and shipped_path(file).exists():
            file = shipped_path(file)
        if not file.is_file():
            raise UserError(f"{file}: no such reference stride for the gait prior (prior.gait); make one with "
                            "`python -m predictive solve --speed V --cycle full --rate-hz 100 --out PATH`")
        trajectory = Trajectory.load(file)
        if trajectory.n_samples < 10:
            raise UserError(f"{file}: a gait prior needs one stride of ≥ 10 samples, got {trajectory.n_samples}")
        for name, value in (("weight", weight), ("angle_scale", angle_scale), ("speed_scale", speed_scale),
                            ("symmetry_time", symmetry_time)):
            if not (np.isfinite(value) and value > 0):
                raise UserError(f"{file}: gait prior {name} must be a positive number, got {value}")
        for name, value in (("symmetry_weight", symmetry_weight), ("mirror_weight", mirror_weight)):
            if not (np.isfinite(value) and value >= 0):
                raise UserError(f"{file}: gait prior {name} must be ≥ 0, got {value}")
        n = len(_Q_COLUMNS)
        scales = np.concatenate([np.full(n, angle_scale), np.full(n, speed_scale)])
        return cls(trajectory=trajectory, scales=scales, weight=float(weight), source=str(file),
                   symmetry_weight=float(symmetry_weight), symmetry_time=float(symmetry_time),
                   mirror_weight=float(mirror_weight), clock=bool(clock))

    def __post_init__(self) -> None:
        # the compared columns of every sample, computed once (the reward reads them at every step)
        t = self.trajectory
        object.__setattr__(self, "_states", np.concatenate([t.q[:, _Q_COLUMNS], t.u[:, _Q_COLUMNS]], axis=1)
                           .astype(np.float64))

    @property
    def states(self) -> np.ndarray:
        """(K, 14) pelvis tilt and joint angles (rad), then their speeds (rad/s), one row per sample."""
        return self._states  # type: ignore[attr-defined,no-any-return]

    @property
    def half_stride_steps(self) -> int:
        """T/2 in control steps (half the reference's samples, at least 1)."""
        return max(1, round(self.trajectory.n_samples / 2))

    def start_state(self) -> tuple[np.ndarray, np.ndarray]:
        """(q, u) of the reference's first sample: where a clock agent's evaluation episodes start."""
        return self.trajectory.q[0].copy(), self.trajectory.u[0].copy()

    def stride_states(self) -> np.ndarray:
        """The reference stride's (q, u) rows (K, 18), for ``WalkerConfig.reset_states``."""
        return np.concatenate([self.trajectory.q, self.trajectory.u], axis=1)

    @property
    def period_steps(self) -> int:
        """K, the clock's period in control steps (one reference sample per step)."""
        return self.trajectory.n_samples

    def _distances(self, obs: np.ndarray) -> np.ndarray:
        """(N, K) RMS normalised distance of each observation row to each reference sample."""
        s = np.asarray(obs, dtype=np.float64)[:, _OBS_COLUMNS]
        d = (s[:, None, :] - self.states[None, :, :]) / self.scales
        return np.sqrt(np.mean(d * d, axis=2))

    def start_phase(self, obs: np.ndarray) -> np.ndarray:
        """(N,) the clock's first sample for episodes starting at observations ``obs`` (N, ≥ 22):
        the reference sample nearest each."""
        return np.argmin(self._distances(obs), axis=1)

    def policy_input(self, obs: np.ndarray, phase: np.ndarray) -> np.ndarray:
        """What the policy sees, float32: observations (N, 22) with the clock entries of sample
        indices ``phase`` (N,) appended — with ``mirror_policy``, the rows in the second half
        stride mirrored and the clock running once per half stride."""
        phase = np.asarray(phase) % self.period_steps
        obs = np.asarray(obs, dtype=np.float32)
        period = self.period_steps
        if self.mirror_policy:
            period //= 2
            second = phase >= period
            obs = np.where(second[:, None], obs[:, _OBS_MIRROR], obs)
        angle = 2.0 * np.pi * (phase % period) / period
        clock = np.stack([np.sin(angle), np.cos(angle)], axis=-1)
        return np.concatenate([obs, clock.astype(np.float32)], axis=-1)

    def reward(self, obs: np.ndarray, phase: np.ndarray | None = None) -> np.ndarray:
        """r_prior of each row of raw observations ``obs`` (N, ≥ 22) (module docstring), (N,): to the
        nearest sample, or with ``phase`` (N,) to those samples (clock mode)."""
        if phase is None:
            return self.weight * np.exp(-np.min(self._distances(obs), axis=1))
        s = np.asarray(obs, dtype=np.float64)[:, _OBS_COLUMNS]
        d = (s - self.states[np.asarray(phase) % self.period_steps]) / self.scales
        return self.weight * np.exp(-np.sqrt(np.mean(d * d, axis=1)))


def load_prior(config: AgentConfig) -> GaitPrior | None:
    """The gait prior of an agent configuration (:meth:`GaitPrior.from_config`), or None without a
    reference stride; a feedforward is computed for the configuration's environment."""
    if not config.prior.feedforward:
        return GaitPrior.from_config(config.prior)
    env = make_env(config)
    try:
        return GaitPrior.from_config(config.prior, env)
    finally:
        env.close()


def clock_space(space: spaces.Box) -> spaces.Box:
    """The observation space ``space`` with the two clock entries (each in [−1, 1]) appended."""
    low = np.concatenate([space.low, -np.ones(len(CLOCK_NAMES))]).astype(space.dtype)
    high = np.concatenate([space.high, np.ones(len(CLOCK_NAMES))]).astype(space.dtype)
    return spaces.Box(low, high, dtype=space.dtype)  # type: ignore[arg-type]


class GaitPriorReward(VecEnvWrapper):
    """Adds :meth:`GaitPrior.reward` of each step's resulting observation (for an episode's last
    step, its final observation) to the reward of a vectorised environment (module docstring);
    in clock mode also appends each environment's clock to its observations (final ones included)."""

    def __init__(self, venv: VecEnv, prior: GaitPrior) -> None:
        space = venv.observation_space
        if prior.clock:
            assert isinstance(space, spaces.Box)
            space = clock_space(space)
        super().__init__(venv, observation_space=space)
        self.prior = prior
        self.phase = np.zeros(self.num_envs, dtype=np.int64)  # clock sample of each environment
        self.loaded_share = np.ones((self.num_envs, 2))  # c̄_R, c̄_L
        self.angles = np.zeros((self.num_envs, prior.half_stride_steps, 6))  # ring of the last T/2 joint angles
        self.steps = np.zeros(self.num_envs, dtype=np.int64)  # steps since each episode's start

    def step_async(self, actions: np.ndarray) -> None:
        self.venv.step_async(self.prior.act(actions, self.phase))

    def reset(self) -> np.ndarray:
        self.loaded_share[:] = 1.0
        self.steps[:] = 0
        obs = self.venv.reset()
        if not self.prior.clock:
            return obs
        self.phase = self.prior.start_phase(obs)
        return self.prior.policy_input(obs, self.phase)

    def step_wait(self) -> VecEnvStepReturn:
        obs, rewards, dones, infos = self.venv.step_wait()
        seen = np.array(obs, dtype=np.float64, copy=True)
        for i in np.flatnonzero(dones):
            final = infos[i].get("terminal_observation")
            if final is not None:
                seen[i] = final
        clock = (self.phase + 1) % self.prior.period_steps if self.prior.clock else None
        extra = self.prior.reward(seen, clock)
        if self.prior.symmetry_weight > 0:
            loaded = seen[:, _LOAD_COLUMNS] > CONTACT_THRESHOLD_BW
            alpha = CONTROL_DT / self.prior.symmetry_time
            self.loaded_share += alpha * (loaded - self.loaded_share)
            balance = self.prior.symmetry_weight * (1.0 - np.abs(self.loaded_share[:, 0] - self.loaded_share[:, 1]))
            extra += balance
        if self.prior.mirror_weight > 0:
            extra += self._mirror(seen[:, _JOINT_COLUMNS])
        done = np.asarray(dones, dtype=bool)
        self.loaded_share[done] = 1.0  # the next episode starts standing
        self.steps[done] = 0
        for i, info in enumerate(infos):
            info["reward_prior"] = float(extra[i])
        if clock is not None:
            for i in np.flatnonzero(done):
                final = infos[i].get("terminal_observation")
                if final is not None:
                    infos[i]["terminal_observation"] = self.prior.policy_input(final[None], clock[i:i + 1])[0]
            if done.any():  # the next episode's clock starts at its first observation
                clock[done] = self.prior.start_phase(obs[done])
            self.phase = clock
            obs = self.prior.policy_input(obs, clock)
        return obs, rewards + extra.astype(rewards.dtype), dones, infos

    def _mirror(self, angles: np.ndarray) -> np.ndarray:
        """r_mirror of the joint angles (N, 6: right hip, knee, ankle, left ...) after this step."""
        h = self.prior.half_stride_steps
        slot = self.steps % h
        rows = np.arange(self.num_envs)
        past = self.angles[rows, slot]  # θ(t − T/2) where a half stride has passed
        diff = np.concatenate([angles[:, 3:] - past[:, :3], angles[:, :3] - past[:, 3:]], axis=1)
        scale = self.prior.scales[0]
        same = np.sqrt(np.mean(np.square((angles[:, 3:] - angles[:, :3]) / scale), axis=1))
        bonus = self.prior.mirror_weight * np.exp(-np.sqrt(np.mean(np.square(diff / scale), axis=1))) * (1.0 - np.exp(-same))
        bonus[self.steps < h] = 0.0
        self.angles[rows, slot] = angles
        self.steps += 1
        return bonus


__all__ = ["CLOCK_NAMES", "PRIOR_COORDINATES", "GaitPrior", "GaitPriorReward", "clock_space", "load_prior"]
