"""Body parameters: Winter scaling, validation, YAML round trip."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sspinn.model.body import PARAMETERS, BodyParameters, IMUPlacement, JointLimits, ParameterError, Segment
from sspinn.model.contact import ContactParameters


def test_reference_gait2d_parameterisation():
    """75 kg / 1.80 m reproduces the gait2d table of ../shared/data/README.md."""
    b = BodyParameters.from_anthropometry(1.80, 75.0)
    assert b.pelvis.mass == pytest.approx(50.85)
    assert b.pelvis.inertia == pytest.approx(3.178, abs=1e-3)
    assert b.pelvis.com[1] == pytest.approx(0.3155, abs=1e-4)
    assert b.femur_r.mass == pytest.approx(7.5)
    assert b.femur_r.inertia == pytest.approx(0.1522, abs=1e-4)
    assert b.femur_r.com[1] == pytest.approx(-0.191, abs=1e-3)
    assert b.femur_r.length == pytest.approx(0.441)
    assert b.tibia_l.mass == pytest.approx(3.4875)
    assert b.tibia_l.inertia == pytest.approx(0.0624, abs=1e-4)
    assert b.tibia_l.com[1] == pytest.approx(-0.1917, abs=1e-4)
    assert b.foot_r.mass == pytest.approx(1.0875)
    assert b.foot_r.inertia == pytest.approx(0.0184, abs=1e-4)
    assert b.foot_r.com == pytest.approx((0.0768, -0.0351))
    assert b.foot_r.heel == pytest.approx((-0.06, -0.0702))
    assert b.foot_r.toe == pytest.approx((0.1636, -0.0702))
    assert b.segment_mass_total == pytest.approx(75.0)


def test_scaling_is_linear():
    a = BodyParameters.from_anthropometry(1.6, 60.0)
    b = BodyParameters.from_anthropometry(1.6 * 1.1, 60.0 * 1.2)
    assert b.femur_r.length == pytest.approx(1.1 * a.femur_r.length)
    assert b.femur_r.mass == pytest.approx(1.2 * a.femur_r.mass)
    assert b.femur_r.inertia == pytest.approx(1.2 * 1.1**2 * a.femur_r.inertia)


def test_vector_layout(body):
    v = body.vector()
    assert v.shape == (len(PARAMETERS),) == (41,)
    assert v[PARAMETERS.index("femur_l_length")] == body.femur_l.length
    assert v[PARAMETERS.index("foot_r_toe_x")] == body.foot_r.toe[0]


@pytest.mark.parametrize(
    "height, mass, match",
    [(0.0, 70.0, "height"), (1.75, -70.0, "mass"), (float("nan"), 70.0, "finite"), (175.0, 70.0, "metres"), (1.75, 0.07, "kilograms")],
)
def test_bad_anthropometry_is_rejected(height, mass, match):
    with pytest.raises(ParameterError, match=match):
        BodyParameters.from_anthropometry(height, mass)


def test_bad_segment_is_rejected():
    with pytest.raises(ParameterError, match="mass"):
        Segment(mass=-1.0, inertia=0.1, com=(0, -0.2), length=0.4)
    with pytest.raises(ParameterError, match="inertia"):
        Segment(mass=1.0, inertia=float("nan"), com=(0, -0.2), length=0.4)
    with pytest.raises(ParameterError, match="damping"):
        ContactParameters(damping=-1.0)


def test_yaml_round_trip(tmp_path, body):
    path = tmp_path / "body.yaml"
    body.to_yaml(path)
    again = BodyParameters.from_yaml(path)
    np.testing.assert_allclose(again.vector(), body.vector())


def test_yaml_errors_name_the_file(tmp_path):
    path = tmp_path / "bad.yaml"
    path.write_text("body:\n  height: 1.75\n  mass: 70\n  wingspan: 2\n")
    with pytest.raises(ParameterError, match="bad.yaml.*wingspan"):
        BodyParameters.from_yaml(path)
    path.write_text("body:\n  height: 1.75\n")
    with pytest.raises(ParameterError, match="bad.yaml.*mass"):
        BodyParameters.from_yaml(path)


def test_default_config_loads():
    from pathlib import Path

    b = BodyParameters.from_yaml(Path(__file__).resolve().parents[1] / "configs" / "body" / "default.yaml")
    assert b.height == 1.75 and b.mass == 70.0


def test_segment_override_from_dict():
    b = BodyParameters.from_dict({"height": 1.75, "mass": 70, "femur_r": {"mass": 9.0}})
    assert b.femur_r.mass == 9.0 and b.femur_l.mass != 9.0


def test_imu_placement_and_limits():
    imu = IMUPlacement.default(1.75)
    assert IMUPlacement.from_vector(imu.vector()) == imu
    with pytest.raises(ParameterError, match="missing"):
        IMUPlacement(positions={"pelvis": (0.0, 0.0)})
    lo, hi = JointLimits().arrays()
    assert lo[1] == pytest.approx(-math.pi / 3) and hi[1] == pytest.approx(0.1)


def test_anatomical_limits_admit_what_the_generator_may_produce():
    """The estimator's anatomical bounds contain the synthetic generator's ranges of motion (so L_B
    never fights a true synthetic gait); the paper's bounds stop the knee at 60°, short of the
    generator's running swing (up to 120°)."""
    from predictive.ocp.settings import default_joint_limits

    gen_lo, gen_hi = default_joint_limits().arrays()
    lo, hi = JointLimits.named("anatomical").arrays()
    assert np.all(lo <= gen_lo) and np.all(hi >= gen_hi)
    paper_lo, _ = JointLimits.named("paper").arrays()
    assert paper_lo[1] > gen_lo[1] and lo[1] == pytest.approx(-math.radians(140))
    with pytest.raises(ParameterError, match="unknown set 'loose'"):
        JointLimits.named("loose")
