"""A trained SSPINNpose network on disk: :func:`save_model` and :func:`load_model`.

A model file (``model.pt`` of a ``sspinn train`` run) is a ``"sspinn-model"`` file of
:mod:`sspinn.torch_files` (the safe, versioned ``.pt`` format) with the entries
:data:`MODEL_ENTRIES`: the network's weights, the hyperparameters that rebuild it
(:class:`~sspinn.estimator.network.SSPINNposeNet`), the IMU segments it reads, the training configuration
(a plain dict) and the per-channel IMU standard deviations, and ``trained_on`` (absent from
the oldest files): the names of the recordings whose IMU signals its self-supervised training saw,
those of the model it was fine-tuned or adapted from included (:func:`trained_on`; evaluation
names the evaluated recordings among them), and ``baselines`` (absent from older files; None when
the training recordings had no labels): the trivial predictors fitted on the labels of the
recordings a training from scratch saw, as plain numbers and strings
(:meth:`~sspinn.estimator.trivial_predictors.TrivialPredictor.to_dict`; a fine-tuned or adapted
model keeps its starting model's), which evaluation compares with. A training checkpoint holds
the same entries and more, so it can be loaded as a model too.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import torch

from sspinn.estimator.network import NetworkConfig, SSPINNposeNet, feature_std_floor
from sspinn.estimator.trivial_predictors import TrivialPredictor
from sspinn.model.conventions import SEGMENTS
from sspinn.torch_files import CHECKPOINT, MODEL, ModelFileError, check_finite_weights, load_torch_file, save_torch_file

#: Entries of a model file (a checkpoint has them too, and can be used as a model).
MODEL_ENTRIES: tuple[str, ...] = ("model", "hyperparameters", "segments", "config", "imu_std")
#: What to do when a model file is unusable (the end of every :class:`ModelFileError` message).
MODEL_HINT = "pass the model.pt (or checkpoint.pt) of a finished `sspinn train` run"


def save_model(
    model: SSPINNposeNet, path: Path, segments: tuple[str, ...], config: dict[str, Any], imu_std: torch.Tensor,
    trained_on: tuple[str, ...] = (), baselines: TrivialPredictor | None = None,
) -> Path:
    """The trained model alone (weights + what is needed to rebuild and run it), written
    atomically in the safe format of :mod:`sspinn.torch_files`; ``config`` is the training
    configuration as a plain dict (``TrainConfig.to_dict()``), ``trained_on`` the names of the
    recordings its training saw, ``baselines`` the trivial predictors of its training data."""
    check_finite_weights(path, model.state_dict(), "training diverged: nothing written")
    return save_torch_file(
        path, MODEL,
        {"model": model.state_dict(), "hyperparameters": model.hyperparameters(), "segments": tuple(segments),
         "config": config, "imu_std": imu_std, "trained_on": tuple(trained_on), "baselines": baselines_entry(baselines)},
    )


def baselines_entry(baselines: TrivialPredictor | None) -> dict[str, Any] | None:
    """The ``baselines`` entry of a model file or checkpoint: plain data, or None."""
    return None if baselines is None else baselines.to_dict()


def read_baselines(state: dict[str, Any], path: Path) -> TrivialPredictor | None:
    """The trivial predictors stored in a model file's or checkpoint's ``state``; None when the
    file has none (older files, unlabelled training data). Raises :class:`ModelFileError` for a
    malformed entry."""
    entry = state.get("baselines")
    if entry is None:
        return None
    try:
        return TrivialPredictor.from_dict(entry)
    except ValueError as exc:
        raise ModelFileError(f"{path}: its baselines entry is damaged ({exc}); {MODEL_HINT}") from None


def trained_on(path: str | Path) -> tuple[str, ...] | None:
    """Names of the recordings whose IMU signals the training of the model (or checkpoint) at
    ``path`` saw, those of the models it started from included; None for a file written before
    the entry existed (unknown)."""
    state = load_torch_file(Path(path), (MODEL, CHECKPOINT), MODEL_ENTRIES, MODEL_HINT)
    names = state.get("trained_on")
    return None if names is None else tuple(str(n) for n in names)


def _network_config(state: dict[str, Any], path: Path) -> tuple[int, NetworkConfig]:
    hp = dict(state["hyperparameters"]) if isinstance(state["hyperparameters"], dict) else {}
    try:
        n_inputs = int(hp.pop("n_inputs"))
        return n_inputs, NetworkConfig(**hp)
    except (KeyError, TypeError, ValueError) as exc:
        raise ModelFileError(f"{path}: unusable network hyperparameters {state['hyperparameters']!r} ({exc}); {MODEL_HINT}") from None


def load_weights(model: SSPINNposeNet, state: dict[str, Any], path: Path) -> None:
    """``model.load_state_dict`` with an error that names the file and both network sizes; the
    input normalisation of files written before :func:`~sspinn.estimator.network.feature_std_floor`
    existed is floored on the way (idempotent for newer files)."""
    try:
        model.load_state_dict(state["model"])
    except (RuntimeError, TypeError, AttributeError) as exc:
        theirs = state.get("hyperparameters")
        raise ModelFileError(
            f"{path}: its network ({theirs}) does not fit this run's ({model.hyperparameters()}): "
            f"{_first_mismatch(exc)}; use the same network settings, or another run folder"
        ) from None
    segments = tuple(state.get("segments", ()))
    if segments and all(s in SEGMENTS for s in segments) and model.n_inputs == len(feature_std_floor(segments)):
        model.set_normalisation(model.input_mean.clone(), model.input_std.clone(), feature_std_floor(segments))


def _first_mismatch(exc: BaseException) -> str:
    """The first specific line of a ``load_state_dict`` error (e.g. "size mismatch for ...")."""
    lines = [line.strip().rstrip(".") for line in str(exc).splitlines() if line.strip()]
    specific = [line for line in lines if not line.startswith("Error(s) in loading")]
    return (specific or lines or [type(exc).__name__])[0]


@dataclass(frozen=True)
class StoredModel:
    """A trained SSPINNpose network as read from one model file (or checkpoint).

    Attributes:
        network: the network, in eval mode, on the device it was loaded to.
        segments: the IMU segments it reads, in input order.
        config: its training configuration as saved (a plain dict of ``TrainConfig`` fields).
        imu_std: (n_segments, 3) per-channel IMU standard deviations of its training data
            (specific force m/s², angular rate rad/s), the scale of the IMU loss.
        trained_on: names of the recordings whose IMU signals its training saw (those of the
            models it started from included); ``None`` for files written before the entry existed.
        path: the file it was read from.
        baselines: the trivial predictors fitted on its training data's labels; ``None`` for
            files written before the entry existed or trained on unlabelled recordings.
    """

    network: SSPINNposeNet
    segments: tuple[str, ...]
    config: dict[str, Any]
    imu_std: torch.Tensor
    trained_on: tuple[str, ...] | None
    path: Path
    baselines: TrivialPredictor | None = None


def load_model(path: str | Path, device: str | torch.device = "cpu") -> StoredModel:
    """Rebuild a saved model (the file is read once). Raises :class:`ModelFileError` naming the
    file and what is wrong with it."""
    path = Path(path)
    state = load_torch_file(path, (MODEL, CHECKPOINT), MODEL_ENTRIES, MODEL_HINT, device)
    n_inputs, net_config = _network_config(state, path)
    model = SSPINNposeNet(n_inputs, net_config)
    load_weights(model, state, path)
    check_finite_weights(path, model.state_dict(), "the model is damaged or its training diverged: retrain it")
    segments = tuple(state["segments"])
    unknown = [s for s in segments if s not in SEGMENTS]
    if unknown or not isinstance(state["config"], dict):
        raise ModelFileError(f"{path}: unknown IMU segments {unknown} or a damaged config entry; {MODEL_HINT}")
    model.to(device).eval()
    names = state.get("trained_on")
    return StoredModel(
        network=model, segments=segments, config=state["config"], imu_std=torch.as_tensor(state["imu_std"]),
        trained_on=None if names is None else tuple(str(n) for n in names), path=path,
        baselines=read_baselines(state, path),
    )


# ------------------------------------------------------------------------------------------ export
class StreamingStep(torch.nn.Module):
    """One time step of a unidirectional network with its LSTM state carried by the caller:
    ``(x (B, F), h (L, B, H), c (L, B, H)) → (raw outputs (B, n_outputs), h, c)`` (L LSTM layers of H
    units). The form a real-time system runs, and the form :func:`export_streaming` exports."""

    def __init__(self, model: SSPINNposeNet) -> None:
        super().__init__()
        if model.config.bidirectional:
            raise ValueError("a bidirectional network needs the whole recording: only unidirectional ones stream")
        self.model = model

    def forward(self, x: torch.Tensor, h: torch.Tensor, c: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        y, (h, c) = self.model(x.unsqueeze(1), (h, c))
        return y.squeeze(1), h, c

    def initial_state(self, batch: int = 1) -> tuple[torch.Tensor, torch.Tensor]:
        """The zero LSTM state (h, c) of a recording's first sample."""
        cfg = self.model.config
        zeros = torch.zeros(cfg.layers, batch, cfg.hidden)
        return zeros, zeros.clone()


def export_streaming(model: SSPINNposeNet, path: str | Path) -> Path:
    """Export :class:`StreamingStep` of ``model`` with ``torch.export`` (the maintained export
    API; ``torch.jit.trace`` is deprecated) into a ``.pt2`` program, the batch size dynamic.

    Why one step and not a whole sequence: ``torch.export`` specialises an ``nn.LSTM``'s sequence
    length to the example's (measured with torch 2.13), and the step is what a streaming system
    runs; :func:`run_exported` loops it over a recording. Load with
    ``torch.export.load(path).module()``; no sspinn code is needed to run it.
    """
    import warnings

    path = Path(path)
    step = StreamingStep(model).eval()
    h, c = step.initial_state(2)
    dynamic = torch.export.Dim.AUTO
    with warnings.catch_warnings():  # nn.LSTM re-assigns its flat weights while traced: harmless
        warnings.filterwarnings("ignore", message="The tensor attributes self.model.lstm._flat_weights")
        program = torch.export.export(
            step, (torch.zeros(2, model.n_inputs), h, c),
            dynamic_shapes={"x": {0: dynamic}, "h": {1: dynamic}, "c": {1: dynamic}}, strict=False,
        )
    path.parent.mkdir(parents=True, exist_ok=True)
    torch.export.save(program, str(path))
    return path


def run_exported(step: torch.nn.Module, x: torch.Tensor, layers: int, hidden: int) -> torch.Tensor:
    """Raw outputs (B, T, n_outputs) of an exported (or eager) :class:`StreamingStep` over inputs
    x (B, T, F), from the zero state: the same as the network's forward pass on x."""
    h = torch.zeros(layers, x.shape[0], hidden)
    c = torch.zeros_like(h)
    outputs = []
    for t in range(x.shape[1]):
        y, h, c = step(x[:, t], h, c)
        outputs.append(y)
    return torch.stack(outputs, dim=1)
