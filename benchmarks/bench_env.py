"""Speed of the SagittalWalker environments, next to Gymnasium's MuJoCo ``Walker2d-v5`` measured in the same run.

Run ``python benchmarks/bench_env.py`` (about a minute on 2 CPU cores), ``--quick`` for a smoke run,
``--step-study`` to also repeat the physics step-size study quoted in the docstring of
:class:`envs.sagittal_walker.SagittalWalkerEnv` (a few more minutes), ``--json PATH`` to save the results.

What is measured:

1. **Single environment**, random actions (uniform in the action box, drawn beforehand), no rendering,
   ``reset()`` whenever an episode ends: steps/s of ``SagittalWalkerEnv`` and of ``Walker2d-v5``
   (``gymnasium.make``, i.e. with Gymnasium's default wrappers, and the unwrapped environment). Both are
   timed in alternating rounds (median of the rounds), so machine load affects them alike. The baseline
   needs ``pip install "gymnasium[mujoco]"`` (the ``bench`` extra); without it the script says so and
   reports no ratio. Target: ours ≥ Walker2d-v5.
2. **Physics only**, one control interval (50 substeps) from a standing state: the allocation-free
   in-place stepper :func:`sspinn.model.simulation.advance` (the environment's call) and
   :func:`sspinn.model.simulation.step` (the same stepper on copies of the state; the difference is the
   wrapper's overhead).
3. **Batched torch environment** (:class:`envs.batched.BatchedSagittalWalker`) at batch 4,096,
   float32, random actions, CPU (CUDA too when available): environment steps/s = batch × steps / time,
   and the ratio to the single environment. Target: ≥ 100× the single environment.
4. ``--step-study``: PD-controlled landings (forward speed 1.3 m/s, three sink speeds → three peak
   loads) integrated with semi-implicit Euler at several substeps and slip velocities v_s; the error of
   the 100 Hz ground reaction forces against RK4 at 10 µs shows where the stiff friction starts to
   chatter. Plus random-action episodes of the environment: episode length, peak joint speed, peak
   vertical force, physics failures.

Timing: ``time.perf_counter``, warm-up first (numba compilation, torch allocator).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import torch

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from envs.batched import BatchedSagittalWalker  # noqa: E402
from envs.sagittal_walker import SagittalWalkerEnv  # noqa: E402
from sspinn.model import kinematics, simulation  # noqa: E402
from sspinn.model.body import BodyParameters  # noqa: E402
from sspinn.model.contact import ContactParameters  # noqa: E402
from sspinn.model.simulation import METHODS, advance  # noqa: E402

TARGET_SINGLE_RATIO = 1.0
TARGET_BATCH_RATIO = 100.0


def _run_steps(env: Any, actions: np.ndarray) -> float:
    """Seconds for len(actions) steps with resets on episode end."""
    env.reset(seed=0)
    t0 = time.perf_counter()
    for a in actions:
        _, _, terminated, truncated, _ = env.step(a)
        if terminated or truncated:
            env.reset()
    return time.perf_counter() - t0


def bench_single(n_steps: int, rounds: int) -> dict[str, Any]:
    import gymnasium

    import envs

    candidates: dict[str, Any] = {
        "SagittalWalker-v0 (gymnasium.make)": gymnasium.make(envs.ENV_ID),
        "SagittalWalker-v0 (unwrapped)": SagittalWalkerEnv(),
    }
    baseline_error = None
    try:
        candidates["Walker2d-v5 (gymnasium.make)"] = gymnasium.make("Walker2d-v5")
        candidates["Walker2d-v5 (unwrapped)"] = gymnasium.make("Walker2d-v5").unwrapped
    except Exception as exc:  # mujoco missing or broken
        baseline_error = f"{type(exc).__name__}: {exc}"
    rng = np.random.default_rng(0)
    actions = {name: rng.uniform(-1, 1, (n_steps,) + env.action_space.shape).astype(np.float32) for name, env in candidates.items()}
    for name, env in candidates.items():  # warm-up
        _run_steps(env, actions[name][: min(200, n_steps)])
    times: dict[str, list[float]] = {name: [] for name in candidates}
    for _ in range(rounds):
        for name, env in candidates.items():
            times[name].append(_run_steps(env, actions[name]))
    rates = {name: n_steps / statistics.median(t) for name, t in times.items()}
    # mean episode length under random actions (context for the reset share of the timing)
    lengths = {}
    for name, env in candidates.items():
        env.reset(seed=1)
        n, count = 0, 0
        for a in actions[name][:2000]:
            _, _, te, tr, _ = env.step(a)
            n += 1
            if te or tr:
                count += 1
                env.reset()
        lengths[name] = n / max(count, 1)
    return {"rates": rates, "episode_length": lengths, "baseline_error": baseline_error, "n_steps": n_steps, "rounds": rounds}


def bench_physics(repeats: int) -> dict[str, float]:
    env = SagittalWalkerEnv()
    env.reset(seed=0)
    q0, u0 = env.state
    tau = np.zeros(6)
    grf = np.zeros(4)
    no_passive = np.zeros(14)
    method = METHODS.index("semi_implicit_euler")

    def in_place() -> None:
        advance(q0.copy(), u0.copy(), tau, no_passive, env.body_vector, env.contact_vector, 2e-4, 50, method, True, grf)

    def on_copies() -> None:
        simulation.step(q0, u0, tau, env.body_vector, env.contact_vector, 2e-4, 50, "semi_implicit_euler", True)

    in_place()
    on_copies()
    samples: dict[str, list[float]] = {"sspinn.model.simulation.advance": [], "sspinn.model.simulation.step": []}
    for _ in range(9):  # alternating rounds; the minimum is the least load-disturbed estimate
        for name, fn in (("sspinn.model.simulation.advance", in_place), ("sspinn.model.simulation.step", on_copies)):
            t0 = time.perf_counter()
            for _ in range(repeats):
                fn()
            samples[name].append((time.perf_counter() - t0) / repeats * 1e6)  # µs per control interval
    out = {name: min(s) for name, s in samples.items()}
    return out


def bench_batched(batch: int, steps: int, device: str) -> dict[str, float]:
    env = BatchedSagittalWalker(batch, device=device, dtype=torch.float32, seed=0)
    env.reset(seed=0)
    gen = torch.Generator(device=device).manual_seed(0)
    actions = [torch.rand(batch, 6, generator=gen, device=device) * 2 - 1 for _ in range(steps + 1)]
    with torch.no_grad():
        env.step(actions[0])  # warm-up
        if device == "cuda":
            torch.cuda.synchronize()
        t0 = time.perf_counter()
        for a in actions[1:]:
            env.step(a)
        if device == "cuda":
            torch.cuda.synchronize()
        seconds = time.perf_counter() - t0
    return {"env_steps_per_s": batch * steps / seconds, "seconds_per_step": seconds / steps}


# ------------------------------------------------------------------------------------------------
# Step-size study
# ------------------------------------------------------------------------------------------------
def _landing(body: BodyParameters, sink: float) -> tuple[np.ndarray, np.ndarray]:
    q = np.array([0, 0, -0.05, 0.3, -0.1, 0.0, -0.2, -0.3, 0.0])
    pk = kinematics.point_kinematics(q, np.zeros(9), np.zeros(9), np.zeros(2), body)
    rows = [kinematics.point_index(f"{pt}_{s}") for pt in ("heel", "toe") for s in "rl"]
    q[1] += 0.002 - pk[rows, 1].min()  # lowest sole point 2 mm above the ground
    u = np.zeros(9)
    u[0], u[1] = 1.3, -sink
    return q, u


def _pd_landing(body: BodyParameters, vs: float, method: str, dt: float, sink: float, duration: float = 0.25) -> np.ndarray | None:
    """100 Hz GRF (n, 4) of a PD-held landing (gains low enough for 100 Hz control)."""
    p, c = body.vector(), ContactParameters(slip_velocity=vs).vector()
    q, u = _landing(body, sink)
    q_ref = q.copy()
    kp, kd = np.array([150, 150, 60] * 2), np.array([8, 5, 1.5] * 2)
    limit = 3.0 * body.segment_mass_total
    grf, out = np.zeros(4), []
    for _ in range(int(round(duration / 0.01))):
        tau = -kp * (q[3:] - q_ref[3:]) - kd * u[3:]
        tau[[0, 3]] += 150 * (q[2] - q_ref[2]) + 8 * u[2]
        torque = np.clip(tau, -limit, limit)
        if not advance(q, u, torque, np.zeros(14), p, c, dt, int(round(0.01 / dt)), METHODS.index(method), True, grf):
            return None
        out.append(grf.copy())
    return np.array(out)


def step_study(quick: bool) -> dict[str, Any]:
    body = BodyParameters.from_anthropometry(1.75, 70.0)
    bw = body.body_weight
    dts = [1e-4, 2e-4, 5e-4] if quick else [1e-4, 1.25e-4, 1 / 6000, 2e-4, 2.5e-4, 1 / 3000, 5e-4]
    rows = []
    for vs in (0.05, 0.1, 0.2):
        for sink in (0.3, 1.0, 2.0):
            ref = _pd_landing(body, vs, "rk4", 1e-5, sink)
            errors = {}
            for dt in dts:
                g = _pd_landing(body, vs, "semi_implicit_euler", dt, sink)
                errors[f"{dt * 1e3:.3g} ms"] = float("inf") if g is None else float(np.abs(g - ref).max() / bw)
            rows.append({"slip_velocity": vs, "sink_speed": sink, "peak_fy_bw": float(ref[:, 1::2].max() / bw), "grf_error_bw": errors})
    episodes = {}
    for label, kwargs in (("default (v_s 0.2, 50 substeps)", {}), ("v_s 0.1, 100 substeps", {"slip_velocity": 0.1, "substeps": 100})):
        env = SagittalWalkerEnv(**kwargs)
        rng = np.random.default_rng(0)
        lengths, max_rate, max_fy, failures = [], [], [], 0
        for ep in range(30 if quick else 300):
            obs, _ = env.reset(seed=ep)
            rate = fy = 0.0
            for k in range(1000):  # noqa: B007 (k is the episode length below)
                obs, _, terminated, truncated, info = env.step(rng.uniform(-1, 1, 6))
                rate = max(rate, float(np.abs(obs[10:17]).max()))
                fy = max(fy, float(obs[[18, 20]].max()))
                failures += int(info["physics_failure"])
                if terminated or truncated:
                    break
            lengths.append(k + 1)
            max_rate.append(rate)
            max_fy.append(fy)
        episodes[label] = {
            "episodes": len(lengths),
            "mean_length_steps": float(np.mean(lengths)),
            "median_peak_angular_rate_rad_s": float(np.median(max_rate)),
            "median_peak_fy_bw": float(np.median(max_fy)),
            "p99_peak_fy_bw": float(np.percentile(max_fy, 99)),
            "physics_failures": failures,
        }
    return {"landings": rows, "random_episodes": episodes}


# ------------------------------------------------------------------------------------------------
def main(argv: list[str] | None = None) -> dict[str, Any]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="smoke run: few steps, small batch")
    parser.add_argument("--step-study", action="store_true", help="also run the physics step-size study")
    parser.add_argument("--json", type=Path, help="save the results as JSON")
    args = parser.parse_args(argv)
    torch_threads = torch.get_num_threads()
    print(f"# bench_env — {platform.processor() or platform.machine()}, {os.cpu_count()} CPUs, "
          f"Python {platform.python_version()}, torch {torch.__version__} ({torch_threads} threads), numpy {np.__version__}")

    n_steps, rounds = (500, 2) if args.quick else (4000, 5)
    single = bench_single(n_steps, rounds)
    rates = single["rates"]
    ours = rates["SagittalWalker-v0 (gymnasium.make)"]
    print(f"\n## Single environment, random actions, no rendering ({n_steps} steps × {rounds} alternating rounds, median)\n")
    print("| environment | steps/s | mean episode length (steps) |\n|---|---:|---:|")
    for name, rate in rates.items():
        print(f"| {name} | {rate:,.0f} | {single['episode_length'][name]:.1f} |")
    baseline = rates.get("Walker2d-v5 (gymnasium.make)")
    if baseline is None:
        print(f"\nWalker2d-v5 baseline unavailable ({single['baseline_error']}); install the bench extra: "
              'pip install "gymnasium[mujoco]"')
        ratio_single = None
    else:
        ratio_single = ours / baseline
        verdict = "met" if ratio_single >= TARGET_SINGLE_RATIO else "NOT met"
        print(f"\nratio SagittalWalker / Walker2d-v5 (both via gymnasium.make): {ratio_single:.2f}× "
              f"(target ≥ {TARGET_SINGLE_RATIO:.0f}×: {verdict})")

    physics = bench_physics(100 if args.quick else 400)
    print("\n## Physics of one control interval (50 substeps of 0.2 ms, semi-implicit Euler)\n")
    print("| stepper | µs per control step (min of 9 alternating rounds) |\n|---|---:|")
    for name, us in physics.items():
        print(f"| {name} | {us:.1f} |")

    batch, steps = (256, 2) if args.quick else (4096, 3)
    devices = ["cpu"] + (["cuda"] if torch.cuda.is_available() else [])
    batched: dict[str, dict[str, float]] = {}
    for device in devices:
        # CPU: the default thread count and a single thread (at batch 4,096 most torch ops are too small
        # to gain from threads, and on a loaded 2-core machine the threads' synchronisation costs more)
        for threads in sorted({torch_threads, 1}, reverse=True) if device == "cpu" else [torch_threads]:
            torch.set_num_threads(threads)
            batched[f"{device}, {threads} thread(s)"] = bench_batched(batch, steps, device)
    torch.set_num_threads(torch_threads)
    print(f"\n## Batched torch environment, batch {batch:,}, float32, {steps} steps after one warm-up step\n")
    print("| device | env steps/s | s per batched step | ratio to single env | target |\n|---|---:|---:|---:|---|")
    for device, res in batched.items():
        ratio = res["env_steps_per_s"] / ours
        verdict = "met" if ratio >= TARGET_BATCH_RATIO else "NOT met"
        res["ratio_to_single"] = ratio
        print(f"| {device} | {res['env_steps_per_s']:,.0f} | {res['seconds_per_step']:.3f} | {ratio:.2f}× | "
              f"≥ {TARGET_BATCH_RATIO:.0f}×: {verdict} |")

    results: dict[str, Any] = {"single": single, "ratio_single_to_walker2d": ratio_single, "physics_us": physics,
                               "batched": batched, "batch": batch, "torch_threads": torch_threads}
    if args.step_study:
        study = step_study(args.quick)
        results["step_study"] = study
        print("\n## Step-size study: max |GRF − GRF_RK4(10 µs)| at 100 Hz (BW), semi-implicit Euler, PD-held landings\n")
        dts = list(study["landings"][0]["grf_error_bw"])
        print("| v_s (m/s) | sink (m/s) | peak F_y (BW) | " + " | ".join(dts) + " |")
        print("|---:|---:|---:|" + "---:|" * len(dts))
        for row in study["landings"]:
            cells = " | ".join(f"{e:.3f}" for e in row["grf_error_bw"].values())
            print(f"| {row['slip_velocity']} | {row['sink_speed']} | {row['peak_fy_bw']:.2f} | {cells} |")
        print("\n## Random-action episodes\n")
        for label, res in study["random_episodes"].items():
            print(f"* {label}: " + ", ".join(f"{k} = {v:.3g}" if isinstance(v, float) else f"{k} = {v}" for k, v in res.items()))
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(results, indent=2, default=str))
    return results


if __name__ == "__main__":
    main()
