"""Do the optimisation tests and the default synthetic dataset survive other machines?

IPOPT's path depends on rounding: the same code and inputs reached other local optima (and one
infeasible stride) on an AMD EPYC with AVX-512 than on an AVX2 machine. This script
simulates such machines by perturbations that change the floating-point path but not the
problem, and runs, under each of them,

1. the optimisation tests (``tests/test_ocp.py``, ``tests/test_tracking.py``,
   ``tests/test_synthetic.py``) in a fresh pytest process, and
2. the default synthetic dataset (``configs/synth/default.yaml``) generated **cold** (an empty
   cache of its own) with ``python -m predictive synth``.

A perturbation passes when every test passes and the dataset is complete: exit 0, every
recording of the configuration present, the labels' Kane residual ≤ 1e-6 BW / BW·H. Strides that
needed a fallback rung, and recordings that ended early, are counted (they are not failures:
that is what the fallback ladder is for) and reported.

Perturbations (:data:`PERTURBATIONS`): relative noise of 1e-9 or 1e-8 on every IPOPT initial
guess with different seeds (``SSPINN_OCP_JITTER``, :mod:`predictive.ocp.perturbation`), 1 vs 2
BLAS/OpenMP threads, MUMPS pivoting options (``SSPINN_IPOPT_OPTIONS``), and other dataset seeds.

Usage (one process per job; ``--jobs 2`` runs two perturbations side by side on one thread each)::

    python scripts/check_robustness.py --out results/robustness --jobs 2
    python scripts/check_robustness.py --only tests --perturbations jitter_1e-9_s1 threads_1

Each finished perturbation is written to ``<out>/<name>.json`` at once, so an interrupted run
continues where it stopped (``--force`` redoes them); ``<out>/summary.md`` holds the table and the
pass rate. Exit code 0 only if every perturbation passed.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
OCP_TESTS = ("tests/test_ocp.py", "tests/test_tracking.py", "tests/test_synthetic.py")
DEFAULT_CONFIG = ROOT / "configs" / "synth" / "default.yaml"
RESIDUAL_TOL = 1e-6  # BW, BW·H


@dataclass(frozen=True)
class Perturbation:
    """One simulated machine: environment variables for every process, and an optional
    synthetic-dataset seed (None: the configuration's own)."""

    name: str
    env: dict[str, str] = field(default_factory=dict)
    seed: int | None = None
    description: str = ""


def _jitter(eps: str, seed: int) -> dict[str, str]:
    return {"SSPINN_OCP_JITTER": eps, "SSPINN_OCP_SEED": str(seed)}


def _ipopt(options: dict[str, Any]) -> dict[str, str]:
    return {"SSPINN_IPOPT_OPTIONS": json.dumps(options)}


def _threads(n: int) -> dict[str, str]:
    return {v: str(n) for v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")}


PERTURBATIONS: tuple[Perturbation, ...] = (
    Perturbation("jitter_1e-9_s1", _jitter("1e-9", 1), description="guesses × (1 + 1e-9·N(0,1)), seed 1"),
    Perturbation("jitter_1e-9_s2", _jitter("1e-9", 2), description="guesses × (1 + 1e-9·N(0,1)), seed 2"),
    Perturbation("jitter_1e-9_s3", _jitter("1e-9", 3), description="guesses × (1 + 1e-9·N(0,1)), seed 3"),
    Perturbation("jitter_1e-8_s4", _jitter("1e-8", 4), description="guesses × (1 + 1e-8·N(0,1)), seed 4"),
    Perturbation("threads_1", _threads(1), description="1 BLAS/OpenMP thread"),
    Perturbation("threads_2", _threads(2), description="2 BLAS/OpenMP threads"),
    Perturbation("mumps_pivtol_1e-4", _ipopt({"mumps_pivtol": 1e-4}), description="MUMPS pivot tolerance 1e-4 (default 1e-6)"),
    Perturbation(
        "mumps_order_scaling",
        _ipopt({"mumps_pivot_order": 5, "mumps_scaling": 8}),
        description="MUMPS METIS ordering, scaling 8 (defaults: auto, 77)",
    ),
    Perturbation(
        "jitter_1e-9_s5_threads_1", {**_jitter("1e-9", 5), **_threads(1)}, description="jitter seed 5 and 1 thread"
    ),
    Perturbation("dataset_seed_1", seed=1, description="synthetic dataset seed 1 (other subjects and plans)"),
    Perturbation("dataset_seed_2", seed=2, description="synthetic dataset seed 2 (other subjects and plans)"),
    Perturbation("jitter_1e-9_s6_seed_3", _jitter("1e-9", 6), seed=3, description="jitter seed 6 and dataset seed 3"),
)


def _env(p: Perturbation, threads_each: int) -> dict[str, str]:
    env = dict(os.environ)
    env.update(_threads(threads_each))
    env.update(p.env)  # a thread perturbation overrides the default
    env.setdefault("PYTHONHASHSEED", "0")
    return env


def run_tests(p: Perturbation, env: dict[str, str], log: Path) -> dict[str, Any]:
    """The optimisation tests in a fresh pytest process; returns pass/fail and pytest's summary."""
    t0 = time.perf_counter()
    cmd = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", *OCP_TESTS]
    proc = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True)
    log.write_text(proc.stdout + proc.stderr)
    lines = [ln for ln in proc.stdout.strip().splitlines() if ln.strip()]
    return {"passed": proc.returncode == 0, "summary": lines[-1] if lines else "", "seconds": time.perf_counter() - t0}


def run_dataset(p: Perturbation, env: dict[str, str], log: Path) -> dict[str, Any]:
    """The default synthetic dataset, cold, in a temporary folder; returns pass/fail and stats."""
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix=f"robust_{p.name}_") as tmp:
        out, cache = Path(tmp) / "data", Path(tmp) / "cache"
        cmd = [sys.executable, "-m", "predictive", "synth", "--config", str(DEFAULT_CONFIG), "--out", str(out)]
        cmd += ["--cache-dir", str(cache), "--workers", "1", "--no-progress"]
        if p.seed is not None:
            cmd += ["--seed", str(p.seed)]
        proc = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True)
        log.write_text(proc.stdout + proc.stderr)
        result: dict[str, Any] = {"exit_code": proc.returncode, "seconds": time.perf_counter() - t0}
        if proc.returncode != 0 or not (out / "dataset.json").exists():
            tail = (proc.stderr.strip().splitlines() or ["?"])[-1]
            return {**result, "passed": False, "reason": f"exit {proc.returncode}: {tail}"}
        info = json.loads((out / "dataset.json").read_text())["info"]
    expected = info["config"]["n_subjects"] * info["config"]["programs_per_subject"]
    res = info["kane_residual"]
    events = info.get("events", [])
    complete = info["n_recordings"] == expected and not any(e["event"] == "dropped" for e in events)
    exact = res["max_trans_bw"] <= RESIDUAL_TOL and res["max_rot_bwh"] <= RESIDUAL_TOL
    result.update(
        {
            "passed": complete and exact,
            "recordings": info["n_recordings"],
            "expected_recordings": expected,
            "duration_s": info["total_duration_s"],
            "strides": sum(info["solver"]["fallbacks"].values()),
            "fallbacks": {k: v for k, v in info["solver"]["fallbacks"].items() if v and k != "warm"},
            "ended_early": [e["recording"] for e in events if e["event"] == "ended_early"],
            "plans_redrawn": sum(e["event"] == "plan_redrawn" for e in events),
            "kane_residual_max": max(res["max_trans_bw"], res["max_rot_bwh"]),
        }
    )
    if not result["passed"]:
        result["reason"] = "incomplete dataset" if not complete else "Kane residual above tolerance"
    return result


def check(p: Perturbation, out: Path, only: str | None, threads_each: int, force: bool) -> dict[str, Any]:
    path = out / f"{p.name}.json"
    if path.exists() and not force:
        done = json.loads(path.read_text())
        if done.get("only") == only:
            return done
    env = _env(p, threads_each)
    record: dict[str, Any] = {"name": p.name, "description": p.description, "env": p.env, "seed": p.seed, "only": only}
    if only in (None, "tests"):
        record["tests"] = run_tests(p, env, out / f"{p.name}_tests.log")
    if only in (None, "dataset"):
        record["dataset"] = run_dataset(p, env, out / f"{p.name}_dataset.log")
    record["passed"] = all(record[k]["passed"] for k in ("tests", "dataset") if k in record)
    tmp = path.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(record, indent=2))
    tmp.replace(path)
    status = "PASS" if record["passed"] else "FAIL"
    print(f"{status}  {p.name}: " + json.dumps({k: record[k] for k in ("tests", "dataset") if k in record}), flush=True)
    return record


def summary(records: list[dict[str, Any]]) -> str:
    rows = [
        "| perturbation | tests | dataset | strides on a fallback rung | ended early | time (s) |",
        "|---|---|---|---|---|---|",
    ]
    for r in records:
        t, d = r.get("tests"), r.get("dataset")
        tests = "–" if t is None else f"{'pass' if t['passed'] else 'FAIL'} ({t['summary']})"
        data = "–" if d is None else ("pass" if d["passed"] else f"FAIL: {d.get('reason', '')}")
        if d is not None and d["passed"]:
            data += f" ({d['recordings']}/{d['expected_recordings']} recordings, {d['duration_s']:.0f} s)"
        fb = "–" if d is None or "fallbacks" not in d else (", ".join(f"{k} {v}" for k, v in d["fallbacks"].items()) or "0")
        early = "–" if d is None or "ended_early" not in d else (", ".join(d["ended_early"]) or "0")
        seconds = sum(x["seconds"] for x in (t, d) if x is not None)
        rows.append(f"| {r['name']}: {r['description']} | {tests} | {data} | {fb} | {early} | {seconds:.0f} |")
    n_pass = sum(r["passed"] for r in records)
    rows.append("")
    rows.append(f"**Pass rate: {n_pass}/{len(records)} ({100 * n_pass / max(len(records), 1):.0f} %)**")
    return "\n".join(rows)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=ROOT / "results" / "robustness", help="result folder")
    parser.add_argument("--jobs", type=int, default=1, help="perturbations run side by side (1 thread each)")
    parser.add_argument("--only", choices=("tests", "dataset"), default=None, help="run one half only")
    parser.add_argument("--perturbations", nargs="+", default=None, help="names (default: all)")
    parser.add_argument("--force", action="store_true", help="redo perturbations already in --out")
    args = parser.parse_args(argv)
    chosen = list(PERTURBATIONS)
    if args.perturbations:
        known = {p.name: p for p in PERTURBATIONS}
        unknown = sorted(set(args.perturbations) - set(known))
        if unknown:
            parser.error(f"unknown perturbation(s) {unknown}; known: {sorted(known)}")
        chosen = [known[n] for n in args.perturbations]
    if args.jobs < 1:
        parser.error(f"--jobs must be >= 1, got {args.jobs}")
    args.out.mkdir(parents=True, exist_ok=True)
    threads_each = 1 if args.jobs > 1 else 2
    t0 = time.perf_counter()
    with ThreadPoolExecutor(max_workers=args.jobs) as pool:
        records = list(pool.map(lambda p: check(p, args.out, args.only, threads_each, args.force), chosen))
    text = summary(records)
    text += f"\n\nCommand: `python scripts/check_robustness.py {' '.join(argv if argv is not None else sys.argv[1:])}`"
    text += f" ({time.perf_counter() - t0:.0f} s wall)\n"
    (args.out / "summary.md").write_text(text)
    print(text)
    shutil.rmtree(args.out / "__pycache__", ignore_errors=True)
    return 0 if all(r["passed"] for r in records) else 1


if __name__ == "__main__":
    raise SystemExit(main())
