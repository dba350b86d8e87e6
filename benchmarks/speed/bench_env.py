"""Speed of the SagittalWalker environments, next to Gymnasium's MuJoCo ``Walker2d-v5`` measured in the same run.

Run ``python -m benchmarks.speed.bench_env`` (a few minutes on 2 CPU cores), ``--quick`` for a smoke run,
``--step-study`` to also repeat the physics step-size study quoted in the docstring of
:class:`envs.sagittal_walker.SagittalWalkerEnv` (a few more minutes), ``--json PATH`` to save the results.
``--threads K`` sets numba's threads (default: all cores, ``NUMBA_NUM_THREADS``).

What is measured:

1. **Environment steps/s**, random actions (uniform in the action box, drawn beforehand), no
   rendering, resets whenever an episode ends, all timed in the same alternating rounds (median of
   the rounds, so that machine load affects them alike) and printed as ratios to the single
   environment (unwrapped ``SagittalWalkerEnv``): the single environment (also through
   ``gymnasium.make``), the native vector environment :class:`envs.vector.SagittalWalkerVectorEnv`
   at N = 1, 8, 64, 512 (one compiled call per step, ``numba.prange`` over the walkers), SB3's
   ``DummyVecEnv`` of 8 single environments (as ``python -m agents train`` with ``env.vec_env:
   dummy`` builds it: ``gymnasium.make`` wrappers and a Monitor each) and Gymnasium's MuJoCo
   ``Walker2d-v5``. The last needs ``pip install "gymnasium[mujoco]"`` (the ``bench`` extra);
   without it the script says so. Targets: single ≥ Walker2d-v5; vector env ≥ 2.5× the single
   environment at N ≥ 64 (2 cores).
2. **Physics only**, one control interval (50 substeps) from a standing state: the allocation-free
   in-place stepper :func:`sspinn.model.simulation.advance` (the environment's call) and
   :func:`sspinn.model.simulation.step` (the same stepper on copies of the state; the difference is the
   wrapper's overhead); and the **roofline**: the compiled physics alone of 512 walkers in one
   ``prange`` call on all cores (:func:`envs.kernels.physics_parallel`) — model evaluations/s, and
   that rate ÷ substeps, the most environment steps/s the vector environment could reach.
3. **PPO end-to-end** (``--ppo-updates``, default 24 rollouts): ``stable_baselines3.PPO`` with the
   network and hyperparameters of two recipes, ``configs/agents/ppo.yaml`` (8 environments,
   [256, 256] networks, 10 epochs of minibatches of 256) and ``ppo_clock_walk_256envs.yaml`` (256
   environments, 32 steps each per rollout, [64, 64] networks, 10 epochs of minibatches of 2,048,
   the gait-clock prior), VecNormalize, 1 torch thread, learning a fixed number of steps through
   the native vector environment and through ``DummyVecEnv``: environment steps/s of the whole
   loop (stepping, policy, updates), and the same environments' steps/s alone. Target: native ≥ 2×
   DummyVecEnv. How much the environment can matter is set by the recipe: with 8 environments and
   large networks the updates take most of the time.
4. **Batched torch environment** (:class:`envs.batched.BatchedSagittalWalker`) at batch 4,096,
   float32, random actions, CPU (CUDA too when available): environment steps/s = batch × steps / time,
   and the ratio to the single environment. Target: ≥ 100× the single environment.
5. ``--step-study``: PD-controlled landings (forward speed 1.3 m/s, three sink speeds → three peak
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
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numba
import numpy as np

from envs.openmp import prefer_passive_openmp  # noqa: E402

prefer_passive_openmp()  # as python -m agents does: OpenMP for the vector environment (envs.kernels)

from envs import kernels  # noqa: E402
from envs.batched import BatchedSagittalWalker  # noqa: E402
from envs.sagittal_walker import SagittalWalkerEnv  # noqa: E402
from envs.vector import SagittalWalkerVectorEnv  # noqa: E402
from sspinn.model import kinematics, simulation  # noqa: E402
from sspinn.model.body import BodyParameters  # noqa: E402
from sspinn.model.contact import ContactParameters  # noqa: E402
from sspinn.model.simulation import METHODS, advance  # noqa: E402
from sspinn.run_folder import atomic_write_text  # noqa: E402

# isort: split
import torch  # noqa: E402  (after prefer_passive_openmp: torch loads OpenMP)

TARGET_SINGLE_RATIO = 1.0
TARGET_BATCH_RATIO = 100.0
TARGET_VECTOR_RATIO = 2.5  # at N >= 64
TARGET_PPO_RATIO = 2.0
VECTOR_SIZES = (1, 8, 64, 512)
#: PPO recipes timed end to end (configs/agents/): the 8-environment one and the 256-environment one.
PPO_CONFIGS = ("ppo.yaml", "ppo_clock_walk_256envs.yaml")
ROOT = Path(__file__).resolve().parents[2]
SINGLE = "SagittalWalker-v0 (unwrapped)"


def _run_steps(env: Any, actions: np.ndarray) -> float:
    """Seconds for len(actions) steps with resets on episode end."""
    env.reset(seed=0)
    t0 = time.perf_counter()
    for a in actions:
        _, _, terminated, truncated, _ = env.step(a)
        if terminated or truncated:
            env.reset()
    return time.perf_counter() - t0


class _Single:
    """Steps of one Gymnasium environment (resets on episode end)."""

    def __init__(self, env: Any, n_steps: int, seed: int = 0) -> None:
        self.env = env
        self.actions = np.random.default_rng(seed).uniform(-1, 1, (n_steps, *env.action_space.shape)).astype(np.float32)
        env.reset(seed=seed)

    def __call__(self) -> int:
        env = self.env
        for a in self.actions:
            _, _, terminated, truncated, _ = env.step(a)
            if terminated or truncated:
                env.reset()
        return len(self.actions)


class _Vector:
    """Steps of a Gymnasium vector environment (auto-reset) or an SB3 VecEnv."""

    def __init__(self, env: Any, n: int, n_steps: int, sb3: bool = False, seed: int = 0, threads: int | None = None) -> None:
        self.env, self.n, self.sb3, self.threads = env, n, sb3, threads
        self.actions = np.random.default_rng(seed).uniform(-1, 1, (max(n_steps // n, 10), n, 6)).astype(np.float32)
        if sb3:
            env.seed(seed)
            env.reset()
        else:
            env.reset(seed=seed)

    def __call__(self) -> int:
        threads = numba.get_num_threads()
        if self.threads is not None:
            numba.set_num_threads(self.threads)
        try:
            for a in self.actions:
                self.env.step(a)
        finally:
            numba.set_num_threads(threads)
        return self.actions.shape[0] * self.n


def _episode_length(runner: Any, steps: int = 2000) -> float | None:
    """Mean episode length under random actions (context for the reset share of the timing)."""
    if not isinstance(runner, _Single):
        return None
    env = runner.env
    env.reset(seed=1)
    n, count = 0, 0
    for a in runner.actions[:steps]:
        _, _, te, tr, _ = env.step(a)
        n += 1
        if te or tr:
            count += 1
            env.reset()
    return n / max(count, 1)


def bench_steps(n_steps: int, rounds: int) -> dict[str, Any]:
    """Environment steps/s of every candidate in alternating rounds (module docstring, item 1)."""
    import gymnasium
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import DummyVecEnv

    import envs
    from agents.config import config_from_dict
    from agents.train import make_env

    runners: dict[str, Any] = {
        SINGLE: _Single(SagittalWalkerEnv(), n_steps),
        "SagittalWalker-v0 (gymnasium.make)": _Single(gymnasium.make(envs.ENV_ID), n_steps),
    }
    for n in VECTOR_SIZES:
        runners[f"vector env, N = {n}"] = _Vector(SagittalWalkerVectorEnv(n), n, max(n_steps, 4 * n))
    big = VECTOR_SIZES[-1]
    runners[f"vector env, N = {big}, 1 thread"] = _Vector(SagittalWalkerVectorEnv(big), big, max(n_steps, 4 * big), threads=1)
    dummy_config = config_from_dict({"algo": "ppo", "env": {"n_envs": 8, "vec_env": "dummy"}})
    dummy = make_vec_env(lambda: make_env(dummy_config), n_envs=8, vec_env_cls=DummyVecEnv)
    runners["SB3 DummyVecEnv, 8 single envs"] = _Vector(dummy, 8, n_steps, sb3=True)
    baseline_error = None
    try:
        runners["Walker2d-v5 (gymnasium.make)"] = _Single(gymnasium.make("Walker2d-v5"), n_steps)
        runners["Walker2d-v5 (unwrapped)"] = _Single(gymnasium.make("Walker2d-v5").unwrapped, n_steps)
    except Exception as exc:  # mujoco missing or broken
        baseline_error = f"{type(exc).__name__}: {exc}"
    for runner in runners.values():  # warm-up (numba compilation is cached on disk)
        runner()
    times: dict[str, list[float]] = {name: [] for name in runners}
    done: dict[str, int] = {}
    for _ in range(rounds):
        for name, runner in runners.items():
            t0 = time.perf_counter()
            done[name] = runner()
            times[name].append(time.perf_counter() - t0)
    rates = {name: done[name] / statistics.median(t) for name, t in times.items()}
    lengths = {name: _episode_length(r) for name, r in runners.items()}
    return {"rates": rates, "episode_length": lengths, "baseline_error": baseline_error, "n_steps": n_steps,
            "rounds": rounds}


def bench_roofline(n: int, repeats: int) -> dict[str, float]:
    """Model evaluations/s of the compiled physics of ``n`` walkers in one parallel call."""
    env = SagittalWalkerEnv()
    env.reset(seed=0)
    q0, u0 = env.state
    q, u = np.tile(q0, (n, 1)), np.tile(u0, (n, 1))
    tau, grf = np.zeros((n, 6)), np.zeros((n, 4))
    p = np.tile(env.body_vector, (n, 1))
    method = METHODS.index(env.method)
    work = np.zeros((n, kernels.WALKER_WORK_ROWS, 9))
    args = (env.passive_parameters, p, env.contact_vector, env.physics_dt, env.substeps, method, grf, work)
    kernels.physics_parallel(q.copy(), u.copy(), tau, *args)  # compile / load
    best = float("inf")
    for _ in range(repeats):
        qq, uu = q.copy(), u.copy()
        t0 = time.perf_counter()
        kernels.physics_parallel(qq, uu, tau, *args)
        best = min(best, time.perf_counter() - t0)
    evals = n * env.substeps / best
    return {"walkers": n, "evaluations_per_s": evals, "env_steps_per_s": evals / env.substeps, "threads": numba.get_num_threads()}


def _env_only_rates(config: Any, n_steps: int) -> dict[str, float]:
    """Environment steps/s of ``config``'s environments alone (random actions, training wrappers
    included: the prior, VecNormalize), through the native vector env and DummyVecEnv."""
    import tempfile

    from agents.gait_prior import load_prior
    from agents.train import make_training_envs

    rates = {}
    for kind in ("native", "dummy"):
        kind_config = config.with_overrides(env={**config.to_dict()["env"], "vec_env": kind})
        with tempfile.TemporaryDirectory() as tmp:
            env = make_training_envs(kind_config, Path(tmp), 0, load_prior(kind_config))
            runner = _Vector(env, config.env.n_envs, n_steps, sb3=True)
            runner()  # warm-up
            t0 = time.perf_counter()
            done = runner()
            rates[kind] = done / (time.perf_counter() - t0)
            env.close()
    return rates


def bench_ppo(config_path: Path, updates: int) -> dict[str, Any]:
    """Environment steps/s of PPO learning ``updates`` rollouts of ``config_path``'s recipe
    (n_steps × n_envs steps each) through the native vector env and through DummyVecEnv, and the
    share of each run spent stepping environments, estimated from the env-only rates of the same
    environments (:func:`_env_only_rates`): the ratio native/Dummy cannot exceed
    T_dummy / (T_dummy − t_env,dummy) — what is left if stepping cost nothing (Amdahl)."""
    import tempfile

    from agents.config import load_config
    from agents.train import train

    base = load_config(config_path)
    data = base.to_dict()
    if data.get("prior") and data["prior"].get("gait") and not Path(data["prior"]["gait"]).is_absolute():
        data["prior"]["gait"] = str(Path(__file__).resolve().parents[2] / data["prior"]["gait"])  # from any folder
    base = base.with_overrides(prior=data.get("prior"))
    per_update = base.env.n_envs * base.hyperparameters["n_steps"]
    total_steps = updates * per_update
    out: dict[str, Any] = {"config": config_path.name, "total_steps": total_steps, "n_envs": base.env.n_envs,
                           "net_arch": list(base.policy.net_arch)}

    def config(kind: str, steps: int) -> Any:
        return base.with_overrides(
            total_timesteps=steps,
            env={**data["env"], "vec_env": kind},
            logging={**data["logging"], "eval_freq": 0, "tensorboard": False, "checkpoint_freq": 10**9},
        )

    threads = numba.get_num_threads()  # a recipe's env.threads applies to its own runs only
    numba.set_num_threads(base.env.threads or threads)
    env_only = _env_only_rates(config("native", 1), max(min(updates, 4) * per_update, 4096))
    with tempfile.TemporaryDirectory() as tmp:  # warm-up: one short run of each (imports, torch, numba cache)
        for kind in ("native", "dummy"):
            train(config(kind, 1), Path(tmp) / kind)
    for kind in ("native", "dummy"):
        with tempfile.TemporaryDirectory() as tmp:
            t0 = time.perf_counter()
            model = train(config(kind, total_steps), Path(tmp) / "run")
            seconds = time.perf_counter() - t0
        env_seconds = model.num_timesteps / env_only[kind]
        out[kind] = {"env_steps_per_s": model.num_timesteps / seconds, "seconds": seconds, "steps": model.num_timesteps,
                     "env_only_steps_per_s": env_only[kind], "env_share": min(env_seconds / seconds, 1.0)}
    numba.set_num_threads(threads)
    out["ratio"] = out["native"]["env_steps_per_s"] / out["dummy"]["env_steps_per_s"]
    rest = out["dummy"]["seconds"] * (1.0 - out["dummy"]["env_share"])
    out["ratio_bound"] = out["dummy"]["seconds"] / rest if rest > 0 else float("inf")
    return out


def bench_physics(repeats: int) -> dict[str, float]:
    env = SagittalWalkerEnv()
    env.reset(seed=0)
    q0, u0 = env.state
    tau = np.zeros(6)
    grf = np.zeros(4)
    no_passive = np.zeros(14)
    method = METHODS.index("semi_implicit_euler")
    p, c = env.body_vector, env.contact_vector  # properties that build the vectors: outside the timing

    def in_place() -> None:
        advance(q0.copy(), u0.copy(), tau, no_passive, p, c, 2e-4, 50, method, True, grf)

    def on_copies() -> None:
        simulation.step(q0, u0, tau, p, c, 2e-4, 50, "semi_implicit_euler", True)

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


def bench_batched(batch: int, steps: int, device: str, compile: bool | str = False) -> dict[str, float]:
    """Environment steps/s of the batched torch environment: ``steps`` timed steps after one
    warm-up step (which also compiles when ``compile``: its seconds are reported apart)."""
    env = BatchedSagittalWalker(batch, device=device, dtype=torch.float32, seed=0, compile=compile)
    env.reset(seed=0)
    gen = torch.Generator(device=device).manual_seed(0)
    actions = [torch.rand(batch, 6, generator=gen, device=device) * 2 - 1 for _ in range(steps + 1)]
    with torch.no_grad():
        t0 = time.perf_counter()
        env.step(actions[0])  # warm-up (and compilation)
        if device == "cuda":
            torch.cuda.synchronize()
        warm_up = time.perf_counter() - t0
        t0 = time.perf_counter()
        for a in actions[1:]:
            env.step(a)
        if device == "cuda":
            torch.cuda.synchronize()
        seconds = time.perf_counter() - t0
    return {"env_steps_per_s": batch * steps / seconds, "seconds_per_step": seconds / steps, "warm_up_s": warm_up,
            "final_q": env.q.detach().cpu().numpy()}


def batched_only(sizes: Sequence[int], steps: int, rounds: int, json_path: Path | None) -> dict[str, Any]:
    """``--batched-only``: the single environment on this machine's CPU (the baseline, measured in
    the same run), then the batched torch environment at each size on the GPU when there is one
    (else the CPU), eager and with ``compile=True``; ratios to the single environment. Writes the
    JSON after every row, so that a run cut short keeps what it measured."""
    single_runner = _Single(SagittalWalkerEnv(), 2000)
    single_runner()  # warm-up (numba)
    rates = []
    for _ in range(rounds):
        t0 = time.perf_counter()
        done = single_runner()
        rates.append(done / (time.perf_counter() - t0))
    single = statistics.median(rates)
    device = "cuda" if torch.cuda.is_available() else "cpu"
    name = torch.cuda.get_device_name() if device == "cuda" else platform.processor() or platform.machine()
    print(f"single environment (CPU, unwrapped): {single:,.0f} env steps/s (median of {rounds} rounds of 2,000 steps)")
    print(f"\n## Batched torch environment on {device} ({name}), float32, {steps} steps after one warm-up step\n")
    print("| batch | compiled | env steps/s | s per batched step | warm-up s | ratio to single env | target | "
          "median / max abs. difference of the final q from eager |\n|---:|---|---:|---:|---:|---:|---|---|")
    results: dict[str, Any] = {"device": device, "device_name": name, "single_env_steps_per_s": single, "rows": []}
    modes: tuple[bool | str, ...] = (False, True, "reduce-overhead", "step-graph") if device == "cuda" else (False, True)
    for batch in sizes:
        eager_q = None
        for compiled in modes:
            try:
                res = bench_batched(batch, steps, device, compile=compiled)
            except Exception as exc:  # report a mode that fails on this machine and go on
                print(f"| {batch:,} | {compiled} | failed: {type(exc).__name__}: {str(exc).splitlines()[0][:200]} | | | | |")
                continue
            ratio = res["env_steps_per_s"] / single
            verdict = "met" if ratio >= TARGET_BATCH_RATIO else "NOT met"
            final_q = res.pop("final_q")
            eager_q = final_q if compiled is False else eager_q
            diff = np.abs(final_q - eager_q)
            res["diff_median"], res["diff_max"] = float(np.median(diff)), float(diff.max())
            print(f"| {batch:,} | {'no' if compiled is False else 'yes' if compiled is True else compiled} | {res['env_steps_per_s']:,.0f} | "
                  f"{res['seconds_per_step']:.4f} | {res['warm_up_s']:.1f} | {ratio:.1f}× | ≥ {TARGET_BATCH_RATIO:.0f}×: {verdict} | "
                  f"{res['diff_median']:.1e} / {res['diff_max']:.1e} |", flush=True)
            results["rows"].append({"batch": batch, "compiled": compiled, "ratio_to_single": ratio, **res})
            if json_path is not None:
                atomic_write_text(json_path, json.dumps(results, indent=2))
    return results


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
    parser.add_argument("--threads", type=int, help="numba threads (default: all cores / NUMBA_NUM_THREADS)")
    parser.add_argument("--batched-only", type=int, nargs="+", metavar="N",
                        help="only the batched torch environment at these batch sizes (GPU when present, eager and "
                             "compiled) beside the single environment on the CPU")
    parser.add_argument("--ppo-updates", type=int, help="PPO rollouts (n_steps × n_envs steps each) per recipe and "
                        "environment kind (0: skip; default 24, --quick 1)")
    args = parser.parse_args(argv)
    if args.threads is not None:
        numba.set_num_threads(args.threads)
    if args.ppo_updates is None:
        args.ppo_updates = 1 if args.quick else 24
    torch_threads = torch.get_num_threads()
    if args.batched_only:
        print(f"# bench_env --batched-only — {os.cpu_count()} CPUs, Python {platform.python_version()}, "
              f"torch {torch.__version__}, numpy {np.__version__}")
        return batched_only(args.batched_only, 2 if args.quick else 5, 2 if args.quick else 5, args.json)
    print(f"# bench_env — {platform.processor() or platform.machine()}, {os.cpu_count()} CPUs, "
          f"Python {platform.python_version()}, torch {torch.__version__} ({torch_threads} threads), numpy {np.__version__}")

    n_steps, rounds = (400, 2) if args.quick else (4000, 5)
    single = bench_steps(n_steps, rounds)
    rates = single["rates"]
    ours = rates[SINGLE]
    print(f"\n## Environment steps/s, random actions, no rendering (≈{n_steps} steps per candidate × {rounds} "
          f"alternating rounds, median; numba threads: {numba.get_num_threads()})\n")
    print("| environment | env steps/s | ratio to the single env | mean episode length (steps) |\n|---|---:|---:|---:|")
    for name, rate in rates.items():
        length = single["episode_length"][name]
        print(f"| {name} | {rate:,.0f} | {rate / ours:.2f}× | {'' if length is None else f'{length:.1f}'} |")
    single["ratios"] = {name: rate / ours for name, rate in rates.items()}
    vector_ok = all(single["ratios"][f"vector env, N = {n}"] >= TARGET_VECTOR_RATIO for n in VECTOR_SIZES if n >= 64)
    print(f"\nvector env ≥ {TARGET_VECTOR_RATIO}× the single env at N ≥ 64: {'met' if vector_ok else 'NOT met'}")
    baseline = rates.get("Walker2d-v5 (gymnasium.make)")
    if baseline is None:
        print(f"Walker2d-v5 baseline unavailable ({single['baseline_error']}); install the bench extra: "
              'pip install "gymnasium[mujoco]"')
        ratio_single = None
    else:
        ratio_single = rates["SagittalWalker-v0 (gymnasium.make)"] / baseline
        verdict = "met" if ratio_single >= TARGET_SINGLE_RATIO else "NOT met"
        print(f"ratio SagittalWalker / Walker2d-v5 (both via gymnasium.make): {ratio_single:.2f}× "
              f"(target ≥ {TARGET_SINGLE_RATIO:.0f}×: {verdict})")

    physics = bench_physics(100 if args.quick else 400)
    roofline = bench_roofline(64 if args.quick else 512, 3 if args.quick else 10)
    print("\n## Physics of one control interval (50 substeps of 0.2 ms, semi-implicit Euler)\n")
    print("| stepper | µs per control step (min of 9 alternating rounds) |\n|---|---:|")
    for name, us in physics.items():
        print(f"| {name} | {us:.1f} |")
    best_vector = max(rates[f"vector env, N = {n}"] for n in VECTOR_SIZES)
    print(f"\nroofline: the physics alone of {roofline['walkers']} walkers in one prange call "
          f"({roofline['threads']} threads): {roofline['evaluations_per_s']:,.0f} model evaluations/s = "
          f"{roofline['env_steps_per_s']:,.0f} env steps/s at {SagittalWalkerEnv().substeps} substeps; the best vector "
          f"env rate above is {best_vector / roofline['env_steps_per_s']:.0%} of it")

    ppo = []
    for name in (PPO_CONFIGS if args.ppo_updates > 0 else ()):
        res = bench_ppo(ROOT / "configs" / "agents" / name, args.ppo_updates)
        ppo.append(res)
        verdict = "met" if res["ratio"] >= TARGET_PPO_RATIO else "NOT met"
        print(f"\n## PPO end-to-end, configs/agents/{name} ({res['n_envs']} envs, net {res['net_arch']}), "
              f"{res['native']['steps']:,} steps ({args.ppo_updates} rollouts of n_steps × n_envs), after a warm-up run of each\n")
        print("| environments | env steps/s learning | s | env steps/s alone | share stepping envs (est.) |\n"
              "|---|---:|---:|---:|---:|")
        for kind in ("native", "dummy"):
            r = res[kind]
            print(f"| {kind} | {r['env_steps_per_s']:,.0f} | {r['seconds']:.1f} | {r['env_only_steps_per_s']:,.0f} | "
                  f"{r['env_share']:.0%} |")
        print(f"\nnative / DummyVecEnv: {res['ratio']:.2f}× (target ≥ {TARGET_PPO_RATIO:.0f}×: {verdict}); "
              f"bound if stepping cost nothing: {res['ratio_bound']:.2f}×")

    batch, steps = (256, 2) if args.quick else (4096, 3)
    devices = ["cpu"] + (["cuda"] if torch.cuda.is_available() else [])
    batched: dict[str, dict[str, float]] = {}
    for device in devices:
        # CPU: the default thread count and a single thread (at batch 4,096 most torch ops are too small
        # to gain from threads, and on a loaded 2-core machine the threads' synchronisation costs more)
        for threads in sorted({torch_threads, 1}, reverse=True) if device == "cpu" else [torch_threads]:
            torch.set_num_threads(threads)
            batched[f"{device}, {threads} thread(s)"] = {k: v for k, v in bench_batched(batch, steps, device).items() if k != "final_q"}
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
                               "roofline": roofline, "ppo": ppo, "batched": batched, "batch": batch,
                               "torch_threads": torch_threads}
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
        atomic_write_text(args.json, json.dumps(results, indent=2, default=str))
    return results


if __name__ == "__main__":
    main()
