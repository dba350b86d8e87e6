"""SSPINNpose on real continuous IMU recordings: the CMU treadmill benchmark.

Six adults walked ~60 s on an instrumented treadmill at 0.72–0.78 m/s, normally (``CSBaseline``)
and with a mock stiff knee (``CSStiffKnee``), with 8 Xsens IMUs in unknown mountings
(``../shared/data/cmu_treadmill_imu_grf``). Top to bottom:

1. **Import** every trial with :func:`sspinn.imu.pipeline.import_imu` (calibration onto the sagittal
   plane from the data, GRF aligned by cross-correlation, belt speed as the speed label):
   Sub01–Sub04 into the train split, Sub05–Sub06 into the test split. Cached: a trial already
   imported by this importer version is reused.
2. **Four arms** (and a fifth on request), each evaluated on Sub05–Sub06:
   ``scratch`` (self-supervised training on the real training trials, no labels),
   ``zero_shot`` (the model ``make demo`` trains on synthetic data only, ``--pretrained``),
   ``finetune`` (that model, fine-tuned self-supervised on the real training trials; the CLI's
   ``sspinn finetune``) — none of these three saw the test subjects — and ``adapted`` (that
   model adapted to the test subjects' own unlabeled IMU recordings, ``sspinn adapt``'s
   :func:`~sspinn.estimator.training.adaptation_config`: it saw their IMU signals, never their labels);
   on request (``--arms adapted_all``) the same adaptation on every trial's unlabeled IMU, the
   training subjects' too.
   The two trainings use the demo configuration with ``--steps`` steps; every arm stops on its
   step count, continues from its checkpoint when rerun, and arms can run as processes side by
   side (``--arms scratch`` and ``--arms finetune``, one thread each).
3. **Metrics** over each aligned test trial after a 1 s warm-up, leaving out any turn the import
   found and any span where its GRF labels are off (:func:`evaluated`; Sub05 CSStiffKnee turns
   round on the belt first, Sub06 CSStiffKnee's GRF jumps by 0.17 s after 51 s): vertical and horizontal GRF RMSE
   (%BW, both feet), heel-strike and toe-off timing error (ms; :mod:`sspinn.data.gait_events`, 5 %BW
   threshold on estimated and measured force alike), and the speed error against the belt speed.
   Beside them the baselines, on the same samples: the training subjects' constant mean GRF and
   mean speed (:class:`sspinn.estimator.trivial_predictors.TrivialPredictor`), the Froude speed
   sqrt(Fr · g · L) (m/s; Fr the training subjects' mean Froude number, L the test subject's leg
   length from the height), and their mean GRF profile placed at
   the test trial's measured heel strikes (:class:`sspinn.estimator.trivial_predictors.GRFProfilePredictor`, oracle
   timing, per condition), and the same profile placed at heel strikes found in the foot IMUs'
   angular rate by the standard gyroscope rule (:func:`sspinn.data.gait_events.foot_imu_heel_strikes`;
   no oracle: the baseline an estimate's GRF must beat). Targets: GRF RMSE ≤ 15 %BW, heel-strike timing ≤ 30 ms,
   speed error ≤ 0.10 m/s. And the speed while standing (both feet down for at least 0.5 s in the
   measured GRF: the belt is still) on every trial an arm did not train on: target ≤ 0.05 m/s.
4. **Report**: ``<out>/report.md`` (tables per trial and per condition, verdicts), ``metrics.json``,
   and plots of estimated vs measured GRF over a few strides (``<out>/plots``).

Usage: ``python -m benchmarks.accuracy.bench_cmu_continuous [--out results/cmu] [--pretrained
results/demo/run/model.pt] [--steps 6000] [--arms scratch finetune zero_shot adapted] [--threads 1]``.
The same protocol runs on other trials of this kind (continuous IMU + treadmill GRF, one trial per
subject and condition): ``--source DIR --train-subjects A B --test-subjects C --conditions X Y
--imu-pattern '{subject}/{condition}/*_Accel.trc' --grf-pattern '{subject}/{condition}/*_GRF.mot'
[--subjects-csv table.csv] [--sensor-map map.yaml]`` (files raw or ``.gz``; the defaults are the
CMU trials above). ``--adapt-set weights.temporal=10 …`` adapts with other settings (as ``sspinn
adapt --set``; a new ``--out``); ``--grf-lowpass 10 6`` adds rows for every arm's GRF low-passed
offline at those cut-offs; ``--load-transfer`` rows for every arm with the vertical GRF of double
support moved between the feet at a constant rate (:mod:`sspinn.estimator.load_transfer`).
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import json
import sys
import time
from pathlib import Path

import numpy as np
import yaml

from benchmarks.accuracy.inverse_dynamics import highest_cutoff
from benchmarks.accuracy.inverse_dynamics import lowpass as grf_lowpass
from sspinn.data.dataset import SAMPLE_RATE_HZ, Dataset, Recording
from sspinn.data.gait_events import foot_imu_heel_strikes, grf_event_timing, standing_mask, true_runs
from sspinn.estimator.evaluation import finite_or_null
from sspinn.estimator.inference import GaitEstimate, estimate_recording
from sspinn.estimator.load_transfer import linear_load_transfer
from sspinn.estimator.model_store import load_model
from sspinn.estimator.sspinnpose import SSPINNpose
from sspinn.estimator.training import TrainConfig, adaptation_config
from sspinn.estimator.trivial_predictors import GRFProfilePredictor, TrivialPredictor
from sspinn.imu.pipeline import IMPORTER_VERSION, import_imu
from sspinn.imu.turns import turning_mask
from sspinn.model.body import BodyParameters
from sspinn.model.conventions import GRAVITY
from sspinn.run_folder import atomic_write_text

REPO = Path(__file__).resolve().parents[2]
TRAIN_SUBJECTS = ("Sub01", "Sub02", "Sub03", "Sub04")
TEST_SUBJECTS = ("Sub05", "Sub06")
#: Condition → what it is, for the report (another condition is shown by its name).
CONDITIONS = {"CSBaseline": "normal walking", "CSStiffKnee": "stiff-knee walking"}
#: Where a trial's files are, below ``--source``; ``{subject}`` and ``{condition}`` are filled
#: in, glob wildcards allowed; a file may also be gzip-compressed (the pattern + ``.gz``).
IMU_PATTERN = "{subject}/{condition}/OpenSim_{subject}_{condition}_Accel.trc"
GRF_PATTERN = "{subject}/{condition}/OpenSim_{subject}_{condition}_GRF.mot"
ARMS = ("scratch", "zero_shot", "finetune", "adapted", "adapted_all")
#: The arms run when ``--arms`` is not given.
DEFAULT_ARMS = ("scratch", "zero_shot", "finetune", "adapted")
WARMUP = 100  # samples (1 s) of LSTM warm-up left out of every metric
TARGETS = {"grf_rmse": 15.0, "hs_ms": 30.0, "speed": 0.10, "standing_speed": 0.05}
#: Row names of the baselines in the results and the report.
CONSTANT, FROUDE, PROFILE = "constant mean GRF / mean speed", "Froude speed", "mean GRF profile (measured timing)"
PROFILE_IMU = "mean GRF profile (foot-IMU timing)"
EVENT_WINDOW_S = 0.3  # an estimated event further than this from the measured one counts as missed


# ------------------------------------------------------------------------------------- 1. import
@dataclasses.dataclass(frozen=True)
class Protocol:
    """Which trials the benchmark runs on (the command line's ``--source``, ``--train-subjects``,
    ``--test-subjects``, ``--conditions``, ``--imu-pattern``, ``--grf-pattern``,
    ``--subjects-csv``, ``--sensor-map``; defaults: the CMU treadmill data as in the module
    docstring). ``subjects_csv`` has one row per subject with ``subject, height_m, mass_kg,
    treadmill_speed_mps``."""

    source: Path
    train_subjects: tuple[str, ...] = TRAIN_SUBJECTS
    test_subjects: tuple[str, ...] = TEST_SUBJECTS
    conditions: tuple[str, ...] = tuple(CONDITIONS)
    imu_pattern: str = IMU_PATTERN
    grf_pattern: str = GRF_PATTERN
    subjects_csv: Path | None = None
    sensor_map: Path = REPO / "configs/sensor_maps/cmu_treadmill.yaml"

    def label(self, condition: str) -> str:
        return CONDITIONS.get(condition, condition)


@dataclasses.dataclass(frozen=True)
class Trial:
    """One trial's files and subject: IMU file (any file of the export), GRF file, height m, mass kg, belt speed m/s."""

    subject: str
    condition: str
    imu: Path
    grf: Path
    height_m: float
    mass_kg: float
    speed_mps: float

    @property
    def name(self) -> str:
        return f"{self.subject}_{self.condition}"


def _find(source: Path, pattern: str, subject: str, condition: str, what: str) -> Path:
    """The one file of ``pattern`` (filled in; raw or ``.gz``) below ``source``."""
    filled = pattern.format(subject=subject, condition=condition)
    found = sorted({*source.glob(filled), *source.glob(filled + ".gz")})
    if len(found) != 1:
        raise FileNotFoundError(f"{source}: {'no' if not found else len(found)} {what} file(s) match {filled}[.gz]"
                                + (f" ({', '.join(p.name for p in found[:4])})" if found else "")
                                + ": check --source and the file pattern")
    return found[0]


def discover_trials(protocol: Protocol, subjects: tuple[str, ...] | None = None) -> list[Trial]:
    """The trials of ``subjects`` (default: the protocol's training then test subjects) in every
    condition, with their files and the subject table's height, mass and belt speed."""
    table = protocol.subjects_csv or protocol.source / "subjects.csv"
    if not table.exists():
        raise FileNotFoundError(f"{table}: no subject table (subject, height_m, mass_kg, treadmill_speed_mps); give --subjects-csv")
    with open(table, newline="") as fh:
        rows = {row["subject"]: row for row in csv.DictReader(fh)}
    trials = []
    for subject in subjects or (*protocol.train_subjects, *protocol.test_subjects):
        if subject not in rows:
            raise KeyError(f"{table}: no row for subject {subject!r} (has {sorted(rows)})")
        row = rows[subject]
        for condition in protocol.conditions:
            trials.append(Trial(subject, condition, _find(protocol.source, protocol.imu_pattern, subject, condition, "IMU"),
                                _find(protocol.source, protocol.grf_pattern, subject, condition, "GRF"),
                                float(row["height_m"]), float(row["mass_kg"]), float(row["treadmill_speed_mps"])))
    return trials


def import_trials(protocol: Protocol, data: Path, train_subjects: tuple[str, ...], test_subjects: tuple[str, ...],
                  end_s: float | None = None) -> None:
    """Import every trial of the subjects into the dataset folder ``data`` (cached; ``end_s``:
    only the first seconds, for ``--quick``). A trial cached in the other split (another
    ``--train-subjects`` / ``--test-subjects`` on the same ``--out``) is a ``SystemExit`` naming it."""
    index = data / "dataset.json"
    imported = json.loads(index.read_text()).get("info", {}).get("imported", {}) if index.exists() else {}
    for trial in discover_trials(protocol, (*train_subjects, *test_subjects)):
        split = "train" if trial.subject in train_subjects else "test"
        sidecar = data / f"{trial.name}.json"
        if sidecar.exists() and json.loads(sidecar.read_text()).get("provenance", {}).get("importer_version") == IMPORTER_VERSION:
            cached = imported.get(trial.name, {}).get("split", split)
            if cached != split:
                raise SystemExit(f"{data}: {trial.name} was imported into the {cached!r} split, this run puts it into {split!r}; "
                                 "give another --out for another choice of train and test subjects")
            continue
        start = time.perf_counter()
        result = import_imu(
            [trial.imu], protocol.sensor_map, trial.height_m, trial.mass_kg, data, subject=trial.subject, name=trial.name,
            grf=trial.grf, speed=trial.speed_mps, split=split, end_s=end_s, overwrite=True,  # a stale import is replaced
        )
        lag = result.alignment.lag_s if result.alignment else float("nan")
        print(f"imported {trial.name}: {result.recording.duration:.1f} s, GRF lag {lag:+.3f} s "
              f"({time.perf_counter() - start:.1f} s)", flush=True)


# ------------------------------------------------------------------------------------- 2. train
#: Training settings that do not change the model an arm trains (its budget, threads, device, logging).
RUNTIME_SETTINGS = ("steps", "threads", "time_limit_s", "device", "log_every", "checkpoint_every")


def result_settings(train_config: dict) -> dict:
    """``train_config`` (a ``TrainConfig`` as a dict) less its :data:`RUNTIME_SETTINGS`."""
    return {k: v for k, v in train_config.items() if k not in RUNTIME_SETTINGS}


def train_arm(arm: str, train: list[Recording], out: Path, config_path: Path, steps: int, threads: int, pretrained: Path,
              adapt_settings: tuple[str, ...] = ()) -> Path:
    """Train one arm (``scratch`` or ``finetune`` to ``steps`` steps on ``train``, ``adapted``
    to :data:`~sspinn.estimator.training.ADAPT_STEPS` on the test recordings passed as ``train``,
    with ``adapt_settings`` — ``"key=value"`` as ``sspinn adapt --set`` takes them); returns its
    model file. An arm already in ``out`` with other settings is an error (one run, one folder)."""
    run = out / arm
    if arm in ("adapted", "adapted_all"):
        config = adaptation_config(load_model(pretrained).config, str(pretrained), list(adapt_settings), threads=threads,
                                   time_limit_s=4 * 3600.0)
        if steps < config.steps:  # the smoke run
            config = dataclasses.replace(config, steps=steps)
    else:
        config = TrainConfig.from_yaml(config_path, threads=threads, time_limit_s=4 * 3600.0)
        # a run shorter than the configuration's starts (the smoke run) trains one start
        config = dataclasses.replace(config, steps=steps, starts=config.starts if steps > config.start_steps else 1)
        config.finetune = arm == "finetune"
    kept = run / "config.yaml"
    if kept.exists():
        before, now = result_settings(yaml.safe_load(kept.read_text())["train"]), result_settings(json.loads(json.dumps(config.to_dict())))
        differ = sorted(k for k in before.keys() & now.keys() if before[k] != now[k])  # options of another code version aside
        if differ:
            sys.exit(f"{run}: this arm was trained with other settings ({', '.join(differ)}: see {kept}); give another --out for these")
    summary = run / "training_summary.json"
    if summary.exists() and json.loads(summary.read_text())["steps"] >= config.steps:
        return run / "model.pt"
    resume = (run / "checkpoint.pt").exists()
    if arm == "scratch":
        estimator = SSPINNpose(config).fit(train, out=run, resume=resume)
    elif arm in ("adapted", "adapted_all"):  # the configuration above, from the pretrained weights
        estimator = SSPINNpose.load(pretrained).adapt(train, out=run, resume=resume, settings=adapt_settings, threads=threads,
                                                      time_limit_s=config.time_limit_s, steps=config.steps)
    else:  # finetune: the configuration above (fine-tuning weights), from the pretrained weights
        estimator = SSPINNpose.load(pretrained)
        estimator.config = config
        estimator.finetune(train, out=run, resume=resume)
    print(f"{arm}: {estimator.steps_} steps ({estimator.stopped_by_}) → {run / 'model.pt'}", flush=True)
    return run / "model.pt"


# ------------------------------------------------------------------------------------ 3. metrics
def grf_rmse_pct(est: np.ndarray, ref: np.ndarray, columns: list[int], mass: float) -> float:
    """RMSE of GRF columns (N) pooled over both feet, %BW."""
    return float(100 * np.sqrt(np.mean((est[:, columns] - ref[:, columns]) ** 2)) / (mass * GRAVITY))


def evaluated(rec: Recording) -> slice:
    """The samples every metric uses: after the :data:`WARMUP`, outside the turns ``sspinn
    import`` found (:func:`sspinn.imu.turns.turning_mask`: a sagittal model does not describe a
    turn) and outside the spans where the GRF labels are off (a jump of the lag between the files,
    ``grf_misaligned_s``: :mod:`sspinn.imu.time_alignment`) — the longest run of such samples (the
    whole trial after the warm-up when it has neither)."""
    keep = ~(turning_mask(rec) | rec.provenance_mask("grf_misaligned_s"))
    keep[:WARMUP] = False
    start, stop = max(true_runs(keep), key=lambda r: r[1] - r[0])
    return slice(start, stop)


def trial_metrics(grf: np.ndarray, speed: float | None, rec: Recording) -> dict[str, float]:
    """Metrics of an estimated GRF (T, 4) (and mean speed, m/s) against ``rec``'s labels, on the
    :func:`evaluated` samples."""
    assert rec.labels is not None and rec.labels.grf is not None and rec.labels.speed is not None
    sl = evaluated(rec)
    ref, est = rec.labels.grf[sl], grf[sl]
    out = {"vertical": grf_rmse_pct(est, ref, [1, 3], rec.mass), "horizontal": grf_rmse_pct(est, ref, [0, 2], rec.mass),
           "all": grf_rmse_pct(est, ref, [0, 1, 2, 3], rec.mass)}
    for key, kind in (("hs", "heel_strikes"), ("to", "toe_offs")):
        t = grf_event_timing(est, ref, rec.mass * GRAVITY, SAMPLE_RATE_HZ, kind, EVENT_WINDOW_S)
        out |= {f"{key}_ms": t.mean_abs_ms, f"{key}_bias_ms": t.bias_ms, f"{key}_matched": t.matched / max(1, t.n_reference),
                f"{key}_extra": t.n_estimated - t.matched}
    if speed is not None:
        out["speed"] = speed
        out["speed_error"] = abs(speed - float(np.mean(rec.labels.speed[sl])))
    return out


def condition_of(rec: Recording, conditions: tuple[str, ...] = tuple(CONDITIONS)) -> str:
    """The trial's condition (one of ``conditions``), from its name ``<subject>_<condition>``."""
    return next(c for c in conditions if rec.name.endswith(f"_{c}"))


def transferred(arm: str) -> str:
    """Row name of an arm whose double-support load was shared offline (``--load-transfer``)."""
    return f"{arm}, linear load transfer"


def lowpassed(arm: str, cutoff_hz: float) -> str:
    """Row name of an arm whose GRF was low-passed offline (``--grf-lowpass``)."""
    return f"{arm}, GRF low-passed {cutoff_hz:g} Hz"


def evaluate(models: dict[str, Path], test: list[Recording], train: list[Recording], conditions: tuple[str, ...] = tuple(CONDITIONS),
             lowpass: tuple[float, ...] = (), load_transfer: bool = False,
             ) -> tuple[dict, dict[str, dict[str, GaitEstimate]], dict[str, np.ndarray]]:
    """Per trial: the metrics of every arm and of the baselines (and of every arm's GRF after a
    zero-phase low-pass at each ``lowpass`` cut-off, Hz: a second-order Butterworth run forwards
    and backwards with its −3 dB point at the cut-off, offline only; with ``load_transfer``, of
    every arm's GRF with the double-support load shared linearly:
    :func:`~sspinn.estimator.load_transfer.linear_load_transfer`); the estimates and the mean
    profile's GRF (for the plots)."""
    trivial = TrivialPredictor.fit(train, f"the training subjects' labels ({', '.join(sorted({r.subject for r in train}))})")
    profiles = {c: GRFProfilePredictor.fit([r for r in train if condition_of(r, conditions) == c], f"training subjects, {c}")
                for c in conditions}
    results: dict[str, dict] = {}
    estimates: dict[str, dict[str, GaitEstimate]] = {}
    profile_grf: dict[str, np.ndarray] = {}
    loaded = {arm: load_model(path) for arm, path in models.items()}
    for rec in test:
        base = trivial.predict(rec)
        profile_grf[rec.name] = profiles[condition_of(rec, conditions)].predict_grf(rec)
        imu_timing = [foot_imu_heel_strikes(rec.imu[:, rec.segments.index(f), 2], SAMPLE_RATE_HZ) for f in ("foot_r", "foot_l")]
        profile_imu = profiles[condition_of(rec, conditions)].predict_grf(rec, imu_timing)
        froude = trial_metrics(base.grf, trivial.speed_for(rec, "froude"), rec)
        row = {"belt_speed": float(np.mean(rec.labels.speed)) if rec.labels and rec.labels.speed is not None else None,
               CONSTANT: trial_metrics(base.grf, float(np.mean(base.u[:, 0])), rec),
               FROUDE: {k: v if k in ("speed", "speed_error") else float("nan") for k, v in froude.items()},  # a speed only
               PROFILE: trial_metrics(profile_grf[rec.name], None, rec),
               PROFILE_IMU: trial_metrics(profile_imu, None, rec)}
        estimates[rec.name] = {}
        body = BodyParameters.from_anthropometry(rec.height, rec.mass)
        for arm, stored in loaded.items():
            est = estimate_recording(stored.network, rec, stored.segments)
            estimates[rec.name][arm] = est
            speed = float(np.mean(est.u[evaluated(rec), 0]))
            row[arm] = trial_metrics(est.grf, speed, rec)
            for cutoff in lowpass:
                row[lowpassed(arm, cutoff)] = trial_metrics(grf_lowpass(est.grf, SAMPLE_RATE_HZ, cutoff), speed, rec)
            if load_transfer:
                shared = linear_load_transfer(est, body, SAMPLE_RATE_HZ)
                row[transferred(arm)] = trial_metrics(shared.grf, speed, rec)
        results[rec.name] = row
    return results, estimates, profile_grf


def standing_speeds(estimates: dict[str, dict[str, GaitEstimate]], test: list[Recording], train: list[Recording],
                    zero_shot: Path | None) -> dict[str, dict[str, float]]:
    """Per trial with standing (the measured GRF's :func:`~sspinn.data.gait_events.standing_mask`):
    its seconds of standing and every arm's mean |forward velocity| there (m/s; the truth is 0),
    on the trials the arm did not train on: the test trials for every arm (``estimates``, as
    :func:`evaluate` made them), the training trials too for the ``zero_shot`` model."""
    out: dict[str, dict[str, float]] = {}
    trivial = TrivialPredictor.fit(train, "the training subjects' labels")
    stored = load_model(zero_shot) if zero_shot is not None else None
    for rec in [*test, *train]:
        assert rec.labels is not None and rec.labels.grf is not None
        standing = standing_mask(rec.labels.grf, rec.mass * GRAVITY, SAMPLE_RATE_HZ)
        if not standing.any():
            continue
        arms = estimates.get(rec.name)
        if arms is None:  # a training trial: only the zero-shot model has not seen it
            arms = {} if stored is None else {"zero_shot": estimate_recording(stored.network, rec, stored.segments)}
        row = {"standing_s": standing.sum() / SAMPLE_RATE_HZ, CONSTANT: float(np.abs(trivial.predict(rec).u[standing, 0]).mean())}
        row |= {arm: float(np.abs(est.u[standing, 0]).mean()) for arm, est in arms.items()}
        out[rec.name] = row
    return out


# ------------------------------------------------------------------------------------- 4. report
def plot_trial(path: Path, rec: Recording, estimates: dict[str, GaitEstimate], profile: np.ndarray) -> None:
    """Right foot's vertical and horizontal GRF over ~4 strides from 20 s: every arm vs measured."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from sspinn.model.drawing import save_figure

    assert rec.labels is not None and rec.labels.grf is not None
    start = min(2000, rec.n_samples // 3)
    sl = slice(start, min(rec.n_samples, start + 550))
    t = rec.time[sl]
    bw = rec.mass * GRAVITY
    fig, axes = plt.subplots(2, 1, figsize=(11, 6), sharex=True)
    for ax, col, label in ((axes[0], 1, "vertical"), (axes[1], 0, "horizontal (anterior +)")):
        ax.plot(t, rec.labels.grf[sl, col] / bw, color="k", lw=2, label="measured (treadmill)")
        ax.plot(t, profile[sl, col] / bw, color="0.6", ls="--", label="mean profile, measured timing")
        for arm, est in estimates.items():
            ax.plot(t, est.grf[sl, col] / bw, label=arm)
        ax.set_ylabel(f"right GRF {label} (BW)")
    axes[0].legend(fontsize=8, ncol=3)
    axes[1].set_xlabel("time (s)")
    fig.suptitle(f"{rec.name}: estimated vs measured GRF (held-out subject)")
    save_figure(fig, path, dpi=90)


def _finite_mean(values: list[float]) -> float:
    """Mean of the finite values, NaN if none (a metric a predictor does not have, e.g. timing)."""
    v = np.asarray(values, dtype=float)
    return float(v[np.isfinite(v)].mean()) if np.isfinite(v).any() else float("nan")


def _fmt(value: float | None, spec: str) -> str:
    return "n/a" if value is None or not np.isfinite(value) else format(value, spec)


def report(results: dict, training: dict[str, dict], out: Path, protocol: Protocol | None = None,
           standing: dict[str, dict[str, float]] | None = None) -> str:
    """Markdown tables: per trial, and per condition (mean over the test subjects) with verdicts;
    the speed while standing (:func:`standing_speeds`) when given."""
    protocol = protocol or Protocol(REPO.parent / "shared/data/cmu_treadmill_imu_grf")
    first = next(iter(results.values()), {})
    arm_rows = [k for k in first if k not in (CONSTANT, FROUDE, PROFILE, PROFILE_IMU, "belt_speed")]
    rows = [CONSTANT, FROUDE, PROFILE, PROFILE_IMU, *arm_rows]
    lines = [f"# SSPINNpose on real continuous IMU data ({protocol.source.name}; test subjects {', '.join(protocol.test_subjects)})", "",
             f"Trained (self-supervised, no labels) on {', '.join(protocol.train_subjects)}, conditions "
             f"{', '.join(protocol.conditions)}; metrics over each whole aligned "
             f"test trial after {WARMUP / SAMPLE_RATE_HZ:.0f} s of warm-up, turns and lag jumps found by the import left out. GRF RMSE in %BW (both feet), event timing "
             "errors in ms (mean |Δt| over matched events; matched = share of measured events with an estimated one within "
             f"{1e3 * EVENT_WINDOW_S:.0f} ms), speed in m/s.", ""]
    for arm, info in training.items():
        lines.append(f"- `{arm}`: {info}")
    if any(", GRF low-passed" in a for a in arm_rows):
        lines.append("- `<arm>, GRF low-passed F Hz`: the same estimate with its GRF low-passed at F Hz, forwards and backwards "
                     "(second-order Butterworth, the double pass −3 dB at F): offline only")
    if any(a.endswith(transferred("")) for a in arm_rows):
        lines.append(f"- `{transferred('<arm>')}`: the same estimate with the vertical GRF of each double support moved from the "
                     "trailing to the leading foot at a constant rate, the total kept (`sspinn infer --load-transfer`): offline only")
    lines += ["", "## Per trial", "", "| trial | predictor | vGRF | hGRF | GRF all | HS ms | HS matched | TO ms | speed | belt | speed error |",
              "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for name, row in results.items():
        for predictor in rows:
            if predictor not in row:
                continue
            m = row[predictor]
            lines.append(f"| {name} | {predictor} | {_fmt(m['vertical'], '.1f')} | {_fmt(m['horizontal'], '.1f')} | "
                         f"{_fmt(m['all'], '.1f')} | {_fmt(m['hs_ms'], '.0f')} | {_fmt(m['hs_matched'], '.0%')} | "
                         f"{_fmt(m['to_ms'], '.0f')} | {_fmt(m.get('speed'), '.3f')} | {_fmt(row['belt_speed'], '.3f')} | "
                         f"{_fmt(m.get('speed_error'), '.3f')} |")
    lines += ["", "## Per condition (mean over the two test subjects) against the targets", ""]
    for condition in protocol.conditions:
        label = protocol.label(condition)
        trials = [row for name, row in results.items() if name.endswith(f"_{condition}")]
        if not trials:
            continue
        lines += [f"### {label} ({condition})", "", "| predictor | GRF all | vGRF | hGRF | HS ms | TO ms | speed error |", "|---|---:|---:|---:|---:|---:|---:|"]
        means = {p: {k: _finite_mean([t[p].get(k, np.nan) for t in trials]) for k in ("all", "vertical", "horizontal", "hs_ms", "to_ms", "speed_error")}
                 for p in rows if p in trials[0]}
        for predictor, m in means.items():
            lines.append(f"| {predictor} | {_fmt(m['all'], '.1f')} | {_fmt(m['vertical'], '.1f')} | {_fmt(m['horizontal'], '.1f')} | "
                         f"{_fmt(m['hs_ms'], '.0f')} | {_fmt(m['to_ms'], '.0f')} | {_fmt(m['speed_error'], '.3f')} |")
        lines.append("")
        const, prof, froude, prof_imu = means[CONSTANT], means[PROFILE], means.get(FROUDE), means.get(PROFILE_IMU)
        for arm in (a for a in arm_rows if a in means):
            m = means[arm]
            verdicts = [
                f"GRF {m['all']:.1f} %BW: {'meets' if m['all'] <= TARGETS['grf_rmse'] else 'MISSES'} ≤ {TARGETS['grf_rmse']:g}, "
                f"{'beats' if m['all'] < const['all'] else 'WORSE than'} the constant mean ({const['all']:.1f}), "
                f"{'beats' if m['all'] < prof['all'] else 'worse than'} the profile at measured timing ({prof['all']:.1f})"
                + (f", {'beats' if m['all'] < prof_imu['all'] else 'WORSE than'} the profile at foot-IMU timing "
                   f"({prof_imu['all']:.1f})" if prof_imu is not None else ""),
                f"HS {_fmt(m['hs_ms'], '.0f')} ms: {'meets' if m['hs_ms'] <= TARGETS['hs_ms'] else 'MISSES'} ≤ {TARGETS['hs_ms']:g}",
                f"speed error {m['speed_error']:.3f} m/s: {'meets' if m['speed_error'] <= TARGETS['speed'] else 'MISSES'} ≤ "
                f"{TARGETS['speed']:.2f}, {'beats' if m['speed_error'] < const['speed_error'] else 'WORSE than'} the training "
                f"subjects' mean speed ({const['speed_error']:.3f})"
                + (f", {'beats' if m['speed_error'] < froude['speed_error'] else 'WORSE than'} their Froude speed "
                   f"({froude['speed_error']:.3f})" if froude is not None else ""),
            ]
            lines.append(f"- **{arm}**: " + "; ".join(verdicts))
        names = [name for name in results if name.endswith(f"_{condition}")]
        for arm in (a for a in ARMS if a in means and len(names) == 2):
            (n1, r1), (n2, r2) = ((n, results[n]) for n in names)
            lines.append(f"- speed tracking, {arm}: estimate {n1.split('_')[0]} − {n2.split('_')[0]} = "
                         f"{r1[arm]['speed'] - r2[arm]['speed']:+.3f} m/s, belts {r1['belt_speed'] - r2['belt_speed']:+.3f} m/s "
                         f"(the training mean predicts 0, the Froude speed {r1[FROUDE]['speed'] - r2[FROUDE]['speed']:+.3f})")
        lines.append("")
    if standing:
        arms = [CONSTANT] + [a for a in ARMS if any(a in row for row in standing.values())]
        lines += ["## Speed while standing (both feet down ≥ 0.5 s in the measured GRF; the truth is 0 m/s)", "",
                  f"Target ≤ {TARGETS['standing_speed']:.2f} m/s. Each arm only on trials it did not train on.", "",
                  "| trial | standing s | " + " | ".join(arms) + " |", "|---|---:|" + "---:|" * len(arms)]
        for name, row in standing.items():
            lines.append(f"| {name} | {row['standing_s']:.1f} | " + " | ".join(_fmt(row.get(a), '.3f') for a in arms) + " |")
        lines.append("")
        for arm in arms:
            values = [(row[arm], row["standing_s"]) for row in standing.values() if arm in row]
            mean = sum(v * w for v, w in values) / sum(w for _, w in values)
            lines.append(f"- **{arm}**: {mean:.3f} m/s over {sum(w for _, w in values):.1f} s of standing in {len(values)} trials: "
                         f"{'meets' if mean <= TARGETS['standing_speed'] else 'MISSES'} ≤ {TARGETS['standing_speed']:.2f}")
        lines.append("")
    lines += ["## GRF over a few strides", ""] + [f"![{n}](plots/{n}.png)" for n in results]
    text = "\n".join(lines) + "\n"
    atomic_write_text(out / "report.md", text)
    return text


def parse_args(argv: list[str] | None = None) -> tuple[argparse.Namespace, Protocol]:
    """The command line (module docstring) and the trials' protocol it describes."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--source", type=Path, default=REPO.parent / "shared/data/cmu_treadmill_imu_grf",
                        help="folder of the trials (the file patterns are below it)")
    parser.add_argument("--train-subjects", nargs="+", default=list(TRAIN_SUBJECTS), help="subjects trained on (train split)")
    parser.add_argument("--test-subjects", nargs="+", default=list(TEST_SUBJECTS), help="held-out subjects evaluated (test split)")
    parser.add_argument("--conditions", nargs="+", default=list(CONDITIONS), help="conditions: every subject has one trial of each")
    parser.add_argument("--imu-pattern", default=IMU_PATTERN,
                        help="IMU file of a trial below --source, with {subject} and {condition} (glob wildcards allowed; "
                             "the file may be gzipped, pattern + .gz)")
    parser.add_argument("--grf-pattern", default=GRF_PATTERN, help="GRF .mot file of a trial, as --imu-pattern")
    parser.add_argument("--subjects-csv", type=Path, default=None,
                        help="subject table (subject, height_m, mass_kg, treadmill_speed_mps); default <source>/subjects.csv")
    parser.add_argument("--sensor-map", type=Path, default=REPO / "configs/sensor_maps/cmu_treadmill.yaml")
    parser.add_argument("--out", type=Path, default=REPO / "results/cmu")
    parser.add_argument("--pretrained", type=Path, default=REPO / "results/demo/run/model.pt",
                        help="model trained on synthetic data only (what `make demo` writes)")
    parser.add_argument("--config", type=Path, default=REPO / "configs/sspinn/demo.yaml", help="training configuration")
    parser.add_argument("--steps", type=int, default=6000, help="training steps of the scratch and finetune arms")
    parser.add_argument("--arms", nargs="+", choices=ARMS, default=list(DEFAULT_ARMS))
    parser.add_argument("--threads", type=int, default=1, help="torch threads per training (two side by side: 1 each)")
    parser.add_argument("--adapt-set", nargs="+", default=[], metavar="KEY=VALUE",
                        help="settings of the adapted arm's adaptation, as `sspinn adapt --set` (e.g. weights.temporal=10)")
    parser.add_argument("--grf-lowpass", nargs="+", type=float, default=[], metavar="HZ",
                        help="also score every arm's GRF after a zero-phase low-pass at each cut-off (offline smoothing)")
    parser.add_argument("--load-transfer", action="store_true",
                        help="also score every arm with the double-support load moved between the feet at a constant rate (offline)")
    parser.add_argument("--no-report", action="store_true", help="only import and train (e.g. one arm per process)")
    parser.add_argument("--quick", action="store_true",
                        help="smoke run: the first training subject → the first test subject, first 20 s, 3 steps")
    args = parser.parse_args(argv)
    highest = highest_cutoff(SAMPLE_RATE_HZ)
    bad = [f for f in args.grf_lowpass if not 0 < f < highest]
    if bad:
        parser.error(f"--grf-lowpass {bad[0]:g}: a cut-off must lie between 0 and {highest:g} Hz (the double pass's −3 dB point)")
    overlap = set(args.train_subjects) & set(args.test_subjects)
    if overlap:
        parser.error(f"subjects {sorted(overlap)} are in both --train-subjects and --test-subjects")
    for option, pattern in (("--imu-pattern", args.imu_pattern), ("--grf-pattern", args.grf_pattern)):
        try:
            pattern.format(subject="s", condition="c")
        except (KeyError, IndexError, ValueError) as exc:
            parser.error(f"{option} {pattern!r}: only {{subject}} and {{condition}} can be filled in ({exc})")
    if not args.source.exists():
        parser.error(f"{args.source}: the trials' folder is not there (the CMU treadmill data: see ../shared/data/README.md)")
    needs_pretrained = {"zero_shot", "finetune", "adapted", "adapted_all"} & set(args.arms)
    if needs_pretrained and not args.pretrained.exists():
        parser.error(f"{args.pretrained}: no synthetic-only model for {sorted(needs_pretrained)}; run `make demo` first or pass --pretrained")
    protocol = Protocol(args.source, tuple(args.train_subjects), tuple(args.test_subjects), tuple(args.conditions),
                        args.imu_pattern, args.grf_pattern, args.subjects_csv, args.sensor_map)
    try:  # every file there before anything runs
        discover_trials(protocol, (*protocol.train_subjects[:1], *protocol.test_subjects[:1]) if args.quick else None)
    except (FileNotFoundError, KeyError) as exc:
        parser.error(str(exc).strip('"'))
    return args, protocol


def main(argv: list[str] | None = None) -> dict:
    """Run the benchmark (module docstring); returns the per-trial metrics (empty with ``--no-report``)."""
    args, protocol = parse_args(argv)
    subjects = ((protocol.train_subjects[:1], protocol.test_subjects[:1]) if args.quick
                else (protocol.train_subjects, protocol.test_subjects))
    steps = 3 if args.quick else args.steps
    data = args.out / "data"
    import_trials(protocol, data, *subjects, end_s=20.0 if args.quick else None)
    dataset = Dataset.open(data)
    train, test = dataset.load("train"), dataset.load("test")
    models: dict[str, Path] = {}
    training: dict[str, dict] = {}
    for arm in args.arms:
        if arm == "zero_shot":
            models[arm] = args.pretrained
            training[arm] = {"model": str(args.pretrained), "real-data steps": 0}
            continue
        recordings = {"adapted": test, "adapted_all": train + test}.get(arm, train)
        models[arm] = train_arm(arm, recordings, args.out, args.config, steps, args.threads, args.pretrained,
                                tuple(args.adapt_set))
        summary = json.loads((args.out / arm / "training_summary.json").read_text())
        settings = f", with {' '.join(args.adapt_set)}" if args.adapt_set else ""
        training[arm] = {"steps": summary["steps"], "stopped_by": summary["stopped_by"],
                         "wall_s_last_run": summary["wall_s_this_run"], "threads": args.threads,
                         "from": str(args.pretrained) if arm != "scratch" else "random initialisation",
                         "config": {"finetune": args.config.name + " (fine-tuning weights)",
                                    "adapted": "the pretrained model's own (sspinn adapt), on the TEST subjects' unlabeled IMU" + settings,
                                    "adapted_all": "the pretrained model's own (sspinn adapt), on EVERY trial's unlabeled IMU "
                                                   "(training and test subjects)" + settings}.get(arm, args.config.name)}
    if args.no_report:
        return {}
    results, estimates, profile_grf = evaluate(models, test, train, protocol.conditions, tuple(args.grf_lowpass), args.load_transfer)
    (args.out / "plots").mkdir(parents=True, exist_ok=True)
    for rec in test:
        plot_trial(args.out / "plots" / f"{rec.name}.png", rec, estimates[rec.name], profile_grf[rec.name])
    standing = standing_speeds(estimates, test, train, models.get("zero_shot"))
    metrics = {"training": training, "trials": results, "standing": standing}
    atomic_write_text(args.out / "metrics.json", json.dumps(finite_or_null(metrics), indent=2, allow_nan=False))
    print(report(results, training, args.out, protocol, standing))
    return results


if __name__ == "__main__":
    main(sys.argv[1:])
