"""Training flushes subnormal floats to zero and gives the caller's setting back."""

from __future__ import annotations

import numpy as np
import torch

from sspinn.estimator.training import TrainConfig, Trainer, denormals_flushed

SUBNORMAL = 1e-39  # below float32's smallest normal number, 1.18e-38


def flushing() -> bool:
    """Whether this thread's float32 arithmetic turns a subnormal into 0."""
    return float(torch.tensor([SUBNORMAL], dtype=torch.float64).to(torch.float32)[0] * 2.0) == 0.0


def test_inside_subnormals_are_zero_and_the_setting_is_restored() -> None:
    assert not flushing()
    with denormals_flushed():
        assert flushing()
    assert not flushing()
    assert np.float32(SUBNORMAL) * np.float32(2.0) > 0  # NumPy after it: as before


def test_a_caller_that_flushes_already_keeps_flushing() -> None:
    torch.set_flush_denormal(True)
    try:
        with denormals_flushed():
            assert flushing()
        assert flushing()
    finally:
        torch.set_flush_denormal(False)
    assert not flushing()


def test_training_flushes_while_it_runs_and_not_after(tiny_run, tmp_path, monkeypatch) -> None:
    _, _, cfg, train, _ = tiny_run
    seen: list[bool] = []
    real_step = torch.optim.Adam.step

    def step(self, *args, **kwargs):
        seen.append(flushing())
        return real_step(self, *args, **kwargs)

    monkeypatch.setattr(torch.optim.Adam, "step", step)
    Trainer(TrainConfig.from_yaml(cfg, steps=2), tmp_path / "run").fit(train)
    assert seen == [True, True]
    assert not flushing()
