"""Hard upper bounds and one-line errors for what a user's input may ask for: sizes, memory,
files that are no regular files, text that is not UTF-8, duplicate keys, deep nesting, devices
(sspinn.resource_limits, sspinn.yaml_config, the readers, sspinn.cli, envs, agents)."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest
import yaml

from sspinn.cli import main
from sspinn.data.dataset import DataFormatError, Recording, read_csv_table
from sspinn.resource_limits import MAX_ROWS, ResourceLimitError, check_allocation, input_file, physical_memory_bytes
from sspinn.yaml_config import ConfigError, read_config_file

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "models" / "pretrained" / "example_walk.csv"


def _one_line_error(capsys, argv: list[str], *needles: str) -> str:
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "internal error" not in err, err
    for needle in needles:
        assert needle in err, err
    return err


@pytest.mark.parametrize(("setting", "needle"), [
    ("steps=1000000000000000", "option steps must be an integer <= 1e+08"),
    ("batch_size=1000000000", "option batch_size must be an integer <= 1e+06"),
    ("batch_size=100000", "batch_size 100000 × window"),
    ("weights.kane=-1", "option weights.kane must be a number >= 0"),
    ("weights_after_starts={kane: -1}", "weights_after_starts.kane must be a finite number >= 0"),
    ("lr=1e9", "option lr must be a number > 0 and <= 1"),
    ("device=tpu", "'tpu' is not a device"),
])
def test_training_settings_beyond_their_bounds_are_refused_before_training(tmp_path, capsys, setting, needle) -> None:
    _one_line_error(capsys, ["train", "--data", str(EXAMPLE), "--out", str(tmp_path / "r"), "--set", setting], needle)
    assert not (tmp_path / "r").exists()


def test_flags_are_bounded_and_cuda_without_a_gpu_is_one_line(tmp_path, capsys) -> None:
    with pytest.raises(SystemExit) as stop:  # argparse's own exit, status 2
        main(["train", "--data", str(EXAMPLE), "--out", str(tmp_path / "r"), "--steps", "1" + "0" * 15])
    assert stop.value.code == 2 and "must be an integer <= 1e+08" in capsys.readouterr().err
    import torch

    if torch.cuda.is_available():
        pytest.skip("a CUDA GPU is visible")
    for device in ("cuda", "cuda:7"):
        _one_line_error(capsys, ["train", "--data", str(EXAMPLE), "--out", str(tmp_path / "r"), "--device", device],
                        "sees no CUDA GPU")


@pytest.mark.parametrize("config", ["/dev/zero", "/etc"])
def test_a_config_that_is_no_regular_file_is_named_as_it_is(tmp_path, capsys, config) -> None:
    err = _one_line_error(capsys, ["train", "--config", config, "--data", str(EXAMPLE), "--out", str(tmp_path / "r")])
    assert f"{config}: is a" in err and ".yaml" not in err


def test_a_relative_config_missing_here_is_not_replaced_by_the_shipped_one(tmp_path, capsys, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    _one_line_error(capsys, ["train", "--config", "configs/sspinn/demo.yaml", "--data", str(EXAMPLE), "--out", "r"],
                    "configs/sspinn/demo.yaml: no such configuration file")


def test_yaml_files_not_utf8_duplicate_keys_deep_nesting_and_extends_of_a_folder(tmp_path) -> None:
    bad = tmp_path / "latin1.yaml"
    bad.write_bytes("train:\n  device: caf\xe9\n".encode("latin-1"))
    with pytest.raises(ConfigError, match=r"latin1.yaml: not UTF-8 text"):
        read_config_file(bad)
    dup = tmp_path / "dup.yaml"
    dup.write_text("train:\n  steps: 5\n  steps: 6\n")
    with pytest.raises(ConfigError, match=r"dup.yaml: not valid YAML: duplicate key 'steps'"):
        read_config_file(dup)
    deep = tmp_path / "deep.yaml"
    deep.write_text("a: " + "[" * 5000 + "]" * 5000 + "\n")
    with pytest.raises(ConfigError, match="deep.yaml: lists or mappings nested"):
        read_config_file(deep)
    for target in ("/etc", "/dev/zero"):
        ext = tmp_path / "ext.yaml"
        ext.write_text(f"extends: {target}\n")
        with pytest.raises(ConfigError, match=f"{target}: is a"):
            read_config_file(ext)


def test_data_files_fifo_size_rows_and_duplicate_sidecar_keys(tmp_path) -> None:
    fifo = tmp_path / "walk.csv"
    os.mkfifo(fifo)
    with pytest.raises(DataFormatError, match="is a FIFO"):
        read_csv_table(fifo)  # returns at once, never blocks
    with pytest.raises(ResourceLimitError, match="more than the 0 MiB"):
        input_file(EXAMPLE, max_bytes=1000)
    rows = tmp_path / "rows.csv"
    with open(rows, "w") as fh:
        fh.write("time\n")
        fh.write("0\n" * (MAX_ROWS + 1))
    with pytest.raises(DataFormatError, match=f"more than the {MAX_ROWS}"):
        read_csv_table(rows)
    rows.unlink()
    (tmp_path / "w.csv").write_text(EXAMPLE.read_text())
    sidecar = EXAMPLE.with_suffix(".json").read_text()
    (tmp_path / "w.json").write_text(sidecar.replace('{', '{"format": "x", ', 1))
    with pytest.raises(DataFormatError, match="w.json: not valid JSON \\(duplicate key 'format'\\)"):
        Recording.load(tmp_path / "w.csv")


def test_memory_bound_follows_the_machine() -> None:
    check_allocation(physical_memory_bytes() * 0.4, "x")
    with pytest.raises(ResourceLimitError, match="batch 9 needs about"):
        check_allocation(physical_memory_bytes() * 0.6, "batch 9")


def test_agents_buffers_and_counts_are_bounded(tmp_path) -> None:
    pytest.importorskip("stable_baselines3")
    from agents.config import load_config

    data = yaml.safe_load((ROOT / "configs" / "agents" / "ppo.yaml").read_text())
    data.setdefault("hyperparameters", {})["n_steps"] = 10**8
    path = tmp_path / "a.yaml"
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(ConfigError, match="n_steps 100000000 × env.n_envs .* needs about"):
        load_config(path)
    data["hyperparameters"]["n_steps"] = 10**12
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(ConfigError, match="at most 1e\\+09"):
        load_config(path)


def test_env_reset_options_must_be_a_mapping_and_actions_real() -> None:
    from envs.sagittal_walker import SagittalWalkerEnv

    env = SagittalWalkerEnv()
    with pytest.raises(TypeError, match=r"options=\.\.\.\) must be a dict .* got the list \[1, 2\]"):
        env.reset(options=[1, 2])
    env.reset(seed=0)
    with pytest.raises(ValueError, match="action must be real"):
        env.step(np.zeros(6) + 1j)


def test_a_trc_time_column_in_ms_is_refused(tmp_path) -> None:
    from sspinn.imu.stream import IMUImportError
    from sspinn.imu.vendor_readers import read_trc_vectors

    head = "PathFileType\t4\t(X/Y/Z)\tx.trc\nDataRate\tCameraRate\tNumFrames\n100\t100\t50\nFrame#\tTime\ts1\n\t\tX1\tY1\tZ1\n"
    rows = "".join(f"{k + 1}\t{k * 10}\t9.8\t0\t0\n" for k in range(50))
    (tmp_path / "x.trc").write_text(head + rows)
    with pytest.raises(IMUImportError, match=r"x.trc: the time column steps by 10 .* DataRate is 100 Hz \(the time column in ms\?\)"):
        read_trc_vectors(tmp_path / "x.trc")
    (tmp_path / "y.trc").write_text(head.replace("100\t100\t50", "\t\t50") + rows)
    with pytest.raises(IMUImportError, match="is it in ms or samples"):
        read_trc_vectors(tmp_path / "y.trc")


def test_export_writes_through_the_safe_path_and_the_sidecar_written_is_json(tmp_path) -> None:
    # the sidecar of a saved recording still loads (duplicate-key hook does not reject valid JSON)
    rec = Recording.load(EXAMPLE)
    rec.save(tmp_path)
    assert json.loads((tmp_path / f"{rec.name}.json").read_text())["format"]
    assert Recording.load(tmp_path / f"{rec.name}.csv").n_samples == rec.n_samples


def test_resume_with_other_settings_warns_naming_them(tiny_run, tmp_path, capsys) -> None:
    import shutil

    _, data, cfg, _, run = tiny_run
    out = Path(shutil.copytree(run, tmp_path / "run"))
    assert main(["train", "--config", str(cfg), "--data", str(data), "--out", str(out), "--resume", "--set", "lr=0.01"]) == 0
    err = capsys.readouterr().err
    assert "resuming with settings other than the checkpoint's (lr 0.001 → 0.01)" in err, err


def test_sigterm_during_training_is_handled_like_ctrl_c() -> None:
    import signal

    from sspinn.cli import _sigterm_as_ctrl_c
    from sspinn.interrupt import DeferredInterrupt

    with DeferredInterrupt() as interrupt:
        previous = _sigterm_as_ctrl_c()
        try:
            os.kill(os.getpid(), signal.SIGTERM)
            assert interrupt.requested  # the step finishes, then the checkpoint is saved
        finally:
            signal.signal(signal.SIGTERM, previous)


def test_an_empty_config_file_is_an_error_and_braces_mean_the_defaults(tmp_path) -> None:
    from sspinn.estimator.training import TrainConfig
    from sspinn.yaml_config import load_config

    (tmp_path / "empty.yaml").write_text("")
    with pytest.raises(ConfigError, match="empty.yaml: the configuration file is empty; write {} to take every default"):
        load_config(TrainConfig, tmp_path / "empty.yaml", "train")
    (tmp_path / "braces.yaml").write_text("{}\n")
    assert load_config(TrainConfig, tmp_path / "braces.yaml", "train") == TrainConfig()
