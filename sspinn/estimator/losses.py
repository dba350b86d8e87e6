"""SSPINNpose's self-supervised losses: physics, measurement and plausibility terms.

Every term is a mean squared error of dimensionless quantities (forces in body weights BW,
torques in BW·BH, kinematic errors in the units of :func:`sspinn.estimator.network.output_affine`):

=========  ======  ===================================================================
term       weight  meaning
=========  ======  ===================================================================
kane       3       Kane residual M(q)q̈ − f(q, u, τ, F_gc) with the contact-model GRFs
                   (or the network's own, ``grf: direct``)
temporal   3       dq/dt − u and du/dt − q̈ (central differences), each divided by the
                   sequence's standard deviation of the derivative (floored at 10 % of
                   its typical magnitude: 1.5 m/s, 0.5 m/s, 4 rad/s; 10 m/s², 50 rad/s²)
imu        30      virtual − measured IMU signals, divided by each channel's standard
                   deviation (over the training data) or by its expected error
                   (:class:`IMUNoise`), averaged over IMUs and channels
contact    100     separately estimated ankle kinematics − forward kinematics (L_GC;
                   contact model only)
bounds     10000   joint limits (hip, ankle [−π/3, π/3], knee [−π/3, 0.1] rad by
                   default), |pelvis velocity| ≤ 10 m/s, pelvis height in [0, 2] m,
                   each foot carrying ≥ 20 % BW on average over the sequence, and the
                   sequence's mean forward pelvis velocity ≥ 0 (L_B; see below); with
                   direct GRFs also the friction cone |F_x| ≤ 0.8·F_y
torque     1       speed-weighted effort: (τ / (BW·BH) / max(ẋ_root, 1 m/s))² (L_τ)
slide      30      (|ẋ_contact| / (1 m/s) · F_y / BW)² — no sliding under load (contact
                   model only)
stance     0       on the body model's own contact points (forward kinematics of q, u):
                   (|ẋ| / (1 m/s) · F_y/BW)² + (y / 5 cm · F_y/BW)² + (max(0, −y) / 5 cm)²
                   — a loaded foot neither slides nor floats, no foot below the floor (L_S;
                   with direct GRFs the floor is a band, see below)
foot_speed 1       foot-IMU horizontal speed vs a ZUPT Kalman estimate, penalised only
                   beyond 30 % of the sequence's maximum ZUPT speed (L_FS)
gyro       0       the gyroscope channels of L_IMU once more (L_G; see below)
=========  ======  ===================================================================

Fine-tuning multiplies the kane, temporal and contact weights by 10 (:meth:`LossWeights.finetune`).

**Forward, not backward.** Accelerometers and gyroscopes cannot see a constant velocity added to
the whole body, and without the foot-speed term (running: no zero-velocity phase) nothing else
told a gait from its mirror image running backwards: trained on running, the network converged
to pelvis velocities of −2 to −3 m/s (the semi-real running trial gave −3 m/s). The
calibration (:mod:`sspinn.imu.calibration`) and the synthetic data define x as the subject's
anterior direction, so the mean forward velocity over a training window (≥ 1 s, a stride or
more) is ≥ 0 for every gait, standing included; its violation is part of L_B.

**Stance anchors the speed (L_S, not in the paper).** L_slide reads the contact point's velocity
from the separately estimated ankle kinematics, which L_GC ties to the body model only loosely
(a 2.8 m/s mismatch during a running stance costs less than the dynamics gain from it). So a
running estimate could put its pelvis near 0 m/s and its stance on the foot that is really in
swing (which then hardly moves). L_S penalises the same product on the forward kinematics of
the estimated q, u — the model's own loaded foot must not slide, which fixes the pelvis speed
to the leg's motion during stance — and, at the same load, the contact point's height above the
floor, plus any depth below it (the loaded foot must be the one on the floor). Its default weight is 0 (the paper's losses);
``configs/sspinn/demo.yaml`` sets it.

**Direct ground reaction forces (``grf: direct``, not in the paper).** When the network outputs
the forces (:mod:`sspinn.estimator.network`), L_GC and L_slide have no separate ankles to act on (they are
0) and L_S carries the contact conditions alone: a loaded contact point must not slide, and its
height must lie in a band, [−:data:`STANCE_SINK`, +:data:`STANCE_CLEARANCE`] around the floor,
not at 0: the subject's feet are not the assumed model's (Winter scaling; segment lengths differ
by a few per cent), so the true motion puts the model's loaded contact points up to 5.2 cm below
or 1.3 cm above the floor (synthetic training recordings, labels through the assumed body), and the
pelvis height, which no IMU sees, takes up a constant offset. No foot may sink deeper than the
band. The friction cone |F_x| ≤ 0.8·F_y joins L_B.

**Angular rates weigh more (L_G, not in the paper).** L_IMU weighs every channel by its spread
over the training data, but the channels are not equally trustworthy: a sensor mounted 3° off
its nominal angle (the synthetic error model's misalignment, a real strap's rotation) puts
g·sin 3° ≈ 0.5 m/s² of gravity into the wrong accelerometer axis for the whole recording — the
same size as the pelvis accelerometer's gait signal — while its gyroscope still reads the
segment's angular rate (the true kinematics of the synthetic training recordings miss the
measured accelerometers by 10–64 % of their spread, the limbs' gyroscopes by 3–11 % — the
pelvis's, whose rates are small, by 30–45 %). The network can
only explain such offsets by tilting segments. L_G adds the gyroscope part of L_IMU again, so
λ_G shifts the fit towards the rates. Its default weight is 0 (the paper's losses).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace

import torch

from sspinn.estimator.network import FORCE_OUTPUTS, TYPICAL_QDD, TYPICAL_U, Estimate
from sspinn.model import dynamics, kinematics
from sspinn.model.body import JointLimits
from sspinn.model.contact import ContactParameters
from sspinn.model.conventions import GRAVITY, SEGMENTS

#: L_S's height scale, m: a loaded contact point this far above the floor (or any point this
#: far below it) costs as much as one sliding at 1 m/s.
STANCE_HEIGHT = 0.05
#: With direct GRFs, the band of contact-point heights that L_S allows under load, m: from
#: this far below the floor (a foot may sink no deeper, loaded or not) …
STANCE_SINK = 0.05
#: … to this far above it.
STANCE_CLEARANCE = 0.01
#: With direct GRFs, the friction coefficient of the friction cone in L_B.
FRICTION = 0.8


@dataclass(frozen=True)
class LossWeights:
    """λ of each term (defaults: the paper's)."""

    kane: float = 3.0
    temporal: float = 3.0
    imu: float = 30.0
    contact: float = 100.0
    bounds: float = 10000.0
    torque: float = 1.0
    slide: float = 30.0
    foot_speed: float = 1.0
    stance: float = 0.0
    gyro: float = 0.0

    @classmethod
    def unit(cls) -> LossWeights:
        """Every λ = 1: the terms as they are, e.g. to compare estimates (``Trainer.physics_check``)."""
        return cls(**{k: 1.0 for k in asdict(cls())})

    def finetune(self) -> LossWeights:
        """The paper's fine-tuning weights: kane, temporal and contact × 10."""
        return replace(self, kane=10 * self.kane, temporal=10 * self.temporal, contact=10 * self.contact)

    def as_dict(self) -> dict[str, float]:
        return asdict(self)


@dataclass(frozen=True)
class IMUNoise:
    """The expected error of each IMU channel, by which L_IMU divides it instead of the channel's
    standard deviation (the paper's).

    σ = √(σ_abs² + (κ·std)²) per channel, std its standard deviation over the training data:
    an absolute part (soft-tissue motion, noise, the gravity a few degrees of misalignment put
    into the wrong axis) and a part proportional to the signal (misplacement and the assumed
    segment lengths scale the accelerations; the angular rate of a rigid segment is the same
    everywhere on it, so κ is small for the gyroscopes).

    Why: dividing by the std weights a channel by 1/std², so the pelvis, whose signals are small
    (std 3 m/s² and 0.45 rad/s against 7–18 m/s² and 2.4–4.1 rad/s on the limbs), weighs the most,
    although its errors are as large in absolute terms as everyone's: through the true
    kinematics, the synthetic training recordings (default error model) miss by 1.6–2.2 m/s² and
    0.15–0.17 rad/s on every segment, i.e. 0.34–0.49 of the pelvis's std and 0.04–0.07 of the
    limbs' gyroscopes. A network fitting the pelvis signals better than the truth does bends
    the other segments to do it.

    Attributes:
        acc, gyr: absolute parts, m/s² and rad/s.
        acc_relative, gyr_relative: κ of the accelerometers and gyroscopes.
    """

    acc: float = 2.0
    gyr: float = 0.2
    acc_relative: float = 0.1
    gyr_relative: float = 0.02

    def __post_init__(self) -> None:
        for name in ("acc", "gyr", "acc_relative", "gyr_relative"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"imu_noise.{name} must be a finite number >= 0, got {value}")
        if self.acc == 0 and self.acc_relative == 0 or self.gyr == 0 and self.gyr_relative == 0:
            raise ValueError(f"imu_noise: an accelerometer or gyroscope error of zero would divide by zero ({self})")

    def scales(self, std: torch.Tensor) -> torch.Tensor:
        """σ (n_imu, 3) of channels [acc_x, acc_y, gyr_z] with standard deviations ``std`` (n_imu, 3)."""
        floor = std.new_tensor([self.acc, self.acc, self.gyr])
        kappa = std.new_tensor([self.acc_relative, self.acc_relative, self.gyr_relative])
        return torch.sqrt(floor**2 + (kappa * std) ** 2)


@dataclass
class Batch:
    """What the losses need besides the estimate; B sequences of T samples.

    imu: (B, T, n_imu, 3) measured signals of ``segments``; imu_std: (n_imu, 3) channel scales
    (the standard deviations, or :meth:`IMUNoise.scales`);
    p: (B, 41) body parameters; height, mass: (B,); placement: (B, 21) IMU placement (may be a
    learnable tensor); zupt_speed: (B, T, 2) foot horizontal speed of a ZUPT filter for the
    right and left foot IMU (NaN where unavailable) or None; dt: s; out_scale/out_offset: the
    network's output affine map per sequence (used by the trainer to decode, not by the losses).
    """

    imu: torch.Tensor
    imu_std: torch.Tensor
    segments: tuple[str, ...]
    p: torch.Tensor
    height: torch.Tensor
    mass: torch.Tensor
    placement: torch.Tensor
    dt: float
    zupt_speed: torch.Tensor | None = None
    out_scale: torch.Tensor | None = None  # (B, n_outputs) network output scale per sequence
    out_offset: torch.Tensor | None = None  # (B, n_outputs)


def _relu2(x: torch.Tensor) -> torch.Tensor:
    return torch.relu(x).square()


def _central_diff(x: torch.Tensor, dt: float) -> torch.Tensor:
    """d/dt along the time axis (-2) by central differences; drops the first and last sample."""
    return (x[:, 2:] - x[:, :-2]) / (2 * dt)


class PhysicsLosses:
    """Computes every loss term of an :class:`Estimate` for a :class:`Batch`.

    Args:
        weights: λ per term.
        contact: contact-model parameters (vector or dataclass); default ContactParameters().
        limits: joint limits for the bounds term.
        foot_load: minimum mean vertical force per foot over a sequence, in BW.
        grf: the network's ground contact (:attr:`sspinn.estimator.network.NetworkConfig.grf`):
            ``"contact_model"`` (forces from the estimated ankles) or ``"direct"``.
    """

    def __init__(
        self,
        weights: LossWeights | None = None,
        contact: ContactParameters | None = None,
        limits: JointLimits | None = None,
        foot_load: float = 0.2,
        grf: str = "contact_model",
    ) -> None:
        self.grf = grf
        self.weights = weights or LossWeights()
        self.contact = (contact or ContactParameters()).vector()
        lo, hi = (limits or JointLimits()).arrays()
        self.lower, self.upper = torch.as_tensor(lo), torch.as_tensor(hi)
        self.foot_load = foot_load

    def __call__(self, est: Estimate, batch: Batch) -> dict[str, torch.Tensor]:
        """Dict of every weighted term plus ``total`` (scalars) and ``grf`` (B, T, 4, N) for logging."""
        return self.weigh(self.terms(est, batch))

    def weigh(self, terms: dict[str, torch.Tensor], weights: LossWeights | None = None) -> dict[str, torch.Tensor]:
        """:meth:`terms`' output weighted by λ (``weights``, default :attr:`weights`), with their
        sum ``total``. Apart from :meth:`terms` so that a compiled :meth:`terms` does not depend
        on the weights (they change within a run: ``finetune_last``, ``weights_after_starts``;
        each change would recompile)."""
        lam = (weights or self.weights).as_dict()
        weighted = {k: lam[k] * v for k, v in terms.items() if k != "grf"}
        return {**weighted, "total": sum(weighted.values()), "grf": terms["grf"]}

    def terms(self, est: Estimate, batch: Batch) -> dict[str, torch.Tensor]:
        """Every term, unweighted (scalars), and ``grf`` (B, T, 4, N) for logging."""
        q, u, qdd, tau = est.q, est.u, est.qdd, est.tau
        like = q
        p = batch.p[:, None, :]
        c = torch.as_tensor(self.contact, dtype=like.dtype, device=like.device)
        weight = (batch.mass * GRAVITY)[:, None]  # BW, (B, 1)
        bwbh = weight * batch.height[:, None]
        terms: dict[str, torch.Tensor] = {}

        direct = self.grf in FORCE_OUTPUTS
        points = est.grf_points if self.grf == "two_point" else None
        if direct:
            if est.grf is None or (self.grf == "two_point" and points is None):
                raise ValueError(f"the {self.grf}-GRF losses need an estimate with forces (a network with grf: {self.grf})")
            grf = est.grf
        else:  # ground contact on the separately estimated ankle kinematics
            gc = dynamics.contact_from_ankles(q, u, est.ankle_global(), est.mu_hat, p, c)  # (B, T, 2, 6)
            grf = gc[..., :2].flatten(-2)
        load = grf[..., 1::2] / weight[..., None]  # F_y / BW per foot, (B, T, 2)
        w = dynamics.contact_fraction(q, c)

        # L_K
        if points is None:
            r = dynamics.kane_residual(q, u, qdd, tau, grf, w, p)
        else:  # linear in the forces: each point's force at its own place (toe w = 0, heel w = 1)
            toe, heel = torch.zeros_like(w), torch.ones_like(w)
            r = (dynamics.kane_residual(q, u, qdd, tau, points[..., 0, :].flatten(-2), toe, p)
                 + dynamics.kane_residual(q, u, qdd, tau, points[..., 1, :].flatten(-2), heel, p)
                 - dynamics.kane_residual(q, u, qdd, tau, torch.zeros_like(grf), toe, p))
        r_scaled = torch.cat([r[..., :2] / weight[..., None], r[..., 2:] / bwbh[..., None]], dim=-1)
        terms["kane"] = r_scaled.square().mean()

        # L_T
        dq, du = _central_diff(q, batch.dt), _central_diff(u, batch.dt)
        # sequence std of each derivative, floored at a tenth of its typical magnitude so that a
        # nearly constant estimate cannot blow the normalised error up
        su = torch.maximum(u.detach().std(dim=1, keepdim=True), 0.1 * torch.tensor(TYPICAL_U).to(u))
        sa = torch.maximum(qdd.detach().std(dim=1, keepdim=True), 0.1 * torch.tensor(TYPICAL_QDD).to(u))
        terms["temporal"] = ((dq - u[:, 1:-1]) / su).square().mean() + ((du - qdd[:, 1:-1]) / sa).square().mean()

        # L_IMU
        placement = batch.placement[:, None, :]
        idx = [SEGMENTS.index(s) for s in batch.segments]
        virtual = kinematics.virtual_imu(q, u, qdd, placement, p)[..., idx, :]
        imu_error = ((virtual - batch.imu) / batch.imu_std).square()
        terms["imu"] = imu_error.mean()
        terms["gyro"] = imu_error[..., 2].mean()  # L_G: [acc_x, acc_y, gyr_z] per IMU

        # L_GC: ankle kinematics, estimated vs forward kinematics (x relative to the hip)
        pk = kinematics.point_kinematics(q, u, qdd, w, p)
        zero = torch.zeros((), dtype=like.dtype, device=like.device)
        if direct:
            terms["contact"] = zero
        else:
            fk = torch.stack([pk[..., kinematics.point_index(f"ankle_{s}"), :] for s in "rl"], dim=-2)
            fk = torch.cat([fk[..., :1] - q[..., None, :1], fk[..., 1:]], dim=-1)
            h = batch.height[:, None, None, None]
            gc_scale = torch.cat([h * 0.1, h * 0.1, torch.ones_like(h), torch.ones_like(h), 10 * torch.ones_like(h), 10 * torch.ones_like(h)], dim=-1)
            terms["contact"] = ((est.ankle - fk) / gc_scale).square().mean()

        # L_B
        lower, upper = self.lower.to(like), self.upper.to(like)
        joints = q[..., 3:]
        bounds = (
            _relu2(lower - joints).mean()
            + _relu2(joints - upper).mean()
            + _relu2(u[..., :2].abs() - 10.0).mean()
            + _relu2(-q[..., 1]).mean()
            + _relu2(q[..., 1] - 2.0).mean()
            + _relu2(self.foot_load - load.mean(dim=1)).mean()
            + _relu2(-u[..., 0].mean(dim=1)).mean()
        )
        if points is not None:  # the friction cone at each point
            point_load = points[..., 1] / weight[..., None, None]
            bounds = bounds + _relu2(points[..., 0].abs() / weight[..., None, None] - FRICTION * point_load).mean()
        elif direct:  # the friction cone
            bounds = bounds + _relu2(grf[..., 0::2].abs() / weight[..., None] - FRICTION * load).mean()
        terms["bounds"] = bounds

        # L_τ
        speed = u[..., :1].abs().clamp_min(1.0)
        terms["torque"] = (tau / bwbh[..., None] / speed).square().mean()

        # L_slide
        terms["slide"] = zero if direct else (gc[..., 4].abs() * load).square().mean()

        # L_S: the body model's own contact points (forward kinematics) under the same loads
        if points is None:
            cp = torch.stack([pk[..., kinematics.point_index(f"contact_{s}"), :4] for s in "rl"], dim=-2)  # (B, T, 2, 4)
        else:  # toe and heel of each foot, each under its own load: (B, T, 2 feet, 2 points, 4)
            cp = torch.stack([torch.stack([pk[..., kinematics.point_index(f"{point}_{s}"), :4] for point in ("toe", "heel")], dim=-2)
                              for s in "rl"], dim=-3)
            load = points[..., 1] / weight[..., None, None]
        y = cp[..., 1]
        if direct:  # a band around the floor (module docstring)
            off_floor, sunk = torch.relu(y - STANCE_CLEARANCE) + torch.relu(-y - STANCE_SINK), torch.relu(-y - STANCE_SINK)
        else:
            off_floor, sunk = y, torch.relu(-y)
        terms["stance"] = (
            (cp[..., 2].abs() * load).square().mean()
            + (off_floor / STANCE_HEIGHT * load).square().mean()
            + (sunk / STANCE_HEIGHT).square().mean()
        )

        # L_FS
        if batch.zupt_speed is not None:
            kin = kinematics.imu_kinematics(q, u, qdd, placement, p)
            feet = [SEGMENTS.index("foot_r"), SEGMENTS.index("foot_l")]
            v_est = kin[..., feet, 2].abs()  # horizontal speed of the foot IMUs
            v_ref = batch.zupt_speed
            known = torch.isfinite(v_ref)
            v_ref0 = torch.where(known, v_ref, torch.zeros_like(v_ref))
            margin = 0.3 * v_ref0.amax(dim=1, keepdim=True)
            excess = _relu2((v_est - v_ref0).abs() - margin)
            terms["foot_speed"] = (excess * known).sum() / known.sum().clamp_min(1)
        else:
            terms["foot_speed"] = torch.zeros((), dtype=like.dtype, device=like.device)

        return {**terms, "grf": grf.detach()}
