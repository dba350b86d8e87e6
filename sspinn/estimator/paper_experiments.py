"""The SSPINNpose paper's remaining claims as experiments on data whose truth is known.

``sspinn experiment <name>`` trains one model per *arm* of an experiment on the training split of
a labelled dataset (by default the synthetic one of ``make demo``) and scores it on the held-out
test split, walking and running apart, beside the trivial predictors
(:mod:`sspinn.estimator.trivial_predictors`) and the figures the paper reports (Dorschky et al.
2025, SSPINNpose, Table 2 and the ablation table). Every arm is a set of ``--set``-style
overrides of one training configuration and has the same step budget (``--steps``).

Experiments (:data:`EXPERIMENTS`):

* ``sensor-sets`` — the sparse IMU sets of the paper's Table 2 (``imus``). L_IMU averages over
  the IMUs and channels present (:mod:`sspinn.estimator.losses`), so its weight relative to the
  other terms stays as with all seven sensors, as the paper rescales it;
* ``finetune`` — the last quarter of the budget with the fine-tuning weights
  (:meth:`~sspinn.estimator.losses.LossWeights.finetune`, ``finetune_last``) against none;
* ``placement`` — the IMU placement optimised with the network (``learn_placement``) against
  the nominal one; besides the metrics, each sensor's placement error against the truth stored
  by the synthetic data (``provenance.ground_truth.imu_placement``) before and after;
* ``ablations`` — no input noise and each auxiliary loss term switched off;
* ``loss-weights`` — each loss weight of the configuration halved and doubled.

The run folder (``--out``) holds ``experiment.json`` (what was asked: budget, data,
configuration), one sub-folder per arm (a training run folder of
:class:`~sspinn.estimator.training.Trainer` plus ``arm.json``, its scores), ``results.json``,
``report.md`` and, for ``sensor-sets``, ``sensor_sets.png``. A rerun skips finished arms (those
with ``arm.json``) and resumes interrupted ones from their checkpoints; a finished result is
replaced only with ``--overwrite``.
"""

from __future__ import annotations

import argparse
import json
import shutil
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from sspinn.data.dataset import SAMPLE_RATE_HZ, Dataset, Recording
from sspinn.errors import UserError
from sspinn.estimator.evaluation import BASELINE_OF, check_evaluable, compare_with_baseline
from sspinn.estimator.training import IMU_CONFIGURATIONS, TrainConfig
from sspinn.model.conventions import SEGMENTS
from sspinn.run_folder import RunLock, atomic_write_text, json_text
from sspinn.yaml_config import ConfigError, shipped_path

#: The dataset ``make demo`` generates and trains on (the Makefile's ``SYNTH``).
DEFAULT_DATA = shipped_path("data/synth_default")
#: The training configuration every arm starts from.
DEFAULT_CONFIG = shipped_path("configs/sspinn/demo.yaml")
#: Optimiser steps per arm unless ``--steps`` says otherwise.
DEFAULT_STEPS = 2000
#: Samples of LSTM warm-up left out of the metrics (as ``sspinn evaluate``).
SKIP = 50
#: The metrics of the tables: key of :class:`~sspinn.estimator.evaluation.Metrics` → column head.
METRICS: dict[str, str] = {"jae_deg": "JAE (°)", "jte_pct_bwbh": "JTE (%BW·BH)", "grfe_pct_bw": "GRFE (%BW)",
                           "speed_error_mps": "speed error (m/s)"}
#: The paper whose claims the experiments test.
PAPER = "Dorschky et al. 2025, SSPINNpose"


class ExperimentError(UserError):
    """An experiment cannot run as asked (unknown experiment or arm, a run folder that holds
    another experiment's or another budget's results, a dataset without the splits)."""


@dataclass(frozen=True)
class Arm:
    """One arm of an experiment.

    Attributes:
        name: its folder name and ``--arms`` key.
        what: what it changes, in words (for the report).
        settings: ``"dotted.key=value"`` overrides of the training configuration (as ``--set``).
        paper: the paper's (JAE °, JTE %BW·BH, GRFE %BW, speed error m/s) for it, None if it
            reports none.
        built: False for an arm the paper has and this project has no switch for (listed in the
            report as not built, never trained).
        steps: the arm's own step budget (None: ``--steps``), for an arm that stands for several
            others together.
        subsets: keys of :data:`~sspinn.estimator.training.IMU_CONFIGURATIONS` the trained model
            is also scored on, with the test recordings' other IMUs removed (a model trained
            with ``sensor_dropout``).
    """

    name: str
    what: str
    settings: tuple[str, ...] = ()
    paper: tuple[float, float, float, float] | None = None
    built: bool = True
    steps: int | None = None
    subsets: tuple[str, ...] = ()


#: The paper's all-sensor result (Table 2), the reference of the sensor sets and the ablations.
PAPER_ALL = (9.1, 3.8, 16.6, 0.15)


#: The sensor sets of the paper's Table 2 (the rest of IMU_CONFIGURATIONS are single segments).
PAPER_SETS = ("all", "feet_thighs", "feet_shanks", "shanks_pelvis", "shanks_thighs")
#: ``sensor_dropout`` of the ``any_subset`` arm: each IMU of a window missing with this probability.
ANY_SUBSET_DROPOUT = 0.5


def _sensor_sets(base: TrainConfig, steps: int) -> list[Arm]:
    paper = {"all": PAPER_ALL, "feet_thighs": (9.8, 4.2, 18.3, 0.19), "feet_shanks": (10.5, 4.0, 17.1, 0.27),
             "shanks_pelvis": (13.6, 8.2, 30.7, 0.19), "shanks_thighs": (17.3, 6.2, 23.6, 0.33)}
    arms = [Arm(name, f"IMUs {', '.join(IMU_CONFIGURATIONS[name])}", (f"imus={name}",), paper.get(name)) for name in IMU_CONFIGURATIONS]
    # one model for every subset, with the paper's sets' per-set models' budget together (their
    # starts included: the same number of optimiser steps in all)
    extra = (base.starts - 1) * base.start_steps if base.starts > 1 else 0
    total = len(PAPER_SETS) * (steps + extra) - extra
    arms.append(Arm("any_subset", f"one model for every set: all IMUs, each missing from a training window with probability "
                    f"{ANY_SUBSET_DROPOUT:g} (sensor_dropout), {total} steps (the {len(PAPER_SETS)} paper's sets' "
                    "budgets together); scored on every set", ("imus=all", f"sensor_dropout={ANY_SUBSET_DROPOUT:g}"),
                    steps=total, subsets=tuple(IMU_CONFIGURATIONS)))
    return arms


def _finetune(base: TrainConfig, steps: int) -> list[Arm]:
    last = max(1, steps // 4)
    return [
        Arm("base", "the configuration's loss weights throughout", ("finetune_last=0", "finetune=false")),
        Arm("finetuned", f"the last {last} of the {steps} steps with the fine-tuning weights (Kane, temporal and contact × 10)",
            (f"finetune_last={last}", "finetune=false")),
    ]


def _placement(base: TrainConfig, steps: int) -> list[Arm]:
    return [
        Arm("nominal", "the nominal IMU placement, fixed", ("learn_placement=false",)),
        Arm("learned", "the IMU placement of each training recording optimised with the network", ("learn_placement=true",)),
    ]


def _ablations(base: TrainConfig, steps: int) -> list[Arm]:
    paper = {"no_input_noise": (10.8, 6.1, 36.1, 0.28), "no_bounds": (13.1, 7.0, 27.6, 0.95), "no_torque": (11.7, 6.3, 25.4, 0.55),
             "no_slide": (9.5, 3.9, 18.8, 0.86), "no_foot_speed": (9.4, 3.9, 14.9, 0.28)}
    arms = [Arm("full", "the configuration as it is", (), PAPER_ALL),
            Arm("no_input_noise", "no input noise (η = 0)", ("input_noise=0",), paper["no_input_noise"])]
    # with direct GRF outputs L_slide is zero by construction; L_S carries the no-sliding condition there
    slide, slide_symbol = ("stance", "L_S (no sliding, floating or sinking of a loaded foot; L_slide is 0 with direct GRFs)") \
        if base.network.grf == "direct" else ("slide", "L_slide")
    for name, term, symbol in (("no_bounds", "bounds", "L_B"), ("no_torque", "torque", "L_τ"), ("no_slide", slide, slide_symbol),
                               ("no_foot_speed", "foot_speed", "L_FS")):
        settings = [f"weights.{term}=0"]
        if term in base.weights_after_starts:
            settings.append(f"weights_after_starts.{term}=0")
        arms.append(Arm(name, f"without {symbol} (weights.{term} = 0)", tuple(settings), paper[name]))
    if base.network.grf == "direct":
        arms.append(Arm("two_contact_points", "two fixed contact points per foot (toe and heel), each with its own force, "
                        "instead of one point moving along the foot (network.grf = two_point)", ("network.grf=two_point",),
                        paper=(10.7, 4.1, 22.8, 0.38)))
    else:
        arms.append(Arm("two_contact_points", "two fixed contact points per foot (toe and heel); built for direct-GRF networks "
                        "(network.grf = two_point), not for the contact model", paper=(10.7, 4.1, 22.8, 0.38), built=False))
    return arms


def _loss_weights(base: TrainConfig, steps: int) -> list[Arm]:
    arms = [Arm("base", "the configuration's loss weights")]
    inactive = {"contact", "slide"} if base.network.grf == "direct" else set()  # zero by construction with direct GRFs
    for term, value in base.weights.as_dict().items():
        if value == 0 or term in inactive:
            continue  # halving or doubling a term that is off changes nothing
        for tag, factor in (("half", 0.5), ("double", 2.0)):
            settings = [f"weights.{term}={value * factor:g}"]
            after = base.weights_after_starts.get(term)
            if after:
                settings.append(f"weights_after_starts.{term}={after * factor:g}")
            arms.append(Arm(f"{term}_{tag}", f"weights.{term} × {factor:g} ({value:g} → {value * factor:g})", tuple(settings)))
    return arms


#: The misplacements of the ``misplacement`` experiment: name → (shift along each segment, m;
#: rotation, rad), every sensor at once with a random sign per sensor.
MISPLACEMENTS: dict[str, tuple[float, float]] = {
    "none": (0.0, 0.0), "2 cm": (0.02, 0.0), "5 cm": (0.05, 0.0), "10 cm": (0.10, 0.0), "20 cm": (0.20, 0.0),
    "10°": (0.0, np.radians(10)), "20°": (0.0, np.radians(20)), "30°": (0.0, np.radians(30)),
}


def _misplacement(base: TrainConfig, steps: int) -> list[Arm]:
    return [
        Arm("nominal", "the configuration as it is (nominal placement), scored on test recordings with misplaced sensors"),
        Arm("learned", "the placement learned with the network (learn_placement), scored on the same misplaced test "
            "recordings (the placement of a new recording stays nominal)", ("learn_placement=true",)),
    ]


def _placed(rec: Recording) -> np.ndarray:
    """(7, 3) [x (m), y (m), angle (rad)] of the sensors as ``rec`` was recorded: the true placement
    (:func:`true_placement`), or the nominal one where none is stored."""
    truth = true_placement(rec)
    return (rec.placement.vector() if truth is None else truth.ravel()).reshape(len(SEGMENTS), 3).copy()


def misplaced_placement(rec: Recording, along_m: float, angle_rad: float, seed: int = 0) -> np.ndarray:
    """(7, 3) [x (m), y (m), angle (rad)] per sensor where :func:`misplaced` puts it: the true
    placement (``true_placement``; the nominal one if not stored) with every sensor ``along_m``
    further along its segment (y on the pelvis, thighs and shanks, x on the feet) and turned by
    ``angle_rad``, each with a random sign (seeded)."""
    after = _placed(rec)
    sign = np.where(np.random.default_rng(seed).random((len(SEGMENTS), 2)) < 0.5, -1.0, 1.0)
    for i, s in enumerate(SEGMENTS):
        after[i, 0 if s.startswith("foot") else 1] += sign[i, 0] * along_m
        after[i, 2] += sign[i, 1] * angle_rad
    return after


def misplaced(rec: Recording, along_m: float, angle_rad: float, seed: int = 0) -> Recording:
    """``rec`` as if every sensor sat where :func:`misplaced_placement` puts it (``along_m`` further
    along its segment, turned by ``angle_rad``, random signs): the signals plus the change of the
    virtual IMU signals of its labels (u and q̈ by central differences of q where not labelled)
    between the true placement and the moved one. The body is the Winter-scaled one of its height
    and mass (the change, not the signal, comes from it)."""
    from sspinn.model.body import BodyParameters, IMUPlacement
    from sspinn.model.kinematics import virtual_imu

    lab = rec.labels
    if lab is None or lab.q is None or not np.isfinite(lab.q).all():
        raise ExperimentError(f"{rec.name}: misplacing sensors needs its labelled coordinates q (all nine)")
    dt = 1.0 / SAMPLE_RATE_HZ  # rates and accelerations by central differences where not labelled
    u = lab.u if lab.u is not None and np.isfinite(lab.u).all() else np.gradient(lab.q, dt, axis=0)
    qdd = lab.qdd if lab.qdd is not None and np.isfinite(lab.qdd).all() else np.gradient(u, dt, axis=0)
    before, after = _placed(rec), misplaced_placement(rec, along_m, angle_rad, seed)
    p = BodyParameters.from_anthropometry(rec.height, rec.mass).vector()
    change = (virtual_imu(lab.q, u, qdd, IMUPlacement.from_vector(after.ravel()), p)
              - virtual_imu(lab.q, u, qdd, IMUPlacement.from_vector(before.ravel()), p))
    idx = [SEGMENTS.index(s) for s in rec.segments]
    return replace(rec, imu=rec.imu + change[:, idx])


@dataclass(frozen=True)
class Experiment:
    """An experiment: its arms (a function of the base configuration and the step budget) and
    what the paper claims about it."""

    arms: Callable[[TrainConfig, int], list[Arm]]
    claim: str
    source: str


EXPERIMENTS: dict[str, Experiment] = {
    "sensor-sets": Experiment(_sensor_sets, "sparse sensor sets still give plausible motion; single-segment sets did "
                              "not lead to meaningful results", "Table 2"),
    "finetune": Experiment(_finetune, "fine-tuning with L_K and L_T × 10 trades accuracy: JTE −10 %, GRFE −20 %, JAE +5 %, "
                           "speed error +33 %", "the fine-tuning results"),
    "placement": Experiment(_placement, "optimising the IMU placement jointly with the network recovers how the sensors were "
                            "mounted", "the placement optimisation"),
    "ablations": Experiment(_ablations, "every auxiliary term matters", "the ablation table; the full model's row is Table 2's all-sensor one"),
    "misplacement": Experiment(_misplacement, "(the paper's removed sensitivity study) the estimate tolerates sensors moved "
                               "along their segments or turned", "the sensitivity study removed from the paper"),
    "loss-weights": Experiment(_loss_weights, "the results are robust to halving or doubling each loss weight, except L_IMU "
                               "and L_B", "the loss-weight sensitivity"),
}


# ------------------------------------------------------------------------------ running
@dataclass(frozen=True)
class Request:
    """What one ``sspinn experiment`` call asks for.

    Attributes:
        experiment: a key of :data:`EXPERIMENTS`.
        out: the experiment's run folder.
        data: a labelled dataset folder with ``train`` and ``test`` splits.
        config: the training configuration every arm starts from (YAML).
        steps: optimiser steps per arm (the budget; with ``starts`` > 1 in the configuration,
            the chosen start's steps count in it as in ``sspinn train``).
        settings: ``--set`` overrides for every arm (before the arm's own).
        arms: the arms to run (None: all).
        overwrite: replace finished arms (and a folder made with another budget, data or configuration).
    """

    experiment: str
    out: Path
    data: Path = DEFAULT_DATA
    config: Path = DEFAULT_CONFIG
    steps: int = DEFAULT_STEPS
    settings: tuple[str, ...] = ()
    arms: tuple[str, ...] | None = None
    overwrite: bool = False

    def identity(self) -> dict[str, Any]:
        """What an arm's result depends on besides the arm (``experiment.json``)."""
        return {"experiment": self.experiment, "steps": self.steps, "data": str(Path(self.data).resolve()),
                "config": str(Path(self.config).resolve()), "settings": list(self.settings)}


def base_config(request: Request, arm: Arm | None = None) -> TrainConfig:
    """The training configuration of ``arm`` (None: the base, shared by every arm)."""
    from sspinn.estimator.sspinnpose import resolve_train_config

    settings = [*request.settings, *(arm.settings if arm else ())]
    try:
        return resolve_train_config(request.config, settings, steps=arm.steps if arm and arm.steps else request.steps)
    except ConfigError as exc:
        if "must be fewer than steps" not in str(exc):
            raise
        raise ExperimentError(f"--steps {request.steps}: {exc}; give more steps, or fewer or shorter starts "
                              "(--set starts=1, --set start_steps=K)") from None


def arms_of(request: Request) -> list[Arm]:
    """The experiment's arms (all of them, in report order)."""
    if request.experiment not in EXPERIMENTS:
        raise ExperimentError(f"unknown experiment {request.experiment!r}; choose one of {', '.join(EXPERIMENTS)}")
    return EXPERIMENTS[request.experiment].arms(base_config(request), request.steps)


def selected_arms(request: Request, arms: list[Arm]) -> list[Arm]:
    """The arms ``request.arms`` names (all built ones without it)."""
    if request.arms is None:
        return [a for a in arms if a.built]
    by_name = {a.name: a for a in arms}
    unknown = [n for n in request.arms if n not in by_name]
    if unknown:
        raise ExperimentError(f"--arms {','.join(unknown)}: not an arm of {request.experiment}; its arms: {', '.join(by_name)}")
    not_built = [n for n in request.arms if not by_name[n].built]
    if not_built:
        raise ExperimentError(f"--arms {','.join(not_built)}: not built in this project ({by_name[not_built[0]].what})")
    return [by_name[n] for n in dict.fromkeys(request.arms)]


def load_splits(data: Path) -> tuple[list[Recording], list[Recording]]:
    """(training, test) recordings of a labelled dataset folder."""
    data = Path(data)
    if not (data / "dataset.json").is_file():
        raise ExperimentError(f"{data}: not a dataset folder (no dataset.json); generate one with `python -m predictive synth` "
                              "(as `make demo` does) or pass --data")
    dataset = Dataset.open(data)
    missing = [s for s in ("train", "test") if s not in dataset.splits]
    if missing:
        raise ExperimentError(f"{data}: has no {' and no '.join(missing)} split (it has {', '.join(dataset.splits)}); "
                              "an experiment trains on 'train' and scores on 'test'")
    return dataset.load("train"), dataset.load("test")


def run(request: Request, log: Callable[[str], None] = print) -> dict[str, Any]:
    """Run (or resume) the experiment's selected arms, then write ``results.json``,
    ``report.md`` and the plot from every finished arm in the folder; returns the results."""
    arms = arms_of(request)
    chosen = selected_arms(request, arms)
    out = Path(request.out)
    train, test = load_splits(request.data)  # before the folder is claimed: a wrong --data leaves nothing behind
    with RunLock(out):
        _claim_folder(request, out, arms, chosen, log)
        for arm in chosen:
            _run_arm(request, arm, train, test, out / arm.name, log)
        results = collect(request, arms, train, test)
        atomic_write_text(out / "results.json", json_text(results, non_finite="null"))
        atomic_write_text(out / "report.md", report(results))
        if request.experiment == "sensor-sets":
            plot_sensor_sets(out, [a for a in arms if (out / a.name / "arm.json").exists()], test)
        if request.experiment == "misplacement":
            plot_misplacement(out, {n: a for n, a in results["arms"].items() if a["status"] == "finished"})
    log(f"report: {out / 'report.md'}")
    return results


def _claim_folder(request: Request, out: Path, arms: list[Arm], chosen: list[Arm], log: Callable[[str], None]) -> None:
    """Check ``experiment.json`` against the request (another budget, data or configuration is
    an error without ``overwrite``); with ``overwrite``, clear what will be replaced."""
    marker = out / "experiment.json"
    identity = request.identity()
    if marker.exists():
        held = json.loads(marker.read_text())
        if held != identity:
            changed = [k for k in identity if held.get(k) != identity[k]]
            if not request.overwrite:
                raise ExperimentError(
                    f"{out}: holds {held.get('experiment')} results made with another {', '.join(changed)} "
                    f"({', '.join(f'{k}: {held.get(k)!r}' for k in changed)}); rerun with those, replace them with "
                    "--overwrite, or choose another --out")
            log(f"--overwrite: {out} was made with another {', '.join(changed)}; its arms are removed")
            for arm in arms:
                if (out / arm.name).is_dir():
                    shutil.rmtree(out / arm.name)
    if request.overwrite:
        for arm in chosen:
            if (out / arm.name).exists():
                log(f"--overwrite: removing {out / arm.name}")
                shutil.rmtree(out / arm.name)
    atomic_write_text(marker, json.dumps(identity, indent=2))


def _run_arm(request: Request, arm: Arm, train: list[Recording], test: list[Recording], folder: Path,
             log: Callable[[str], None]) -> None:
    from sspinn.estimator.sspinnpose import SSPINNpose

    if (folder / "arm.json").exists():
        log(f"{arm.name}: finished, skipped ({folder / 'arm.json'}; --overwrite to run it again)")
        return
    config = base_config(request, arm)
    resume = (folder / "checkpoint.pt").exists()
    log(f"{arm.name}: {'resuming' if resume else 'training'} {config.steps} steps — {arm.what}")
    est = SSPINNpose(config).fit(train, folder, resume=resume)
    if est.stopped_by_ == "time_limit":
        log(f"WARNING: {arm.name} stopped by the safety time limit at step {est.steps_} of {config.steps}; not scored, "
            "rerun to resume it")
        return
    result: dict[str, Any] = {"arm": arm.name, "what": arm.what, "settings": list(arm.settings), "steps": est.steps_,
                              "by_program": score(est, train, test, str(request.data))}
    if arm.subsets:
        result["by_subset"] = {name: score(est, train, [r.select_imus(IMU_CONFIGURATIONS[name]) for r in test], str(request.data))
                               for name in arm.subsets}
    if request.experiment == "placement":
        result["placement"] = placement_errors(folder / "checkpoint.pt", train)
    if request.experiment == "misplacement":
        result["by_misplacement"] = {name: score(est, train, [misplaced(r, along, angle, seed=k) for k, r in enumerate(test)],
                                                 str(request.data))
                                     for name, (along, angle) in MISPLACEMENTS.items()}
    atomic_write_text(folder / "arm.json", json_text(result, non_finite="null"))


def score(est: Any, train: list[Recording], test: list[Recording], where: str) -> dict[str, Any]:
    """Per gait program of ``test`` (and "all" with several): the model's and the trivial
    predictors' mean metrics (:func:`~sspinn.estimator.evaluation.compare_with_baseline`, the
    predictors fitted on the training split's labels)."""
    from sspinn.estimator.trivial_predictors import reference_predictor

    seen = sorted({r.name for r in test} & set(est.trained_on_))
    if seen:
        raise ExperimentError(f"the test split shares recordings with the training split ({', '.join(seen)}); "
                              "an experiment scores on held-out recordings only")
    estimates = [est.predict(r) for r in test]
    check_evaluable(estimates, test, SKIP)
    baseline = reference_predictor(test, train, where)
    comparison = compare_with_baseline(estimates, test, baseline, SKIP)
    return {program: {**c, "baseline_source": baseline.source} for program, c in comparison.items()}


def true_placement(rec: Recording) -> np.ndarray | None:
    """(7, 3) true [x (m), y (m), angle (rad)] of each sensor in its segment frame, as the
    synthetic data store it (``provenance.ground_truth.imu_placement``); None when not stored."""
    stored = rec.provenance.get("ground_truth", {}).get("imu_placement") if isinstance(rec.provenance, dict) else None
    if not isinstance(stored, dict) or set(stored) != set(SEGMENTS):
        return None
    return np.array([[*stored[s]["position_m"], stored[s]["angle_rad"]] for s in SEGMENTS], dtype=float)


def placement_errors(checkpoint: Path, train: list[Recording]) -> dict[str, Any]:
    """Per sensor: the mean absolute error (over the training recordings) of the nominal and of
    the placement in ``checkpoint`` (the learned one with ``learn_placement``) against the truth:
    x and y in the segment frame (cm) and the angle (°); and the median over the recordings of
    the position error's length √(Δx² + Δy²) (cm)."""
    from sspinn.estimator.training import CHECKPOINT_ENTRIES
    from sspinn.torch_files import CHECKPOINT, load_torch_file

    state = load_torch_file(checkpoint, (CHECKPOINT,), CHECKPOINT_ENTRIES, "rerun the arm with --overwrite", "cpu")
    by_name = {r.name: r for r in train}
    learned = state["placement"].numpy().reshape(len(state["recordings"]), len(SEGMENTS), 3)
    truths, nominal, after = [], [], []
    for k, name in enumerate(state["recordings"]):
        truth = true_placement(by_name[name])
        if truth is None:
            continue
        truths.append(truth)
        nominal.append(by_name[name].placement.vector().reshape(len(SEGMENTS), 3))
        after.append(learned[k])
    if not truths:
        return {"truth_stored": False, "note": "the training recordings store no true placement "
                "(provenance.ground_truth.imu_placement); only synthetic data made by `python -m predictive synth` do"}
    truth = np.stack(truths)

    def errors(values: list[np.ndarray]) -> dict[str, dict[str, float]]:
        diff = np.stack(values) - truth
        err = np.abs(diff).mean(0)
        position = np.median(np.hypot(diff[..., 0], diff[..., 1]), axis=0)
        return {s: {"x_cm": 100 * err[i, 0], "y_cm": 100 * err[i, 1], "angle_deg": float(np.degrees(err[i, 2])),
                    "position_median_cm": float(100 * position[i])}
                for i, s in enumerate(SEGMENTS) if s in state["segments"]}

    return {"truth_stored": True, "recordings": len(truths), "nominal": errors(nominal), "after": errors(after)}


# ------------------------------------------------------------------------------ results and report
def collect(request: Request, arms: list[Arm], train: list[Recording], test: list[Recording]) -> dict[str, Any]:
    """Every arm's status and scores (finished arms from their ``arm.json``), the paper's figures
    and the trivial predictors."""
    out = Path(request.out)
    rows: dict[str, Any] = {}
    for arm in arms:
        entry: dict[str, Any] = {"what": arm.what, "settings": list(arm.settings),
                                 "paper": dict(zip(METRICS, arm.paper)) if arm.paper else None}
        path = out / arm.name / "arm.json"
        if not arm.built:
            entry["status"] = "not built"
        elif path.exists():
            entry.update(json.loads(path.read_text()), status="finished")
        else:
            entry["status"] = "not run"
        rows[arm.name] = entry
    experiment, config = EXPERIMENTS[request.experiment], base_config(request)
    starts = config.starts if config.starts > 1 else 1
    return {"experiment": request.experiment, "claim": experiment.claim, "paper_source": f"{PAPER}, {experiment.source}",
            "steps_per_arm": request.steps, "starts": starts, "start_steps": config.start_steps if starts > 1 else 0,
            "steps_in_all_per_arm": request.steps + (starts - 1) * config.start_steps if starts > 1 else request.steps, "data": str(request.data), "config": str(request.config),
            "settings": list(request.settings), "train_recordings": len(train), "test_recordings": len(test),
            "skip_samples": SKIP, "arms": rows}


def command(results: dict[str, Any]) -> str:
    """The ``sspinn experiment`` command that makes these results (``OUT`` for the folder)."""
    words = ["sspinn experiment", results["experiment"], "--data", results["data"], "--steps", str(results["steps_per_arm"])]
    if Path(results["config"]).resolve() != DEFAULT_CONFIG.resolve():
        words += ["--config", results["config"]]
    words += [w for s in results["settings"] for w in ("--set", s)]
    return " ".join(words + ["--out OUT"])


def _cell(value: Any, fmt: str = ".3g") -> str:
    return format(value, fmt) if isinstance(value, (int, float)) and np.isfinite(value) else "n/a"


def _worse(head: str, model: Any, baseline: Any) -> str:
    """``"JAE (°) 12.8 vs 11.3 (+13 %)"`` when the model is no better than the trivial predictor, else ``""``."""
    if not (isinstance(model, float) and isinstance(baseline, float) and model >= baseline):
        return ""
    by = f"{100 * (model / baseline - 1):+.0f} %" if baseline > 1e-6 else "the trivial predictor's is 0"
    return f"{head} {model:.3g} vs {baseline:.3g} ({by})"


def report(results: dict[str, Any]) -> str:
    """``report.md`` of :func:`collect`'s results."""
    arms = results["arms"]
    finished = {n: a for n, a in arms.items() if a["status"] == "finished"}
    programs = list(dict.fromkeys(p for a in finished.values() for p in a["by_program"]))
    heads = list(METRICS.values())
    lines = [f"# Experiment `{results['experiment']}`", "",
             f"The paper's claim: {results['claim']}.", "",
             f"Budget: {results['steps_per_arm']} optimiser steps per arm"
             + (f" ({results['starts']} starts of {results['start_steps']} steps, the most physical one continuing: "
                f"{results['steps_in_all_per_arm']} steps in all)" if results["starts"] > 1 else "")
             + f"; configuration {results['config']}"
             + (f" with {' '.join('--set ' + s for s in results['settings'])}" if results["settings"] else "")
             + f"; trained on the {results['train_recordings']} recordings of the training split of {results['data']}, "
             f"scored on its {results['test_recordings']} test recordings (first {results['skip_samples']} samples of each left "
             f"out). Command: `{command(results)}`.", ""]
    if not finished:
        lines += ["No arm has finished yet: results not yet measured.", ""]
    for program in programs:
        first = next(a["by_program"][program] for a in finished.values() if program in a["by_program"])
        base, source = first["baseline"], first["baseline_source"]
        lines += [f"## {program} ({first['recordings']} test recording(s))", "",
                  "| arm | what it changes | " + " | ".join(heads) + " |", "|---|---|" + "---|" * len(heads)]
        worse = []
        for name, a in arms.items():
            if a["status"] != "finished" or program not in a["by_program"]:
                lines.append(f"| {name} | {a['what']} | " + " | ".join([a["status"]] * len(heads)) + " |")
                continue
            model = a["by_program"][program]["model"]
            lines.append(f"| {name} | {a['what']} | " + " | ".join(_cell(model[k]) for k in METRICS) + " |")
            cells = [_worse(head, model[k], base[k]) for k, head in METRICS.items()]
            if any(cells):
                worse.append(f"- **{name} is worse than the trivial predictors on {program}**: " + "; ".join(c for c in cells if c))
        lines.append("| trivial predictors | " + ", ".join(BASELINE_OF[k] for k in METRICS) + " | "
                     + " | ".join(_cell(base[k]) for k in METRICS) + " |")
        froude = first.get("froude", {}).get("speed_error_mps")  # absent from arms scored before it existed
        lines += ["", f"Trivial predictors: {source}."
                  + (f" Beside the mean speed, the Froude speed (the same data's mean Froude number at each test subject's "
                     f"leg length): speed error {_cell(froude)} m/s." if froude is not None else ""), ""]
        lines += worse + ([""] if worse else [])
        reference = next(iter(finished))
        if len(finished) > 1 and program in finished[reference]["by_program"]:
            ref = finished[reference]["by_program"][program]["model"]
            lines += [f"Change against `{reference}` (%):", "", "| arm | " + " | ".join(heads) + " |", "|---|" + "---|" * len(heads)]
            for name, a in finished.items():
                if name == reference or program not in a["by_program"]:
                    continue
                model = a["by_program"][program]["model"]
                lines.append(f"| {name} | " + " | ".join(
                    f"{100 * (model[k] / ref[k] - 1):+.0f}" if isinstance(model[k], float) and isinstance(ref[k], float) and ref[k] > 0
                    else "n/a" for k in METRICS) + " |")
            lines.append("")
    with_paper = {n: a for n, a in arms.items() if a["paper"]}
    lines += [f"## The paper's figures ({results['paper_source']})", ""]
    if with_paper:
        lines += ["Measured on the paper's real recordings: a yardstick, not a number this synthetic benchmark must match.", "",
                  "| arm | " + " | ".join(heads) + " |", "|---|" + "---|" * len(heads)]
        lines += [f"| {n} | " + " | ".join(_cell(a["paper"][k]) for k in METRICS) + " |" for n, a in with_paper.items()]
    else:
        lines.append(f"The paper reports: {results['claim']}.")
    lines.append("")
    placements = {n: a["placement"] for n, a in finished.items() if a.get("placement")}
    if placements:
        lines += ["## IMU placement against the truth", "",
                  "Mean absolute error over the training recordings, in each segment's frame (y along the thigh, shank "
                  "and pelvis, x along the foot), and the median length of the position error: nominal (what the "
                  "estimator is told) → after training.", ""]
        for name, p in placements.items():
            if not p["truth_stored"]:
                lines += [f"- {name}: {p['note']}.", ""]
                continue
            keys = ("x_cm", "y_cm", "angle_deg", "position_median_cm")
            lines += [f"### {name} ({p['recordings']} recordings)", "",
                      "| sensor | x (cm) | y (cm) | angle (°) | median position error (cm) |", "|---|---|---|---|---|"]
            for s, nom in p["nominal"].items():
                aft = p["after"][s]
                lines.append(f"| {s} | " + " | ".join(f"{_cell(nom.get(k), '.2f')} → {_cell(aft.get(k), '.2f')}" for k in keys) + " |")
            lines.append("")
    for name, a in finished.items():
        if a.get("by_subset"):
            lines += _any_subset_section(name, a, finished)
    if any(a.get("by_misplacement") for a in finished.values()):
        lines += _misplacement_section(finished)
    if results["experiment"] == "sensor-sets" and finished:
        lines += ["![estimated poses per sensor set](sensor_sets.png)", ""]
    return "\n".join(lines)


def _misplacement_section(finished: dict[str, Any]) -> list[str]:
    """The report's table of the metrics against the misplacement of every sensor."""
    heads = list(METRICS.values())
    lines = ["## Sensors misplaced on the test recordings", "",
             "Every sensor of every test recording moved along its segment (cm) or turned (°), each by the same amount "
             "with a random sign (`sspinn.estimator.paper_experiments.misplaced`); the model is told the nominal placement.", ""]
    scored = {n: a["by_misplacement"] for n, a in finished.items() if a.get("by_misplacement")}
    programs = list(dict.fromkeys(p for by in scored.values() for r in by.values() for p in r))
    for program in programs:
        lines += [f"### {program}", "", "| misplacement | arm | " + " | ".join(heads) + " |", "|---|---|" + "---|" * len(heads)]
        for where in MISPLACEMENTS:
            for arm, by in scored.items():
                model = by.get(where, {}).get(program, {}).get("model")
                if model is not None:
                    lines.append(f"| {where} | {arm} | " + " | ".join(_cell(model[k]) for k in METRICS) + " |")
        first = next(iter(scored.values()))["none"][program]["baseline"]
        lines += ["| – | trivial predictors | " + " | ".join(_cell(first[k]) for k in METRICS) + " |", ""]
    lines += ["![metrics against the misplacement](misplacement.png)", ""]
    return lines


def plot_misplacement(out: Path, finished: dict[str, Any]) -> Path | None:
    """``misplacement.png``: per metric (columns) and gait (rows), the metric against the shift
    (cm, bottom axis) and the rotation (°, a second panel row) for each arm."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from sspinn.model.drawing import save_figure

    scored = {n: a["by_misplacement"] for n, a in finished.items() if a.get("by_misplacement")}
    if not scored:
        return None
    programs = [p for p in dict.fromkeys(p for by in scored.values() for r in by.values() for p in r) if p != "all"]
    shifts = [k for k, (d, a) in MISPLACEMENTS.items() if a == 0]
    turns = ["none"] + [k for k, (d, a) in MISPLACEMENTS.items() if a > 0]
    fig, axes = plt.subplots(2 * len(programs), len(METRICS), figsize=(3.4 * len(METRICS), 2.6 * 2 * len(programs)), squeeze=False)
    for row, program in enumerate(programs):
        for kind, keys, xs, unit in (("shift", shifts, [100 * MISPLACEMENTS[k][0] for k in shifts], "cm"),
                                     ("turn", turns, [np.degrees(MISPLACEMENTS[k][1]) for k in turns], "°")):
            r = 2 * row + (kind == "turn")
            for col, (key, head) in enumerate(METRICS.items()):
                ax = axes[r, col]
                for arm, by in scored.items():
                    ax.plot(xs, [by[k][program]["model"][key] for k in keys], marker="o", label=arm)
                ax.axhline(by["none"][program]["baseline"][key], color="0.5", ls="--", label="trivial")
                ax.set_xlabel(f"{kind} ({unit})")
                ax.set_title(f"{program}: {head}", fontsize=9)
                if r == 0 and col == 0:
                    ax.legend(fontsize=7)
    return save_figure(fig, out / "misplacement.png", dpi=80)


#: Largest relative difference (on every metric) at which one model for every subset counts as
#: matching the per-set models.
ANY_SUBSET_TOLERANCE = 0.10


def _any_subset_section(name: str, arm: dict[str, Any], finished: dict[str, Any]) -> list[str]:
    """The report's comparison of a model scored on several IMU subsets (``by_subset``) with the
    models trained for one subset each (the arms named after the subsets)."""
    heads = list(METRICS.values())
    lines = [f"## One model for every sensor set (`{name}`)", "",
             f"`{name}` scored with only each set's IMUs in the test recordings, beside the model trained for that set "
             f"(its arm); Δ: relative difference, a match within ±{100 * ANY_SUBSET_TOLERANCE:.0f} % on every metric of the "
             f"paper's sets counts as matching.", ""]
    verdicts = []
    programs = list(dict.fromkeys(p for r in arm["by_subset"].values() for p in r))
    for program in programs:
        lines += [f"### {program}", "", "| set | " + " | ".join(f"{h}: own / one model / Δ" for h in heads) + " |",
                  "|---|" + "---|" * len(heads)]
        for subset, by_program in arm["by_subset"].items():
            one = by_program.get(program, {}).get("model")
            own_arm = finished.get(subset)
            own = own_arm["by_program"].get(program, {}).get("model") if own_arm else None
            if one is None:
                continue
            cells, deltas = [], []
            for k in METRICS:
                if own is not None and isinstance(own[k], float) and isinstance(one[k], float) and own[k] > 0:
                    delta = one[k] / own[k] - 1
                    deltas.append(delta)
                    cells.append(f"{_cell(own[k])} / {_cell(one[k])} / {100 * delta:+.0f} %")
                else:
                    cells.append(f"{'not run' if own is None else 'n/a'} / {_cell(one[k])} / –")
            lines.append(f"| {subset} | " + " | ".join(cells) + " |")
            if subset in PAPER_SETS and subset != "all":
                if len(deltas) == len(METRICS):
                    worst = max(deltas)
                    verdicts.append((program, subset, worst))
        lines.append("")
    if verdicts:
        bad = [v for v in verdicts if v[2] > ANY_SUBSET_TOLERANCE]
        if bad:
            lines.append(f"**Not within {100 * ANY_SUBSET_TOLERANCE:.0f} % of the per-set models** on "
                         + "; ".join(f"{s} ({p}, up to {100 * w:+.0f} %)" for p, s, w in bad) + ".")
        else:
            lines.append(f"Within {100 * ANY_SUBSET_TOLERANCE:.0f} % of (or better than) the per-set models on every metric of "
                         f"the paper's paired sets, walking and running (worst {100 * max(v[2] for v in verdicts):+.0f} %).")
        lines.append("")
    return lines


def plot_sensor_sets(out: Path, arms: list[Arm], test: list[Recording]) -> Path | None:
    """``sensor_sets.png``: per gait program (rows) and sensor set (columns), the estimated poses
    of the program's first test recording at eight instants (in colour) over the true ones (grey)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from sspinn.estimator.sspinnpose import SSPINNpose
    from sspinn.estimator.trivial_predictors import program_of
    from sspinn.model.body import BodyParameters
    from sspinn.model.drawing import draw_stick_figure, save_figure

    if not arms:
        return None
    firsts = {}
    for rec in test:
        firsts.setdefault(program_of(rec), rec)
    fig, axes = plt.subplots(len(firsts), len(arms), figsize=(3.2 * len(arms), 2.6 * len(firsts)), squeeze=False)
    for row, (program, rec) in enumerate(firsts.items()):
        body = BodyParameters.from_anthropometry(rec.height, rec.mass)
        for col, arm in enumerate(arms):
            est = SSPINNpose.load(out / arm.name / "model.pt").predict(rec)
            ax = axes[row, col]
            for i, k in enumerate(np.linspace(min(SKIP, rec.n_samples - 1), rec.n_samples - 1, 8).astype(int)):
                if rec.labels is not None and rec.labels.q is not None:
                    truth = rec.labels.q[k].copy()
                    truth[0] = 0.6 * i
                    draw_stick_figure(ax, np.nan_to_num(truth), body, alpha=0.25)
                q = est.q[k].copy()
                q[0] = 0.6 * i
                draw_stick_figure(ax, q, body)
            ax.set_aspect("equal")
            ax.axhline(0, color="0.6")
            ax.set_title(f"{arm.name}: {program}", fontsize=9)
            ax.set_xticks([])
    return save_figure(fig, out / "sensor_sets.png", dpi=80)


# ------------------------------------------------------------------------------ command line
def _arm_list(text: str) -> tuple[str, ...]:
    names = tuple(n.strip() for n in text.split(",") if n.strip())
    if not names:
        raise argparse.ArgumentTypeError("expected arm names separated by commas, e.g. all,feet_shanks")
    return names


def add_parser(sub: Any) -> None:
    """The ``experiment`` sub-command of ``sspinn``."""
    from sspinn.errors import bounded

    p = sub.add_parser("experiment", help="one of the paper's claims measured on labelled data (arms trained and scored)")
    p.add_argument("name", choices=list(EXPERIMENTS), help="the experiment")
    p.add_argument("--out", type=Path, required=True, help="the experiment's run folder (one sub-folder per arm)")
    p.add_argument("--data", type=Path, default=DEFAULT_DATA, help=f"labelled dataset with train and test splits (default: {DEFAULT_DATA})")
    p.add_argument("--config", type=Path, default=DEFAULT_CONFIG, help="training configuration of every arm (default: the shipped demo.yaml)")
    p.add_argument("--steps", type=bounded(int, 1, 10_000_000), default=DEFAULT_STEPS, help=f"optimiser steps per arm (default {DEFAULT_STEPS})")
    p.add_argument("--arms", type=_arm_list, default=None, help="comma-separated arms to run (default: all); the report lists every finished one")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="override a config entry of every arm (repeatable)")
    p.add_argument("--overwrite", action="store_true", help="run finished arms again (and replace a folder made with another budget, data or configuration)")


def run_command(args: argparse.Namespace) -> int:
    """``sspinn experiment``: run it and print where the report is."""
    run(Request(args.name, args.out, args.data, args.config, args.steps, tuple(args.set), args.arms, args.overwrite))
    return 0


def list_arms(name: str, config: str | Path = DEFAULT_CONFIG, steps: int = DEFAULT_STEPS) -> Sequence[Arm]:
    """The arms of experiment ``name`` for a configuration and budget (e.g. for the docs)."""
    return arms_of(Request(name, Path("."), config=Path(config), steps=steps))
