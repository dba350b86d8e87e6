"""Wall time per stride of label-free IMU tracking by optimal control, and its accuracy, for
four ways of running its multi-start, measured in the same run on the same stride.

Run ``python -m benchmarks.speed.bench_imu_tracking`` (about 3 min on an idle 2-core CPU; both cases,
all paths), ``--quick`` for a smoke run (the synthetic stride on 40 nodes only), ``--json PATH``
to also save the results. Threads are pinned to one per process (``OMP_NUM_THREADS`` etc.
default to 1); every path but the default runs in this one process.

Paths (:func:`predictive.ocp.imu_tracking.solve_imu_tracking`, its ``starts``, ``agree_rtol`` and
``workers`` arguments; the default multi-start of three speed guesses, the same label-free choice
rule in all):

* baseline, ``starts="independent"``: per start, a predictive multi-start
  (:data:`~predictive.ocp.collocation.DEFAULT_STARTS`) builds the guess and a tracking NLP of its
  own is built and solved (speed continuation: fixed, then free speed);
* ``starts="shared", agree_rtol=None``: the guesses by speed continuation on one predictive NLP
  (a multi-start at the middle speed only), and one tracking NLP and IPOPT solver for every
  start and both continuation steps; every start runs;
* ``workers=1``: as before, the starts from the middle speed outwards, stopped once two
  in-phase successful starts agree on the objective (``agree_rtol`` 1e-4; a start not run costs
  neither its guess nor its tracking);
* default: the same with a worker process for the predictive guesses where the machine has two
  cores (:class:`predictive.ocp.imu_tracking.ContinuedGuesses`): the middle speed's first start
  and the continuations run there while this process solves the second start and builds and
  runs the tracking NLP.

Cases: the averaged walking stride ``../shared/data/dorschky_P03_walking`` (skipped when absent;
1.75 m / 70 kg assumed, variance scaling, 100 nodes, as ``python -m predictive track-imu``) and
a synthetic stride made by the project's own tools (the predictive gait at 1.2 m/s over a 1.2 s
stride started at its right heel strike, its virtual IMUs and labels:
:func:`predictive.experiments.solution_vs_labels.recording_from_solution`; std scaling).

Reported per case and path: wall time of ``solve_imu_tracking`` (cold: no guess cache) split
into predictive guesses, IPOPT (all runs) and the rest (NLP and solver builds), the IPOPT
iterations per start, the chosen objective and speed, and the accuracy against the labels
(:func:`~predictive.experiments.solution_vs_labels.compare_with_labels`); then the ratios of
the baseline's wall time to each other path's and the largest difference of their accuracy
metrics from the baseline's. Timings on a
shared machine are contended: compare them only within one run.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[2]
DEFAULT_DATA = REPO.parent / "shared" / "data" / "dorschky_P03_walking"
#: The paths compared: name → keyword arguments of ``solve_imu_tracking`` (baseline first, default last).
PATHS: dict[str, dict[str, Any]] = {
    "independent": {"starts": "independent"},
    "all starts": {"starts": "shared", "agree_rtol": None, "workers": 1},
    "one process": {"workers": 1},
    "default": {},
}
METRICS = ("angle_rmsd_deg", "moment_rmsd_pct_bwbh", "grf_rmse_pct_bw", "speed_error_mps")


def synthetic_stride(n_nodes: int) -> Any:
    """The synthetic averaged stride (see the module docstring) on ``n_nodes`` nodes per stride."""
    from predictive import solve_predictive
    from predictive.experiments.solution_vs_labels import recording_from_solution
    from predictive.ocp.imu_tracking import roll_cycle
    from sspinn.model.body import IMUPlacement

    sol = solve_predictive(1.2, n_nodes=n_nodes // 2, duration=1.2)
    sol = roll_cycle(sol, sol.right_heel_strike())
    return recording_from_solution(sol, IMUPlacement.default(1.75))


def run_case(name: str, recording: Any, n_nodes: int, scales: str) -> list[dict[str, Any]]:
    """Every path on one stride; one row per path."""
    from predictive.experiments.solution_vs_labels import compare_with_labels
    from predictive.ocp.imu_tracking import solve_imu_tracking
    from sspinn.model.body import BodyParameters

    body = BodyParameters.from_anthropometry(recording.height, recording.mass)
    rows = []
    for path, kwargs in PATHS.items():
        t0 = time.perf_counter()
        result = solve_imu_tracking(recording, body, n_nodes=n_nodes, imu_scales=scales, **kwargs)
        wall = time.perf_counter() - t0
        sol, info = result.solution, result.info
        cmp = compare_with_labels(sol, recording)
        rows.append({
            "case": name,
            "path": path,
            "n_nodes": n_nodes,
            "wall_s": wall,
            "guess_s": info["guess_time_s"],
            "ipopt_s": info["ipopt_time_s"],
            "other_s": wall - info["guess_time_s"] - info["ipopt_time_s"],
            "iterations": [s.get("iterations", "-") for s in info["starts"]],  # "-": skipped
            "objectives": [s.get("objective") for s in info["starts"]],
            "status": sol.status,
            "objective": sol.objective,
            "speed": sol.speed,
            **{m: float(getattr(cmp, m)) for m in METRICS},
        })
        print(f"  {name} / {path}: {wall:.1f} s", flush=True)
    return rows


def report(rows: list[dict[str, Any]]) -> str:
    lines = [
        f"{'case':<12} {'path':<12} {'wall s':>7} {'guess s':>8} {'IPOPT s':>8} {'other s':>8} "
        f"{'iterations':>14} {'objective':>11} {'speed':>6} {'angles °':>9} {'moments':>8} {'GRF %BW':>8} {'v err':>6}"
    ]
    for r in rows:
        its = "/".join(str(i) for i in r["iterations"])
        lines.append(
            f"{r['case']:<12} {r['path']:<12} {r['wall_s']:>7.1f} {r['guess_s']:>8.1f} {r['ipopt_s']:>8.1f} {r['other_s']:>8.1f} "
            f"{its:>14} {r['objective']:>11.6g} {r['speed']:>6.3f} {r['angle_rmsd_deg']:>9.2f} "
            f"{r['moment_rmsd_pct_bwbh']:>8.2f} {r['grf_rmse_pct_bw']:>8.2f} {r['speed_error_mps']:>6.3f}"
        )
    lines.append("")
    baseline = next(iter(PATHS))
    for case in dict.fromkeys(r["case"] for r in rows):
        base = next(r for r in rows if r["case"] == case and r["path"] == baseline)
        for new in (r for r in rows if r["case"] == case and r["path"] != baseline):
            diffs = ", ".join(f"{m} {abs(new[m] - base[m]):.2g}" for m in METRICS)
            lines.append(
                f"{case}: {new['path']} is {base['wall_s'] / new['wall_s']:.2f}x faster than the baseline "
                f"({new['wall_s']:.1f} s vs {base['wall_s']:.1f} s per stride); objective differs by "
                f"{abs(new['objective'] - base['objective']) / abs(base['objective']):.1e} (relative); |Δ| {diffs}"
            )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> list[dict[str, Any]]:
    """Run the benchmark; returns its rows (one per case and path)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA, help="averaged-stride folder (skipped when absent)")
    parser.add_argument("--nodes", type=int, default=100, help="collocation nodes per stride")
    parser.add_argument("--quick", action="store_true", help="smoke run: the synthetic stride on 40 nodes only")
    parser.add_argument("--json", type=Path, default=None, help="also write the rows as JSON")
    args = parser.parse_args(argv)

    rows: list[dict[str, Any]] = []
    if args.quick:
        print("quick: synthetic stride, 40 nodes", flush=True)
        rows += run_case("synthetic", synthetic_stride(40), 40, "std")
    else:
        if (args.data / "signals.csv").exists():
            from sspinn.data.csv_readers import read_averaged_stride

            print(f"real stride: {args.data}", flush=True)
            recording = read_averaged_stride(args.data, height=1.75, mass=70.0, periods=1)
            rows += run_case(args.data.name.removeprefix("dorschky_"), recording, args.nodes, "auto")
        else:
            print(f"real stride skipped: {args.data} not present (../shared/data is optional)", flush=True)
        print("synthetic stride", flush=True)
        rows += run_case("synthetic", synthetic_stride(args.nodes), args.nodes, "std")
    print()
    print(f"{platform.processor() or platform.machine()}, OMP_NUM_THREADS={os.environ.get('OMP_NUM_THREADS', 'unset')}")
    print(report(rows))
    if args.json is not None:
        from sspinn.run_folder import atomic_write_text

        atomic_write_text(args.json, json.dumps(rows, indent=1) + "\n")
    return rows


if __name__ == "__main__":
    # one thread, before numba, BLAS and torch start theirs (they are imported lazily); a run
    # in-process (the smoke test) leaves the caller's settings alone
    for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS", "TORCH_NUM_THREADS"):
        os.environ.setdefault(_var, "1")
    main(sys.argv[1:])
