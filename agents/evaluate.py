"""Evaluate a trained agent: deterministic episodes on N seeds, a JSON report, a plot of joint
angles, torques and ground reaction forces, and an animation rendered by the environment.

    python -m agents evaluate --checkpoint runs/ppo/best_model.zip --episodes 5 --out runs/ppo/eval
    python -m agents record --checkpoint runs/ppo/best_model.zip --out walk.gif

``evaluate`` writes into ``--out``:

* ``metrics.json``: per episode (seed, distance in m over the episode — 10 s unless it fell —,
  mean speed and speed error in m/s, mechanical cost of transport, fell yes/no, return, and the
  gait metrics of :func:`sspinn.data.gait_metrics.gait_metrics`: step time / step length / stance
  asymmetry in %, foot sliding per step in cm, impact peak in BW, cadence, hip/knee/ankle angle RMSD (mean over legs) to
  Winter's walking in degrees when its data is found and the target is below 2 m/s) and their
  summary (:func:`agents.rollout.summarize`), the walking targets missed (below 2 m/s,
  :func:`agents.rollout.walking_target_misses`; an empty list: all met), plus the checkpoint,
  algorithm and environment arguments;
* ``traces.png``: time series of the first episode (:func:`plot_traces`);
* ``episode.gif``: the first episode through the environment's ``rgb_array`` mode.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from agents.builders import WALKING_BELOW_M_S, make_env
from agents.checkpoints import load_agent
from agents.config import ENV_RATE_HZ, AgentConfig
from agents.rollout import EpisodeResult, run_episode, summarize, walking_target_misses
from sspinn.data.gait_metrics import winter_or_none
from sspinn.errors import UserError
from sspinn.model.drawing import save_figure
from sspinn.run_folder import atomic_path, atomic_write_json

#: Most bytes of frames an animation keeps in memory before it is written (1500 frames of the
#: default 600×400 image).
MAX_ANIMATION_BYTES = 1500 * 600 * 400 * 3


def evaluate(
    checkpoint: str | Path,
    out: str | Path,
    episodes: int = 5,
    seed: int = 0,
    target_speed: float | None = None,
    max_steps: int | None = None,
    video: bool = True,
    fps: int = 25,
    data_dir: str | Path | None = None,
) -> dict[str, Any]:
    """Run ``episodes`` deterministic episodes (seeds ``seed``, ``seed + 1``, ...) at
    ``target_speed`` m/s (default: the run's evaluation target), write the report, plot and
    animation into ``out`` and return the report. ``data_dir``: the shared data folder holding
    ``winter_walking`` (default ``$SSPINN_SHARED_DATA``, :mod:`sspinn.data.shared_data`; absent: no angle RMSD)."""
    if episodes < 1:
        raise ValueError(f"episodes must be >= 1, got {episodes}")
    agent = load_agent(checkpoint)
    config = agent.config
    target = config.env.target_speed if target_speed is None else float(target_speed)
    overrides: dict[str, Any] = {} if max_steps is None else {"max_episode_steps": max_steps}
    frame_every = _frame_every(fps) if video else 0
    if video:
        check_animation_size(config, max_steps, fps, "lower --fps or --max-steps, or use --no-video")
    env = make_env(config, render_mode="rgb_array" if video else None, **overrides)
    reference = winter_or_none(data_dir) if target < WALKING_BELOW_M_S else None
    try:
        results = [
            run_episode(agent, env, seed + i, target, frame_every=frame_every if i == 0 else 0,
                        reference=reference)
            for i in range(episodes)
        ]
    finally:
        env.close()
    out_dir = Path(out)
    out_dir.mkdir(parents=True, exist_ok=True)
    report = {
        "checkpoint": str(checkpoint),
        "algo": config.algo,
        "target_speed": target,
        "env_kwargs": {**config.env.kwargs, **overrides},
        "gait_reference": "Winter's normal walking (right leg)" if reference is not None else None,
        "episodes": [r.metrics() for r in results],
        "summary": summarize(results),
        "walking_target_misses": walking_target_misses(results) if target < WALKING_BELOW_M_S else None,
    }
    atomic_write_json(out_dir / "metrics.json", report)
    plot_traces(results[0], out_dir / "traces.png")
    if video:
        write_animation(results[0].frames, out_dir / "episode.gif", fps)
    return report


def record(
    checkpoint: str | Path,
    out: str | Path,
    seed: int = 0,
    target_speed: float | None = None,
    max_steps: int | None = None,
    fps: int = 25,
) -> EpisodeResult:
    """Render one deterministic episode of ``checkpoint`` to ``out`` (``.gif``, or ``.mp4`` with
    ``imageio-ffmpeg`` installed) and return its result."""
    check_animation_path(out)
    agent = load_agent(checkpoint)
    config = agent.config
    target = config.env.target_speed if target_speed is None else float(target_speed)
    overrides: dict[str, Any] = {} if max_steps is None else {"max_episode_steps": max_steps}
    check_animation_size(config, max_steps, fps, "lower --fps or --max-steps")
    env = make_env(config, render_mode="rgb_array", **overrides)
    try:
        result = run_episode(agent, env, seed, target, frame_every=_frame_every(fps))
    finally:
        env.close()
    write_animation(result.frames, out, fps)
    return result


def _frame_every(fps: int) -> int:
    if not 1 <= fps <= ENV_RATE_HZ:
        raise ValueError(f"fps must lie in [1, {ENV_RATE_HZ}] (the environment runs at {ENV_RATE_HZ} Hz), got {fps}")
    return max(round(ENV_RATE_HZ / fps), 1)


def check_animation_size(config: AgentConfig, max_steps: int | None, fps: int, hint: str) -> None:
    """UserError if the frames of one episode of ``max_steps`` (default: the environment's
    ``max_episode_steps``) at ``fps`` would take more than :data:`MAX_ANIMATION_BYTES` of memory."""
    from envs.config import WalkerConfig

    kwargs = config.env.kwargs
    steps = max_steps if max_steps is not None else int(kwargs.get("max_episode_steps", WalkerConfig.max_episode_steps))
    frames = steps // _frame_every(fps) + 1
    size = frames * int(kwargs.get("width", 600)) * int(kwargs.get("height_px", 400)) * 3
    if size > MAX_ANIMATION_BYTES:
        raise UserError(f"an animation of {steps} steps at {fps} frames/s holds {frames} frames ({size / 1e9:.1f} GB), "
                        f"more than the {MAX_ANIMATION_BYTES / 1e9:.1f} GB allowed; {hint}")


def check_animation_path(path: str | Path) -> Path:
    """``path`` if it names a .gif, or a .mp4 with ``imageio-ffmpeg`` installed; else ValueError."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".mp4":
        try:
            import imageio_ffmpeg  # noqa: F401
        except ImportError as exc:
            raise ValueError("writing .mp4 needs the imageio-ffmpeg package (pip install imageio-ffmpeg); "
                             "or write a .gif") from exc
    elif suffix != ".gif":
        raise ValueError(f"animation must be a .gif or .mp4 file, got {path.name}")
    return path


def write_animation(frames: list[np.ndarray], path: str | Path, fps: int) -> Path:
    """Write RGB frames as a looping GIF (Pillow) or an MP4 (needs the ``imageio-ffmpeg`` package),
    atomically."""
    import imageio.v3 as iio

    path = check_animation_path(path)
    if not frames:
        raise ValueError("no frames to write")
    with atomic_path(path) as tmp:
        if path.suffix.lower() == ".gif":
            iio.imwrite(tmp, np.stack(frames), extension=".gif", duration=1000.0 / fps, loop=0)
        else:
            iio.imwrite(tmp, np.stack(frames), extension=".mp4", fps=fps)
    return path


def plot_traces(result: EpisodeResult, path: str | Path) -> Path:
    """3×3 figure of one episode: joint angles (deg) and actuator torques (N·m) of hip, knee and
    ankle (right red, left blue), vertical and horizontal ground reaction forces (N) and the hip
    speed against the target (m/s)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from sspinn.model.conventions import SIDES

    traj = result.trajectory
    if traj is None:
        raise ValueError("the episode has no trajectory")
    # after each step: states and forces from sample 1 on, the torque applied during the step
    t, q, tau, grf = traj.time[1:], traj.q[1:], traj.tau[:-1], traj.grf[1:]
    colors = {"r": "tab:red", "l": "tab:blue"}
    fig, axes = plt.subplots(3, 3, figsize=(13, 8.5), sharex=True)
    for j, joint in enumerate(("hip", "knee", "ankle")):
        for s, side in enumerate(SIDES):
            k = 3 * s + j
            axes[0, j].plot(t, np.degrees(q[:, 3 + k]), color=colors[side], lw=1, label=side)
            axes[1, j].plot(t, tau[:, k], color=colors[side], lw=1, label=side)
        axes[0, j].set_title(f"{joint} angle (deg)")
        axes[1, j].set_title(f"{joint} torque (N·m)")
    for s, side in enumerate(SIDES):
        axes[2, 0].plot(t, grf[:, 2 * s + 1], color=colors[side], lw=1, label=side)
        axes[2, 1].plot(t, grf[:, 2 * s], color=colors[side], lw=1, label=side)
    axes[2, 0].set_title("vertical GRF (N)")
    axes[2, 1].set_title("horizontal GRF (N)")
    axes[2, 2].plot(t, traj.u[1:, 0], color="k", lw=0.8, label="hip speed")
    axes[2, 2].axhline(result.target_speed, color="tab:green", ls="--", label="target")
    axes[2, 2].set_title("hip forward speed (m/s)")
    axes[2, 2].legend(loc="lower right", fontsize=8)
    axes[0, 0].legend(loc="upper right", fontsize=8)
    for ax in axes[2]:
        ax.set_xlabel("time (s)")
    for ax in axes.flat:
        ax.grid(alpha=0.3)
    cot = "inf" if not np.isfinite(result.cost_of_transport) else f"{result.cost_of_transport:.2f}"
    fig.suptitle(
        f"seed {result.seed}: {result.distance:.2f} m in {result.duration:.2f} s "
        f"(mean {result.mean_speed:.2f} m/s, target {result.target_speed:.2f}), CoT {cot}, "
        f"{'fell' if result.fell else 'no fall'}"
    )
    return save_figure(fig, path, dpi=90)
