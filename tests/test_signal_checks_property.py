"""Property-based test of :mod:`sspinn.data.signal_checks` on real data: wiring and labelling
mistakes (:mod:`sspinn.testing.perturbations`) drawn by hypothesis on excerpts of imported CMU
treadmill walking (``sspinn import`` of ``../shared/data/cmu_treadmill_imu_grf``) must each be
detected (an error or a finding), with the detection rate per kind printed and required ≥ 95 %;
the untouched trials (all six subjects, both conditions, in the slow tier) and the project's own
legitimate recordings (a predicted walk, an averaged stride, semi-real running) must give none.

Drawn kinds (:data:`sspinn.testing.perturbations.KINDS`) include what ``sspinn import`` makes of
a 3D sensor's mistakes: a negated gyroscope or two swapped accelerometer axes arrive as a
mirrored acc_x (``acc_x_sign``), a shank or foot gyroscope × 0.5 as gyr_z × 0.5 (``gyro_scale``); rate
mislabels are drawn both from the factors the cadence detects
(:data:`~sspinn.testing.perturbations.DETECTABLE_RATE_FACTORS`, ``rate``) and from × 0.4–0.8 and
× 1.25–2 (``rate_near``), which only the joint constraints judge.

Not drawn, because the checks cannot see them without labels (measured and listed in
``docs/bad_input.md``): the pelvis's gyr_z negated or scaled, a thigh's gyr_z × 0.5, thigh/shank swapped within a leg,
and all leg sensors swapped between the sides
(:data:`sspinn.testing.perturbations.KINDS_NOT_CLAIMED`).
"""

from __future__ import annotations

import contextlib
import io
import warnings
from collections import defaultdict
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("hypothesis")  # in the dev extra
from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from sspinn.data.csv_readers import read_averaged_stride  # noqa: E402
from sspinn.data.dataset import DataFormatError, Recording  # noqa: E402
from sspinn.data.signal_checks import label_findings, recording_findings  # noqa: E402
from sspinn.imu import pipeline  # noqa: E402
from sspinn.model.body import IMUPlacement  # noqa: E402
from sspinn.model.conventions import SEGMENTS  # noqa: E402
from sspinn.testing.perturbations import KINDS, perturb  # noqa: E402
from sspinn.testing.sensor_mounting import read_gait_csv, synthetic_walk  # noqa: E402
from tests.conftest import shared_data  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
CMU_MAP = REPO / "configs" / "sensor_maps" / "cmu_treadmill.yaml"
GAIT = Path(__file__).resolve().parent / "fixtures" / "predicted_walk_1.3.csv"
#: (subject, condition, height m, mass kg) of the six CMU subjects (subjects.csv).
SUBJECTS = {"Sub01": (1.81, 66.7), "Sub02": (1.65, 56.0), "Sub03": (1.87, 78.6), "Sub04": (1.67, 70.5),
            "Sub05": (1.90, 81.6), "Sub06": (1.64, 69.7)}
EXCERPT_S = 20.0


def _import(folder: Path, subject: str, condition: str) -> Recording:
    """One CMU trial imported with its GRF (no figure)."""
    source = shared_data("cmu_treadmill_imu_grf") / subject / condition
    height, mass = SUBJECTS[subject]
    stem = f"OpenSim_{subject}_{condition}"
    with pytest.MonkeyPatch.context() as patch, contextlib.redirect_stdout(io.StringIO()):
        patch.setattr(pipeline, "plot_calibration", lambda path, *a, **k: Path(path))
        return pipeline.import_imu([source / f"{stem}_Accel.trc.gz"], CMU_MAP, height, mass, folder, subject=subject,
                                   name=f"{subject}_{condition}", grf=source / f"{stem}_GRF.mot.gz").recording


@pytest.fixture(scope="module")
def walks(tmp_path_factory) -> list[Recording]:
    """Two whole imported CMU walking trials (normal and stiff-knee)."""
    folder = tmp_path_factory.mktemp("cmu")
    return [_import(folder, "Sub01", "CSBaseline"), _import(folder, "Sub04", "CSStiffKnee")]


def _detected(rec: Recording, imu: np.ndarray) -> list[str]:
    """The findings for ``rec`` with its IMU array replaced by ``imu``, or the error as one."""
    try:
        changed = Recording(name=rec.name, imu=imu, segments=rec.segments, height=rec.height, mass=rec.mass,
                            subject=rec.subject, placement=rec.placement)
        return recording_findings(changed, rec.name)
    except DataFormatError as exc:
        return [f"error: {exc}"]


def _rates(walks: list[Recording], draws: int) -> dict[str, list[bool]]:
    """Detections per kind over ``draws`` hypothesis draws (derandomised: the same draws every run;
    the kinds in turn, hypothesis draws the trial, the excerpt's start and the mistake's details)."""
    hits: dict[str, list[bool]] = defaultdict(list)
    missed: list[str] = []

    @settings(max_examples=draws, derandomize=True, database=None, deadline=None)
    @given(trial=st.integers(0, len(walks) - 1), start=st.floats(0.0, 1.0), seed=st.integers(0, 2**32 - 1))
    def draw(trial: int, start: float, seed: int) -> None:
        kind = KINDS[sum(len(h) for h in hits.values()) % len(KINDS)]  # every kind equally often
        rec = walks[trial]
        n = int(EXCERPT_S * 100)
        k = int(start * (rec.n_samples - n))
        imu = rec.imu if kind == "rate" else rec.imu[k:k + n]  # a 10× speed-up needs the whole trial
        changed, what = perturb(imu, rec.segments, kind, np.random.default_rng(seed))
        found = _detected(rec, changed)
        hits[kind].append(bool(found))
        if not found:
            missed.append(f"{rec.name} from {k / 100:.1f} s: {what.description}")

    draw()
    print(f"\n{draws} draws on {', '.join(r.name for r in walks)}:")
    for kind in KINDS:
        print(f"  {kind:<10} {sum(hits[kind])} of {len(hits[kind])} detected")
    print("  missed: " + ("; ".join(missed) if missed else "none"))
    return hits


def _check(hits: dict[str, list[bool]]) -> None:
    total = [x for h in hits.values() for x in h]
    assert np.mean(total) >= 0.95, f"detection rate {np.mean(total):.1%} < 95 %"
    for kind, h in hits.items():
        assert np.mean(h) >= 0.9, f"{kind}: detection rate {np.mean(h):.0%}"


def test_mistakes_detected_quick(walks):
    _check(_rates(walks, 30))


@pytest.mark.slow
def test_mistakes_detected_200_draws(walks):
    hits = _rates(walks, 210)
    assert sum(len(h) for h in hits.values()) >= 200
    _check(hits)


def test_untouched_excerpts_silent(walks):
    for rec in walks:
        assert recording_findings(rec, rec.name) == [] and label_findings(rec, rec.name) == []
        for start in range(0, rec.n_samples - 2000, 1000):
            assert _detected(rec, rec.imu[start:start + 2000]) == [], (rec.name, start)


@pytest.mark.slow
def test_every_cmu_trial_silent(tmp_path):
    """All twelve CMU trials as imported, GRF labels included: no finding."""
    loud = {}
    for subject in SUBJECTS:
        for condition in ("CSBaseline", "CSStiffKnee"):
            rec = _import(tmp_path, subject, condition)
            found = recording_findings(rec, rec.name) + label_findings(rec, rec.name)
            if found:
                loud[rec.name] = found
    assert loud == {}


def test_legitimate_synthetic_recordings_silent():
    """A predicted walk (virtual IMUs, 2 s standing + 20 strides), the averaged real stride and
    the semi-real running: no finding."""
    gait = read_gait_csv(GAIT)
    imu = synthetic_walk(gait.q, gait.u, gait.qdd, strides=20, standing_s=2.0)
    walk = Recording(name="predicted", imu=imu, segments=SEGMENTS, height=1.75, mass=70.0, placement=IMUPlacement.default(1.75))
    assert recording_findings(walk, walk.name) == []
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        stride = read_averaged_stride(shared_data("dorschky_P03_walking"), periods=10)
    assert recording_findings(stride, "stride") == [] and label_findings(stride, "stride") == []


@pytest.mark.slow
def test_semi_real_running_silent():
    from benchmarks.accuracy.semi_real_running import hamner_running_recording

    rec = hamner_running_recording(shared_data("opensim_hamner_run"))
    assert recording_findings(rec, rec.name) == [] and label_findings(rec, rec.name) == []
