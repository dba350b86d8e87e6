"""Independent-engine check: the Kane model against the same body built in pymunk (Chipmunk2D).

Both engines release the body from one state with joint angular velocities of a few rad/s, no
torques and no ground, so the segments swing relative to each other (joint ranges of 40–160°
within the second) while the body falls. pymunk knows nothing of our derivation: it gets masses,
inertias about the centres of mass and pivot positions, and solves the joint constraints with
its iterative impulse solver.

The body is the shared ``body`` fixture of ``conftest.py`` (1.75 m, 70 kg).

Tolerances (measured with dt = 1e-4 s, 100 solver iterations, error_bias = 1e-6 per second):

* Joint angles and pelvis tilt: measured max |Δ| = 0.0088° over 1 s (0.0060° over the first
  0.3 s). Chipmunk integrates with first-order semi-implicit Euler, so the difference is its
  O(dt) truncation error: it halves with dt (0.0044° at 5e-5 s) and doubles at 2e-4 s, and the
  solver iterations hardly matter (20 give the same). Tolerance 0.02° (≈2× the measured value);
  a 2 % error in one segment's inertia already gives 0.076°, a wrong joint sign > 100°.
* Joint rates: measured 0.043°/s, tolerance 0.1°/s.
* Hip position: measured 0.49 mm after 1 s; that is exactly the semi-implicit Euler offset of a
  falling body, ½·g·dt·t = 0.49 mm. Tolerance 1 mm.
* Joint drift (distance between the two anchors of a pivot, from the iterative solver and its
  error correction): measured 0.015 mm, tolerance 0.05 mm.
"""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks.accuracy.pymunk_engine import segment_states, simulate_pymunk
from sspinn.model.body import BodyParameters
from sspinn.model.conventions import SEGMENTS
from sspinn.model.kinematics import point_index, point_kinematics, segment_kinematics
from sspinn.model.simulation import simulate

DURATION = 1.0  # s
SAMPLE_DT = 0.01  # s
PYMUNK_DT = 1e-4  # s
ITERATIONS = 100
ERROR_BIAS = 1e-6  # fraction of joint error left after 1 s

ANGLE_TOL_DEG = 0.02
RATE_TOL_DEG_S = 0.1
HIP_TOL_M = 1e-3
GAP_TOL_M = 5e-5

#: Free-flight initial state: hip 0.95 m up, moving forward, joints bent and swinging.
Q0 = np.array([0.1, 0.95, 0.1, 0.4, -0.6, 0.15, -0.3, -0.2, -0.1])
U0 = np.array([1.2, 0.3, -0.5, 3.0, -4.0, 2.0, -2.5, 3.5, -3.0])


@pytest.fixture(scope="module")
def reference(body: BodyParameters):
    return simulate(Q0, U0, body, duration=DURATION, sample_dt=SAMPLE_DT, substeps=10, contact=None, method="rk4")


def _run_pymunk(body: BodyParameters, dt: float = PYMUNK_DT) -> dict[str, np.ndarray]:
    return simulate_pymunk(
        body, Q0, U0, duration=DURATION, dt=dt, sample_dt=SAMPLE_DT, iterations=ITERATIONS, error_bias=ERROR_BIAS
    )


@pytest.fixture(scope="module")
def pymunk_run(body: BodyParameters) -> dict[str, np.ndarray]:
    return _run_pymunk(body)


def test_initial_geometry_matches_generated_kinematics(body: BodyParameters) -> None:
    """The pymunk set-up's own forward kinematics agrees with the generated code."""
    states = segment_states(body, Q0, U0)
    points = point_kinematics(Q0, U0, np.zeros(9), np.zeros(2), body)
    segments = segment_kinematics(Q0, U0, np.zeros(9))
    for name, point in [
        ("femur_r", "hip"),
        ("tibia_r", "knee_r"),
        ("foot_r", "ankle_r"),
        ("femur_l", "hip"),
        ("tibia_l", "knee_l"),
        ("foot_l", "ankle_l"),
    ]:
        np.testing.assert_allclose(states[name].origin, points[point_index(point), :2], atol=1e-12)
        np.testing.assert_allclose(states[name].origin_velocity, points[point_index(point), 2:4], atol=1e-12)
    for i, name in enumerate(SEGMENTS):
        np.testing.assert_allclose([states[name].angle, states[name].rate], segments[i, :2], atol=1e-12)


def test_joint_angles_agree_with_pymunk(reference, pymunk_run: dict[str, np.ndarray]) -> None:
    np.testing.assert_allclose(pymunk_run["t"], reference.t)
    motion = np.degrees(np.ptp(reference.q[:, 3:], axis=0))
    assert motion.min() > 30.0, f"the test motion is too small to be informative: {motion}"
    angle_err = np.degrees(np.abs(pymunk_run["q"][:, 2:] - reference.q[:, 2:])).max()
    rate_err = np.degrees(np.abs(pymunk_run["u"][:, 2:] - reference.u[:, 2:])).max()
    hip_err = np.abs(pymunk_run["q"][:, :2] - reference.q[:, :2]).max()
    assert angle_err < ANGLE_TOL_DEG, f"pelvis tilt / joint angles differ by {angle_err:.4f} deg"
    assert rate_err < RATE_TOL_DEG_S, f"angular rates differ by {rate_err:.4f} deg/s"
    assert hip_err < HIP_TOL_M, f"hip position differs by {hip_err * 1e3:.3f} mm"


def test_pymunk_joints_stay_together(pymunk_run: dict[str, np.ndarray]) -> None:
    gap = pymunk_run["joint_gap"].max()
    assert gap < GAP_TOL_M, f"pymunk pivot joints drift apart by {gap * 1e3:.4f} mm"


def test_difference_is_pymunk_integration_error(body: BodyParameters, reference, pymunk_run) -> None:
    """Doubling pymunk's step doubles the difference: pymunk converges to our model (first order)."""
    coarse = _run_pymunk(body, dt=2 * PYMUNK_DT)
    err_fine = np.abs(pymunk_run["q"][:, 2:] - reference.q[:, 2:]).max()
    err_coarse = np.abs(coarse["q"][:, 2:] - reference.q[:, 2:]).max()
    assert 1.6 < err_coarse / err_fine < 2.4, f"error ratio {err_coarse / err_fine:.2f} is not first order"
