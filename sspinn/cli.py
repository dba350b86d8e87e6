"""Command-line interface: ``sspinn <command>`` (or ``python -m sspinn <command>``).

Commands: ``showcase`` (a physics showcase; the main job, ``make demo``, chains ``python -m
predictive synth`` → ``sspinn train`` → ``sspinn evaluate`` → ``sspinn adapt`` → ``sspinn
evaluate``), ``train``, ``finetune``, ``adapt``, ``evaluate``, ``infer`` (estimates and their per-window quality), ``calibrate-quality``, ``export``,
``experiment`` (the paper's claims, :mod:`sspinn.estimator.paper_experiments`). ``--data``
accepts a dataset folder (with ``dataset.json``), a folder with an averaged stride
(``signals.csv`` + ``meta.json``) or a single recording ``.csv``.
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import sys
from collections.abc import Callable
from pathlib import Path

from sspinn.data.dataset import Dataset
from sspinn.data.loading import dataset_recordings, open_recordings
from sspinn.errors import ArgumentParser, UserError, bounded, run_cli
from sspinn.estimator.inference import ImplausibleEstimateError, NonFiniteEstimateError
from sspinn.run_folder import RunLock, atomic_path, output_target
from sspinn.yaml_config import add_config_flags, flag_overrides, shipped_path

#: Fields of :class:`~sspinn.estimator.training.TrainConfig` that ``train`` and ``finetune`` take as flags.
TRAIN_FLAGS = ("steps", "seed", "device", "time_limit_s")



class RunFolderError(UserError):
    """The output folder holds a finished run, or is the source model's own folder."""


def _data_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--data", type=Path, required=True, help="dataset folder, averaged-stride folder or recording .csv")
    p.add_argument("--periods", type=bounded(int, 1, 10_000), default=10, help="strides of circular padding for averaged data (≥ 1)")
    p.add_argument("--height", type=bounded(float, 0.5, 2.5, " m"), default=1.75, help="assumed height (m) for averaged data without one")
    p.add_argument("--mass", type=bounded(float, 10.0, 300.0, " kg"), default=70.0, help="assumed mass (kg) for averaged data without one")


def _train(args: argparse.Namespace, command: str) -> int:
    from sspinn.estimator.sspinnpose import SSPINNpose

    check_device(flag_overrides(args).get("device"), "--device")
    for setting in args.set:
        key, _, value = setting.partition("=")
        if key.strip() == "device":
            check_device(value.strip(), f"--set {setting!r}:")
    _check_run_folder(args, command)
    recordings = open_recordings(args.data, getattr(args, "split", "train"), args.periods, args.height, args.mass)
    resume = args.resume or (args.auto_resume and (args.out / "checkpoint.pt").exists())
    from sspinn.estimator.training import NonFiniteLossError

    if resume and command != "adapt":
        _warn_resume_changes(_train_config(args), args.out / "checkpoint.pt")
    previous = _sigterm_as_ctrl_c()
    try:
        if command == "train":
            est = SSPINNpose(_train_config(args)).fit(recordings, args.out, resume=resume)
        elif command == "adapt":
            est = SSPINNpose.load(args.model).adapt(recordings, args.out, resume=resume, settings=args.set,
                                                    **flag_overrides(args))
        else:
            est = SSPINNpose.load(args.model)
            est.config = _train_config(args)
            est.finetune(recordings, args.out, resume=resume)
    except NonFiniteLossError as exc:  # a user's setting (a learning rate too high), not a bug
        raise UserError(f"{args.out}: training diverged: {exc}; lower the learning rate (--lr / --set lr=) or "
                        "check the recordings") from None
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)
    print(f"{'adapted' if command == 'adapt' else 'trained'} {est.steps_} steps → {args.out / 'model.pt'}")
    if est.stopped_by_ == "time_limit":
        print(
            f"WARNING: stopped by the safety time limit ({est.config_.time_limit_s:.0f} s) at step {est.steps_} of "
            f"{est.config_.steps}, not by the step count: the result depends on this machine's speed and load",
            file=sys.stderr,
        )
    return 0


def _train_config(args: argparse.Namespace):  # -> TrainConfig (imported lazily: torch)
    """The training configuration of ``--config`` (a file that must exist there — a relative
    path is never looked up anywhere else — or a shipped name: demo, smoke, paper) with the flags
    and ``--set`` applied."""
    from sspinn.estimator.sspinnpose import CONFIG_DIR
    from sspinn.estimator.training import TrainConfig
    from sspinn.yaml_config import MissingConfigFileError

    path = Path(args.config)
    if str(path) == path.name and not path.suffix and (CONFIG_DIR / f"{path}.yaml").is_file():
        path = CONFIG_DIR / f"{path}.yaml"
    elif not path.exists():
        names = ", ".join(sorted(p.stem for p in CONFIG_DIR.glob("*.yaml")))
        raise MissingConfigFileError(f"{path}: no such configuration file (give the path of one, or a shipped name: {names})")
    config = TrainConfig.from_yaml(path, settings=list(args.set), **flag_overrides(args))
    check_device(config.device, f"{path}: device")
    return config


#: Settings a resumed run may change without a warning: its length, machine and logging.
RESUME_FREE = ("steps", "threads", "time_limit_s", "device", "log_every", "checkpoint_every")


def _warn_resume_changes(config, checkpoint: Path) -> None:
    """A WARNING line naming every setting (other than :data:`RESUME_FREE`) that differs from the
    one the checkpoint was trained with: a resumed run is then not the run it continues."""
    from sspinn.torch_files import CHECKPOINT, load_torch_file

    if not checkpoint.is_file():
        return
    saved = load_torch_file(checkpoint, (CHECKPOINT,), ("config",), "resume from an intact checkpoint").get("config", {})
    now = config.to_dict()
    refused = ("network", "imus")  # the checkpoint's loader refuses these itself, naming them
    changed = [f"{k} {saved[k]!r} → {now[k]!r}" for k in now
               if k in saved and k not in RESUME_FREE + refused and saved[k] != now[k]]
    if changed:
        print(f"WARNING: {checkpoint}: resuming with settings other than the checkpoint's ({'; '.join(changed)}): the "
              "result is not that of the run it continues", file=sys.stderr)


def _sigterm_as_ctrl_c():  # -> the previous handler, or None outside the main thread
    """SIGTERM (``kill``, a batch system's stop) handled as Ctrl-C is: training finishes the step
    it is in, saves the checkpoint and stops (a second signal stops at once)."""
    import threading

    if threading.current_thread() is not threading.main_thread():
        return None

    def forward(signum: int, frame: object) -> None:
        handler = signal.getsignal(signal.SIGINT)
        if callable(handler):
            handler(signal.SIGINT, frame)
        else:
            raise KeyboardInterrupt

    return signal.signal(signal.SIGTERM, forward)


def check_device(name: str | None, where: str) -> None:
    """A :class:`UserError` naming ``where`` unless ``name`` is ``auto``, ``cpu`` or a CUDA device
    this torch can use (``cuda``, ``cuda:<k>`` below the number of GPUs)."""
    if name in (None, "auto", "cpu"):
        return
    import torch

    try:
        device = torch.device(name)
    except (RuntimeError, TypeError):
        device = None
    if device is None or device.type not in ("cpu", "cuda"):
        raise UserError(f"{where} {name!r} is not a device sspinn trains on: use cpu, cuda, cuda:<k> or auto")
    if device.type == "cuda" and not torch.cuda.is_available():
        raise UserError(f"{where} {name!r}: this torch ({torch.__version__}) sees no CUDA GPU; use cpu or auto")
    if device.type == "cuda" and device.index is not None and device.index >= torch.cuda.device_count():
        raise UserError(f"{where} {name!r}: there are {torch.cuda.device_count()} CUDA GPU(s) (cuda:0 …); use another index")


#: Files of a run folder that make it a (finished or resumable) run.
RUN_FILES = ("model.pt", "checkpoint.pt")


def _holds_run(folder: Path) -> bool:
    return any((folder / name).exists() for name in RUN_FILES)


def _new_output_folder(args: argparse.Namespace, holds_result: Callable[[Path], bool], what: str, hint: str) -> None:
    """A finished result is never replaced without ``--overwrite``: when ``args.out`` holds one
    (``holds_result``), the command writes to the first free ``<out>_2``, ``<out>_3``, … instead
    and says so (:func:`sspinn.run_folder.output_target`)."""
    args.out = output_target(args.out, holds_result, getattr(args, "overwrite", False), what, hint)


def _check_run_folder(args: argparse.Namespace, command: str) -> None:
    """A finished run is never replaced without ``--overwrite`` (a new run goes to a new folder,
    :func:`_new_output_folder`); adapt and finetune never write into the folder of the model they
    start from. Under ``torchrun`` (several processes) a folder holding a run is refused instead:
    every rank must write to the same folder."""
    out = args.out
    model = getattr(args, "model", None)
    if model is not None and out.resolve() == Path(model).resolve().parent:
        raise RunFolderError(f"{out}: is the folder of the model {model} that {command} starts from; choose another --out")
    if int(os.environ.get("RANK", "0")) != 0:  # under torchrun rank 0 owns (and checks) the folder
        return
    if args.resume or args.auto_resume or getattr(args, "overwrite", False):
        return
    if out.is_dir():
        with RunLock(out):  # a run still training there is named first (RunFolderBusyError)
            pass
    present = ", ".join(name for name in RUN_FILES if (out / name).exists())
    if int(os.environ.get("WORLD_SIZE", "1")) > 1 and present:
        raise RunFolderError(
            f"{out}: holds a run ({present}); continue it with --resume, replace it with --overwrite, or choose another --out"
        )
    _new_output_folder(args, _holds_run, f"a run ({present})", "continue it with --resume, ")


def _evaluate(args: argparse.Namespace) -> int:
    from sspinn.estimator.evaluation import EvaluationError, evaluate
    from sspinn.estimator.sspinnpose import SSPINNpose

    _new_output_folder(args, lambda f: (f / "metrics.json").exists() or (f / "report.md").exists(), "an evaluation", "")
    est = SSPINNpose.load(args.model, load_transfer=args.load_transfer)
    reference = None
    if (args.data / "dataset.json").exists():  # one read of the index for both splits
        dataset = Dataset.open(args.data)
        recs = dataset.load(args.split)
        if "train" in dataset.splits and est.baselines_ is None:  # the fallback baselines' data
            reference = recs if args.split == "train" else dataset.load("train")
    else:
        recs = open_recordings(args.data, args.split, args.periods, args.height, args.mass)
    from sspinn.estimator import uncertainty

    bands = None
    bands_file = args.uncertainty or uncertainty.calibration_path(args.model)
    if args.uncertainty is not None:  # named: it must fit this model
        bands = uncertainty.load_calibration(args.uncertainty, args.model)
    elif bands_file.exists():
        try:
            bands = uncertainty.load_calibration(bands_file, args.model)
        except uncertainty.UncertaintyError as exc:  # e.g. left from an earlier model: the metrics do not need it
            print(f"WARNING: {exc}; evaluated without intervals")
    try:
        result = evaluate(est, recs, args.out, reference=reference, reference_where=str(args.data),
                          title=f"{args.model} on {args.data} ({args.split})"
                          + (", the double-support load transferred linearly (offline)" if args.load_transfer else ""),
                          skip=args.skip, uncertainty=bands)
    except (EvaluationError, NonFiniteEstimateError, ImplausibleEstimateError) as exc:
        raise type(exc)(f"{args.model} on {args.data} ({args.split} split), recording {exc}") from None
    print(json.dumps(result["mean"], indent=2))
    print(f"against the trivial predictors ({result['baseline_source']}):")
    for program, c in result["by_program"].items():
        cells = [
            f"{key} {c['model'][key]:.3g} vs {c['baseline'][key]:.3g}"
            + (" (WORSE)" if key in c["worse_than_baseline"] else "")
            + (f", Froude speed {c['froude'][key]:.3g}" + (" (WORSE)" if key in c["worse_than_froude"] else "")
               if key in c["froude"] else "")
            for key in c["model"]
            if key in c["baseline"] and key not in ("jitter", "n_samples", "kane_residual", "hs_timing_ms", "hs_matched")
        ]
        print(f"  {program:<5} " + "; ".join(cells))
        if c["worse_than_baseline"]:
            print(f"  FAILURE: on {program}, {', '.join(c['worse_than_baseline'])} no better than the trivial predictor")
        if c["worse_than_froude"]:
            print(f"  FAILURE: on {program}, {', '.join(c['worse_than_froude'])} no better than the Froude speed")
    if "interval_coverage" in result:
        cov = result["interval_coverage"]
        print(f"coverage of the {100 * cov['level']:.0f} % intervals ({bands_file}):")
        for program, groups in cov["by_program"].items():
            print(f"  {program:<5} " + "; ".join(f"{g} {100 * v:.1f} %" for g, v in groups.items()))
    print(f"report: {args.out / 'report.md'}")
    return 0


def _infer(args: argparse.Namespace) -> int:
    import warnings

    from sspinn.estimator.quality import (
        QualityWarning,
        calibration_path,
        flag_findings,
        input_findings,
        load_calibration,
    )
    from sspinn.estimator.sspinnpose import SSPINNpose
    from sspinn.imu.turns import turn_findings

    _new_output_folder(args, lambda f: any(f.glob("*_estimate.csv")), "estimates", "")
    recs = open_recordings(args.data, args.split, args.periods, args.height, args.mass)
    est = SSPINNpose.load(args.model, load_transfer=args.load_transfer)
    quality_file = args.quality or calibration_path(args.model)
    calibration = load_calibration(quality_file, args.model) if args.quality or quality_file.exists() else None
    if calibration is None:
        print(f"NOTE: {args.model} has no quality calibration ({quality_file}): the per-window loss terms are written "
              "without scores or flags, and the inputs are not compared with the training data's; write one with "
              f"`sspinn calibrate-quality --model {args.model} --data DATASET`")
    from sspinn.estimator import uncertainty

    uncertainty_file = args.uncertainty or uncertainty.calibration_path(args.model)
    bands = (uncertainty.load_calibration(uncertainty_file, args.model)
             if args.uncertainty or uncertainty_file.exists() else None)
    if bands is None:
        print(f"NOTE: {args.model} has no uncertainty calibration ({uncertainty_file}): no intervals are written; write one "
              f"with `sspinn calibrate-uncertainty --model {args.model} --data DATASET --split val`")
    try:
        estimates = [est.predict(r) for r in recs]  # all checked before anything is written
        widths = [uncertainty.intervals(bands, est.network_, est.segments_, r) for r in recs] if bands else []
    except (NonFiniteEstimateError, ImplausibleEstimateError) as exc:
        raise type(exc)(f"{args.model} on {args.data}, recording {exc}") from None
    for k, (rec, estimate) in enumerate(zip(recs, estimates)):
        path = estimate.to_csv(args.out / f"{estimate.name}_estimate.csv")
        if bands is not None:
            band_path = uncertainty.write_intervals(args.out / f"{estimate.name}_uncertainty.csv", estimate.time, widths[k], bands.level)
            print(f"{estimate.name}: {100 * bands.level:.0f} % intervals → {band_path}")
        quality = est.quality(rec)
        findings = []
        if calibration is not None:
            calibration.apply(quality)
            findings = input_findings(rec, quality, calibration, str(args.model))
        where = quality.to_csv(args.out / f"{estimate.name}_quality.csv")
        flagged = "" if quality.flagged is None else f", {int(quality.flagged.sum())} flagged"
        print(f"{estimate.name}: {len(estimate.time)} samples → {path}; quality of {quality.n_windows} windows{flagged} → {where}")
        if calibration is not None:
            findings += flag_findings(quality, calibration, str(where))
        findings += turn_findings(rec)
        for text in findings:
            warnings.warn(text, QualityWarning, stacklevel=1)
    return 0


def _calibrate_quality(args: argparse.Namespace) -> int:
    import warnings

    from sspinn.estimator import calibration_files
    from sspinn.estimator.quality import (
        ERROR_QUANTILE,
        MIN_CALIBRATION_WINDOWS,
        QualityWarning,
        calibrate,
        calibration_path,
        training_recordings,
    )
    from sspinn.estimator.sspinnpose import SSPINNpose

    target = _calibration_target(args, calibration_path(args.model))  # checked before the work
    est = SSPINNpose.load(args.model)
    recs = [r for split in args.split for r in open_recordings(args.data, split, args.periods, args.height, args.mass)]
    estimates = [est.predict(r) for r in recs]
    # the calibration recordings when they hold the training ones (the default, --split train),
    # else the whole dataset: each file is read once
    training = training_recordings(recs, est.trained_on_) or training_recordings(dataset_recordings(args.data),
                                                                                 est.trained_on_)
    if not training:
        print(f"NOTE: the {len(est.trained_on_)} recordings {args.model} was trained on are not all in {args.data}: "
              "the input ranges are those of the calibration recordings")
    cal, _, _ = calibrate(est.network_, est.segments_, est.imu_std_, est.config_.joint_limits, recs, estimates, args.model,
                          f"{args.data} ({', '.join(args.split)})", training=training)
    out = calibration_files.save_new(cal.to_json(), target, "quality", args.overwrite)
    if out is None:  # the same calibration again (a rerun of make demo)
        print(f"{target}: unchanged")
        return 0
    fit = cal.fit
    if fit["n_windows"] < MIN_CALIBRATION_WINDOWS:
        warnings.warn(f"{out}: calibrated on only {int(fit['n_windows'])} windows of {cal.window_s:g} s; a threshold "
                      f"needs at least {MIN_CALIBRATION_WINDOWS} (more labelled recordings in --split)", QualityWarning,
                      stacklevel=1)
    print(f"calibrated on {len(recs)} recordings ({int(fit['n_windows'])} windows of {cal.window_s:g} s): threshold "
          f"{cal.threshold:.3g} flags {fit['flag_rate']:.0%} of them (precision {fit['precision']:.0%}, recall "
          f"{fit['recall']:.0%} for the {1 - ERROR_QUANTILE:.0%} with the largest error) → {out}")
    return 0


def _calibrate_uncertainty(args: argparse.Namespace) -> int:
    from sspinn.estimator import calibration_files, uncertainty
    from sspinn.estimator.sspinnpose import SSPINNpose
    from sspinn.estimator.trivial_predictors import program_of

    target = _calibration_target(args, uncertainty.calibration_path(args.model))  # checked before the work
    est = SSPINNpose.load(args.model)
    seen = set(args.split) & set(args.check)
    if seen:
        raise UserError(f"--check {' '.join(sorted(seen))}: also calibrated on; check on split(s) not in --split")
    recs = [r for split in args.split for r in open_recordings(args.data, split, args.periods, args.height, args.mass)]
    trained = [r.name for r in recs if r.name in est.trained_on_]
    if trained:
        print(f"NOTE: the model's training saw the IMU signals of {', '.join(trained)}: its errors there are smaller than on "
              "new recordings, so the intervals come out too narrow; calibrate on recordings it was not trained on (val)")
    cal = uncertainty.calibrate(est.network_, est.segments_, args.model, recs, [est.predict(r) for r in recs], args.level,
                                args.passes)
    for split in args.check:
        checked = open_recordings(args.data, split, args.periods, args.height, args.mass)
        estimates = [est.predict(r) for r in checked]
        widths = [uncertainty.intervals(cal, est.network_, est.segments_, r) for r in checked]
        cal.checked[split] = uncertainty.coverage(estimates, checked, widths, [program_of(r) for r in checked])
    out = calibration_files.save_new(cal.to_json(), target, "uncertainty", args.overwrite)
    if out is None:  # the same calibration again (a rerun of make demo)
        print(f"{target}: unchanged")
        return 0
    print(f"calibrated {100 * cal.level:.0f} % intervals on {len(recs)} recordings ({', '.join(args.split)}) → {out}")
    for split, table in cal.checked.items():
        print(f"coverage of the {100 * cal.level:.0f} % intervals on {split} (target {100 * cal.level:.0f} %):")
        for program, groups in table.items():
            print(f"  {program:<5} " + "; ".join(f"{g} {100 * v:.1f} %" for g, v in groups.items()))
    return 0


def _calibration_target(args: argparse.Namespace, default: Path) -> Path:
    """Where a calibration is written: ``--out`` or ``default``; never the model file itself, and
    an existing file that is no calibration (not JSON text) is never replaced, even with
    ``--overwrite``."""
    target = Path(args.out or default)
    if target.exists() and target.resolve() == Path(args.model).resolve():
        raise RunFolderError(f"--out {target}: is the model file being calibrated; choose another --out")
    if target.is_file():
        try:
            json.loads(target.read_text(encoding="utf-8"))
        except (UnicodeDecodeError, ValueError):
            raise RunFolderError(f"--out {target}: an existing file that is no calibration (not JSON); it is left as it is: "
                                 "choose another --out") from None
    return target


def _export(args: argparse.Namespace) -> int:
    from sspinn.estimator.sspinnpose import SSPINNpose

    if args.out.resolve() == args.model.resolve():
        raise RunFolderError(f"--out {args.out}: is the model file the program is exported from; choose another --out")
    if args.out.is_dir():
        raise RunFolderError(f"--out {args.out}: is a folder; give the program's file, e.g. {args.out / 'step.pt2'}")
    out = output_target(args.out, Path.exists, args.overwrite, "an existing file", keep_suffix=True)
    est = SSPINNpose.load(args.model)
    with atomic_path(out, tmp_suffix=".tmp.pt2") as tmp:  # torch.export.save wants the .pt2 ending
        est.export(tmp)
    path = out
    model, segments = est.network_, est.segments_
    cfg = model.config
    print(
        f"torch.export program of one streaming step (x ({model.n_inputs},) per sample, LSTM state "
        f"{cfg.layers}×{cfg.hidden}; IMUs {list(segments)}) → {path}; run: torch.export.load(path).module()"
    )
    return 0


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``sspinn``: returns the exit status (2 and one line on stderr for a user
    error; ``--debug`` shows the traceback; see :func:`sspinn.errors.run_cli`)."""
    return run_cli(_main, "sspinn", argv, user_errors=(ValueError,))


def _main(argv: list[str]) -> int:
    from sspinn.estimator.training import (  # its fields define the train/finetune/adapt flags
        ADAPT_LR,
        ADAPT_STEPS,
        TrainConfig,
    )

    parser = ArgumentParser(prog="sspinn", description="Sagittal gait dynamics from IMUs, self-supervised.",
                                     epilog="--debug anywhere shows the traceback of an error")
    sub = parser.add_subparsers(dest="command", required=True)

    demo = sub.add_parser("showcase", help="a short physics showcase of the model (a drop landing, plots)")
    demo.add_argument("--out", type=Path, default=Path("results/showcase"), help="output folder")
    demo.add_argument("--body", type=Path, default=None, help="body YAML (default: 1.75 m, 70 kg)")

    for name, help_text in (
        ("train", "self-supervised training"),
        ("finetune", "continue training with the fine-tuning weights"),
        ("adapt", "adapt a trained model to unlabeled recordings (the model's own config, fewer steps, a low constant rate, no input noise)"),
    ):
        p = sub.add_parser(name, help=help_text)
        if name == "adapt":
            p.add_argument("--model", type=Path, required=True, help="trained model.pt to adapt")
        else:
            p.add_argument("--config", type=Path, default=shipped_path("configs/sspinn/demo.yaml"), help="training configuration (default: the shipped demo.yaml)")
        _data_args(p)
        if name == "adapt":
            p.add_argument("--split", default="test", help="the dataset split to adapt to (its labels are never read)")
        p.add_argument("--out", type=Path, required=True, help="run folder (checkpoints, TensorBoard, model.pt)")
        p.add_argument("--resume", action="store_true", help="continue from <out>/checkpoint.pt")
        p.add_argument("--auto-resume", action="store_true", help="continue from <out>/checkpoint.pt if it exists, else start")
        p.add_argument("--overwrite", action="store_true",
                       help="replace a run already in --out (its model and checkpoint; else a new folder <out>_2 …)")
        # flags that override config fields: typed, checked and documented by TrainConfig itself
        add_config_flags(
            p, TrainConfig, TRAIN_FLAGS + (("lr",) if name == "adapt" else ()), flags={"time_limit_s": "--time-limit"},
            helps={"lr": f"constant Adam learning rate (default {ADAPT_LR:g})", "steps": f"optimiser steps (default {ADAPT_STEPS})"}
            if name == "adapt" else None,
        )
        p.add_argument(
            "--set", action="append", default=[], metavar="KEY=VALUE",
            help="override a config entry, dotted for sections (repeatable), e.g. --set weights.kane=0",
        )
        if name == "finetune":
            p.add_argument("--model", type=Path, required=True, help="trained model.pt to start from")
            add_config_flags(p, TrainConfig, ["learn_placement"])

    ev = sub.add_parser("evaluate", help="metrics and a report against labels")
    ev.add_argument("--model", type=Path, required=True)
    _data_args(ev)
    ev.add_argument("--split", default="test")
    ev.add_argument("--skip", type=int, default=50, help="samples of LSTM warm-up excluded from the metrics")
    ev.add_argument("--out", type=Path, required=True)
    ev.add_argument("--overwrite", action="store_true", help="replace an evaluation already in --out (else a new folder <out>_2 …)")
    ev.add_argument("--uncertainty", type=Path, default=None,
                    help="uncertainty calibration file (default: <model>.uncertainty.json beside the model, if there)")
    ev.add_argument("--load-transfer", action="store_true", help="score the estimates as `sspinn infer --load-transfer` writes them")

    inf = sub.add_parser("infer", help="estimates of recordings without labels → CSV")
    inf.add_argument("--model", type=Path, required=True)
    _data_args(inf)
    inf.add_argument("--split", default="test")
    inf.add_argument("--out", type=Path, required=True)
    inf.add_argument("--overwrite", action="store_true", help="replace estimates already in --out (else a new folder <out>_2 …)")
    inf.add_argument("--quality", type=Path, default=None,
                     help="quality calibration file (default: <model>.quality.json beside the model, if there)")
    inf.add_argument("--uncertainty", type=Path, default=None,
                     help="uncertainty calibration file (default: <model>.uncertainty.json beside the model, if there)")
    inf.add_argument("--load-transfer", action="store_true",
                     help="offline: move the vertical GRF of each double support from the trailing to the leading foot at a "
                          "constant rate, the torques following (lowers the GRF error on real walkers, raises it on synthetic gaits)")

    cq = sub.add_parser("calibrate-quality", help="calibrate the per-window quality score on labelled recordings (JSON beside the model)")
    cq.add_argument("--model", type=Path, required=True)
    _data_args(cq)
    cq.add_argument("--split", nargs="+", default=["train"], help="labelled split(s) to calibrate on (not those you evaluate on)")
    cq.add_argument("--out", type=Path, default=None, help="calibration file (default: <model>.quality.json)")
    cq.add_argument("--overwrite", action="store_true", help="replace a different calibration already in --out")

    cu = sub.add_parser("calibrate-uncertainty",
                        help="calibrate the per-sample intervals of every estimate on labelled recordings (JSON beside the model)")
    cu.add_argument("--model", type=Path, required=True)
    _data_args(cu)
    cu.add_argument("--split", nargs="+", default=["val"], help="labelled split(s) the model was not trained on to calibrate on")
    cu.add_argument("--check", nargs="*", default=[], help="labelled split(s) to check the coverage on (written into the file)")
    cu.add_argument("--level", type=bounded(float, 0.5, 0.99), default=0.9, help="nominal coverage of the intervals")
    cu.add_argument("--passes", type=bounded(int, 2, 1000), default=16, help="Monte Carlo dropout runs per recording")
    cu.add_argument("--out", type=Path, default=None, help="calibration file (default: <model>.uncertainty.json)")
    cu.add_argument("--overwrite", action="store_true", help="replace a different calibration already in --out")

    ex = sub.add_parser("export", help="torch.export program of one streaming step of a trained network (.pt2)")
    ex.add_argument("--model", type=Path, required=True)
    ex.add_argument("--out", type=Path, required=True, help="program file (.pt2)")
    ex.add_argument("--overwrite", action="store_true", help="replace the file already at --out (else a NOTE and <out>_2.pt2, …)")

    from sspinn.imu import pipeline as imu_import  # sspinn import: vendor IMU files + sensor map → calibrated recording

    imu_import.add_parser(sub)
    from sspinn.estimator import paper_experiments  # sspinn experiment: the paper's claims, arm by arm

    paper_experiments.add_parser(sub)

    args = parser.parse_args(argv)
    if args.command == "showcase":
        from sspinn.model import showcase as demo_mod
        from sspinn.model.body import BodyParameters

        body = BodyParameters.from_yaml(args.body) if args.body else None
        demo_mod.main(args.out, body)
        return 0
    if args.command in ("train", "finetune", "adapt"):
        return _train(args, args.command)
    if args.command == "evaluate":
        return _evaluate(args)
    if args.command == "infer":
        return _infer(args)
    if args.command == "export":
        return _export(args)
    if args.command == "calibrate-quality":
        return _calibrate_quality(args)
    if args.command == "calibrate-uncertainty":
        return _calibrate_uncertainty(args)
    if args.command == "import":
        return imu_import.run(args)
    if args.command == "experiment":
        return paper_experiments.run_command(args)
    raise AssertionError(args.command)  # argparse enforces the sub-commands


if __name__ == "__main__":
    sys.exit(main())
