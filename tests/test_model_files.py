"""Safe model/checkpoint files with clear errors, one process per run
folder, and a Ctrl-C resume that is bit-identical to an uninterrupted run."""

from __future__ import annotations

import os
import signal
import subprocess
import sys

import numpy as np
import pytest
import torch

from sspinn.cli import main
from sspinn.estimator.model_store import load_model
from sspinn.estimator.training import TrainConfig, Trainer
from sspinn.run_folder import RunFolderBusyError, RunLock, atomic_path
from sspinn.torch_files import FORMAT_VERSION, ModelFileError, load_torch_file, save_torch_file


class _RunsCode:
    """Unpickling this would run ``touch <marker>``."""

    def __init__(self, marker: str) -> None:
        self.marker = marker

    def __reduce__(self):
        return (os.system, (f"touch {self.marker}",))


def test_a_crafted_file_runs_no_code(tiny_run, tmp_path):
    evil = tmp_path / "model.pt"
    marker = tmp_path / "pwned"
    torch.save({"model": _RunsCode(str(marker))}, evil)
    with pytest.raises(ModelFileError, match=r"model\.pt: holds Python objects .* could run code"):
        load_model(evil)
    assert not marker.exists()


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (lambda p, good: p.write_bytes(np.random.default_rng(0).bytes(4096)), "not a torch file"),
        (lambda p, good: p.write_bytes(b""), "the file is empty"),
        (lambda p, good: p.write_bytes(good.read_bytes()[: good.stat().st_size // 2]), "truncated"),
        (lambda p, good: p.mkdir(), "is a folder"),
        (lambda p, good: torch.save({"weights": torch.zeros(3)}, p), r"lacks the entries \['model'"),
        (lambda p, good: torch.save([1, 2, 3], p), "holds a list, not a model"),
        (lambda p, good: torch.save({"format": "sspinn-model", "version": FORMAT_VERSION + 1}, p), "newer than this sspinn"),
        (lambda p, good: torch.save({"format": "gait-generator", "version": 1}, p), "is a 'gait-generator' file"),
        (lambda p, good: None, "no such file"),
    ],
    ids=["random-bytes", "empty", "truncated", "folder", "no-keys", "a-list", "newer-version", "other-kind", "missing"],
)
def test_broken_model_files_name_the_file_and_the_problem(tiny_run, tmp_path, capsys, make, message):
    _, data, _, _, run = tiny_run
    bad = tmp_path / "broken.pt"
    make(bad, run / "model.pt")
    with pytest.raises(ModelFileError, match=message) as info:
        load_model(bad)
    assert str(bad) in str(info.value) and "sspinn train" in str(info.value)
    assert main(["infer", "--model", str(bad), "--data", str(data), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and str(bad) in err and "Traceback" not in err
    assert not (tmp_path / "o").exists()


def test_nan_weights_are_refused_before_anything_is_written(tiny_run, tmp_path, capsys):
    _, data, cfg, _, run = tiny_run
    state = torch.load(run / "model.pt", weights_only=True)
    next(iter(state["model"].values())).fill_(float("nan"))
    torch.save(state, tmp_path / "nan.pt")
    with pytest.raises(ModelFileError, match="non-finite"):
        load_model(tmp_path / "nan.pt")
    assert main(["infer", "--model", str(tmp_path / "nan.pt"), "--data", str(data), "--out", str(tmp_path / "o")]) == 2
    assert main(["evaluate", "--model", str(tmp_path / "nan.pt"), "--data", str(data), "--out", str(tmp_path / "e")]) == 2
    assert main(["finetune", "--config", str(cfg), "--model", str(tmp_path / "nan.pt"), "--data", str(data),
                 "--out", str(tmp_path / "f")]) == 2
    assert "non-finite" in capsys.readouterr().err
    assert not (tmp_path / "o").exists() and not (tmp_path / "e").exists() and not (tmp_path / "f" / "model.pt").exists()


def test_files_without_a_format_entry_still_load(tiny_run, tmp_path):
    _, _, _, _, run = tiny_run
    state = torch.load(run / "model.pt", weights_only=True)
    assert state["format"] == "sspinn-model" and state["version"] == FORMAT_VERSION
    del state["format"], state["version"]
    torch.save(state, tmp_path / "old.pt")
    segments = load_model(tmp_path / "old.pt").segments
    assert segments == tuple(state["segments"])


def test_resume_from_a_truncated_checkpoint_or_another_network_is_a_clear_error(tiny_run, tmp_path, capsys):
    _, data, cfg, train, run = tiny_run
    out = tmp_path / "run"
    out.mkdir()
    good = (run / "checkpoint.pt").read_bytes()
    (out / "checkpoint.pt").write_bytes(good[: len(good) // 3])
    args = ["train", "--config", str(cfg), "--data", str(data), "--out", str(out)]
    for flag in ("--resume", "--auto-resume"):
        assert main([*args, flag]) == 2
        err = capsys.readouterr().err
        assert f"{out / 'checkpoint.pt'}: truncated" in err and "Errno" not in err.split(":")[0]
    (out / "checkpoint.pt").write_bytes(good)
    assert main([*args, "--resume", "--set", "network.hidden=16", "--steps", "5"]) == 2
    assert "does not fit this run" in capsys.readouterr().err
    (out / "checkpoint.pt").write_bytes((run / "model.pt").read_bytes())
    assert main([*args, "--resume"]) == 2
    assert "is a 'sspinn-model' file, not one of ['sspinn-checkpoint']" in capsys.readouterr().err


def test_debug_flag_shows_the_traceback(tiny_run, tmp_path):
    _, data, _, _, _ = tiny_run
    with pytest.raises(ModelFileError):
        main(["infer", "--debug", "--model", str(tmp_path / "nope.pt"), "--data", str(data), "--out", str(tmp_path / "o")])


def test_saved_files_are_atomic_with_unique_temporary_names(tmp_path):
    with atomic_path(tmp_path / "x.pt") as a, atomic_path(tmp_path / "x.pt") as b:
        assert a != b and a.parent == b.parent == tmp_path
        a.write_text("a")
        b.write_text("b")
    assert (tmp_path / "x.pt").read_text() == "a"  # the outer context finishes last
    with pytest.raises(RuntimeError), atomic_path(tmp_path / "y.pt") as tmp:
        tmp.write_text("half")
        raise RuntimeError
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.pt"]
    save_torch_file(tmp_path / "z.pt", "sspinn-model", {"model": {}})
    assert load_torch_file(tmp_path / "z.pt", ("sspinn-model",), ("model",), "hint")["version"] == FORMAT_VERSION


# ---------------------------------------------------------------------------------- run lock
def test_a_second_run_into_the_same_folder_is_refused(tiny_run, tmp_path, capsys):
    _, data, cfg, train, _ = tiny_run
    out = tmp_path / "busy"
    with RunLock(out):
        with pytest.raises(RunFolderBusyError, match=rf"in use by PID {os.getpid()} on host"):
            Trainer(TrainConfig.from_yaml(cfg), out).fit(train)
        assert main(["train", "--config", str(cfg), "--data", str(data), "--out", str(out)]) == 2
        assert f"this run folder is in use by PID {os.getpid()}" in capsys.readouterr().err
    assert not (out / "model.pt").exists() and not (out / "tensorboard").exists()
    Trainer(TrainConfig.from_yaml(cfg, steps=1), out).fit(train)  # released: now it trains
    assert (out / "model.pt").exists() and (out / ".lock").read_text() == ""


def test_a_stale_lock_of_a_dead_process_is_taken_over_with_a_warning(tmp_path):
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    import json
    import socket

    (tmp_path / ".lock").write_text(json.dumps({"pid": dead.pid, "host": socket.gethostname(), "started": 0.0, "command": "x"}))
    with pytest.warns(UserWarning, match=rf"stale lock of PID {dead.pid} .* no longer running"), RunLock(tmp_path):
        assert json.loads((tmp_path / ".lock").read_text())["pid"] == os.getpid()


def test_a_lock_held_by_another_process_names_it(tmp_path):
    code = ("import sys, time; from sspinn.run_folder import RunLock; "
            f"lock = RunLock({str(tmp_path)!r}).acquire(); print('locked', flush=True); sys.stdin.readline()")
    holder = subprocess.Popen([sys.executable, "-c", code], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "locked"
        with pytest.raises(RunFolderBusyError, match=rf"PID {holder.pid} on host .* wait for it"):
            RunLock(tmp_path).acquire()
    finally:
        holder.communicate("\n")
    # the holder ended without releasing: its record is stale, and the lock is free
    with pytest.warns(UserWarning, match=f"stale lock of PID {holder.pid}"), RunLock(tmp_path):
        pass


# ---------------------------------------------------------------------------------- Ctrl-C
def _weights(trainer: Trainer) -> list[torch.Tensor]:
    return [v.clone() for v in trainer.model.state_dict().values()]


@pytest.mark.parametrize("how", ["sigint", "exception-mid-step"])
def test_ctrl_c_then_resume_is_bit_identical_to_an_uninterrupted_run(tiny_run, tmp_path, monkeypatch, how):
    _, _, cfg, train, _ = tiny_run
    handler_before = signal.getsignal(signal.SIGINT)  # SIG_IGN when pytest runs as a background job
    config = TrainConfig.from_yaml(cfg, steps=5)
    full = Trainer(config, tmp_path / "full")
    full.fit(train)

    import sspinn.estimator.training as tr

    real_batch, real_step = tr.make_batch, torch.optim.Adam.step
    calls = {"batch": 0, "step": 0}

    def batch_then_sigint(*a, **k):  # Ctrl-C arrives in the middle of the third step
        calls["batch"] += 1
        if calls["batch"] == 3:
            signal.raise_signal(signal.SIGINT)
        return real_batch(*a, **k)

    def raise_in_third_update(self, *a, **k):  # KeyboardInterrupt raised mid-step, after the draws
        calls["step"] += 1
        if calls["step"] == 3:
            raise KeyboardInterrupt
        return real_step(self, *a, **k)

    with monkeypatch.context() as m:
        if how == "sigint":
            m.setattr(tr, "make_batch", batch_then_sigint)
        else:
            m.setattr(torch.optim.Adam, "step", raise_in_third_update)
        with pytest.raises(KeyboardInterrupt):
            Trainer(config, tmp_path / "cut").fit(train)
    saved = torch.load(tmp_path / "cut" / "checkpoint.pt", weights_only=True)["step"]
    assert saved == (3 if how == "sigint" else 2)  # SIGINT lets the step finish
    rest = Trainer(config, tmp_path / "cut")
    rest.fit(train, resume=True)
    for a, b in zip(_weights(full), _weights(rest)):
        assert torch.equal(a, b)
    assert signal.getsignal(signal.SIGINT) is handler_before  # the trainer's handler is removed again


def test_bad_options_are_one_line_errors(tiny_run, tmp_path, capsys):
    _, data, cfg, _, _ = tiny_run
    base = ["train", "--config", str(cfg), "--data", str(data), "--out", str(tmp_path / "r")]
    for extra, message in (
        (["--set", "window=abc"], "option window must be an integer, got 'abc'"),
        (["--set", "lr=.nan"], "option lr must be a finite number, got nan"),
        (["--set", "lr=nan"], "option lr must be a finite number, got nan"),
            (["--set", "lr=fast"], "option lr must be a number, got 'fast'"),
        (["--set", "lr=-1"], "lr must be a finite number > 0"),
        (["--set", "network.hidden=big"], "option network.hidden must be an integer"),
    ):
        assert main(base + extra) == 2, extra
        err = capsys.readouterr().err
        assert message in err and err.count("\n") == 1, (extra, err)
    for periods in ("0", "-3", "x"):
        with pytest.raises(SystemExit) as info:
            main(["infer", "--model", "m.pt", "--data", str(data), "--out", "o", "--periods", periods])
        assert info.value.code == 2
        assert "--periods" in capsys.readouterr().err
    assert TrainConfig.from_yaml(cfg, settings=["lr=1e-3"]).lr == 1e-3  # YAML 1.1 reads 1e-3 as a string


@pytest.mark.slow
def test_two_real_training_processes_and_a_real_ctrl_c(tiny_run, tmp_path, capsys):
    """The reported case: a second `sspinn train` into the folder of a running one stops
    with the owner's PID; Ctrl-C (SIGINT) to the first saves a checkpoint at a step boundary,
    exits 130 and releases the folder."""
    import time
    from pathlib import Path

    _, data, cfg, _, _ = tiny_run
    out = tmp_path / "shared"
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1])}
    first = subprocess.Popen(
        [sys.executable, "-m", "sspinn", "train", "--config", str(cfg), "--data", str(data), "--out", str(out),
         "--steps", "100000", "--set", "checkpoint_every=1"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
    )
    try:
        deadline = time.monotonic() + 120
        while f'"pid": {first.pid}' not in ((out / ".lock").read_text() if (out / ".lock").exists() else ""):
            assert first.poll() is None and time.monotonic() < deadline, "the first run did not start"
            time.sleep(0.2)
        while not (out / "checkpoint.pt").exists():  # set up, and training (a checkpoint every step)
            assert first.poll() is None and time.monotonic() < deadline
            time.sleep(0.2)
        assert main(["train", "--config", str(cfg), "--data", str(data), "--out", str(out), "--steps", "2"]) == 2
        assert f"in use by PID {first.pid} on host" in capsys.readouterr().err
        first.send_signal(signal.SIGINT)
        printed, err = first.communicate(timeout=120)
    finally:
        if first.poll() is None:
            first.kill()
    assert first.returncode == 130, err
    assert "interrupted at step" in printed and "interrupt: finishing the current step" in err and "Traceback" not in err
    state = torch.load(out / "checkpoint.pt", weights_only=True)
    assert state["step"] >= 0 and (out / ".lock").read_text() == ""
    assert main(["train", "--config", str(cfg), "--data", str(data), "--out", str(out), "--resume",
                 "--steps", str(state["step"] + 1)]) == 0
