"""Real 3D IMU exports onto the sagittal recording format: vendor files
(:mod:`~sspinn.imu.vendor_readers`) into a common stream (:mod:`~sspinn.imu.stream`), a sensor map
(:mod:`~sspinn.imu.sensor_map`), calibration onto the sagittal plane
(:mod:`~sspinn.imu.calibration`) with its report (:mod:`~sspinn.imu.calibration_report`) and
cross-sensor checks (:mod:`~sspinn.imu.cross_sensor_checks`), GRF time alignment
(:mod:`~sspinn.imu.time_alignment`) and the import pipeline behind ``sspinn import``
(:mod:`~sspinn.imu.pipeline`)."""
