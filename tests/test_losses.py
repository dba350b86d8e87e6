"""SSPINNpose losses on hand-checkable cases (float64)."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from sspinn.estimator.losses import Batch, LossWeights, PhysicsLosses
from sspinn.estimator.network import Estimate
from sspinn.model import dynamics, kinematics
from sspinn.model.body import BodyParameters, IMUPlacement
from sspinn.model.contact import ContactParameters
from sspinn.model.conventions import GRAVITY, SEGMENTS

UNIT = LossWeights.unit()
DT = 0.01


def fk_ankles(q: torch.Tensor, u: torch.Tensor, qdd: torch.Tensor, p: torch.Tensor) -> torch.Tensor:
    """The estimator's ankle states (x relative to the pelvis) from forward kinematics."""
    w = dynamics.contact_fraction(q, torch.as_tensor(ContactParameters().vector()))
    pk = kinematics.point_kinematics(q, u, qdd, w, p)
    fk = torch.stack([pk[..., kinematics.point_index(f"ankle_{s}"), :] for s in "rl"], dim=-2)
    return torch.cat([fk[..., :1] - q[..., None, :1], fk[..., 1:]], dim=-1)


def batch_of(q: torch.Tensor, u: torch.Tensor, qdd: torch.Tensor, p: torch.Tensor, height: float, mass: float) -> Batch:
    """A loss batch whose IMU data are the model's own virtual IMUs of the motion."""
    placement = torch.as_tensor(IMUPlacement.default(height).vector())[None]
    return Batch(
        imu=kinematics.virtual_imu(q, u, qdd, placement[:, None], p), imu_std=torch.ones(len(SEGMENTS), 3, dtype=torch.float64),
        segments=SEGMENTS, p=p[None], height=torch.tensor([height], dtype=torch.float64),
        mass=torch.tensor([mass], dtype=torch.float64), placement=placement, dt=DT,
    )


def exact_case(T: int = 120, height: float = 1.75, mass: float = 70.0, dynamic: bool = True):
    """A smooth motion q(t), u(t) with feet on the ground, torques τ(t), and q̈ either analytic
    (``dynamic=False``: temporally exact) or from forward dynamics with the contact-model GRFs
    (``dynamic=True``: the equations of motion hold exactly at every sample); ankle states from
    forward kinematics and IMU data from the model's virtual IMUs."""
    body = BodyParameters.from_anthropometry(height, mass)
    t = torch.arange(T, dtype=torch.float64) * DT
    amp = torch.tensor([0.0, 0.02, 0.05, 0.4, -0.4, 0.2, -0.3, -0.3, 0.1], dtype=torch.float64)
    off = torch.tensor([0.0, 0.86, 0.0, 0.0, -0.55, 0.0, 0.0, -0.6, 0.0], dtype=torch.float64)
    om = 2 * np.pi * 0.9
    q = off + amp * torch.sin(om * t)[:, None]
    u = amp * om * torch.cos(om * t)[:, None]
    qdd = -amp * om**2 * torch.sin(om * t)[:, None]
    q[:, 0], u[:, 0], qdd[:, 0] = 1.3 * t, 1.3, 0.0
    q, u, qdd = q[None], u[None], qdd[None]
    p = torch.as_tensor(body.vector())
    c = torch.as_tensor(ContactParameters().vector())
    w = dynamics.contact_fraction(q, c)
    ankle = fk_ankles(q, u, qdd, p)
    mu_hat = 0.3 * torch.ones(1, T, 2, dtype=torch.float64)
    tau = 20.0 * torch.sin(om * t)[None, :, None].expand(1, T, 6)
    est = Estimate(q=q, u=u, qdd=qdd, tau=tau, ankle=ankle, mu_hat=mu_hat)
    grf = dynamics.contact_from_ankles(q, u, est.ankle_global(), mu_hat, p, c)[..., :2].flatten(-2)
    if dynamic:
        est.qdd = qdd = dynamics.forward_dynamics(q, u, tau, grf, w, p)
        est.ankle = fk_ankles(q, u, qdd, p)
    return est, batch_of(q, u, qdd, p, height, mass), grf


def test_exact_motion_has_zero_kane_contact_and_imu_loss():
    est, batch, grf = exact_case()
    assert grf[..., 1::2].max() > 100.0, "the feet must be loaded for a meaningful Kane test"
    terms = PhysicsLosses(UNIT)(est, batch)
    assert terms["kane"] < 1e-20
    assert terms["contact"] < 1e-24
    assert terms["imu"] < 1e-20
    # with analytic q̈ the motion is temporally exact: central differences of a sinusoid have a
    # relative error (ω·dt)²/6 ≈ 0.05 %, so the temporal loss is tiny
    est, batch, _ = exact_case(dynamic=False)
    assert PhysicsLosses(UNIT)(est, batch)["temporal"] < 1e-5


def test_each_physics_term_detects_its_violation():
    est, batch, _ = exact_case()
    losses = PhysicsLosses(UNIT)
    est.tau = est.tau + 10.0  # 10 N·m wrong on every joint
    assert losses(est, batch)["kane"] > 1e-6
    est2, _, _ = exact_case()
    est2.ankle = est2.ankle + torch.tensor([0.0, 0.01, 0, 0, 0, 0], dtype=torch.float64)  # 1 cm too high
    assert losses(est2, batch)["contact"] == pytest.approx(((0.01 / (0.1 * 1.75)) ** 2) / 6, rel=1e-6)
    est3, batch3, _ = exact_case(dynamic=False)
    base3 = losses(est3, batch3)["temporal"]
    est3.u = est3.u * 1.1
    assert losses(est3, batch3)["temporal"] > 100 * base3
    batch.imu = batch.imu + 0.5
    assert losses(est, batch)["imu"] == pytest.approx(0.25, rel=1e-6)
    assert losses(est, batch)["gyro"] == pytest.approx(0.25, rel=1e-6)
    batch.imu[..., :2] = batch.imu[..., :2] + 1.0  # accelerometers only: L_G does not see it
    assert losses(est, batch)["gyro"] == pytest.approx(0.25, rel=1e-6)
    assert losses(est, batch)["imu"] > 1.0


def test_bounds_values():
    est, batch, grf = exact_case()
    losses = PhysicsLosses(UNIT)
    bw = 70.0 * GRAVITY
    foot_term = torch.relu(0.2 - grf[..., 1::2].mean(dim=1) / bw).square().mean()
    b0 = losses(est, batch)["bounds"]
    assert b0 == pytest.approx(float(foot_term), abs=1e-12)
    est.q = est.q.clone()
    est.q[..., 4] = 0.2  # knee hyperextended by 0.1 rad beyond its 0.1 limit
    b1 = losses(est, batch)["bounds"]
    assert b1 - foot_term == pytest.approx(0.1**2 / 6, rel=1e-6)  # one joint of six, every sample


def test_bounds_rule_out_walking_backwards():
    """The same motion with −1.3 m/s added to the pelvis (what IMUs cannot tell apart) costs
    (1.3 m/s)² in L_B; forward it costs nothing."""
    est, batch, grf = exact_case()
    losses = PhysicsLosses(UNIT)
    forward = losses(est, batch)["bounds"]
    est.u = est.u.clone()
    est.u[..., 0] -= 2 * 1.3
    assert losses(est, batch)["bounds"] - forward == pytest.approx(1.3**2, rel=1e-9)


def test_foot_speed_margin():
    est, batch, _ = exact_case()
    losses = PhysicsLosses(UNIT)
    p = batch.p[:, None]
    kin = kinematics.imu_kinematics(est.q, est.u, est.qdd, batch.placement[:, None], p)
    v = kin[..., [SEGMENTS.index("foot_r"), SEGMENTS.index("foot_l")], 2].abs()
    batch.zupt_speed = v.clone()
    assert losses(est, batch)["foot_speed"] == 0.0
    batch.zupt_speed = v + 0.29 * v.amax(dim=1, keepdim=True)  # inside the 30 % margin
    assert losses(est, batch)["foot_speed"] == 0.0
    batch.zupt_speed = v + 0.5
    margin = 0.3 * batch.zupt_speed.amax(dim=1, keepdim=True)
    expected = torch.relu(0.5 - margin).square().mean()
    assert losses(est, batch)["foot_speed"] == pytest.approx(float(expected), rel=1e-9)


def test_weights_and_finetune():
    w = LossWeights()
    assert (w.kane, w.temporal, w.imu, w.contact, w.bounds, w.torque, w.slide, w.foot_speed) == (3, 3, 30, 100, 10000, 1, 30, 1)
    f = w.finetune()
    assert (f.kane, f.temporal, f.contact, f.imu) == (30, 30, 1000, 30)
    est, batch, _ = exact_case()
    est.tau = est.tau + 10.0
    a = PhysicsLosses(UNIT)(est, batch)
    b = PhysicsLosses(w)(est, batch)
    assert b["kane"] == pytest.approx(3 * a["kane"])
    assert b["total"] == pytest.approx(sum(float(b[k]) for k in w.as_dict()))


def standing_case(height: float = 1.75, mass: float = 70.0, T: int = 10):
    """Standing still, feet flat on the floor, each loaded by the contact model (est = FK)."""
    body = BodyParameters.from_anthropometry(height, mass)
    q = torch.zeros(1, T, 9, dtype=torch.float64)
    q[..., 1] = body.standing_hip_height
    u, qdd = torch.zeros_like(q), torch.zeros_like(q)
    p = torch.as_tensor(body.vector())
    c = torch.as_tensor(ContactParameters().vector())
    est = Estimate(q=q, u=u, qdd=qdd, tau=torch.zeros(1, T, 6, dtype=torch.float64), ankle=fk_ankles(q, u, qdd, p),
                   mu_hat=torch.zeros(1, T, 2, dtype=torch.float64))
    batch = batch_of(q, u, qdd, p, height, mass)
    load = dynamics.contact_from_ankles(q, u, est.ankle_global(), est.mu_hat, p, c)[..., 1] / (mass * GRAVITY)
    return est, batch, load


def test_stance_term_ties_the_loaded_foot_to_the_body_model():
    """L_S (not in the paper): a loaded contact point of the body model's own kinematics must
    neither slide nor float; a body that moves while its separately estimated ankles stay put
    (what let running estimates sit at 0 m/s) pays for it, the standing body hardly at all."""
    est, batch, load = standing_case()
    assert load.min() > 0.1, "both feet must carry load"
    losses = PhysicsLosses(UNIT)
    still = float(losses(est, batch)["stance"])
    assert still < 0.05  # the contact points sit a few mm in the floor under the model's stiffness
    sliding = Estimate(**{**est.__dict__, "u": est.u.clone()})
    sliding.u[..., 0] = 1.0  # the whole body at 1 m/s: the loaded contact points slide at 1 m/s
    assert float(losses(sliding, batch)["stance"]) - still == pytest.approx(float(load.square().mean()), rel=1e-6)
    floating = Estimate(**{**est.__dict__, "q": est.q.clone()})
    floating.q[..., 1] += 0.05  # 5 cm above the floor but still loaded through the ankle estimates
    assert float(losses(floating, batch)["stance"]) > still + 0.5 * float(load.square().mean())
    sunk = Estimate(**{**est.__dict__, "q": est.q.clone()})
    sunk.q[..., 1] -= 0.10  # 10 cm below the floor: (−0.1 / 0.05)² = 4 even without load
    assert float(losses(sunk, batch)["stance"]) > 3.0


def direct(est: Estimate, grf: torch.Tensor) -> Estimate:
    """The same motion as a direct-GRF network's estimate with the forces ``grf`` (B, T, 4)."""
    return Estimate(q=est.q, u=est.u, qdd=est.qdd, tau=est.tau, grf=grf)


def test_direct_grf_satisfies_the_equations_of_motion_exactly():
    """With the contact model's forces as the direct outputs, the exact motion has zero Kane and
    IMU loss, and the terms on separately estimated ankles are 0 (there are none)."""
    est, batch, grf = exact_case()
    losses = PhysicsLosses(UNIT, grf="direct")
    terms = losses(direct(est, grf), batch)
    assert terms["kane"] < 1e-20 and terms["imu"] < 1e-20
    assert terms["contact"] == 0.0 and terms["slide"] == 0.0
    wrong = grf.clone()
    wrong[..., 1] += 70.0 * GRAVITY * 0.1  # 0.1 BW too much on the right foot
    assert losses(direct(est, wrong), batch)["kane"] > 1e-3
    with pytest.raises(ValueError, match="no separately estimated ankles"):
        PhysicsLosses(UNIT)(direct(est, grf), batch)
    with pytest.raises(ValueError, match="need an estimate with forces"):
        losses(est, batch)  # a contact-model estimate under the direct-GRF losses


def test_direct_grf_friction_cone():
    est, batch, grf = exact_case()
    losses = PhysicsLosses(UNIT, grf="direct")
    bw = 70.0 * GRAVITY
    inside = grf.clone()
    inside[..., 0::2] = 0.8 * inside[..., 1::2]  # on the cone: free
    base = float(losses(direct(est, inside), batch)["bounds"])
    outside = inside.clone()
    outside[..., 0] += 0.1 * bw  # 0.1 BW beyond the cone on the right foot, every sample
    assert float(losses(direct(est, outside), batch)["bounds"]) - base == pytest.approx(0.1**2 / 2, rel=1e-6)


def test_direct_grf_stance_band():
    """L_S with direct GRFs: a loaded foot may sit anywhere from 5 cm below to 1 cm above the
    floor (the assumed body is not the subject's), not higher, and no foot sinks deeper."""
    est, batch, _ = standing_case()
    losses = PhysicsLosses(UNIT, grf="direct")
    T = est.q.shape[1]
    bw = 70.0 * GRAVITY
    grf = torch.tensor([0.0, 0.5 * bw, 0.0, 0.5 * bw], dtype=torch.float64).expand(1, T, 4)
    still = float(losses(direct(est, grf), batch)["stance"])
    assert still < 1e-12
    lowered = Estimate(**{**direct(est, grf).__dict__, "q": est.q.clone()})
    lowered.q[..., 1] -= 0.04  # 4 cm into the floor: inside the band
    assert float(losses(lowered, batch)["stance"]) < 1e-12
    raised = Estimate(**{**direct(est, grf).__dict__, "q": est.q.clone()})
    raised.q[..., 1] += 0.03  # ≈ 3 cm up: ≈ 2 cm beyond the 1 cm clearance, loaded with 0.5 BW
    y = kinematics.point_kinematics(raised.q, raised.u, raised.qdd, dynamics.contact_fraction(raised.q), batch.p[:, None])
    height = y[..., [kinematics.point_index("contact_r"), kinematics.point_index("contact_l")], 1]
    expected = (torch.relu(height - 0.01) / 0.05 * 0.5).square().mean()
    assert float(losses(raised, batch)["stance"]) == pytest.approx(float(expected), rel=1e-9)
    assert float(expected) > 0.03
    sunk = Estimate(**{**direct(est, torch.zeros_like(grf)).__dict__, "q": est.q.clone()})
    sunk.q[..., 1] -= 0.08  # 8 cm down, unloaded: ≈ 3 cm beyond the band
    assert float(losses(sunk, batch)["stance"]) > 0.25


def test_direct_grf_decoding_keeps_vertical_forces_positive():
    from sspinn.estimator.network import NetworkConfig, decode, output_affine

    config = NetworkConfig(grf="direct")
    assert config.n_outputs == 36 and NetworkConfig().n_outputs == 46
    scale, offset = (torch.as_tensor(a)[None] for a in output_affine(1.75, 70.0, 0.9, grf="direct"))
    raw = torch.randn(1, 50, 36, dtype=torch.float64) * 5
    est = decode(raw, scale, offset, 0.01, "direct")
    assert est.ankle is None and est.mu_hat is None
    assert (est.grf[..., 1::2] >= 0).all()
    bw = 70.0 * 9.81
    torch.testing.assert_close(est.grf[..., 0], 0.5 * bw * raw[..., 32])
    torch.testing.assert_close(est.grf[..., 1], bw * torch.nn.functional.softplus(raw[..., 33]))
    with pytest.raises(ValueError, match="grf must be one of"):
        NetworkConfig(grf="springs")


def test_imu_noise_scales_weigh_small_signals_less():
    """σ = √(σ_abs² + (κ·std)²): a limb gyroscope (std 2.5 rad/s) keeps about its weight relative
    to its accelerometer's, the pelvis (std 0.45 rad/s, 3 m/s²) is no longer weighted as if its
    small signals were precise; bad settings are refused."""
    from sspinn.estimator.losses import IMUNoise

    std = torch.tensor([[3.0, 10.0, 0.45], [12.0, 11.0, 2.5]], dtype=torch.float64)
    sigma = IMUNoise().scales(std)
    expected = torch.sqrt(torch.tensor([2.0, 2.0, 0.2], dtype=torch.float64) ** 2 + (torch.tensor([0.1, 0.1, 0.02], dtype=torch.float64) * std) ** 2)
    torch.testing.assert_close(sigma, expected)
    assert sigma[0, 2] > 0.4 * std[0, 2] and sigma[1, 2] < 0.1 * std[1, 2]
    for bad in ({"acc": -1.0}, {"gyr": float("nan")}, {"acc_relative": float("inf")}, {"gyr": 0.0, "gyr_relative": 0.0}):
        with pytest.raises(ValueError, match="imu_noise"):
            IMUNoise(**bad)
