"""``python -m predictive train-generator`` and ``python -m predictive generate``.

* ``train-generator --config configs/predictive/generator.yaml --out runs/generator [--resume | --overwrite]``:
  trains the self-supervised gait generator (:mod:`predictive.generator.gait_generator`); writes
  ``checkpoint.pt`` (also on Ctrl-C), ``generator.pt``, ``history.csv`` and ``config.yaml``. The
  default ``--config`` is the one shipped with the project, wherever the command runs.
* ``generate --model runs/generator/generator.pt --speed 1.3 --out results/generated/walk_1.3``:
  one gait cycle for a speed and body, written like an OCP solution (``.npz``/``.json``, summary,
  plot against Winter's walking data when available). A speed or body outside the ranges the
  generator was trained on (its file's ``speeds``, ``heights``, ``masses``) is refused; with
  ``--force`` it is generated with a WARNING and the summary lists it under ``extrapolated``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from predictive.ocp.limits import MAX_REFINE_ITERATIONS
from sspinn.errors import UserError, bounded
from sspinn.run_folder import OVERWRITE_HELP, output_target, run_outputs, stem_outputs
from sspinn.yaml_config import shipped_path

COMMANDS = ("train-generator", "generate")


def add_parsers(sub: argparse._SubParsersAction) -> None:
    train = sub.add_parser(COMMANDS[0], help="train the self-supervised gait generator (no data)")
    train.add_argument("--config", type=Path, default=shipped_path("configs/predictive/generator.yaml"),
                       help="GeneratorConfig YAML (default: the project's configs/predictive/generator.yaml)")
    train.add_argument("--out", type=Path, required=True, help="run folder")
    train.add_argument("--resume", action="store_true", help="continue from <out>/checkpoint.pt")
    train.add_argument("--auto-resume", action="store_true", help="resume if <out>/checkpoint.pt exists")
    train.add_argument("--overwrite", action="store_true",
                       help="replace the run already in --out (its checkpoint, generator, history and snapshots are deleted "
                       "first; else a NOTE and the first free <out>_2, …)")
    train.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                       help="override a config entry (repeatable), e.g. --set steps=30000 --set weights.kane=3000")
    gen = sub.add_parser(COMMANDS[1], help="one gait cycle from a trained generator")
    gen.add_argument("--model", type=Path, required=True, help="generator.pt")
    # speed, height and mass: checked against the model (predictive.ocp.limits) and then against
    # the ranges the generator was trained on, which only its file knows
    gen.add_argument("--speed", type=float, required=True, help="m/s, within the generator's training range (see --force)")
    gen.add_argument("--height", type=float, default=1.75, help="m, within the generator's training range")
    gen.add_argument("--mass", type=float, default=70.0, help="kg, within the generator's training range")
    gen.add_argument("--refine", type=bounded(int, 0, MAX_REFINE_ITERATIONS), default=0,
                     help=f"L-BFGS iterations of the per-gait fine-tune, 0–{MAX_REFINE_ITERATIONS}")
    gen.add_argument("--force", action="store_true",
                     help="generate even outside the generator's training range (with a WARNING)")
    gen.add_argument("--out", type=Path, required=True, help="output path without suffix")
    gen.add_argument("--overwrite", action="store_true", help=OVERWRITE_HELP)


def run(args: argparse.Namespace) -> int:
    from predictive.generator.gait_generator import RUN_OUTPUTS, GaitGenerator, GeneratorConfig

    if args.command == COMMANDS[0]:
        config = GeneratorConfig.from_yaml(args.config, settings=args.set)
        resume = args.resume or (args.auto_resume and (args.out / "checkpoint.pt").exists())
        if args.resume and args.overwrite:
            raise UserError("--resume continues the run in --out and --overwrite replaces it: give one of them")
        if not resume:  # a folder holding a run: continued with --resume, replaced with --overwrite, else a new folder
            args.out = output_target(args.out, lambda f: bool(run_outputs(f, RUN_OUTPUTS)), args.overwrite,
                                     "a generator run", "continue it with --resume, ")
        generator = GaitGenerator(config).fit(args.out, resume=resume, overwrite=args.overwrite and not resume)
        print(f"trained {generator.steps_} steps in {generator.training_wall_s_:.0f} s → {args.out / 'generator.pt'}")
        return 0
    from predictive.ocp.gait_analysis import compare_with_reference, load_winter, plot_gait
    from predictive.ocp.limits import RequestError, check_body, check_speed
    from predictive.ocp.solution import SOLUTION_OUTPUTS
    from sspinn.model.body import BodyParameters
    from sspinn.run_folder import atomic_write_text, json_text

    check_speed(args.speed, "--speed")
    check_body(args.height, args.mass)
    args.out = output_target(args.out, stem_outputs(SOLUTION_OUTPUTS), args.overwrite, "a generated gait")
    generator = GaitGenerator.load(args.model)
    outside = generator.outside_training_range(args.speed, args.height, args.mass)
    if outside and not args.force:
        raise RequestError(f"{'; '.join(outside)} of {args.model}: the generator would extrapolate; "
                           "use --force to generate anyway")
    for problem in outside:
        print(f"WARNING: {problem} of {args.model}: extrapolated, no physics loss checked this gait", file=sys.stderr)
    body = BodyParameters.from_anthropometry(args.height, args.mass)
    sol = generator.predict(args.speed, body, refine_iterations=args.refine, force=args.force)
    summary = sol.summary()
    # the node residual of an OCP solution uses the collocation's backward differences; a
    # generated cycle has analytic q̈, so report the residual with those instead
    for key in [k for k in summary if k.startswith(("node_residual", "resampled_100hz"))]:
        del summary[key]
    summary["kane_rms_bw_analytic"] = sol.settings["kane_rms_bw"]
    if outside:
        summary["extrapolated"] = outside
    reference = None
    if args.speed < 2.0:
        try:
            reference = load_winter()
            summary.update({f"winter_{k}": v for k, v in compare_with_reference(sol, reference).items()})
        except FileNotFoundError as exc:
            print(f"(no comparison with Winter: {exc})")
    summary_path = args.out.with_name(args.out.name + "_summary.json")
    text = json_text(summary, default=float, label=summary_path)  # refuses NaN before anything is written
    path = sol.save(args.out)
    plot_gait(sol, args.out.with_name(args.out.name + ".png"), reference)
    atomic_write_text(summary_path, text)
    print(text)
    print(f"wrote {path}")
    return 0
