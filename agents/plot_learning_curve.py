"""Learning curve of a run from its logs (no TensorBoard needed).

    python -m agents.plot_learning_curve runs/ppo_walk --out docs/ppo_learning_curve.png

Reads ``<run>/monitor/*.monitor.csv`` (every training episode: return, length, distance) and
``<run>/evaluations.csv`` (periodic deterministic evaluations, :class:`agents.train.WalkerEvalCallback`)
and draws three panels against environment steps: episode return (training, rolling mean, and
evaluation), distance per episode (training and evaluation, with the 10 m goal) and evaluation
falls / mean speed.

The environments of a ``DummyVecEnv`` step in lock-step, so the training step count at the end of
an episode of environment *i* is ``n_envs × (steps done by environment i)``; this also holds
across ``--resume`` (the Monitor files are appended to).

Why not SB3's ``results_plotter``: its ``load_results``/``ts2xy`` merge the environments'
episodes in wall-clock order and count steps as the running sum of finished episodes' lengths,
which lags the steps taken by up to an episode per environment; the lock-step count above is exact.
"""

from __future__ import annotations

import csv
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from sspinn.errors import ArgumentParser, bounded, run_cli
from sspinn.model.drawing import save_figure


def read_monitor(run_dir: str | Path) -> dict[str, np.ndarray]:
    """Training episodes of all environments, sorted by step count: ``timesteps``, ``return``,
    ``length`` (control steps) and ``distance`` (m)."""
    files = sorted(Path(run_dir, "monitor").glob("*.monitor.csv"))
    if not files:
        raise FileNotFoundError(f"no monitor files in {Path(run_dir, 'monitor')}")
    steps: list[np.ndarray] = []
    returns: list[float] = []
    lengths: list[int] = []
    distances: list[float] = []
    for path in files:
        with path.open() as fh:
            rows = list(csv.DictReader(line for line in fh if not line.startswith("#")))
        length = np.array([int(r["l"]) for r in rows], dtype=np.int64)
        steps.append(len(files) * np.cumsum(length))
        returns += [float(r["r"]) for r in rows]
        lengths += length.tolist()
        distances += [float(r.get("distance") or "nan") for r in rows]
    order = np.argsort(np.concatenate(steps), kind="stable")
    return {
        "timesteps": np.concatenate(steps)[order],
        "return": np.asarray(returns)[order],
        "length": np.asarray(lengths)[order],
        "distance": np.asarray(distances)[order],
    }


def read_evaluations(run_dir: str | Path) -> dict[str, np.ndarray]:
    """Columns of ``evaluations.csv`` as float arrays (empty dict if there is none yet)."""
    path = Path(run_dir, "evaluations.csv")
    if not path.is_file():
        return {}
    with path.open() as fh:
        rows = list(csv.DictReader(fh))
    if not rows:
        return {}
    return {key: np.array([float(r[key]) if r[key] not in ("", "None") else np.nan for r in rows]) for key in rows[0]}


def rolling_mean(values: np.ndarray, window: int) -> np.ndarray:
    """Trailing mean over ``window`` samples (shorter at the start)."""
    cumulative = np.cumsum(np.insert(values.astype(np.float64), 0, 0.0))
    idx = np.arange(1, len(values) + 1)
    start = np.maximum(idx - window, 0)
    return (cumulative[idx] - cumulative[start]) / (idx - start)


def plot_learning_curve(run_dir: str | Path, out: str | Path, window: int = 100, goal_m: float = 10.0) -> Path:
    """Draw the learning curve of ``run_dir`` into ``out`` (PNG) and return the path."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    train = read_monitor(run_dir)
    ev = read_evaluations(run_dir)
    x = train["timesteps"] / 1e6
    fig, axes = plt.subplots(3, 1, figsize=(8, 9), sharex=True)

    ax = axes[0]
    ax.plot(x, train["return"], ".", ms=1, color="0.75", label="training episodes")
    ax.plot(x, rolling_mean(train["return"], window), color="tab:blue", label=f"training, mean of {window}")
    if ev:
        ax.plot(ev["timesteps"] / 1e6, ev["mean_return"], "o-", ms=3, color="tab:red", label="evaluation (deterministic)")
    ax.set_ylabel("episode return")
    ax.legend(fontsize=8, loc="upper left")

    ax = axes[1]
    ax.plot(x, train["distance"], ".", ms=1, color="0.75", label="training episodes")
    ax.plot(x, rolling_mean(train["distance"], window), color="tab:blue", label=f"training, mean of {window}")
    if ev:
        ax.plot(ev["timesteps"] / 1e6, ev["mean_distance_m"], "o-", ms=3, color="tab:red", label="evaluation, mean")
        ax.plot(ev["timesteps"] / 1e6, ev["min_distance_m"], "v", ms=3, color="tab:red", alpha=0.5,
                label="evaluation, min")
    ax.axhline(goal_m, color="tab:green", ls="--", label=f"goal {goal_m:g} m in 10 s")
    ax.set_ylabel("distance per episode (m)")
    ax.legend(fontsize=8, loc="upper left")

    ax = axes[2]
    if ev:
        episodes = int(np.nanmax(ev["episodes"]))
        ax.bar(ev["timesteps"] / 1e6, ev["falls"], width=0.6 * np.min(np.diff(ev["timesteps"]), initial=1e5) / 1e6,
               color="tab:red", alpha=0.5, label=f"evaluation falls (of {episodes})")
        ax.set_ylim(0, episodes + 0.5)
        ax.set_ylabel("falls")
        twin = ax.twinx()
        twin.plot(ev["timesteps"] / 1e6, ev["mean_speed_m_s"], "o-", ms=3, color="k", label="evaluation mean speed")
        twin.set_ylabel("mean speed (m/s)")
        ax.legend(fontsize=8, loc="upper left")
        twin.legend(fontsize=8, loc="upper right")
    ax.set_xlabel("environment steps (millions)")
    for a in axes:
        a.grid(alpha=0.3)
    fig.suptitle(f"{Path(run_dir).name}: {int(train['timesteps'][-1]):,} steps, {len(train['return'])} training episodes")
    return save_figure(fig, out, dpi=100)


#: Longest rolling-mean window, episodes.
MAX_WINDOW = 100_000


def main(argv: Sequence[str] | None = None) -> int:
    """Command line: ``python -m agents.plot_learning_curve RUN_DIR --out PNG`` (the project's
    error path: one line and exit status 2 for a user error, see :func:`sspinn.errors.run_cli`)."""
    return run_cli(_main, "python -m agents.plot_learning_curve", argv, user_errors=(ValueError,))


def _main(argv: list[str]) -> int:
    parser = ArgumentParser(prog="python -m agents.plot_learning_curve", description=__doc__.splitlines()[0])
    parser.add_argument("run_dir", help="run directory written by python -m agents train")
    parser.add_argument("--out", default=None, help="PNG path (default <run_dir>/learning_curve.png)")
    parser.add_argument("--window", type=bounded(int, 1, MAX_WINDOW), default=100,
                        help=f"rolling-mean window, episodes (1–{MAX_WINDOW})")
    args = parser.parse_args(argv)
    out = args.out or Path(args.run_dir, "learning_curve.png")
    print(plot_learning_curve(args.run_dir, out, window=args.window))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
