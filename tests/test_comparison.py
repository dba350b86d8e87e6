"""The predictive-simulation comparison harness on tiny budgets."""

from __future__ import annotations

import json

import numpy as np
import pytest

from envs.sagittal_walker import SagittalWalkerEnv
from predictive.experiments.controller_comparison import (
    ComparisonConfig,
    MethodSpec,
    executed_kane_residual,
    mean_right_cycle,
    run_comparison,
    winter_rmsd,
)
from predictive.generator.gait_generator import GeneratorConfig, GeneratorTrainer
from predictive.ocp.gait_analysis import ReferenceGait
from sspinn.model.trajectory import Trajectory


def _episode(n_cycles: int = 5, period: int = 100, bw: float = 700.0, steps: int | None = None) -> Trajectory:
    """An episode as the rollout gives it: the reset state, then the state after each step."""
    n = n_cycles * period if steps is None else steps
    phase = (np.arange(n) % period) / period
    q = np.zeros((n + 1, 9))
    q[1:, 3:6] = np.stack([np.sin(2 * np.pi * phase), -np.abs(np.sin(np.pi * phase)), 0.1 * phase], axis=1)
    grf = np.zeros((n + 1, 4))
    grf[1:, 1] = np.where(phase < 0.6, bw, 0.0)
    zeros = np.zeros_like(q)
    return Trajectory(time=0.01 * np.arange(n + 1), q=q, u=zeros, qdd=zeros, tau=np.zeros((n + 1, 6)), grf=grf,
                      w=np.zeros((n + 1, 2)))


def test_mean_right_cycle_and_rmsd_recover_a_known_cycle() -> None:
    cyc = mean_right_cycle(_episode(), 700.0, 0.01)
    assert cyc is not None
    pct = cyc["percent"]
    np.testing.assert_allclose(cyc["hip"], np.sin(2 * np.pi * pct / 100), atol=1e-9)
    np.testing.assert_allclose(cyc["grf_y"][:60], 1.0)
    ref = ReferenceGait(pct, cyc["hip"], cyc["knee"], cyc["ankle"], cyc["grf_x"], cyc["grf_y"], 1.3, 1.0)
    assert all(v == pytest.approx(0.0, abs=1e-9) for v in winter_rmsd(cyc, ref).values())
    shifted = ReferenceGait(pct, cyc["hip"] + np.radians(5), cyc["knee"], cyc["ankle"], cyc["grf_x"], cyc["grf_y"], 1.3, 1.0)
    assert winter_rmsd(cyc, shifted)["rmsd_hip_deg"] == pytest.approx(5.0)
    assert mean_right_cycle(_episode(steps=150), 700.0, 0.01) is None  # < 2 strikes after 2 s


def test_executed_kane_residual_is_small_for_the_simulation_and_large_for_a_fake() -> None:
    env = SagittalWalkerEnv()
    env.reset(seed=0)
    q0, u0 = env.state
    qs, us, taus = [q0], [u0], []
    for _ in range(60):
        _, _, _, _, info = env.step(np.zeros(6, np.float32))  # the body sags onto the feet
        q, u = env.state
        qs.append(q), us.append(u), taus.append(info["torques"])
    q, u = np.array(qs), np.array(us)
    tau = np.vstack([taus, np.zeros((1, 6))])
    episode = Trajectory(time=0.01 * np.arange(len(q)), q=q, u=u, qdd=np.zeros_like(q), tau=tau, grf=np.zeros((len(q), 4)),
                         w=np.zeros((len(q), 2)))
    real = executed_kane_residual(episode, env)
    lifted = q.copy()
    lifted[:, 1] += 0.01  # the same motion 1 cm higher: the contact forces no longer match it
    fake = executed_kane_residual(Trajectory(time=episode.time, q=lifted, u=u, qdd=episode.qdd, tau=tau, grf=episode.grf,
                                             w=episode.w), env)
    assert real < 0.01 and fake > 10 * real  # measured 0.0023 BW


def test_config_validation() -> None:
    with pytest.raises(ValueError, match="kind must be"):
        MethodSpec("x", "magic")
    with pytest.raises(ValueError, match="needs model"):
        MethodSpec("x", "generator")
    with pytest.raises(ValueError, match="seeds"):
        ComparisonConfig(seeds=[])


def test_run_comparison_end_to_end_on_tiny_budgets(tmp_path, capsys) -> None:
    gen = GeneratorConfig(harmonics=3, hidden=16, layers=1, points=8, batch_size=4, warmup_steps=5, steps=2,
                          snapshot_every=5, log_every=1)
    GeneratorTrainer(gen, tmp_path / "gen").fit()
    cfg = ComparisonConfig(
        speeds=[1.3], seeds=[0],
        methods=[
            {"name": "generator", "kind": "generator", "model": str(tmp_path / "gen" / "generator.pt")},
            {"name": "PPO", "kind": "sb3", "checkpoints": {1.3: str(tmp_path / "missing.zip")}},
        ],
        conditions={"push 20 % BW": {"disturbances": {"push_force": 20.0, "push_phase": "midstance_r"}}},
        animation_s=0.2,
    )
    cells = run_comparison(cfg, tmp_path / "report")
    assert [c.method for c in cells] == ["generator", "PPO"]
    assert len(cells[0].episodes) == 1 and cells[1].note == "not trained for this speed"
    summary = cells[0].summary()
    assert 0.0 <= summary["success_rate"] <= 1.0 and summary["per_speed_time_s"] > 0
    data = json.loads((tmp_path / "report" / "results.json").read_text())
    assert data["summary"][0]["method"] == "generator"
    text = (tmp_path / "report" / "report.md").read_text()
    assert "| generator | 1.3 |" in text and "not trained" in text
    assert len(cells[0].conditions["push 20 % BW"]) == 1 and "condition_success" in summary
    assert "| method | speed (m/s) | nominal | push 20 % BW |" in text
    assert (tmp_path / "report" / "gait_generator_1.3.gif").stat().st_size > 0
    with pytest.raises(ValueError, match="conditions.bad"):
        ComparisonConfig(conditions={"bad": {"target_speed": 2.0}})
    assert (tmp_path / "report" / "learning_curves.png").exists()

    # an interrupted or repeated run into the folder keeps the finished cells whose inputs are unchanged
    (tmp_path / "report" / "report.md").unlink()
    again = run_comparison(cfg, tmp_path / "report")
    assert [c.episodes for c in again] == [c.episodes for c in cells]
    assert again[0].setup_time_s == cells[0].setup_time_s  # read back, not measured again
    assert np.isnan(again[1].setup_time_s) and np.isnan(cells[1].setup_time_s)  # nothing built: NaN, written as null
    assert (tmp_path / "report" / "report.md").exists()
    kept = sorted(p.name for p in (tmp_path / "report" / "cells").iterdir())
    assert kept == ["generator@1.3.json", "ppo@1.3.json"]
    GeneratorTrainer(gen, tmp_path / "gen").fit(overwrite=True)  # the model file changed: its cell runs again
    capsys.readouterr()
    rerun = run_comparison(cfg, tmp_path / "report")
    printed = capsys.readouterr().out
    assert "[compare] generator at 1.3 m/s …" in printed and "[compare] PPO at 1.3 m/s: kept from an earlier run" in printed
    run_comparison(cfg, tmp_path / "report", overwrite=True)  # everything again
    assert "kept from an earlier run" not in capsys.readouterr().out
    assert rerun[0].setup_time_s != cells[0].setup_time_s  # measured again


@pytest.mark.slow
def test_bench_predictive_times_a_new_speed(tmp_path, capsys) -> None:
    """benchmarks/accuracy/bench_predictive.py (new-speed part) runs on a tiny generator and prints ratios."""
    import runpy
    from pathlib import Path

    import yaml

    gen = GeneratorConfig(harmonics=3, hidden=16, layers=1, points=8, batch_size=4, warmup_steps=3, steps=1, snapshot_every=0)
    GeneratorTrainer(gen, tmp_path / "gen").fit()
    cfg = tmp_path / "compare.yaml"
    cfg.write_text(yaml.safe_dump({"compare": {"speeds": [1.3], "seeds": [0], "methods": [
        {"name": "g", "kind": "generator", "model": str(tmp_path / "gen" / "generator.pt")}]}}))
    bench = runpy.run_path(str(Path(__file__).resolve().parents[1] / "benchmarks" / "accuracy" / "bench_predictive.py"), run_name="bench")
    assert bench["main"](["--config", str(cfg), "--out", str(tmp_path / "out"), "--new-speeds", "1.1", "--new-bodies", "1.7:60",
                          "--skip-table"]) == 0
    out = capsys.readouterr().out
    assert "baseline: OCP re-solve" in out and "generator (forward pass + LQR + start choice)" in out
    rows = json.loads((tmp_path / "out" / "new_speed_timing.json").read_text())
    assert len(rows["speeds"]) == 3 and all(r["time_s"] > 0 for r in rows["speeds"])
    assert len(rows["bodies"]) == 2 and "Other bodies" in out


def test_sb3_controller_is_the_agents_predict_with_state_and_episode_start() -> None:
    from agents.checkpoints import LoadedAgent
    from predictive.controller import Controller
    from predictive.experiments.controller_comparison import SB3Controller

    class Model:
        def predict(self, observation, state=None, episode_start=None, deterministic=True):
            self.seen = (observation.copy(), deterministic)
            return np.ones(6, np.float32), None

    agent = LoadedAgent(model=Model(), config=None, obs_mean=np.full(22, 1.0), obs_var=np.full(22, 0.25))  # type: ignore[arg-type]
    ctrl = SB3Controller(agent)
    assert isinstance(ctrl, Controller) and ctrl.initial_state is None
    action, state = ctrl.predict(np.full(22, 2.0, np.float32), None, episode_start=True)
    assert state is None and action.shape == (6,)
    obs, det = agent.model.seen
    np.testing.assert_allclose(obs, 2.0, rtol=1e-6)  # normalised as in training: (2 − 1) / 0.5
    assert det is True


def test_leg_length_calibration_picks_a_controller_per_episode() -> None:
    from predictive.controller import LegLengthCalibrated
    from sspinn.model.body import BodyParameters

    made = []

    class Fixed:
        def __init__(self, body):
            self.body, self.initial_state = body, (np.array([0, 0.9 * body.height / 1.75] + [0] * 7, float), np.zeros(9))

        def predict(self, obs, state=None, episode_start=None, deterministic=True):
            return np.full(6, self.body.height, np.float32), (0 if state is None else state + 1)

    class Source:
        def controller_for(self, speed, body=None):
            made.append(body.height)
            return Fixed(body)

    body = BodyParameters.from_anthropometry(1.75, 70.0)
    ctrl = LegLengthCalibrated(Source(), 1.3, body)
    obs = np.zeros(22)
    obs[0] = 0.9 * 1.05  # legs 5 % longer than announced
    action, state = ctrl.predict(obs, None)
    assert action[0] == pytest.approx(1.75 * 1.05) and state[0][0] == pytest.approx(1.05)
    action, state = ctrl.predict(obs * 0 + 0.9, state, episode_start=False)  # within an episode: kept
    assert action[0] == pytest.approx(1.75 * 1.05) and state[1][0] == 1
    obs[0] = 0.9 * 1.004  # within the tolerance: the nominal controller
    action, state = ctrl.predict(obs, state, episode_start=True)
    assert action[0] == pytest.approx(1.75) and state[0][0] == 1.0
    ctrl.predict(np.r_[0.9 * 1.05, np.zeros(21)], state, episode_start=True)
    assert made == pytest.approx([1.75, 1.75 * 1.05])  # made once per ratio


def test_a_missing_generator_stops_the_comparison_before_any_method_runs(tmp_path, capsys) -> None:
    cfg = ComparisonConfig(speeds=[1.3], seeds=[0], methods=[
        {"name": "OCP", "kind": "ocp", "n_nodes": 10},
        {"name": "generator", "kind": "generator", "model": str(tmp_path / "missing" / "generator.pt")},
    ])
    with pytest.raises(FileNotFoundError, match=r"missing/generator.pt: no gait generator here.*train-generator"):
        run_comparison(cfg, tmp_path / "report")
    assert "[compare]" not in capsys.readouterr().out
