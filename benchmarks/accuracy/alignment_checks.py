"""The IMU–GRF time alignment of ``sspinn import`` and its warnings, measured on the twelve CMU
treadmill trials (``../shared/data/cmu_treadmill_imu_grf``: 6 subjects × normal and stiff-knee
walking), as recorded and with their GRF edited in known ways.

Each trial is read, resampled and calibrated as the importer does it
(:func:`sspinn.imu.time_alignment.imu_signals`), then aligned (:func:`~sspinn.imu.time_alignment.align_to_grf`)
with the GRF's vertical forces as recorded or edited:

* **as recorded** — with the files' shared clock (the CMU IMU and GRF files start together and
  last equally long: the importer's default) and with ``--separate-clocks`` (a lag search);
* **sides swapped** — the right and left forces exchanged; also shifted by −0.2, −0.1, +0.1 and
  +0.2 of a stride (every lag in the window), and with separate clocks;
* **left 0.15 s late** — one channel delayed (force channels offset in time);
* **GRF ±0.15 s** — the whole GRF delayed or advanced (a shared clock that is wrong);
* **GRF +3.3 s, separate clocks** — a large offset the search must find;
* **clock jump** — 0.2 s of GRF samples lost at 60 % of the trial (lag jump).

Printed: (1) the lag per trial (used, measured in the window, per foot, the exchanged sides'
fit over the labelled one, the best score beyond the window over the best inside it); (2) heel
strikes of the aligned GRF (:func:`sspinn.data.gait_events.detect_events`, 10 %BW) against the
foot IMUs' own heel strikes (:func:`sspinn.data.gait_events.foot_imu_heel_strikes`, the
gyroscope rule, no force) at the shared clock's lag, the searched lag and the per-foot lags;
(3) each warning's count per condition, training subjects (Sub01–Sub04, on which the thresholds
were set) and held-out ones (Sub05–Sub06) apart. ``--imports`` also runs the whole ``sspinn
import`` (default options) on each trial and counts every warning it prints, alignment or not.

Usage::

    python -m benchmarks.accuracy.alignment_checks [--data DIR] [--imports] [--out FILE.md]
"""

from __future__ import annotations

import argparse
import csv
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sspinn.data.gait_events import detect_events, event_timing, foot_imu_heel_strikes
from sspinn.imu.calibration import calibrate
from sspinn.imu.sensor_map import SensorMap
from sspinn.imu.stream import RATE_HZ, resample
from sspinn.imu.time_alignment import Alignment, align_to_grf, imu_signals
from sspinn.imu.vendor_readers import read_imu_files, read_treadmill_grf
from sspinn.model.conventions import GRAVITY

REPO = Path(__file__).resolve().parents[1]
MAP = REPO / "configs" / "sensor_maps" / "cmu_treadmill.yaml"
TRAINING = ("Sub01", "Sub02", "Sub03", "Sub04")
HELD_OUT = ("Sub05", "Sub06")
CONDITIONS = ("CSBaseline", "CSStiffKnee")
#: Warning kinds of the alignment: a phrase each message holds → a short name.
KINDS = {"the time alignment is ambiguous": "ambiguous lag", "look offset in time": "channels offset",
         "look swapped between": "sides swapped", "may be swapped between": "swapped or half a stride",
         "shared clock": "clock overruled", "the IMU and the GRF jumps": "lag jump"}
#: Largest heel-strike pairing distance, s.
MATCH_S = 0.3


@dataclass
class Trial:
    """One CMU trial's alignment inputs (:func:`align_to_grf`'s arguments), its vertical forces
    (side → (n,) N), the feet's calibrated sagittal rates (side → (n,) rad/s) and body weight (N)."""

    subject: str
    condition: str
    inputs: tuple
    stride_s: float
    vertical: dict[str, np.ndarray]
    foot_rate: dict[str, np.ndarray]
    body_weight: float

    @property
    def name(self) -> str:
        return f"{self.subject} {self.condition}"


def load_trial(folder: Path, subject: str, condition: str, smap: SensorMap, mass: float) -> Trial:
    """Read, resample and calibrate one trial as ``sspinn import`` does."""
    stream = read_imu_files([folder / f"OpenSim_{subject}_{condition}_Accel.trc.gz"])
    _, stream = resample(stream)
    by_segment = smap.by_segment()
    signals = {seg: (stream.sensors[a.sensor].acc, stream.sensors[a.sensor].gyr) for seg, a in by_segment.items()}
    cal = calibrate(signals, by_segment, RATE_HZ)
    _, forces = read_treadmill_grf(folder / f"OpenSim_{subject}_{condition}_GRF.mot.gz")
    rate = {s: cal.sensors[f"foot_{s}"].project(*signals[f"foot_{s}"])[:, 2] for s in "rl"}
    return Trial(subject, condition, imu_signals(signals), cal.stride_period_s, {s: f[:, 1] for s, f in forces.items()}, rate,
                 mass * GRAVITY)


def delayed(x: np.ndarray, seconds: float) -> np.ndarray:
    """``x`` delayed by ``seconds`` (advanced if negative), its end values repeated."""
    k = int(round(seconds * RATE_HZ))
    if k == 0:
        return x.copy()
    return np.concatenate([np.full(k, x[0]), x[:-k]]) if k > 0 else np.concatenate([x[-k:], np.full(-k, x[-1])])


def clock_jump(x: np.ndarray, at: float, seconds: float) -> np.ndarray:
    """``seconds`` of samples lost at the fraction ``at`` of ``x`` (later samples move up)."""
    i, k = int(at * len(x)), int(round(seconds * RATE_HZ))
    return np.concatenate([x[:i], x[i + k:], np.full(k, x[-1])])


def swapped(v: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    return {"r": v["l"], "l": v["r"]}


@dataclass(frozen=True)
class Condition:
    """A GRF edit, the clock the importer uses, the warnings that should fire (any of them; none:
    no warning at all) and the lag shift the edit adds (s; the expected lag is the as-recorded
    clock's plus it)."""

    name: str
    edit: Callable[[Trial], dict[str, np.ndarray]]
    same_clock: bool
    expected: tuple[str, ...]
    shift_s: Callable[[Trial], float] = lambda t: 0.0


def conditions() -> list[Condition]:
    out = [Condition("as recorded", lambda t: t.vertical, True, ()),
           Condition("as recorded, separate clocks", lambda t: t.vertical, False, ()),
           Condition("sides swapped", lambda t: swapped(t.vertical), True, ("sides swapped",))]
    for f in (-0.2, -0.1, 0.1, 0.2):
        out.append(Condition(f"sides swapped, GRF {f:+.1f} stride", lambda t, f=f: {s: delayed(v, f * t.stride_s)
                                                                                     for s, v in swapped(t.vertical).items()},
                             True, ("sides swapped",), lambda t, f=f: f * t.stride_s))
    out += [Condition("sides swapped, separate clocks", lambda t: swapped(t.vertical), False,
                      ("sides swapped", "swapped or half a stride")),
            Condition("left 0.15 s late", lambda t: {"r": t.vertical["r"], "l": delayed(t.vertical["l"], 0.15)}, True,
                      ("channels offset",)),
            Condition("GRF 0.15 s late", lambda t: {s: delayed(v, 0.15) for s, v in t.vertical.items()}, True, ("clock overruled",),
                      lambda t: 0.15),
            Condition("GRF 0.15 s early", lambda t: {s: delayed(v, -0.15) for s, v in t.vertical.items()}, True, ("clock overruled",),
                      lambda t: -0.15),
            Condition("GRF 3.3 s late, separate clocks", lambda t: {s: delayed(v, 3.3) for s, v in t.vertical.items()}, False, (),
                      lambda t: 3.3),
            Condition("clock jump 0.2 s at 60 %", lambda t: {s: clock_jump(v, 0.6, 0.2) for s, v in t.vertical.items()}, True,
                      ("lag jump",))]
    return out


def align(trial: Trial, vertical: dict[str, np.ndarray], same_clock: bool, per_foot: bool = False) -> Alignment:
    still, hit, activity, names = trial.inputs
    n = max(len(activity), len(next(iter(vertical.values()))))
    return align_to_grf(still, hit, vertical, activity, trial.stride_s, RATE_HZ, max_lag_s=n / RATE_HZ + 1.0, names=names,
                        clock_lag_s=0.0 if same_clock else None, per_foot=per_foot)


def kinds(alignment: Alignment) -> list[str]:
    return [next((k for phrase, k in KINDS.items() if phrase in w), w[:40]) for w in alignment.warnings]


def heel_strike_error(trial: Trial, lags: dict[str, float]) -> dict[str, tuple[float, float]]:
    """Per foot (bias, mean |error|) ms of the GRF heel strikes, mapped to IMU time with that
    foot's lag, against the foot IMU's heel strikes."""
    out = {}
    for s, lag in lags.items():
        grf = detect_events(trial.vertical[s], trial.body_weight, RATE_HZ).heel_strikes - lag * RATE_HZ
        t = event_timing(np.round(grf).astype(int), foot_imu_heel_strikes(trial.foot_rate[s], RATE_HZ), RATE_HZ, MATCH_S)
        out[s] = (t.bias_ms, t.mean_abs_ms)
    return out


def import_warnings(folder: Path, subject: str, condition: str, mass: float, height: float) -> list[str]:
    """The warnings a whole default ``sspinn import`` of the trial prints (no figure)."""
    from sspinn.imu import pipeline

    with tempfile.TemporaryDirectory() as tmp:
        keep, pipeline.plot_calibration = pipeline.plot_calibration, lambda path, *a, **k: Path(path)
        try:
            result = pipeline.import_imu([folder / f"OpenSim_{subject}_{condition}_Accel.trc.gz"], MAP, height, mass, tmp,
                                         grf=folder / f"OpenSim_{subject}_{condition}_GRF.mot.gz")
        finally:
            pipeline.plot_calibration = keep
    return list(result.calibration.warnings)


def warning_kind(text: str) -> str:
    """A short name for any import warning."""
    phrases = {**KINDS, "fits the hip joints better": "another sensor fits the pelvis", "the gyroscope reads": "gyroscope scale",
               "|specific force|": "accelerometer scale", "upside down": "upside down", "do not move like one leg": "legs mixed",
               "look swapped in the sensor map": "map sides swapped", "body weight": "GRF vs body weight",
               "carry less than": "feet unloaded", "turn": "turning"}
    return next((k for phrase, k in phrases.items() if phrase in text), text.split(":")[1][:50] if ":" in text else text[:50])


def main(argv: list[str] | None = None) -> str:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=REPO.parent / "shared" / "data" / "cmu_treadmill_imu_grf")
    parser.add_argument("--imports", action="store_true", help="also run the whole import on each trial and count its warnings")
    parser.add_argument("--out", type=Path, default=None, help="write the tables to this Markdown file too")
    args = parser.parse_args(argv)
    if not (args.data / "subjects.csv").exists():
        parser.error(f"{args.data}: the CMU treadmill data is not there (see ../shared/data/README.md); give --data")
    smap = SensorMap.from_yaml(MAP)
    with open(args.data / "subjects.csv", newline="") as fh:
        rows = {row["subject"]: row for row in csv.DictReader(fh)}
    trials = [load_trial(args.data / sub / cond, sub, cond, smap, float(rows[sub]["mass_kg"]))
              for sub in (*TRAINING, *HELD_OUT) for cond in CONDITIONS]
    out: list[str] = []

    def emit(*lines: str) -> None:
        print("\n".join(lines), flush=True)
        out.extend(lines)

    emit("## Lag per trial, as recorded", "",
         "| trial | lag used (s) | from | measured in window (s) | per foot r / l (s) | exchanged / labelled | beyond / in window | "
         "search lag (s) | warnings |", "|---|---:|---|---:|---|---:|---:|---:|---|")
    for t in trials:
        a, b = align(t, t.vertical, True), align(t, t.vertical, False)
        beyond = a.runner_up.score if a.runner_up is not None else float("nan")  # the best candidate that may overrule
        inside = max(a.fit.labelled.score, a.fit.exchanged.score)
        emit(f"| {t.name}{' (held out)' if t.subject in HELD_OUT else ''} | {a.lag_s:+.2f} | {a.clock} | {a.measured_lag_s:+.2f} | "
             f"{a.side_lags['r']:+.2f} / {a.side_lags['l']:+.2f} | {a.fit.sides_ratio:.2f} | {beyond / inside:.2f} | {b.lag_s:+.2f} | "
             f"{'; '.join(kinds(a)) or '–'} |")
    emit("", "## Heel strikes of the aligned GRF against the foot IMUs' own (bias / mean |error|, ms; right, left)", "",
         "| trial | shared clock r | l | searched lag r | l | per-foot lags r | l |", "|---|---:|---:|---:|---:|---:|---:|")
    sums: dict[str, list[float]] = {}
    for t in trials:
        a, b = align(t, t.vertical, True), align(t, t.vertical, False)
        cells = []
        for key, lags in (("clock", {s: 0.0 for s in "rl"}), ("search", {s: b.lag_s for s in "rl"}), ("per-foot", a.side_lags)):
            err = heel_strike_error(t, lags)
            for s in "rl":
                cells.append(f"{err[s][0]:+.0f} / {err[s][1]:.0f}")
                sums.setdefault(f"{key} {'held' if t.subject in HELD_OUT else 'train'}", []).append(err[s][1])
        emit(f"| {t.name}{' (held out)' if t.subject in HELD_OUT else ''} | " + " | ".join(cells) + " |")
    emit("", "Mean |error| over feet and trials (ms): " + "; ".join(f"{k} {np.mean(v):.1f}" for k, v in sums.items()), "")
    emit("## Warnings per condition (training Sub01–Sub04: of 8 trials; held out Sub05–Sub06: of 4)", "",
         "| condition | expected | fired as expected (train / held out) | other warnings (train / held out) | "
         "median \\|lag − expected\\| (s) |", "|---|---|---:|---|---:|")
    for c in conditions():
        hit = {"train": 0, "held": 0}
        other: dict[str, dict[str, int]] = {}
        errors = []
        for t in trials:
            group = "held" if t.subject in HELD_OUT else "train"
            a = align(t, c.edit(t), c.same_clock)
            found = kinds(a)
            hit[group] += any(k in found for k in c.expected) if c.expected else not found
            for k in found:
                if k not in c.expected:
                    other.setdefault(k, {"train": 0, "held": 0})[group] += 1
            errors.append(abs(a.lag_s - c.shift_s(t)))
        others = "; ".join(f"{k} {v['train']} / {v['held']}" for k, v in other.items()) or "–"
        emit(f"| {c.name} | {', or '.join(c.expected) or 'no warning'} | {hit['train']} / {hit['held']} | {others} | {np.median(errors):.2f} |")
    if args.imports:
        emit("", "## Every warning of a whole default import (trials warned, training / held out)", "")
        counts: dict[str, dict[str, list[str]]] = {}
        for sub in (*TRAINING, *HELD_OUT):
            for cond in CONDITIONS:
                row = rows[sub]
                for w in import_warnings(args.data / sub / cond, sub, cond, float(row["mass_kg"]), float(row["height_m"])):
                    names = counts.setdefault(warning_kind(w), {"train": [], "held": []})["held" if sub in HELD_OUT else "train"]
                    if f"{sub} {cond}" not in names:
                        names.append(f"{sub} {cond}")
        emit("| warning | training (of 8) | held out (of 4) |", "|---|---|---|")
        for k, v in sorted(counts.items()):
            emit(f"| {k} | {len(v['train'])} {', '.join(v['train'])} | {len(v['held'])} {', '.join(v['held'])} |")
    text = "\n".join(out) + "\n"
    if args.out is not None:
        from sspinn.run_folder import atomic_write_text

        atomic_write_text(args.out, text)
    return text


if __name__ == "__main__":
    main()
