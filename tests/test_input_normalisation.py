"""Input normalisation of the network: features that did not (or hardly) vary in training.

A model trained on synthetic subjects that all had the same IMU placement and nearly the same
height met a real 1.90 m subject with forefoot sensors: divided by a std floored at 1e-6 those
inputs became 10⁴–10⁵ σ and saturated the LSTM (a constant output over a whole trial)."""

from __future__ import annotations

import numpy as np
import torch

from sspinn.estimator.inference import estimate_recording
from sspinn.estimator.model_store import MODEL_ENTRIES, load_model, load_weights, save_model
from sspinn.estimator.network import UNSEEN_STD, NetworkConfig, SSPINNposeNet, feature_std_floor, input_features
from sspinn.model.body import IMUPlacement
from sspinn.model.conventions import SEGMENTS
from sspinn.testing import walking_recording
from sspinn.torch_files import MODEL, load_torch_file


def test_constant_features_are_masked_and_small_stds_floored() -> None:
    n = 3 * len(SEGMENTS) + 2 + 3 * len(SEGMENTS)
    net = SSPINNposeNet(n, NetworkConfig(hidden=8, layers=1, dense=8))
    mean = torch.ones(n)
    std = torch.full((n,), 2.0)
    std[21] = 1e-3  # height: 1 mm spread in training
    std[23] = 0.0  # a placement value identical in every training recording
    net.set_normalisation(mean, std, feature_std_floor(SEGMENTS))
    assert net.input_std[21] == 0.05 and net.input_std[23] == UNSEEN_STD and net.input_std[0] == 2.0


def test_old_model_files_get_the_mask_on_load(tmp_path) -> None:
    rec = walking_recording(n=200)
    x = input_features(rec.imu, rec.height, rec.mass, rec.placement.vector(), SEGMENTS)
    torch.manual_seed(0)
    net = SSPINNposeNet(x.shape[1], NetworkConfig(hidden=16, layers=1, dense=16))
    std = torch.as_tensor(x.std(0), dtype=torch.float32)
    net.input_mean.copy_(torch.as_tensor(x.mean(0), dtype=torch.float32))
    net.input_std.copy_(std.clamp_min(1e-6))  # what files written before the mask hold
    path = save_model(net, tmp_path / "model.pt", SEGMENTS, {}, torch.ones(len(SEGMENTS), 3))
    stored = load_model(path)
    model, segments = stored.network, stored.segments
    assert (model.input_std[3 * len(SEGMENTS):] >= 0.05).all()
    # fine-tuning reads the weights through load_weights: the same floor and mask
    fresh = SSPINNposeNet(x.shape[1], NetworkConfig(hidden=16, layers=1, dense=16))
    load_weights(fresh, load_torch_file(path, (MODEL,), MODEL_ENTRIES, "", "cpu"), path)
    torch.testing.assert_close(fresh.input_std, model.input_std)
    moved = IMUPlacement.default(rec.height)
    moved.positions["foot_r"] = (0.26, -0.03)  # a forefoot sensor 14 cm further forward
    nominal = estimate_recording(model, rec, segments)
    forefoot = estimate_recording(model, rec, segments, placement=moved.vector())
    np.testing.assert_allclose(forefoot.q, nominal.q, atol=1e-6)  # the placement never varied: ignored
    saturated = SSPINNposeNet(x.shape[1], NetworkConfig(hidden=16, layers=1, dense=16))
    saturated.load_state_dict(net.state_dict())  # the stored normalisation as it was
    z = (input_features(rec.imu, rec.height, rec.mass, moved.vector(), SEGMENTS) - x.mean(0)) / saturated.input_std.numpy()
    assert np.abs(z).max() > 1e4  # what the LSTM received before


def test_a_network_without_body_inputs_ignores_height_mass_and_placement(tmp_path) -> None:
    """``body_inputs: false``: the constants stay in the layout but are normalised to 0, so two
    subjects of other sizes with the same IMU signals get the same raw outputs — also after a
    save and load (the mask lives in the saved statistics)."""
    rec = walking_recording(n=150)
    x = input_features(rec.imu, rec.height, rec.mass, rec.placement.vector(), SEGMENTS)
    n_const = x.shape[1] - 3 * len(SEGMENTS)
    torch.manual_seed(0)
    net = SSPINNposeNet(x.shape[1], NetworkConfig(hidden=16, layers=1, dense=16, body_inputs=False))
    net.set_normalisation(torch.as_tensor(x.mean(0), dtype=torch.float32), torch.full((x.shape[1],), 2.0),
                          feature_std_floor(SEGMENTS), constants=n_const)
    assert (net.input_std[-n_const:] == UNSEEN_STD).all() and (net.input_std[:-n_const] == 2.0).all()
    tall = input_features(rec.imu, 1.95, 95.0, IMUPlacement.default(1.95).vector(), SEGMENTS)
    with torch.no_grad():
        a, _ = net(torch.as_tensor(x, dtype=torch.float32)[None])
        b, _ = net(torch.as_tensor(tall, dtype=torch.float32)[None])
    torch.testing.assert_close(a, b, atol=1e-6, rtol=0)
    path = save_model(net, tmp_path / "model.pt", SEGMENTS, {}, torch.ones(len(SEGMENTS), 3))
    loaded = load_model(path).network
    assert not loaded.config.body_inputs and (loaded.input_std[-n_const:] == UNSEEN_STD).all()
