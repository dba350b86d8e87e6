"""Train a PPO agent on SagittalWalker-v0 and evaluate it.

    python examples/train_ppo.py [--quick] [--out runs/example_ppo]

The full recipe is configs/agents/ppo.yaml (20 M steps); --quick trains 128 steps of a tiny network.
"""

import argparse
import tempfile
from pathlib import Path

import agents

ROOT = Path(__file__).resolve().parents[1]
parser = argparse.ArgumentParser()
parser.add_argument("--quick", action="store_true")
parser.add_argument("--out", type=Path, default=None, help="run folder (default: a temporary one)")
args = parser.parse_args()

settings = ["total_timesteps=128", "env.n_envs=1", "env.kwargs.max_episode_steps=50", "policy.net_arch=[16]",
            "hyperparameters.n_steps=64", "hyperparameters.batch_size=32", "hyperparameters.n_epochs=1",
            "logging.eval_freq=0", "logging.tensorboard=false"] if args.quick else []
config = agents.load_config(ROOT / "configs" / "agents" / "ppo.yaml", settings=settings)

with tempfile.TemporaryDirectory() as tmp:
    out = args.out or Path(tmp) / "ppo"
    agents.train_agent(config, out, overwrite=args.out is not None)
    report = agents.evaluate_agent(out / "final_model.zip", out / "eval", episodes=1, video=False,
                             max_steps=50 if args.quick else None)
summary = report["summary"]
print(f"{config.total_timesteps} training steps: walked {summary['mean_distance_m']:.2f} m at "
      f"{summary['mean_speed_m_s']:.2f} m/s (target {report['target_speed']} m/s), {summary['falls']} fall(s)")
