"""Physics of the model: structure of M and f, energy conservation, exactness of the residual."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from sspinn.model import dynamics, kinematics, passive, simulation
from sspinn.model.contact import ContactParameters
from sspinn.model.conventions import GRAVITY, index
from sspinn.model.dynamics import StateError
from sspinn.testing import on_ground, random_inputs


def standing(body) -> np.ndarray:
    """Upright pose with the soles 1 mm above the ground."""
    q = np.zeros(9)
    q[1] = body.femur_r.length + body.tibia_r.length - body.foot_r.heel[1] + 1e-3
    return q


def test_mass_matrix_symmetric_positive_definite(rng, body):
    for _ in range(10):
        M = dynamics.mass_matrix(random_inputs(rng)["q"], body)
        np.testing.assert_allclose(M, M.T, atol=1e-12)
        assert np.linalg.eigvalsh(M).min() > 0


def test_total_mass_and_static_gravity(body):
    """M[tx,tx] is the total mass; at rest in the air f_y is −m·g and no torque is needed
    to hold the upright pose (all CoMs on the vertical line through the hip)."""
    q = standing(body) + np.array([0, 1.0, 0, 0, 0, 0, 0, 0, 0])
    M = dynamics.mass_matrix(q, body)
    assert M[0, 0] == pytest.approx(body.segment_mass_total)
    f = dynamics.forcing(q, np.zeros(9), np.zeros(6), np.zeros(4), np.full(2, 0.5), body)
    assert f[1] == pytest.approx(-body.segment_mass_total * GRAVITY)
    qdd = dynamics.forward_dynamics(q, np.zeros(9), np.zeros(6), np.zeros(4), np.full(2, 0.5), body)
    np.testing.assert_allclose(qdd, [0, -GRAVITY, 0, 0, 0, 0, 0, 0, 0], atol=1e-8)


def test_torques_are_generalized_forces(rng, body):
    """τ_j enters f only at coordinate j with unit gain (action–reaction at every joint)."""
    x = random_inputs(rng)
    f0 = dynamics.forcing(x["q"], x["u"], np.zeros(6), x["grf"], x["w"], body)
    for j in range(6):
        tau = np.zeros(6)
        tau[j] = 1.0
        df = dynamics.forcing(x["q"], x["u"], tau, x["grf"], x["w"], body) - f0
        np.testing.assert_allclose(df, np.eye(9)[3 + j], atol=1e-12)


def test_inverse_dynamics_round_trip(rng, body):
    x = random_inputs(rng, batch=(5,))
    qdd = dynamics.forward_dynamics(x["q"], x["u"], x["tau"], x["grf"], x["w"], body)
    tau, pelvis = dynamics.inverse_dynamics(x["q"], x["u"], qdd, x["grf"], x["w"], body)
    np.testing.assert_allclose(tau, x["tau"], atol=1e-8)
    np.testing.assert_allclose(pelvis, 0.0, atol=1e-8)


def test_grf_generalized_force_is_jacobian_transpose(rng, body):
    """A unit force at the contact point does virtual work through that point's velocity."""
    x = random_inputs(rng)
    f0 = dynamics.forcing(x["q"], x["u"], x["tau"], np.zeros(4), x["w"], body)
    for k, (col, side) in enumerate([(2, "r"), (3, "r"), (2, "l"), (3, "l")]):
        grf = np.zeros(4)
        grf[k] = 1.0
        df = dynamics.forcing(x["q"], x["u"], x["tau"], grf, x["w"], body) - f0
        row = kinematics.point_index(f"contact_{side}")
        # velocity of the point along x (k even) or y (k odd) is J[row] @ u: probe with unit u
        J = np.array([kinematics.point_kinematics(x["q"], e, np.zeros(9), x["w"], body)[row, col] for e in np.eye(9)])
        np.testing.assert_allclose(df, J, atol=1e-12)


def test_energy_is_conserved_without_contact_damping_or_torques(body):
    """Free flight with spinning joints: RK4 at 1 ms keeps total energy to < 1e-6 (relative)."""
    q0 = standing(body) + np.array([0, 1.0, 0.2, 0.4, -0.8, 0.1, -0.3, -0.2, -0.1])
    u0 = np.array([1.0, 3.0, -1.0, 4.0, -6.0, 5.0, -3.0, 7.0, -4.0])
    traj = simulation.simulate(q0, u0, body, duration=2.0, sample_dt=0.01, substeps=10, contact=None, method="rk4")
    kin, pot = dynamics.energy(traj.q, traj.u, body)
    total = kin + pot
    drift = np.abs(total - total[0]).max() / abs(total[0])
    assert drift < 1e-6, f"relative energy drift {drift:.2e}"
    assert np.ptp(kin) > 0.1 * abs(total[0]), "the test motion must exchange kinetic and potential energy"


@pytest.mark.parametrize("method, order", [("rk4", 4), ("semi_implicit_euler", 1)])
def test_integrators_converge_at_their_order(body, method, order):
    q0 = standing(body) + np.array([0, 0.5, 0.1, 0.3, -0.5, 0.1, -0.2, -0.3, 0.0])
    u0 = np.array([0.5, 0.0, 1.0, 2.0, -3.0, 1.0, -2.0, 3.0, -1.0])
    ref = simulation.simulate(q0, u0, body, duration=0.2, sample_dt=0.2, substeps=800, contact=None, method=method).q[-1]
    errs = [
        np.abs(simulation.simulate(q0, u0, body, duration=0.2, sample_dt=0.2, substeps=n, contact=None, method=method).q[-1] - ref).max()
        for n in (25, 50)
    ]
    assert np.log2(errs[0] / errs[1]) == pytest.approx(order, abs=0.4)


@pytest.mark.slow
@pytest.mark.parametrize("method", simulation.METHODS)
def test_numba_stepper_matches_the_generic_integrators(body, method):
    """The in-place numba stepper (simulate → advance) against the generic integrator definitions of
    sspinn.model.integrators (through step_torch, float64): 0.1 s with contact (≈1 BW peak), random torques,
    and with passive joint moments (evaluated at the start of every substep on both sides)."""
    contact = ContactParameters(slip_velocity=0.2)
    q0 = on_ground(np.array([0, 0, 0.05, 0.2, -0.3, 0.1, -0.1, -0.2, 0.05]), body, clearance=0.002)
    u0 = np.array([1.0, -0.5, 0.2, 0.5, -1.0, 0.5, -0.5, 0.5, -0.2])
    dt, substeps, n = 1e-4, 10, 100
    tau = np.random.default_rng(0).uniform(-30, 30, (n, 6))
    traj = simulation.simulate(q0, u0, body, duration=n * dt * substeps, sample_dt=dt * substeps, substeps=substeps,
                               torques=tau, contact=contact, method=method)
    assert traj.grf[:, 1::2].max() > 0.5 * body.body_weight, "the feet must load the ground"
    p, c = torch.tensor(body.vector()), torch.tensor(contact.vector())
    q, u = torch.tensor(q0), torch.tensor(u0)
    for k in range(n):
        q, u, grf = simulation.step_torch(q, u, torch.tensor(tau[k]), p, c, dt=dt, substeps=substeps, method=method)
        np.testing.assert_allclose(q.numpy(), traj.q[k + 1], rtol=0, atol=1e-12)
        np.testing.assert_allclose(u.numpy(), traj.u[k + 1], rtol=0, atol=1e-11)
        np.testing.assert_allclose(grf.numpy(), traj.grf[k + 1], rtol=0, atol=1e-12 * body.body_weight)

    params = passive.passive_parameters()
    traj = simulation.simulate(q0, u0, body, duration=n * dt * substeps, sample_dt=dt * substeps, substeps=substeps,
                               torques=tau, contact=contact, method=method, passive=params)
    lower, upper = torch.tensor(params[:6]), torch.tensor(params[6:12])
    q, u = torch.tensor(q0), torch.tensor(u0)
    for k in range(n):
        for _ in range(substeps):
            moment = passive.passive_torque(q[3:], u[3:], lower, upper, params[12], params[13])
            q, u, grf = simulation.step_torch(q, u, torch.tensor(tau[k]) + moment, p, c, dt=dt, method=method)
    np.testing.assert_allclose(q.numpy(), traj.q[-1], rtol=0, atol=1e-12)
    np.testing.assert_allclose(u.numpy(), traj.u[-1], rtol=0, atol=1e-11)
    q1, u1, grf1 = simulation.step(q0, u0, tau[0], body.vector(), contact.vector(), dt, substeps, method, passive=params)
    np.testing.assert_array_equal(q1, traj.q[1])  # step and simulate run the same compiled stepper
    np.testing.assert_array_equal(grf1, traj.grf[1])


def test_passive_joint_moments():
    """Damping only inside the range, quadratic soft limits beyond it; NumPy and torch alike."""
    k, b = 1e4, 2.0
    angle = np.array([-1.0, -0.6, 0.0, 2.0, 2.1])
    rate = np.array([1.0, 0.0, -3.0, 0.0, 0.5])
    expected = np.array([k * 0.4**2 - b, 0.0, 6.0, 0.0, -k * 0.1**2 - 1.0])
    np.testing.assert_allclose(passive.passive_torque(angle, rate, -0.6, 2.0, k, b), expected, rtol=1e-12, atol=1e-9)
    t = passive.passive_torque(torch.tensor(angle), torch.tensor(rate), -0.6, 2.0, k, b)
    np.testing.assert_allclose(t.numpy(), expected, rtol=1e-12, atol=1e-9)
    params = passive.passive_parameters({"knee": (-2.0, 0.1)}, stiffness=0.0, damping=0.5)
    assert params.shape == (passive.N_PASSIVE,)
    np.testing.assert_array_equal(params[[1, 4, 7, 10]], [-2.0, -2.0, 0.1, 0.1])
    assert params[0] == passive.DEFAULT_JOINT_RANGE["hip"][0] and tuple(params[12:]) == (0.0, 0.5)
    with pytest.raises(ValueError, match="joint_damping"):
        passive.passive_parameters(damping=-1.0)


def test_kane_residual_of_a_simulated_trajectory_vanishes_as_the_step_shrinks(body, contact):
    """RK4 with ground contact and torques; the trajectory is differentiated independently
    (central differences of the sampled speeds), so the Kane residual measures the integration
    plus differentiation error: O(h²), shrinking ~4× per halving of the step. The default
    forward-simulation friction (v_s = 0.05 m/s) is stiff: explicit RK4 is stable only below
    h ≈ 1.3e-4 s here (measured), so the steps are taken below that."""
    q0 = on_ground(np.array([0, 0, 0.05, 0.2, -0.3, 0.1, -0.1, -0.2, 0.05]), body, clearance=0.005)
    u0 = np.array([1.0, -0.3, 0.2, 0.5, -1.0, 0.5, -0.5, 0.5, -0.2])
    duration = 0.3
    maxima = []
    for h in (6.25e-5, 3.125e-5, 1.5625e-5):
        n = int(round(duration / h))
        tau = np.tile([20.0, -10.0, 5.0, -15.0, 10.0, -5.0], (n, 1))
        traj = simulation.simulate(q0, u0, body, duration=duration, sample_dt=h, substeps=1, torques=tau, contact=contact, method="rk4")
        assert traj.grf[:, 1::2].max() > 0.5 * body.body_weight, "the feet must load the ground"
        qdd = (traj.u[2:] - traj.u[:-2]) / (2 * h)
        q, u = traj.q[1:-1], traj.u[1:-1]
        grf, w = dynamics.contact_forces(q, u, body, contact)
        r = dynamics.kane_residual(q, u, qdd, traj.tau[1:-1], grf, w, body)
        maxima.append(np.abs(r).max() / body.body_weight)
    ratios = [maxima[0] / maxima[1], maxima[1] / maxima[2]]
    assert all(3.0 < ratio < 5.0 for ratio in ratios), (maxima, ratios)
    assert maxima[-1] < 1e-5, f"residual {maxima[-1]:.2e} BW at the smallest step"
    # and with the exact (model) accelerations the residual is at round-off level
    qdd_model = dynamics.forward_dynamics(q, u, traj.tau[1:-1], grf, w, body)
    assert np.abs(dynamics.kane_residual(q, u, qdd_model, traj.tau[1:-1], grf, w, body)).max() < 1e-9 * body.body_weight


def test_nan_states_and_bad_shapes_raise_clear_errors(body):
    q = np.zeros(9)
    q[4] = np.nan
    with pytest.raises(StateError, match=r"q: non-finite value nan at index \(4,\)"):
        dynamics.mass_matrix(q, body)
    with pytest.raises(StateError, match="q: expected last axis of size 9"):
        dynamics.mass_matrix(np.zeros(8), body)
    with pytest.raises(StateError, match="body parameters"):
        dynamics.mass_matrix(np.zeros(9), np.zeros(40))
    with pytest.raises(StateError, match="q0"):
        simulation.simulate(q, np.zeros(9), body, duration=0.1)
    with pytest.raises(ValueError, match="unknown integrator"):
        simulation.simulate(np.zeros(9), np.zeros(9), body, duration=0.1, method="euler")


def test_virtual_imu_at_rest_reads_gravity(body, imu):
    q = standing(body)
    q[index("pelvis_tilt")] = 0.3
    q[index("hip_r")] = -0.3  # right femur vertical again
    sig = kinematics.virtual_imu(q, np.zeros(9), np.zeros(9), imu, body)
    np.testing.assert_allclose(sig[1], [0.0, GRAVITY, 0.0], atol=1e-12)  # femur_r: upright
    np.testing.assert_allclose(sig[0], [GRAVITY * np.sin(0.3), GRAVITY * np.cos(0.3), 0.0], atol=1e-12)


def test_virtual_imu_matches_differentiated_positions(body, imu):
    """The sensor's specific force equals the second derivative of its position (finite
    differences along a smooth motion), rotated into the sensor frame, minus gravity."""
    t = np.linspace(0, 1, 2001)
    h = t[1] - t[0]
    amp = np.array([0.3, 0.05, 0.2, 0.5, -0.6, 0.3, -0.4, -0.5, 0.2])
    q = amp * np.sin(2 * np.pi * t[:, None] * np.arange(1, 10) / 3)
    u = np.gradient(q, h, axis=0)
    qdd = np.gradient(u, h, axis=0)
    sig = kinematics.virtual_imu(q, u, qdd, imu, body)
    seg = 2  # tibia_r: sensor at its position in the tibia frame (origin knee)
    pk = kinematics.point_kinematics(q, u, qdd, np.zeros((len(t), 2)), body)
    knee = pk[:, kinematics.point_index("knee_r"), :2]
    theta = kinematics.segment_kinematics(q, u, qdd)[:, seg, 0]
    x, y = imu.positions["tibia_r"]
    pos = knee + np.stack([x * np.cos(theta) - y * np.sin(theta), x * np.sin(theta) + y * np.cos(theta)], -1)
    np.testing.assert_allclose(kinematics.imu_kinematics(q, u, qdd, imu, body)[:, seg, :2], pos, atol=1e-12)
    acc = np.gradient(np.gradient(pos, h, axis=0), h, axis=0)
    acc[:, 1] += GRAVITY
    along_x = acc[:, 0] * np.cos(theta) + acc[:, 1] * np.sin(theta)
    sl = slice(10, -10)
    np.testing.assert_allclose(sig[sl, seg, 0], along_x[sl], atol=5e-3 * np.abs(along_x).max())
    np.testing.assert_allclose(sig[:, seg, 2], u[:, 2] + u[:, 3] + u[:, 4], atol=1e-12)


def test_contact_model_behaviour(body, contact):
    q = standing(body)
    u = np.zeros(9)
    # 2 cm above the ground: essentially no force (the softplus transition is 1/β ≈ 3 mm wide)
    grf, w = dynamics.contact_forces(q + np.eye(9)[1] * 0.019, u, body, contact)
    assert grf[1] < 1e-3 * body.body_weight
    np.testing.assert_allclose(w, 0.5)  # flat feet: halfway between toe and heel
    # 1 cm penetration, at rest: F_y ≈ k·d·BW = 1 BW per foot
    q[1] -= 0.011
    grf, _ = dynamics.contact_forces(q, u, body, contact)
    assert grf[1] == pytest.approx(body.body_weight, rel=0.02)
    # sliding forward: friction points backward, bounded by μ·F_y
    u[0] = 1.0
    grf, _ = dynamics.contact_forces(q, u, body, contact)
    assert -contact.friction * grf[1] <= grf[0] < 0
    # learned friction: μ_max·tanh(μ̂)·F_y
    grf_l, _ = dynamics.contact_forces(q, np.zeros(9), body, contact, mu_hat=np.array([10.0, -10.0]))
    assert grf_l[0] == pytest.approx(contact.friction_max * grf_l[1], rel=1e-6)
    assert grf_l[2] == pytest.approx(-contact.friction_max * grf_l[3], rel=1e-6)
    # toes up → contact at the heel
    q[index("ankle_r")] = 0.5
    assert dynamics.contact_forces(q, u, body, contact)[1][0] > 0.99


def test_contact_from_ankles_equals_forward_kinematics_contact(rng, body, contact):
    x = random_inputs(rng, batch=(6,))
    x["q"][..., 1] = 0.92  # feet around the ground
    pk = kinematics.point_kinematics(x["q"], x["u"], x["qdd"], np.zeros((6, 2)), body)
    ankle = np.concatenate([pk[:, kinematics.point_index(f"ankle_{s}"), :4] for s in "rl"], axis=-1)
    out = dynamics.contact_from_ankles(x["q"], x["u"], ankle, x["mu_hat"], body, contact)
    grf, w = dynamics.contact_forces(x["q"], x["u"], body, contact, mu_hat=x["mu_hat"])
    np.testing.assert_allclose(out[..., :2].reshape(6, 4), grf, rtol=1e-10, atol=1e-9)
    assert np.abs(grf[:, 1::2]).max() > 1.0, "the test must load at least one foot"
    contact_pts = kinematics.point_kinematics(x["q"], x["u"], x["qdd"], w, body)
    for i, s in enumerate("rl"):
        np.testing.assert_allclose(out[:, i, 2:], contact_pts[:, kinematics.point_index(f"contact_{s}"), :4], atol=1e-12)
