"""Human gait norms of the shared human recordings: what :func:`sspinn.data.gait_norms.check_gait_norms`
measures on real walking and running, against the human ranges it checks.

Recordings (``$SSPINN_SHARED_DATA`` or ``--data``; a missing folder is skipped with a note):

* ``winter_walking``: Winter's averaged stride (1.325 m/s, 56.7 kg), both feet's vertical GRF,
  repeated 8 times (one stride, so every stance is the same).
* ``opensim_subject01_walk``: treadmill walking, 600 Hz GRF, the scaled model's mass (72.6 kg);
  the speed is not recorded, the walking ranges at 1.3 m/s are applied; the IK angles (60 Hz) with
  the GRF resampled to them give the hip/knee/ankle RMSD to Winter's walking.
* ``opensim_hamner_run``: treadmill running, 60 Hz GRF, 65.9 kg, belt speed estimated from the IK
  and the GRF (``estimate_belt_speed`` of ``benchmarks/accuracy/semi_real_running.py``).
* ``cmu_treadmill_imu_grf``: six adults at Froude 0.25 (0.73–0.77 m/s, ``subjects.csv``), 100 Hz
  treadmill GRF, the normal (``CSBaseline``) and the mock stiff-knee (``CSStiffKnee``) trials; the
  walking ranges of the slowest tabulated speed (0.8 m/s) apply.

Usage: ``python -m benchmarks.accuracy.gait_norms_references [--data ../shared/data] [--json out.json]``.
Prints one Markdown table (the figures of ``docs/results/gait_norms_references.md``).

``--solution PATH [PATH …]`` scores periodic gait cycles written by ``python -m predictive solve``
(``PATH.npz`` + ``PATH.json``; speed, stride duration and body from the file) the same way:
the cycle repeated :data:`REPEATS` times, its :func:`sspinn.data.gait_metrics.gait_metrics`, the
walking targets it misses (:data:`sspinn.data.gait_metrics.WALKING_TARGETS`; falls and distance
do not apply to a cycle) and its norms, beside the rows of the human recordings.
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
from pathlib import Path
from typing import Any

import numpy as np

G = 9.81


def _winter(data: Path) -> list[tuple[str, Any]]:
    from sspinn.data.gait_metrics import load_winter
    from sspinn.data.gait_norms import check_gait_norms

    winter = load_winter(data)
    table = np.genfromtxt(data / "winter_walking" / "signals.csv", delimiter=",", names=True)
    vertical = np.tile(np.stack([table["grf_y_r"], table["grf_y_l"]], axis=1), (8, 1))
    return [("Winter, averaged stride (×8)", check_gait_norms(vertical, winter.speed, rate_hz=len(table) / winter.duration))]


def _subject01(data: Path) -> list[tuple[str, Any]]:
    from sspinn.data.gait_metrics import winter_or_none
    from sspinn.data.gait_norms import check_gait_norms
    from sspinn.data.opensim_files import (
        read_external_loads,
        read_opensim_columns,
        read_opensim_header,
        read_osim_model,
    )
    from sspinn.model.trajectory import Trajectory

    folder = data / "opensim_subject01_walk"
    weight = read_osim_model(folder / "subject01.osim").mass * G
    loads = read_external_loads(folder / "subject01_walk_grf.xml")
    grf = read_opensim_columns(folder / "subject01_walk_grf.mot")
    t_grf = grf.column("time")
    vertical = np.stack([grf.column(loads[f"calcn_{s}"].force + "y") for s in "rl"], axis=1) / weight
    report = check_gait_norms(vertical, 1.3, rate_hz=1.0 / float(np.median(np.diff(t_grf))))
    ik_path = folder / "subject01_walk_IK.mot"
    ik = read_opensim_columns(ik_path)
    scale = math.pi / 180 if read_opensim_header(ik_path).get("inDegrees", "no").strip().lower() == "yes" else 1.0
    t = ik.column("time")
    q = np.zeros((len(t), 9))
    for f, side in enumerate("rl"):
        for j, name in enumerate(("hip_flexion", "knee_angle", "ankle_angle")):
            q[:, 3 + 3 * f + j] = scale * ik.column(f"{name}_{side}")
    forces = np.zeros((len(t), 4))
    forces[:, 1], forces[:, 3] = (np.interp(t, t_grf, weight * vertical[:, f]) for f in range(2))
    n = len(t)
    trajectory = Trajectory(time=t - t[0], q=q, u=np.zeros((n, 9)), qdd=np.zeros((n, 9)), tau=np.zeros((n, 6)), grf=forces,
                            w=np.full((n, 2), 0.5))
    angles = check_gait_norms(trajectory, 1.3, body_weight_n=weight, reference=winter_or_none(data))
    return [("OpenSim subject01, treadmill walk (speed not recorded: 1.3 m/s ranges)", report),
            ("OpenSim subject01, IK angles + GRF at 60 Hz (RMSD to Winter)", angles)]


def _hamner(data: Path) -> list[tuple[str, Any]]:
    from benchmarks.accuracy.semi_real_running import estimate_belt_speed, read_hamner_files
    from sspinn.data.gait_norms import check_gait_norms

    files = read_hamner_files(data / "opensim_hamner_run")
    speed = estimate_belt_speed(files).speed
    vertical = np.stack([files.loads[s][:, 1] for s in "rl"], axis=1) / (files.mass * G)
    rate = 1.0 / float(np.median(np.diff(files.t_grf)))
    return [(f"Hamner subject02, treadmill run ({speed:.2f} m/s, estimated)", check_gait_norms(vertical, speed, "run", rate_hz=rate))]


def _cmu(data: Path) -> list[tuple[str, Any]]:
    from sspinn.data.gait_norms import check_gait_norms
    from sspinn.data.opensim_files import read_opensim_columns

    folder = data / "cmu_treadmill_imu_grf"
    with open(folder / "subjects.csv", newline="") as handle:
        subjects = list(csv.DictReader(handle))
    out = []
    for condition in ("CSBaseline", "CSStiffKnee"):
        for row in subjects:
            sub = row["subject"]
            path = folder / sub / condition / f"OpenSim_{sub}_{condition}_GRF.mot.gz"
            if not path.exists():
                continue
            grf = read_opensim_columns(path)
            vertical = np.stack([grf.column("rFy"), grf.column("lFy")], axis=1) / (float(row["mass_kg"]) * G)
            rate = 1.0 / float(np.median(np.diff(grf.column("time"))))
            speed = max(0.5, float(row["treadmill_speed_mps"]))
            out.append((f"CMU {sub} {condition} ({speed:.2f} m/s)", check_gait_norms(vertical, speed, rate_hz=rate, settle_s=2.0)))
    return out


#: Cycles a periodic solution is repeated for scoring.
REPEATS = 8


def _solution(path: Path, data: Path | None) -> tuple[str, Any, Any, list[str]]:
    """(row name, norms report, gait metrics, target misses) of a periodic solution repeated
    :data:`REPEATS` times (the samples of one period: time < duration; the pelvis advanced by
    speed × duration per cycle)."""
    from predictive.ocp.solution import GaitSolution
    from sspinn.data.gait_metrics import WALKING_TARGETS, gait_metrics, winter_or_none
    from sspinn.data.gait_norms import check_gait_norms
    from sspinn.model.trajectory import Trajectory

    cycle = GaitSolution.load(path)
    dt = float(np.median(np.diff(cycle.time)))
    n = int(np.sum(cycle.time < cycle.duration - 0.5 * dt))
    if abs(n * dt - cycle.duration) > 0.5 * dt:
        raise ValueError(f"{path}: nodes not on a uniform grid over the stride ({n} × {dt:.4f} s ≠ {cycle.duration} s)")
    q = np.concatenate([cycle.q[:n] + np.eye(9)[0] * cycle.speed * cycle.duration * k for k in range(REPEATS)])
    tile = {name: np.tile(getattr(cycle, name)[:n], (REPEATS, 1)) for name in ("u", "qdd", "tau", "grf", "w")}
    walk = Trajectory(time=np.arange(REPEATS * n) * dt, q=q, **tile)
    reference = winter_or_none(data)
    body = cycle.body
    metrics = gait_metrics(walk, body, reference=reference)
    mode = "walk" if cycle.speed < 2.0 else "run"
    norms = check_gait_norms(walk, cycle.speed, mode, body_weight_n=body.body_weight, reference=reference if mode == "walk" else None)
    misses = WALKING_TARGETS.misses(metrics) if mode == "walk" else []
    return f"{path} ({cycle.speed:g} m/s, {cycle.status})", norms, metrics, misses


def _cell(value: float, digits: int) -> str:
    return "–" if not math.isfinite(value) else f"{value:.{digits}f}"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=None, help="the shared data folder (default $SSPINN_SHARED_DATA)")
    parser.add_argument("--json", type=Path, default=None, help="also write the reports as JSON (a new file)")
    parser.add_argument("--solution", type=Path, nargs="+", default=[], help="periodic solutions (predictive solve) to score too")
    args = parser.parse_args(argv)

    from sspinn.data.shared_data import shared_data_dir

    data = args.data if args.data is not None else shared_data_dir()
    if data is None or not Path(data).is_dir():
        print(f"no shared data folder: {data} (set SSPINN_SHARED_DATA or pass --data)", file=sys.stderr)
        return 2
    data = Path(data)
    rows: list[tuple[str, Any]] = []
    for name, reader in (("winter_walking", _winter), ("opensim_subject01_walk", _subject01),
                         ("opensim_hamner_run", _hamner), ("cmu_treadmill_imu_grf", _cmu)):
        if not (data / name).is_dir():
            print(f"(skipped: {data / name} not found)")
            continue
        rows += reader(data)
    scored = [_solution(path, data) for path in args.solution]
    rows += [(name, norms) for name, norms, _, _ in scored]

    print("| recording | mode | stances (inside all ranges) | vertical peak BW | valley BW | stance % | double support % "
          "| flight % | cadence steps/min | taps | RMSD hip/knee/ankle ° | verdict |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for name, r in rows:
        rmsd = ("–" if not math.isfinite(r.rmsd_knee_deg)
                else f"{r.rmsd_hip_deg:.1f} / {r.rmsd_knee_deg:.1f} / {r.rmsd_ankle_deg:.1f}")
        failed = [k for k, v in r.checks.items() if v is False]
        verdict = "pass" if r.passed else "FAIL: " + ", ".join(failed)
        print(f"| {name} | {r.ranges.mode} | {len(r.stances)} ({100 * r.fraction_inside:.0f} %) | {_cell(r.peak_bw, 2)} | "
              f"{_cell(r.valley_bw, 2) if r.ranges.valley_bw else '–'} | {_cell(r.stance_percent, 1)} | "
              f"{_cell(r.double_support_percent, 1)} | {_cell(r.flight_percent, 1)} | {_cell(r.cadence_steps_per_min, 0)} | "
              f"{r.taps} | {rmsd} | {verdict} |")
    if scored:
        print("\n| solution | cadence steps/min | step time r / l s | heel strikes r / l | taps | flight % of time "
              "| double support % of stride | distance per step m | step length r / l m | impact BW | slide cm/step "
              "| walking targets missed |")
        print("|---|---|---|---|---|---|---|---|---|---|---|---|")
        for name, _, m, misses in scored:
            print(f"| {name} | {_cell(m.cadence_steps_per_min, 0)} | {_cell(m.step_time_r, 3)} / {_cell(m.step_time_l, 3)} | "
                  f"{m.heel_strikes_r} / {m.heel_strikes_l} | {m.taps_r + m.taps_l} | {_cell(m.flight_percent, 1)} | "
                  f"{_cell(m.double_support_percent, 1)} | {_cell(m.distance_per_step_m, 3)} | "
                  f"{_cell(m.step_length_r, 3)} / {_cell(m.step_length_l, 3)} | {_cell(m.peak_impact_bw, 2)} | "
                  f"{_cell(m.foot_slide_per_step_cm, 1)} | {'; '.join(misses) if misses else 'none'} |")
    if args.json is not None:
        from sspinn.run_folder import atomic_write_json

        if args.json.exists():
            print(f"{args.json}: exists; not replaced", file=sys.stderr)
            return 2
        atomic_write_json(args.json, {name: r.as_dict() for name, r in rows})
    return 0


if __name__ == "__main__":
    sys.exit(main())
