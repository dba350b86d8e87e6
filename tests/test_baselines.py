"""Trivial predictors (sspinn/estimator/trivial_predictors.py) and the report's comparison with them."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from sspinn.data.dataset import Labels, Recording
from sspinn.estimator.evaluation import compare_with_baseline, compute_metrics, speed_tracking_error, write_report
from sspinn.estimator.trivial_predictors import ALL, TrivialPredictor, program_of
from sspinn.model.conventions import COORDINATES, GRAVITY, GRF, JOINTS, SEGMENTS

T = 300


def _recording(name: str, program: str, speed: float, grf_bw: float, seed: int, mass: float = 70.0, T: int = T) -> Recording:
    rng = np.random.default_rng(seed)
    t = np.arange(T) / 100.0
    imu = rng.standard_normal((T, len(SEGMENTS), 3))
    imu[:, :, 1] += GRAVITY  # specific force: gravity on the vertical axis
    cols = {c: 0.3 * np.sin(2 * np.pi * t + i) + 0.1 * i for i, c in enumerate(COORDINATES)}
    cols["pelvis_tx"] = speed * t
    cols |= {f"tau_{j}": 20 * np.sin(2 * np.pi * t + i) for i, j in enumerate(JOINTS)}
    cols |= {g: grf_bw * mass * GRAVITY * (1 + 0.5 * np.sin(2 * np.pi * t)) for g in GRF}
    cols["speed"] = np.full(T, speed)
    return Recording(
        name=name, imu=imu, segments=SEGMENTS, height=1.75, mass=mass,
        labels=Labels.from_columns(cols, T), provenance={"program": {"name": program}},
    )


def test_means_are_per_program_and_the_prediction_is_constant() -> None:
    walk, run = _recording("w", "walk", 1.3, 0.5, 0), _recording("r", "run", 3.0, 0.8, 1)
    pred = TrivialPredictor.fit([walk, run], "train")
    assert set(pred.means) == {"walk", "run", ALL}
    assert pred.means["walk"].speed == pytest.approx(1.3) and pred.means["run"].speed == pytest.approx(3.0)
    assert pred.means[ALL].speed == pytest.approx(2.15)
    np.testing.assert_allclose(pred.means["run"].grf_bw, 0.8, rtol=1e-2)
    heavy = _recording("x", "run", 3.3, 0.8, 2, mass=90.0)
    est = pred.predict(heavy)
    assert np.all(est.tau == 0) and np.allclose(est.u[:, 0], 3.0)
    np.testing.assert_allclose(est.grf, np.tile(pred.means["run"].grf_bw * 90.0 * GRAVITY, (T, 1)))  # × body weight
    assert np.ptp(est.q[:, 2:], axis=0).max() == 0  # constant posture
    m = compute_metrics(est, heavy)
    assert m.speed_error_mps == pytest.approx(0.3)
    # a program the reference never saw falls back to the means over all recordings
    assert pred.means_for(_recording("s", "sprint", 6.0, 1.0, 3)).speed == pytest.approx(2.15)
    assert program_of(Recording("n", heavy.imu, SEGMENTS, 1.75, 70.0)) == ALL
    imported = Recording("Sub05_CSBaseline", heavy.imu, SEGMENTS, 1.75, 70.0)  # no program: the name's last part
    assert program_of(imported) == ALL and program_of(imported, from_name=True) == "CSBaseline"
    assert program_of(_recording("s", "sprint", 6.0, 1.0, 3), from_name=True) == "sprint"
    with pytest.raises(ValueError, match="no recording with the labels"):
        TrivialPredictor.fit([Recording("n", heavy.imu, SEGMENTS, 1.75, 70.0)], "nothing")


def test_report_says_plainly_when_the_estimate_is_worse(tmp_path: Path) -> None:
    train = [_recording("w", "walk", 1.3, 0.5, 0), _recording("r", "run", 3.0, 0.8, 1)]
    tests = [_recording("w2", "walk", 1.4, 0.5, 4), _recording("r2", "run", 3.2, 0.8, 5)]
    pred = TrivialPredictor.fit(train, "training split")
    perfect = [pred.predict(r) for r in tests]
    for est, rec in zip(perfect, tests):  # the true labels: every error zero except jitter
        est.q[:] = rec.labels.q
        est.tau[:] = rec.labels.tau
        est.grf[:] = rec.labels.grf
        est.u[:, 0] = rec.labels.speed
    cmp = compare_with_baseline(perfect, tests, pred)
    assert set(cmp) == {"walk", "run", "all"} and all(not c["worse_than_baseline"] for c in cmp.values())
    # the trivial predictor itself is never better than itself: every metric flagged
    cmp = compare_with_baseline([pred.predict(r) for r in tests], tests, pred)
    assert set(cmp["walk"]["worse_than_baseline"]) == {"jae_deg", "jte_pct_bwbh", "grfe_pct_bw", "speed_error_mps", "speed_tracking_mps"}
    result = write_report([pred.predict(r) for r in tests], tests, tmp_path, "t", baseline=pred)
    text = (tmp_path / "report.md").read_text()
    assert "WORSE than the baseline" in text and "### walk" in text and "### run" in text
    assert result["by_program"]["run"]["baseline"]["speed_error_mps"] == pytest.approx(0.2)


def test_speed_tracking_sees_what_the_mean_speed_error_cannot() -> None:
    """A recording at 1.0 then 1.6 m/s (mean 1.3): the trivial predictor that knows the mean has
    no speed error but a tracking error of 0.3 m/s; an estimate that follows the speed, 10 %
    slow, has a speed error of 0.13 and a tracking error of 0.13."""
    n = 400  # two 2-s windows
    rec = _recording("w", "walk", 1.3, 0.5, 0, T=n)
    speed = np.where(np.arange(n) < n // 2, 1.0, 1.6)
    rec.labels.speed[:] = speed
    pred = TrivialPredictor.fit([_recording("t", "walk", 1.3, 0.5, 1)], "train")
    m = compute_metrics(pred.predict(rec), rec)
    assert m.speed_error_mps == pytest.approx(0.0, abs=1e-12) and m.speed_tracking_mps == pytest.approx(0.3)
    est = pred.predict(rec)
    est.u[:, 0] = 0.9 * speed
    m = compute_metrics(est, rec)
    assert m.speed_error_mps == pytest.approx(0.13) and m.speed_tracking_mps == pytest.approx(0.1 * np.sqrt(0.5 * (1.0 + 1.6**2)))
    # only whole windows count; none fits → NaN
    assert speed_tracking_error(np.r_[np.ones(200), 5 * np.ones(50)], np.zeros(250), 100.0) == pytest.approx(1.0)
    assert np.isnan(speed_tracking_error(np.ones(199), np.zeros(199), 100.0))


def test_reference_predictor_is_labelled_by_what_it_was_fitted_on() -> None:
    from sspinn.estimator.trivial_predictors import ORACLE_SOURCE, reference_predictor

    a, b, c = (_recording(n, "walk", 1.3 + 0.1 * k, 0.5, k) for k, n in enumerate("abc"))
    assert reference_predictor([a, b], [a, b], "d").source == ORACLE_SOURCE  # split "all": train is the evaluated set
    assert reference_predictor([a, b], None, "d").source == ORACLE_SOURCE
    assert reference_predictor([a, b], [a], "d").source == f"{ORACLE_SOURCE} (1 of the 2: the training split of d)"
    partial = reference_predictor([a, b], [b, c], "d")
    assert "holds 1 of the 2 evaluated recordings (in part an oracle)" in partial.source
    fair = reference_predictor([a], [b, c], "d")
    assert fair.source == "means of the training split of d" and fair.means[ALL].speed == pytest.approx(1.45)
    unlabelled = Recording("u", c.imu, SEGMENTS, 1.75, 70.0)
    assert reference_predictor([a], [unlabelled], "d").source == f"{ORACLE_SOURCE} (the training split of d has no labels)"


def _split_all_data(folder: Path, speed: float = 1.3) -> Path:
    """Two recordings p, q in every split (``sspinn import --split all``), at ``speed`` m/s."""
    from sspinn.imu.pipeline import add_to_index
    from sspinn.testing import make_recording

    folder.mkdir()
    rng = np.random.default_rng(0)
    for name in ("p", "q"):
        rec = make_recording(name, name, 150, rng)
        rec.labels.speed[:] = speed
        add_to_index(folder, rec, "all")
    return folder


def _old_format_copy(model: Path, out: Path) -> Path:
    """``model`` as a file written before model files stored their baselines (no such entry)."""
    import torch

    state = torch.load(model, weights_only=True)
    del state["baselines"]
    torch.save(state, out)
    return out


def test_evaluate_with_an_old_model_file_after_import_split_all_calls_the_baseline_an_oracle(
        tmp_path: Path, tiny_run, capsys) -> None:
    """A model file without stored baselines and a folder where every recording is in train, val
    and test (``sspinn import --split all``): the trivial predictor is fitted on the evaluated
    recordings and must say so, and that the model file stores none."""
    from sspinn.cli import main
    from sspinn.estimator.model_store import load_model

    old = _old_format_copy(tiny_run[4] / "model.pt", tmp_path / "old.pt")
    assert load_model(old).baselines is None
    data = _split_all_data(tmp_path / "data")
    assert main(["evaluate", "--model", str(old), "--data", str(data), "--out", str(tmp_path / "ev"), "--skip", "10"]) == 0
    printed = capsys.readouterr().out
    assert "against the trivial predictors (oracle: fitted on the evaluated recordings):" in printed
    [note] = [line for line in printed.splitlines() if line.startswith("NOTE:")]
    assert "stores no trivial predictors of its training data" in note and "oracle" in note
    report = (tmp_path / "ev" / "report.md").read_text()
    assert "(oracle: fitted on the evaluated recordings)" in report and "training" not in report


def _plain(pred: TrivialPredictor) -> str:
    """The predictor's plain data as text (NaN, for a label column no recording has, equal to NaN)."""
    import json

    return json.dumps(pred.to_dict(), sort_keys=True)


def test_stored_baselines_round_trip_through_the_model_file(tiny_run, tmp_path: Path) -> None:
    """Training stores the means of its training recordings' labels (a, b: 1.3 m/s); model file
    and checkpoint give them back, and a file saved again keeps them."""
    import torch

    from sspinn.estimator.model_store import load_model, save_model
    from sspinn.estimator.trivial_predictors import TRAINING_SOURCE

    _, _, _, train, run = tiny_run
    stored = load_model(run / "model.pt")
    pred = stored.baselines
    assert pred is not None and pred.source == TRAINING_SOURCE and pred.fitted_on == ("a", "b")
    expected = TrivialPredictor.fit(train, TRAINING_SOURCE)
    assert pred.means[ALL].speed == pytest.approx(1.3) and pred.means[ALL].n_samples == 300
    np.testing.assert_allclose(pred.means[ALL].q, expected.means[ALL].q)
    np.testing.assert_allclose(pred.means[ALL].grf_bw, expected.means[ALL].grf_bw)
    assert pred.means[ALL].froude == pytest.approx(expected.means[ALL].froude)
    assert _plain(load_model(run / "checkpoint.pt").baselines) == _plain(pred)
    # plain data only: the file loads with weights_only, and the entry survives a save
    assert isinstance(torch.load(run / "model.pt", weights_only=True)["baselines"]["programs"][ALL]["q"], list)
    again = save_model(stored.network, tmp_path / "again.pt", stored.segments, stored.config, stored.imu_std, (), pred)
    assert _plain(load_model(again).baselines) == _plain(pred)
    with pytest.raises(ValueError, match="malformed|shape"):
        TrivialPredictor.from_dict({**pred.to_dict(), "programs": {ALL: {**pred.to_dict()["programs"][ALL], "q": [0.0]}}})


def test_evaluate_prefers_the_stored_baselines_and_never_fits_on_the_evaluated_recordings(tmp_path: Path, tiny_run, capsys) -> None:
    """The evaluated recordings walk at 2.0 m/s, the model's training recordings at 1.3: the
    mean-speed baseline is 0.7 m/s off. A baseline fitted on the evaluated recordings (or on the
    split-"all" training split next to them) would be 0 off."""
    import json

    from sspinn.cli import main

    data = _split_all_data(tmp_path / "data", speed=2.0)
    assert main(["evaluate", "--model", str(tiny_run[4] / "model.pt"), "--data", str(data), "--out", str(tmp_path / "ev"),
                 "--skip", "10"]) == 0
    printed = capsys.readouterr().out
    assert "against the trivial predictors (means of the model's training data):" in printed and "NOTE:" not in printed
    assert "Froude speed" in printed
    metrics = json.loads((tmp_path / "ev" / "metrics.json").read_text())
    assert metrics["baseline_source"] == "means of the model's training data" and metrics["baselines_stored_in_model"]
    assert metrics["by_program"][ALL]["baseline"]["speed_error_mps"] == pytest.approx(0.7)
    # 1.75 m subjects throughout: the Froude speed is the mean speed
    assert metrics["by_program"][ALL]["froude"]["speed_error_mps"] == pytest.approx(0.7)
    report = (tmp_path / "ev" / "report.md").read_text()
    assert "(means of the model's training data)" in report and "(Froude speed)" in report and "oracle" not in report


def test_stored_baselines_of_the_evaluated_recordings_are_called_an_oracle(tiny_run) -> None:
    from sspinn.estimator.model_store import load_model
    from sspinn.estimator.trivial_predictors import ORACLE_SOURCE, reference_predictor

    _, _, _, train, run = tiny_run
    stored = load_model(run / "model.pt").baselines
    assert reference_predictor(train, None, "d", stored).source == ORACLE_SOURCE
    assert reference_predictor(train[:1], None, "d", stored).source == (
        "means of the model's training data, which holds 1 of the 1 evaluated recordings (in part an oracle)")
    other = _recording("z", "walk", 1.3, 0.5, 7)
    assert reference_predictor([other], [other], "d", stored) is stored  # the split next to the data is not used
    assert "holds 1 of the 2 evaluated recordings (in part an oracle)" in reference_predictor([train[0], other], None, "d", stored).source


def test_froude_speed_scales_with_the_square_root_of_leg_length() -> None:
    """Fitted on one 1.75 m subject at 1.3 m/s: the Froude speed of 1.75 m is 1.3; of two
    subjects of other heights, in the ratio sqrt(L1 / L2) (leg length ∝ height)."""
    from sspinn.estimator.trivial_predictors import leg_length

    pred = TrivialPredictor.fit([_recording("t", "walk", 1.3, 0.5, 0)], "train")
    same = _recording("s", "walk", 1.0, 0.5, 1)
    assert pred.speed_for(same, "froude") == pytest.approx(1.3) and pred.speed_for(same) == pytest.approx(1.3)
    short, tall = _recording("a", "walk", 1.0, 0.5, 2), _recording("b", "walk", 1.0, 0.5, 3)
    short.height, tall.height = 1.55, 1.95
    l1, l2 = leg_length(short), leg_length(tall)
    assert l1 / l2 == pytest.approx(1.55 / 1.95) and 0.75 < l1 < 0.9
    v1, v2 = pred.speed_for(short, "froude"), pred.speed_for(tall, "froude")
    assert v1 / v2 == pytest.approx(np.sqrt(l1 / l2)) and v1 < 1.3 < v2
    assert pred.means["walk"].froude == pytest.approx(1.3**2 / (GRAVITY * leg_length(same)))
    est = pred.predict(tall, speed="froude")
    assert np.allclose(est.u[:, 0], v2) and compute_metrics(est, tall).speed_error_mps == pytest.approx(v2 - 1.0)
    # subjects who walk at the training Froude number: the Froude speed knows their speeds, the mean speed does not
    short.labels.speed[:], tall.labels.speed[:] = v1, v2
    cmp = compare_with_baseline([pred.predict(r) for r in (short, tall)], [short, tall], pred)
    assert cmp["walk"]["froude"]["speed_error_mps"] == pytest.approx(0.0, abs=1e-12)
    assert cmp["walk"]["baseline"]["speed_error_mps"] == pytest.approx(((1.3 - v1) + (v2 - 1.3)) / 2)
    assert cmp["walk"]["worse_than_froude"] == ["speed_error_mps", "speed_tracking_mps"]
    with pytest.raises(ValueError, match="speed must be one of"):
        pred.speed_for(same, "median")


def test_resuming_a_checkpoint_without_baselines(tiny_run, tmp_path: Path) -> None:
    """A checkpoint from before the entry existed: a training from scratch (it saw only its own
    recordings) fits them on resume; one that started from another model (its ``trained_on``
    names more recordings) stores none rather than the labels of its adaptation recordings."""
    import contextlib
    import dataclasses
    import io
    import shutil

    import torch

    from sspinn.estimator.model_store import load_model
    from sspinn.estimator.training import TrainConfig, Trainer

    _, _, cfg, train, run = tiny_run
    config = dataclasses.replace(TrainConfig.from_yaml(cfg), steps=5)
    for name, trained_on, fitted_on in (("scratch", ("a", "b"), ("a", "b")), ("adapted", ("x", "a", "b"), None)):
        folder = tmp_path / name
        shutil.copytree(run, folder, ignore=shutil.ignore_patterns("*.lock"))
        state = torch.load(folder / "checkpoint.pt", weights_only=True)
        del state["baselines"]
        state["trained_on"] = trained_on
        torch.save(state, folder / "checkpoint.pt")
        with contextlib.redirect_stderr(io.StringIO()):
            Trainer(config, folder).fit(train, resume=True)
        stored = load_model(folder / "model.pt").baselines
        assert (stored.fitted_on if stored is not None else None) == fitted_on, name
