"""The human priors of the gait NLPs (predictive.ocp.settings) and the synthetic data's norms check
(predictive.synth.norms): fast unit tests, no optimisation."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from predictive.ocp.collocation import OCPSettings
from predictive.ocp.settings import grf_cap_bw, winter_angles, winter_grf
from predictive.ocp.stride_nlp import StrideSettings
from predictive.synth.norms import MIN_INSIDE, RecordingNorms, outside_norms
from sspinn.data.gait_norms import human_ranges

#: ../shared/data (optional real recordings; see tests/conftest.py)
SHARED_DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"


def test_the_grf_cap_lies_inside_the_human_peak_range_and_rises_with_speed() -> None:
    speeds = [0.8, 1.0, 1.3, 1.6, 1.8]
    caps = [grf_cap_bw(v, 0.5) for v in speeds]
    assert np.all(np.diff(caps) > 0)
    for v, cap in zip(speeds, caps):
        low, high = human_ranges(v, "walk").peak_bw
        assert low < cap < high
        assert grf_cap_bw(v, 0.0) == pytest.approx(low) and grf_cap_bw(v, 1.0) == pytest.approx(high)
    low, high = human_ranges(3.5, "run").peak_bw
    assert grf_cap_bw(3.5, 0.5) == pytest.approx(0.5 * (low + high))
    assert grf_cap_bw(0.0, 0.5) == grf_cap_bw(0.5, 0.5)  # standing: the slowest walking row


def test_the_winter_fits_reproduce_the_published_stride() -> None:
    if not (SHARED_DATA / "winter_walking").exists():
        pytest.skip("../shared/data/winter_walking not present")
    from sspinn.data.gait_metrics import load_winter

    ref = load_winter(SHARED_DATA)
    phase = ref.percent / 100.0
    fit = winter_angles(phase)
    for j, name in enumerate(("hip", "knee", "ankle")):
        assert np.degrees(np.sqrt(np.mean((fit[:, j] - getattr(ref, name)) ** 2))) < 0.5, name
    assert np.sqrt(np.mean((winter_grf(phase) - ref.grf_y) ** 2)) < 0.02


def test_the_winter_fits_have_a_human_shape_without_the_data() -> None:
    phase = np.linspace(0, 1, 200, endpoint=False)
    angles = np.degrees(winter_angles(phase))
    assert angles[:, 1].min() < -55 and angles[:, 1].max() <= 0.5  # knee: ≈ 65° swing flexion, no hyperextension
    fy = winter_grf(phase)
    stance = np.mean(fy > 0.1)
    assert 0.57 <= stance <= 0.63 and 1.0 < fy.max() < 1.2 and fy.min() >= 0.0


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"effort": "quartic"}, "effort"),
        ({"w_grf_cap": -1.0}, "w_grf_cap"),
        ({"w_angle_prior": float("nan")}, "w_angle_prior"),
        ({"w_grf_prior": -0.1}, "w_grf_prior"),
        ({"w_slip": -1.0}, "w_slip"),
        ({"grf_cap_fraction": 1.5}, "grf_cap_fraction"),
        ({"angle_prior_sd_deg": 0.0}, "angle_prior_sd_deg"),
        ({"grf_prior_sd_bw": 0.0}, "grf_prior_sd_bw"),
    ],
)
def test_prior_settings_are_validated_in_both_problems(kwargs: dict, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        OCPSettings(speed=1.0, **kwargs)
    with pytest.raises(ValueError, match=match):
        StrideSettings(**kwargs)


def test_both_problems_share_the_priors() -> None:
    stride = StrideSettings()
    periodic = stride.ocp_settings(1.3, 57, 1.14)
    for name in ("effort", "w_grf_cap", "grf_cap_fraction", "w_angle_prior", "angle_prior_sd_deg", "w_grf_prior", "w_slip"):
        assert getattr(periodic, name) == getattr(stride, name), name


def _norms(name: str, inside: int, stances: int, taps: int = 0) -> RecordingNorms:
    nan = float("nan")
    judged = stances + taps
    return RecordingNorms(name, "walk", stances, taps, inside, inside / judged if judged else nan, {"peak": stances - inside},
                          1.2, 1.3, 0.7, 60.0, 20.0, 0.0)


def test_a_recording_needs_most_stances_inside() -> None:
    good, bad, tapping, empty = _norms("a", 20, 20), _norms("b", 18, 20), _norms("c", 20, 20, taps=3), _norms("d", 0, 0)
    assert good.passed and not bad.passed and not tapping.passed and not empty.passed
    assert outside_norms({n.name: n for n in (good, bad, tapping, empty)}) == ["b", "c", "d"]
    assert MIN_INSIDE == 0.95
    line = bad.line()
    assert "OUT" in line and "peak 2" in line and "90 %" in line
    assert good.as_dict()["passed"] is True and empty.as_dict()["fraction_inside"] is None
