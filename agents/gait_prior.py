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

The terms are a wrapper of the training environments only (:class:`GaitPriorReward`, an SB3
``VecEnvWrapper`` applied inside ``VecNormalize``): observations, episodes and the environment's
own rewards and metrics are unchanged, so evaluations, ``agents evaluate`` and the controller
comparison judge the agent on the environment's task alone. The reward added at each step is in
the ``info`` key ``reward_prior``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Final

import numpy as np
from stable_baselines3.common.vec_env import VecEnv, VecEnvWrapper
from stable_baselines3.common.vec_env.base_vec_env import VecEnvStepReturn

from envs.config import CONTROL_DT
from envs.task import OBS_INDEX
from sspinn.data.gait_events import CONTACT_THRESHOLD_BW
from sspinn.errors import UserError
from sspinn.model.conventions import COORDINATES
from sspinn.model.trajectory import Trajectory
from sspinn.yaml_config import shipped_path

#: Coordinates compared: pelvis tilt and the six joint angles (indices into q), with their speeds.
PRIOR_COORDINATES: Final[tuple[str, ...]] = COORDINATES[2:]
_Q_COLUMNS: Final = tuple(COORDINATES.index(name) for name in PRIOR_COORDINATES)
_LOAD_COLUMNS: Final = (OBS_INDEX["grf_y_r"], OBS_INDEX["grf_y_l"])  # vertical GRF, BW
_JOINT_COLUMNS: Final = tuple(OBS_INDEX[name] for name in COORDINATES[3:])  # hip, knee, ankle right, then left
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
    """

    trajectory: Trajectory
    scales: np.ndarray
    weight: float
    source: str
    symmetry_weight: float = 0.0
    symmetry_time: float = 1.0
    mirror_weight: float = 0.0

    @classmethod
    def from_file(cls, path: str | Path, weight: float, angle_scale: float, speed_scale: float,
                  symmetry_weight: float = 0.0, symmetry_time: float = 1.0, mirror_weight: float = 0.0) -> GaitPrior:
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
                   mirror_weight=float(mirror_weight))

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

    def stride_states(self) -> np.ndarray:
        """The reference stride's (q, u) rows (K, 18), for ``WalkerConfig.reset_states``."""
        return np.concatenate([self.trajectory.q, self.trajectory.u], axis=1)

    def reward(self, obs: np.ndarray) -> np.ndarray:
        """r_prior of each row of raw observations ``obs`` (N, 22) (module docstring), (N,)."""
        s = np.asarray(obs, dtype=np.float64)[:, _OBS_COLUMNS]
        d = (s[:, None, :] - self.states[None, :, :]) / self.scales
        nearest = np.sqrt(np.min(np.mean(d * d, axis=2), axis=1))
        return self.weight * np.exp(-nearest)


class GaitPriorReward(VecEnvWrapper):
    """Adds :meth:`GaitPrior.reward` of each step's resulting observation (for an episode's last
    step, its final observation) to the reward of a vectorised environment (module docstring)."""

    def __init__(self, venv: VecEnv, prior: GaitPrior) -> None:
        super().__init__(venv)
        self.prior = prior
        self.loaded_share = np.ones((self.num_envs, 2))  # c̄_R, c̄_L
        self.angles = np.zeros((self.num_envs, prior.half_stride_steps, 6))  # ring of the last T/2 joint angles
        self.steps = np.zeros(self.num_envs, dtype=np.int64)  # steps since each episode's start

    def reset(self) -> np.ndarray:
        self.loaded_share[:] = 1.0
        self.steps[:] = 0
        return self.venv.reset()

    def step_wait(self) -> VecEnvStepReturn:
        obs, rewards, dones, infos = self.venv.step_wait()
        seen = np.array(obs, dtype=np.float64, copy=True)
        for i in np.flatnonzero(dones):
            final = infos[i].get("terminal_observation")
            if final is not None:
                seen[i] = final
        prior = self.prior.reward(seen)
        extra = prior.copy()
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


__all__ = ["PRIOR_COORDINATES", "GaitPrior", "GaitPriorReward"]
