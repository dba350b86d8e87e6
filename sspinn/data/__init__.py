"""Recordings on disk and in memory: the recording format and its dataset index
(:mod:`~sspinn.data.dataset`), readers of other tabular forms (:mod:`~sspinn.data.csv_readers`)
and of OpenSim files (:mod:`~sspinn.data.opensim_files`), plausibility checks of signals and
labels (:mod:`~sspinn.data.plausibility`), the IMU sensor-noise model
(:mod:`~sspinn.data.sensor_noise`) and the one gait-event detector
(:mod:`~sspinn.data.gait_events`)."""
