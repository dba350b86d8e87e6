"""Self-supervised gait generator: one network, (speed, height, mass) → a periodic gait cycle.

The SSPINNpose paper's proposed next step: keep its physics losses, replace the IMU-tracking term
by a physiological objective, and learn gait without data. Here a small MLP maps the target speed
and the body's height and mass to a **Fourier series of the gait cycle**; the physics decides
whether a gait is acceptable, the objective which one is chosen.

Representation (chosen so that the constraints the OCP imposes hold by construction):

* Cycle duration T = :func:`predictive.ocp.generic_gait.typical_stride_duration` of the speed (as the
  OCP's default, which fixes it because a free duration drifts to shuffling strides).
* Right-leg joint angles: mean + harmonics 1…K of the cycle. Left leg: the right leg half a cycle
  later (odd harmonics change sign) — the symmetric gait of the OCP's half-cycle mode.
  Pelvis height, trunk tilt and the periodic part of pelvis_tx: mean + even harmonics only (their
  period is half a cycle). pelvis_tx = v·t + periodic part, so the average speed is exactly v.
* q̇ and q̈ are the analytic time derivatives, so the temporal-consistency loss of SSPINNpose
  (dq/dt = q̇, dq̇/dt = q̈) holds exactly and periodicity is built in.
* Ground reaction forces come from the environment's forward-simulation contact model
  (:func:`sspinn.model.dynamics.contact_forces`, slip velocity of the Gymnasium environment); the joint
  torques from inverse dynamics (:func:`sspinn.model.dynamics.inverse_dynamics`); what inverse
  dynamics cannot explain is the residual force on the unactuated pelvis — the Kane residual.

Loss per batch of (speed, body) at random phases of the half cycle (the other half is mirrored):

* ``kane``: mean squared pelvis residual in BW (forces) and BW·H (moment) — SSPINNpose's L_K;
* ``effort``: the OCP's objective — mean Σ_j (τ_j / 0.1·BW·H)² of the actuator torques (total
  minus the environment's passive joint moments), ankle strength-scaled, plus ``w_acc`` × the
  acceleration regularisation on the normalised cycle (:mod:`predictive.ocp.collocation`);
* ``bounds``: SSPINNpose's L_B with the OCP's ranges — joint ranges, pelvis height and tilt, and
  the environment's torque limits (with a margin for feedback);
* ``slide``: SSPINNpose's L_slide, (contact-point speed × F_y / BW)²;
* ``clearance`` (weight 0 = off): a foot that moves forward faster than the pelvis (swing) keeps
  its heel and toe ``clearance_height`` above the ground, Σ σ((ẋ_foot − ẋ_pelvis)/0.1 m/s) ·
  (max(c − y, 0) / c)² over heel and toe. Without it the effort objective lets swing feet skim
  the ground by millimetres, where the smooth contact model already produces scuffing forces
  and any joint-angle error trips the body.

Training starts with ``warmup_steps`` of fitting the data-free textbook shapes of
:func:`predictive.ocp.generic_gait.generic_gait` (the OCP's initial guess), then minimises the loss
with Adam, then (``polish_iterations`` > 0) polishes the whole network with L-BFGS on a fixed grid
of speeds and bodies with the Kane and bounds weights × ``polish_factor`` — the per-gait fine-tune
of :func:`generate` folded into training, so that running gaits need no fine-tune at deployment.
No recorded or optimised gait is used. Checkpoints every ``checkpoint_every`` steps,
``resume``, a checkpoint on Ctrl-C and a CSV learning curve (loss vs wall time).
"""

from __future__ import annotations

import csv
import dataclasses
import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import torch
import yaml

from predictive.ocp.generic_gait import generic_gait, typical_stride_duration
from predictive.ocp.limits import MAX_REFINE_ITERATIONS, RequestError
from predictive.ocp.settings import ankle_strength, default_joint_limits
from predictive.ocp.solution import GaitSolution
from sspinn.model import dynamics, kinematics
from sspinn.model.body import BodyParameters
from sspinn.model.contact import ContactParameters
from sspinn.model.conventions import GRAVITY, N_TAU
from sspinn.model.passive import passive_parameters, passive_torque
from sspinn.run_folder import RunLock, atomic_path, atomic_write_text, claim_run_folder
from sspinn.torch_files import load_torch_file, save_torch_file
from sspinn.yaml_config import config_from_mapping, load_config

#: Kinds of file (see :mod:`sspinn.torch_files`): a trained generator and a training checkpoint.
GENERATOR = "gait-generator"
GENERATOR_CHECKPOINT = "gait-generator-checkpoint"

#: Forward-simulation friction slip velocity of the Gymnasium environment, m/s (envs.sagittal_walker).
ENV_SLIP_VELOCITY = 0.2
#: Environment's default actuator strength, N·m/kg (envs.task).
ENV_MAX_TORQUE = 3.0
#: L-BFGS iterations per call (and per history row / checkpoint) in the polish stage.
POLISH_CHUNK = 25


@dataclass(frozen=True)
class GeneratorWeights:
    """Loss weights (dimensionless; terms in the module docstring)."""

    kane: float = 1000.0
    effort: float = 1.0
    w_acc: float = 0.1
    bounds: float = 1000.0
    slide: float = 10.0
    clearance: float = 0.0


@dataclass
class GeneratorConfig:
    """Everything that defines a generator and its training (``configs/predictive/*.yaml``).

    Attributes:
        speeds: (min, max) training speeds, m/s. heights: (min, max) m. masses: (min, max) kg.
        harmonics: Fourier harmonics K of the legs (the pelvis uses the even ones ≤ K).
        hidden, layers: MLP width and number of hidden layers.
        points: phases per half cycle in each loss evaluation (random offset per step).
        batch_size: (speed, body) pairs per step. steps: Adam steps after the warm-up.
        warmup_steps: steps fitting :func:`generic_gait`. lr: Adam learning rate (cosine decay
        to lr/10). torque_margin: the bound on |τ| is this fraction of the environment's limit.
        seed, threads (0 = torch default), checkpoint_every, log_every, time_limit_s (0 = none).
        snapshot_every: keep ``snapshots/generator_<step>.pt`` every this many steps (with the wall
        time), for learning curves of the closed-loop result (0 = none).
        clearance_height: c of the ``clearance`` term, m.
        tilt_range: (min, max) pelvis tilt of the ``bounds`` term, rad (+: trunk leaning back).
        kane_ramp: the Kane weight grows geometrically from ``weights.kane`` to ``weights.kane ×
        kane_ramp`` over the Adam steps (1 = constant).
        polish_iterations: L-BFGS iterations of the polish stage after the Adam steps (0 = none):
            the per-gait fine-tune folded into training — the whole network is refined on a fixed
            grid of gaits (speeds every ``polish_speed_step`` m/s over ``speeds`` × five bodies:
            the corners and the centre of ``heights`` × ``masses``, ``polish_points`` phases per
            half cycle) with the Kane and bounds weights × ``polish_factor``, so that one forward
            pass gives gaits as consistent as the fine-tune's. Counted as steps (in chunks of
            :data:`POLISH_CHUNK` iterations).
    """

    speeds: tuple[float, float] = (0.8, 3.7)
    heights: tuple[float, float] = (1.6, 1.9)
    masses: tuple[float, float] = (55.0, 90.0)
    harmonics: int = 10
    hidden: int = 128
    layers: int = 3
    points: int = 100
    batch_size: int = 16
    steps: int = 3000
    warmup_steps: int = 300
    lr: float = 1e-3
    torque_margin: float = 0.8
    weights: GeneratorWeights = field(default_factory=GeneratorWeights)
    seed: int = 0
    threads: int = 0
    checkpoint_every: int = 250
    snapshot_every: int = 1000
    log_every: int = 25
    time_limit_s: float = 0.0
    kane_ramp: float = 1.0
    clearance_height: float = 0.03
    tilt_range: tuple[float, float] = (-0.6, 0.6)
    polish_iterations: int = 0
    polish_factor: float = 10.0
    polish_points: int = 50
    polish_speed_step: float = 0.1

    def __post_init__(self) -> None:
        if isinstance(self.weights, dict):
            self.weights = GeneratorWeights(**self.weights)
        for name in ("speeds", "heights", "masses"):
            lo, hi = getattr(self, name)
            if not 0 < lo <= hi:
                raise ValueError(f"{name} must be (min, max) with 0 < min <= max, got {getattr(self, name)}")
            setattr(self, name, (float(lo), float(hi)))
        lo, hi = self.tilt_range
        if not lo < hi:
            raise ValueError(f"tilt_range must be (min, max) with min < max, got {self.tilt_range}")
        self.tilt_range = (float(lo), float(hi))
        for name in ("harmonics", "hidden", "layers", "points", "batch_size", "checkpoint_every", "log_every"):
            setattr(self, name, int(getattr(self, name)))
            if getattr(self, name) < 1:
                raise ValueError(f"{name} must be >= 1, got {getattr(self, name)}")
        for name in ("kane_ramp", "polish_factor", "polish_speed_step", "clearance_height"):
            if not (math.isfinite(getattr(self, name)) and getattr(self, name) > 0):
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")
        self.polish_iterations = int(self.polish_iterations)
        if self.polish_iterations < 0 or int(self.polish_points) < 1:
            raise ValueError(f"polish_iterations must be >= 0 and polish_points >= 1, got {self.polish_iterations}, "
                             f"{self.polish_points}")
        self.polish_points = int(self.polish_points)

    @classmethod
    def from_yaml(cls, path: str | Path, settings: list[str] | None = None) -> GeneratorConfig:
        """Load ``path``; ``settings``: ``"dotted.key=value"`` overrides, e.g. ``["steps=30000"]``."""
        return load_config(cls, path, "generator", settings=settings or ())

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)


class GaitGeneratorNet(torch.nn.Module):
    """The generator's network (inside :class:`GaitGenerator`): an MLP (speed, height, mass) → Fourier coefficients (B, 9, 1 + 2K) of q over one cycle.

    Columns: mean, then cos(2πkφ), sin(2πkφ) for k = 1…K (φ = t/T). Rows in coordinate order;
    pelvis_tx holds only its periodic part (:meth:`cycle` adds v·t).
    """

    def __init__(self, harmonics: int = 10, hidden: int = 128, layers: int = 3) -> None:
        super().__init__()
        self.harmonics = K = harmonics
        dims = [3] + [hidden] * layers
        mods: list[torch.nn.Module] = []
        for a, b in zip(dims[:-1], dims[1:]):
            mods += [torch.nn.Linear(a, b), torch.nn.SiLU()]
        self.body = torch.nn.Sequential(*mods)
        self.head = torch.nn.Linear(hidden, 6 * (1 + 2 * K))  # pelvis x, y, tilt and the right leg
        torch.nn.init.zeros_(self.head.weight)
        torch.nn.init.zeros_(self.head.bias)
        k = torch.arange(1, K + 1, dtype=torch.float64).repeat_interleave(2)
        even = (k % 2 == 0).to(torch.float64)
        # scale of each coefficient: rows x, y, tilt (even harmonics only), hip, knee, ankle
        harm = torch.stack([0.03 / k * even, 0.02 / k * even, 0.05 / k * even, 0.4 / k, 0.4 / k, 0.3 / k])
        mean = torch.tensor([[0.0], [0.03], [0.2], [0.3], [0.3], [0.2]], dtype=torch.float64)
        self.register_buffer("scale", torch.cat([mean, harm], dim=1).float())
        self.register_buffer("odd_sign", torch.cat([torch.ones(1), torch.where(even > 0, 1.0, -1.0)]).float())

    def raw(self, speed: torch.Tensor, height: torch.Tensor, mass: torch.Tensor) -> torch.Tensor:
        """The free coefficients (B, 6, 1 + 2K) before scaling: pelvis x, y, tilt, right leg."""
        x = torch.stack([(speed - 2.0), (height - 1.75) / 0.1, (mass - 70.0) / 10.0], dim=-1)
        return self.head(self.body(x)).view(-1, 6, 1 + 2 * self.harmonics)

    def coefficients(self, raw: torch.Tensor) -> torch.Tensor:
        """Fourier coefficients (B, 9, 1 + 2K) of all coordinates from the free ones."""
        scaled = raw * self.scale
        right = scaled[:, 3:]
        left = right * self.odd_sign  # the right leg half a cycle later
        return torch.cat([scaled[:, :3], right, left], dim=1)

    def forward(self, speed: torch.Tensor, height: torch.Tensor, mass: torch.Tensor) -> torch.Tensor:
        return self.coefficients(self.raw(speed, height, mass))


def fourier_basis(phase: torch.Tensor, harmonics: int) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Basis (P, 1 + 2K) at cycle phases φ and its first and second derivatives w.r.t. φ."""
    k = torch.arange(1, harmonics + 1, dtype=phase.dtype, device=phase.device)
    ang = 2 * math.pi * phase[:, None] * k
    c, s = torch.cos(ang), torch.sin(ang)
    w = 2 * math.pi * k
    one, zero = torch.ones_like(phase[:, None]), torch.zeros_like(phase[:, None])
    basis = torch.cat([one, torch.stack([c, s], -1).flatten(-2)], dim=1)
    d1 = torch.cat([zero, torch.stack([-w * s, w * c], -1).flatten(-2)], dim=1)
    d2 = torch.cat([zero, torch.stack([-(w**2) * c, -(w**2) * s], -1).flatten(-2)], dim=1)
    return basis, d1, d2


def cycle(
    coeffs: torch.Tensor, speed: torch.Tensor, duration: torch.Tensor, hip_height: torch.Tensor, phase: torch.Tensor
) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """(q, u, q̈), each (B, P, 9), of the generated gaits at phases φ (P,) of the cycle.

    pelvis_ty's mean is ``hip_height`` (B,) (standing hip height, m) plus the network's offset.
    """
    basis, d1, d2 = fourier_basis(phase.to(coeffs), coeffs.shape[-1] // 2)
    T = duration[:, None, None]
    q = torch.einsum("bcn,pn->bpc", coeffs, basis)
    u = torch.einsum("bcn,pn->bpc", coeffs, d1) / T
    qdd = torch.einsum("bcn,pn->bpc", coeffs, d2) / T**2
    v = speed[:, None]
    offset = torch.zeros_like(q)
    offset[..., 0] = v * duration[:, None] * phase.to(q)
    offset[..., 1] = hip_height[:, None]
    u_offset = torch.zeros_like(u)
    u_offset[..., 0] = v
    return q + offset, u + u_offset, qdd


@dataclass
class BodyPool:
    """Bodies (Winter scaling) to train on: heights (m), masses (kg), parameter vectors (n, 41),
    standing hip heights (m) and the :class:`BodyParameters` themselves."""

    heights: np.ndarray
    masses: np.ndarray
    p: np.ndarray
    hip_height: np.ndarray
    bodies: list[BodyParameters]

    @classmethod
    def sample(cls, n: int, heights: tuple[float, float], masses: tuple[float, float], rng: np.random.Generator) -> BodyPool:
        h = rng.uniform(*heights, n)
        m = rng.uniform(*masses, n)
        bodies = [BodyParameters.from_anthropometry(float(a), float(b)) for a, b in zip(h, m)]
        return cls(h, m, np.stack([b.vector() for b in bodies]), np.array([b.standing_hip_height for b in bodies]), bodies)


class GaitLosses:
    """The loss terms of the module docstring for a batch of generated cycles."""

    def __init__(self, config: GeneratorConfig) -> None:
        self.config = config
        #: multiplier of the Kane weight (the trainer's ramp, :attr:`GeneratorConfig.kane_ramp`)
        self.kane_scale = 1.0
        self.contact = torch.as_tensor(ContactParameters(slip_velocity=ENV_SLIP_VELOCITY).vector())
        self.passive = torch.as_tensor(passive_parameters())
        lo, hi = default_joint_limits().arrays()
        self.lower, self.upper = torch.as_tensor(lo), torch.as_tensor(hi)

    def physics(self, q: torch.Tensor, u: torch.Tensor, qdd: torch.Tensor, p: torch.Tensor) -> dict[str, torch.Tensor]:
        """GRF (…, 4), contact fractions w, total joint torques τ (…, 6, N·m), actuator torques
        (τ minus passive moments) and the pelvis residual (…, 3)."""
        c = self.contact.to(q)
        grf, w = dynamics.contact_forces(q, u, p, c)
        tau, root = dynamics.inverse_dynamics(q, u, qdd, grf, w, p)
        ps = self.passive.to(q)
        actuator = tau - passive_torque(q[..., 3:], u[..., 3:], ps[:6], ps[6:12], ps[12], ps[13])
        return {"grf": grf, "w": w, "tau": tau, "actuator": actuator, "root": root}

    def __call__(
        self, q: torch.Tensor, u: torch.Tensor, qdd: torch.Tensor, p: torch.Tensor, height: torch.Tensor,
        mass: torch.Tensor, duration: torch.Tensor,
    ) -> dict[str, torch.Tensor]:
        cfg, lam = self.config, self.config.weights
        ph = self.physics(q, u, qdd, p)
        bw = (mass * GRAVITY)[:, None]
        bwbh = bw * height[:, None]
        root = ph["root"]
        kane = (root[..., 0] / bw).square() + (root[..., 1] / bw).square() + (root[..., 2] / bwbh).square()
        tn = ph["actuator"] / (0.1 * bwbh[..., None])
        ankles = [2, 5]
        scaled = tn.clone()
        scaled[..., ankles] = tn[..., ankles] * ankle_strength(tn[..., ankles], q[..., [5, 8]], 1.0, torch.exp, torch.tanh)
        effort = scaled.square().sum(-1)
        acc = (qdd * (duration[:, None, None] ** 2 / (4 * math.pi**2))).square().sum(-1)
        joints = q[..., 3:]
        tau_limit = cfg.torque_margin * ENV_MAX_TORQUE * mass[:, None, None]
        relu2 = lambda x: torch.relu(x).square()  # noqa: E731
        bounds = (
            relu2(self.lower.to(q) - joints).sum(-1)
            + relu2(joints - self.upper.to(q)).sum(-1)
            + (relu2(ph["actuator"].abs() - tau_limit) / tau_limit**2).sum(-1)
            + relu2(0.3 * height[:, None] - q[..., 1]) + relu2(q[..., 1] - 0.7 * height[:, None])
            + relu2(cfg.tilt_range[0] - q[..., 2]) + relu2(q[..., 2] - cfg.tilt_range[1])
        )
        pk = kinematics.point_kinematics(q, u, qdd, ph["w"], p)
        vx = torch.stack([pk[..., kinematics.point_index(f"contact_{s}"), 2] for s in "rl"], dim=-1)
        slide = (vx * ph["grf"][..., 1::2] / bw[..., None]).square().sum(-1)
        c = cfg.clearance_height
        swing = torch.sigmoid((vx - u[..., :1]) / 0.1)
        low = torch.stack([
            relu2(1 - pk[..., kinematics.point_index(f"{point}_{s}"), 1] / c) for s in "rl" for point in ("heel", "toe")
        ], dim=-1).view(*vx.shape, 2).sum(-1)
        clearance = (swing * low).sum(-1)
        terms = {
            "kane": lam.kane * self.kane_scale * kane.mean(),
            "effort": lam.effort * effort.mean(),
            "acc": lam.effort * lam.w_acc * acc.mean(),
            "bounds": lam.bounds * bounds.mean(),
            "slide": lam.slide * slide.mean(),
            "clearance": lam.clearance * clearance.mean(),
        }
        terms["total"] = sum(terms.values())
        terms["kane_rms_bw"] = kane.mean().sqrt().detach()
        return terms


#: What a generator run writes into its folder (:class:`GeneratorTrainer`).
RUN_OUTPUTS: tuple[str, ...] = ("checkpoint.pt", "generator.pt", "history.csv", "snapshots")


class GeneratorTrainer:
    """Trains a :class:`GaitGeneratorNet` (module docstring; behind :meth:`GaitGenerator.fit`).
    ``fit()`` writes ``checkpoint.pt``, ``generator.pt`` and ``history.csv`` (step, wall time,
    losses) into ``out``.

    Attributes after ``fit``: ``model_``, ``history_`` (list of dicts), ``train_time_s_``.
    """

    def __init__(self, config: GeneratorConfig, out: str | Path) -> None:
        self.config = config
        self.out = Path(out)
        self.step = 0
        self.wall = 0.0
        self.history_: list[dict[str, float]] = []
        torch.manual_seed(config.seed)
        self.rng = np.random.default_rng(config.seed)
        self.model_ = GaitGeneratorNet(config.harmonics, config.hidden, config.layers).double()
        self.optimizer = torch.optim.Adam(self.model_.parameters(), lr=config.lr)
        self.bodies = BodyPool.sample(256, config.heights, config.masses, self.rng)
        self.losses = GaitLosses(config)
        self._polish: tuple[dict[str, torch.Tensor], GaitLosses, torch.optim.LBFGS] | None = None
        self._polish_state: dict[str, Any] | None = None  # a checkpoint's L-BFGS state, loaded lazily

    @property
    def total_steps(self) -> int:
        return self.config.warmup_steps + self.config.steps + self.config.polish_iterations

    @property
    def adam_steps(self) -> int:
        """Warm-up and Adam steps (the polish stage follows them)."""
        return self.config.warmup_steps + self.config.steps

    def _polish_problem(self) -> tuple[dict[str, torch.Tensor], GaitLosses, torch.optim.LBFGS]:
        """The polish stage's fixed grid of gaits, its losses and its optimiser (config docstring)."""
        cfg = self.config
        lo, hi = cfg.speeds
        speeds = np.arange(lo, hi + 1e-9, cfg.polish_speed_step) if hi > lo else np.array([lo])
        (h0, h1), (m0, m1) = cfg.heights, cfg.masses
        bodies = [BodyParameters.from_anthropometry(h, m) for h, m in
                  [(h0, m0), (h0, m1), (h1, m0), (h1, m1), (0.5 * (h0 + h1), 0.5 * (m0 + m1))]]
        rows = [(v, b) for b in bodies for v in speeds]
        t = lambda x: torch.as_tensor(np.asarray(x, dtype=np.float64))  # noqa: E731
        grid = {
            "speed": t([v for v, _ in rows]), "duration": t([typical_stride_duration(v) for v, _ in rows]),
            "height": t([b.height for _, b in rows]), "mass": t([b.mass for _, b in rows]),
            "hip": t([b.standing_hip_height for _, b in rows]), "p": t(np.stack([b.vector() for _, b in rows]))[:, None, :],
            "phase": t((np.arange(cfg.polish_points) + 0.5) / cfg.polish_points * 0.5),
        }
        w = cfg.weights
        weights = dataclasses.replace(w, kane=w.kane * cfg.polish_factor, bounds=w.bounds * cfg.polish_factor)
        losses = GaitLosses(GeneratorConfig(**{**cfg.to_dict(), "weights": weights}))
        optimizer = torch.optim.LBFGS(self.model_.parameters(), lr=1.0, max_iter=POLISH_CHUNK, history_size=50,
                                      line_search_fn="strong_wolfe")
        return grid, losses, optimizer

    def _polish_chunk(self) -> dict[str, torch.Tensor]:
        """Up to :data:`POLISH_CHUNK` L-BFGS iterations; returns the last evaluated loss terms and
        advances ``step`` by the iterations done (to the end when L-BFGS has converged)."""
        if self._polish is None:
            self._polish = self._polish_problem()
            if self._polish_state is not None:
                self._polish[2].load_state_dict(self._polish_state)
        grid, losses, optimizer = self._polish
        last: dict[str, torch.Tensor] = {}

        def closure() -> torch.Tensor:
            optimizer.zero_grad()
            coeffs = self.model_(grid["speed"], grid["height"], grid["mass"])
            q, u, qdd = cycle(coeffs, grid["speed"], grid["duration"], grid["hip"], grid["phase"])
            terms = losses(q, u, qdd, grid["p"], grid["height"], grid["mass"], grid["duration"])
            terms["total"].backward()
            last.update(terms)
            return terms["total"]

        first = optimizer.param_groups[0]["params"][0]
        before = optimizer.state[first].get("n_iter", 0)
        optimizer.step(closure)
        done = optimizer.state[first]["n_iter"] - before
        remaining = self.total_steps - self.step
        self.step += remaining if done < min(POLISH_CHUNK, remaining) else min(done, remaining)
        return last

    def _batch(self) -> dict[str, torch.Tensor]:
        cfg = self.config
        idx = self.rng.integers(0, len(self.bodies.heights), cfg.batch_size)
        speed = self.rng.uniform(*cfg.speeds, cfg.batch_size)
        T = np.array([typical_stride_duration(v) for v in speed])
        phase = (np.arange(cfg.points) + self.rng.uniform()) / cfg.points * 0.5  # half a cycle
        t = lambda x: torch.as_tensor(np.asarray(x, dtype=np.float64))  # noqa: E731
        return {
            "idx": t(idx).long(), "speed": t(speed), "duration": t(T), "phase": t(phase),
            "height": t(self.bodies.heights[idx]), "mass": t(self.bodies.masses[idx]),
            "p": t(self.bodies.p[idx])[:, None, :], "hip": t(self.bodies.hip_height[idx]),
        }

    def _warmup_loss(self, b: dict[str, torch.Tensor], q: torch.Tensor) -> torch.Tensor:
        target = np.stack([
            generic_gait(float(v), float(T), b["phase"].numpy() * float(T), self.bodies.bodies[int(i)])
            for v, T, i in zip(b["speed"], b["duration"], b["idx"])
        ])
        target = torch.as_tensor(target)
        err = q[..., 1:] - target[..., 1:]
        return err.square().mean() * 100.0

    def _kane_scale(self) -> float:
        cfg = self.config
        x = (self.step - cfg.warmup_steps) / max(cfg.steps, 1)
        return cfg.kane_ramp ** min(max(x, 0.0), 1.0)

    def _lr(self) -> float:
        cfg = self.config
        if self.step < cfg.warmup_steps:
            return cfg.lr
        x = (self.step - cfg.warmup_steps) / max(cfg.steps, 1)
        return cfg.lr * (0.1 + 0.9 * 0.5 * (1 + math.cos(math.pi * min(x, 1.0))))

    def _adam_step(self) -> dict[str, torch.Tensor]:
        """One warm-up or Adam step on a random batch; returns its loss terms."""
        b = self._batch()
        coeffs = self.model_(b["speed"], b["height"], b["mass"])
        q, u, qdd = cycle(coeffs, b["speed"], b["duration"], b["hip"], b["phase"])
        if self.step < self.config.warmup_steps:
            terms = {"warmup": self._warmup_loss(b, q)}
            terms["total"] = terms["warmup"]
        else:
            self.losses.kane_scale = self._kane_scale()
            terms = self.losses(q, u, qdd, b["p"], b["height"], b["mass"], b["duration"])
        if not torch.isfinite(terms["total"]):
            return terms
        for group in self.optimizer.param_groups:
            group["lr"] = self._lr()
        self.optimizer.zero_grad(set_to_none=True)
        terms["total"].backward()
        torch.nn.utils.clip_grad_norm_(self.model_.parameters(), 1.0)
        self.optimizer.step()
        self.step += 1
        return terms

    def fit(self, resume: bool = False, overwrite: bool = False) -> GaitGeneratorNet:
        """Train (continuing from ``<out>/checkpoint.pt`` with ``resume``); the run folder is
        owned by this run while it trains (:class:`sspinn.run_folder.RunLock`). Without
        ``resume``, a folder holding a run (:data:`RUN_OUTPUTS`) is refused unless ``overwrite``,
        which deletes that run's files first."""
        if resume and overwrite:
            raise ValueError("resume continues the run in the folder and overwrite replaces it: give one of them")
        with RunLock(self.out):
            if not resume:
                claim_run_folder(self.out, RUN_OUTPUTS, overwrite, "continue it with --resume, ")
            return self._fit(resume)

    def _fit(self, resume: bool) -> GaitGeneratorNet:
        from tqdm.auto import tqdm

        cfg = self.config
        self.out.mkdir(parents=True, exist_ok=True)
        if cfg.threads:
            torch.set_num_threads(cfg.threads)
        ckpt = self.out / "checkpoint.pt"
        if resume:
            if not ckpt.exists():
                raise FileNotFoundError(f"resume: no checkpoint at {ckpt}")
            self._load(ckpt)
        atomic_write_text(self.out / "config.yaml", yaml.safe_dump({"generator": cfg.to_dict()}, sort_keys=False))
        start = time.perf_counter() - self.wall
        bar = tqdm(total=self.total_steps, initial=self.step, desc="gait generator", unit="step", dynamic_ncols=True)
        try:
            while self.step < self.total_steps:
                before = self.step
                terms = self._adam_step() if self.step < self.adam_steps else self._polish_chunk()
                if not torch.isfinite(terms["total"]):
                    raise FloatingPointError(f"step {self.step}: non-finite loss {terms}; last checkpoint: {ckpt}")
                self.wall = time.perf_counter() - start
                bar.update(self.step - before)
                crossed = lambda every, before=before: self.step // every > before // every  # noqa: E731
                if crossed(cfg.log_every) or self.step == self.total_steps:
                    rec = {"step": self.step, "wall_s": self.wall, **{k: float(v.detach()) for k, v in terms.items()}}
                    self.history_.append(rec)
                    bar.set_postfix(loss=f"{rec['total']:.3g}", kane_rms=f"{rec.get('kane_rms_bw', float('nan')):.2g}")
                if crossed(cfg.checkpoint_every):
                    self._save(ckpt)
                if cfg.snapshot_every and crossed(cfg.snapshot_every):
                    (self.out / "snapshots").mkdir(exist_ok=True)
                    save_generator(self.model_, self.out / "snapshots" / f"generator_{self.step:06d}.pt", cfg, self.wall)
                if cfg.time_limit_s and self.wall > cfg.time_limit_s:
                    bar.write(f"time limit of {cfg.time_limit_s:.0f} s reached at step {self.step}")
                    break
        except KeyboardInterrupt:
            bar.write(f"interrupted at step {self.step}: saving {ckpt} (continue with resume)")
            self._save(ckpt)
            raise
        finally:
            bar.close()
        self._save(ckpt)
        save_generator(self.model_, self.out / "generator.pt", cfg, self.wall)
        self._write_history()
        self.train_time_s_ = self.wall
        return self.model_

    def _save(self, path: Path) -> None:
        state = {
            "model": self.model_.state_dict(), "optimizer": self.optimizer.state_dict(), "step": self.step,
            "wall": self.wall, "history": self.history_, "rng": self.rng.bit_generator.state,
            "torch_rng": torch.get_rng_state(), "config": self.config.to_dict(),
            "polish_optimizer": self._polish[2].state_dict() if self._polish is not None else self._polish_state,
        }
        save_torch_file(path, GENERATOR_CHECKPOINT, state)

    def _load(self, path: Path) -> None:
        state = load_torch_file(
            path, (GENERATOR_CHECKPOINT,), ("model", "optimizer", "step", "wall", "history", "rng", "torch_rng"),
            "delete it (or choose a new output folder) to start afresh",
        )
        self.model_.load_state_dict(state["model"])
        self.optimizer.load_state_dict(state["optimizer"])
        self.step, self.wall, self.history_ = state["step"], state["wall"], state["history"]
        self.rng.bit_generator.state = state["rng"]
        torch.set_rng_state(state["torch_rng"])
        self._polish, self._polish_state = None, state.get("polish_optimizer")

    def _write_history(self) -> None:
        if not self.history_:
            return
        keys = sorted({k for r in self.history_ for k in r}, key=lambda k: (k not in ("step", "wall_s"), k))
        with atomic_path(self.out / "history.csv") as tmp, open(tmp, "w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=keys)
            w.writeheader()
            w.writerows(self.history_)


def save_generator(model: GaitGeneratorNet, path: str | Path, config: GeneratorConfig, wall_s: float = float("nan")) -> Path:
    """Weights + config (+ the training wall time so far, s) in one file (behind :meth:`GaitGenerator.save`)."""
    return save_torch_file(path, GENERATOR, {"state": model.state_dict(), "config": config.to_dict(), "wall_s": wall_s})


def load_generator(path: str | Path) -> tuple[GaitGeneratorNet, GeneratorConfig]:
    """(network in eval mode, its config) from :func:`save_generator`'s file (behind
    :meth:`GaitGenerator.load`); the network's
    ``training_wall_s_`` is the training wall time (s) when the file was written (NaN if unknown)."""
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"{path}: no gait generator here (train one with `python -m predictive train-generator`)")
    data = load_torch_file(path, (GENERATOR,), ("state", "config"), "train one with `python -m predictive train-generator`")
    cfg = config_from_mapping(GeneratorConfig, dict(data["config"]), str(path))
    model = GaitGeneratorNet(cfg.harmonics, cfg.hidden, cfg.layers).double()
    model.load_state_dict(data["state"])
    model.training_wall_s_ = float(data.get("wall_s", float("nan")))
    return model.eval(), cfg


#: Samples per generated cycle.
SAMPLES_RANGE = (4, 10_000)


def outside_training_range(config: GeneratorConfig, speed: float, height: float, mass: float) -> list[str]:
    """What of ``speed`` (m/s), ``height`` (m) and ``mass`` (kg) lies outside the ranges the
    generator of ``config`` was trained on, in words (empty: all inside)."""
    found = []
    for name, value, (low, high), unit in (("speed", speed, config.speeds, "m/s"), ("height", height, config.heights, "m"),
                                           ("mass", mass, config.masses, "kg")):
        if not (math.isfinite(value) and low <= value <= high):
            found.append(f"{name} {value:g} {unit} is outside its training range {low:g}–{high:g} {unit}")
    return found


def generate(
    model: GaitGeneratorNet, speed: float, body: BodyParameters | None = None, n: int = 200, refine_iterations: int = 0,
    config: GeneratorConfig | None = None,
    refine_kane_factor: float = 1.0,
    force: bool = False,
) -> GaitSolution:
    """The generated gait cycle for ``speed`` (m/s) and ``body`` (default 1.75 m, 70 kg) at ``n``
    equally spaced samples, as a :class:`GaitSolution` (``status="generated"`` or ``"refined"``;
    torques are the total joint torques from inverse dynamics, as an OCP solution's).

    A speed or body outside the ranges the generator was trained on (``config.speeds``,
    ``heights``, ``masses``) raises :class:`predictive.ocp.limits.RequestError`: the network
    extrapolates there, with no physics loss having checked it. ``force=True`` generates anyway.

    ``refine_iterations`` > 0: the brief per-gait fine-tune — L-BFGS on this gait's free Fourier
    coefficients (the network's output as the start), minimising the training loss at ``n``
    phases of the half cycle, with the Kane weight × ``refine_kane_factor`` (SSPINNpose's
    fine-tuning mode multiplies L_K by 10). Still no data: the same self-supervised loss.
    """
    body = body or BodyParameters.from_anthropometry()
    config = config or GeneratorConfig()
    outside = outside_training_range(config, speed, body.height, body.mass)
    if outside and not force:
        raise RequestError(f"{'; '.join(outside)} of this generator: it would extrapolate (force=True to generate anyway)")
    if not 0 <= refine_iterations <= MAX_REFINE_ITERATIONS:
        raise RequestError(f"refine_iterations {refine_iterations} is outside 0–{MAX_REFINE_ITERATIONS}")
    if not SAMPLES_RANGE[0] <= n <= SAMPLES_RANGE[1]:
        raise RequestError(f"n {n} samples is outside {SAMPLES_RANGE[0]}–{SAMPLES_RANGE[1]}")
    start = time.perf_counter()
    T = typical_stride_duration(speed)
    f64 = lambda x: torch.tensor([x], dtype=torch.float64)  # noqa: E731
    height, mass = body.height, body.mass
    v, dur, hip, H, M = f64(speed), f64(T), f64(body.standing_hip_height), f64(height), f64(mass)
    p = torch.as_tensor(body.vector())
    losses = GaitLosses(config)
    with torch.no_grad():
        raw = model.raw(v, H, M)
    if refine_iterations > 0:
        weights = dataclasses.replace(config.weights, kane=config.weights.kane * refine_kane_factor)
        refine_losses = GaitLosses(GeneratorConfig(**{**config.to_dict(), "weights": weights}))
        raw = raw.clone().requires_grad_(True)
        half = torch.arange(n, dtype=torch.float64) / n * 0.5
        opt = torch.optim.LBFGS([raw], lr=1.0, max_iter=refine_iterations, history_size=50, line_search_fn="strong_wolfe")

        def closure() -> torch.Tensor:
            opt.zero_grad()
            q_, u_, a_ = cycle(model.coefficients(raw), v, dur, hip, half)
            loss = refine_losses(q_, u_, a_, p[None, None], H, M, dur)["total"]
            loss.backward()
            return loss

        opt.step(closure)
    with torch.no_grad():
        phase = torch.arange(n, dtype=torch.float64) / n
        q, u, qdd = cycle(model.coefficients(raw.detach()), v, dur, hip, phase)
        ph = losses.physics(q[0], u[0], qdd[0], p)
    root = ph["root"].numpy()
    return GaitSolution(
        time=phase.numpy() * T, q=q[0].numpy(), u=u[0].numpy(), qdd=qdd[0].numpy(), tau=ph["tau"].numpy(),
        grf=ph["grf"].numpy(), w=ph["w"].numpy(), speed=float(speed), duration=T, body_parameters=body.to_dict(),
        status="refined" if refine_iterations > 0 else "generated", iterations=refine_iterations,
        solve_time=time.perf_counter() - start,
        settings={"generator": True, "speed": float(speed), "kane_rms_bw": float(np.sqrt(np.mean(root[:, :2] ** 2)) / body.body_weight)},
        contact=dataclasses.asdict(ContactParameters(slip_velocity=ENV_SLIP_VELOCITY)),
        tau_max=np.full(N_TAU, 0.1 * body.body_weight * height),
    )



class GaitGenerator:
    """The self-supervised gait generator, in the shape of every trained model of the project
    (:class:`sspinn.SSPINNpose`): construct with settings, ``fit``, ``predict``, ``save``/``load``::

        gen = GaitGenerator(GeneratorConfig.from_yaml("configs/predictive/generator.yaml")).fit("runs/gen")
        walk = gen.predict(1.3)                    # a GaitSolution: one periodic cycle at 1.3 m/s
        gen = GaitGenerator.load("runs/gen/generator.pt")

    Args:
        config: training settings (default :class:`GeneratorConfig`); after ``load``, the file's.

    Attributes (set by ``fit`` or ``load``):
        network_: the trained :class:`GaitGeneratorNet` (float64, eval mode).
        training_wall_s_: the training wall time, s (NaN if unknown).
        steps_: training steps of the last ``fit`` (None after ``load``).
        history_: the last ``fit``'s learning curve (one dict per logged step; empty after ``load``).
    """

    def __init__(self, config: GeneratorConfig | None = None) -> None:
        self.config = config or GeneratorConfig()

    def fit(self, out: str | Path, resume: bool = False, overwrite: bool = False) -> GaitGenerator:
        """Train into the run folder ``out`` (``checkpoint.pt``, ``generator.pt``, ``history.csv``);
        ``resume`` continues an interrupted run there, ``overwrite`` replaces a finished one."""
        trainer = GeneratorTrainer(self.config, out)
        network = trainer.fit(resume=resume, overwrite=overwrite)
        self._set(network.eval(), trainer.wall, trainer.step, trainer.history_)
        return self

    @classmethod
    def load(cls, path: str | Path) -> GaitGenerator:
        """The generator saved at ``path`` (``generator.pt`` of a run, or :meth:`save`'s file)."""
        network, config = load_generator(path)
        generator = cls(config)
        generator._set(network, network.training_wall_s_, None, [])
        return generator

    def _set(self, network: GaitGeneratorNet, wall_s: float, steps: int | None, history: list[dict[str, float]]) -> None:
        self.network_ = network
        self.training_wall_s_ = float(wall_s)
        self.steps_ = steps
        self.history_ = history

    def _check_fitted(self) -> None:
        if not hasattr(self, "network_"):
            raise RequestError("this GaitGenerator has no trained network: call fit(out) or GaitGenerator.load(path)")

    def predict(self, speed: float, body: BodyParameters | None = None, n: int = 200, refine_iterations: int = 0,
                refine_kane_factor: float = 1.0, force: bool = False) -> GaitSolution:
        """The gait cycle for ``speed`` (m/s) and ``body`` at ``n`` samples (:func:`generate`: its
        checks of the training range, and the optional per-gait fine-tune)."""
        self._check_fitted()
        return generate(self.network_, speed, body, n, refine_iterations, self.config, refine_kane_factor, force)

    def outside_training_range(self, speed: float, height: float, mass: float) -> list[str]:
        """What of ``speed`` (m/s), ``height`` (m) and ``mass`` (kg) lies outside the training ranges, in words."""
        return outside_training_range(self.config, speed, height, mass)

    def save(self, path: str | Path) -> Path:
        """Write the generator file (atomically, safe format) and return its path."""
        self._check_fitted()
        return save_generator(self.network_, path, self.config, self.training_wall_s_)

    def __repr__(self) -> str:
        state = f"trained ({self.training_wall_s_:.0f} s)" if hasattr(self, "network_") else "not fitted"
        return f"GaitGenerator(speeds={self.config.speeds}; {state})"


__all__ = ["GaitGenerator", "GaitGeneratorNet", "GeneratorConfig", "GeneratorWeights"]
