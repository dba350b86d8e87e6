"""Sensor placement fitted to a gait's kinematics (sspinn.estimator.placement_fit): exact
rigid-body sensors moved and turned away from the nominal placement are found again."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from sspinn.data.dataset import Recording
from sspinn.estimator.placement_fit import PlacementFitError, fit_placement
from sspinn.model.body import BodyParameters, IMUPlacement
from sspinn.model.conventions import SEGMENTS
from sspinn.model.kinematics import virtual_imu
from sspinn.validation.sensor_mounting import read_gait_csv

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
