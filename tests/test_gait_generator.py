"""Self-supervised gait generator: representation, losses, training/resume, generation."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from predictive.generator.gait_generator import (
    GaitGeneratorNet,
    GaitLosses,
    GeneratorConfig,
    GeneratorTrainer,
    cycle,
    fourier_basis,
    generate,
    load_generator,
)
from sspinn.model import dynamics
from sspinn.model.body import BodyParameters


def test_fourier_basis_derivatives_match_finite_differences() -> None:
    phase = torch.linspace(0, 1, 50, dtype=torch.float64)
    h = 1e-6
    b, d1, d2 = fourier_basis(phase, 4)
    bp, d1p, _ = fourier_basis(phase + h, 4)
    bm, d1m, _ = fourier_basis(phase - h, 4)
    torch.testing.assert_close(d1, (bp - bm) / (2 * h), atol=1e-5, rtol=1e-6)
    torch.testing.assert_close(d2, (d1p - d1m) / (2 * h), atol=1e-3, rtol=1e-6)


def _random_generator(seed: int = 0) -> GaitGeneratorNet:
    torch.manual_seed(seed)
    g = GaitGeneratorNet(harmonics=4, hidden=16, layers=2).double()
    torch.nn.init.normal_(g.head.weight, std=0.5)
    torch.nn.init.normal_(g.head.bias, std=0.5)
    return g


def test_cycle_is_symmetric_periodic_and_has_the_target_speed() -> None:
    g = _random_generator()
    v, T, hip = torch.tensor([1.7], dtype=torch.float64), torch.tensor([1.0], dtype=torch.float64), torch.tensor([0.9], dtype=torch.float64)
    coeffs = g(v, torch.tensor([1.8], dtype=torch.float64), torch.tensor([80.0], dtype=torch.float64))
    phase = torch.arange(40, dtype=torch.float64) / 40
    q, u, qdd = cycle(coeffs, v, T, hip, phase)
    q2, _, _ = cycle(coeffs, v, T, hip, phase + 0.5)
    torch.testing.assert_close(q2[0, :, 6:], q[0, :, 3:6])  # left leg = right leg half a cycle later
    torch.testing.assert_close(q2[0, :, 1:3], q[0, :, 1:3])  # pelvis y, tilt: period T/2
    q1, _, _ = cycle(coeffs, v, T, hip, phase + 1.0)
    torch.testing.assert_close(q1[0, :, 0] - q[0, :, 0], torch.full((40,), 1.7, dtype=torch.float64))  # v·T per cycle
    assert u[0, :, 0].mean().item() == pytest.approx(1.7, abs=1e-12)
    assert q[0, :, 1].mean().item() == pytest.approx(0.9 + 0.03 * float(g.raw(v, torch.tensor([1.8]).double(), torch.tensor([80.0]).double())[0, 1, 0].detach()), abs=1e-9)


def test_losses_use_inverse_dynamics_consistently() -> None:
    """τ and the pelvis residual from GaitLosses.physics reproduce the Kane residual: with τ the
    joint rows vanish and the pelvis rows are the reported residual."""
    g = _random_generator(1)
    body = BodyParameters.from_anthropometry(1.7, 65.0)
    one = lambda x: torch.tensor([x], dtype=torch.float64)  # noqa: E731
    q, u, qdd = cycle(g(one(1.3), one(1.7), one(65.0)), one(1.3), one(1.14), one(body.standing_hip_height), torch.arange(20, dtype=torch.float64) / 20)
    p = torch.as_tensor(body.vector())
    ph = GaitLosses(GeneratorConfig()).physics(q[0], u[0], qdd[0], p)
    r = dynamics.kane_residual(q[0], u[0], qdd[0], ph["tau"], ph["grf"], ph["w"], p)
    torch.testing.assert_close(r[:, 3:], torch.zeros_like(r[:, 3:]), atol=1e-8, rtol=0)
    torch.testing.assert_close(r[:, :3], ph["root"])
    terms = GaitLosses(GeneratorConfig())(q, u, qdd, p[None, None], one(1.7), one(65.0), one(1.14))
    assert all(torch.isfinite(v) for v in terms.values())
    assert terms["kane_rms_bw"].item() == pytest.approx(
        math.sqrt(float(((r[:, 0] ** 2 + r[:, 1] ** 2) / (65 * 9.81) ** 2 + (r[:, 2] / (65 * 9.81 * 1.7)) ** 2).mean().detach())), rel=1e-9)


def _tiny(**kw) -> GeneratorConfig:
    return GeneratorConfig(harmonics=3, hidden=16, layers=1, points=8, batch_size=4, warmup_steps=3, steps=4,
                           checkpoint_every=2, snapshot_every=3, log_every=1, **kw)


def test_training_resume_is_exact_and_writes_its_files(tmp_path) -> None:
    straight = GeneratorTrainer(_tiny(), tmp_path / "a")
    straight.fit()
    assert (tmp_path / "a" / "generator.pt").exists() and (tmp_path / "a" / "history.csv").exists()
    assert len(list((tmp_path / "a" / "snapshots").glob("generator_*.pt"))) == 2
    first = GeneratorTrainer(_tiny(), tmp_path / "b")
    first.config.steps = 1  # stop after warm-up + 1 step, then resume to the full length
    first.fit()
    second = GeneratorTrainer(_tiny(), tmp_path / "b")
    second.fit(resume=True)
    assert second.step == straight.step == 7
    for x, y in zip(straight.model_.state_dict().values(), second.model_.state_dict().values()):
        torch.testing.assert_close(x, y)
    model, cfg = load_generator(tmp_path / "a" / "generator.pt")
    sol = generate(model, 1.3, n=40, config=cfg)
    assert sol.q.shape == (40, 9) and sol.tau.shape == (40, 6) and sol.status == "generated"
    grf, w = dynamics.contact_forces(sol.q, sol.u, sol.body, sol.contact_parameters)
    r = dynamics.kane_residual(sol.q, sol.u, sol.qdd, sol.tau, grf, w, sol.body)
    np.testing.assert_allclose(r[:, 3:], 0, atol=1e-8)  # τ from inverse dynamics (analytic q̈)
    refined = generate(model, 1.3, n=40, config=cfg, refine_iterations=5)
    assert refined.status == "refined"
    with pytest.raises(FileNotFoundError, match="no gait generator"):
        load_generator(tmp_path / "missing.pt")
    with pytest.raises(FileNotFoundError, match="no checkpoint"):
        GeneratorTrainer(_tiny(), tmp_path / "c").fit(resume=True)


def test_the_generator_object_fits_predicts_saves_and_loads(tmp_path) -> None:
    """GaitGenerator: construct with settings → fit → predict → save/load, the same gait before and
    after; the training range and an unfitted generator are clear errors."""
    from predictive.generator import GaitGenerator
    from predictive.ocp.limits import RequestError

    with pytest.raises(RequestError, match="no trained network"):
        GaitGenerator(_tiny()).predict(1.3)
    generator = GaitGenerator(_tiny()).fit(tmp_path / "run")
    assert generator.steps_ == 7 and len(generator.history_) == 7 and generator.training_wall_s_ > 0
    walk = generator.predict(1.3, n=40)
    assert walk.q.shape == (40, 9) and walk.status == "generated"
    again = GaitGenerator.load(generator.save(tmp_path / "copy.pt"))
    np.testing.assert_array_equal(again.predict(1.3, n=40).q, walk.q)
    np.testing.assert_array_equal(GaitGenerator.load(tmp_path / "run" / "generator.pt").predict(1.3, n=40).q, walk.q)
    assert again.config == generator.config and again.steps_ is None
    assert again.outside_training_range(9.0, 1.75, 70.0) and not again.outside_training_range(1.3, 1.75, 70.0)
    with pytest.raises(RequestError, match="outside its training range"):
        again.predict(9.0)


def test_bad_generator_config() -> None:
    with pytest.raises(ValueError, match="speeds"):
        GeneratorConfig(speeds=(2.0, 1.0))
    with pytest.raises(ValueError, match="points"):
        GeneratorConfig(points=0)


def test_generator_config_yaml(tmp_path) -> None:
    path = tmp_path / "g.yaml"
    path.write_text("generator:\n  steps: 5\n  weights: {kane: 10.0}\n")
    cfg = GeneratorConfig.from_yaml(path)
    assert cfg.steps == 5 and cfg.weights.kane == 10.0 and cfg.weights.effort == 1.0
    path.write_text("generator:\n  stepz: 5\n")
    with pytest.raises(ValueError, match=r"g.yaml: unknown generator option\(s\) \['stepz'\]"):
        GeneratorConfig.from_yaml(path)
    with pytest.raises(FileNotFoundError, match="no such configuration file"):
        GeneratorConfig.from_yaml(tmp_path / "missing.yaml")


def test_generator_cli_set_overrides(tmp_path) -> None:
    from predictive.__main__ import main

    cfg = tmp_path / "g.yaml"
    cfg.write_text("generator: {harmonics: 2, hidden: 8, layers: 1, points: 4, batch_size: 2, warmup_steps: 1, steps: 50, snapshot_every: 0}\n")
    assert main(["train-generator", "--config", str(cfg), "--out", str(tmp_path / "run"), "--set", "steps=2"]) == 0
    assert GeneratorConfig.from_yaml(tmp_path / "run" / "config.yaml").steps == 2
    assert main(["train-generator", "--config", str(cfg), "--out", str(tmp_path / "run2"), "--set", "stepz"]) == 2


def test_polish_stage_lowers_the_grid_loss_and_resumes_exactly(tmp_path) -> None:
    polish = {"polish_iterations": 50, "polish_points": 4, "polish_speed_step": 1.0}
    straight = GeneratorTrainer(_tiny(**polish), tmp_path / "a")
    straight.fit()
    assert straight.step == 57 and straight.step == straight.total_steps
    polished = [r for r in straight.history_ if r["step"] > straight.adam_steps]
    assert len(polished) >= 2 and polished[-1]["total"] < polished[0]["total"]
    first = GeneratorTrainer(_tiny(**{**polish, "polish_iterations": 25}), tmp_path / "b")
    first.fit()  # stops after one chunk of the polish stage
    second = GeneratorTrainer(_tiny(**polish), tmp_path / "b")
    second.fit(resume=True)
    assert second.step == 57
    for x, y in zip(straight.model_.state_dict().values(), second.model_.state_dict().values()):
        torch.testing.assert_close(x, y)
    with pytest.raises(ValueError, match="polish_factor"):
        GeneratorConfig(polish_factor=0.0)


def test_clearance_term_penalises_a_swing_foot_near_the_ground_only() -> None:
    body = BodyParameters.from_anthropometry()
    weights = {"kane": 0.0, "effort": 0.0, "w_acc": 0.0, "bounds": 0.0, "slide": 0.0, "clearance": 1.0}
    losses = GaitLosses(GeneratorConfig(weights=weights, clearance_height=0.03))
    one = lambda x: torch.tensor([x], dtype=torch.float64)  # noqa: E731
    q = torch.zeros(1, 1, 9, dtype=torch.float64)
    u = torch.zeros(1, 1, 9, dtype=torch.float64)
    u[..., 0] = 1.0  # pelvis forward at 1 m/s
    u[..., 3] = 4.0  # right hip flexing: the right foot moves forward faster than the pelvis (swing)
    u[..., 6] = -4.0  # left hip extending: the left foot moves backward relative to the pelvis (stance)
    p = torch.as_tensor(body.vector())[None, None]

    def clearance(hip_height: float) -> float:
        q[..., 1] = hip_height
        terms = losses(q, u, torch.zeros_like(q), p, one(body.height), one(body.mass), one(1.0))
        return float(terms["clearance"])

    on_ground = clearance(body.standing_hip_height)
    assert 1.5 < on_ground < 2.1  # heel and toe of the swing foot at the ground: (1 - 0/c)² each
    assert clearance(body.standing_hip_height + 0.1) < 1e-6  # 10 cm up: clear
