"""Outputs of ``python -m predictive`` and ``python -m agents``: an error of the operating system
(no space left, read-only file system, permission denied, a file where a folder is expected) is
one line naming the path (:func:`sspinn.errors.run_cli`); every file is written atomically, so a
failure in the middle of a write leaves the previous file (or none) and no temporary file; the
default configuration files are found from any working directory.

A real mid-write failure is made with ``RLIMIT_FSIZE``: the kernel refuses to let this process
grow a file beyond the limit (EFBIG, "File too large") partway through writing it."""

from __future__ import annotations

import contextlib
import errno
import json
import os
import resource
import signal
import subprocess
import sys
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np
import pytest

import predictive.__main__ as predictive_cli
from sspinn.errors import EXIT_INTERNAL_ERROR, EXIT_USER_ERROR, run_cli
from sspinn.run_folder import NonFiniteValueError, atomic_path, atomic_write_json, atomic_write_text

ROOT = Path(__file__).resolve().parents[1]


@contextlib.contextmanager
def file_size_limit(n_bytes: int) -> Iterator[None]:
    """Files written by this process cannot grow beyond ``n_bytes`` (writes fail with EFBIG)."""
    handler = signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    soft, hard = resource.getrlimit(resource.RLIMIT_FSIZE)
    resource.setrlimit(resource.RLIMIT_FSIZE, (n_bytes, hard))
    try:
        yield
    finally:
        resource.setrlimit(resource.RLIMIT_FSIZE, (soft, hard))
        signal.signal(signal.SIGXFSZ, handler)


def _raiser(exc: BaseException) -> Callable[[list[str]], int]:
    def main(argv: list[str]) -> int:
        raise exc

    return main


# ------------------------------------------------------------------------------------------------
# OS errors → one line naming the path
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("exc", "text"),
    [
        (OSError(errno.ENOSPC, "No space left on device", "/data/out.npz"),
         "/data/out.npz: No space left on device; free some space or choose an output folder on another disk"),
        (OSError(errno.EROFS, "Read-only file system", "/mnt/ro/run"),
         "/mnt/ro/run: Read-only file system; choose an output folder on a writable file system"),
        (PermissionError(errno.EACCES, "Permission denied", "/root/x.json"),
         "/root/x.json: Permission denied; check the permissions or choose another path"),
        (NotADirectoryError(errno.ENOTDIR, "Not a directory", "notes.txt/run"),
         "notes.txt/run: Not a directory; a part of this path is a file where a folder is expected"),
        (OSError(errno.EDQUOT, "Disk quota exceeded"), "Disk quota exceeded; free some space or choose an output folder on another disk"),
        (FileNotFoundError("model.pt: no such file"), "model.pt: no such file"),
    ],
)
def test_os_errors_are_one_line_user_errors(capsys, exc: OSError, text: str) -> None:
    assert run_cli(_raiser(exc), "prog", []) == EXIT_USER_ERROR
    assert capsys.readouterr().err == f"prog: error: {text}\n"
    with pytest.raises(type(exc)):
        run_cli(_raiser(exc), "prog", ["--debug"])


def test_other_os_errors_stay_internal(capsys) -> None:
    assert run_cli(_raiser(OSError(errno.EIO, "Input/output error")), "prog", []) == EXIT_INTERNAL_ERROR
    assert "internal error: OSError" in capsys.readouterr().err


def test_atomic_path_names_the_target_not_its_temporary_file(tmp_path: Path) -> None:
    target = tmp_path / "summary.json"
    with pytest.raises(OSError) as caught, atomic_path(target) as tmp:
        tmp.write_text("{")
        raise OSError(errno.ENOSPC, "No space left on device")  # as a write() reports it: no file name
    assert caught.value.errno == errno.ENOSPC and caught.value.filename == str(target)
    assert list(tmp_path.iterdir()) == []


def test_an_output_below_a_file_is_one_line(small_generator, tmp_path: Path, capsys) -> None:
    (tmp_path / "notes.txt").write_text("a file, not a folder")
    out = tmp_path / "notes.txt" / "walk"
    code = predictive_cli.main(["generate", "--model", str(small_generator), "--speed", "1.2", "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "Traceback" not in err, err
    assert f"{tmp_path / 'notes.txt'}: File exists; this is a file where a folder is expected" in err, err


def test_agents_output_below_a_file_is_one_line(tmp_path: Path, capsys) -> None:
    pytest.importorskip("stable_baselines3")
    from agents.__main__ import main

    (tmp_path / "notes.txt").write_text("x")
    (tmp_path / "c.yaml").write_text("algo: ppo\n")
    code = main(["train", "--config", str(tmp_path / "c.yaml"), "--out", str(tmp_path / "notes.txt" / "run")])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "notes.txt" in err, err


def test_a_full_disk_while_generating_is_one_line_and_leaves_no_file(small_generator, tmp_path: Path) -> None:
    """The whole command in a child process whose files may not exceed 4 kB (the solution .npz is larger)."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    script = ("import resource, signal, sys; signal.signal(signal.SIGXFSZ, signal.SIG_IGN); "
              "resource.setrlimit(resource.RLIMIT_FSIZE, (4096, resource.RLIM_INFINITY)); "
              "from predictive.__main__ import main; sys.exit(main(sys.argv[1:]))")
    proc = subprocess.run([sys.executable, "-c", script, "generate", "--model", str(small_generator), "--speed", "1.2",
                           "--out", str(tmp_path / "walk")], capture_output=True, text=True, env=env, timeout=120)
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.count("\n") == 1 and "Traceback" not in proc.stderr, proc.stderr
    assert f"{tmp_path / 'walk.npz'}: File too large" in proc.stderr, proc.stderr
    assert not [p.name for p in tmp_path.iterdir()], "a partial or temporary file was left"


# ------------------------------------------------------------------------------------------------
# atomic writes: a failure mid-write keeps the previous file and leaves no temporary file
# ------------------------------------------------------------------------------------------------
def _keeps_the_old_file(path: Path, write: Callable[[], object], limit: int) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(b"previous")
    with pytest.raises(OSError) as caught, file_size_limit(limit):
        write()
    assert caught.value.errno == errno.EFBIG
    assert path.read_bytes() == b"previous"
    assert not [p.name for p in path.parent.iterdir() if p.name.endswith(".tmp")]


def test_text_and_json_writes_are_atomic(tmp_path: Path) -> None:
    big = {"values": list(range(2000))}
    _keeps_the_old_file(tmp_path / "a.json", lambda: atomic_write_json(tmp_path / "a.json", big), 1000)
    _keeps_the_old_file(tmp_path / "a.md", lambda: atomic_write_text(tmp_path / "a.md", "x" * 5000), 1000)
    with pytest.raises(NonFiniteValueError, match=r"b.json: refusing to write non-finite nan at runs\[1\].speed"):
        atomic_write_json(tmp_path / "b.json", {"runs": [{"speed": 1.0}, {"speed": float("nan")}]})
    assert not (tmp_path / "b.json").exists()
    atomic_write_json(tmp_path / "c.json", {"x": float("inf"), "y": [np.float32(1.5)]}, non_finite="null", default=float)
    assert json.loads((tmp_path / "c.json").read_text()) == {"x": None, "y": [1.5]}


def test_figures_and_solutions_are_written_atomically(small_generator, tmp_path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from predictive.generator.gait_generator import generate, load_generator
    from sspinn.model.drawing import save_figure

    fig, ax = plt.subplots()
    ax.plot(np.arange(100), np.sin(np.arange(100)))
    _keeps_the_old_file(tmp_path / "f.png", lambda: save_figure(fig, tmp_path / "f.png"), 2000)
    model, config = load_generator(small_generator)
    sol = generate(model, 1.2, n=50, config=config)
    _keeps_the_old_file(tmp_path / "s.npz", lambda: sol.save(tmp_path / "s"), 2000)


def test_generator_history_is_written_atomically(tmp_path: Path) -> None:
    from predictive.generator.gait_generator import GeneratorConfig, GeneratorTrainer

    trainer = GeneratorTrainer(GeneratorConfig(harmonics=2, hidden=8, layers=1), tmp_path)
    trainer.history_ = [{"step": k, "wall_s": 0.1 * k, "total": 1.0 / (k + 1)} for k in range(500)]
    _keeps_the_old_file(tmp_path / "history.csv", trainer._write_history, 2000)


def test_agent_files_are_written_atomically(tmp_path: Path) -> None:
    pytest.importorskip("stable_baselines3")
    from agents.checkpoints import save_checkpoint, vecnormalize_path
    from agents.config import save_config
    from agents.evaluate import write_animation
    from tests.test_agents import tiny

    frames = [np.full((40, 60, 3), k, dtype=np.uint8) for k in range(30)]
    _keeps_the_old_file(tmp_path / "walk.gif", lambda: write_animation(frames, tmp_path / "walk.gif", 25), 1000)
    config = tiny()
    _keeps_the_old_file(tmp_path / "config.yaml", lambda: save_config(config, tmp_path / "config.yaml"), 100)

    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    from agents.builders import make_env

    venv = VecNormalize(DummyVecEnv([lambda: make_env(config)]))
    model = PPO("MlpPolicy", venv, n_steps=64, batch_size=32, policy_kwargs={"net_arch": [8]}, device="cpu")
    path = tmp_path / "checkpoints" / "model_64_steps.zip"
    _keeps_the_old_file(path, lambda: save_checkpoint(model, path, venv), 5000)
    assert not vecnormalize_path(path).exists() or vecnormalize_path(path).stat().st_size > 0
    venv.close()


# ------------------------------------------------------------------------------------------------
# default configuration files from another working directory
# ------------------------------------------------------------------------------------------------
def test_default_configs_are_the_shipped_ones() -> None:
    parser = predictive_cli.build_parser()
    for argv in (["train-generator", "--out", "o"], ["synth", "--out", "o"], ["compare", "--out", "o"]):
        config = parser.parse_args(argv).config
        assert config.is_absolute() and config.is_file() and config.is_relative_to(ROOT / "configs"), config


def test_train_generator_runs_from_another_folder(tmp_path: Path) -> None:
    env = {**os.environ, "PYTHONPATH": str(ROOT), "OMP_NUM_THREADS": "1"}
    sets = ["harmonics=2", "hidden=8", "layers=1", "points=4", "batch_size=2", "warmup_steps=1", "steps=1",
            "snapshot_every=0", "threads=1", "polish_iterations=0"]
    proc = subprocess.run([sys.executable, "-m", "predictive", "train-generator", "--out", "run",
                           *[a for s in sets for a in ("--set", s)]],
                          cwd=tmp_path, capture_output=True, text=True, env=env, timeout=180)
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "run" / "generator.pt").is_file() and (tmp_path / "run" / "config.yaml").is_file()


def test_torch_files_on_a_full_disk_are_os_errors_naming_the_file(tmp_path: Path) -> None:
    import torch

    from sspinn.torch_files import save_torch_file

    _keeps_the_old_file(tmp_path / "generator.pt",
                        lambda: save_torch_file(tmp_path / "generator.pt", "gait-generator", {"w": torch.zeros(10_000)}), 4096)
    with pytest.raises(OSError) as caught, file_size_limit(4096):
        save_torch_file(tmp_path / "g2.pt", "gait-generator", {"w": torch.zeros(10_000)})
    assert caught.value.filename == str(tmp_path / "g2.pt")


# ------------------------------------------------------------------------------------------------
# a finished result is never replaced without --overwrite
# ------------------------------------------------------------------------------------------------
def test_generate_writes_beside_an_earlier_gait_unless_overwrite(small_generator, tmp_path: Path, capsys) -> None:
    out = tmp_path / "walk_1.2"
    argv = ["generate", "--model", str(small_generator), "--speed", "1.2", "--out", str(out)]
    assert predictive_cli.main(argv) == 0
    first = (tmp_path / "walk_1.2.npz").read_bytes()
    capsys.readouterr()
    assert predictive_cli.main(argv) == 0
    assert f"NOTE: {out} holds a generated gait; writing to {tmp_path / 'walk_1.2_2'} instead" in capsys.readouterr().out
    assert (tmp_path / "walk_1.2.npz").read_bytes() == first and (tmp_path / "walk_1.2_2.npz").is_file()
    (tmp_path / "walk_1.2.npz").write_bytes(b"old")
    assert predictive_cli.main([*argv, "--overwrite"]) == 0
    assert (tmp_path / "walk_1.2.npz").read_bytes() == first and not (tmp_path / "walk_1.2_3.npz").exists()


def test_train_generator_starts_a_new_folder_beside_a_finished_run(tmp_path: Path, capsys) -> None:
    sets = ["harmonics=2", "hidden=8", "layers=1", "points=4", "batch_size=2", "warmup_steps=1", "steps=1",
            "snapshot_every=0", "threads=1", "polish_iterations=0"]
    argv = ["train-generator", "--out", str(tmp_path / "run"), *[a for s in sets for a in ("--set", s)]]
    assert predictive_cli.main(argv) == 0
    before = (tmp_path / "run" / "generator.pt").stat().st_mtime_ns
    capsys.readouterr()
    assert predictive_cli.main(argv) == 0
    assert "NOTE:" in capsys.readouterr().out and (tmp_path / "run_2" / "generator.pt").is_file()
    assert (tmp_path / "run" / "generator.pt").stat().st_mtime_ns == before
    (tmp_path / "run" / "snapshots").mkdir()  # a file of the old run that the new one does not write
    assert predictive_cli.main([*argv, "--overwrite"]) == 0
    assert not (tmp_path / "run" / "snapshots").exists() and not (tmp_path / "run_3").exists()
    assert predictive_cli.main([*argv, "--overwrite", "--resume"]) == 2


def test_synth_refuses_to_replace_a_dataset_of_another_configuration(tmp_path: Path) -> None:
    from predictive.synth import pipeline

    index = {"splits": {"train": ["a"]}, "info": {"generator": pipeline.GENERATOR_NAME, "config_key": "1" * 64}}
    (tmp_path / "dataset.json").write_text(json.dumps(index))
    (tmp_path / "a.csv").write_text("x")
    pipeline._check_out_dir(tmp_path, "1" * 64, overwrite=False)  # the same configuration: written again
    with pytest.raises(FileExistsError, match="another configuration or generator version.*--overwrite"):
        pipeline._check_out_dir(tmp_path, "2" * 64, overwrite=False)
    pipeline._check_out_dir(tmp_path, "2" * 64, overwrite=True)
    assert (tmp_path / "a.csv").exists()  # nothing is removed before the new recordings are ready
    pipeline._remove_earlier_output(tmp_path)
    assert list(tmp_path.iterdir()) == []
