"""The generated backends (NumPy, torch, CasADi, numba) agree, batch, and differentiate."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
import torch

from sspinn.model import dynamics, kinematics, simulation
from sspinn.model._generated import model_numba
from sspinn.testing import random_inputs


def _all_outputs(x: dict, p, c, imu):
    """Every model function evaluated on one set of inputs (any backend)."""
    grf_sim, w_sim = dynamics.contact_forces(x["q"], x["u"], p, c)
    grf_learned, _ = dynamics.contact_forces(x["q"], x["u"], p, c, mu_hat=x["mu_hat"])
    kin, pot = dynamics.energy(x["q"], x["u"], p)
    return {
        "mass_matrix": dynamics.mass_matrix(x["q"], p),
        "forcing": dynamics.forcing(x["q"], x["u"], x["tau"], x["grf"], x["w"], p),
        "kane_residual": dynamics.kane_residual(x["q"], x["u"], x["qdd"], x["tau"], x["grf"], x["w"], p),
        "forward_dynamics": dynamics.forward_dynamics(x["q"], x["u"], x["tau"], x["grf"], x["w"], p),
        "point_kinematics": kinematics.point_kinematics(x["q"], x["u"], x["qdd"], x["w"], p),
        "segment_kinematics": kinematics.segment_kinematics(x["q"], x["u"], x["qdd"]),
        "virtual_imu": kinematics.virtual_imu(x["q"], x["u"], x["qdd"], imu, p),
        "imu_kinematics": kinematics.imu_kinematics(x["q"], x["u"], x["qdd"], imu, p),
        "kinetic": kin,
        "potential": pot,
        "grf_sim": grf_sim,
        "w_sim": w_sim,
        "grf_learned": grf_learned,
        "contact_from_ankles": dynamics.contact_from_ankles(x["q"], x["u"], x["ankle"], x["mu_hat"], p, c),
    }


def _casadi_eval(fn_outputs: dict, x: dict, p, c, imu) -> dict:
    """Evaluate through CasADi symbols (SX), so the CasADi graph itself is tested."""
    sym = {k: ca.SX.sym(k, v.shape[-1]) for k, v in x.items()}
    out = _all_outputs(sym, ca.DM(p), ca.DM(c), ca.DM(imu))
    f = ca.Function("all", list(sym.values()), list(out.values()))
    res = f(*[ca.DM(v) for v in x.values()])
    return {k: np.array(v) for k, v in zip(out, res)}


def test_backends_agree_float64(rng, body, contact, imu):
    p, c, im = body.vector(), contact.vector(), imu.vector()
    for _ in range(5):
        x = random_inputs(rng)
        ref = _all_outputs(x, p, c, im)
        tor = _all_outputs({k: torch.tensor(v) for k, v in x.items()}, torch.tensor(p), torch.tensor(c), torch.tensor(im))
        cas = _casadi_eval(ref, x, p, c, im)
        for name, value in ref.items():
            scale = max(1.0, float(np.abs(value).max()))
            np.testing.assert_allclose(tor[name].numpy(), value, rtol=0, atol=1e-10 * scale, err_msg=f"torch {name}")
            np.testing.assert_allclose(cas[name].reshape(np.shape(value)), value, rtol=0, atol=1e-10 * scale, err_msg=f"casadi {name}")


def test_numba_kernels_agree(rng, body, contact):
    p, c = body.vector(), contact.vector()
    for _ in range(5):
        x = random_inputs(rng)
        M, f = np.empty((9, 9)), np.empty(9)
        model_numba.mass_matrix_forcing(x["q"], x["u"], x["tau"], x["grf"], x["w"], p, M, f)
        np.testing.assert_allclose(M, dynamics.mass_matrix(x["q"], p), rtol=0, atol=1e-10)
        np.testing.assert_allclose(f, dynamics.forcing(x["q"], x["u"], x["tau"], x["grf"], x["w"], p), rtol=0, atol=1e-9)
        grf, w = np.empty(4), np.empty(2)
        model_numba.contact_simulation(x["q"], x["u"], p, c, grf, w)
        grf_ref, w_ref = dynamics.contact_forces(x["q"], x["u"], p, c)
        np.testing.assert_allclose(grf, grf_ref, rtol=1e-12, atol=1e-10)
        np.testing.assert_allclose(w, w_ref, rtol=0, atol=1e-12)
        gc = np.empty((2, 6))
        model_numba.contact_learned_from_ankles(x["q"], x["u"], x["ankle"], x["mu_hat"], p, c, gc, w)
        np.testing.assert_allclose(gc, dynamics.contact_from_ankles(x["q"], x["u"], x["ankle"], x["mu_hat"], p, c), rtol=1e-12, atol=1e-10)
        qdd_ref = dynamics.forward_dynamics_with_contact(x["q"], x["u"], x["tau"], p, c)[0]
        np.testing.assert_allclose(simulation.accel(x["q"], x["u"], x["tau"], p, c, True), qdd_ref, rtol=1e-9, atol=1e-8)


def test_batching_and_broadcasting(rng, body):
    x = random_inputs(rng, batch=(3, 4))
    r = dynamics.kane_residual(x["q"], x["u"], x["qdd"], x["tau"], x["grf"], x["w"], body)
    assert r.shape == (3, 4, 9)
    single = dynamics.kane_residual(x["q"][1, 2], x["u"][1, 2], x["qdd"][1, 2], x["tau"][1, 2], x["grf"][1, 2], x["w"][1, 2], body)
    np.testing.assert_allclose(r[1, 2], single, rtol=1e-13, atol=1e-10)
    M = dynamics.mass_matrix(torch.tensor(x["q"]), body)
    assert M.shape == (3, 4, 9, 9) and M.dtype == torch.float64


def test_float32_torch(rng, body):
    x = random_inputs(rng, batch=(16,))
    ref = dynamics.kane_residual(x["q"], x["u"], x["qdd"], x["tau"], x["grf"], x["w"], body)
    t = {k: torch.tensor(v, dtype=torch.float32) for k, v in x.items()}
    r32 = dynamics.kane_residual(t["q"], t["u"], t["qdd"], t["tau"], t["grf"], t["w"], body)
    assert r32.dtype == torch.float32
    np.testing.assert_allclose(r32.numpy(), ref, rtol=1e-4, atol=1e-3 * np.abs(ref).max())


@pytest.mark.skipif(not torch.cuda.is_available(), reason="no CUDA device on this machine")
def test_cuda_matches_cpu(rng, body):
    x = {k: torch.tensor(v) for k, v in random_inputs(rng, batch=(8,)).items()}
    cpu = dynamics.kane_residual(x["q"], x["u"], x["qdd"], x["tau"], x["grf"], x["w"], body)
    g = {k: v.cuda() for k, v in x.items()}
    gpu = dynamics.kane_residual(g["q"], g["u"], g["qdd"], g["tau"], g["grf"], g["w"], body)
    torch.testing.assert_close(gpu.cpu(), cpu)


def test_autograd_matches_finite_differences(rng, body, contact, imu):
    """torch.autograd.gradcheck: analytical Jacobians vs central finite differences (float64)."""
    x = {k: torch.tensor(v, requires_grad=True) for k, v in random_inputs(rng, batch=(2,)).items()}
    p = torch.tensor(body.vector(), requires_grad=True)
    c = torch.tensor(contact.vector())
    im = torch.tensor(imu.vector(), requires_grad=True)

    def residual(q, u, qdd, tau, grf, w, p):
        return dynamics.kane_residual(q, u, qdd, tau, grf, w, p)

    assert torch.autograd.gradcheck(residual, (x["q"], x["u"], x["qdd"], x["tau"], x["grf"], x["w"], p), atol=1e-6, rtol=1e-5)
    assert torch.autograd.gradcheck(lambda q, u, qdd, im: kinematics.virtual_imu(q, u, qdd, im, p), (x["q"], x["u"], x["qdd"], im), atol=1e-6, rtol=1e-5)
    q = x["q"].detach().clone()
    q[..., 1] = 0.93  # feet near the ground so the contact forces are non-trivial
    q.requires_grad_(True)
    assert torch.autograd.gradcheck(lambda q, u, mu: dynamics.contact_forces(q, u, p, c, mu_hat=mu)[0], (q, x["u"], x["mu_hat"]), atol=1e-5, rtol=1e-4)
    assert torch.autograd.gradcheck(lambda q, u: simulation.step_torch(q, u, x["tau"], p, c, dt=1e-3, method="rk4")[0], (q, x["u"]), atol=1e-6, rtol=1e-5)
