"""The ``solve`` sub-command of ``python -m predictive``: one predictive gait (trajectory optimisation).

``python -m predictive solve --speed 1.3 --out results/ocp/walk_1.3``

Solves the predictive gait problem (:func:`predictive.ocp.collocation.solve_predictive`), prints
IPOPT's status, iterations, solve time, the Kane residual at the nodes, stance fractions and —
when Winter's walking is at hand (``--data-dir`` or ``$SSPINN_SHARED_DATA``) — the RMSD against Winter's normal walking,
the gait against the human norms at its speed (``human_norms``: per-stance vertical GRF peak and
valley, stance / double-support / flight shares, cadence, angle RMSD;
:func:`predictive.ocp.gait_analysis.solution_norms`), and writes ``<out>.npz``/``<out>.json`` (the solution), ``<out>_summary.json`` and ``<out>.png``
(angles and GRF versus % gait cycle). When ``--out`` already holds a solution, it writes to the
first free ``<out>_2``, ``<out>_3``, … and says so, unless ``--overwrite``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

import numpy as np

from predictive.ocp.collocation import OCPError, solve_predictive
from predictive.ocp.gait_analysis import compare_with_reference, load_winter, plot_gait, solution_norms
from predictive.ocp.limits import (
    DURATION_RANGE_S,
    NODES_RANGE,
    RATE_RANGE_HZ,
    WEIGHT_RANGE,
    check_body,
    check_speed,
    solution_problems,
)
from predictive.ocp.solution import SOLUTION_OUTPUTS, GaitSolution
from sspinn.errors import UserError, bounded
from sspinn.run_folder import OVERWRITE_HELP, atomic_write_text, json_text, output_target, stem_outputs

#: Sub-command name.
COMMAND = "solve"

#: Speeds below this are compared with Winter's walking data, m/s.
WALKING_MAX_SPEED = 2.0


def add_parser(sub: Any) -> argparse.ArgumentParser:
    """Register the ``solve`` sub-command on an ``argparse`` sub-parsers object."""
    solve = sub.add_parser(COMMAND, help="solve a predictive gait problem and write the solution + plot")
    solve.add_argument("--speed", type=float, required=True, help="average speed, m/s")
    solve.add_argument("--out", type=Path, required=True, help="output path without suffix")
    solve.add_argument("--nodes", type=bounded(int, *NODES_RANGE), default=None,
                       help=f"collocation nodes, {NODES_RANGE[0]}–{NODES_RANGE[1]} (default 50 half / 100 full)")
    solve.add_argument("--rate-hz", type=bounded(float, *RATE_RANGE_HZ, " Hz"), default=None,
                       help="put the nodes on a sampling grid of this rate, e.g. 100 (instead of --nodes; "
                       f"{RATE_RANGE_HZ[0]:g}–{RATE_RANGE_HZ[1]:g} Hz, at most {NODES_RANGE[1]} nodes)")
    solve.add_argument("--cycle", choices=("half", "full"), default="half", help="symmetric half or full cycle")
    solve.add_argument("--effort", choices=("squared", "cubed"), default="cubed",
                       help="exponent of the normalised torques in the effort (default cubed)")
    solve.add_argument("--duration", type=bounded(float, *DURATION_RANGE_S, " s"), default=None,
                       help=f"stride duration, {DURATION_RANGE_S[0]:g}–{DURATION_RANGE_S[1]:g} s (default: typical)")
    solve.add_argument("--free-duration", action="store_true", help="optimise the stride duration")
    solve.add_argument("--w-acc", type=bounded(float, *WEIGHT_RANGE), default=None,
                       help=f"weight of the acceleration regularisation ({WEIGHT_RANGE[0]:g}–{WEIGHT_RANGE[1]:g})")
    for flag, what in (("--w-grf-cap", "GRF cap prior"), ("--w-angle-prior", "Winter angle prior (walking)"),
                       ("--w-grf-prior", "Winter vertical-GRF prior (walking)"), ("--w-slip", "sliding-power term")):
        solve.add_argument(flag, type=bounded(float, *WEIGHT_RANGE), default=None,
                           help=f"weight of the {what} (default: predictive.ocp.settings.ProblemSettings; 0 leaves it out)")
    solve.add_argument("--guess", type=Path, default=None, help="previous solution (.npz/.json) as initial guess")
    solve.add_argument("--height", type=float, default=1.75, help="body height, m")
    solve.add_argument("--mass", type=float, default=70.0, help="body mass, kg")
    solve.add_argument("--data-dir", type=Path, default=None,
                       help="folder holding winter_walking/ (default: $SSPINN_SHARED_DATA; without it no comparison)")
    solve.add_argument("--verbose", action="store_true", help="print IPOPT's iteration log")
    solve.add_argument("--overwrite", action="store_true", help=OVERWRITE_HELP)
    return solve


def _check_solve_args(args: argparse.Namespace) -> None:
    """Reject what the model cannot do before anything is built (see predictive.ocp.limits; the
    ranges of the numeric options are checked by argparse)."""
    check_speed(args.speed, "--speed")
    check_body(args.height, args.mass)
    if args.nodes is not None and args.rate_hz is not None:
        raise UserError("give --nodes or --rate-hz, not both")
    if args.rate_hz is not None and args.free_duration:
        raise UserError("--rate-hz needs a fixed stride duration (drop --free-duration)")


def run(args: argparse.Namespace) -> int:
    """Run the sub-command; returns the exit code (1 if IPOPT failed or the solution is not acceptable)."""
    from sspinn.model.body import BodyParameters

    _check_solve_args(args)
    args.out = output_target(args.out, stem_outputs(SOLUTION_OUTPUTS), args.overwrite, "a solution")
    body = BodyParameters.from_anthropometry(args.height, args.mass)
    extra = {name: getattr(args, name) for name in ("w_acc", "w_grf_cap", "w_angle_prior", "w_grf_prior", "w_slip")
             if getattr(args, name) is not None}
    guess = GaitSolution.load(args.guess) if args.guess is not None else None
    try:
        sol = solve_predictive(
            args.speed,
            body,
            n_nodes=args.nodes,
            rate_hz=args.rate_hz,
            effort=args.effort,
            gait_cycle=args.cycle,
            guess=guess,
            duration=args.duration,
            free_duration=args.free_duration,
            verbose=args.verbose,
            **extra,
        )
    except OCPError as exc:
        print(f"FAILED: {exc}", file=sys.stderr)
        if exc.solution is not None:
            path = exc.solution.save(args.out.with_name(args.out.name + "_failed"))
            print(f"last iterate written to {path}", file=sys.stderr)
        return 1
    problems = solution_problems(sol)
    if problems:
        where = ""
        if all(np.isfinite(getattr(sol, k)).all() for k in ("q", "u", "tau", "grf")):
            where = f"; the rejected solution is written to {sol.save(args.out.with_name(args.out.name + '_failed'))} for inspection"
        print(f"FAILED: IPOPT reported {sol.status}, but the solution is not acceptable: {'; '.join(problems)}{where}",
              file=sys.stderr)
        return 1
    summary = sol.summary()
    reference = None
    if args.speed < WALKING_MAX_SPEED:
        try:
            reference = load_winter(args.data_dir)
        except FileNotFoundError as exc:
            print(f"(no comparison with Winter: {exc})")
        else:
            summary.update({f"winter_{k}": v for k, v in compare_with_reference(sol, reference).items()})
    if sol.speed > 0:  # human norms (sspinn.data.gait_norms); the RMSD where Winter's walking is at hand
        norms = solution_norms(sol, reference)
        summary["human_norms"] = norms.summary()
        summary["human_norms_passed"] = norms.passed
    summary_path = args.out.with_name(args.out.name + "_summary.json")
    summary_text = json_text(summary, label=summary_path)  # refuses NaN before anything is written
    npz = sol.save(args.out)
    png = plot_gait(sol, args.out.with_name(args.out.name + ".png"), reference)
    atomic_write_text(summary_path, summary_text)
    width = max(len(k) for k in summary)
    for key, value in summary.items():
        text = f"{value:.6g}" if isinstance(value, float) else str(value)
        print(f"{key:<{width}}  {text}")
    print(f"wrote {npz}, {npz.with_name(npz.name[:-4] + '.json')}, {summary_path}, {png}")
    return 0


__all__ = ["COMMAND", "WALKING_MAX_SPEED", "add_parser", "run"]
