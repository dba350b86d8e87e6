"""Sensor placement fitted to a gait's kinematics (benchmarks.studies.placement_fit): exact
rigid-body sensors moved and turned away from the nominal placement are found again."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from benchmarks.studies.placement_fit import PlacementFitError, fit_placement, segment_motion
from sspinn.data.dataset import Recording
from sspinn.model.body import BodyParameters, IMUPlacement
from sspinn.model.conventions import SEGMENTS
from sspinn.model.kinematics import virtual_imu
from sspinn.testing.sensor_mounting import read_gait_csv

GAIT = Path(__file__).resolve().parent / "fixtures" / "predicted_walk_1.3.csv"


@pytest.fixture(scope="module")
def walk():
    """Five strides of the predicted 1.3 m/s walk (the acceleration does not depend on pelvis_tx,
    so repeating the stride is exact), a body and its nominal placement."""
    stride = read_gait_csv(GAIT)
    q, u, qdd = (np.tile(v, (5, 1)) for v in (stride.q, stride.u, stride.qdd))
    body = BodyParameters.from_anthropometry(1.75, 70.0)
    return q, u, qdd, body, IMUPlacement.default(body.height).vector().reshape(len(SEGMENTS), 3)


def _recording(walk, truth: np.ndarray, bias: np.ndarray, segments: tuple[str, ...] = SEGMENTS) -> Recording:
    q, u, qdd, body, nominal = walk
    imu = virtual_imu(q, u, qdd, truth.ravel(), body.vector())
    imu[:, :, :2] += bias
    idx = [SEGMENTS.index(s) for s in segments]
    return Recording("moved", imu[:, idx], segments, body.height, body.mass,
                     placement=IMUPlacement.from_vector(nominal.ravel()))


def test_the_segment_motion_terms_are_the_virtual_imu(walk) -> None:
    """a₀ + A_x·x + A_y·y, turned by θ, is the generated virtual IMU of a sensor at (x, y, θ)."""
    q, u, qdd, body, nominal = walk
    a0, ax, ay = segment_motion(type("Gait", (), {"q": q, "u": u, "qdd": qdd})(), body).terms()
    placement = nominal + [0.03, -0.05, 0.2]
    x, y, theta = (placement[:, i][None, :, None] for i in range(3))
    a = a0 + ax * x + ay * y
    turned = np.stack((np.cos(theta[..., 0]) * a[..., 0] + np.sin(theta[..., 0]) * a[..., 1],
                       -np.sin(theta[..., 0]) * a[..., 0] + np.cos(theta[..., 0]) * a[..., 1]), axis=-1)
    np.testing.assert_allclose(turned, virtual_imu(q, u, qdd, placement.ravel(), body.vector())[..., :2], atol=1e-9)


def test_moved_and_turned_sensors_are_found_again(walk) -> None:
    q, u, qdd, body, nominal = walk
    rng = np.random.default_rng(0)
    truth = nominal + np.column_stack((rng.choice([-1, 1], (7, 2)) * 0.03, rng.choice([-1, 1], 7) * np.radians(5.0)))
    bias = rng.normal(0.0, 0.2, (7, 2))
    rec = _recording(walk, truth, bias)

    gait = type("Gait", (), {"q": q, "u": u, "qdd": qdd})()  # the true kinematics: the fit must land on the truth
    fit = fit_placement(rec, gait, body)
    found = fit.placement.vector().reshape(len(SEGMENTS), 3)
    np.testing.assert_allclose(found[:, :2], truth[:, :2], atol=1e-4)  # m
    np.testing.assert_allclose(found[:, 2], truth[:, 2], atol=1e-4)  # rad
    np.testing.assert_allclose(fit.bias, bias, atol=1e-3)  # m/s²
    assert (fit.rms < 1e-4).all() and (fit.rms_nominal > 0.1).all()


def test_segments_without_a_sensor_keep_the_nominal_placement(walk) -> None:
    q, u, qdd, body, nominal = walk
    truth = nominal + [0.02, -0.02, 0.05]
    rec = _recording(walk, truth, np.zeros((7, 2)), segments=("pelvis", "femur_r", "foot_l"))
    gait = type("Gait", (), {"q": q, "u": u, "qdd": qdd})()
    fit = fit_placement(rec, gait, body)
    found = fit.placement.vector().reshape(len(SEGMENTS), 3)
    for k, seg in enumerate(SEGMENTS):
        expected = truth[k] if seg in rec.segments else nominal[k]
        np.testing.assert_allclose(found[k], expected, atol=1e-4)
    assert fit.segments == rec.segments and np.isnan(fit.rms[SEGMENTS.index("tibia_r")])


def test_a_gait_of_another_length_or_a_short_recording_is_refused(walk) -> None:
    q, u, qdd, body, nominal = walk
    rec = _recording(walk, nominal, np.zeros((7, 2)))
    short = type("Gait", (), {"q": q[:-5], "u": u[:-5], "qdd": qdd[:-5]})()
    with pytest.raises(PlacementFitError, match="moved: the gait has"):
        fit_placement(rec, short, body)
    broken = q.copy()
    broken[7, 3] = np.nan
    with pytest.raises(PlacementFitError, match="moved: its q are not all finite"):
        fit_placement(rec, type("Gait", (), {"q": broken, "u": u, "qdd": qdd})(), body)
    with pytest.raises(PlacementFitError, match="moved: its qdd are missing"):
        fit_placement(rec, type("Gait", (), {"q": q, "u": u, "qdd": None})(), body)
    few = _recording((q[:150], u[:150], qdd[:150], body, nominal), nominal, np.zeros((7, 2)))
    with pytest.raises(PlacementFitError, match="too short"):
        fit_placement(few, type("Gait", (), {"q": q[:150], "u": u[:150], "qdd": qdd[:150]})(), body)


def test_with_the_angles_kept_only_positions_and_biases_move(walk) -> None:
    q, u, qdd, body, nominal = walk
    truth = nominal + [0.03, -0.02, 0.0]  # moved, not turned: the kept angle is the true one
    bias = np.full((7, 2), 0.1)
    rec = _recording(walk, truth, bias)
    fit = fit_placement(rec, type("Gait", (), {"q": q, "u": u, "qdd": qdd})(), body, angles=False)
    found = fit.placement.vector().reshape(len(SEGMENTS), 3)
    np.testing.assert_allclose(found, truth, atol=1e-4)
    np.testing.assert_allclose(fit.bias, bias, atol=1e-3)


def test_the_recovery_benchmark_finds_moved_sensors_with_a_model(walk, tmp_path: Path, capsys) -> None:
    """``benchmarks/studies/placement_recovery.py --model --misplacements`` on exact sensors of a
    3.3-s walk stored with their true placement: every method scored, the fit to the true
    kinematics on the truth, the misplacement table for every leg segment (a 4-step model: only
    that it runs, not how well)."""
    import dataclasses
    import runpy

    from sspinn.data.dataset import Dataset
    from sspinn.testing import make_recording, tiny_run

    q, u, qdd, body, nominal = walk
    n = 330
    rng = np.random.default_rng(1)
    recs = {}
    for split, names in (("train", ("a_walk",)), ("test", ("b_run",))):
        recs[split] = []
        for name in names:
            truth = nominal + np.column_stack((rng.normal(0.0, 0.02, (7, 2)), rng.normal(0.0, 0.05, 7)))
            base = make_recording(name, name[0], n, rng)
            labels = dataclasses.replace(base.labels, q=q[:n], u=u[:n], qdd=qdd[:n])
            stored = {s: {"position_m": list(truth[k, :2]), "angle_rad": float(truth[k, 2])} for k, s in enumerate(SEGMENTS)}
            recs[split].append(dataclasses.replace(
                base, imu=virtual_imu(q[:n], u[:n], qdd[:n], truth.ravel(), body.vector()), labels=labels,
                placement=IMUPlacement.from_vector(nominal.ravel()),
                provenance={"program": {"name": name.split("_")[1]}, "ground_truth": {"imu_placement": stored}}))
    Dataset.write(tmp_path / "data", recs)
    _, _, run = tiny_run(tmp_path / "model")
    bench = runpy.run_path(str(Path(__file__).resolve().parents[1] / "benchmarks" / "studies" / "placement_recovery.py"), run_name="bench")
    result = bench["main"](["--data", str(tmp_path / "data"), "--model", str(run / "model.pt"), "--misplacements",
                            "--decompose", "--json", str(tmp_path / "p.json")])
    assert {r["sensor"] for r in result["rows"]} == set(SEGMENTS)
    assert all(r["labels_cm"] < 0.05 and np.isfinite(r["estimate_cm"]) for r in result["rows"])  # exact sensors: on the truth
    assert {r["misplacement"] for r in result["misplaced"]} >= {"5 cm", "30°"}
    assert all(np.isfinite([r["estimate_cm"], r["estimate_angle_deg"]]).all() for r in result["misplaced"])
    # --decompose: every arm for every sensor; exact sensors on the true motion land on the truth
    assert {r["arm"] for r in result["decomposed"]} == {"none", "origin_acc", "angle", "rate", "angular_acc", "all"}
    assert len(result["decomposed"]) == 6 * 2 * len(SEGMENTS)
    assert all(r["fit_cm"] < 0.05 for r in result["decomposed"] if r["arm"] == "none")
    assert all(np.isfinite(r["fit_cm"]) for r in result["decomposed"])
    out = capsys.readouterr().out
    assert "fitted to the estimate" in out and "| walk | 20 cm |" in out and "What of the estimate limits the fit" in out
    # --pieces: each 1.5-s piece fitted on its own (two per 3.3-s recording, the rest left out)
    pieces = bench["main"](["--data", str(tmp_path / "data"), "--pieces", "1.5"])
    assert sorted({r["recording"] for r in pieces["rows"]}) == ["a_walk[0-1.5 s]", "a_walk[1.5-3 s]", "b_run[0-1.5 s]",
                                                                "b_run[1.5-3 s]"]
    assert all(r["labels_cm"] < 0.05 for r in pieces["rows"])
