"""SSPINNpose speed: streaming latency and training throughput, each against a named baseline.

1. **Streaming latency** of the paper-size model (LSTM 2×512, dense 128, 7 IMUs) on one CPU
   thread: per-sample wall time of :class:`sspinn.estimator.inference.StreamingEstimator.step` (its
   numba single-step LSTM cell + decoding + contact model), p50/p99 over many samples, next to
   the baseline "the same ``nn.LSTM`` stepped one sample at a time with PyTorch's default
   (oneDNN) path and the physics evaluated with the generated torch code", measured in the
   same run (alternating blocks), and their ratio; also the torch network alone with oneDNN
   off (the previous streaming path). Paper: 3.5 ms; target ≤ 1 ms.
2. **Training throughput** (windows/s, batch 32 × 256 samples for the paper model): one full
   SSPINNpose step (forward, all physics losses, backward, Adam) next to a plain PyTorch
   baseline of the same model (same network, an MSE loss on its raw outputs, no physics) —
   the ratio is the cost of the physics.
3. **Where a training step's time goes**: data preparation, network forward, physics losses,
   backward, optimizer (:func:`profile_step`), for the demo and the paper configuration —
   before (eager physics, the default) and after ``compile: true`` (decoding + losses compiled
   with ``torch.compile``, :class:`sspinn.estimator.training.PhysicsTerms`), measured in the same run, with
   the one-off compile time (the first step) beside the throughput.

4. **Sharing the machine**: demo-size training steps (eager physics) alone and beside one
   busy-looping neighbour process, with 2 threads, 1 thread and ``threads: 0`` (the default:
   the CPUs other work leaves free, :class:`sspinn.estimator.cpu_share.ThreadShare`), measured in
   the same run; target with a neighbour ≥ 0.4× the rate alone, and the default unchanged alone.

Usage: ``python -m benchmarks.speed.bench_sspinn [--quick] [--only-sharing] [--json PATH]``.
"""

from __future__ import annotations

import argparse
import json
import platform
import statistics
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import torch

from sspinn.data.dataset import Recording
from sspinn.estimator.inference import StreamingEstimator
from sspinn.estimator.losses import PhysicsLosses
from sspinn.estimator.network import NetworkConfig, SSPINNposeNet, decode, input_features, output_affine
from sspinn.estimator.training import PhysicsTerms, TrainConfig, WindowSampler, make_batch, prepare
from sspinn.model import dynamics
from sspinn.model.body import BodyParameters, IMUPlacement
from sspinn.model.contact import ContactParameters
from sspinn.model.conventions import GRAVITY, SEGMENTS


def fake_recording(n: int, rng: np.random.Generator) -> Recording:
    imu = rng.normal(scale=1.0, size=(n, len(SEGMENTS), 3))
    imu[:, :, 1] += GRAVITY
    return Recording(name="bench", imu=imu, segments=SEGMENTS, height=1.75, mass=70.0)


def percentiles(samples: list[float]) -> tuple[float, float]:
    a = np.array(samples) * 1e3
    return float(np.percentile(a, 50)), float(np.percentile(a, 99))


def bench_streaming(config: NetworkConfig, n: int, rng: np.random.Generator, rounds: int = 4) -> dict:
    """Per-sample latencies of the three streaming paths, measured in ``rounds`` alternating
    blocks of n / rounds samples each (so a change of machine load hits all of them alike;
    within a block one path runs alone, as in real use, with its weights warm in cache)."""
    torch.set_num_threads(1)
    per_round = max(1, n // rounds)
    rec = fake_recording(rounds * per_round + 50, rng)
    n_inputs = input_features(rec.imu[:1], 1.75, 70.0, IMUPlacement.default().vector(), SEGMENTS).shape[1]
    model = SSPINNposeNet(n_inputs, config).eval()
    stream = StreamingEstimator(model, SEGMENTS, 1.75, 70.0)
    features = torch.as_tensor(input_features(rec.imu, 1.75, 70.0, stream.placement, SEGMENTS), dtype=torch.float32)
    body = BodyParameters.from_anthropometry(1.75, 70.0)
    p = torch.as_tensor(body.vector())
    c = torch.as_tensor(ContactParameters().vector())
    scale, offset = (torch.as_tensor(a)[None] for a in output_affine(1.75, 70.0, body.standing_hip_height))
    states: dict[str, object] = {"baseline": None, "network": None}

    def ours(k: int) -> None:
        stream.step(rec.imu[k])

    def baseline(k: int) -> None:  # default oneDNN path, torch physics (inputs prepared outside the timing)
        raw, states["baseline"] = model(features[k : k + 1][None], states["baseline"])
        est = decode(raw.double(), scale, offset, 0.01)
        dynamics.contact_from_ankles(est.q, est.u, est.ankle_global(), est.mu_hat, p, c)

    def network(k: int) -> None:  # the torch network alone, oneDNN off (the previous streaming path)
        with torch.backends.mkldnn.flags(enabled=False):
            _, states["network"] = model(features[k : k + 1][None], states["network"])

    times: dict[str, list[float]] = {"ours": [], "baseline": [], "network": []}
    with torch.no_grad(), warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="TF32 acceleration")  # torch's notice on toggling oneDNN
        for fn in (ours, baseline, network):  # warm-up (numba cache load, allocators)
            for k in range(50):
                fn(k)
        for r in range(rounds):
            for name, fn in (("ours", ours), ("baseline", baseline), ("network", network)):
                for k in range(50 + r * per_round, 50 + (r + 1) * per_round):
                    t0 = time.perf_counter()
                    fn(k)
                    times[name].append(time.perf_counter() - t0)
    return {
        "ours_ms": percentiles(times["ours"]), "baseline_ms": percentiles(times["baseline"]),
        "network_only_ms": percentiles(times["network"]), "samples": len(times["ours"]), "rounds": rounds,
    }


def bench_training(config: NetworkConfig, batch: int, window: int, repeats: int, rng: np.random.Generator) -> dict:
    torch.set_num_threads(2)
    data = prepare([fake_recording(window * 4, rng) for _ in range(2)], SEGMENTS, zupt=False)
    imu_std = torch.ones(len(SEGMENTS), 3)
    n_inputs = input_features(data[0].recording.imu[:1], 1.75, 70.0, data[0].placement, SEGMENTS).shape[1]
    losses = PhysicsLosses()
    results = {}
    for name in ("plain", "sspinn"):
        torch.manual_seed(0)
        model = SSPINNposeNet(n_inputs, config)
        opt = torch.optim.Adam(model.parameters(), lr=1e-3)
        times = []
        for r in range(repeats + 1):
            which = [int(i) for i in rng.integers(0, len(data), batch)]
            starts = [int(s) for s in rng.integers(0, window * 3, batch)]
            x, b = make_batch(data, which, starts, window, SEGMENTS, imu_std, torch.device("cpu"))
            t0 = time.perf_counter()
            raw, _ = model(x)
            if name == "plain":
                loss = raw.square().mean()
            else:
                est = decode(raw, b.out_scale, b.out_offset, b.dt)
                loss = losses(est, b)["total"]
            opt.zero_grad()
            loss.backward()
            opt.step()
            if r > 0:  # the first step warms up allocators
                times.append(time.perf_counter() - t0)
        results[name] = batch / statistics.median(times)
    return {"plain_windows_per_s": results["plain"], "sspinn_windows_per_s": results["sspinn"], "batch": batch, "window": window}


#: Phases of one training step, in order (see :func:`profile_step`).
PHASES = ("data", "forward", "physics", "backward", "optimizer")


def profile_step(config: NetworkConfig, batch: int, window: int, repeats: int, threads: int, rng: np.random.Generator,
                 compiled: bool = False) -> dict:
    """Wall time of each phase of one :class:`sspinn.estimator.training.Trainer` step (median over
    ``repeats`` steps after one warm-up; CPU, so every phase has finished when the clock is
    read): window draw + :func:`make_batch` + input noise (data), the LSTM and head (forward),
    decoding + every physics loss (physics), ``loss.backward()`` (backward), gradient clipping +
    Adam (optimizer). Synthetic recordings without ZUPT speeds (L_FS off), as in
    :func:`bench_training`; the losses of the network's ground contact (``config.grf``). ``compiled``: the physics through ``torch.compile``
    (:class:`~sspinn.estimator.training.PhysicsTerms`); the warm-up step's wall time, which includes the
    compilation, is reported as ``first_step_s``."""
    torch.set_num_threads(threads)
    data = prepare([fake_recording(window * 8, rng) for _ in range(4)], SEGMENTS, zupt=False, grf=config.grf)
    sampler = WindowSampler(data, window, rng)
    imu_std = torch.ones(len(SEGMENTS), 3)
    n_inputs = input_features(data[0].recording.imu[:1], 1.75, 70.0, data[0].placement, SEGMENTS).shape[1]
    torch.manual_seed(0)
    model = SSPINNposeNet(n_inputs, config)
    opt = torch.optim.Adam(model.parameters(), lr=1e-3)
    losses = PhysicsLosses(grf=config.grf)
    physics = PhysicsTerms(compiled)
    noise = torch.full((n_inputs,), 0.25)
    times: dict[str, list[float]] = {k: [] for k in PHASES}
    first_step = 0.0
    for r in range(repeats + 1):
        marks = [time.perf_counter()]
        which, starts = sampler.sample(batch)
        x, b = make_batch(data, which, starts, window, SEGMENTS, imu_std, torch.device("cpu"))
        x = x + torch.randn_like(x) * noise
        marks.append(time.perf_counter())
        raw, _ = model(x)
        marks.append(time.perf_counter())
        loss = physics(losses, raw, b)["total"]
        marks.append(time.perf_counter())
        opt.zero_grad(set_to_none=True)
        loss.backward()
        marks.append(time.perf_counter())
        torch.nn.utils.clip_grad_norm_(model.parameters(), 1.0)
        opt.step()
        marks.append(time.perf_counter())
        if r > 0:
            for k, name in enumerate(PHASES):
                times[name].append(marks[k + 1] - marks[k])
        else:
            first_step = marks[-1] - marks[0]
    if compiled and not physics.compiled:
        raise RuntimeError("torch.compile of the physics failed (see the CompileWarning above)")
    median = {k: statistics.median(v) for k, v in times.items()}
    total = sum(median.values())
    return {"ms": {k: 1e3 * v for k, v in median.items()}, "share": {k: v / total for k, v in median.items()},
            "samples_per_s": batch * window / total, "batch": batch, "window": window, "threads": threads,
            "compiled": compiled, "first_step_s": first_step}


def bench_sharing(config: NetworkConfig, batch: int, window: int, repeats: int, rng: np.random.Generator) -> dict:
    """Demo-size steps/s alone and beside one busy-looping process, for 2, 1 and auto threads."""
    import subprocess

    from sspinn.estimator.cpu_share import free_cpus

    rates: dict[str, dict[str, float]] = {}
    for setting in ("2", "1", "auto"):
        rates[setting] = {}
        for neighbour in (False, True):
            proc = subprocess.Popen([sys.executable, "-c", "while True: pass"]) if neighbour else None
            if proc is not None:
                time.sleep(1.0)
            try:
                threads = free_cpus() if setting == "auto" else int(setting)
                prof = profile_step(config, batch, window, repeats, threads, rng, compiled=False)
            finally:
                if proc is not None:
                    proc.kill()
                    proc.wait()
            rates[setting]["beside" if neighbour else "alone"] = prof["samples_per_s"] / (batch * window)
            rates[setting]["threads_beside" if neighbour else "threads_alone"] = threads
    return rates


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="tiny sizes for a smoke run")
    ap.add_argument("--json", default=None, help="also write the results as JSON")
    ap.add_argument("--only-sharing", action="store_true", help="only section 4 (training beside a busy neighbour)")
    args = ap.parse_args(argv)
    rng = np.random.default_rng(0)
    paper = NetworkConfig()
    cfg = NetworkConfig(hidden=32, layers=2, dense=16) if args.quick else paper
    n, batch, window, repeats = (30, 4, 32, 2) if args.quick else (2000, 32, 256, 5)
    threads_before = torch.get_num_threads()
    demo = TrainConfig.from_yaml(Path(__file__).resolve().parents[2] / "configs" / "sspinn" / "demo.yaml")
    if args.only_sharing:
        return {"sharing": report_sharing(demo, cfg, batch, window, repeats, args.quick, rng)}
    print(f"sspinn SSPINNpose benchmark — torch {torch.__version__}, {platform.machine()}, model LSTM {cfg.layers}×{cfg.hidden}, dense {cfg.dense}")
    s = bench_streaming(cfg, n, rng)
    print(f"\n1. streaming latency per sample, 1 CPU thread, {s['samples']} samples in {s['rounds']} alternating rounds (p50 / p99, ms)")
    o, b, net = s["ours_ms"], s["baseline_ms"], s["network_only_ms"]
    print(f"   sspinn StreamingEstimator (numba LSTM cell + numba physics) {o[0]:7.3f} / {o[1]:7.3f}")
    print(f"   baseline: nn.LSTM stepped, PyTorch defaults + torch physics {b[0]:7.3f} / {b[1]:7.3f}")
    print(f"   for reference: torch network alone, oneDNN off             {net[0]:7.3f} / {net[1]:7.3f}")
    print(f"   baseline / sspinn: {b[0] / o[0]:.1f}× (p50), {b[1] / o[1]:.1f}× (p99);  paper 3.5 ms, target ≤ 1 ms: "
          f"p50 {'met' if o[0] <= 1.0 else 'NOT met'}, p99 {'met' if o[1] <= 1.0 else 'NOT met'}")
    t = bench_training(cfg, batch, window, repeats, rng)
    print(f"\n2. training throughput, batch {t['batch']} × {t['window']} samples, 2 threads (windows/s)")
    print(f"   plain PyTorch (same model, MSE on raw outputs)          {t['plain_windows_per_s']:9.1f}")
    print(f"   sspinn (all physics losses)                             {t['sspinn_windows_per_s']:9.1f}")
    print(f"   physics overhead: sspinn / plain = {t['sspinn_windows_per_s'] / t['plain_windows_per_s']:.2f}×")
    demo_net, demo_size = (cfg, (batch, window)) if args.quick else (demo.network, (demo.batch_size, demo.window))
    profiles = {}
    for name, net, (pb, pw) in (("demo", demo_net, demo_size), ("paper", cfg, (batch, window))):
        label = f"{name} (LSTM {net.layers}×{net.hidden}, batch {pb} × {pw}, GRF {net.grf})"
        pair = {}
        for compiled in (False, True):
            prof = profile_step(net, pb, pw, repeats if args.quick else 10, 2, rng, compiled=compiled)
            profiles[f"{label}, {'compiled' if compiled else 'eager'} physics"] = pair[compiled] = prof
        print(f"\n3. one training step, {label}, 2 threads (ms per step; share)")
        print(f"   {'phase':<10} {'before: eager physics':>24} {'after: compile: true':>24}")
        for phase in PHASES:
            print(f"   {phase:<10} {pair[False]['ms'][phase]:14.1f} {pair[False]['share'][phase]:8.1%} "
                  f"{pair[True]['ms'][phase]:14.1f} {pair[True]['share'][phase]:8.1%}")
        print(f"   throughput {pair[False]['samples_per_s']:14,.0f} {'':8} {pair[True]['samples_per_s']:14,.0f}   samples/s"
              f"  → after/before {pair[True]['samples_per_s'] / pair[False]['samples_per_s']:.2f}×")
        print(f"   first step, compilation included (a few seconds when inductor's cache holds it): "
              f"{pair[True]['first_step_s']:.1f} s, against {pair[False]['first_step_s']:.2f} s eager")
    sharing = report_sharing(demo, cfg, batch, window, repeats, args.quick, rng)
    torch.set_num_threads(threads_before)
    result = {"streaming": s, "training": t, "profile": profiles, "sharing": sharing, "config": cfg.__dict__, "quick": args.quick}
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(result, fh, indent=2)
    return result


def report_sharing(demo: TrainConfig, cfg: NetworkConfig, batch: int, window: int, repeats: int, quick: bool,
                   rng: np.random.Generator) -> dict:
    net, (pb, pw) = (cfg, (batch, window)) if quick else (demo.network, (demo.batch_size, demo.window))
    rates = bench_sharing(net, pb, pw, repeats if quick else 30, rng)
    print(f"\n4. training beside a busy neighbour, demo size (batch {pb} × {pw}, eager physics; steps/s)")
    print(f"   {'threads':<8} {'alone':>8} {'beside one busy process':>24} {'ratio':>7}")
    for setting, r in rates.items():
        ratio = r["beside"] / r["alone"]
        print(f"   {setting:<8} {r['alone']:8.1f} {r['beside']:24.1f} {ratio:7.2f}×   (threads used {r['threads_alone']}/{r['threads_beside']})"
              + ("   target ≥ 0.4×: " + ("met" if ratio >= 0.4 else "NOT met") if setting == "auto" else ""))
    return rates


if __name__ == "__main__":
    main(sys.argv[1:])
