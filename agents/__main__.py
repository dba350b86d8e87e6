"""``python -m agents {train,evaluate,record}``: see :mod:`agents`."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from envs.openmp import prefer_passive_openmp
from sspinn.errors import ArgumentParser, bounded
from sspinn.run_folder import OVERWRITE_HELP, output_target
from sspinn.yaml_config import add_config_flags, flag_overrides

#: Fields of :class:`agents.config.AgentConfig` that ``train`` takes as flags (dotted) → flag name
#: where it is not the field's; ``--target-speed`` sets ``env.kwargs.target_speed`` too.
TRAIN_FLAGS: dict[str, str] = {"algo": "--algo", "total_timesteps": "--total-timesteps", "seed": "--seed",
                               "env.eval_target_speed": "--target-speed"}


#: Ranges of the numeric options of ``evaluate`` and ``record`` (the ``train`` flags take theirs
#: from :class:`agents.config.AgentConfig`): target speed (m/s, as ``env.eval_target_speed``),
#: seeds (numpy's 32-bit seeds), episode length in control steps (10 min at 100 Hz), episodes.
MAX_TARGET_SPEED = 12.0
MAX_SEED = 2**32 - 1
MAX_EPISODE_STEPS = 60_000
MAX_EPISODES = 1000


def build_parser() -> argparse.ArgumentParser:
    """The command-line interface."""
    from agents.config import ENV_RATE_HZ, AgentConfig

    parser = ArgumentParser(prog="python -m agents", description="SB3 agents for sspinn/SagittalWalker-v0")
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("train", help="train an agent from a YAML config")
    p.add_argument("--config", required=True, help="YAML file (configs/agents/*.yaml)")
    p.add_argument("--out", required=True, help="run directory (checkpoints, logs, best model)")
    p.add_argument("--resume", action="store_true", help="continue from the latest checkpoint in --out")
    p.add_argument("--overwrite", action="store_true", help="replace the run already in --out (its checkpoints, "
                   "models, evaluations, monitor and TensorBoard files are deleted first)")
    add_config_flags(p, AgentConfig, TRAIN_FLAGS, flags=TRAIN_FLAGS, helps={
        "algo": "must match the config's algo if given",
        "env.eval_target_speed": "override the training and evaluation target speed, m/s (env.kwargs.target_speed)",
    })

    for name, text in (("evaluate", "deterministic evaluation: JSON, plot, animation"),
                       ("record", "render one deterministic episode to a GIF or MP4")):
        p = sub.add_parser(name, help=text)
        p.add_argument("--checkpoint", required=True, help="SB3 .zip or APG/SHAC/AHAC .pt (its run's config.yaml is found next to it)")
        p.add_argument("--target-speed", type=bounded(float, 0.0, MAX_TARGET_SPEED, " m/s"),
                       help=f"m/s, 0–{MAX_TARGET_SPEED:g} (default: the config's evaluation target)")
        p.add_argument("--seed", type=bounded(int, 0, MAX_SEED), default=0, help=f"first episode seed (0–{MAX_SEED})")
        p.add_argument("--max-steps", type=bounded(int, 1, MAX_EPISODE_STEPS),
                       help=f"episode length in control steps, 1–{MAX_EPISODE_STEPS} (default: the env's)")
        p.add_argument("--overwrite", action="store_true", help=OVERWRITE_HELP)
        if name == "evaluate":
            p.add_argument("--episodes", type=bounded(int, 1, MAX_EPISODES), default=5,
                           help=f"episodes (seeds seed, seed+1, ...), 1–{MAX_EPISODES}")
            p.add_argument("--out", required=True, help="output folder (metrics.json, traces.png, episode.gif)")
            p.add_argument("--no-video", action="store_true", help="skip the animation")
            p.add_argument("--data-dir", help="folder holding winter_walking/ for the angle RMSD (default: $SSPINN_SHARED_DATA)")
        else:
            p.add_argument("--out", required=True, help="output file, .gif or .mp4")
        p.add_argument("--fps", type=bounded(int, 1, ENV_RATE_HZ), default=25,
                       help=f"animation frame rate, 1–{ENV_RATE_HZ} (the env runs at {ENV_RATE_HZ} Hz)")
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point; returns the exit status (2 and one line on stderr for a user error,
    ``--debug`` for the traceback; see :func:`sspinn.errors.run_cli`)."""
    from sspinn.errors import run_cli

    prefer_passive_openmp()  # before torch loads OpenMP: the vector environment's threads wait passively
    return run_cli(_main, "python -m agents", argv, user_errors=(ValueError,))


def _main(argv: list[str]) -> int:
    args = build_parser().parse_args(argv)
    from agents.config import ConfigError, load_config

    if args.command == "train":
        from agents.train import train

        overrides = flag_overrides(args)
        algo = overrides.pop("algo", None)
        if "env.eval_target_speed" in overrides:
            overrides["env.kwargs.target_speed"] = overrides["env.eval_target_speed"]
        config = load_config(args.config, overrides)
        if algo is not None and algo != config.algo:
            raise ConfigError(f"--algo {algo} but {args.config} has algo: {config.algo}")
        train(config, args.out, resume=args.resume, overwrite=args.overwrite)
    elif args.command == "evaluate":
        from agents.evaluate import evaluate

        args.out = output_target(args.out, lambda f: (f / "metrics.json").exists(), args.overwrite, "an evaluation")
        report = evaluate(args.checkpoint, args.out, episodes=args.episodes, seed=args.seed,
                          target_speed=args.target_speed, max_steps=args.max_steps,
                          video=not args.no_video, fps=args.fps, data_dir=args.data_dir)
        s = report["summary"]

        def fmt(key: str, digits: int = 2) -> str:
            return "n/a" if s[key] is None else f"{s[key]:.{digits}f}"

        print(f"{s['episodes']} episodes at {report['target_speed']:.2f} m/s: distance {s['mean_distance_m']:.2f} m "
              f"(min {s['min_distance_m']:.2f}), speed {s['mean_speed_m_s']:.2f} m/s "
              f"(|error| {s['mean_abs_speed_error_m_s']:.3f}), CoT {fmt('mean_cost_of_transport')}, "
              f"falls {s['falls']}, cadence {fmt('mean_cadence_steps_per_min', 0)} steps/min, "
              f"foot slide {s['mean_foot_slide_m']:.2f} m ({fmt('mean_foot_slide_per_step_cm', 1)} cm/step), "
              f"asymmetry step time {fmt('mean_step_time_asymmetry', 1)} % / step length "
              f"{fmt('mean_step_length_asymmetry', 1)} % / stance {fmt('mean_stance_asymmetry', 1)} %, "
              f"impact {fmt('mean_peak_impact_bw')} BW, flight {fmt('mean_flight_percent', 0)} %, RMSD to Winter hip/knee/ankle {fmt('mean_rmsd_hip_deg', 1)}/"
              f"{fmt('mean_rmsd_knee_deg', 1)}/{fmt('mean_rmsd_ankle_deg', 1)} deg, double support "
              f"{fmt('mean_double_support_percent', 0)} %, taps/step {fmt('mean_taps_per_step', 2)}; written to {args.out}")
        misses = report["walking_target_misses"]
        if misses is not None:
            print("walking targets: all met" if not misses else f"walking targets MISSED ({len(misses)}): " + "; ".join(misses))
    else:
        from agents.evaluate import record

        args.out = output_target(args.out, Path.exists, args.overwrite, "an earlier recording", keep_suffix=True)
        result = record(args.checkpoint, args.out, seed=args.seed, target_speed=args.target_speed,
                        max_steps=args.max_steps, fps=args.fps)
        print(f"distance {result.distance:.2f} m in {result.duration:.2f} s, fell: {result.fell}; wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
