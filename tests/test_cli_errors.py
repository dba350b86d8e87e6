"""One error path for the three command lines (sspinn.errors.run_cli), the agents' run
folder lock, and the core's independence from envs/predictive/agents."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from sspinn.errors import EXIT_INTERNAL_ERROR, EXIT_INTERRUPTED, EXIT_USER_ERROR, UserError, one_line, run_cli
from sspinn.run_folder import RunFolderBusyError, RunLock

ROOT = Path(__file__).resolve().parents[1]


def _raiser(exc: BaseException):
    def main(argv: list[str]) -> int:
        assert "--debug" not in argv
        raise exc

    return main


@pytest.mark.parametrize(
    ("exc", "code", "text"),
    [
        (UserError("data.csv: column 'x' has nan\nsecond line"), EXIT_USER_ERROR, "prog: error: data.csv: column 'x' has nan | second line\n"),
        (FileNotFoundError("nope.yaml: no such file"), EXIT_USER_ERROR, "prog: error: nope.yaml: no such file\n"),
        (KeyboardInterrupt(), EXIT_INTERRUPTED, "prog: interrupted\n"),
        (ZeroDivisionError("division by zero"), EXIT_INTERNAL_ERROR,
         "prog: internal error: ZeroDivisionError: division by zero (run again with --debug for the traceback and report it)\n"),
    ],
)
def test_run_cli_prints_one_line_and_the_exit_code(capsys, exc, code, text) -> None:
    assert run_cli(_raiser(exc), "prog", ["a"]) == code
    assert capsys.readouterr().err == text
    with pytest.raises(type(exc)):
        run_cli(_raiser(exc), "prog", ["a", "--debug"])


def test_run_cli_passes_the_status_and_extra_user_errors(capsys) -> None:
    assert run_cli(lambda argv: len(argv), "prog", ["x", "y"]) == 2
    assert run_cli(_raiser(LookupError("k")), "prog", [], user_errors=(LookupError,)) == EXIT_USER_ERROR
    assert one_line("a\n\n  b  \n") == "a | b"


@pytest.mark.parametrize(
    "argv",
    [
        [sys.executable, "-m", "sspinn", "infer", "--model", "none.pt", "--data", "nowhere", "--out", "o"],
        [sys.executable, "-m", "predictive", "solve", "--speed", "-1", "--out", "o"],
        [sys.executable, "-m", "agents", "train", "--config", "missing.yaml", "--out", "o"],
    ],
    ids=["sspinn", "predictive", "agents"],
)
@pytest.mark.slow
def test_the_three_command_lines_exit_2_with_one_line(tmp_path: Path, argv: list[str]) -> None:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.run(argv, cwd=tmp_path, capture_output=True, text=True, env=env, timeout=120)
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.count("\n") == 1 and "error:" in proc.stderr and "Traceback" not in proc.stderr, proc.stderr
    debug = subprocess.run([*argv, "--debug"], cwd=tmp_path, capture_output=True, text=True, env=env, timeout=120)
    assert debug.returncode == 1 and "Traceback" in debug.stderr


def test_agents_training_refuses_a_folder_in_use(tmp_path: Path) -> None:
    pytest.importorskip("stable_baselines3")
    from agents.train import train
    from tests.test_agents import tiny

    with RunLock(tmp_path), pytest.raises(RunFolderBusyError, match=f"PID {os.getpid()}"):
        train(tiny(), tmp_path)
    assert not (tmp_path / "checkpoints").exists()


def test_the_core_never_imports_envs_predictive_or_agents() -> None:
    offenders = [
        str(p.relative_to(ROOT)) for p in (ROOT / "sspinn").rglob("*.py")
        for pkg in ("envs", "predictive", "agents")
        if f"import {pkg}" in p.read_text() or f"from {pkg}" in p.read_text()
    ]
    assert offenders == []


class _RunsCode:
    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def __reduce__(self):
        return (os.system, (f"touch {self.marker}",))


def test_agent_files_run_no_code(tmp_path: Path) -> None:
    pytest.importorskip("stable_baselines3")
    import base64
    import json
    import pickle
    import zipfile

    from agents.checkpoints import UnsafeCheckpointError, load_statistics, safe_custom_objects
    from tests.test_agents import tiny

    marker = tmp_path / "pwned"
    evil = base64.b64encode(pickle.dumps(_RunsCode(marker))).decode()
    with zipfile.ZipFile(tmp_path / "model.zip", "w") as archive:
        archive.writestr("data", json.dumps({"policy_class": {":serialized:": evil}, "payload": {":serialized:": evil}}))
    with pytest.raises(UnsafeCheckpointError, match=r"model.zip: holds pickled Python objects \['payload'\]"):
        safe_custom_objects(tmp_path / "model.zip", tiny())
    (tmp_path / "stats.pkl").write_bytes(pickle.dumps(_RunsCode(marker)))
    with pytest.raises(UnsafeCheckpointError, match=r"stats.pkl: not VecNormalize statistics \(refusing to load posix.system\)"):
        load_statistics(tmp_path / "stats.pkl")
    (tmp_path / "junk.zip").write_bytes(b"not a zip")
    with pytest.raises(UnsafeCheckpointError, match="junk.zip: not an SB3 checkpoint"):
        safe_custom_objects(tmp_path / "junk.zip", tiny())
    assert not marker.exists()
