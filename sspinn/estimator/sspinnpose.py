"""SSPINNpose as one estimator object: configure, ``fit`` or ``load``, ``adapt``, ``predict``.

In the style of gaitmap and scikit-learn: the constructor only stores settings; the action
methods (:meth:`SSPINNpose.fit`, :meth:`SSPINNpose.adapt`) return the estimator itself and leave
their results in attributes with a trailing underscore (``network_``, ``segments_``,
``config_``, ``trained_on_``, ``steps_``, ``stopped_by_``); :meth:`SSPINNpose.predict` returns a
:class:`~sspinn.estimator.inference.GaitEstimate`.

>>> import sspinn
>>> est = sspinn.SSPINNpose.load("models/pretrained/model.pt")        # doctest: +SKIP
>>> [rec] = sspinn.open_recordings("my_data/walk.csv")                # doctest: +SKIP
>>> estimate = est.predict(rec)                                      # doctest: +SKIP
>>> estimate.tau, estimate.grf, estimate.u[:, 0]   # torques N·m, GRFs N, speed m/s   # doctest: +SKIP

Training writes its run folder (checkpoints, TensorBoard, ``model.pt``) through
:class:`~sspinn.estimator.training.Trainer`; without ``out`` it trains in a temporary folder and
keeps only the model in memory (save it with :meth:`SSPINNpose.save`).
"""

from __future__ import annotations

import contextlib
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import torch

from sspinn.data.dataset import Recording
from sspinn.data.signal_checks import check_recording, estimate_findings, warn
from sspinn.errors import UserError
from sspinn.estimator.inference import GaitEstimate, StreamingEstimator, estimate_recording
from sspinn.estimator.model_store import StoredModel, export_streaming, load_model, save_model
from sspinn.estimator.network import SSPINNposeNet
from sspinn.estimator.quality import WindowQuality, window_quality
from sspinn.estimator.training import TrainConfig, Trainer, adaptation_config
from sspinn.estimator.trivial_predictors import TrivialPredictor
from sspinn.estimator.uncertainty import UncertaintyCalibration, intervals
from sspinn.yaml_config import shipped_path

#: The repository's named training configurations (``configs/sspinn/<name>.yaml``), found from
#: the installed package rather than the working directory.
CONFIG_DIR = shipped_path("configs/sspinn")


class NotFittedError(UserError):
    """The estimator has no trained network yet: ``fit`` it or ``load`` one."""


def resolve_train_config(config: TrainConfig | str | Path | None, settings: Sequence[str] = (), **overrides: Any) -> TrainConfig:
    """A :class:`TrainConfig` from a config object, a YAML path, or the name of one of the
    repository's configurations (``"demo"``, ``"smoke"``, ``"paper"``); ``None`` is ``"demo"``.
    A relative path that does not exist in the working directory is looked up in
    :data:`CONFIG_DIR` by its file name, so the defaults work from any folder."""
    if isinstance(config, TrainConfig):
        return config
    path = Path(config if config is not None else "demo")
    if not path.suffix:
        path = CONFIG_DIR / f"{path}.yaml"
    elif not path.is_absolute() and not path.exists() and (CONFIG_DIR / path.name).exists() and path.parent.name == "sspinn":
        path = CONFIG_DIR / path.name
    return TrainConfig.from_yaml(path, settings=list(settings), **overrides)


class SSPINNpose:
    """Self-supervised physics-informed estimation of sagittal gait from IMUs.

    Args:
        config: training settings: a :class:`~sspinn.estimator.training.TrainConfig`, a YAML
            path, or a configuration name (``"demo"``, the CPU-sized default; ``"paper"``;
            ``"smoke"``).
        device: ``"cpu"``, ``"cuda"``, ``"cuda:1"`` … for prediction and adaptation (training
            uses the config's ``device``).
        load_transfer: ``predict`` moves the vertical GRF of each double support from the trailing
            to the leading foot at a constant rate, the torques following
            (:func:`~sspinn.estimator.load_transfer.linear_load_transfer`; offline analysis: on real
            walkers it lowers the GRF error, on the synthetic gaits it raises it).

    Attributes (set by ``fit``, ``adapt`` or ``load``):
        network_: the trained :class:`~sspinn.estimator.network.SSPINNposeNet` (eval mode).
        segments_: the IMU segments it reads, in input order.
        config_: the :class:`TrainConfig` it was trained with.
        imu_std_: (n_segments, 3) IMU standard deviations of its training data (m/s², rad/s).
        trained_on_: names of the recordings whose IMU signals its training saw.
        baselines_: the trivial predictors fitted on its training data's labels
            (:class:`~sspinn.estimator.trivial_predictors.TrivialPredictor`), stored in the model
            file; None for older files and unlabelled training data.
        steps_: optimiser steps of the last ``fit``/``adapt`` (None after ``load``).
        stopped_by_: ``"steps"`` or ``"time_limit"`` for the last ``fit``/``adapt``.
        path_: the model file it was loaded from or last saved to.
    """

    def __init__(self, config: TrainConfig | str | Path | None = None, device: str = "cpu", load_transfer: bool = False) -> None:
        self.config = config
        self.device = device
        self.load_transfer = load_transfer

    # ------------------------------------------------------------------ construction
    @classmethod
    def load(cls, path: str | Path, device: str = "cpu", load_transfer: bool = False) -> SSPINNpose:
        """An estimator from a model file (``model.pt`` of a run, or a shipped model); ``load_transfer``
        as in the constructor."""
        est = cls(device=device, load_transfer=load_transfer)
        est._set(load_model(path, device), steps=None, stopped_by=None)
        return est

    def _set(self, stored: StoredModel, steps: int | None, stopped_by: str | None) -> None:
        self.network_: SSPINNposeNet = stored.network
        self.segments_: tuple[str, ...] = stored.segments
        self.config_: TrainConfig = resolve_train_config_from_dict(stored.config, str(stored.path))
        self.imu_std_: torch.Tensor = stored.imu_std
        self.trained_on_: tuple[str, ...] = stored.trained_on or ()
        self.baselines_: TrivialPredictor | None = stored.baselines
        self.steps_ = steps
        self.stopped_by_ = stopped_by
        self.path_: Path = stored.path
        self._stored = stored

    @property
    def stored_(self) -> StoredModel:
        """The trained model as a :class:`StoredModel` (what a model file holds)."""
        self._check_fitted()
        return self._stored

    def _check_fitted(self) -> None:
        if not hasattr(self, "network_"):
            raise NotFittedError("this SSPINNpose has no trained network: call fit(recordings) or SSPINNpose.load(path)")

    # ------------------------------------------------------------------ actions
    def fit(self, recordings: Sequence[Recording], out: str | Path | None = None, resume: bool = False) -> SSPINNpose:
        """Train self-supervised on ``recordings`` (their labels are never read). ``out`` is the
        run folder (checkpoints, TensorBoard, ``model.pt``; ``resume`` continues an interrupted
        run there); without it the run uses a temporary folder and only the model is kept."""
        config = resolve_train_config(self.config)
        return self._train(config, recordings, out, resume=resume, init_from=None)

    def adapt(
        self, recordings: Sequence[Recording], out: str | Path | None = None, resume: bool = False,
        settings: Sequence[str] = (), **overrides: Any,
    ) -> SSPINNpose:
        """Adapt the trained network to new, unlabeled recordings (a new subject's): its own
        configuration, :data:`~sspinn.estimator.training.ADAPT_STEPS` steps at a low constant
        rate, no input noise (:func:`~sspinn.estimator.training.adaptation_config`;
        ``overrides`` such as ``steps=``, ``lr=``, ``threads=`` and ``settings`` change it)."""
        self._check_fitted()
        config = adaptation_config(self._stored.config, str(self.path_), list(settings), **overrides)
        return self._train(config, recordings, out, resume=resume, init_from=None if resume else self._stored)

    def finetune(self, recordings: Sequence[Recording], out: str | Path | None = None, resume: bool = False) -> SSPINNpose:
        """Continue training the trained network with the fine-tuning weights (the paper's
        L_K, L_T and contact terms × 10), with this estimator's ``config``."""
        self._check_fitted()
        config = resolve_train_config(self.config)
        config.finetune = True
        return self._train(config, recordings, out, resume=resume, init_from=None if resume else self._stored)

    def _train(self, config: TrainConfig, recordings: Sequence[Recording], out: str | Path | None, resume: bool,
               init_from: StoredModel | None) -> SSPINNpose:
        for rec in recordings:
            check_recording(rec, rec.name)
        with tempfile.TemporaryDirectory(prefix="sspinn-run-") if out is None else contextlib.nullcontext(out) as folder:
            trainer = Trainer(config, folder)
            network = trainer.fit(list(recordings), resume=resume, init_from=init_from)
        # the trained network as model.pt holds it (every rank under torchrun has it; only rank 0 writes)
        stored = StoredModel(
            network=network.to(self.device).eval(), segments=trainer.segments, config=trainer.config.to_dict(),
            imu_std=trainer.imu_std, trained_on=trainer.trained_on,
            path=Path(folder) / "model.pt" if out is not None else Path("<memory>"), baselines=trainer.baselines,
        )
        self._set(stored, steps=trainer.step, stopped_by=trainer.stopped_by)
        return self

    def predict(self, recording: Recording) -> GaitEstimate:
        """Estimates of one recording: coordinates, rates, accelerations, joint torques, GRFs,
        contact (:class:`~sspinn.estimator.inference.GaitEstimate`; the forward speed is
        ``u[:, 0]``). Raises a one-line error for missing IMUs or non-finite/implausible output; warns
        (:mod:`sspinn.data.signal_checks`) about implausible input signals and an implausible estimate."""
        self._check_fitted()
        check_recording(recording, recording.name)
        estimate = estimate_recording(self.network_, recording, self.segments_, load_transfer=self.load_transfer)
        warn(estimate_findings(recording.name, estimate.grf[:, 1] + estimate.grf[:, 3], estimate.u[:, 0], recording.imu,
                               recording.segments, recording.height, recording.mass))
        return estimate

    def quality(self, recording: Recording) -> WindowQuality:
        """The self-supervised loss terms of the estimate of ``recording`` per window, computed
        on the recording itself (:func:`~sspinn.estimator.quality.window_quality`; no labels);
        score and flags come from a calibration (:meth:`~sspinn.estimator.quality.QualityCalibration.apply`)."""
        self._check_fitted()
        return window_quality(self.network_, recording, self.segments_, self.imu_std_, self.config_.joint_limits)

    def intervals(self, recording: Recording, calibration: UncertaintyCalibration) -> np.ndarray:
        """(T, n_channels) half-widths of the calibrated intervals of the estimate of
        ``recording``, per channel of :data:`sspinn.estimator.uncertainty.CHANNELS` (rad, N·m, N,
        m/s); the calibration comes from ``sspinn calibrate-uncertainty`` (its file:
        :func:`sspinn.estimator.uncertainty.load_calibration`)."""
        self._check_fitted()
        return intervals(calibration, self.network_, self.segments_, recording)

    def stream(self, height: float, mass: float) -> StreamingEstimator:
        """A sample-by-sample estimator for one subject (height m, mass kg) with a carried LSTM
        state (:class:`~sspinn.estimator.inference.StreamingEstimator`)."""
        self._check_fitted()
        return StreamingEstimator(self.network_, self.segments_, height, mass)

    def save(self, path: str | Path) -> Path:
        """Write the model file (atomically, safe format) and return its path."""
        self._check_fitted()
        path = save_model(self.network_, Path(path), self.segments_, self._stored.config, self.imu_std_, self.trained_on_,
                          self.baselines_)
        self.path_ = path
        return path

    def export(self, path: str | Path) -> Path:
        """A ``torch.export`` program of one streaming step (``.pt2``)."""
        self._check_fitted()
        return export_streaming(self.network_, path)

    def __repr__(self) -> str:
        state = f"trained on {len(self.trained_on_)} recording(s), IMUs {list(self.segments_)}" if hasattr(self, "network_") else "not fitted"
        return f"SSPINNpose(config={self.config!r}, device={self.device!r}; {state})"


def resolve_train_config_from_dict(data: dict[str, Any], source: str) -> TrainConfig:
    """The :class:`TrainConfig` saved in a model file (a plain dict)."""
    from sspinn.yaml_config import config_from_mapping

    return config_from_mapping(TrainConfig, data, source, what="train option")

