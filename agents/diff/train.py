"""``python -m agents train`` for ``algo: apg | shac | ahac`` (called by :func:`agents.train.train`).

A run folder of these algorithms holds::

    <out>/config.yaml                          the validated configuration
    <out>/checkpoints/model_<steps>_steps.pt   periodic checkpoints (DiffAgent.save: weights, optimisers, counters)
    <out>/best_model.pt                        best periodic evaluation (mean return)
    <out>/final_model.pt                       end of training
    <out>/evaluations.csv                      one row per evaluation (the SB3 runs' columns)
    <out>/training.csv                         one row per window: loss, reward, gradient health

Evaluations are those of the SB3 runs (:func:`agents.rollout.run_episode` on the single
environment, deterministic, fixed seeds, the same columns), the first one before any update (the
untrained policy). ``--resume`` continues from the latest checkpoint with its step count; a first
Ctrl-C finishes the window, saves a checkpoint and stops (:class:`sspinn.interrupt.DeferredInterrupt`).
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

from agents.builders import WALKING_BELOW_M_S, make_env
from agents.checkpoints import (
    CHECKPOINT_DIR,
    CHECKPOINT_PREFIX,
    EVAL_COLUMNS,
    append_csv_row,
    latest_checkpoint,
    open_run_folder,
)
from agents.config import AgentConfig
from agents.diff.agent import DiffAgent
from agents.diff.settings import settings_of
from agents.rollout import run_episode, summarize
from sspinn.data.gait_metrics import winter_or_none
from sspinn.interrupt import DeferredInterrupt

#: What a run of these algorithms leaves in its folder besides its config (see the module docstring).
DIFF_RUN_OUTPUTS: tuple[str, ...] = ("final_model.pt", "best_model.pt", "evaluations.csv", "training.csv", CHECKPOINT_DIR)
#: Columns of ``training.csv`` (see :meth:`agents.diff.agent.DiffAgent.update_window`).
TRAINING_COLUMNS: tuple[str, ...] = (
    "steps", "updates", "loss", "mean_reward", "grad_norm", "clipped", "grad_first_action", "grad_last_action",
    "grad_variance", "cut_rate", "critic_loss", "episodes", "episode_return", "episode_distance", "action_std",
)


def agent_from_config(config: AgentConfig) -> DiffAgent:
    """A new agent with the configuration's algorithm, settings, walkers, environment and seed."""
    return DiffAgent(config.algo, settings_of(config), config.env.n_envs, config.env.kwargs, config.seed,
                     obs_clip=config.normalize.clip_obs, config=config)


class DiffEvaluator:
    """The SB3 runs' periodic evaluation for a :class:`DiffAgent`: ``eval_episodes`` deterministic
    episodes on fixed seeds at the evaluation target, a row of ``evaluations.csv``, and
    ``best_model.pt`` when the mean return is the best so far."""

    def __init__(self, config: AgentConfig, run_dir: Path) -> None:
        self.config, self.run_dir, self.columns = config, run_dir, EVAL_COLUMNS
        self.env = make_env(config)
        self.reference = winter_or_none() if config.env.target_speed < WALKING_BELOW_M_S else None
        self.best_return = -float("inf")
        self.started = time.perf_counter()

    def __call__(self, agent: DiffAgent) -> dict[str, Any]:
        lg = self.config.logging
        results = [run_episode(agent, self.env, lg.eval_seed + i, self.config.env.target_speed, reference=self.reference)
                   for i in range(lg.eval_episodes)]
        summary = summarize(results)
        row = {"timesteps": agent.num_timesteps, "wall_s": round(time.perf_counter() - self.started, 1), **summary}
        append_csv_row(self.run_dir / "evaluations.csv", row, self.columns)
        if summary["mean_return"] > self.best_return:
            self.best_return = summary["mean_return"]
            agent.save(self.run_dir / "best_model.pt")
        print(f"[eval] {agent.num_timesteps:>10d} steps  return {summary['mean_return']:7.1f}  distance "
              f"{summary['mean_distance_m']:5.2f} m  speed {summary['mean_speed_m_s']:4.2f} m/s  "
              f"falls {summary['falls']}/{summary['episodes']}", flush=True)
        return row

    def close(self) -> None:
        self.env.close()


def train_diff(config: AgentConfig, run_dir: Path, resume: bool, overwrite: bool) -> DiffAgent:
    """Train ``config`` (algo apg/shac/ahac) into ``run_dir``; the caller holds the run's lock."""
    checkpoint = latest_checkpoint(run_dir, suffix=".pt")
    open_run_folder(config, run_dir, checkpoint, resume, overwrite, DIFF_RUN_OUTPUTS)
    if checkpoint is not None and resume:
        agent = DiffAgent.load(checkpoint, config=config)
        print(f"resuming from {checkpoint} at {agent.num_timesteps:,} steps", flush=True)
    else:
        agent = agent_from_config(config)
    lg = config.logging
    evaluator = DiffEvaluator(config, run_dir) if lg.eval_freq > 0 else None
    folder = run_dir / CHECKPOINT_DIR
    folder.mkdir(exist_ok=True)
    interrupt = DeferredInterrupt("finishing the current window, then saving a checkpoint (Ctrl-C again to stop at once)")
    interrupted: list[Path] = []

    def save_checkpoint() -> Path:
        return agent.save(folder / f"{CHECKPOINT_PREFIX}_{agent.num_timesteps}_steps.pt")

    def after_window(agent: DiffAgent, stats: dict[str, float]) -> bool:
        before = stats["steps"] - agent.n_envs * agent.settings.horizon
        append_csv_row(run_dir / "training.csv", {**stats, "steps": int(stats["steps"]), "updates": agent.updates},
                       TRAINING_COLUMNS)
        if lg.verbose:
            print(f"[window {agent.updates}] {int(stats['steps']):,} steps  loss {stats['loss']:.3f}  reward "
                  f"{stats['mean_reward']:.3f}  |g| {stats['grad_norm']:.3g}", flush=True)
        if int(stats["steps"]) // lg.checkpoint_freq > int(before) // lg.checkpoint_freq:
            save_checkpoint()
        if evaluator is not None and int(stats["steps"]) // lg.eval_freq > int(before) // lg.eval_freq:
            evaluator(agent)
        if interrupt.requested:
            interrupted.append(save_checkpoint())
            return False
        return True

    print(f"training {config.algo.upper()} through the differentiable simulator ({agent.n_envs} walkers, horizon "
          f"{agent.settings.horizon}) from step {agent.num_timesteps:,} to {config.total_timesteps:,} → {run_dir}",
          flush=True)
    if evaluator is not None and agent.num_timesteps == 0:
        evaluator(agent)
    interrupt.install()
    try:
        agent.learn(config.total_timesteps, callback=after_window)
    finally:
        interrupt.restore()
        if evaluator is not None:
            evaluator.close()
    if interrupted:
        print(f"interrupted at step {agent.num_timesteps:,}: saved {interrupted[0]} (continue with --resume)", flush=True)
        raise KeyboardInterrupt
    save_checkpoint()
    agent.save(run_dir / "final_model.pt")
    print(f"trained {agent.num_timesteps:,} steps → {run_dir / 'final_model.pt'}", flush=True)
    return agent
