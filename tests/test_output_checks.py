"""No estimate or report is written with non-finite values, and nothing is
written when a command fails."""

from __future__ import annotations

import json

import numpy as np
import pytest

from sspinn.cli import main
from sspinn.data.dataset import Dataset
from sspinn.estimator.inference import ImplausibleEstimateError, NonFiniteEstimateError, estimate_recording
from sspinn.estimator.model_store import load_model
from sspinn.estimator.network import SSPINNposeNet


@pytest.fixture()
def nan_network(monkeypatch):
    real = SSPINNposeNet.forward

    def forward(self, x, *a, **k):
        raw, state = real(self, x, *a, **k)
        raw = raw.clone()
        raw[:, 30:, 5] = float("nan")  # a NaN from sample 30 on
        return raw, state

    monkeypatch.setattr(SSPINNposeNet, "forward", forward)


def test_a_nan_estimate_is_an_error_naming_the_quantity_and_sample(tiny_run, nan_network):
    _, data, _, _, run = tiny_run
    stored = load_model(run / "model.pt")
    model, segments = stored.network, stored.segments
    rec = Dataset.open(data).load("test")[0]
    with pytest.raises(NonFiniteEstimateError, match=r"c: the estimate's q is not finite from sample 30 on"):
        estimate_recording(model, rec, segments)


@pytest.mark.parametrize("command", ["infer", "evaluate"])
def test_infer_and_evaluate_write_nothing_from_a_nan_network(tiny_run, nan_network, tmp_path, capsys, command):
    _, data, _, _, run = tiny_run
    assert main([command, "--model", str(run / "model.pt"), "--data", str(data), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "not finite from sample 30" in err and err.count("\n") == 1
    assert not (tmp_path / "o").exists()


def test_evaluate_without_labels_or_with_too_large_skip_leaves_no_folder(tiny_run, tmp_path, capsys):
    _, data, _, _, run = tiny_run
    rec = Dataset.open(data).load("test")[0]
    rec.labels = None
    Dataset.write(tmp_path / "unlabelled", {"test": [rec]})
    args = ["evaluate", "--model", str(run / "model.pt"), "--out", str(tmp_path / "rep")]
    assert main([*args, "--data", str(tmp_path / "unlabelled")]) == 2
    assert "no labels to evaluate against" in capsys.readouterr().err
    assert main([*args, "--data", str(data), "--skip", "500"]) == 2
    assert "--skip 500 leaves no samples" in capsys.readouterr().err
    assert not (tmp_path / "rep").exists()


def test_metrics_without_a_label_group_are_null_not_nan(tiny_run, tmp_path):
    _, data, _, _, run = tiny_run
    rec = Dataset.open(data).load("test")[0]
    rec.labels.tau = None  # no torque labels: the torque error is not defined
    Dataset.write(tmp_path / "d", {"test": [rec]})
    assert main(["evaluate", "--model", str(run / "model.pt"), "--data", str(tmp_path / "d"), "--out", str(tmp_path / "r"),
                 "--skip", "10"]) == 0
    text = (tmp_path / "r" / "metrics.json").read_text()
    assert "NaN" not in text and json.loads(text)["mean"]["jte_pct_bwbh"] is None
    assert "n/a" in (tmp_path / "r" / "report.md").read_text() and "nan" not in (tmp_path / "r" / "report.md").read_text()


def test_a_saved_estimate_is_finite(tiny_run, tmp_path):
    _, data, _, _, run = tiny_run
    stored = load_model(run / "model.pt")
    model, segments = stored.network, stored.segments
    est = estimate_recording(model, Dataset.open(data).load("test")[0], segments)
    est.grf[3, 1] = np.inf
    with pytest.raises(NonFiniteEstimateError, match="grf is not finite from sample 3"):
        est.to_csv(tmp_path / "e.csv")
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize(("column", "value", "message"), [
    (5, 50.0, r"c: the estimated pelvis tilt / joint angle reaches \d+(\.\d+)? rad at sample 30"),
    (8, 500.0, r"c: the estimated forward pelvis speed reaches \d+(\.\d+)? m/s at sample 30"),
])
def test_a_physically_impossible_estimate_is_an_error(tiny_run, monkeypatch, tmp_path, capsys, column, value, message):
    _, data, _, _, run = tiny_run
    real = SSPINNposeNet.forward

    def forward(self, x, *a, **k):
        raw, state = real(self, x, *a, **k)
        raw = raw.clone()
        raw[:, 30:, column] = value  # raw outputs far outside what training produces
        return raw, state

    monkeypatch.setattr(SSPINNposeNet, "forward", forward)
    stored = load_model(run / "model.pt")
    model, segments = stored.network, stored.segments
    with pytest.raises(ImplausibleEstimateError, match=message):
        estimate_recording(model, Dataset.open(data).load("test")[0], segments)
    assert main(["infer", "--model", str(run / "model.pt"), "--data", str(data), "--out", str(tmp_path / "o")]) == 2
    assert "no human movement reaches; nothing written" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


def test_labels_with_a_negative_vertical_force_are_refused() -> None:
    import numpy as np

    from sspinn.estimator.evaluation import EvaluationError, check_evaluable
    from sspinn.testing import walking_recording

    rec = walking_recording()
    assert rec.labels is not None and rec.labels.grf is not None
    rec.labels.grf[:, 1] *= -1.0  # the vertical force negated
    with pytest.raises(EvaluationError, match="vertical GRF labels reach -1.02 BW"):
        check_evaluable([], [rec], 0)
    rec.labels.grf[:, 1] = np.abs(rec.labels.grf[:, 1])
    check_evaluable([], [rec], 0)
