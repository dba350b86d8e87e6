"""Nothing lost: locks never follow links or truncate foreign files, export and import never
replace a file without --overwrite (sspinn.run_folder, sspinn.cli, sspinn.imu.pipeline)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from sspinn.cli import main
from sspinn.imu.pipeline import recording_target
from sspinn.run_folder import RunLock, UnsafeLockFileError

ROOT = Path(__file__).resolve().parents[1]
PRETRAINED = ROOT / "models" / "pretrained" / "model.pt"


def _victim(tmp_path: Path) -> Path:
    victim = tmp_path / "victim"
    victim.write_text("precious\n")
    return victim


def test_a_lock_that_is_a_symbolic_link_is_refused_untouched(tmp_path: Path, capsys) -> None:
    victim = _victim(tmp_path)
    (tmp_path / "r").mkdir()
    (tmp_path / "r" / ".lock").symlink_to(victim)
    with pytest.raises(UnsafeLockFileError, match=r"r/\.lock: is a symbolic link .* never followed"):
        RunLock(tmp_path / "r").acquire()
    assert victim.read_text() == "precious\n"
    # the command line: one line, exit 2, the file untouched
    assert main(["train", "--data", str(tmp_path / "none"), "--out", str(tmp_path / "r")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "symbolic link" in err and victim.read_text() == "precious\n"


def test_a_lock_that_is_a_hard_link_or_a_foreign_file_is_refused_untouched(tmp_path: Path) -> None:
    victim = _victim(tmp_path)
    (tmp_path / "h").mkdir()
    os.link(victim, tmp_path / "h" / ".lock")
    with pytest.raises(UnsafeLockFileError, match="hard link"):
        RunLock(tmp_path / "h").acquire()
    (tmp_path / "g").mkdir()
    (tmp_path / "g" / ".lock").write_text("notes of mine\n")
    with pytest.raises(UnsafeLockFileError, match="not a lock file of sspinn"):
        RunLock(tmp_path / "g").acquire()
    assert victim.read_text() == "precious\n" and (tmp_path / "g" / ".lock").read_text() == "notes of mine\n"
    (tmp_path / "g" / ".lock").write_text("")  # an empty lock file (a clean exit's) is taken
    with RunLock(tmp_path / "g"):
        assert '"pid"' in (tmp_path / "g" / ".lock").read_text()


def test_export_never_replaces_a_file_without_overwrite(tmp_path: Path, capsys) -> None:
    if not PRETRAINED.exists():
        pytest.skip(f"{PRETRAINED} absent")
    model = tmp_path / "model.pt"
    model.write_bytes(PRETRAINED.read_bytes())
    assert main(["export", "--model", str(model), "--out", str(model)]) == 2
    assert "is the model file" in capsys.readouterr().err and model.read_bytes() == PRETRAINED.read_bytes()
    (tmp_path / "checkpoint.pt").write_text("mine\n")
    assert main(["export", "--model", str(model), "--out", str(tmp_path / "checkpoint.pt")]) == 0
    out = capsys.readouterr().out
    assert "NOTE:" in out and "checkpoint_2.pt" in out and (tmp_path / "checkpoint.pt").read_text() == "mine\n"
    assert (tmp_path / "checkpoint_2.pt").stat().st_size > 0
    assert not [p for p in tmp_path.iterdir() if p.name.endswith(".tmp.pt2")]


def test_import_names_never_replace_silently(tmp_path: Path, capsys) -> None:
    (tmp_path / "a.csv").write_text("labelled\n")
    assert recording_target(tmp_path, "a", overwrite=False) == "a_2"
    assert "NOTE:" in capsys.readouterr().out
    assert recording_target(tmp_path, "a", overwrite=True) == "a"
    (tmp_path / "b_calibration.md").write_text("a report\n")  # the report of a recording removed since
    assert recording_target(tmp_path, "b", overwrite=False) == "b_2"
    for bad in ("X_calibration", "", ".hidden", "new\nline"):
        with pytest.raises(ValueError, match="not a usable recording name"):
            recording_target(tmp_path, bad, overwrite=False)


@pytest.mark.parametrize("command", ["calibrate-quality", "calibrate-uncertainty"])
def test_calibrations_never_replace_the_model_or_a_file_that_is_no_calibration(tmp_path: Path, capsys, command) -> None:
    model = tmp_path / "model.pt"
    model.write_bytes(b"PK\x03\x04 not really a model")
    for target, needle in ((model, "is the model file being calibrated"), (tmp_path / "notes.bin", "no calibration (not JSON)")):
        if target != model:
            target.write_bytes(b"\xff\xfe binary")
        before = target.read_bytes()
        assert main([command, "--model", str(model), "--data", str(tmp_path), "--out", str(target), "--overwrite"]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and needle in err, err
        assert target.read_bytes() == before
