"""The dataset index has one writer: locked, atomic, and safe against name collisions and paths."""

from __future__ import annotations

import json
import multiprocessing as mp
from pathlib import Path

import numpy as np
import pytest

from sspinn.data.dataset import DataFormatError, Dataset
from sspinn.testing import make_recording


def _add_many(root: str, worker: int) -> None:
    rng = np.random.default_rng(worker)
    for k in range(5):
        Dataset.add(root, make_recording(f"w{worker}_{k}", f"s{worker}", 50, rng), ("train",))


def test_concurrent_adds_lose_nothing(tmp_path: Path) -> None:
    ctx = mp.get_context("fork")
    procs = [ctx.Process(target=_add_many, args=(str(tmp_path), w)) for w in range(3)]
    for p in procs:
        p.start()
    for p in procs:
        p.join()
    assert all(p.exitcode == 0 for p in procs)
    index = json.loads((tmp_path / "dataset.json").read_text())
    assert sorted(index["splits"]["train"]) == sorted(f"w{w}_{k}" for w in range(3) for k in range(5))
    assert len(Dataset.open(tmp_path).load("train")) == 15


def test_a_name_taken_is_refused_and_only_overwrite_by_the_same_subject_replaces(tmp_path: Path) -> None:
    rng = np.random.default_rng(0)
    Dataset.add(tmp_path, make_recording("walk", "s1", 50, rng), ("train",))
    with pytest.raises(DataFormatError, match="already holds a recording 'walk'.*--overwrite"):
        Dataset.add(tmp_path, make_recording("walk", "s1", 60, rng), ("test",))
    with pytest.raises(DataFormatError, match="subject 's1'"):
        Dataset.add(tmp_path, make_recording("walk", "s2", 50, rng), ("test",), overwrite=True)
    assert Dataset.open(tmp_path).splits == {"train": ["walk"]}
    Dataset.add(tmp_path, make_recording("walk", "s1", 60, rng), ("test",), overwrite=True)
    assert Dataset.open(tmp_path).splits == {"train": [], "test": ["walk"]}


def test_a_file_of_the_same_name_not_in_the_index_is_not_replaced(tmp_path: Path) -> None:
    (tmp_path / "a.csv").write_text("labelled\n")  # e.g. a synthetic dataset's recording
    with pytest.raises(DataFormatError, match="already holds a recording 'a'"):
        Dataset.add(tmp_path, make_recording("a", "s1", 50, np.random.default_rng(0)), ("train",))
    assert (tmp_path / "a.csv").read_text() == "labelled\n"


def test_an_index_naming_a_path_outside_is_refused(tmp_path: Path) -> None:
    (tmp_path / "outside").mkdir()
    (tmp_path / "outside" / "secret.csv").write_text("x\n")
    (tmp_path / "d").mkdir()
    (tmp_path / "d" / "dataset.json").write_text(json.dumps({"splits": {"train": ["../outside/secret"]}}))
    with pytest.raises(DataFormatError, match="'../outside/secret' is not a usable recording name"):
        Dataset.open(tmp_path / "d")


def test_the_dataset_lock_never_follows_a_symbolic_link(tmp_path: Path) -> None:
    victim = tmp_path / "victim"
    victim.write_text("precious\n")
    (tmp_path / "d").mkdir()
    (tmp_path / "d" / ".dataset.lock").symlink_to(victim)
    with pytest.raises(DataFormatError, match="symbolic link"):
        Dataset.add(tmp_path / "d", make_recording("a", "s1", 50, np.random.default_rng(0)), ("train",))
    assert victim.read_text() == "precious\n"


@pytest.mark.parametrize("name", ["../x", "/tmp/abs", "dataset", "a/b", "..", "", ".hidden", "two\nlines",
                                  "walk_calibration"])
def test_names_that_escape_or_collide_are_refused(tmp_path: Path, name: str) -> None:
    with pytest.raises(DataFormatError, match="not a usable recording name"):
        Dataset.add(tmp_path / "d", make_recording(name, "s1", 50, np.random.default_rng(0)), ("train",))
    assert not (tmp_path / "x.csv").exists() and not (tmp_path / "d" / "dataset.json").exists()


def test_write_leaves_no_temporary_files(tmp_path: Path) -> None:
    rng = np.random.default_rng(1)
    Dataset.write(tmp_path, {"train": [make_recording("a", "s1", 50, rng)], "test": [make_recording("b", "s2", 50, rng)]})
    assert sorted(p.name for p in tmp_path.iterdir() if not p.name.startswith(".dataset.lock")) == [
        "a.csv", "a.json", "b.csv", "b.json", "dataset.json"]
