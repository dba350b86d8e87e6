"""One model for any subset of its IMUs: training with ``sensor_dropout`` gives the network
presence flags; a missing IMU's values cannot reach the network; such a model estimates (and
scores its quality) from a recording with fewer IMUs, while a model without flags refuses one
with a one-line error."""

from __future__ import annotations

import contextlib
import io

import numpy as np
import pytest
import torch
import yaml

from sspinn.data.dataset import DataFormatError, Dataset
from sspinn.estimator.network import NetworkConfig, SSPINNposeNet
from sspinn.estimator.quality import window_quality
from sspinn.estimator.sspinnpose import SSPINNpose
from sspinn.estimator.training import TrainConfig, Trainer
from sspinn.testing import tiny_run


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory):
    """The tiny run of sspinn.testing (no dropout) and the same with sensor_dropout 0.5."""
    root = tmp_path_factory.mktemp("dropout")
    data, cfg, plain = tiny_run(root)
    settings = yaml.safe_load(cfg.read_text())
    settings["train"]["sensor_dropout"] = 0.5
    cfg2 = root / "dropout.yaml"
    cfg2.write_text(yaml.safe_dump(settings))
    with contextlib.redirect_stderr(io.StringIO()):
        Trainer(TrainConfig.from_yaml(cfg2), root / "dropout").fit(Dataset.open(data).load("train"))
    return data, plain, root / "dropout"


def test_dropout_gives_the_network_presence_flags_and_bad_values_are_refused():
    assert TrainConfig(sensor_dropout=0.3).network.sensor_presence
    assert not TrainConfig().network.sensor_presence
    for bad in (-0.1, 1.0, float("nan")):
        with pytest.raises(ValueError, match="sensor_dropout must be in"):
            TrainConfig(sensor_dropout=bad)


def test_a_missing_imu_cannot_reach_the_network():
    torch.manual_seed(0)
    net = SSPINNposeNet(6 * 7 + 2, NetworkConfig(hidden=8, layers=1, dropout=0.0, dense=8, sensor_presence=True)).eval()
    x = torch.randn(1, 20, 44)
    present = torch.ones(1, 7)
    present[0, 3] = 0.0
    changed = x.clone()
    changed[..., 9:12] = 1e3  # the fourth IMU's channels
    with torch.no_grad():
        np.testing.assert_array_equal(net(x, present=present)[0].numpy(), net(changed, present=present)[0].numpy())
        assert not torch.equal(net(x)[0], net(changed)[0])  # present, it is read
    plain = SSPINNposeNet(44, NetworkConfig(hidden=8, layers=1, dropout=0.0, dense=8))
    with pytest.raises(ValueError, match="no sensor presence inputs"):
        plain(x, present=present)


def test_every_training_window_keeps_at_least_one_imu(runs):
    data, _, _ = runs
    trainer = Trainer(TrainConfig(sensor_dropout=0.95, device="cpu"), "unused")
    trainer.segments, trainer.rng, trainer.device = ("pelvis", "foot_r", "foot_l"), np.random.default_rng(1), torch.device("cpu")
    present = trainer._draw_presence(500).numpy()
    assert present.shape == (500, 3) and (present.sum(1) >= 1).all()
    assert 0.03 < present.mean() < 0.5  # mostly missing, as asked


def test_a_dropout_model_estimates_from_any_subset(runs):
    data, _, dropout = runs
    est = SSPINNpose.load(dropout / "model.pt")
    [rec] = Dataset.open(data).load("test")
    full = est.predict(rec)
    for subset in (("foot_r", "foot_l"), ("pelvis",), ("femur_r", "tibia_r", "femur_l", "tibia_l")):
        part = est.predict(rec.select_imus(subset))
        assert part.q.shape == full.q.shape and np.isfinite(part.q).all()
        assert not np.array_equal(part.q, full.q)
        quality = window_quality(est.network_, rec.select_imus(subset), est.segments_, est.imu_std_)
        assert all(np.isfinite(v).all() for v in quality.terms.values())


def test_a_model_without_flags_names_the_missing_imus(runs):
    data, plain, _ = runs
    est = SSPINNpose.load(plain / "model.pt")
    [rec] = Dataset.open(data).load("test")
    with pytest.raises(DataFormatError, match=r"missing \['pelvis'.*sensor_dropout > 0 accepts any subset"):
        est.predict(rec.select_imus(("foot_r", "foot_l")))
