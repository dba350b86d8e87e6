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


def test_evaluate_after_import_split_all_calls_the_baseline_an_oracle(tmp_path: Path, tiny_run, capsys) -> None:
    """A folder where every recording is in train, val and test (``sspinn import --split all``):
    the trivial predictor is fitted on the evaluated recordings and must say so."""
    from sspinn.cli import main
    from sspinn.imu.pipeline import add_to_index
    from sspinn.testing import make_recording

    _, _, _, _, run = tiny_run
    data = tmp_path / "data"
    data.mkdir()
    rng = np.random.default_rng(0)
    for name in ("p", "q"):
        rec = make_recording(name, name, 150, rng)
        rec.save(data)
        add_to_index(data, rec, "all")
    assert main(["evaluate", "--model", str(run / "model.pt"), "--data", str(data), "--out", str(tmp_path / "ev"), "--skip", "10"]) == 0
    printed = capsys.readouterr().out
    assert "against the trivial predictors (oracle: fitted on the evaluated recordings):" in printed
    report = (tmp_path / "ev" / "report.md").read_text()
    assert "(oracle: fitted on the evaluated recordings)" in report and "training split" not in report
