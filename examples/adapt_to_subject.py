"""Adapt the shipped model, self-supervised, to one subject's unlabeled recording, then estimate again.

    python examples/adapt_to_subject.py [--quick]

Adaptation reads the IMU signals only (never labels): 1,000 steps by default; --quick: 3 steps, uncompiled.
"""

import sys
import tempfile
from pathlib import Path

import numpy as np

import sspinn

ROOT = Path(__file__).resolve().parents[1]
quick = {"steps": 3, "compile": False} if "--quick" in sys.argv else {}

estimator = sspinn.SSPINNpose.load(ROOT / "models" / "pretrained" / "model.pt")
recording = sspinn.open_recordings(ROOT / "models" / "pretrained" / "example_walk.csv")[0]
before = estimator.predict(recording)

with tempfile.TemporaryDirectory() as run:
    adapted = estimator.adapt([recording], out=run, threads=1, **quick)
    adapted.save(Path(run) / "adapted.pt")
    after = sspinn.SSPINNpose.load(Path(run) / "adapted.pt").predict(recording)

change = np.degrees(np.abs(after.q[:, 3:] - before.q[:, 3:]).mean())
print(f"adapted for {adapted.steps_} steps on {recording.name}: mean joint-angle change {change:.2f}°")
