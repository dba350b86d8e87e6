"""Comparison harness: self-supervised gait generator vs SB3 agents vs trajectory optimisation.

Every method is run on the same :class:`envs.sagittal_walker.SagittalWalkerEnv` (default physics,
the task's body, target speed and reset seeds) and scored by the same code:

* **generator** — the self-supervised gait generator (:mod:`predictive.generator.gait_generator`):
  one forward pass per speed (optionally a brief L-BFGS fine-tune), deployed by
  :class:`predictive.generator.closed_loop.GaitTracker` (feedforward + periodic LQR);
* **ocp** — predictive trajectory optimisation (:func:`predictive.ocp.collocation.solve_predictive`
  with the environment's contact model, 100 nodes per half cycle) deployed the same way;
* **sb3** — trained stable-baselines3 agents (:mod:`agents`), one checkpoint per target speed.

All of them are :class:`predictive.controller.Controller` objects (SB3's ``predict`` convention;
the SB3 agents through :class:`SB3Controller`), made by ``controller_for(speed, body)`` of a
:class:`predictive.controller.ControllerSource` and run by the same episode loop.

Start states: the gait trackers start on their reference at their start sample
(``tracker.start``, :class:`predictive.generator.closed_loop.TrackerSettings`; ``reset(options=
{"initial_state": ...})``) with the environment's reset noise; the SB3 agents start standing, as
trained. The gait trackers do not learn gait initiation — a stated difference, not hidden.

Disturbance conditions (``conditions``: name → ``env.reset`` options ``reset_noise_scale`` and
``disturbances``, :class:`envs.disturbances.Disturbances`: pushes, observation noise and delay,
actuator strength, body mismatch) rerun every controller's episodes, built for the nominal
environment, under each condition; the report adds a table of episodes without a fall per condition.
With ``animation_s`` > 0, each controller's first seconds at each speed are written as
``gait_<method>_<speed>.gif``.

Metrics per (method, speed), over the seeds: success rate (no fall in the episode, 10 s),
|speed error| (m/s, mean speed over the episode vs target), cost of transport (the environment's
mechanical CoT), mean |Kane residual| of the executed motion (BW; translational rows, q̈ by
central differences of the 100 Hz states, the GRF of the environment's contact model, actuator
plus passive torques — it measures how far the 100 Hz samples are from satisfying the continuous
equations, i.e. mostly the sampling of impacts; the same computation for every method), joint
angle RMSD to Winter's walking (deg; right hip/knee/ankle, the mean normalised cycle from right
heel strikes after the first 2 s; speeds < 2 m/s and when Winter's data is at hand: ``data_dir`` or ``$SSPINN_SHARED_DATA``), jitter
(mean |d³θ/dt³|, rad/s³), the gait metrics of :func:`sspinn.data.gait_metrics.gait_metrics`
(asymmetries, sliding, impact, cadence, flight, double support, taps per step), the share of
episodes meeting every walking target (:data:`sspinn.data.gait_metrics.WALKING_TARGETS`; speeds
< 2 m/s), and the wall-clock **time to obtain the controller** (one-off training)
and **time per new speed** (what a new target speed costs: a forward pass + LQR; an OCP solve +
LQR; retraining the agent).

A comparison is a long job: every finished (method, speed) cell is kept in ``<out>/cells/`` (one
JSON file, written atomically), so a run stopped by Ctrl-C or a crash continues where it stopped
when started again with the same ``--out``. A kept cell is reused only while its inputs are
unchanged — the configuration that shapes it (method, speed, seeds, body, tracker, conditions)
and the SHA-256 of the method's model files (:func:`cell_key`); otherwise it is run again. The
run owns its folder while it runs (:class:`sspinn.run_folder.RunLock`).
"""

from __future__ import annotations

import json
import math
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import gymnasium
import numpy as np

import envs  # noqa: F401  (registers the environment)
from agents.checkpoints import checkpoint_steps, load_agent, vecnormalize_path
from agents.evaluate import write_animation
from agents.plot_learning_curve import read_evaluations
from agents.rollout import run_episode
from predictive.controller import Controller as ControllerProtocol
from predictive.controller import LegLengthCalibrated, start_options
from predictive.generator.closed_loop import TrackerSettings
from predictive.generator.controllers import GeneratorControllers, OCPControllers
from predictive.ocp.collocation import OCPError
from predictive.synth.cache import jsonable, stable_hash
from sspinn.data.gait_events import contact_onsets
from sspinn.data.gait_metrics import WALKING_TARGETS, winter_or_none
from sspinn.estimator.calibration_files import file_sha256
from sspinn.estimator.evaluation import angle_jitter
from sspinn.model.body import BodyParameters
from sspinn.model.drawing import draw_stick_figure, save_figure
from sspinn.model.trajectory import Trajectory
from sspinn.run_folder import RunLock, atomic_write_json, atomic_write_text, claim_run_folder
from sspinn.yaml_config import load_config

#: Samples of the normalised gait cycle.
CYCLE_POINTS = 100
#: Episodes start with this much simulated time (s) excluded from the gait-cycle average.
SETTLE_S = 2.0
#: Gait-quality metrics (:class:`sspinn.data.gait_metrics.GaitMetrics`) averaged over the episodes.
GAIT_KEYS = ("step_time_asymmetry", "step_length_asymmetry", "stance_asymmetry", "foot_slide_per_step_cm",
             "peak_impact_bw", "cadence_steps_per_min", "flight_percent", "double_support_percent", "taps_per_step")
#: ``env.reset`` options a disturbance condition may set (:class:`envs.disturbances.Disturbances`).
CONDITION_OPTIONS = ("reset_noise_scale", "disturbances")


@dataclass
class MethodSpec:
    """One method of the comparison (see the module docstring).

    Attributes:
        name: label in the report. kind: "generator", "ocp" or "sb3".
        model: generator.pt (kind generator). refine_iterations: per-speed L-BFGS fine-tune
            (0: one forward pass), with the Kane weight × refine_kane_factor.
        n_nodes: OCP nodes per half cycle (kind ocp).
        checkpoints: target speed (m/s) → SB3 checkpoint .zip (kind sb3); speeds without one are
            reported as "not trained".
        calibrate_legs: (kind generator) read the leg length from each episode's first observation
            and re-plan for it (:class:`predictive.controller.LegLengthCalibrated`).
    """

    name: str
    kind: str
    model: str | None = None
    refine_iterations: int = 0
    refine_kane_factor: float = 10.0
    n_nodes: int = 100
    checkpoints: dict[float, str] = field(default_factory=dict)
    calibrate_legs: bool = False

    def __post_init__(self) -> None:
        if self.kind not in ("generator", "ocp", "sb3"):
            raise ValueError(f"method {self.name!r}: kind must be generator, ocp or sb3, got {self.kind!r}")
        if self.kind == "generator" and not self.model:
            raise ValueError(f"method {self.name!r}: kind generator needs model: <generator.pt>")
        self.checkpoints = {float(k): str(v) for k, v in self.checkpoints.items()}


@dataclass
class ComparisonConfig:
    """The task set and the methods (``configs/predictive/compare.yaml``)."""

    speeds: list[float] = field(default_factory=lambda: [1.3, 3.5])
    seeds: list[int] = field(default_factory=lambda: [0, 1, 2, 3, 4])
    height: float = 1.75
    mass: float = 70.0
    methods: list[MethodSpec] = field(default_factory=list)
    tracker: TrackerSettings = field(default_factory=TrackerSettings)
    data_dir: str | None = None
    snapshot_seeds: list[int] = field(default_factory=lambda: [0])
    conditions: dict[str, dict[str, Any]] = field(default_factory=dict)
    animation_s: float = 0.0

    def __post_init__(self) -> None:
        self.methods = [m if isinstance(m, MethodSpec) else MethodSpec(**m) for m in self.methods]
        for name, options in self.conditions.items():
            if not isinstance(options, dict) or set(options) - set(CONDITION_OPTIONS):
                raise ValueError(f"conditions.{name}: expected a mapping of {list(CONDITION_OPTIONS)} "
                                 f"(env.reset options), got {options!r}")
        if isinstance(self.tracker, dict):
            self.tracker = TrackerSettings(**self.tracker)
        if not self.speeds or any(not (0 < v <= 12) for v in self.speeds):
            raise ValueError(f"speeds must be a non-empty list of m/s in (0, 12], got {self.speeds}")
        if not self.seeds:
            raise ValueError("seeds must not be empty")
        if not (0.0 <= self.animation_s <= 10.0):
            raise ValueError(f"animation_s must be 0–10 s, got {self.animation_s}")

    @classmethod
    def from_yaml(cls, path: str | Path) -> ComparisonConfig:
        return load_config(cls, path, "compare")


@dataclass
class BuiltController:
    """A controller (:class:`predictive.controller.Controller`, None when it could not be made)
    and what it cost."""

    controller: ControllerProtocol | None
    setup_time_s: float  # one-off (training) wall time, s
    per_speed_time_s: float  # wall time for this speed, s
    reference: Any = None  # the GaitSolution tracked (gait trackers)
    note: str = ""


class SB3Controller:
    """A trained stable-baselines3 agent as a :class:`predictive.controller.Controller`: the
    agent's own ``predict`` (observation normalised as in training; state and ``episode_start``
    passed through, so an agent's gait clock restarts with the episode). ``agent``: an
    :class:`agents.checkpoints.LoadedAgent` or any object with that ``predict``."""

    def __init__(self, agent: Any) -> None:
        self.agent = agent

    @property
    def initial_state(self) -> Any:
        """The agent's start state: its reference stride's first sample for a clock agent, else
        None (the agents learned to start from standing)."""
        return getattr(self.agent, "initial_state", None)

    def predict(
        self, observation: np.ndarray, state: Any = None, episode_start: Any = None, deterministic: bool = True
    ) -> tuple[np.ndarray, Any]:
        return self.agent.predict(observation, state=state, episode_start=episode_start, deterministic=deterministic)


# ------------------------------------------------------------------------------------------ methods
def make_env(config: ComparisonConfig, speed: float) -> Any:
    return gymnasium.make("sspinn/SagittalWalker-v0", height=config.height, mass=config.mass, target_speed=speed)


def tracked(source: Any, speed: float, env: Any, setup_s: float) -> BuiltController:
    """``source.controller_for(speed, body)`` for the environment's body; the time per speed is
    the plan plus the LQR (:func:`predictive.generator.controllers.track`)."""
    tracker = source.controller_for(speed, env.unwrapped.body)
    info = tracker.info
    return BuiltController(tracker, setup_s, info["plan_time_s"] + info["lqr_time_s"], info["plan"], info["note"])


def generator_controller(spec: MethodSpec, config: ComparisonConfig, speed: float, env: Any) -> BuiltController:
    source = GeneratorControllers.from_file(spec.model, tracker=config.tracker, refine_iterations=spec.refine_iterations,
                                            refine_kane_factor=spec.refine_kane_factor)
    if spec.calibrate_legs:
        start = time.perf_counter()
        calibrated = LegLengthCalibrated(source, speed, env.unwrapped.body)
        info = calibrated.info
        return BuiltController(calibrated, source.training_time_s, time.perf_counter() - start, info.get("plan"),
                               info.get("note", ""))
    return tracked(source, speed, env, source.training_time_s)


def ocp_controller(spec: MethodSpec, config: ComparisonConfig, speed: float, env: Any) -> BuiltController:
    start = time.perf_counter()
    try:
        return tracked(OCPControllers(spec.n_nodes, config.tracker), speed, env, 0.0)
    except OCPError as exc:
        return BuiltController(None, 0.0, time.perf_counter() - start, None, f"OCP failed: {exc.status}")


def agent_training_time(checkpoint: Path) -> float:
    """Wall time (s) the run had trained when ``checkpoint`` was written, from its
    ``evaluations.csv``: the row at or before a periodic checkpoint's steps; for ``best_model.zip``
    the evaluation with the highest mean return (when the callback saved it); else the last row."""
    cols = agent_evaluations(checkpoint)
    if not cols:
        return float("nan")
    wall = cols["wall_s"]
    try:
        steps = checkpoint_steps(checkpoint)
    except ValueError:
        steps = None
    if steps is None:
        if Path(checkpoint).name.startswith("best_model"):
            return float(wall[np.nanargmax(cols["mean_return"])])
        return float(wall[-1])
    before = wall[cols["timesteps"] <= steps]
    return float((before if len(before) else wall)[-1])


def agent_evaluations(checkpoint: str | Path) -> dict[str, np.ndarray]:
    """Columns of the run's ``evaluations.csv`` (:func:`agents.plot_learning_curve.read_evaluations`),
    found next to the checkpoint or up to two folders above it; empty if there is none."""
    for folder in Path(checkpoint).resolve().parents[:3]:
        cols = read_evaluations(folder)
        if cols:
            return cols
    return {}


def sb3_controller(spec: MethodSpec, config: ComparisonConfig, speed: float, env: Any) -> BuiltController:
    path = spec.checkpoints.get(float(speed))
    if path is None or not Path(path).exists():
        return BuiltController(None, float("nan"), float("nan"), None, "not trained for this speed")
    agent = load_agent(path)
    train_s = agent_training_time(Path(path))
    return BuiltController(SB3Controller(agent), train_s, train_s, None, f"{agent.config.algo} {Path(path).name}")


BUILDERS = {"generator": generator_controller, "ocp": ocp_controller, "sb3": sb3_controller}


# ------------------------------------------------------------------------------------------ metrics
def executed_trajectory(episode: Trajectory, env: Any) -> Trajectory | None:
    """The executed motion of an episode (the rollout's :class:`~sspinn.model.trajectory.Trajectory`:
    states after each step, the actuator torque of each step) with the dynamics' own terms, at its
    interior samples 1 … n−2 of the steps: q̈ by central differences of u, τ the actuator torque
    averaged over the two intervals around the sample plus the passive joint moments, GRF and w of
    the environment's contact model. None with fewer than three samples."""
    e = env.unwrapped
    q, u, tau = episode.q[1:], episode.u[1:], episode.tau[:-1]
    if len(q) < 3:
        return None
    dt = float(e.dt)
    qdd = (u[2:] - u[:-2]) / (2 * dt)
    qm, um = q[1:-1], u[1:-1]
    tau_m = 0.5 * (tau[1:-1] + tau[2:])
    tau_total = tau_m + e.passive_torque(qm[:, 3:], um[:, 3:])
    return Trajectory.from_contact_model(dt * np.arange(1, len(q) - 1), qm, um, qdd, tau_total, e.body, e.contact)


def executed_kane_residual(episode: Trajectory, env: Any) -> float:
    """Mean |Kane residual| (BW) of the pelvis translation rows over the episode (module
    docstring): :meth:`~sspinn.model.trajectory.Trajectory.kane_residual` of :func:`executed_trajectory`."""
    executed = executed_trajectory(episode, env)
    if executed is None:
        return float("nan")
    return float(np.mean(np.abs(executed.kane_residual(env.unwrapped.body)[:, :2])))


def mean_right_cycle(episode: Trajectory, body_weight: float, dt: float) -> dict[str, np.ndarray] | None:
    """Mean right-leg cycle (hip, knee, ankle in rad; GRF x, y in BW; CYCLE_POINTS samples from
    right heel strike, :func:`sspinn.data.gait_events.contact_onsets`) over the complete cycles
    after SETTLE_S, or None without two strikes."""
    q, grf = episode.q[1:], episode.grf[1:]
    fy = grf[:, 1] / body_weight
    strikes = contact_onsets(fy)
    strikes = strikes[strikes * dt >= SETTLE_S]
    if len(strikes) < 2:
        return None
    signals = {
        "hip": q[:, 3], "knee": q[:, 4], "ankle": q[:, 5],
        "grf_x": grf[:, 0] / body_weight, "grf_y": fy,
    }
    frac = np.arange(CYCLE_POINTS) / CYCLE_POINTS
    out = {}
    for name, y in signals.items():
        cycles = [np.interp(frac, np.arange(b - a) / (b - a), y[a:b]) for a, b in zip(strikes[:-1], strikes[1:])]
        out[name] = np.mean(cycles, axis=0)
    out["percent"] = frac * 100
    return out


def winter_rmsd(cycle: dict[str, np.ndarray] | None, reference: Any) -> dict[str, float]:
    """RMSD (deg) of hip, knee, ankle between a mean cycle and Winter's (resampled to its grid)."""
    if cycle is None or reference is None:
        return {}
    out = {}
    for name in ("hip", "knee", "ankle"):
        ref = getattr(reference, name)
        sim = np.interp(reference.percent, cycle["percent"], cycle[name], period=100.0)
        out[f"rmsd_{name}_deg"] = float(np.degrees(np.sqrt(np.mean((sim - ref) ** 2))))
    return out


# ------------------------------------------------------------------------------------------ harness
@dataclass
class CellResult:
    """Results of one (method, speed)."""

    method: str
    kind: str
    speed: float
    note: str
    setup_time_s: float
    per_speed_time_s: float
    episodes: list[dict[str, Any]] = field(default_factory=list)
    cycle: dict[str, list[float]] | None = None
    stick_q: list[list[float]] | None = None
    conditions: dict[str, list[dict[str, Any]]] = field(default_factory=dict)

    def summary(self) -> dict[str, Any]:
        eps = self.episodes
        if not eps:
            return {"method": self.method, "speed": self.speed, "note": self.note, "success_rate": None}

        def mean(key: str) -> float | None:
            vals = [e[key] for e in eps if e.get(key) is not None and math.isfinite(e[key])]
            return float(np.mean(vals)) if vals else None

        return {
            "method": self.method, "speed": self.speed, "note": self.note,
            "success_rate": float(np.mean([not e["fell"] for e in eps])),
            "mean_distance_m": mean("distance_m"),
            "abs_speed_error_m_s": float(np.mean([abs(e["speed_error_m_s"]) for e in eps])),
            "cost_of_transport": mean("cost_of_transport"),
            "kane_residual_bw": mean("kane_residual_bw"),
            "rmsd_hip_deg": mean("rmsd_hip_deg"), "rmsd_knee_deg": mean("rmsd_knee_deg"),
            "rmsd_ankle_deg": mean("rmsd_ankle_deg"),
            "jitter_rad_s3": mean("jitter_rad_s3"),
            **{key: mean(key) for key in GAIT_KEYS},
            "walking_targets_met": (float(np.mean([not e["walking_target_misses"] for e in eps]))
                                    if all(e.get("walking_target_misses") is not None for e in eps) else None),
            "condition_success": {name: float(np.mean([not e["fell"] for e in rows])) for name, rows in self.conditions.items()},
            "setup_time_s": self.setup_time_s, "per_speed_time_s": self.per_speed_time_s,
        }


def evaluate_controller(
    built: BuiltController, env: Any, speed: float, seeds: list[int], reference: Any,
    condition: dict[str, Any] | None = None,
) -> tuple[list[dict[str, Any]], dict[str, np.ndarray] | None, np.ndarray | None]:
    """Episodes over ``seeds`` (under the ``env.reset`` options of a disturbance ``condition``) →
    per-episode metrics, the mean cycle of the first successful episode and its states (for stick figures)."""
    e = env.unwrapped
    controller = built.controller
    rows, cycle, states = [], None, None
    for seed in seeds:
        res = run_episode(controller, env, seed, speed,
                          reset_options=start_options(controller, condition))
        assert res.trajectory is not None
        m = res.metrics()
        m["kane_residual_bw"] = executed_kane_residual(res.trajectory, env)
        m["jitter_rad_s3"] = angle_jitter(res.trajectory.q[1:, 3:], 1.0 / e.dt)
        c = mean_right_cycle(res.trajectory, e.body.body_weight, e.dt) if not res.fell else None
        m.update(winter_rmsd(c, reference) if speed < 2.0 else {})
        m["walking_target_misses"] = (WALKING_TARGETS.misses(res.gait, fell=res.fell, distance_m=res.distance, duration_s=res.duration)
                                      if speed < 2.0 else None)
        rows.append(m)
        if c is not None and cycle is None:
            cycle, states = c, res.trajectory.q[1:]
    return rows, cycle, states


def slug(name: str) -> str:
    """A file-name form of a method's name (letters, digits and underscores)."""
    return "".join(c if c.isalnum() else "_" for c in name.lower()).strip("_")


def write_gait_animation(built: BuiltController, config: ComparisonConfig, speed: float, path: Path) -> Path:
    """The first ``config.animation_s`` s of the controller's nominal episode with the first reset
    seed, rendered by the environment at 25 frames/s, as a GIF."""
    steps = max(1, int(round(config.animation_s * 100)))
    env = gymnasium.make("sspinn/SagittalWalker-v0", height=config.height, mass=config.mass, target_speed=speed,
                         render_mode="rgb_array", max_episode_steps=steps)
    try:
        res = run_episode(built.controller, env, config.seeds[0], speed, frame_every=4,
                          reset_options=start_options(built.controller))
    finally:
        env.close()
    return write_animation(res.frames, path, fps=25)


#: Sub-folder of a comparison's ``--out`` holding its finished cells (module docstring).
CELLS_DIR = "cells"
#: The report files of a finished comparison (and of ``python -m predictive robustness``).
REPORT_FILES: tuple[str, ...] = ("report.md", "results.json")


def method_files(spec: MethodSpec, speed: float) -> list[Path]:
    """The files a method's cell at ``speed`` reads: the generator's model, or the SB3 checkpoint
    for that speed with its VecNormalize statistics (those that exist); none for the OCP."""
    if spec.kind == "generator" and spec.model:
        return [Path(spec.model)]
    if spec.kind == "sb3" and speed in spec.checkpoints:
        zip_path = Path(spec.checkpoints[speed])
        return [p for p in (zip_path, vecnormalize_path(zip_path)) if p.exists()]
    return []


def cell_key(config: ComparisonConfig, spec: MethodSpec, speed: float) -> str:
    """What a cell's result depends on, hashed: the configuration fields that shape it, the method,
    the speed, and the SHA-256 of the files it reads (:func:`method_files`)."""
    shaping = {k: v for k, v in asdict(config).items() if k not in ("methods", "speeds", "snapshot_seeds")}
    files = {str(p): file_sha256(p) for p in method_files(spec, speed) if p.is_file()}
    return stable_hash({"config": jsonable(shaping), "method": jsonable(asdict(spec)), "speed": speed, "files": files})


def _cell_path(out: Path, spec: MethodSpec, speed: float) -> Path:
    return out / CELLS_DIR / f"{slug(spec.name)}@{speed:g}.json"


def load_cell(path: Path, key: str) -> CellResult | None:
    """The cell kept at ``path`` if it was computed from the same inputs (``key``), else None
    (also for an unreadable file, which is then run again)."""
    try:
        data = json.loads(path.read_text())
        if data.get("key") != key:
            return None
        fields = dict(data["cell"])
        for name in ("setup_time_s", "per_speed_time_s"):  # NaN (nothing built) is written as null
            fields[name] = float("nan") if fields[name] is None else float(fields[name])
        return CellResult(**fields)
    except (OSError, ValueError, TypeError, KeyError):
        return None


def run_comparison(config: ComparisonConfig, out: str | Path, overwrite: bool = False) -> list[CellResult]:
    """Run every method at every speed; write ``results.json``, ``report.md`` and plots to ``out``.
    Cells finished by an earlier, interrupted run into ``out`` with the same inputs are reused
    (module docstring), unless ``overwrite``: then the kept cells and the report are deleted first."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    with RunLock(out):
        if overwrite:
            claim_run_folder(out, (CELLS_DIR, *REPORT_FILES), overwrite=True)
        return _run_comparison(config, out)


def _run_comparison(config: ComparisonConfig, out: Path) -> list[CellResult]:
    missing = sorted({spec.model for spec in config.methods if spec.kind == "generator" and not Path(str(spec.model)).is_file()})
    if missing:  # before hours of other methods, not when the method's turn comes
        raise FileNotFoundError(f"{', '.join(missing)}: no gait generator here (train one with `python -m predictive "
                                "train-generator`, or remove its methods from the configuration)")
    reference = winter_or_none(config.data_dir)
    cells: list[CellResult] = []
    for speed in config.speeds:
        env = None
        for spec in config.methods:
            path, key = _cell_path(out, spec, speed), cell_key(config, spec, speed)
            cell = load_cell(path, key) if path.exists() else None
            if cell is not None:
                print(f"[compare] {spec.name} at {speed} m/s: kept from an earlier run ({path})", flush=True)
                cells.append(cell)
                continue
            env = env or make_env(config, speed)
            print(f"[compare] {spec.name} at {speed} m/s …", flush=True)
            ctrl = BUILDERS[spec.kind](spec, config, speed, env)
            cell = CellResult(spec.name, spec.kind, speed, ctrl.note, ctrl.setup_time_s, ctrl.per_speed_time_s)
            if ctrl.controller is not None:
                rows, cycle, states = evaluate_controller(ctrl, env, speed, config.seeds, reference)
                cell.episodes = rows
                cell.cycle = {k: v.tolist() for k, v in cycle.items()} if cycle is not None else None
                cell.stick_q = states[:: max(1, len(states) // 400)].tolist() if states is not None else None
                for name, options in config.conditions.items():
                    cell.conditions[name] = evaluate_controller(ctrl, env, speed, config.seeds, reference, options)[0]
                if config.animation_s > 0:
                    write_gait_animation(ctrl, config, speed, out / f"gait_{slug(spec.name)}_{speed}.gif")
            path.parent.mkdir(exist_ok=True)
            atomic_write_json(path, {"key": key, "cell": asdict(cell)}, default=_json_default, non_finite="null")
            cells.append(cell)
            s = cell.summary()
            print(f"[compare]   success {s.get('success_rate')}, distance {s.get('mean_distance_m')}, "
                  f"under disturbances {s.get('condition_success', {})}, note: {cell.note}", flush=True)
        if env is not None:
            env.close()
    write_report(config, cells, out, reference)
    return cells


# ------------------------------------------------------------------------------------------ report
def learning_curves(config: ComparisonConfig) -> dict[str, dict[float, tuple[list[float], list[float]]]]:
    """Per method and speed: (wall time s, mean distance in a 10 s episode m) over training — SB3
    from its evaluation log, the generator from its snapshots (closed loop, ``snapshot_seeds``)."""
    curves: dict[str, dict[float, tuple[list[float], list[float]]]] = {}
    seen_models: set[str] = set()
    for spec in config.methods:
        if spec.kind == "sb3":
            for speed, path in spec.checkpoints.items():
                cols = agent_evaluations(path)
                if cols:
                    curves.setdefault(spec.name, {})[speed] = (cols["wall_s"].tolist(), cols["mean_distance_m"].tolist())
        elif spec.kind == "generator" and spec.model not in seen_models:  # one curve per trained network
            seen_models.add(str(spec.model))
            snaps = sorted(Path(spec.model).parent.glob("snapshots/generator_*.pt"))
            for speed in config.speeds:
                env = make_env(config, speed)
                xs, ys = [], []
                for snap in snaps:
                    ctrl = generator_controller(MethodSpec(spec.name, "generator", str(snap)), config, speed, env)
                    rows, _, _ = evaluate_controller(ctrl, env, speed, config.snapshot_seeds, None)
                    xs.append(ctrl.setup_time_s)
                    ys.append(float(np.mean([r["distance_m"] for r in rows])))
                env.close()
                if xs:
                    curves.setdefault(spec.name, {})[speed] = (xs, ys)
    return curves


def write_report(config: ComparisonConfig, cells: list[CellResult], out: Path, reference: Any) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    summaries = [c.summary() for c in cells]
    atomic_write_json(  # NaN (a method not run at a speed) → null
        out / "results.json",
        {"config": jsonable(asdict(config)), "summary": summaries, "episodes": {f"{c.method}@{c.speed}": c.episodes for c in cells},
         "condition_episodes": {f"{c.method}@{c.speed}": c.conditions for c in cells}},
        default=_json_default, non_finite="null",
    )
    # learning curves vs wall time
    curves = learning_curves(config)
    fig, axes = plt.subplots(1, len(config.speeds), figsize=(5.5 * len(config.speeds), 4), squeeze=False)
    for ax, speed in zip(axes[0], config.speeds):
        for name, per_speed in curves.items():
            if speed in per_speed:
                xs, ys = per_speed[speed]
                ax.plot(np.asarray(xs) / 60, ys, marker=".", label=name)
        for c in cells:
            if c.speed == speed and c.kind == "ocp" and c.episodes:
                ax.plot([c.per_speed_time_s / 60], [c.summary()["mean_distance_m"]], "k*", ms=12, label=c.method)
        ax.axhline(speed * 10, color="grey", ls=":", lw=1, label="target × 10 s")
        ax.set(xscale="log", xlabel="wall time to obtain the controller (min, log scale)", ylabel="distance in 10 s (m)",
               title=f"{speed} m/s")
        ax.legend(fontsize=7)
    save_figure(fig, out / "learning_curves.png", dpi=110)
    # gait-cycle curves
    for speed in config.speeds:
        fig, axes = plt.subplots(1, 4, figsize=(16, 3.5))
        for c in cells:
            if c.speed == speed and c.cycle is not None:
                for ax, key in zip(axes, ("hip", "knee", "ankle", "grf_y")):
                    y = np.asarray(c.cycle[key])
                    ax.plot(c.cycle["percent"], y if key == "grf_y" else np.degrees(y), label=c.method)
        if reference is not None and speed < 2.0:
            for ax, key in zip(axes, ("hip", "knee", "ankle", "grf_y")):
                y = getattr(reference, key)
                ax.plot(reference.percent, y if key == "grf_y" else np.degrees(y), "k--", label="Winter")
        for ax, key in zip(axes, ("hip (deg)", "knee (deg)", "ankle (deg)", "vertical GRF (BW)")):
            ax.set(xlabel="% gait cycle (right heel strike)", title=key)
        axes[0].legend(fontsize=7)
        fig.suptitle(f"mean executed gait cycle at {speed} m/s (right leg)")
        save_figure(fig, out / f"cycles_{speed}.png", dpi=110)
    # stick figures
    body = BodyParameters.from_anthropometry(config.height, config.mass)
    with_sticks = [c for c in cells if c.stick_q]
    if with_sticks:
        fig, axes = plt.subplots(len(with_sticks), 1, figsize=(12, 2.2 * len(with_sticks)), squeeze=False)
        for ax, c in zip(axes[:, 0], with_sticks):
            qs = np.asarray(c.stick_q)
            start = len(qs) // 2
            for k in range(start, min(start + 60, len(qs)), 6):
                draw_stick_figure(ax, qs[k], body, alpha=0.35 + 0.65 * (k - start) / 60)
            ax.set_aspect("equal")
            ax.set_title(f"{c.method} at {c.speed} m/s", fontsize=9)
            ax.axhline(0, color="k", lw=0.5)
        save_figure(fig, out / "stick_figures.png", dpi=100)
    # markdown
    cols = [("success_rate", "success", "{:.0%}"), ("mean_distance_m", "distance (m)", "{:.2f}"),
            ("abs_speed_error_m_s", "|speed err| (m/s)", "{:.3f}"), ("cost_of_transport", "CoT", "{:.2f}"),
            ("kane_residual_bw", "Kane res. (BW)", "{:.3f}"), ("rmsd_hip_deg", "hip RMSD (°)", "{:.1f}"),
            ("rmsd_knee_deg", "knee RMSD (°)", "{:.1f}"), ("rmsd_ankle_deg", "ankle RMSD (°)", "{:.1f}"),
            ("jitter_rad_s3", "jitter (rad/s³)", "{:.0f}"),
            ("step_time_asymmetry", "asym. step time (%)", "{:.1f}"), ("step_length_asymmetry", "asym. step length (%)", "{:.1f}"),
            ("stance_asymmetry", "asym. stance (%)", "{:.1f}"), ("foot_slide_per_step_cm", "slide/step (cm)", "{:.1f}"),
            ("peak_impact_bw", "impact (BW)", "{:.2f}"), ("cadence_steps_per_min", "cadence (steps/min)", "{:.0f}"),
            ("flight_percent", "flight (% of time)", "{:.1f}"), ("double_support_percent", "double support (% of stride)", "{:.1f}"),
            ("taps_per_step", "taps/step", "{:.2f}"), ("walking_targets_met", "all walking targets met", "{:.0%}"),
            ("setup_time_s", "one-off time (s)", "{:.0f}"),
            ("per_speed_time_s", "time per speed (s)", "{:.1f}")]
    lines = [f"# Predictive simulation comparison ({config.height} m, {config.mass} kg; seeds {config.seeds})", "",
             "| method | speed (m/s) | " + " | ".join(c[1] for c in cols) + " | note |",
             "|---|---|" + "---|" * len(cols) + "---|"]
    for s in summaries:
        vals = []
        for key, _, fmt in cols:
            v = s.get(key)
            vals.append("–" if v is None or (isinstance(v, float) and not math.isfinite(v)) else fmt.format(v))
        lines.append(f"| {s['method']} | {s['speed']} | " + " | ".join(vals) + f" | {s.get('note', '')} |")
    if config.conditions:
        names = list(config.conditions)
        lines += ["", "Episodes without a fall (of the reset seeds) under each disturbance condition "
                  "(`env.reset` options; the controllers were built for the nominal environment):", "",
                  "| method | speed (m/s) | nominal | " + " | ".join(names) + " |", "|---|---|---|" + "---|" * len(names)]
        for c in cells:
            if not c.episodes:
                continue
            counts = [f"{sum(not e['fell'] for e in c.episodes)}/{len(c.episodes)}"] + [
                f"{sum(not e['fell'] for e in c.conditions.get(n, []))}/{len(c.conditions.get(n, []))}" for n in names]
            lines.append(f"| {c.method} | {c.speed} | " + " | ".join(counts) + " |")
        lines += ["", "Conditions: " + "; ".join(f"**{n}** `{config.conditions[n]}`" for n in names)]
    lines += ["", "Time until a controller first covers ≥ 90 % of the target distance in a 10 s episode",
              "(learning curves: SB3 evaluation log, 5 seeds, no falls; generator snapshots, "
              f"seeds {config.snapshot_seeds}; OCP: solve + LQR):", "",
              "| method | " + " | ".join(f"{v} m/s" for v in config.speeds) + " |", "|---|" + "---|" * len(config.speeds)]
    for name, per_speed in curves.items():
        cells_txt = []
        for v in config.speeds:
            if v not in per_speed:
                cells_txt.append("–")
                continue
            xs, ys = per_speed[v]
            hit = [x for x, y in zip(xs, ys) if y >= 0.9 * v * 10]
            cells_txt.append(f"{hit[0] / 60:.1f} min" if hit else f"not within {max(xs) / 60:.0f} min")
        lines.append(f"| {name} | " + " | ".join(cells_txt) + " |")
    for name in dict.fromkeys(c.method for c in cells if c.kind == "ocp"):  # OCP: solve + LQR per speed
        per_speed = {c.speed: c for c in cells if c.method == name}
        lines.append(f"| {name} | " + " | ".join(
            f"{c.per_speed_time_s:.0f} s" if c and c.episodes and c.summary()["mean_distance_m"] >= 0.9 * v * 10 else "–"
            for v in config.speeds for c in [per_speed.get(v)]) + " |")
    lines += ["", "![learning curves](learning_curves.png)", ""]
    lines += [f"![cycles {v}](cycles_{v}.png)" for v in config.speeds]
    lines += ["", "![stick figures](stick_figures.png)", "", "Metrics and start states: see `predictive/experiments/controller_comparison.py`."]
    path = out / "report.md"
    return atomic_write_text(path, "\n".join(lines) + "\n")



def _json_default(obj: Any) -> Any:
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    return str(obj)


__all__ = [
    "BuiltController", "CellResult", "ComparisonConfig", "MethodSpec", "SB3Controller", "evaluate_controller", "executed_kane_residual",
    "executed_trajectory", "learning_curves", "mean_right_cycle", "run_comparison", "winter_rmsd", "write_report",
]
