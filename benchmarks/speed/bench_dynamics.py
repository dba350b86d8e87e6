"""Speed of the generated model code against a naive SymPy ``lambdify`` baseline measured in the same run.

Run ``python -m benchmarks.speed.bench_dynamics`` (0.5–1.5 min on 2 CPU cores), ``--quick`` for a smoke run
(one small batch, one repeat: ~15 s, most of it deriving and lambdifying the model; its figures mean
little), ``--json PATH`` to also save the results. ``--no-cuda`` skips the GPU even when torch sees one.

What is measured:

1. **Kane residual, forward + backward, torch float32** (CPU; CUDA too when available), at batch 4,096 and
   65,536 states. One call = ``r = kane_residual(q, u, qdd, tau, grf, w, p)``, ``loss = r.square().sum()``,
   ``loss.backward()`` with ``requires_grad`` on q, u, qdd, tau and grf (w and the body parameters p are
   constant inputs).

   * ours: :func:`sspinn.model.dynamics.kane_residual` (generated array code with common-subexpression
     elimination, ``sspinn/model/_generated/model_expr.py``);
   * baseline ("naive"): ``sympy.lambdify(..., "torch")`` of each entry of the unsimplified residual
     ``derive().outputs["kane_residual"]`` (no CSE), results joined with ``torch.stack``; inputs are
     passed as the columns of the same tensors (parameters as 0-d tensors), so autograd and batching
     work as for ours.

   Reported: states/s = batch / (median seconds per call), and the ratio ours / naive. Target: ≥ 3×.

2. **Single-state forward dynamics q̈ = M⁻¹ f, NumPy float64**, one state per call from a Python loop:

   * baseline ("naive"): ``sympy.lambdify(..., "numpy")`` of the unsimplified M (9×9) and f (9),
     evaluated on one state, then ``np.linalg.solve``;
   * :func:`sspinn.model.dynamics.forward_dynamics` on one state (the generated array code on NumPy);
   * :func:`sspinn.model.simulation.accel` (numba scalar kernels) called from Python, without and with the
     contact model (with contact it also evaluates the ground reaction forces);
   * :func:`sspinn.model.simulation.simulate` with RK4 (a compiled loop): evaluations/s counts the
     4 · steps accel calls of the rollout (the extra contact evaluation per output sample is not
     counted, so this slightly understates the rate).

   Reported: evaluations/s (median over repeats of loops lasting at least ``min_repeat_s``) and the
   ratio to the baseline.

Every row also reports the largest deviation from its baseline on the benchmarked inputs, so a fast
but wrong result cannot pass unnoticed. Timing: ``time.perf_counter``, warm-up calls first (numba
compilation, torch allocator), median of several repeats; torch uses ``TORCH_THREADS`` threads.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from functools import partial
from pathlib import Path
from typing import Any, NamedTuple

import numba
import numpy as np
import sympy as sp
import torch

from sspinn.model import dynamics, simulation
from sspinn.model.body import BodyParameters
from sspinn.model.contact import ContactParameters
from sspinn.model.derivation import SymbolicModel, derive
from sspinn.model.kinematics import point_index, point_kinematics
from sspinn.testing import random_inputs

TORCH_THREADS = 2
TARGET_RATIO = 3.0  # Kane residual forward + backward: ours ≥ 3× the naive lambdify baseline
RESIDUAL_INPUTS = ("q", "u", "qdd", "tau", "grf", "w", "p")  # argument order of kane_residual
GRAD_INPUTS = ("q", "u", "qdd", "tau", "grf")
SEED = 0


@dataclass(frozen=True)
class Settings:
    """How much to measure."""

    batches: tuple[int, ...]
    warmup: int  # untimed calls before timing
    repeats: int  # timed repeats; the median is reported
    min_repeat_s: float  # a single-state repeat loops until it lasts at least this long
    sim_duration: float  # s of simulated motion per simulate() call


FULL = Settings(batches=(4096, 65536), warmup=3, repeats=7, min_repeat_s=0.25, sim_duration=1.0)
QUICK = Settings(batches=(256,), warmup=1, repeats=1, min_repeat_s=0.01, sim_duration=0.05)


@dataclass
class Row:
    """One measured figure."""

    section: str
    method: str
    device: str
    batch: int
    rate: float  # states/s (section 1) or evaluations/s (section 2)
    ratio: float  # rate / baseline rate
    max_deviation: float | None  # largest |difference| from the baseline's result (relative in section 1)
    spread: float  # (slowest − fastest) / median repeat time: how noisy the figure is


@dataclass
class Results:
    settings: dict[str, Any]
    environment: dict[str, Any]
    rows: list[Row] = field(default_factory=list)
    target_ratio: float = TARGET_RATIO
    total_seconds: float = 0.0


# ------------------------------------------------------------------------------------------------ timing
class Timing(NamedTuple):
    seconds: float  # median over the repeats
    spread: float  # (max − min) / median


def time_calls(fn: Callable[[], Any], warmup: int, repeats: int, sync: Callable[[], None] = lambda: None) -> Timing:
    """Wall time of one call of ``fn`` after ``warmup`` untimed calls (``sync`` waits for a GPU)."""
    for _ in range(warmup):
        fn()
    sync()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        sync()
        times.append(time.perf_counter() - t0)
    median = statistics.median(times)
    return Timing(median, (max(times) - min(times)) / median)


def time_loop(fn: Callable[[], Any], settings: Settings) -> tuple[int, Timing]:
    """(n, timing of n calls) of a fast ``fn``, n chosen so a repeat lasts ``min_repeat_s`` (like timeit)."""
    for _ in range(settings.warmup):
        fn()
    t0 = time.perf_counter()
    fn()
    per_call = max(time.perf_counter() - t0, 1e-7)
    n = max(1, int(settings.min_repeat_s / per_call))

    def loop() -> None:
        for _ in range(n):
            fn()

    return n, time_calls(loop, warmup=0, repeats=settings.repeats)


# ------------------------------------------------------------------------------------------------ inputs
def body_vector() -> np.ndarray:
    return BodyParameters.from_anthropometry(1.75, 70.0).vector()


def standing_state(p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """All joints straight, the lowest foot point 1 cm below the ground (so the contact model acts)."""
    q = np.zeros(9)
    zeros = np.zeros(9)
    points = point_kinematics(q, zeros, zeros, np.zeros(2), p)
    feet = [point_index(f"{end}_{side}") for end in ("heel", "toe") for side in ("r", "l")]
    q[1] = -points[feet, 1].min() - 0.01
    return q, zeros.copy()


# ------------------------------------------------------------------------------------------------ baselines
def flat_symbols(model: SymbolicModel, groups: Sequence[str]) -> list[sp.Symbol]:
    return [s for g in groups for s in model.inputs[g]]


def naive_torch_residual(model: SymbolicModel) -> Callable[..., torch.Tensor]:
    """Kane residual from ``sympy.lambdify(..., "torch")`` of each unsimplified entry, joined by torch.stack.

    (Lambdifying the whole Matrix would wrap the result in ``torch.tensor(...)``, which breaks autograd.)
    """
    residual = model.outputs["kane_residual"]
    symbols = flat_symbols(model, RESIDUAL_INPUTS)
    entries = [sp.lambdify(symbols, residual[i], "torch") for i in range(residual.shape[0])]

    def kane_residual(q, u, qdd, tau, grf, w, p) -> torch.Tensor:
        args = [x for tensor in (q, u, qdd, tau, grf, w, p) for x in tensor.unbind(-1)]
        return torch.stack([entry(*args) for entry in entries], dim=-1)

    return kane_residual


def naive_numpy_forward_dynamics(model: SymbolicModel) -> Callable[..., np.ndarray]:
    """q̈ from ``sympy.lambdify(..., "numpy")`` of the unsimplified M and f, then ``np.linalg.solve``."""
    mass = sp.lambdify(flat_symbols(model, ("q", "p")), model.outputs["mass_matrix"], "numpy")
    force = sp.lambdify(flat_symbols(model, ("q", "u", "tau", "grf", "w", "p")), model.outputs["forcing"], "numpy")

    def forward_dynamics(q, u, tau, grf, w, p) -> np.ndarray:
        M = mass(*q, *p)
        f = force(*q, *u, *tau, *grf, *w, *p)
        return np.linalg.solve(M, f)[:, 0]

    return forward_dynamics


# ------------------------------------------------------------------------------------------------ section 1
def torch_inputs(batch: int, device: str) -> list[torch.Tensor]:
    """Inputs of kane_residual in argument order, float32; leaves with requires_grad for GRAD_INPUTS."""
    data = random_inputs(np.random.default_rng(SEED), (batch,)) | {"p": body_vector()}
    return [
        torch.tensor(data[k], dtype=torch.float32, device=device, requires_grad=k in GRAD_INPUTS)
        for k in RESIDUAL_INPUTS
    ]


def forward_backward(residual: Callable[..., torch.Tensor], inputs: list[torch.Tensor]) -> None:
    """One timed call: residual, loss = r.square().sum(), backward into the input leaves."""
    for x in inputs:
        x.grad = None
    residual(*inputs).square().sum().backward()


def bench_residual_torch(model: SymbolicModel, settings: Settings, devices: list[str]) -> list[Row]:
    """Kane residual forward + backward throughput, ours vs naive lambdify, torch float32."""
    naive = naive_torch_residual(model)
    section = "kane_residual_fwd_bwd_torch_float32"
    rows = []
    for device in devices:
        sync = torch.cuda.synchronize if device == "cuda" else (lambda: None)
        for batch in settings.batches:
            inputs = torch_inputs(batch, device)
            with torch.no_grad():
                r_ours, r_naive = dynamics.kane_residual(*inputs), naive(*inputs)
                deviation = float((r_ours - r_naive).abs().max() / r_naive.abs().max())
            t_naive, t_ours = (
                time_calls(partial(forward_backward, fn, inputs), settings.warmup, settings.repeats, sync)
                for fn in (naive, dynamics.kane_residual)
            )
            rate_naive, rate_ours = batch / t_naive.seconds, batch / t_ours.seconds
            rows.append(Row(section, "naive", device, batch, rate_naive, 1.0, 0.0, t_naive.spread))
            rows.append(
                Row(section, "ours", device, batch, rate_ours, rate_ours / rate_naive, deviation, t_ours.spread)
            )
    return rows


# ------------------------------------------------------------------------------------------------ section 2
def bench_single_state_numpy(model: SymbolicModel, settings: Settings) -> list[Row]:
    """Single-state forward-dynamics evaluations per second, NumPy float64."""
    naive = naive_numpy_forward_dynamics(model)
    p, c = body_vector(), ContactParameters().vector()
    s = random_inputs(np.random.default_rng(SEED), ())
    q, u, tau = s["q"], s["u"], s["tau"]
    grf, w = dynamics.contact_forces(q, u, p, c)  # the forces accel computes itself with contact on
    no_grf, no_w = np.zeros(4), np.zeros(2)

    q0, u0 = standing_state(p)
    n_samples, substeps = max(1, round(settings.sim_duration / 0.01)), 10
    sim_evals = 4 * n_samples * substeps  # rk4: 4 accel evaluations per step

    def rollout() -> None:
        trajectory = simulation.simulate(q0, u0, p, duration=n_samples * 0.01, sample_dt=0.01, substeps=substeps)
        if not np.all(np.isfinite(trajectory.q)):
            raise RuntimeError("simulation diverged: timings would be meaningless")

    reference_contact = naive(q, u, tau, grf, w, p)
    reference_free = naive(q, u, tau, no_grf, no_w, p)
    cases: list[tuple[str, Callable[[], Any], int, np.ndarray | None]] = [
        # (method, one call, model evaluations per call, reference q̈ for the deviation or None)
        ("naive", partial(naive, q, u, tau, grf, w, p), 1, reference_contact),
        ("forward_dynamics", partial(dynamics.forward_dynamics, q, u, tau, grf, w, p), 1, reference_contact),
        ("accel_python_loop_no_contact", partial(simulation.accel, q, u, tau, p, c, False), 1, reference_free),
        ("accel_python_loop_contact", partial(simulation.accel, q, u, tau, p, c, True), 1, reference_contact),
        ("simulate_rk4_compiled_loop_contact", rollout, sim_evals, None),
    ]
    rows = []
    baseline = 0.0
    for method, fn, evals_per_call, reference in cases:
        deviation = None if reference is None else float(np.abs(fn() - reference).max())
        n_calls, timing = time_loop(fn, settings)
        rate = n_calls * evals_per_call / timing.seconds
        baseline = baseline or rate
        section = "forward_dynamics_single_state_numpy"
        rows.append(Row(section, method, "cpu", 1, rate, rate / baseline, deviation, timing.spread))
    return rows


# ------------------------------------------------------------------------------------------------ report
LABELS = {
    "naive": "naive lambdify M, f + np.linalg.solve (baseline)",
    "forward_dynamics": "sspinn.model.dynamics.forward_dynamics (generated, numpy)",
    "accel_python_loop_no_contact": "sspinn.model.simulation.accel, numba, Python loop, no contact",
    "accel_python_loop_contact": "sspinn.model.simulation.accel, numba, Python loop, with contact",
    "simulate_rk4_compiled_loop_contact": "sspinn.model.simulation.simulate rk4 (compiled loop, contact)",
}


def format_table(results: Results) -> str:
    env = results.environment
    lines = [
        f"sspinn dynamics benchmark ({results.settings['mode']} run) — Python {env['python']}, torch {env['torch']}, "
        f"numpy {env['numpy']}, numba {env['numba']}, sympy {env['sympy']}",
        f"{env['cpu_count']} CPU cores ({env['machine']}), torch.set_num_threads({env['torch_threads']}), "
        f"median of {results.settings['repeats']} repeats after {results.settings['warmup']} warm-up calls",
        "",
        "1. Kane residual r = M(q)·q̈ − f, forward + backward (loss = r.square().sum(); grads wrt q, u, qdd, tau, grf)",
        "   naive = sympy.lambdify(module='torch') of each unsimplified entry, torch.stack; torch float32",
        f"   {'device':<7}{'batch':>8}{'naive [states/s]':>20}{'ours [states/s]':>20}{'ours/naive':>12}"
        f"{'max rel |Δr|':>14}",
    ]
    residual = [r for r in results.rows if r.section.startswith("kane_residual")]
    for naive, ours in zip(residual[0::2], residual[1::2]):
        lines.append(
            f"   {ours.device:<7}{ours.batch:>8,}{naive.rate:>20,.0f}{ours.rate:>20,.0f}{ours.ratio:>11.1f}×"
            f"{ours.max_deviation:>14.1e}"
        )
    met = all(r.ratio >= results.target_ratio for r in residual if r.method == "ours")
    lines += [
        f"   target: ours ≥ {results.target_ratio:.0f}× naive at every batch size — {'met' if met else 'NOT met'}",
        "",
        "2. Forward dynamics q̈ = M⁻¹f on a single state, numpy float64 (evaluations per second)",
        f"   {'method':<58}{'evals/s':>14}{'vs baseline':>13}{'max |Δq̈|':>12}",
    ]
    for row in results.rows:
        if row.section.startswith("forward_dynamics"):
            deviation = "—" if row.max_deviation is None else f"{row.max_deviation:.1e}"
            lines.append(f"   {LABELS[row.method]:<58}{row.rate:>14,.0f}{row.ratio:>12.1f}×{deviation:>12}")
    spread = max(row.spread for row in results.rows)
    lines += [
        "   (simulate: 4 accel evaluations per rk4 step counted; Δ of the rollout is not defined)",
        "",
        f"largest timing spread over the repeats of any figure, (slowest − fastest) / median: {spread:.0%}",
        f"total benchmark time: {results.total_seconds:.1f} s",
    ]
    return "\n".join(lines)


def environment() -> dict[str, Any]:
    return {
        "python": platform.python_version(),
        "torch": torch.__version__,
        "numpy": np.__version__,
        "numba": numba.__version__,
        "sympy": sp.__version__,
        "machine": f"{platform.system()} {platform.machine()}",
        "cpu_count": os.cpu_count(),
        "torch_threads": torch.get_num_threads(),
        "cuda": torch.cuda.get_device_name() if torch.cuda.is_available() else None,
    }


def parse_args(argv: Sequence[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fast smoke run: small batch, few repeats")
    parser.add_argument("--json", type=Path, default=None, metavar="PATH", help="also save the results as JSON")
    parser.add_argument("--no-cuda", action="store_true", help="skip CUDA even when available")
    return parser.parse_args(argv)


def main(argv: Sequence[str] | None = None) -> Results:
    args = parse_args(argv)
    settings = QUICK if args.quick else FULL
    torch.set_num_threads(TORCH_THREADS)
    devices = ["cpu"] + (["cuda"] if torch.cuda.is_available() and not args.no_cuda else [])

    t0 = time.perf_counter()
    model = derive()  # cached per process; both baselines start from these unsimplified expressions
    results = Results(
        settings={"mode": "quick" if args.quick else "full", **asdict(settings)}, environment=environment()
    )
    results.rows += bench_residual_torch(model, settings, devices)
    results.rows += bench_single_state_numpy(model, settings)
    results.total_seconds = time.perf_counter() - t0

    print(format_table(results))
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(asdict(results), indent=2) + "\n")
        print(f"results saved to {args.json}")
    return results


if __name__ == "__main__":
    main(sys.argv[1:])
