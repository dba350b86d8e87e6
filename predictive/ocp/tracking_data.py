"""Data → tracked signals: recordings and solutions resampled to the collocation nodes.

:func:`signals_from_recording` turns named IMU channels or label columns of a recording (the first
stride, starting at t = 0) into :class:`~predictive.ocp.tracking.TrackedSignal` s at the node
times t_k = k·T/N by periodic linear interpolation (:func:`resample_periodic`), with default
scales (the data's standard deviation over the cycle, floored) or given ones such as the
across-trial standard deviation of an averaged stride (:func:`averaged_stride_scales`);
:func:`signals_from_solution` computes them from a gait solution (synthetic tests).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from predictive.ocp.solution import GaitSolution
from predictive.ocp.tracking import MIN_SCALES, SIGNAL_KINDS, TrackedSignal, default_scale, signal_function
from sspinn.data.dataset import Recording
from sspinn.model.body import IMUPlacement
from sspinn.model.conventions import GRAVITY, GRF, IMU_CHANNELS


def stride_duration(recording: Recording) -> float:
    """The stride duration of an averaged-stride recording (``provenance['stride_duration_s']``,
    s), else the recording's duration."""
    return float(recording.provenance.get("stride_duration_s", recording.duration))


def recording_signal(recording: Recording, name: str) -> np.ndarray:
    """(n_samples,) one named signal of a recording (IMU channel or label column), SI units."""
    if SIGNAL_KINDS.get(name, ("",))[0] == "imu":
        seg, ch = name.rsplit("_", 2)[0], "_".join(name.rsplit("_", 2)[1:])
        if seg not in recording.segments:
            raise KeyError(f"{recording.name}: no IMU on {seg}; available: {list(recording.segments)}")
        return recording.imu[:, recording.segments.index(seg), IMU_CHANNELS.index(ch)]
    if recording.labels is None:
        raise KeyError(f"{recording.name}: no labels, so no {name!r}")
    return recording.labels.column(name)


def resample_periodic(values: np.ndarray, time: np.ndarray, duration: float, n_nodes: int) -> np.ndarray:
    """Values sampled at ``time`` (s, within one period starting at 0) at the node times
    k·duration/n_nodes, by periodic linear interpolation (period ``duration``)."""
    keep = time < duration - 1e-9
    return np.interp(np.arange(n_nodes) * duration / n_nodes, time[keep], np.asarray(values)[keep], period=duration)


def signals_from_recording(
    recording: Recording,
    names: Sequence[str],
    n_nodes: int,
    *,
    duration: float | None = None,
    scales: Mapping[str, float | np.ndarray] | None = None,
    weights: Mapping[str, float] | None = None,
) -> list[TrackedSignal]:
    """Tracked signals from the first stride of a recording (starting at t = 0).

    Args:
        recording: e.g. :func:`sspinn.data.csv_readers.read_averaged_stride`.
        names: signal names (:data:`SIGNAL_KINDS`; IMU channels or label columns).
        n_nodes: collocation nodes per cycle.
        duration: stride duration, s (default :func:`stride_duration`).
        scales: per-signal scale (scalar, or (n_nodes,) at the nodes); default :func:`default_scale`.
        weights: per-signal weight (default 1).
    """
    T = stride_duration(recording) if duration is None else duration
    scales = scales or {}
    weights = weights or {}
    out = []
    for name in names:
        target = resample_periodic(recording_signal(recording, name), recording.time, T, n_nodes)
        scale = scales.get(name, default_scale(name, target))
        out.append(TrackedSignal(name, target, scale, float(weights.get(name, 1.0))))
    return out


def averaged_stride_scales(
    folder: str | Path, names: Sequence[str], n_nodes: int, mass: float | None = None
) -> dict[str, np.ndarray]:
    """Across-trial standard deviations of an averaged stride (``variance.csv`` next to
    ``signals.csv``, as in ``$SSPINN_SHARED_DATA/dorschky_P03_walking``) at the node times, floored at
    :data:`MIN_SCALES`: the normalisation of Dorschky et al. (2019), who divided the tracking
    errors by the intertrial variance.

    ``names`` are IMU channels (``<segment>_acc_x`` …) or GRFs (``grf_x_r`` …, converted from BW
    to N with ``mass`` in kg). The file's N rows span one stride (``meta.json``'s
    ``stride_duration_s``) and are interpolated periodically to ``n_nodes`` nodes.
    """
    folder = Path(folder)
    path = folder / "variance.csv"
    if not path.exists():
        raise FileNotFoundError(f"{path}: no across-trial variance for this averaged stride")
    with path.open() as fh:
        header = [c.strip() for c in fh.readline().strip().split(",")]
    var = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    n_file = var.shape[0]
    frac = np.arange(n_nodes) / n_nodes
    out: dict[str, np.ndarray] = {}
    for name in names:
        if name not in header:
            raise KeyError(f"{path}: no column {name!r}")
        std = np.sqrt(np.clip(var[:, header.index(name)], 0.0, None))
        if name in GRF:
            if mass is None:
                raise ValueError(f"{name}: the mass is needed to convert BW to N")
            std = std * mass * GRAVITY
        std = np.interp(frac, np.arange(n_file) / n_file, std, period=1.0)
        out[name] = np.maximum(std, MIN_SCALES[SIGNAL_KINDS[name][1]])
    return out


def signals_from_solution(
    sol: GaitSolution, names: Sequence[str], placement: IMUPlacement | None = None
) -> list[TrackedSignal]:
    """Tracked signals computed from a gait solution at its own nodes (for synthetic tests):
    the signals of :func:`signal_function` with the solution's body, scales
    :func:`default_scale`."""
    fun = signal_function(names, sol.body, placement).map(sol.n_nodes)
    y = np.asarray(fun(sol.q.T, sol.u.T, sol.qdd.T, sol.tau.T, sol.grf.T)).T
    return [TrackedSignal(n, y[:, i], default_scale(n, y[:, i])) for i, n in enumerate(names)]
