"""Real 3D IMU exports onto the sagittal recording format: vendor files
(:mod:`~sspinn.imu.vendor_readers`) into a common stream (:mod:`~sspinn.imu.stream`), a sensor map
(:mod:`~sspinn.imu.sensor_map`), calibration onto the sagittal plane
(:mod:`~sspinn.imu.calibration`) with its report (:mod:`~sspinn.imu.calibration_report`) and
cross-sensor checks (:mod:`~sspinn.imu.cross_sensor_checks`), GRF time alignment
(:mod:`~sspinn.imu.time_alignment`) and the import pipeline behind ``sspinn import``
(:mod:`~sspinn.imu.pipeline`)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from sspinn.lazy_exports import attach

#: public name → the module that defines it (imported on first use)
_EXPORTS: dict[str, str] = {
    **dict.fromkeys(("ImportResult", "import_imu",), "sspinn.imu.pipeline"),
    **dict.fromkeys(("Calibration", "SensorCalibrationError", "calibrate",), "sspinn.imu.calibration"),
    **dict.fromkeys(("SensorMap", "SensorMapError",), "sspinn.imu.sensor_map"),
    **dict.fromkeys(("IMUImportError", "IMUStream",), "sspinn.imu.stream"),
    **dict.fromkeys(("read_imu_files",), "sspinn.imu.vendor_readers"),
    **dict.fromkeys(("Alignment", "AlignmentError", "align_to_grf",), "sspinn.imu.time_alignment"),
}
__all__ = [
    "Alignment",
    "AlignmentError",
    "Calibration",
    "IMUImportError",
    "IMUStream",
    "ImportResult",
    "SensorCalibrationError",
    "SensorMap",
    "SensorMapError",
    "align_to_grf",
    "calibrate",
    "import_imu",
    "read_imu_files",
]

if TYPE_CHECKING:  # the names for type checkers and editors; imported on first use at run time
    from sspinn.imu.calibration import Calibration, SensorCalibrationError, calibrate
    from sspinn.imu.pipeline import ImportResult, import_imu
    from sspinn.imu.sensor_map import SensorMap, SensorMapError
    from sspinn.imu.stream import IMUImportError, IMUStream
    from sspinn.imu.time_alignment import Alignment, AlignmentError, align_to_grf
    from sspinn.imu.vendor_readers import read_imu_files

__getattr__, __dir__ = attach(__name__, _EXPORTS)
