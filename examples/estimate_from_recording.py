"""Estimate joint angles, torques, ground reaction forces and speed from one IMU recording.

    python examples/estimate_from_recording.py [RECORDING.csv]

Uses the shipped model (models/pretrained/model.pt) and, by default, its 10-s example walk.
"""

import sys
from pathlib import Path

import numpy as np

import sspinn

ROOT = Path(__file__).resolve().parents[1]
recording_path = sys.argv[1] if len(sys.argv) > 1 else ROOT / "models" / "pretrained" / "example_walk.csv"

estimator = sspinn.SSPINNpose.load(ROOT / "models" / "pretrained" / "model.pt")
recording = sspinn.open_recordings(recording_path)[0]
estimate = estimator.predict(recording)

knee = np.degrees(estimate.q[:, 4])  # knee_r, rad → ° (flexion negative: sspinn.model.conventions)
print(f"{recording.name}: {recording.n_samples} samples at 100 Hz, {recording.height} m, {recording.mass} kg")
print(f"right knee angle: {knee.min():.1f}° to {knee.max():.1f}°")
print(f"peak vertical GRF, right foot: {estimate.grf[:, 1].max() / (recording.mass * 9.81):.2f} BW")
print(f"mean forward speed: {estimate.u[:, 0].mean():.2f} m/s")
