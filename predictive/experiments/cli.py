"""The experiment sub-commands of ``python -m predictive``: ``track-imu``, ``compare`` and ``robustness``.

``python -m predictive track-imu --data $SSPINN_SHARED_DATA/dorschky_P03_walking --out results/ocp/imu_tracking``:
IMU tracking of an averaged stride, compared with its labels. Reads the averaged stride
(:func:`sspinn.data.csv_readers.read_averaged_stride`; body height and mass are not recorded there, so
1.75 m / 70 kg are assumed unless given), solves
:func:`predictive.ocp.imu_tracking.solve_imu_tracking` (labels unused), compares the estimate with
the labels (:func:`predictive.experiments.solution_vs_labels.compare_with_labels`) and prints the
table next to the paper's OCP figures. Writes ``<out>.npz/.json`` (the solution),
``<out>_tracked.npz/.json`` (tracked signals, residuals, starts, times), ``<out>_metrics.json``,
``<out>_table.md`` and ``<out>.png`` (angles, moments, GRF versus the labels over the cycle).
Predictive initial guesses are cached in ``<out>_guesses/``.

``python -m predictive compare --config configs/predictive/compare.yaml --out results/compare``:
the comparison harness of :mod:`predictive.experiments.controller_comparison` (table, learning
curves, gait cycles, stick figures in ``<out>/report.md``).

``python -m predictive robustness --config configs/predictive/robustness.yaml --out results/robustness``:
falls of the generator's controllers per training seed, speed and reset seed under the configured
disturbances (:mod:`predictive.experiments.robustness`).
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path
from typing import Any

from predictive.ocp.limits import MAX_SPEED, NODES_RANGE, WEIGHT_RANGE
from sspinn.errors import bounded
from sspinn.run_folder import OVERWRITE_HELP, atomic_write_text, output_target, run_outputs, stem_outputs
from sspinn.yaml_config import shipped_path

#: Sub-command names.
TRACK_IMU = "track-imu"
COMPARE = "compare"
ROBUSTNESS = "robustness"
COMMANDS = (TRACK_IMU, COMPARE, ROBUSTNESS)
#: Most seeds ``compare --seeds`` keeps.
MAX_SEEDS = 1000


def add_track_imu_parser(sub: Any) -> argparse.ArgumentParser:
    """Register the ``track-imu`` sub-command on an ``argparse`` sub-parsers object."""
    p = sub.add_parser(TRACK_IMU, help="IMU tracking (label-free OCP baseline) of an averaged stride, compared with its labels")
    p.add_argument("--data", type=Path, required=True, help="averaged-stride folder (signals.csv, meta.json)")
    p.add_argument("--out", type=Path, required=True, help="output path without suffix")
    p.add_argument("--nodes", type=bounded(int, *NODES_RANGE), default=100,
                   help=f"collocation nodes per stride ({NODES_RANGE[0]}–{NODES_RANGE[1]})")
    p.add_argument("--height", type=float, default=1.75, help="assumed body height, m (not in the data)")
    p.add_argument("--mass", type=float, default=70.0, help="assumed body mass, kg (not in the data)")
    weights = f"{WEIGHT_RANGE[0]:g}–{WEIGHT_RANGE[1]:g}"
    p.add_argument("--effort-weight", type=bounded(float, *WEIGHT_RANGE), default=0.01, help=f"weight of the torque effort ({weights})")
    p.add_argument("--w-acc", type=bounded(float, *WEIGHT_RANGE), default=0.001,
                   help=f"weight of the acceleration regularisation ({weights})")
    p.add_argument("--imu-weight", type=bounded(float, *WEIGHT_RANGE), default=1.0, help=f"weight of every IMU channel ({weights})")
    p.add_argument("--scales", choices=("auto", "variance", "std"), default="auto",
                   help="normalisation of the tracking errors: across-trial variance (auto: when variance.csv exists)"
                   " or each channel's std over the cycle")
    p.add_argument("--speed-guess", type=bounded(float, 0.0, MAX_SPEED, " m/s"), nargs="+", default=None,
                   help="initial speed(s), m/s; several: multi-start, lowest objective wins (default: from the stride"
                   " duration × 0.85, 1, 1.2: a label-free multi-start)")
    p.add_argument("--fixed-speed", action="store_true", help="fix the speed to the (first) guess instead of optimising it")
    p.add_argument("--guess", choices=("predictive", "generic"), default="predictive", help="initial guess")
    p.add_argument("--starts", choices=("shared", "independent"), default="shared",
                   help="multi-start: guesses by speed continuation and one tracking NLP for all starts (shared), or a"
                   " predictive multi-start and a tracking NLP per start (independent; same optimum, about twice the time)")
    p.add_argument("--all-starts", action="store_true",
                   help="run every start of the shared multi-start (default: from the middle speed outwards, stopped"
                   " once two in-phase starts agree on the objective)")
    p.add_argument("--align", choices=("data", "heel_strike"), default="data",
                   help="time alignment with the labels (data: node 0 = first data sample)")
    p.add_argument("--verbose", action="store_true", help="print IPOPT's iteration log")
    p.add_argument("--overwrite", action="store_true", help=OVERWRITE_HELP)
    return p


def add_compare_parser(sub: Any) -> argparse.ArgumentParser:
    """Register the ``compare`` sub-command on an ``argparse`` sub-parsers object."""
    p = sub.add_parser(COMPARE, help="self-supervised generator vs SB3 agents vs OCP on the same env and metrics")
    p.add_argument("--config", type=Path, default=shipped_path("configs/predictive/compare.yaml"),
                   help="ComparisonConfig YAML (default: the project's configs/predictive/compare.yaml)")
    p.add_argument("--out", type=Path, required=True, help="report folder")
    p.add_argument("--seeds", type=bounded(int, 1, MAX_SEEDS), default=None,
                   help=f"use only the first N seeds (quick runs; 1–{MAX_SEEDS})")
    p.add_argument("--overwrite", action="store_true",
                   help="run every cell again and replace the report in --out (else a finished report is kept: a NOTE and "
                   "the first free <out>_2, …; an interrupted run in --out continues with the cells it finished)")
    return p


def add_robustness_parser(sub: Any) -> argparse.ArgumentParser:
    """Register the ``robustness`` sub-command on an ``argparse`` sub-parsers object."""
    p = sub.add_parser(ROBUSTNESS, help="falls of the generator's controllers per training seed, speed and reset seed")
    p.add_argument("--config", type=Path, default=shipped_path("configs/predictive/robustness.yaml"),
                   help="robustness YAML (default: the project's configs/predictive/robustness.yaml)")
    p.add_argument("--out", type=Path, required=True, help="report folder")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="override a config entry (repeatable), e.g. --set env.reset_noise_scale=0.005")
    p.add_argument("--overwrite", action="store_true", help=OVERWRITE_HELP)
    return p


def run(args: argparse.Namespace) -> int:
    """Run ``args.command`` (one of :data:`COMMANDS`); returns the exit code."""
    if args.command == TRACK_IMU:
        return run_track_imu(args)
    if args.command == COMPARE:
        return run_compare(args)
    if args.command == ROBUSTNESS:
        return run_robustness(args)
    raise ValueError(f"not an experiment sub-command: {args.command!r}")


#: What ``track-imu`` writes beside its ``--out`` path (the solution, the tracked signals, the
#: plot, the table and the metrics).
TRACK_IMU_OUTPUTS: tuple[str, ...] = (".npz", ".json", "_tracked.npz", "_tracked.json", ".png", "_table.md", "_metrics.json")

def _holds_report(folder: Path) -> bool:
    """Whether ``folder`` holds a finished ``compare`` or ``robustness`` report (the same two files)."""
    from predictive.experiments.controller_comparison import REPORT_FILES

    return bool(run_outputs(folder, REPORT_FILES))


def run_compare(args: argparse.Namespace) -> int:
    """Run ``compare``; returns the exit code (a bad configuration raises a user error)."""
    from predictive.experiments.controller_comparison import ComparisonConfig, run_comparison

    config = ComparisonConfig.from_yaml(args.config)
    if args.seeds is not None:
        config.seeds = config.seeds[: args.seeds]
    args.out = output_target(args.out, _holds_report, args.overwrite, "a finished comparison")
    run_comparison(config, args.out, overwrite=args.overwrite)
    print(f"report: {args.out / 'report.md'}")
    return 0


def run_robustness(args: argparse.Namespace) -> int:
    """Run ``robustness``; prints the report; returns the exit code."""
    from predictive.experiments.robustness import RobustnessConfig, report, run_robustness

    config = RobustnessConfig.from_yaml(args.config, settings=args.set)  # a bad one is a one-line user error
    args.out = output_target(args.out, _holds_report, args.overwrite, "a finished robustness report")
    results = run_robustness(config, args.out)
    print(report(config, results))
    print(f"report: {args.out / 'report.md'}")
    return 0


def run_track_imu(args: argparse.Namespace) -> int:
    """Run ``track-imu``; returns the exit code (1 if IPOPT failed on every start)."""
    from predictive.experiments.solution_vs_labels import compare_with_labels, plot_against_labels, write_comparison
    from predictive.ocp.imu_tracking import AGREE_RTOL, solve_imu_tracking
    from predictive.ocp.limits import check_body
    from sspinn.data.csv_readers import read_averaged_stride
    from sspinn.model.body import BodyParameters

    check_body(args.height, args.mass)
    args.out = output_target(args.out, stem_outputs(TRACK_IMU_OUTPUTS), args.overwrite, "an IMU tracking result")
    t0 = time.perf_counter()
    recording = read_averaged_stride(args.data, height=args.height, mass=args.mass, periods=1)
    body = BodyParameters.from_anthropometry(args.height, args.mass)
    result = solve_imu_tracking(
        recording,
        body,
        n_nodes=args.nodes,
        imu_weight=args.imu_weight,
        effort_weight=args.effort_weight,
        w_acc=args.w_acc,
        speed_guess=args.speed_guess,
        free_speed=not args.fixed_speed,
        guess=args.guess,
        guess_cache=args.out.with_name(args.out.name + "_guesses"),
        imu_scales=args.scales,
        verbose=args.verbose,
        starts=args.starts,
        agree_rtol=None if args.all_starts else AGREE_RTOL,
    )
    sol = result.solution
    wall = time.perf_counter() - t0
    n_starts = sum(s["status"] != "skipped" for s in result.info["starts"])
    detail = (
        f"all of it (reading, {n_starts} predictive guess(es), NLP build, {n_starts} IPOPT run(s), {args.starts} starts); "
        f"guesses {result.info['guess_time_s']:.1f} s; IPOPT {result.info['ipopt_time_s']:.1f} s; "
        f"chosen run {sol.iterations} it., {sol.solve_time:.1f} s; "
        f"{result.info['processes']} process(es) of one thread on a {os.cpu_count()}-CPU machine"
    )
    comparison = compare_with_labels(sol, recording, align=args.align, solve_time_s=wall, solve_time_detail=detail)
    npz = result.save(args.out)
    png = plot_against_labels(sol, recording, args.out.with_name(args.out.name + ".png"), result)
    table = comparison.table()
    header = (
        f"IMU tracking of {recording.name}: {args.nodes} nodes, scaling {result.info['scaling']}, "
        f"effort weight {args.effort_weight}, assumed {args.height} m / {args.mass} kg; status {sol.status}"
    )
    starts = "\n".join(
        f"- start {s['speed_guess']:.3f} m/s: skipped (two starts agreed)" if s["status"] == "skipped" else
        f"- start {s['speed_guess']:.3f} m/s: {s['status']}, objective {s['objective']:.4g}, speed {s['speed']:.3f} m/s"
        f"{' (chosen)' if s['chosen'] else ''}"
        for s in result.info["starts"]
    )
    alignment = (
        f"time alignment: {args.align} (shift {comparison.shift_applied_pct:+.1f} % cycle); right heel strike "
        f"(vertical GRF > 0.1 BW) at {comparison.heel_strike_model_pct:.1f} % (model) vs "
        f"{comparison.heel_strike_labels_pct:.1f} % (labels)"
    )
    text = f"{header}\n\n{table}\n\n{alignment}\n\n{starts}\n"
    atomic_write_text(args.out.with_name(args.out.name + "_table.md"), text)
    metrics = write_comparison(
        comparison,
        args.out.with_name(args.out.name + "_metrics.json"),
        extra={"tracking_info": result.info, "residuals": result.residuals(), "settings": sol.settings},
    )
    print(text)
    print(f"wrote {npz}, {metrics}, {png}")
    return 0 if sol.success else 1


__all__ = ["COMMANDS", "COMPARE", "TRACK_IMU", "add_compare_parser", "add_track_imu_parser", "run"]
