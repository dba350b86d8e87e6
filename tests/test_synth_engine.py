"""Synthetic data on joblib backends (predictive.synth.joblib_backend, predictive.synth.pipeline):
the same recordings whatever the backend and the number of workers, progress from every backend,
one-line errors for a backend that does not exist or does not start.

The slow tests generate configs/synth/smoke.yaml cold once in this process (2 subjects × 2 s),
then again with two loky workers from the same periodic gaits (the workers solve the chains);
about 1.5 min on 2 idle cores."""

from __future__ import annotations

import dataclasses
import importlib.util
import json
import shutil
from pathlib import Path
from typing import Any

import joblib
import numpy as np
import pytest

from predictive.__main__ import main as cli_main
from predictive.synth import pipeline
from predictive.synth.config import SynthConfig
from predictive.synth.joblib_backend import BackendError, joblib_backends
from predictive.synth.pipeline import generate_dataset
from sspinn.data.dataset import Dataset
from sspinn.model.conventions import SEGMENTS

SMOKE = Path(__file__).resolve().parents[1] / "configs" / "synth" / "smoke.yaml"


class _Bar:
    """Stands in for the tqdm bar: counts the seconds of data reported."""

    def __init__(self, total: float) -> None:
        self.total = total
        self.n = 0.0
        self.stages: list[str] = []

    def set_description(self, stage: str, refresh: bool = False) -> None:
        self.stages.append(stage)

    def update(self, seconds: float) -> None:
        self.n += seconds

    def close(self) -> None:
        pass


@pytest.fixture
def bars(monkeypatch: pytest.MonkeyPatch) -> list[_Bar]:
    made: list[_Bar] = []

    def progress_bar(enabled: bool, total: float) -> _Bar:
        made.append(_Bar(total))
        return made[-1]

    monkeypatch.setattr(pipeline, "_progress_bar", progress_bar)
    return made


def _smoke(cache: Path, **changes: Any) -> SynthConfig:
    return dataclasses.replace(SynthConfig.from_yaml(SMOKE), cache_dir=str(cache), **changes)


def _files(dataset: Dataset) -> dict[str, bytes]:
    """The recordings' CSV and JSON files by name."""
    root = Path(dataset.root)
    names = [n for split in dataset.splits.values() for n in split]
    return {f"{n}{ext}": (root / f"{n}{ext}").read_bytes() for n in names for ext in (".csv", ".json")}


@pytest.fixture(scope="module")
def serial(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Dataset]:
    """The smoke config generated cold with workers = 1 (in this process)."""
    root = tmp_path_factory.mktemp("serial")
    return root, generate_dataset(_smoke(root / "cache"), root / "out", progress=False)


# ------------------------------------------------------------------------------ same data
@pytest.mark.slow
def test_two_loky_workers_give_the_serial_recordings(serial, tmp_path: Path, bars: list[_Bar]) -> None:
    root, reference = serial
    assert reference.info["cache"]["chain_solved"] == 2
    cache = tmp_path / "cache"
    shutil.copytree(root / "cache" / "periodic", cache / "periodic")  # the workers solve the chains
    config = _smoke(cache, workers=2, backend="loky")
    parallel = generate_dataset(config, tmp_path / "out")
    stats = parallel.info["cache"]
    assert stats["chain_solved"] == 2 and stats["recording_made"] == 2 and stats["periodic_solved"] == 0
    assert parallel.splits == reference.splits
    assert _files(parallel) == _files(reference)
    # the workers' stages reached the bar (through the manager queue), every second of data
    assert any("stride" in s or "periodic" in s for s in bars[0].stages)
    assert bars[0].n == pytest.approx(bars[0].total)
    assert parallel.info["solver"]["build_time_s"] > 0


@pytest.mark.slow
def test_a_backend_registered_by_the_user_gives_the_same_files(serial, tmp_path: Path, bars: list[_Bar]) -> None:
    """A backend unknown to joblib until the user's code registers it (as ray's or a cluster's
    would be): subject-level progress instead of the queue, the same files."""
    root, reference = serial
    joblib.register_parallel_backend("synth-test-threads", joblib.parallel.BACKENDS["threading"])
    assert "synth-test-threads" in joblib_backends()
    config = _smoke(root / "cache", workers=2, backend="synth-test-threads")
    again = generate_dataset(config, tmp_path / "out")
    assert again.info["cache"]["recording_hits"] == 2
    assert _files(again) == _files(reference)
    assert bars[0].n == pytest.approx(bars[0].total)
    assert sum(s.endswith(": done") for s in bars[0].stages) == 2


@pytest.mark.slow
def test_the_placement_benchmark_scores_the_fits_against_the_stored_truth(serial, tmp_path: Path, capsys) -> None:
    """``benchmarks/studies/placement_recovery.py`` on generated data: every sensor scored (the joint-centre
    fits on thighs and shanks), finite errors, the nominal error is the stored truth's distance
    from the nominal, and the fit to the true kinematics lands nearer the truth than the nominal."""
    import runpy

    root, _ = serial
    bench = runpy.run_path(str(Path(__file__).resolve().parents[1] / "benchmarks" / "studies" / "placement_recovery.py"), run_name="bench")
    result = bench["main"](["--data", str(root / "out"), "--json", str(tmp_path / "p.json")])
    assert {r["sensor"] for r in result["rows"]} == set(SEGMENTS)
    legs = [r for r in result["rows"] if r["sensor"][:5] in ("femur", "tibia")]
    assert legs and all(np.isfinite([r["nominal_cm"], r["joint_centres_cm"], r["joint_centres_angle_deg"]]).all() for r in legs)
    assert all(np.isfinite([r["labels_cm"], r["labels_angle_deg"]]).all() for r in result["rows"])
    assert any(r["nominal_cm"] > 0 for r in result["rows"])  # the error model moved the sensors
    assert np.median([r["labels_cm"] for r in result["rows"]]) < np.median([r["nominal_cm"] for r in result["rows"]])
    out = capsys.readouterr().out
    assert "| thigh |" in out and "fitted to the true kinematics" in out
    assert json.loads((tmp_path / "p.json").read_text())["summary"]


# ------------------------------------------------------------------------------ fast
def test_a_bad_backend_name_is_one_line_naming_the_valid_ones(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(BackendError, match=r"'nope' is not a joblib backend; valid: .*loky.*threading"):
        generate_dataset(_smoke(tmp_path / "cache", workers=2, backend="nope"), tmp_path / "out", progress=False)
    assert not (tmp_path / "out").exists()
    code = cli_main(
        ["synth", "--config", str(SMOKE), "--out", str(tmp_path / "cli"), "--workers", "2", "--backend", "nope"]
    )
    err = capsys.readouterr().err
    assert code == 2
    assert err.count("\n") == 1 and "valid: " in err and "loky" in err and "multiprocessing" in err
    assert not (tmp_path / "cli").exists()


def test_one_worker_runs_in_this_process_whatever_the_backend(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """workers = 1 never asks joblib (a backend name is only checked when it is used)."""

    def no_joblib(*args: Any, **kwargs: Any) -> None:
        raise AssertionError("joblib used with workers = 1")

    monkeypatch.setattr(pipeline, "_generate_parallel", no_joblib)
    monkeypatch.setattr(pipeline, "backend_context", no_joblib)
    monkeypatch.setattr(pipeline, "template_library", lambda *a, **k: None)

    def stop(*args: Any, **kwargs: Any) -> None:
        raise RuntimeError("stop")

    monkeypatch.setattr(pipeline, "generate_subject", stop)
    with pytest.raises(RuntimeError, match="stop"):
        generate_dataset(_smoke(tmp_path / "cache", backend="nope"), tmp_path / "out", progress=False)


@pytest.mark.skipif(importlib.util.find_spec("distributed") is not None, reason="dask.distributed is installed")
def test_a_backend_that_cannot_start_is_one_line(tmp_path: Path) -> None:
    with pytest.raises(BackendError, match=r"backend 'dask' .* does not start: .*dask"):
        generate_dataset(_smoke(tmp_path / "cache", workers=2, backend="dask"), tmp_path / "out", progress=False)


def test_a_worker_keeps_its_compiled_stride_nlps_for_its_next_subjects() -> None:
    """One StrideSolverCache per worker thread and settings (building the NLPs takes seconds)."""
    import threading

    settings = SynthConfig.from_yaml(SMOKE).stride
    first = pipeline._worker_solvers(settings)
    assert pipeline._worker_solvers(settings) is first
    other = dataclasses.replace(settings, w_terminal=settings.w_terminal + 1.0)
    assert pipeline._worker_solvers(other) is not first
    in_thread: list[Any] = []
    thread = threading.Thread(target=lambda: in_thread.append(pipeline._worker_solvers(other)))
    thread.start()
    thread.join()
    assert in_thread[0] is not pipeline._worker_solvers(other)


def test_how_and_where_do_not_change_the_dataset_key() -> None:
    config = SynthConfig.from_yaml(SMOKE)
    moved = dataclasses.replace(
        config, workers=8, backend="dask", backend_options={"scheduler_host": "tcp://h:8786"}, cache_dir="/elsewhere"
    )
    assert moved.key() == config.key()
    assert dataclasses.replace(config, seed=1).key() != config.key()
    assert SynthConfig.from_dict(moved.to_dict()) == moved
    with pytest.raises(ValueError, match="backend"):
        dataclasses.replace(config, backend="")
