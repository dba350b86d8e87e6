"""The trajectory type (sspinn.model.trajectory): validation, slicing, resampling, files and the one
Kane residual, and the classes built on it."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from sspinn.data.dataset import DataFormatError, Labels
from sspinn.model import dynamics, simulation
from sspinn.model.conventions import COORDINATES
from sspinn.model.trajectory import COLUMNS, FIELDS, Trajectory, TrajectoryError, residual_scale
from sspinn.testing import on_ground, random_inputs


def random_trajectory(n: int = 12, seed: int = 0, dt: float = 0.01) -> Trajectory:
    x = random_inputs(np.random.default_rng(seed), (n,))
    return Trajectory(time=np.arange(n) * dt, **{k: x[k] for k in ("q", "u", "qdd", "tau", "grf", "w")})


@pytest.fixture(scope="module")
def landing(body, contact):
    """0.1 s of RK4 (h = 0.1 ms) with contact and torques: the feet land and load the ground."""
    h = 1e-4
    q0 = on_ground(np.array([0, 0, 0.05, 0.2, -0.3, 0.1, -0.1, -0.2, 0.05]), body, clearance=0.005)
    u0 = np.array([1.0, -0.3, 0.2, 0.5, -1.0, 0.5, -0.5, 0.5, -0.2])
    tau = np.tile([20.0, -10.0, 5.0, -15.0, 10.0, -5.0], (1000, 1))
    sim = simulation.simulate(q0, u0, body, duration=0.1, sample_dt=h, substeps=1, torques=tau, contact=contact, method="rk4")
    assert sim.grf[:, 1::2].max() > 0.5 * body.body_weight, "the feet must load the ground"
    return sim, h


# ---------------------------------------------------------------------------------- validation
@pytest.mark.parametrize(
    ("field", "value", "message"),
    [
        ("q", np.zeros((12, 8)), r"Trajectory\.q: expected shape \(12, 9\) \(12 samples, as time\), got \(12, 8\)"),
        ("tau", np.zeros((11, 6)), r"Trajectory\.tau: expected shape \(12, 6\)"),
        ("w", np.zeros(12), r"Trajectory\.w: expected shape \(12, 2\)"),
        ("time", np.zeros((12, 1)), r"Trajectory\.time: expected shape \(n,\), got \(12, 1\)"),
        ("grf", [["a"] * 4] * 12, r"Trajectory\.grf: not an array of numbers"),
    ],
)
def test_a_field_of_the_wrong_shape_is_named(field, value, message) -> None:
    arrays = random_trajectory().arrays()
    with pytest.raises(TrajectoryError, match=message):
        Trajectory(**{**arrays, field: value})


def test_non_finite_values_are_allowed_until_checked() -> None:
    traj = random_trajectory()
    traj.grf[5, 1] = np.nan
    assert traj.non_finite() == ("grf", 5, 1)
    with pytest.raises(TrajectoryError, match="grf is not finite from sample 5 on"):
        traj.check_finite()
    assert random_trajectory().check_finite().n_samples == 12


def test_lists_become_float_arrays_and_arrays_are_not_copied() -> None:
    arrays = random_trajectory().arrays()
    traj = Trajectory(**{**arrays, "time": list(range(12))})
    assert traj.time.dtype == np.float64 and traj.q is arrays["q"]


# ---------------------------------------------------------------------------------- slicing
def test_slicing_and_windows() -> None:
    traj = random_trajectory()
    part = traj[2:7]
    assert type(part) is Trajectory and part.n_samples == 5
    for name in FIELDS:
        np.testing.assert_array_equal(getattr(part, name), getattr(traj, name)[2:7])
    assert traj[::3].n_samples == 4
    window = traj.window(0.025, 0.06)  # samples at 0.03, 0.04, 0.05
    np.testing.assert_array_equal(window.time, traj.time[3:6])
    with pytest.raises(TypeError, match="sliced by a slice"):
        traj[3]


def test_columns_are_the_label_columns() -> None:
    traj = random_trajectory()
    cols = traj.columns()
    assert list(cols) == ["time", *(c for names in COLUMNS.values() for c in names)]
    np.testing.assert_array_equal(cols["d_knee_r"], traj.u[:, COORDINATES.index("knee_r")])
    np.testing.assert_array_equal(cols["w_l"], traj.w[:, 1])


# ---------------------------------------------------------------------------------- resampling
def test_linear_resampling_is_exact_at_the_original_times() -> None:
    traj = random_trajectory()
    same = traj.resample(traj.time)
    for name in FIELDS:
        np.testing.assert_array_equal(getattr(same, name), getattr(traj, name))
    mid = traj.resample([0.015])
    np.testing.assert_allclose(mid.tau[0], 0.5 * (traj.tau[1] + traj.tau[2]), rtol=1e-14)
    with pytest.raises(TrajectoryError, match="outside the trajectory"):
        traj.resample([0.2])


def test_periodic_resampling_continues_the_cycle() -> None:
    traj = random_trajectory()
    T, v = 0.12, 1.3  # 12 samples, 0.01 s apart
    traj.q[:, 0] = v * traj.time + 0.01 * np.sin(2 * np.pi * traj.time / T)
    same = traj.resample(traj.time, period=T, speed=v)
    np.testing.assert_allclose(same.q, traj.q, rtol=0, atol=1e-15)
    np.testing.assert_array_equal(same.u, traj.u)
    later = traj.resample(traj.time + 2 * T, period=T, speed=v)  # two cycles on: pelvis_tx moved 2·v·T
    np.testing.assert_allclose(later.q[:, 0], traj.q[:, 0] + 2 * v * T, atol=1e-14)
    np.testing.assert_allclose(later.q[:, 1:], traj.q[:, 1:], atol=1e-14)
    wrap = traj.resample([0.115], period=T, speed=v)  # between the last sample and the next cycle's first
    np.testing.assert_allclose(wrap.tau[0], 0.5 * (traj.tau[-1] + traj.tau[0]), rtol=1e-12)
    with pytest.raises(TrajectoryError, match="must exceed"):
        traj.resample(traj.time, period=0.1)


def test_spline_resampling_is_kinematically_consistent() -> None:
    n, T = 50, 1.0
    t = np.arange(n) * T / n
    traj = random_trajectory(n)
    traj.time = t
    traj.q[:] = np.sin(2 * np.pi * t / T)[:, None]
    traj.q[:, 0] += 1.5 * t
    fine = np.linspace(0.0, 3 * T, 301)
    smooth = traj.resample(fine, period=T, speed=1.5, method="spline")
    w = 2 * np.pi / T
    np.testing.assert_allclose(smooth.q[:, 3], np.sin(w * fine), atol=1e-5)
    np.testing.assert_allclose(smooth.u[:, 3], w * np.cos(w * fine), atol=1e-3)
    np.testing.assert_allclose(smooth.qdd[:, 3], -(w**2) * np.sin(w * fine), atol=0.1)
    np.testing.assert_allclose(smooth.u[:, 0], 1.5 + w * np.cos(w * fine), atol=1e-3)
    np.testing.assert_allclose(traj.resample(t, period=T, speed=1.5, method="spline").q, traj.q, atol=1e-14)


# ---------------------------------------------------------------------------------- files
def test_save_load_round_trip(tmp_path: Path) -> None:
    traj = random_trajectory()
    path = traj.save(tmp_path / "walk_1.3")
    assert path.name == "walk_1.3.npz" and [p.name for p in tmp_path.iterdir()] == ["walk_1.3.npz"]
    back = Trajectory.load(path)
    for name in FIELDS:
        np.testing.assert_array_equal(getattr(back, name), getattr(traj, name))
    assert Trajectory.load(tmp_path / "walk_1.3").n_samples == 12


def test_non_finite_values_are_not_written(tmp_path: Path) -> None:
    traj = random_trajectory()
    traj.u[3, 4] = np.inf
    traj.w[0, 0] = np.nan
    with pytest.raises(TrajectoryError, match=r"refusing to write a trajectory with non-finite \['u', 'w'\]"):
        traj.save(tmp_path / "t.npz")
    assert not list(tmp_path.iterdir())


def test_unreadable_trajectory_files_are_named(tmp_path: Path) -> None:
    (tmp_path / "junk.npz").write_bytes(b"junk")
    with pytest.raises(TrajectoryError, match="junk.npz: not a readable trajectory file"):
        Trajectory.load(tmp_path / "junk.npz")
    np.savez(tmp_path / "partial.npz", time=np.zeros(3))
    with pytest.raises(TrajectoryError, match=r"partial.npz: not a trajectory file \(no \['q'"):
        Trajectory.load(tmp_path / "partial.npz")
    arrays = random_trajectory().arrays()
    arrays["q"] = arrays["q"].copy()
    arrays["q"][1, 1] = np.nan
    np.savez(tmp_path / "nan.npz", **arrays)
    with pytest.raises(TrajectoryError, match="nan.npz: Trajectory: q is not finite from sample 1"):
        Trajectory.load(tmp_path / "nan.npz")
    with pytest.raises(FileNotFoundError):
        Trajectory.load(tmp_path / "none")


# ---------------------------------------------------------------------------------- Kane residual
def test_residual_of_a_simulated_trajectory(landing, body, contact) -> None:
    """The one residual is sspinn.model.dynamics.kane_residual scaled by BW and BW·H, with the stored
    GRF or the contact model's; with the model's own accelerations it vanishes."""
    sim, h = landing
    q, u, tau = sim.q[1:-1], sim.u[1:-1], sim.tau[1:-1]
    qdd = (sim.u[2:] - sim.u[:-2]) / (2 * h)  # differentiated independently of the integrator
    traj = Trajectory.from_contact_model(sim.t[1:-1], q, u, qdd, tau, body, contact)
    grf, w = dynamics.contact_forces(q, u, body, contact)
    np.testing.assert_array_equal(traj.grf, grf)
    expected = dynamics.kane_residual(q, u, qdd, tau, grf, w, body) / residual_scale(body)
    np.testing.assert_array_equal(traj.kane_residual(body), expected)
    np.testing.assert_array_equal(traj.kane_residual(body, contact), expected)
    assert 0 < np.abs(expected).max() < 1e-3  # O(h²) integration and differentiation error
    scale = residual_scale(body)
    assert scale[0] == scale[1] == body.body_weight and (scale[2:] == body.body_weight * body.height).all()
    # stored forces are used as they are; the contact model replaces them
    unloaded = traj.as_trajectory(grf=np.zeros_like(traj.grf))
    assert np.abs(unloaded.kane_residual(body)[:, 1]).max() > 0.4
    np.testing.assert_array_equal(unloaded.kane_residual(body, contact), expected)
    exact = traj.as_trajectory(qdd=dynamics.forward_dynamics(q, u, tau, grf, w, body))
    assert np.abs(exact.kane_residual(body)).max() < 1e-11


def test_gait_solution_node_residual_is_the_trajectory_residual(landing, body, contact) -> None:
    from predictive.ocp.solution import GaitSolution

    sim, h = landing
    n = 400
    q, u = sim.q[:n], sim.u[:n]
    sol = GaitSolution(
        time=sim.t[:n], q=q, u=u, qdd=np.zeros((n, 9)), tau=sim.tau[:n], grf=sim.grf[:n], w=np.zeros((n, 2)),
        speed=1.0, duration=n * h, body_parameters=body.to_dict(), contact=dataclasses.asdict(contact),
    )
    assert isinstance(sol, Trajectory) and sol.n_nodes == n
    # the definition: q̈ = backward differences of u (periodic), GRF from the contact model
    qdd = (u - np.roll(u, 1, axis=0)) / h
    grf, w = dynamics.contact_forces(q, u, body, contact)
    expected = dynamics.kane_residual(q, u, qdd, sim.tau[:n], grf, w, body) / residual_scale(body)
    np.testing.assert_allclose(sol.node_residual(), expected, rtol=1e-12, atol=1e-12)
    np.testing.assert_array_equal(sol.node_residual(), sol.as_trajectory(qdd=qdd).kane_residual(body, contact))
    # a backward-Euler-consistent motion: small away from the wrap-around node
    assert np.abs(sol.node_residual()[1:]).max() < 1e-2


# ---------------------------------------------------------------------------------- labels and subclasses
def test_labels_give_a_trajectory_when_complete() -> None:
    traj = random_trajectory()
    labels = Labels.from_trajectory(traj, speed=np.full(12, 1.2))
    back = labels.trajectory(traj.time)
    for name in FIELDS:
        np.testing.assert_array_equal(getattr(back, name), getattr(traj, name))
    np.testing.assert_array_equal(labels.trajectory().time, np.arange(12) / 100.0)
    assert labels.speed.shape == (12,) and labels.q is not traj.q
    cols = {c: v for c, v in traj.columns().items() if c != "time"}
    del cols["tau_knee_l"]
    partial = Labels.from_columns(cols, 12)
    with pytest.raises(DataFormatError, match=r"no column\(s\) \['tau_knee_l'\]"):
        partial.trajectory()
    with pytest.raises(DataFormatError, match="no tau labels, no grf labels"):
        Labels(q=traj.q, u=traj.u, qdd=traj.qdd, w=traj.w).trajectory()


def test_the_subclasses_check_their_own_per_sample_fields() -> None:
    from predictive.synth.chain import ChainResult
    from sspinn.estimator.inference import GaitEstimate, NonFiniteEstimateError

    arrays = random_trajectory().arrays()
    n = len(arrays["time"])
    extra = {"q_prev": np.zeros(9), "u_prev": np.zeros(9), "strides": [], "h": 0.01}
    chain = ChainResult(**arrays, speed=np.ones(n), stride=np.zeros(n), **extra)
    assert isinstance(chain, Trajectory) and type(chain[2:4]) is Trajectory
    with pytest.raises(TrajectoryError, match=rf"ChainResult\.speed: expected shape \({n},\)"):
        ChainResult(**arrays, speed=np.ones((n, 2)), stride=np.zeros(n), **extra)
    chain.stride[7] = np.nan
    assert chain.non_finite() == ("stride", 7, 1)
    est = GaitEstimate(**arrays, name="e")
    est.grf[7, 0] = np.nan
    with pytest.raises(NonFiniteEstimateError, match="e: the estimate's grf is not finite from sample 7 on"):
        est.check_finite()


def test_a_chain_file_keeps_its_format(tmp_path: Path, body) -> None:
    """The synthetic cache's chain files hold no ``time`` (it is k·h): the format did not change."""
    from predictive.synth.chain import ChainResult, StrideRecord

    traj = random_trajectory(6)
    record = StrideRecord(0, 1.2, 6, "Solve_Succeeded", 10, 0.5, 1, 1.0, 1e-9, planned_speed=1.2)
    chain = ChainResult(
        **traj.arrays(), speed=np.full(6, 1.2), stride=np.zeros(6, np.int64), q_prev=traj.q[0], u_prev=traj.u[0],
        strides=[record], h=0.01,
    )
    path = chain.save(tmp_path / "c")
    with np.load(path) as data:
        assert data.files == ["h", "strides", "ended_early", "q", "u", "qdd", "tau", "grf", "w", "speed", "stride", "q_prev", "u_prev"]
    back = ChainResult.load(path)
    np.testing.assert_allclose(back.time, traj.time, rtol=0, atol=1e-15)
    np.testing.assert_array_equal(back.kane_residual(body), chain.kane_residual(body))
    assert back.strides == [record]
