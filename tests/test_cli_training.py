"""The sspinn CLI and trainer on tiny data: train, resume, Ctrl-C safety, evaluate, infer, export,
streaming."""

from __future__ import annotations

import dataclasses
import shutil

import numpy as np
import pytest
import torch
import yaml

from sspinn.cli import main
from sspinn.data.dataset import Dataset
from sspinn.estimator.inference import StreamingEstimator, estimate_recording
from sspinn.estimator.model_store import load_model, run_exported, trained_on
from sspinn.estimator.training import ADAPT_LR, NonFiniteLossError, TrainConfig, Trainer, adaptation_config
from sspinn.testing import make_recording, tiny_run


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    root = tmp_path_factory.mktemp("tiny")
    rng = np.random.default_rng(3)
    data = root / "data"
    Dataset.write(data, {"train": [make_recording("a", "s1", 150, rng), make_recording("b", "s2", 150, rng)], "test": [make_recording("c", "s3", 120, rng)]})
    cfg = root / "tiny.yaml"
    cfg.write_text(yaml.safe_dump({"train": {
        "network": {"hidden": 8, "layers": 1, "dropout": 0.0, "dense": 8}, "steps": 4, "batch_size": 2, "window": 32,
        "log_every": 1, "checkpoint_every": 2, "device": "cpu",
    }}))
    return root, data, cfg


@pytest.mark.slow
def test_train_resume_evaluate_infer_export(tiny):
    root, data, cfg = tiny
    run = root / "run"
    assert main(["train", "--config", str(cfg), "--data", str(data), "--out", str(run)]) == 0
    for name in ("model.pt", "checkpoint.pt", "config.yaml"):
        assert (run / name).exists()
    assert any((run / "tensorboard").iterdir())
    state = torch.load(run / "checkpoint.pt", weights_only=False)
    assert state["step"] == 4
    assert main(["train", "--config", str(cfg), "--data", str(data), "--out", str(run), "--resume", "--steps", "6"]) == 0
    assert torch.load(run / "checkpoint.pt", weights_only=False)["step"] == 6
    assert main(["train", "--config", str(cfg), "--data", str(data), "--out", str(run), "--auto-resume", "--steps", "7"]) == 0
    assert torch.load(run / "checkpoint.pt", weights_only=False)["step"] == 7
    fresh = root / "fresh"
    assert main(["train", "--config", str(cfg), "--data", str(data), "--out", str(fresh), "--auto-resume", "--steps", "2"]) == 0
    assert torch.load(fresh / "checkpoint.pt", weights_only=False)["step"] == 2
    assert main(["evaluate", "--model", str(run / "model.pt"), "--data", str(data), "--out", str(root / "report"), "--skip", "10"]) == 0
    assert (root / "report" / "report.md").exists() and (root / "report" / "c.png").exists()
    assert main(["infer", "--model", str(run / "model.pt"), "--data", str(data), "--out", str(root / "infer")]) == 0
    header = (root / "infer" / "c_estimate.csv").read_text().splitlines()[0].split(",")
    assert header[:3] == ["time", "pelvis_tx", "pelvis_ty"] and "grf_y_l" in header and "tau_ankle_l" in header
    assert main(["export", "--model", str(run / "model.pt"), "--out", str(root / "model.pt2")]) == 0
    exported = torch.export.load(str(root / "model.pt2")).module()
    model = load_model(run / "model.pt").network
    x = torch.randn(3, 20, model.n_inputs)  # another batch size than the export's example
    torch.testing.assert_close(run_exported(exported, x, model.config.layers, model.config.hidden), model(x)[0])
    assert main(["finetune", "--config", str(cfg), "--model", str(run / "model.pt"), "--data", str(data), "--out", str(root / "ft")]) == 0


@pytest.mark.slow
def test_adapt_continues_a_model_on_the_unlabeled_test_split(tiny, capsys):
    """``sspinn adapt`` starts from the model's weights, trains on the chosen split (the test
    split by default) with the model's own configuration — the weights it ended with, one run
    at a constant low rate — and its labels play no part: stripped of them, the same weights
    result. The adapted model remembers what it saw, and its evaluation says so."""
    root, data, cfg = tiny
    trained = root / "adapt_base"
    assert main(["train", "--config", str(cfg), "--data", str(data), "--out", str(trained),
                 "--set", "weights_after_starts={foot_speed: 0}"]) == 0
    config = adaptation_config(load_model(trained / "model.pt").config, "m", steps=3)
    assert (config.steps, config.lr, config.lr_schedule, config.starts) == (3, ADAPT_LR, "constant", 1)
    assert config.weights.foot_speed == 0 and config.weights_after_starts == {} and config.window == 32
    assert config.input_noise == 0 and load_model(trained / "model.pt").config["input_noise"] > 0
    out = root / "adapted"
    assert main(["adapt", "--model", str(trained / "model.pt"), "--data", str(data), "--out", str(out), "--steps", "3"]) == 0
    state = torch.load(out / "checkpoint.pt", weights_only=False)
    assert state["step"] == 3 and state["recordings"] == ["c"]
    base = load_model(trained / "model.pt").network.state_dict()
    assert any(not torch.equal(a, b) for a, b in zip(base.values(), load_model(out / "model.pt").network.state_dict().values()))
    test = Dataset.open(data).load("test")
    unlabeled = root / "unlabeled"
    Dataset.write(unlabeled, {"test": [dataclasses.replace(r, labels=None) for r in test]})
    assert main(["adapt", "--model", str(trained / "model.pt"), "--data", str(unlabeled), "--out", str(root / "adapted2"), "--steps", "3"]) == 0
    for a, b in zip(load_model(out / "model.pt").network.state_dict().values(), load_model(root / "adapted2" / "model.pt").network.state_dict().values()):
        torch.testing.assert_close(a, b)
    assert trained_on(trained / "model.pt") == ("a", "b") and trained_on(out / "model.pt") == ("a", "b", "c")
    capsys.readouterr()
    assert main(["evaluate", "--model", str(trained / "model.pt"), "--data", str(data), "--out", str(root / "ev0"), "--skip", "10"]) == 0
    assert "NOTE" not in capsys.readouterr().out
    assert main(["evaluate", "--model", str(out / "model.pt"), "--data", str(data), "--out", str(root / "ev1"), "--skip", "10"]) == 0
    assert "saw the IMU signals (never the labels) of 1 of these 1 recordings: c" in capsys.readouterr().out
    assert "saw the IMU signals" in (root / "ev1" / "report.md").read_text()


def test_resume_reproduces_an_uninterrupted_run(tiny):
    root, data, cfg = tiny
    train = Dataset.open(data).load("train")
    config = TrainConfig.from_yaml(cfg)
    full = Trainer(config, root / "full")
    full.fit(train)
    TrainConfig.from_yaml(cfg, steps=2)
    half = Trainer(TrainConfig.from_yaml(cfg, steps=2), root / "half")
    half.fit(train)
    rest = Trainer(config, root / "half")
    rest.fit(train, resume=True)
    for a, b in zip(full.model.state_dict().values(), rest.model.state_dict().values()):
        torch.testing.assert_close(a, b)


def test_keyboard_interrupt_saves_a_checkpoint(tiny, monkeypatch):
    root, data, cfg = tiny
    train = Dataset.open(data).load("train")
    trainer = Trainer(TrainConfig.from_yaml(cfg), root / "interrupted")
    calls = {"n": 0}
    real_step = torch.optim.Adam.step

    def interrupt_on_third(self, *a, **k):
        calls["n"] += 1
        if calls["n"] == 3:
            raise KeyboardInterrupt
        return real_step(self, *a, **k)

    monkeypatch.setattr(torch.optim.Adam, "step", interrupt_on_third)
    with pytest.raises(KeyboardInterrupt):
        trainer.fit(train)
    assert torch.load(root / "interrupted" / "checkpoint.pt", weights_only=False)["step"] == 2


def test_nan_guard_names_the_windows(tiny, monkeypatch):
    root, data, cfg = tiny
    train = Dataset.open(data).load("train")
    trainer = Trainer(TrainConfig.from_yaml(cfg), root / "nan")
    import sspinn.estimator.training as tr

    real = tr.decode

    def poisoned(raw, *a, **k):
        return real(raw * float("nan"), *a, **k)

    monkeypatch.setattr(tr, "decode", poisoned)
    with pytest.raises(NonFiniteLossError, match=r"step 0 \(rank 0\): loss is nan .* on windows \['[ab]\[\d+:\d+\]'"):
        trainer.fit(train)


def test_bad_config_and_data_errors(tiny, tmp_path, capsys):
    root, data, cfg = tiny
    bad = tmp_path / "bad.yaml"
    bad.write_text("train: {stepz: 3}\n")
    assert main(["train", "--config", str(bad), "--data", str(data), "--out", str(tmp_path / "r")]) == 2
    assert "unknown train option(s) ['stepz']" in capsys.readouterr().err
    assert main(["train", "--config", str(cfg), "--data", str(tmp_path), "--out", str(tmp_path / "r")]) == 2
    assert "not a dataset folder" in capsys.readouterr().err
    with pytest.raises(ValueError, match="unknown IMU configuration"):
        TrainConfig(imus="hands")


def test_streaming_matches_whole_sequence(tmp_path):
    data, _, run = tiny_run(tmp_path)  # a finished 4-step run of its own (the CLI test's may be deselected)
    stored = load_model(run / "model.pt")
    model, segments = stored.network, stored.segments
    rec = Dataset.open(data).load("test")[0]
    whole = estimate_recording(model, rec, segments)
    stream = StreamingEstimator(model, segments, rec.height, rec.mass, rec.placement.vector())
    outs = [stream.step(rec.imu[k]) for k in range(40)]
    np.testing.assert_allclose(np.array([o["tau"] for o in outs]), whole.tau[:40], rtol=1e-4, atol=1e-3)
    np.testing.assert_allclose(np.array([o["grf"] for o in outs]), whole.grf[:40], rtol=1e-4, atol=1e-2)
    with pytest.raises(ValueError, match="finite"):
        stream.step(np.full((7, 3), np.nan))


def test_a_direct_grf_network_with_imu_noise_trains_infers_streams_and_exports(tiny):
    """``network.grf: direct`` and ``imu_noise`` through the whole path: the saved model outputs
    36 values, its GRFs come from them (not the contact model), the stream matches the whole
    recording, the exported step reproduces the network, and the L_IMU scales are the noise
    model's, not the standard deviations."""
    root, data, cfg = tiny
    config = yaml.safe_load(cfg.read_text())
    config["train"]["network"]["grf"] = "direct"
    config["train"]["imu_noise"] = {"acc": 2.0, "gyr": 0.2, "acc_relative": 0.1, "gyr_relative": 0.02}
    direct_cfg = root / "direct.yaml"
    direct_cfg.write_text(yaml.safe_dump(config))
    run = root / "direct"
    assert main(["train", "--config", str(direct_cfg), "--data", str(data), "--out", str(run)]) == 0
    stored = load_model(run / "model.pt")
    model, segments, saved = stored.network, stored.segments, stored.config
    assert model.config.grf == "direct" and model.head[-1].out_features == 36
    assert saved["imu_noise"] == config["train"]["imu_noise"]
    state = torch.load(run / "model.pt", weights_only=False)
    train = Dataset.open(data).load("train")
    std = torch.as_tensor(np.concatenate([r.imu for r in train]).std(axis=0), dtype=torch.float32)
    torch.testing.assert_close(state["imu_std"], torch.sqrt(torch.tensor([4.0, 4.0, 0.04]) + (torch.tensor([0.1, 0.1, 0.02]) * std) ** 2))
    rec = Dataset.open(data).load("test")[0]
    whole = estimate_recording(model, rec, segments)
    assert (whole.grf[:, 1::2] >= 0).all()
    stream = StreamingEstimator(model, segments, rec.height, rec.mass, rec.placement.vector())
    outs = [stream.step(rec.imu[k]) for k in range(40)]
    np.testing.assert_allclose(np.array([o["grf"] for o in outs]), whole.grf[:40], rtol=1e-4, atol=1e-2)
    np.testing.assert_allclose(np.array([o["w"] for o in outs]), whole.w[:40], atol=1e-5)
    assert main(["export", "--model", str(run / "model.pt"), "--out", str(root / "direct.pt2")]) == 0
    exported = torch.export.load(str(root / "direct.pt2")).module()
    x = torch.randn(2, 15, model.n_inputs)
    torch.testing.assert_close(run_exported(exported, x, model.config.layers, model.config.hidden), model(x)[0])
    assert main(["evaluate", "--model", str(run / "model.pt"), "--data", str(data), "--out", str(root / "direct_report"), "--skip", "10"]) == 0


def test_a_bidirectional_network_is_not_exported_as_a_streaming_step() -> None:
    from sspinn.estimator.model_store import StreamingStep
    from sspinn.estimator.network import NetworkConfig, SSPINNposeNet

    with pytest.raises(ValueError, match="only unidirectional ones stream"):
        StreamingStep(SSPINNposeNet(10, NetworkConfig(hidden=8, layers=1, dense=8, bidirectional=True)))


def test_cosine_learning_rate_schedule() -> None:
    from sspinn.estimator.training import TrainConfig

    cfg = TrainConfig(steps=100, lr=1e-3, lr_schedule="cosine", lr_final=0.1)
    assert cfg.lr_at(0) == pytest.approx(1e-3) and cfg.lr_at(100) == pytest.approx(1e-4)
    assert cfg.lr_at(50) == pytest.approx(0.55e-3) and cfg.lr_at(10) > cfg.lr_at(20) > cfg.lr_at(90)
    assert TrainConfig(steps=100).lr_at(77) == 1e-3
    with pytest.raises(ValueError, match="lr_schedule"):
        TrainConfig(lr_schedule="step")


def test_starts_choose_the_most_physical_and_continue(tiny):
    """``starts``: short runs of seeds seed, seed+1, …; the one with the lowest Kane term on the
    fixed check windows continues (from its step, optimizer and random state) to ``steps``; a
    rerun reuses the finished starts, and the whole is the chosen seed's uninterrupted run."""
    import json

    root, data, cfg = tiny
    train = Dataset.open(data).load("train")
    config = TrainConfig.from_yaml(cfg, steps=5, settings=["starts=3", "start_steps=2"])
    trainer = Trainer(config, root / "starts")
    trainer.fit(train)
    record = json.loads((root / "starts" / "starts.json").read_text())
    kane = {int(k): v["kane"] for k, v in record["checks"].items()}
    assert sorted(kane) == [0, 1, 2] and record["chosen_seed"] == min(kane, key=kane.get)
    assert trainer.step == 5 and [h["step"] for h in trainer.history][:2] == [1, 2]
    # the chosen start's checks are reproducible from its own folder
    chosen = record["chosen_seed"]
    alone = Trainer(TrainConfig.from_yaml(cfg, steps=5, seed=chosen), root / "alone")
    alone.fit(train)
    for a, b in zip(alone.model.state_dict().values(), trainer.model.state_dict().values()):
        torch.testing.assert_close(a, b)
    with pytest.raises(ValueError, match="start_steps"):
        TrainConfig.from_yaml(cfg, steps=2, settings=["starts=2", "start_steps=2"])


def test_starts_with_a_learning_rate_schedule(tiny):
    """With ``starts`` and a cosine schedule the starts run at the peak rate (their saved
    configs say constant) and the chosen start continues on the schedule over ``steps``."""
    import yaml

    root, data, cfg = tiny
    train = Dataset.open(data).load("train")
    config = TrainConfig.from_yaml(cfg, steps=5, settings=["starts=2", "start_steps=2", "lr_schedule=cosine", "lr_final=0.1"])
    trainer = Trainer(config, root / "cosine")
    trainer.fit(train)
    for seed in (0, 1):
        sub = yaml.safe_load((root / "cosine" / "starts" / f"seed{seed}" / "config.yaml").read_text())["train"]
        assert sub["lr_schedule"] == "constant" and sub["steps"] == 2
    assert trainer.step == 5
    assert trainer.optimizer.param_groups[0]["lr"] == pytest.approx(config.lr_at(4)) and config.lr_at(4) < config.lr


def test_finetune_last_switches_to_the_finetuning_weights(tiny):
    """``finetune_last = steps`` is exactly a run with the fine-tuning weights throughout; with
    ``finetune_last = 2`` the first steps match the plain run and the last two do not."""
    root, data, cfg = tiny
    train = Dataset.open(data).load("train")

    def run(name, **changes):
        config = TrainConfig.from_yaml(cfg, steps=4)
        for key, value in changes.items():
            setattr(config, key, value)
        trainer = Trainer(config, root / name)
        trainer.fit(train)
        return trainer

    whole = run("ft_whole", finetune_last=4)
    plain_ft = run("ft_plain", finetune=True)
    for a, b in zip(whole.model.state_dict().values(), plain_ft.model.state_dict().values()):
        torch.testing.assert_close(a, b)
    plain = run("ft_none")
    last2 = run("ft_last2", finetune_last=2)
    kane = [(h["kane"], g["kane"]) for h, g in zip(plain.history, last2.history)]
    assert kane[0][0] == kane[0][1] and kane[1][0] == kane[1][1]
    assert kane[2][1] > 5 * kane[2][0]  # ×10 weight on a similar residual
    with pytest.raises(ValueError, match="finetune_last"):
        TrainConfig.from_yaml(cfg, steps=4, settings=["finetune_last=5"])


def test_weights_after_starts_change_the_losses_from_start_steps_on(tiny):
    """``weights_after_starts`` leaves the first ``start_steps`` steps exactly as the plain run
    and weighs the terms anew from then on; unknown terms and negative weights are refused."""
    root, data, cfg = tiny
    train = Dataset.open(data).load("train")

    def run(name, *settings):
        trainer = Trainer(TrainConfig.from_yaml(cfg, steps=4, settings=["log_every=1", "start_steps=2", *settings]), root / name)
        trainer.fit(train)
        return trainer

    plain = run("after_none")
    kane = plain.config.weights.kane
    later = run("after_kane", f"weights_after_starts={{kane: {10 * kane}, foot_speed: 0}}")
    pairs = [(h["kane"], g["kane"]) for h, g in zip(plain.history, later.history)]
    assert pairs[0][0] == pairs[0][1] and pairs[1][0] == pairs[1][1]
    assert pairs[2][1] > 5 * pairs[2][0]  # ×10 weight on a similar residual
    assert all(g["foot_speed"] == 0 for g in later.history[2:])
    for bad, match in (("{kane2: 1}", "unknown loss term 'kane2'"), ("{kane: -1}", "finite number >= 0")):
        with pytest.raises(ValueError, match=match):
            TrainConfig.from_yaml(cfg, steps=4, settings=[f"weights_after_starts={bad}"])


@pytest.mark.slow
@pytest.mark.skipif(shutil.which("g++") is None and shutil.which("clang++") is None, reason="inductor needs a C++ compiler")
def test_compiled_physics_trains_like_the_eager_physics(tiny):
    """``compile: true`` (torch.compile of decoding + losses) gives the eager run's losses and
    weights to float32 rounding — and really compiled (no fallback warning), into one graph
    although the loss weights change half-way (``weights_after_starts``: the weighting stays
    outside the compiled graph, so a change costs no recompilation) and another run uses another
    thread count (the forward physics runs on ``PHYSICS_THREADS``)."""
    import warnings

    import torch._dynamo
    from torch._dynamo.utils import counters

    from sspinn.estimator.training import CompileWarning

    root, data, cfg = tiny
    train = Dataset.open(data).load("train")
    runs = {}
    torch._dynamo.reset()
    graphs = counters["stats"]["unique_graphs"]
    for compiled in (False, True):
        settings = [f"compile={str(compiled).lower()}", "start_steps=2", "weights_after_starts={kane: 30, foot_speed: 0}"]
        trainer = Trainer(TrainConfig.from_yaml(cfg, settings=settings), root / f"compiled_{compiled}")
        with warnings.catch_warnings():
            warnings.simplefilter("error", CompileWarning)
            trainer.fit(train)
        assert trainer.physics.compiled is compiled
        runs[compiled] = trainer
    threads = torch.get_num_threads()
    try:  # another thread count (threads: 0 re-measures the free cores) reuses the graph
        other = 1 if runs[True].config.threads != 1 else 2
        settings = ["compile=true", "start_steps=2", "weights_after_starts={kane: 30, foot_speed: 0}", f"threads={other}"]
        Trainer(TrainConfig.from_yaml(cfg, settings=settings), root / "compiled_threads").fit(train)
    finally:
        torch.set_num_threads(threads)
    assert counters["stats"]["unique_graphs"] - graphs == 1
    eager, compiled_run = runs[False], runs[True]
    for a, b in zip(eager.history, compiled_run.history):
        for k in ("kane", "imu", "contact", "stance", "total"):
            assert b[k] == pytest.approx(a[k], rel=1e-3, abs=1e-6), k
    for a, b in zip(eager.model.state_dict().values(), compiled_run.model.state_dict().values()):
        torch.testing.assert_close(a, b, rtol=1e-3, atol=1e-5)


def test_a_failed_compile_falls_back_to_the_eager_physics(tiny, monkeypatch):
    from sspinn.estimator import training
    from sspinn.estimator.training import CompileWarning

    def broken(fn, **kwargs):
        def call(*args):
            raise RuntimeError("no C++ compiler found")
        return call

    monkeypatch.setattr(training.torch, "compile", broken)
    monkeypatch.setattr(training.PhysicsTerms, "_shared", None)  # an earlier test's wrapper would be reused
    root, data, cfg = tiny
    train = Dataset.open(data).load("train")
    trainer = Trainer(TrainConfig.from_yaml(cfg, settings=["compile=true"]), root / "compile_fails")
    with pytest.warns(CompileWarning, match="no C\\+\\+ compiler"):
        trainer.fit(train)
    eager = Trainer(TrainConfig.from_yaml(cfg), root / "compile_eager")
    eager.fit(train)
    assert trainer.step == 4 and not trainer.physics.compiled
    for a, b in zip(eager.model.state_dict().values(), trainer.model.state_dict().values()):
        torch.testing.assert_close(a, b)


_VECTOR_KERNEL = """
import sys, torch
from sspinn.estimator.training import PHYSICS_COMPILE_OPTIONS
if sys.argv[1] == "physics-first":  # the physics' options first, as a training before an environment
    torch.compile(lambda x: x.cos() - 1, options=dict(PHYSICS_COMPILE_OPTIONS))(torch.linspace(0, 1, 4096, dtype=torch.float64))
out = torch.compile(lambda x: x.sin() * 2)(torch.linspace(0, 1, 4096, dtype=torch.float64))
assert torch.allclose(out, torch.linspace(0, 1, 4096, dtype=torch.float64).sin() * 2)
"""


@pytest.mark.slow
@pytest.mark.skipif(shutil.which("g++") is None and shutil.which("clang++") is None, reason="inductor needs a C++ compiler")
def test_the_physics_compile_options_leave_later_compilations_alone(tmp_path):
    """The physics' inductor options hold for its own graphs only: a later compilation in the same
    process (the environment's, default options) still builds with SIMD flags, so it can load the
    vector code that inductor's on-disk cache kept from an earlier process."""
    import os
    import subprocess
    import sys

    env = {**os.environ, "TORCHINDUCTOR_CACHE_DIR": str(tmp_path / "inductor")}
    for order in ("default-only", "physics-first"):  # the first fills the cache with vector code
        done = subprocess.run([sys.executable, "-c", _VECTOR_KERNEL, order], env=env, capture_output=True, text=True)
        assert done.returncode == 0, f"{order}: {done.stderr[-2000:]}"


def test_placement_learning_options(tiny):
    """learn_placement moves each training recording's placement; placement_angles=false keeps the
    angles where they were; placement_lr_factor scales the placement's steps (a group of its own)."""
    root, data, cfg = tiny
    train = Dataset.open(data).load("train")
    nominal = np.stack([r.placement.vector() for r in train]).astype(np.float32)

    def learned(out: str, **changes: object) -> tuple[np.ndarray, Trainer]:
        trainer = Trainer(TrainConfig.from_yaml(cfg, learn_placement=True, **changes), root / out)
        trainer.fit(train)
        return trainer.placement.detach().numpy() - nominal, trainer

    moved, _ = learned("place_all")
    assert np.abs(moved[:, 0::3]).max() > 0 and np.abs(moved[:, 2::3]).max() > 0
    positions, _ = learned("place_positions", placement_angles=False)
    assert np.abs(positions[:, 0::3]).max() > 0 and np.abs(positions[:, 2::3]).max() == 0.0
    slow, trainer = learned("place_slow", placement_lr_factor=0.1)
    assert [g.get("lr_scale", 1.0) for g in trainer.optimizer.param_groups] == [1.0, 0.1]
    assert 0 < np.abs(slow).max() < np.abs(moved).max()  # Adam: each step moves a parameter by about its learning rate
    with pytest.raises(ValueError, match="placement_lr_factor"):
        TrainConfig(placement_lr_factor=0.0)
