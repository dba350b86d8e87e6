"""A trained SSPINNpose network on disk: :func:`save_model` and :func:`load_model`.

A model file (``model.pt`` of a ``sspinn train`` run) is a ``"sspinn-model"`` file of
:mod:`sspinn.model_file` (the safe, versioned ``.pt`` format) with the entries
:data:`MODEL_ENTRIES`: the network's weights, the hyperparameters that rebuild it
(:class:`~sspinn.network.SSPINNposeNet`), the IMU segments it reads, the training configuration
(a plain dict) and the per-channel IMU standard deviations. A training checkpoint holds the same
entries and more, so it can be loaded as a model too.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import torch

from sspinn.conventions import SEGMENTS
from sspinn.model_file import CHECKPOINT, MODEL, ModelFileError, check_finite_weights, load_torch_file, save_torch_file
from sspinn.network import NetworkConfig, SSPINNposeNet

#: Entries of a model file (a checkpoint has them too, and can be used as a model).
MODEL_ENTRIES: tuple[str, ...] = ("model", "hyperparameters", "segments", "config", "imu_std")
#: What to do when a model file is unusable (the end of every :class:`ModelFileError` message).
MODEL_HINT = "pass the model.pt (or checkpoint.pt) of a finished `sspinn train` run"


def save_model(
    model: SSPINNposeNet, path: Path, segments: tuple[str, ...], config: dict[str, Any], imu_std: torch.Tensor
) -> Path:
    """The trained model alone (weights + what is needed to rebuild and run it), written
    atomically in the safe format of :mod:`sspinn.model_file`; ``config`` is the training
    configuration as a plain dict (``TrainConfig.to_dict()``)."""
    check_finite_weights(path, model.state_dict(), "training diverged: nothing written")
    return save_torch_file(
        path, MODEL,
        {"model": model.state_dict(), "hyperparameters": model.hyperparameters(), "segments": tuple(segments),
         "config": config, "imu_std": imu_std},
    )


def _network_config(state: dict[str, Any], path: Path) -> tuple[int, NetworkConfig]:
    hp = dict(state["hyperparameters"]) if isinstance(state["hyperparameters"], dict) else {}
    try:
        n_inputs = int(hp.pop("n_inputs"))
        return n_inputs, NetworkConfig(**hp)
    except (KeyError, TypeError, ValueError) as exc:
        raise ModelFileError(f"{path}: unusable network hyperparameters {state['hyperparameters']!r} ({exc}); {MODEL_HINT}") from None


def load_weights(model: SSPINNposeNet, state: dict[str, Any], path: Path) -> None:
    """``model.load_state_dict`` with an error that names the file and both network sizes."""
    try:
        model.load_state_dict(state["model"])
    except (RuntimeError, TypeError, AttributeError) as exc:
        theirs = state.get("hyperparameters")
        raise ModelFileError(
            f"{path}: its network ({theirs}) does not fit this run's ({model.hyperparameters()}): "
            f"{_first_mismatch(exc)}; use the same network settings, or another run folder"
        ) from None


def _first_mismatch(exc: BaseException) -> str:
    """The first specific line of a ``load_state_dict`` error (e.g. "size mismatch for ...")."""
    lines = [line.strip().rstrip(".") for line in str(exc).splitlines() if line.strip()]
    specific = [line for line in lines if not line.startswith("Error(s) in loading")]
    return (specific or lines or [type(exc).__name__])[0]


def load_model(path: str | Path, device: str | torch.device = "cpu") -> tuple[SSPINNposeNet, tuple[str, ...], dict[str, Any]]:
    """Rebuild a saved model: (model in eval mode, IMU segments, training config dict).
    Raises :class:`ModelFileError` naming the file and what is wrong with it."""
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
    return model, segments, state["config"]
