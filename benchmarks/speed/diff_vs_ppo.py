"""Learning through the differentiable simulator against the SB3 recipes, side by side on one machine.

    python -m benchmarks.speed.diff_vs_ppo --budget 1_600_000 --out runs/diff_vs_ppo      # the full comparison
    python -m benchmarks.speed.diff_vs_ppo --gradients                                    # the gradient study and contact rates
    python -m benchmarks.speed.diff_vs_ppo --rates                                        # the contact force rates only
    python -m benchmarks.speed.diff_vs_ppo --quick                                        # a smoke run (tiny budgets)
    python -m benchmarks.speed.diff_vs_ppo --summarize runs/shac_walk runs/ahac_walk      # curves and gradient health of runs

**Arms** (same environment and body, walking at 1.3 m/s, one torch thread each, ``--threads`` for
numba's vector environment): the 256-environment PPO recipe (``configs/agents/ppo_clock_walk_256envs.yaml``,
gait clock and reference stride), SAC (``configs/agents/sac_clock_walk.yaml``), and APG, SHAC and AHAC
(``configs/agents/{apg,shac,ahac}_walk.yaml``, no gait prior). Each arm trains with
``python -m agents train``'s function into ``<out>/<arm>`` with ``--budget`` environment steps
(arms one after another, so the wall times are comparable on an otherwise idle machine only) and
reports, from its ``evaluations.csv``: the environment steps and wall seconds of its best
evaluation and that evaluation's return, distance in 10 s and falls; and whether its best model
meets every walking target (:data:`sspinn.data.gait_metrics.WALKING_TARGETS`) on reset seeds 0–4.
The goal of the differentiable arms: the targets met within 1/5 of the PPO recipe's steps.

**Gradient study** (``--gradients``): at the initial policy, the APG window loss of N walkers is
differentiated for ``substeps`` ∈ {50, 25, 10} and horizons ∈ {1, 4, 16}: the policy's gradient
norm, ‖∂J/∂a‖ of the window's first and last actions (per walker, of its own window return) and
whether everything is finite — how the gradient through the contact grows with the window and
the integration step; and the distribution of AHAC's cut measure, the per-step change of the
vertical ground reaction force, under a fresh policy (64 walkers × 60 steps).

Step counts, not wall clocks, are the results on a shared machine; the wall times are recorded
beside them (and say so).
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import time
from pathlib import Path
from typing import Any

import torch

from agents.builders import make_env
from agents.checkpoints import load_agent
from agents.config import load_config
from agents.diff import DiffAgent, DiffSettings
from agents.rollout import run_episode, summarize, walking_target_misses
from agents.train import train
from sspinn.run_folder import atomic_write_text

CONFIGS = Path(__file__).resolve().parents[2] / "configs" / "agents"
#: Arm name → configuration file.
ARMS: dict[str, str] = {
    "ppo_256envs": "ppo_clock_walk_256envs.yaml",
    "sac": "sac_clock_walk.yaml",
    "apg": "apg_walk.yaml",
    "shac": "shac_walk.yaml",
    "ahac": "ahac_walk.yaml",
}
MAX_BUDGET = 100_000_000


def quick_overrides(arm: str) -> dict[str, Any]:
    """Tiny budgets and episodes for ``--quick`` (a smoke run, not a result)."""
    common = {"logging.eval_episodes": 1, "logging.tensorboard": False, "env.kwargs.max_episode_steps": 20,
              "logging.verbose": 0}
    if arm == "ppo_256envs":
        return {**common, "env.n_envs": 4, "hyperparameters.n_steps": 8, "hyperparameters.batch_size": 16,
                "hyperparameters.n_epochs": 1, "logging.eval_freq": 32, "logging.checkpoint_freq": 32,
                "total_timesteps": 32}
    if arm == "sac":
        return {**common, "env.n_envs": 1, "hyperparameters.learning_starts": 8, "hyperparameters.batch_size": 8,
                "logging.eval_freq": 16, "logging.checkpoint_freq": 16, "total_timesteps": 16}
    return {**common, "env.n_envs": 2, "env.kwargs.substeps": 5, "hyperparameters.horizon": 2,
            "hyperparameters.critic_iterations": 1, "logging.eval_freq": 4, "logging.checkpoint_freq": 4,
            "total_timesteps": 8}


def best_model_misses(run: Path, episodes: int = 5) -> list[str]:
    """The walking targets (:data:`sspinn.data.gait_metrics.WALKING_TARGETS`, the project's one
    definition) that the run's best model misses on reset seeds 0, 1, … at its evaluation speed
    (:func:`agents.rollout.walking_target_misses`; empty: all met)."""
    best = next(p for p in (run / "best_model.zip", run / "best_model.pt") if p.is_file())
    agent = load_agent(best)
    env = make_env(agent.config)
    try:
        results = [run_episode(agent, env, seed, agent.config.env.target_speed) for seed in range(episodes)]
    finally:
        env.close()
    return walking_target_misses(results)


def summarize_run(run: Path) -> dict[str, Any]:
    """Best evaluation and first evaluation meeting the targets, from ``<run>/evaluations.csv``."""
    with (run / "evaluations.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    best = max(rows, key=lambda r: float(r["mean_return"]))
    return {
        "evaluations": len(rows),
        "last_steps": int(rows[-1]["timesteps"]),
        "best_steps": int(best["timesteps"]),
        "best_wall_s": float(best["wall_s"]),
        "best_return": float(best["mean_return"]),
        "best_distance_m": float(best["mean_distance_m"]),
        "best_falls": int(best["falls"]),
        "untrained_return": float(rows[0]["mean_return"]) if int(rows[0]["timesteps"]) == 0 else None,
    }


def gradient_health(run: Path) -> dict[str, Any]:
    """Statistics of ``<run>/training.csv`` (APG/SHAC/AHAC): windows, environment steps, the
    actor's gradient norm before clipping (median, 90th percentile, max), the share of clipped
    updates, the running gradient variance at the end (mean per parameter), the median ratio of
    the first to the last action's gradient in a window, and AHAC's cuts per walker and step."""
    import numpy as np

    with (run / "training.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    norms = np.array([float(r["grad_norm"]) for r in rows])
    ratio = np.array([float(r["grad_first_action"]) / max(float(r["grad_last_action"]), 1e-30) for r in rows])
    return {
        "windows": len(rows), "env_steps": int(rows[-1]["steps"]),
        "grad_norm_median": float(np.median(norms)), "grad_norm_p90": float(np.percentile(norms, 90)),
        "grad_norm_max": float(norms.max()), "clipped_share": float(np.mean([float(r["clipped"]) for r in rows])),
        "grad_variance_end": float(rows[-1]["grad_variance"]), "first_over_last_median": float(np.median(ratio)),
        "cut_rate": float(np.mean([float(r["cut_rate"]) for r in rows])),
    }


def zero_action_baseline(run: Path) -> dict[str, Any]:
    """The trivial baseline of a run's evaluations: zero actions (no actuator torque) on the same
    environment, target speed and evaluation seeds (``logging.eval_seed`` …)."""
    import numpy as np

    from agents.checkpoints import find_config

    config = find_config(run / "config.yaml")
    env = make_env(config)
    lg = config.logging
    try:
        results = [run_episode(lambda obs: np.zeros(6, dtype=np.float32), env, lg.eval_seed + i, config.env.target_speed)
                   for i in range(lg.eval_episodes)]
    finally:
        env.close()
    summary = summarize(results)
    return {k: summary[k] for k in ("mean_return", "mean_distance_m", "falls", "episodes", "mean_steps")}


def print_summary(runs: list[Path]) -> dict[str, Any]:
    """The evaluation curve (return, distance, falls against environment steps) and the gradient
    health of each run folder, after the zero-action baseline on the first run's evaluation episodes."""
    out: dict[str, Any] = {"zero_action": zero_action_baseline(runs[0])}
    print(f"zero-action baseline: {out['zero_action']}")
    for run in runs:
        with (run / "evaluations.csv").open() as fh:
            curve = [(int(r["timesteps"]), float(r["mean_return"]), float(r["mean_distance_m"]), int(r["falls"]))
                     for r in csv.DictReader(fh)]
        health = gradient_health(run)
        out[str(run)] = {"curve": curve, "gradients": health, **summarize_run(run)}
        print(f"{run}: " + "  ".join(f"{s:,}: {ret:.1f} / {d:.2f} m / {f} falls" for s, ret, d, f in curve))
        print(f"  gradients: {health}")
    return out


def run_arm(arm: str, budget: int, out: Path, quick: bool, threads: int | None, overwrite: bool) -> dict[str, Any]:
    overrides: dict[str, Any] = quick_overrides(arm) if quick else {"total_timesteps": budget}
    if threads is not None and arm in ("ppo_256envs", "sac"):
        overrides["env.threads"] = threads
    config = load_config(CONFIGS / ARMS[arm], overrides)
    started = time.perf_counter()
    train(config, out / arm, overwrite=overwrite)
    wall = time.perf_counter() - started
    misses = best_model_misses(out / arm, 1 if quick else 5)
    return {"arm": arm, "config": ARMS[arm], "env_steps": config.total_timesteps, "wall_s": round(wall, 3),
            "gait_prior": config.prior.gait is not None, **summarize_run(out / arm),
            "walking_targets_met": not misses, "walking_target_misses": misses}


def gradient_study(n_envs: int, substeps: tuple[int, ...], horizons: tuple[int, ...], seed: int) -> list[dict[str, Any]]:
    """The APG window gradient at the initial policy for each substeps × horizon (module docstring)."""
    walk = load_config(CONFIGS / "shac_walk.yaml").env.kwargs
    rows = []
    for sub in substeps:
        for h in horizons:
            agent = DiffAgent("apg", DiffSettings(horizon=h), n_envs=n_envs, env_kwargs={**walk, "substeps": sub},
                              seed=seed)
            window = agent.rollout_window()
            window.loss.backward()
            grads = torch.cat([p.grad.reshape(-1) for p in agent.actor_parameters() if p.grad is not None])
            first, last = (float(a.grad.norm(dim=-1).mean()) * n_envs * h for a in (window.actions[0], window.actions[-1]))
            rows.append({"substeps": sub, "horizon": h, "policy_grad_norm": float(grads.norm()),
                         "first_action_grad": first, "last_action_grad": last,
                         "finite": bool(torch.isfinite(grads).all()) and math.isfinite(first)})
            print(f"  substeps {sub:>3d}  horizon {h:>3d}  |dJ/dθ| {rows[-1]['policy_grad_norm']:10.3g}  "
                  f"|dJ/da| first {first:10.3g}  last {last:10.3g}  finite {rows[-1]['finite']}", flush=True)
    return rows


def contact_rates(n_envs: int, steps: int, seed: int) -> dict[str, float]:
    """Distribution of the per-step change of the larger vertical ground reaction force (BW per
    control step; AHAC's cut measure) of ``n_envs`` walkers under a fresh SHAC agent's stochastic
    policy for ``steps`` steps (falls auto-reset; the terminating steps left out)."""
    import numpy as np

    walk = load_config(CONFIGS / "shac_walk.yaml").env.kwargs
    agent = DiffAgent("shac", n_envs=n_envs, env_kwargs=walk, seed=seed)
    env = agent.env
    bw = float(env.body.body_weight)
    rates, previous = [], env.grf[:, 1::2].clone()
    with torch.no_grad():
        obs = env.observe()
        for _ in range(steps):
            agent.obs_norm.update(obs)
            obs, _, terminated, truncated, info = env.step(agent.predict(obs.numpy(), deterministic=False)[0])
            rate = (info["grf"][:, 1::2] - previous).abs().amax(-1) / bw
            rates.append(rate[~(terminated | truncated)].numpy())
            previous = env.grf[:, 1::2].clone()
    r = np.concatenate(rates)
    out = {f"p{q}": float(np.percentile(r, q)) for q in (50, 75, 90, 95, 99)}
    out |= {f"share_above_{t:g}": float((r > t).mean()) for t in (0.5, 1.0, 2.0)}
    print(f"contact force rate (BW per step), {n_envs} walkers × {steps} steps: "
          + ", ".join(f"{k} {v:.3f}" for k, v in out.items()), flush=True)
    return out


def main(argv: list[str] | None = None) -> dict[str, Any]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--budget", type=int, default=1_600_000, help=f"environment steps per arm (1–{MAX_BUDGET:,})")
    parser.add_argument("--arms", nargs="+", choices=ARMS, default=list(ARMS))
    parser.add_argument("--out", default="runs/diff_vs_ppo", help="folder of the arms' runs")
    parser.add_argument("--overwrite", action="store_true", help="replace the arms' runs already in --out")
    parser.add_argument("--threads", type=int, help="numba threads of the SB3 arms' vector environment (1–64)")
    parser.add_argument("--gradients", action="store_true", help="the gradient study and contact rates only")
    parser.add_argument("--rates", action="store_true", help="the contact force rates only")
    parser.add_argument("--quick", action="store_true", help="tiny budgets: a smoke run, not a result")
    parser.add_argument("--summarize", nargs="+", metavar="RUN", help="only print the curves and gradient health of these runs")
    parser.add_argument("--json", help="write the results here")
    args = parser.parse_args(argv)
    if not 1 <= args.budget <= MAX_BUDGET:
        parser.error(f"--budget must be in [1, {MAX_BUDGET:,}], got {args.budget}")
    if args.threads is not None and not 1 <= args.threads <= 64:
        parser.error(f"--threads must be in [1, 64], got {args.threads}")
    torch.set_num_threads(1)
    if args.summarize:
        summary = print_summary([Path(r) for r in args.summarize])
        if args.json:
            atomic_write_text(Path(args.json), json.dumps(summary, indent=2))
        return summary
    results: dict[str, Any] = {"torch_threads": 1, "numba_threads": args.threads, "quick": args.quick}
    if args.rates:
        results["contact_rates"] = contact_rates(64, 60, 3)
        return results
    print("gradient study (APG window loss at the initial policy; per walker):", flush=True)
    results["gradients"] = (gradient_study(2, (50, 10), (1, 2), 0) if args.quick
                            else gradient_study(16, (50, 25, 10), (1, 4, 16), 0))
    results["contact_rates"] = contact_rates(2, 3, 3) if args.quick else contact_rates(64, 60, 3)
    if not args.gradients:
        out = Path(args.out)
        taken = [arm for arm in args.arms if (out / arm).exists()]
        if taken and not args.overwrite:
            parser.error(f"{out} already holds runs of {taken}: choose another --out or give --overwrite")
        results["arms"] = []
        for arm in args.arms:
            row = run_arm(arm, args.budget, out, args.quick, args.threads, args.overwrite)
            results["arms"].append(row)
            print(f"{arm:>12s}: {row['env_steps']:>10,d} env steps, {row['wall_s']:8.1f} s wall (1 torch thread), best "
                  f"return {row['best_return']:7.1f} at {row['best_steps']:,} steps (distance {row['best_distance_m']:.2f} m, "
                  f"falls {row['best_falls']}), walking targets met by the best model: {row['walking_targets_met']} "
                  f"({len(row['walking_target_misses'])} misses)", flush=True)
    if args.json:
        atomic_write_text(Path(args.json), json.dumps(results, indent=2))
    return results


if __name__ == "__main__":
    main()
