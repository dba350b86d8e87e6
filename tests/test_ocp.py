"""Predictive gait simulation (predictive/): small collocation problems that solve in seconds."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from predictive import (
    DEFAULT_STARTS,
    GaitSolution,
    OCPError,
    OCPSettings,
    Start,
    solve_predictive,
    typical_stride_duration,
)
from predictive.__main__ import main as cli_main
from predictive.ocp.gait_analysis import (
    compare_with_reference,
    load_winter,
    normalised_cycle,
    plot_gait,
    solution_norms,
)
from predictive.ocp.solution import MIRROR_Q, MIRROR_TAU

#: every test here solves optimal-control problems, generates data or trains: the quick loop skips them
pytestmark = pytest.mark.slow

#: ../shared/data (optional real recordings; see tests/conftest.py)
SHARED_DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"


@pytest.fixture(scope="module")
def slow_walk() -> GaitSolution:
    """Walking at 1.2 m/s on a coarse grid (25 nodes per half cycle): a few s. On 15 nodes one of
    four 1e-9 guess perturbations (scripts/check_robustness.py) ended in a hopping gait (flight
    0.47, objective 1.40 instead of 0.19); on 25 nodes all walked (objectives 0.200–0.206)."""
    return solve_predictive(1.2, n_nodes=25)


@pytest.fixture(scope="module")
def standing() -> GaitSolution:
    return solve_predictive(0.0, n_nodes=6, duration=0.4)


def _kinematic_residual(sol: GaitSolution) -> float:
    """max |(q_k − q_{k−1})/h − u_k| over the cycle, the wrap-around (one stride back) included."""
    h = sol.duration / sol.n_nodes
    q_prev = np.roll(sol.q, 1, axis=0)
    q_prev[0, 0] -= sol.stride_length
    return float(np.abs((sol.q - q_prev) / h - sol.u).max())


def test_standing_solves_with_both_feet_loaded(standing: GaitSolution) -> None:
    assert standing.status == "Solve_Succeeded" and standing.success
    assert np.abs(standing.node_residual()).max() < 1e-6
    stance = standing.stance_fractions()
    assert stance["double_support"] == 1.0
    # both feet share the body weight (vertical GRF sums to 1 BW when nothing accelerates)
    np.testing.assert_allclose(standing.grf_bw()[:, [1, 3]].sum(axis=1), 1.0, atol=1e-3)
    np.testing.assert_allclose(standing.q[:, 0], 0.0, atol=1e-6)  # still, to IPOPT's tolerance


def test_slow_walk_satisfies_dynamics_and_periodicity(slow_walk: GaitSolution) -> None:
    sol = slow_walk
    assert sol.status == "Solve_Succeeded"
    assert sol.iterations > 0 and sol.solve_time > 0
    # Kane residual with the NumPy backend at the nodes (BW and BW·H), GRF recomputed
    assert np.abs(sol.node_residual()).max() < 1e-6
    assert _kinematic_residual(sol) < 1e-6
    # average speed and stride
    assert sol.duration == pytest.approx(typical_stride_duration(1.2))
    assert sol.stride_length == pytest.approx(1.2 * sol.duration)
    assert np.mean(sol.u[:, 0]) == pytest.approx(1.2, abs=1e-6)
    # symmetric half cycle: the second half mirrors the first
    n = sol.n_nodes // 2
    np.testing.assert_allclose(sol.q[n:, 1:], sol.q[:n][:, MIRROR_Q][:, 1:])
    np.testing.assert_allclose(sol.tau[n:], sol.tau[:n][:, MIRROR_TAU])
    # walking: each foot on the ground for more than half the cycle, no flight
    stance = sol.stance_fractions()
    assert stance["stance_r"] > 0.5 and stance["flight"] == 0.0
    # within the joint limits (knee flexion negative)
    assert np.all(sol.q[:, [4, 7]] <= 1e-6)


def test_data_free_solve_is_a_multi_start_won_by_the_lowest_objective(slow_walk: GaitSolution) -> None:
    starts = slow_walk.starts
    assert len(starts) == len(DEFAULT_STARTS) and sum(s["chosen"] for s in starts) == 1
    solved = [s for s in starts if s["status"] == "Solve_Succeeded"]
    chosen = next(s for s in starts if s["chosen"])
    assert chosen["objective"] == slow_walk.objective == min(s["objective"] for s in solved)
    assert [s["amplitude"] for s in starts] == [s.amplitude for s in DEFAULT_STARTS]


def test_a_failed_start_is_not_chosen() -> None:
    # the second start may take 2 iterations only: it cannot succeed, the first one must win
    starts = (Start(), Start(ipopt_options={"max_iter": 2}))
    sol = solve_predictive(0.0, n_nodes=6, duration=0.4, starts=starts)
    assert sol.success and [s["chosen"] for s in sol.starts] == [True, False]
    assert sol.starts[1]["status"] == "Maximum_Iterations_Exceeded"
    with pytest.raises(OCPError, match="from any of 1 starts"):
        solve_predictive(0.0, n_nodes=6, duration=0.4, starts=(Start(ipopt_options={"max_iter": 2}),))
    with pytest.raises(ValueError, match="at least one Start"):
        solve_predictive(0.0, n_nodes=6, duration=0.4, starts=())


def test_save_load_round_trip(slow_walk: GaitSolution, tmp_path: Path) -> None:
    path = slow_walk.save(tmp_path / "sub" / "walk_1.2")  # a dot in the name is not a suffix
    assert path.name == "walk_1.2.npz" and (tmp_path / "sub" / "walk_1.2.json").exists()
    back = GaitSolution.load(tmp_path / "sub" / "walk_1.2")
    for name in ("time", "q", "u", "qdd", "tau", "grf", "w", "tau_max"):
        np.testing.assert_array_equal(getattr(back, name), getattr(slow_walk, name))
    for name in ("speed", "duration", "status", "iterations", "solve_time", "objective", "settings", "contact", "starts"):
        assert getattr(back, name) == getattr(slow_walk, name)
    assert back.body == slow_walk.body
    np.testing.assert_allclose(back.node_residual(), slow_walk.node_residual())
    with pytest.raises(FileNotFoundError, match="not found"):
        GaitSolution.load(tmp_path / "missing")


def test_failure_names_ipopt_status() -> None:
    # hip joint centre forced above 1.57 m: the feet cannot reach the ground, nothing holds the body up
    with pytest.raises(OCPError, match="Infeasible_Problem_Detected") as info:
        solve_predictive(0.0, n_nodes=6, duration=0.4, pelvis_height_bounds=(0.9, 1.0))
    assert info.value.status == "Infeasible_Problem_Detected"
    assert info.value.solution is not None and not info.value.solution.success
    # without raising, the last iterate comes back with its status
    sol = solve_predictive(1.0, n_nodes=10, max_iter=3, raise_on_failure=False)
    assert sol.status == "Maximum_Iterations_Exceeded" and not sol.success


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"effort": "quartic"}, "effort"),
        ({"gait_cycle": "quarter"}, "gait_cycle"),
        ({"n_nodes": 2}, "n_nodes"),
        ({"speed": -1.0}, "speed"),
        ({"duration_bounds": (1.0, 0.5)}, "duration_bounds"),
    ],
)
def test_settings_are_validated(kwargs: dict, match: str) -> None:
    args = {"speed": 1.0, **kwargs}
    with pytest.raises(ValueError, match=match):
        OCPSettings(**args)


def test_normalised_cycle_starts_at_right_heel_strike(slow_walk: GaitSolution) -> None:
    n = slow_walk.n_nodes  # resampled at the nodes themselves: no interpolation
    cyc = normalised_cycle(slow_walk, n=n)
    assert cyc.percent[0] == 0.0 and len(cyc.hip) == n
    assert cyc.grf_y[0] > 0.1 and cyc.grf_y[-1] <= 0.1  # loaded at 0 %, unloaded one node before
    start = slow_walk.right_heel_strike()
    np.testing.assert_allclose(cyc.hip, np.roll(slow_walk.q[:, 3], -start))


def test_walking_against_winter_and_the_human_norms_as_documented(tmp_path: Path) -> None:
    """docs/results/gait_norms.md: at 1.3 m/s (the default 50 nodes per half cycle, cubed effort,
    human priors) the gait is inside the human norms — vertical GRF peak 1.13 BW, valley 0.75 BW,
    stance 59 %, double support 18 %, no flight, RMSD to Winter 4.5 / 4.1 / 5.6° — where the
    squared effort without priors walked stiff-legged (1.77 BW, 8 % double support). The bounds
    hold the documented figures with a margin for other IPOPT paths (other CPUs reach other local
    optima), so that a regression fails."""
    if not (SHARED_DATA / "winter_walking").exists():
        pytest.skip("../shared/data/winter_walking not present")
    ref = load_winter(SHARED_DATA)
    assert len(ref.percent) == 50 and ref.speed == pytest.approx(1.325)
    sol = solve_predictive(1.3)
    rmsd = compare_with_reference(sol, ref)
    assert rmsd["rmsd_hip_deg"] <= 7.0 and rmsd["rmsd_knee_deg"] <= 8.0 and rmsd["rmsd_ankle_deg"] <= 7.0
    assert rmsd["rmsd_grf_y_bw"] <= 0.2
    norms = solution_norms(sol, ref)
    assert 1.0 <= norms.peak_bw <= 1.3 and 0.6 <= norms.valley_bw <= 0.9, norms.summary()
    assert 56.0 <= norms.stance_percent <= 65.0 and 12.0 <= norms.double_support_percent <= 25.0, norms.summary()
    assert norms.flight_percent == 0.0 and norms.taps == 0, norms.summary()
    png = plot_gait(solve_predictive(1.2, n_nodes=25), tmp_path / "walk.png", ref)
    assert png.stat().st_size > 10_000


def test_cli_writes_solution_and_plot(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "stand_0.0"
    code = cli_main(["solve", "--speed", "0", "--nodes", "6", "--duration", "0.4", "--out", str(out)])
    assert code == 0
    printed = capsys.readouterr().out
    assert "Solve_Succeeded" in printed and "node_residual_max_trans_bw" in printed
    for suffix in (".npz", ".json", ".png", "_summary.json"):
        assert (tmp_path / f"stand_0.0{suffix}").exists()


def test_sspinn_never_imports_predictive() -> None:
    root = Path(__file__).resolve().parents[1] / "sspinn"
    offenders = [
        p for p in root.rglob("*.py") if "import predictive" in p.read_text() or "from predictive" in p.read_text()
    ]
    assert offenders == []


def test_settings_round_trip_through_solution(slow_walk: GaitSolution) -> None:
    cfg = OCPSettings.from_dict(slow_walk.settings)
    assert cfg.speed == 1.2 and cfg.n_nodes == 25 and cfg.gait_cycle == "half"
    assert cfg.tau_max == (0.1, 0.1, 0.1)


def test_warm_start_from_solution_and_free_duration(slow_walk: GaitSolution) -> None:
    sol = solve_predictive(1.1, n_nodes=12, guess=slow_walk, free_duration=True, duration_bounds=(0.9, 1.3))
    assert sol.success and 0.9 - 1e-6 <= sol.duration <= 1.3 + 1e-6  # IPOPT relaxes bounds by ~1e-8
    assert np.abs(sol.node_residual()).max() < 1e-6
    assert sol.stride_length == pytest.approx(1.1 * sol.duration)


def test_solution_on_a_sampling_grid_satisfies_the_dynamics_at_every_sample() -> None:
    """rate_hz puts the nodes on the sampling grid: the torch backend finds the dynamics satisfied
    at every sample with the solution's own accelerations (no resampling needed)."""
    import torch

    from sspinn.model import dynamics

    sol = solve_predictive(1.2, rate_hz=25.0)
    assert np.allclose(np.diff(sol.time), 1 / 25.0) and sol.duration == pytest.approx(len(sol.time) / 25.0)
    t = lambda x: torch.as_tensor(np.asarray(x))  # noqa: E731
    p, c = t(sol.body.vector()), t(sol.contact_parameters.vector())
    grf, w = dynamics.contact_forces(t(sol.q), t(sol.u), p, c)
    r = dynamics.kane_residual(t(sol.q), t(sol.u), t(sol.qdd), t(sol.tau), grf, w, p).numpy()
    assert np.abs(r[:, :2]).max() / sol.body.body_weight < 1e-6
    with pytest.raises(ValueError, match="not both"):
        solve_predictive(1.2, rate_hz=25.0, n_nodes=10)
