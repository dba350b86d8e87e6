"""Robustness evaluation: disturbances as plain data, per-seed outcomes, the report."""

from __future__ import annotations

import json

import numpy as np
import pytest

from predictive.experiments.robustness import RobustnessConfig, evaluate, evaluation_env, run_robustness
from predictive.generator.gait_generator import GeneratorConfig, GeneratorTrainer
from sspinn.model.body import BodyParameters


class _Recorder:
    """A source whose controllers apply zero torque and remember their first observations."""

    def __init__(self) -> None:
        self.first: list[np.ndarray] = []

    def controller_for(self, speed, body=None):
        source = self

        class Zero:
            initial_state = None

            def predict(self, observation, state=None, episode_start=None, deterministic=True):
                if episode_start:
                    source.first.append(np.asarray(observation).copy())
                return np.zeros(6, np.float32), state

        return Zero()


def test_evaluate_passes_env_overrides_and_reset_options() -> None:
    body = BodyParameters.from_anthropometry()
    env = evaluation_env(2.0, body, {"reset_noise_scale": 0.05, "max_episode_steps": 7})
    assert env.config.reset_noise_scale == 0.05 and env.config.target_speed == 2.0
    q, u = np.zeros(9), np.zeros(9)
    q[1] = 0.5
    rec = _Recorder()
    rows = evaluate(rec, [2.0], [0, 1], body, {"max_episode_steps": 7, "reset_noise_scale": 0.0},
                    {"initial_state": (q, u)})
    assert [r["seed"] for r in rows] == [0, 1] and all(r["steps"] <= 7 for r in rows)
    assert len(rec.first) == 2 and rec.first[0][0] == pytest.approx(0.5)  # the caller's start state won
    assert rec.first[0][21] == pytest.approx(2.0)  # target speed in the observation


def test_bad_environment_override_is_a_config_error(tmp_path) -> None:
    path = tmp_path / "r.yaml"
    path.write_text("robustness:\n  generators: [g.pt]\n  env: {reset_noise: 0.05}\n")
    with pytest.raises(ValueError, match="reset_noise"):
        RobustnessConfig.from_yaml(path)
    with pytest.raises(ValueError, match="generators"):
        RobustnessConfig()


def test_run_robustness_writes_per_seed_outcomes(tmp_path) -> None:
    gen = GeneratorConfig(harmonics=3, hidden=16, layers=1, points=8, batch_size=4, warmup_steps=20, steps=1, snapshot_every=0)
    GeneratorTrainer(gen, tmp_path / "gen").fit()
    path = str(tmp_path / "gen" / "generator.pt")
    cfg = RobustnessConfig(generators=[path], speeds=[1.3], seeds=[0, 1], env={"reset_noise_scale": 0.05, "max_episode_steps": 50})
    results = run_robustness(cfg, tmp_path / "out")
    assert len(results["tracked"][path]) == 2 and len(results["open_loop"][path]) == 2
    text = (tmp_path / "out" / "report.md").read_text()
    ok = sum(not r["fell"] for r in results["tracked"][path])
    assert f"| {path} | {ok}/2 (" in text and "open loop" in text
    assert json.loads((tmp_path / "out" / "results.json").read_text())["config"]["env"]["reset_noise_scale"] == 0.05


def test_shipped_configs_load() -> None:
    from pathlib import Path

    from predictive.experiments.controller_comparison import ComparisonConfig
    from predictive.generator.gait_generator import GeneratorConfig

    root = Path(__file__).resolve().parents[1] / "configs" / "predictive"
    robustness = RobustnessConfig.from_yaml(root / "robustness.yaml")
    compare = ComparisonConfig.from_yaml(root / "compare.yaml")
    assert robustness.tracker == compare.tracker and robustness.tracker.phase == "state"
    assert robustness.tracker.start == "least_sensitive" and robustness.tracker.start_height_error == 0.05
    assert [w.speed for w in robustness.tracker.lqr] == [1.3, 2.2, 3.5] and robustness.env == {"reset_noise_scale": 0.05}
    generator = GeneratorConfig.from_yaml(root / "generator.yaml")
    assert generator.weights.clearance > 0 and generator.polish_iterations > 0
