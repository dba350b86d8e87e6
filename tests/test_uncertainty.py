"""Intervals on every estimate: Monte Carlo dropout spread × a conformal factor. The factor is
the calibration set's quantile (so the calibration recordings themselves are covered at the
nominal level), the files are checked, a model without dropout is refused in one line, and the
CLI writes intervals beside the estimates and bands and coverage into the evaluation."""

from __future__ import annotations

import contextlib
import io
import json

import numpy as np
import pytest
import yaml

from sspinn.cli import main
from sspinn.data.dataset import Dataset, Labels
from sspinn.estimator import uncertainty as U
from sspinn.estimator.sspinnpose import SSPINNpose
from sspinn.model.conventions import COORDINATES, GRF, JOINTS
from sspinn.testing import make_recording


def _labelled(name: str, rng: np.random.Generator, n: int = 160):
    rec = make_recording(name, name, n, rng)
    t = np.arange(n) / 100
    cols = {c: 0.3 * np.sin(2 * np.pi * t + k) for k, c in enumerate(COORDINATES)}
    cols |= {f"d_{c}": 0.5 * np.cos(2 * np.pi * t + k) for k, c in enumerate(COORDINATES)}
    cols |= {f"tau_{j}": 30 * np.sin(2 * np.pi * t + k) for k, j in enumerate(JOINTS)}
    cols |= {g: (343 if g.startswith("grf_y") else 0) + 100 * np.sin(2 * np.pi * t + k) for k, g in enumerate(GRF)}
    cols["speed"] = np.full(n, 1.3)
    rec.labels = Labels.from_columns(cols, n)
    return rec


@pytest.fixture(scope="module")
def trained(tmp_path_factory: pytest.TempPathFactory):
    """A tiny two-layer model with dropout, trained a few steps; a dataset with train/val/test."""
    root = tmp_path_factory.mktemp("unc")
    rng = np.random.default_rng(5)
    Dataset.write(root / "data", {"train": [_labelled("a", rng), _labelled("b", rng)],
                                  "val": [_labelled("c", rng), _labelled("d", rng)], "test": [_labelled("e", rng)]})
    cfg = root / "tiny.yaml"
    cfg.write_text(yaml.safe_dump({"train": {
        "network": {"hidden": 8, "layers": 2, "dropout": 0.3, "dense": 8}, "steps": 3, "batch_size": 2, "window": 32,
        "log_every": 1, "checkpoint_every": 2, "device": "cpu", "threads": 1}}))
    with contextlib.redirect_stderr(io.StringIO()):
        assert main(["train", "--config", str(cfg), "--data", str(root / "data"), "--out", str(root / "run")]) == 0
    return root


def test_the_factor_is_the_calibration_sets_conformal_quantile(trained):
    est = SSPINNpose.load(trained / "run" / "model.pt")
    recs = Dataset.open(trained / "data").load("val")
    estimates = [est.predict(r) for r in recs]
    cal = U.calibrate(est.network_, est.segments_, trained / "run" / "model.pt", recs, estimates, level=0.8, passes=8)
    widths = [U.intervals(cal, est.network_, est.segments_, r) for r in recs]
    covered = U.coverage(estimates, recs, widths, ["walk"] * len(recs))["walk"]
    for group, value in covered.items():  # on its own calibration data: at least the level, barely more
        assert 0.8 <= value <= 0.85, (group, value)
    assert U.UncertaintyCalibration.from_json(cal.to_json(), "x") == cal
    # the spread is seeded: the same intervals again (also through the estimator object)
    np.testing.assert_array_equal(widths[0], est.intervals(recs[0], cal))


def test_files_and_models_that_do_not_fit_are_refused_in_one_line(trained, tmp_path):
    est = SSPINNpose.load(trained / "run" / "model.pt")
    with pytest.raises(U.UncertaintyError, match="not a usable uncertainty calibration"):
        U.UncertaintyCalibration.from_json('{"format": "sspinn-uncertainty-calibration", "version": 1}', "f.json")
    good = json.loads(U.UncertaintyCalibration("0", 0.9, 16, 0, {c: 1.0 for c in U.CHANNELS}, [], {}).to_json())
    good["factor"]["knee_r"] = float("inf") if False else -1.0
    with pytest.raises(U.UncertaintyError, match="not finite or not positive"):
        U.UncertaintyCalibration.from_json(json.dumps(good), "f.json")
    foreign = tmp_path / "other.uncertainty.json"
    U.save_calibration(U.UncertaintyCalibration("0" * 64, 0.9, 16, 0, {c: 1.0 for c in U.CHANNELS}, [], {}), foreign)
    with pytest.raises(U.UncertaintyError, match="another model file"):
        U.load_calibration(foreign, trained / "run" / "model.pt")
    from sspinn.estimator.network import NetworkConfig, SSPINNposeNet

    plain = SSPINNposeNet(est.network_.n_inputs, NetworkConfig(hidden=8, layers=1, dropout=0.0, dense=8))
    [rec] = Dataset.open(trained / "data").load("test")
    with pytest.raises(U.UncertaintyError, match="no dropout"):
        U.spread(plain, rec, est.segments_)


def test_the_cli_calibrates_writes_intervals_and_bands(trained, capsys):
    model, data = trained / "run" / "model.pt", trained / "data"
    assert main(["calibrate-uncertainty", "--model", str(model), "--data", str(data), "--check", "test", "--passes", "4"]) == 0
    out = capsys.readouterr().out
    assert "coverage of the 90 % intervals on test" in out and "angles" in out
    assert main(["calibrate-uncertainty", "--model", str(model), "--data", str(data), "--check", "test", "--passes", "4"]) == 0
    assert "unchanged" in capsys.readouterr().out
    assert main(["calibrate-uncertainty", "--model", str(model), "--data", str(data), "--passes", "5"]) == 2  # another one
    assert "--overwrite" in capsys.readouterr().err
    assert main(["calibrate-uncertainty", "--model", str(model), "--data", str(data), "--split", "test", "--check", "test"]) == 2
    with contextlib.redirect_stderr(io.StringIO()):
        assert main(["infer", "--model", str(model), "--data", str(data), "--split", "test", "--out", str(trained / "inf")]) == 0
    table = np.genfromtxt(trained / "inf" / "e_uncertainty.csv", delimiter=",", names=True)
    assert "knee_r_pm90" in table.dtype.names and len(table) == 160
    assert np.all(table["knee_r_pm90"] > 0)
    with contextlib.redirect_stderr(io.StringIO()):
        assert main(["evaluate", "--model", str(model), "--data", str(data), "--split", "test", "--out", str(trained / "ev")]) == 0
    metrics = json.loads((trained / "ev" / "metrics.json").read_text())
    [groups] = metrics["interval_coverage"]["by_program"].values()
    assert set(groups) == set(U.GROUPS)
    [widths] = metrics["interval_coverage"]["median_half_width"].values()
    assert set(widths) == set(U.GROUPS) and all(v > 0 for v in widths.values())
    report = (trained / "ev" / "report.md").read_text()
    assert "## Coverage of the 90 % intervals" in report and "Median half-width of the intervals" in report
    # another calibration of the same model, named with --uncertainty: its intervals, not the default file's
    other = trained / "other.uncertainty.json"
    assert main(["calibrate-uncertainty", "--model", str(model), "--data", str(data), "--passes", "4", "--level", "0.6",
                 "--out", str(other)]) == 0
    with contextlib.redirect_stderr(io.StringIO()):
        assert main(["evaluate", "--model", str(model), "--data", str(data), "--split", "test", "--out", str(trained / "ev6"),
                     "--uncertainty", str(other)]) == 0
    assert "## Coverage of the 60 % intervals" in (trained / "ev6" / "report.md").read_text()
    foreign = trained / "foreign.uncertainty.json"
    U.save_calibration(U.UncertaintyCalibration("0" * 64, 0.9, 16, 0, {c: 1.0 for c in U.CHANNELS}, [], {}), foreign)
    assert main(["evaluate", "--model", str(model), "--data", str(data), "--split", "test", "--out", str(trained / "ev7"),
                 "--uncertainty", str(foreign)]) == 2
    assert "another model file" in capsys.readouterr().err


def test_median_half_widths_are_in_the_reports_units_per_program():
    rng = np.random.default_rng(3)
    walk, run = make_recording("w", "w", 160, rng), make_recording("r", "r", 160, rng)
    ones = np.ones((160, len(U.CHANNELS)))
    half = U.median_half_widths([walk, run], [ones, 2 * ones], ["walk", "run"], skip=50)
    assert set(half) == {"walk", "run", "all"} and list(half["walk"]) == list(U.HALF_WIDTH_UNITS)
    bw = walk.mass * 9.81
    assert half["walk"]["angles"] == pytest.approx(np.degrees(1.0))
    assert half["walk"]["torques"] == pytest.approx(100 / (bw * walk.height), rel=1e-3)
    assert half["walk"]["GRF"] == pytest.approx(100 / bw, rel=1e-3)
    assert half["run"]["speed"] == 2.0 and half["walk"]["pelvis velocity"] == 1.0
    assert half["walk"]["speed"] < half["all"]["speed"] <= half["run"]["speed"]
