"""Two fixed contact points per foot (``NetworkConfig.grf = "two_point"``): the outputs decode to
toe and heel forces whose sum is the foot's GRF, the Kane residual puts each force at its own
point (equal to the one-point residual when one point carries everything), and the losses train."""

from __future__ import annotations

import numpy as np
import torch

from sspinn.estimator.inference import physical_outputs
from sspinn.estimator.losses import Batch, LossWeights, PhysicsLosses
from sspinn.estimator.network import NetworkConfig, SSPINNposeNet, decode, output_affine
from sspinn.model import dynamics
from sspinn.model.body import BodyParameters


def _estimate(raw: torch.Tensor, grf: str = "two_point"):
    body = BodyParameters.from_anthropometry(1.75, 70.0)
    scale, offset = output_affine(1.75, 70.0, body.standing_hip_height, body.gravity, grf)
    return decode(raw, torch.as_tensor(scale, dtype=raw.dtype)[None], torch.as_tensor(offset, dtype=raw.dtype)[None], 0.01, grf), body


def test_points_sum_to_the_feet_forces_and_the_vertical_ones_are_not_negative():
    torch.manual_seed(0)
    net = SSPINNposeNet(44, NetworkConfig(hidden=8, layers=1, dropout=0.0, dense=8, grf="two_point"))
    raw, _ = net(torch.randn(2, 30, 44))
    est, body = _estimate(raw.double())
    assert est.grf_points.shape == (2, 30, 2, 2, 2) and est.grf.shape == (2, 30, 4)
    torch.testing.assert_close(est.grf[..., 0], est.grf_points[..., 0, :, 0].sum(-1))  # Fx right = toe + heel
    torch.testing.assert_close(est.grf[..., 3], est.grf_points[..., 1, :, 1].sum(-1))  # Fy left
    assert (est.grf_points[..., 1] >= 0).all()
    out = physical_outputs(raw.detach(), body, "two_point")
    assert ((out["w"] >= 0) & (out["w"] <= 1)).all()


def test_the_kane_residual_puts_each_force_at_its_point():
    torch.manual_seed(1)
    raw = torch.randn(1, 20, 40, dtype=torch.float64)
    est, body = _estimate(raw)
    p = torch.as_tensor(body.vector())[None, None]
    losses = PhysicsLosses(LossWeights(), grf="two_point")
    # all the load at the heel: the one-point residual with w = 1 is the same
    points = est.grf_points.clone()
    points[..., 0, :] = 0.0
    est.grf_points, est.grf = points, points.sum(-2).flatten(-2)
    batch = Batch(imu=torch.zeros(1, 20, 7, 3, dtype=torch.float64), imu_std=torch.ones(7, 3, dtype=torch.float64),
                  segments=("pelvis", "femur_r", "tibia_r", "foot_r", "femur_l", "tibia_l", "foot_l"), p=p[:, 0],
                  height=torch.tensor([1.75], dtype=torch.float64), mass=torch.tensor([70.0], dtype=torch.float64),
                  placement=torch.zeros(1, 21, dtype=torch.float64), dt=0.01)
    terms = losses.terms(est, batch)
    one = dynamics.kane_residual(est.q, est.u, est.qdd, est.tau, est.grf, torch.ones(1, 20, 2, dtype=torch.float64), p)
    weight = 70.0 * 9.81
    scaled = torch.cat([one[..., :2] / weight, one[..., 2:] / (weight * 1.75)], -1)
    torch.testing.assert_close(terms["kane"], scaled.square().mean())
    assert all(torch.isfinite(v).all() for v in terms.values())


def test_a_two_point_network_learns_from_its_losses():
    torch.manual_seed(2)
    net = SSPINNposeNet(44, NetworkConfig(hidden=8, layers=1, dropout=0.0, dense=8, grf="two_point"))
    raw, _ = net(torch.randn(1, 20, 44))
    est, body = _estimate(raw)
    batch = Batch(imu=torch.zeros(1, 20, 7, 3), imu_std=torch.ones(7, 3),
                  segments=("pelvis", "femur_r", "tibia_r", "foot_r", "femur_l", "tibia_l", "foot_l"),
                  p=torch.as_tensor(body.vector(), dtype=torch.float32)[None], height=torch.tensor([1.75]), mass=torch.tensor([70.0]),
                  placement=torch.zeros(1, 21), dt=0.01)
    losses = PhysicsLosses(LossWeights(stance=30.0), grf="two_point")
    total = losses.weigh(losses.terms(est, batch), LossWeights(stance=30.0))["total"]
    total.backward()
    grads = [p.grad for p in net.parameters()]
    assert all(g is not None and np.isfinite(g.numpy()).all() for g in grads)
    assert any(g.abs().sum() > 0 for g in grads)
