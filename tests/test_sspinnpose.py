"""The estimator object: load → predict agrees with the lower-level calls; fit without a folder;
adapt keeps the names of what its training saw; the CLI refuses to replace a finished run."""

from __future__ import annotations

import contextlib
import io
from pathlib import Path

import numpy as np
import pytest
import torch

import sspinn
from sspinn.cli import main
from sspinn.estimator.inference import estimate_recording
from sspinn.estimator.model_store import load_model
from sspinn.estimator.sspinnpose import NotFittedError, SSPINNpose, resolve_train_config
from sspinn.estimator.training import TrainConfig
from sspinn.testing import tiny_run


@pytest.fixture(scope="module")
def tiny(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, Path]:
    return tiny_run(tmp_path_factory.mktemp("tiny"))


def test_top_level_names_resolve_lazily() -> None:
    assert sspinn.SSPINNpose is SSPINNpose
    assert sspinn.load_model is load_model
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        _ = sspinn.nope  # type: ignore[attr-defined]


def test_load_then_predict_equals_the_lower_level_calls(tiny: tuple[Path, Path, Path]) -> None:
    data, _, run = tiny
    est = SSPINNpose.load(run / "model.pt")
    [rec] = sspinn.open_recordings(data, "test")
    stored = load_model(run / "model.pt")
    expected = estimate_recording(stored.network, rec, stored.segments)
    got = est.predict(rec)
    np.testing.assert_array_equal(got.q, expected.q)
    np.testing.assert_array_equal(got.grf, expected.grf)
    assert est.segments_ == stored.segments and isinstance(est.config_, TrainConfig)
    assert set(est.trained_on_) == {"a", "b"}
    assert "IMUs" in repr(est)


def test_an_unfitted_estimator_says_what_to_do(tiny: tuple[Path, Path, Path]) -> None:
    data, _, _ = tiny
    [rec] = sspinn.open_recordings(data, "test")
    with pytest.raises(NotFittedError, match="fit"):
        SSPINNpose().predict(rec)


def test_fit_without_a_folder_keeps_the_model_in_memory(tiny: tuple[Path, Path, Path]) -> None:
    data, cfg, _ = tiny
    train = sspinn.open_recordings(data, "train")
    with contextlib.redirect_stderr(io.StringIO()):
        est = SSPINNpose(cfg).fit(train)
    assert est.steps_ == 4 and est.stopped_by_ == "steps" and str(est.path_) == "<memory>"
    [rec] = sspinn.open_recordings(data, "test")
    assert np.isfinite(est.predict(rec).tau).all()


def test_adapt_continues_from_the_loaded_weights_and_names_both_trainings(tiny: tuple[Path, Path, Path], tmp_path: Path) -> None:
    data, _, run = tiny
    test = sspinn.open_recordings(data, "test")
    base = SSPINNpose.load(run / "model.pt")
    before = {k: v.clone() for k, v in base.network_.state_dict().items()}
    with contextlib.redirect_stderr(io.StringIO()):
        adapted = SSPINNpose.load(run / "model.pt").adapt(test, out=tmp_path / "adapted", steps=2)
    assert adapted.steps_ == 2 and set(adapted.trained_on_) == {"a", "b", "c"}
    assert any(not torch.equal(before[k], v) for k, v in adapted.network_.state_dict().items())
    assert (tmp_path / "adapted" / "model.pt").exists()
    saved = adapted.save(tmp_path / "copy.pt")
    assert load_model(saved).trained_on == adapted.trained_on_
    # the baselines stay those of the training data: the adaptation recordings' labels never enter them
    assert adapted.baselines_ is not None and adapted.baselines_.fitted_on == ("a", "b") == base.baselines_.fitted_on
    assert load_model(saved).baselines.fitted_on == ("a", "b")
    assert load_model(tmp_path / "adapted" / "checkpoint.pt").baselines.fitted_on == ("a", "b")


def test_named_configs_resolve_from_any_folder(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.chdir(tmp_path)
    assert resolve_train_config("smoke").steps == TrainConfig.from_yaml(Path(__file__).parents[1] / "configs/sspinn/smoke.yaml").steps
    assert resolve_train_config(Path("configs/sspinn/demo.yaml")).window > 0  # the CLI's default, outside the repository


def test_the_cli_never_replaces_a_finished_result(tiny: tuple[Path, Path, Path], capsys: pytest.CaptureFixture[str]) -> None:
    """A second run, evaluation or inference into a folder holding a finished one goes to a new
    folder and says so; ``--overwrite`` replaces; adapt refuses its source model's folder."""
    data, cfg, run = tiny
    before = (run / "model.pt").read_bytes()
    assert main(["train", "--config", str(cfg), "--data", str(data), "--out", str(run), "--steps", "2"]) == 0
    out = capsys.readouterr().out
    assert f"NOTE: {run} holds a run (model.pt, checkpoint.pt); writing to {run}_2 instead" in out and "--overwrite" in out
    assert (run / "model.pt").read_bytes() == before and (run.parent / f"{run.name}_2" / "model.pt").exists()
    assert main(["adapt", "--model", str(run / "model.pt"), "--data", str(data), "--out", str(run)]) == 2
    assert "starts from" in capsys.readouterr().err
    for command, result in (("evaluate", "metrics.json"), ("infer", "*_estimate.csv")):
        out_dir = run.parent / command
        args = [command, "--model", str(run / "model.pt"), "--data", str(data), "--out", str(out_dir)]
        assert main(args) == 0 and main(args) == 0
        assert f"writing to {out_dir}_2 instead" in capsys.readouterr().out
        assert list(out_dir.glob(result)) and list((out_dir.parent / f"{command}_2").glob(result))
        assert main([*args, "--overwrite"]) == 0 and not (out_dir.parent / f"{command}_3").exists()
