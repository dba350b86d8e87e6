"""torchrun launches the same training with DistributedDataParallel (2 CPU processes, gloo)."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest
import torch
import yaml

from sspinn.data.dataset import Dataset
from sspinn.testing import make_recording


@pytest.mark.slow
def test_torchrun_two_cpu_processes(tmp_path):
    rng = np.random.default_rng(5)
    data = tmp_path / "data"
    Dataset.write(data, {"train": [make_recording("a", "s1", 120, rng), make_recording("b", "s2", 120, rng)]})
    cfg = tmp_path / "tiny.yaml"
    cfg.write_text(yaml.safe_dump({"train": {
        "network": {"hidden": 8, "layers": 1, "dropout": 0.0, "dense": 8}, "steps": 3, "batch_size": 2, "window": 32,
        "log_every": 1, "checkpoint_every": 10, "device": "cpu", "threads": 1,
    }}))
    out = tmp_path / "run"
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    cmd = [sys.executable, "-m", "torch.distributed.run", "--standalone", "--nproc_per_node", "2",
           "-m", "sspinn", "train", "--config", str(cfg), "--data", str(data), "--out", str(out)]
    result = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=300)
    assert result.returncode == 0, result.stderr[-3000:]
    state = torch.load(out / "checkpoint.pt", weights_only=False)
    assert state["world_size"] == 2 and state["step"] == 3
    assert (out / "model.pt").exists()
