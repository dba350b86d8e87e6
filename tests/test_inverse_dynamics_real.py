"""Inverse dynamics of real recordings against references computed by others.

The data-driven tests need ``../shared/data`` (relative to the repository root) and skip without
it; the thresholds are set from the measured agreement with some margin (see
``benchmarks/accuracy/validate_inverse_dynamics.py`` for the numbers).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from benchmarks.accuracy.inverse_dynamics import (
    Comparison,
    csu_inverse_dynamics,
    csu_reference_replica,
    opensim_inverse_dynamics,
)
from sspinn.data.measured_loads import contact_fraction_for_load
from sspinn.data.opensim_files import OpenSimFormatError, read_opensim_header, read_opensim_table
from tests.conftest import shared_data


@pytest.fixture(scope="module")
def csu() -> Comparison:
    return csu_inverse_dynamics(shared_data("csu_2d_inverse_dynamics"))


@pytest.fixture(scope="module")
def opensim() -> Comparison:
    return opensim_inverse_dynamics(shared_data("opensim_subject01_walk"))


# ------------------------------------------------------------------------------ CSU (leg2d)
def test_csu_knee_and_ankle_moments_correlate(csu: Comparison) -> None:
    for joint in ("knee_r", "ankle_r"):
        stats = csu.stat(joint)
        assert stats.r >= 0.9, f"{joint}: r = {stats.r:.3f}"


def test_csu_moment_errors(csu: Comparison) -> None:
    # measured: hip r 0.93 / RMSE 0.068, knee 0.990 / 0.045, ankle 0.9994 / 0.022 N·m/kg
    limits = {"hip_r": (0.85, 0.12), "knee_r": (0.97, 0.08), "ankle_r": (0.995, 0.05)}
    for joint, (r_min, rmse_max) in limits.items():
        stats = csu.stat(joint)
        assert stats.r >= r_min, f"{joint}: r = {stats.r:.3f}"
        assert stats.rmse <= rmse_max, f"{joint}: RMSE = {stats.rmse:.3f} N·m/kg"


def test_csu_angle_sign_mapping(csu: Comparison) -> None:
    """The same sign mapping applied to the angles reproduces leg2d's angles (a wrong sign would
    give errors of the order of the angles themselves, ~1 rad)."""
    assert csu.angles_ours is not None and csu.angles_reference is not None
    diff = csu.angles_ours - csu.angles_reference
    assert np.sqrt(np.mean(diff**2, axis=0)).max() < 0.02  # measured ≤ 0.012 rad
    assert np.abs(diff).max() < 0.08  # measured 0.046 rad (ankle, swing)


@pytest.fixture(scope="module")
def csu_replica() -> Comparison:
    return csu_reference_replica(shared_data("csu_2d_inverse_dynamics"))


def test_csu_with_the_references_own_inputs(csu_replica: Comparison) -> None:
    """With the cutoff (4 Hz) and thigh/shank parameters that generated refresults.mat, the
    remaining differences are those of the differentiation and the contact threshold."""
    # measured: hip 0.979 / 0.038, knee 0.995 / 0.024, ankle 0.9998 / 0.016 N·m/kg
    limits = {"hip_r": (0.96, 0.06), "knee_r": (0.99, 0.04), "ankle_r": (0.999, 0.025)}
    for joint, (r_min, rmse_max) in limits.items():
        stats = csu_replica.stat(joint)
        assert stats.r >= r_min, f"{joint}: r = {stats.r:.4f}"
        assert stats.rmse <= rmse_max, f"{joint}: RMSE = {stats.rmse:.3f} N·m/kg"
    assert csu_replica.angles_ours is not None and csu_replica.angles_reference is not None
    diff = csu_replica.angles_ours - csu_replica.angles_reference
    assert np.sqrt(np.mean(diff**2, axis=0)).max() < 0.003  # measured 0.001 rad (filter edges)


# ------------------------------------------------------------------------------ OpenSim
def test_opensim_moments(opensim: Comparison) -> None:
    # measured r ≥ 0.988 and RMSE ≤ 0.050 N·m/kg on every joint (both legs)
    assert opensim.joints == ("hip_r", "knee_r", "ankle_r", "hip_l", "knee_l", "ankle_l")
    for stats in opensim.stats():
        assert stats.r >= 0.97, f"{stats.joint}: r = {stats.r:.3f}"
        assert stats.rmse <= 0.08, f"{stats.joint}: RMSE = {stats.rmse:.3f} N·m/kg"
    for joint in ("knee_r", "ankle_r", "knee_l", "ankle_l"):
        assert opensim.stat(joint).r >= 0.99


# ------------------------------------------------------------------------------ units
def test_contact_fraction_reproduces_moment() -> None:
    rng = np.random.default_rng(1)
    toe = rng.normal(size=(50, 2))
    heel = toe + np.array([-0.2, 0.01]) + 0.01 * rng.normal(size=(50, 2))
    force = np.column_stack([rng.normal(0, 100, 50), rng.uniform(50, 800, 50)])
    moment = rng.normal(0, 200, 50)
    w = contact_fraction_for_load(toe, heel, force, moment)
    point = toe + w[:, None] * (heel - toe)
    np.testing.assert_allclose(point[:, 0] * force[:, 1] - point[:, 1] * force[:, 0], moment, atol=1e-9)


def test_read_opensim_table(tmp_path: Path) -> None:
    path = tmp_path / "ok.mot"
    path.write_text(
        "Coordinates\t\t\nversion=1\t\t\nnRows=2\ninDegrees=yes\n\nendheader\t\t\n"
        "time\tknee_angle_r\tpelvis_tx\t\t\n"
        "0.0\t-5.0\t0.61\n"
        "0.5\t-10.5\tnan\n"
    )
    names, data = read_opensim_table(path)
    assert names == ["time", "knee_angle_r", "pelvis_tx"]
    assert data.shape == (2, 3)
    np.testing.assert_array_equal(data[:, 1], [-5.0, -10.5])
    assert np.isnan(data[1, 2])
    assert read_opensim_header(path)["inDegrees"] == "yes"


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("version=1\ntime\ta\n0\t1\n", "no 'endheader'"),
        ("endheader\ntime\ta\n0\t1\n1\n", "line 4: expected 2 values"),
        ("endheader\ntime\ta\n0\tabc\n", "non-numeric value 'abc'"),
        ("endheader\ntime\ta\n", "no data rows"),
        ("endheader\ntime\ta\ta\n0\t1\t2\n", "duplicate column"),
    ],
)
def test_read_opensim_table_malformed(tmp_path: Path, text: str, message: str) -> None:
    path = tmp_path / "bad.sto"
    path.write_text(text)
    with pytest.raises(OpenSimFormatError, match=message) as info:
        read_opensim_table(path)
    assert str(path) in str(info.value)


def test_read_opensim_table_missing_file(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError, match="nope.mot"):
        read_opensim_table(tmp_path / "nope.mot")
