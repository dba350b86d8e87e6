"""Recordings on disk and in memory: the recording format and its dataset index
(:mod:`~sspinn.data.dataset`), readers of other tabular forms (:mod:`~sspinn.data.csv_readers`)
and of OpenSim files (:mod:`~sspinn.data.opensim_files`), plausibility checks of signals and
labels (:mod:`~sspinn.data.plausibility`), the IMU sensor-noise model
(:mod:`~sspinn.data.sensor_noise`) and the one gait-event detector
(:mod:`~sspinn.data.gait_events`)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from sspinn.lazy_exports import attach

#: public name → the module that defines it (imported on first use)
_EXPORTS: dict[str, str] = {
    **dict.fromkeys(("Dataset", "DataFormatError", "Labels", "Recording", "SAMPLE_RATE_HZ", "SPLITS",), "sspinn.data.dataset"),
    **dict.fromkeys(("open_recordings", "dataset_recordings", "labelled_recordings",), "sspinn.data.loading"),
    **dict.fromkeys(("read_csv_recording", "read_averaged_stride",), "sspinn.data.csv_readers"),
    **dict.fromkeys(("IMUErrorModel", "measure_imu",), "sspinn.data.sensor_noise"),
    **dict.fromkeys(("GaitEvents", "detect_events",), "sspinn.data.gait_events"),
    **dict.fromkeys(("grf_inputs",), "sspinn.data.measured_loads"),
    **dict.fromkeys(("ImplausibleRecordingError",), "sspinn.data.plausibility"),
    **dict.fromkeys(("ImpossibleSignalError", "SignalWarning", "check_recording",), "sspinn.data.signal_checks"),
}
__all__ = [
    "DataFormatError",
    "Dataset",
    "GaitEvents",
    "IMUErrorModel",
    "ImplausibleRecordingError",
    "ImpossibleSignalError",
    "Labels",
    "Recording",
    "SAMPLE_RATE_HZ",
    "SPLITS",
    "SignalWarning",
    "check_recording",
    "dataset_recordings",
    "detect_events",
    "grf_inputs",
    "labelled_recordings",
    "measure_imu",
    "open_recordings",
    "read_averaged_stride",
    "read_csv_recording",
]

if TYPE_CHECKING:  # the names for type checkers and editors; imported on first use at run time
    from sspinn.data.csv_readers import read_averaged_stride, read_csv_recording
    from sspinn.data.dataset import SAMPLE_RATE_HZ, SPLITS, DataFormatError, Dataset, Labels, Recording
    from sspinn.data.gait_events import GaitEvents, detect_events
    from sspinn.data.loading import dataset_recordings, labelled_recordings, open_recordings
    from sspinn.data.measured_loads import grf_inputs
    from sspinn.data.plausibility import ImplausibleRecordingError
    from sspinn.data.sensor_noise import IMUErrorModel, measure_imu
    from sspinn.data.signal_checks import ImpossibleSignalError, SignalWarning, check_recording

__getattr__, __dir__ = attach(__name__, _EXPORTS)
