"""Synthetic quiet standing (predictive.synth.standing, python -m predictive synth-standing): labels that
satisfy the equations of motion, feet that stay put, and the command's refusals."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from predictive.__main__ import main as predictive_main
from predictive.synth.config import SynthConfig
from predictive.synth.standing import STANDING_ANGLES, leg_angles, standing_recording, standing_trajectory
from predictive.synth.subjects import sample_subjects
from sspinn.data.dataset import Dataset
from sspinn.estimator.zupt import whole_body_still
from sspinn.model.body import BodyParameters
from sspinn.model.kinematics import point_index, point_kinematics

REPO = Path(__file__).resolve().parents[1]
SMOKE = REPO / "configs" / "synth" / "smoke.yaml"


def test_the_body_sways_on_feet_that_stay_flat_and_put_and_the_labels_are_exact() -> None:
    body = BodyParameters.from_anthropometry(1.68, 61.0)
    tr = standing_trajectory(body, 6.0, np.random.default_rng(4))
    r = tr.kane_residual(body)
    assert np.abs(r).max() < 1e-9
    points = point_kinematics(tr.q, tr.u, tr.qdd, tr.w, body)
    for name in ("heel_r", "toe_r", "heel_l", "toe_l"):
        p = points[:, point_index(name), :2]
        assert np.abs(p[:, 1]).max() < 1e-9  # on the ground, flat
        assert np.ptp(p[:, 0]) < 1e-9  # not sliding
    assert 0.005 < np.ptp(tr.q[:, 0]) < 0.05  # the pelvis sways by millimetres to centimetres
    assert np.all((tr.w > 0) & (tr.w < 1))  # the centre of pressure stays under the feet
    np.testing.assert_allclose(tr.grf[:, 1] + tr.grf[:, 3], body.mass * 9.81, rtol=0.01)
    # u and q̈ are the derivatives of q and u (central differences agree to their truncation error)
    np.testing.assert_allclose(np.gradient(tr.q, 0.01, axis=0)[2:-2], tr.u[2:-2], atol=1e-4)
    np.testing.assert_allclose(np.gradient(tr.u, 0.01, axis=0)[2:-2], tr.qdd[2:-2], atol=1e-3)


@pytest.mark.parametrize("index", [0, 1])  # smoke S01 (left leg longer) and S02 (right leg longer)
def test_legs_of_unequal_length_both_stand_on_the_floor(index: int) -> None:
    body = sample_subjects(SynthConfig.from_yaml(SMOKE))[index].body
    assert body.femur_l.length + body.tibia_l.length != pytest.approx(body.femur_r.length + body.tibia_r.length, abs=1e-3)
    legs = leg_angles(body)
    standing = (STANDING_ANGLES["hip"], STANDING_ANGLES["knee"], STANDING_ANGLES["ankle"])
    bent = [side for side in ("r", "l") if legs[side] != standing]
    assert len(bent) == 1 and legs[bent[0]][1] < STANDING_ANGLES["knee"]  # the longer leg flexes its knee more
    tr = standing_trajectory(body, 4.0, np.random.default_rng(1))
    assert np.abs(tr.kane_residual(body)).max() < 1e-9
    points = point_kinematics(tr.q, tr.u, tr.qdd, tr.w, body)
    for name in ("heel_r", "toe_r", "heel_l", "toe_l"):
        p = points[:, point_index(name), :2]
        assert np.abs(p[:, 1]).max() < 5e-5  # both soles on the floor (the right exactly), within 0.05 mm
        assert np.ptp(p[:, 0]) < 5e-5  # and put


def test_a_standing_recording_is_labelled_like_the_walking_ones() -> None:
    subject = sample_subjects(SynthConfig.from_yaml(SMOKE))[0]
    rec = standing_recording(subject, 3.0, seed=0)
    again = standing_recording(subject, 3.0, seed=0)
    np.testing.assert_array_equal(rec.imu, again.imu)  # seeded
    assert rec.name == f"{subject.id}_stand" and rec.n_samples == 301
    assert np.all(rec.labels.column("speed") == 0.0)
    assert rec.provenance["program"]["name"] == "stand"
    assert set(rec.provenance["ground_truth"]["imu_placement"]) == set(rec.segments)
    assert rec.provenance["kane_residual"]["max_trans_bw"] < 1e-9


def test_standing_sensors_are_as_quiet_as_real_ones_and_the_estimate_rests() -> None:
    """No soft-tissue artefact while the body rests: the signals' spread is that of real sensors
    on a person standing still (Xsens MTw: std of ‖acc‖ 0.017–0.044 m/s², rates ≤ 6.5°/s), so the
    whole-body rest detection sees it, as on real standing."""
    subject = sample_subjects(SynthConfig.from_yaml(SMOKE))[1]
    rec = standing_recording(subject, 4.0, seed=2)
    spread = np.linalg.norm(rec.imu[:, :, :2], axis=2).std(axis=0)
    assert spread.max() < 0.05
    assert np.degrees(np.abs(rec.imu[:, :, 2]).max()) < 6.5
    assert whole_body_still(rec.imu, 100.0).all()


def main(argv: list[str]) -> int:
    """``python -m predictive synth-standing ARGV``."""
    return predictive_main(["synth-standing", *argv])


def test_the_command_writes_a_dataset_and_never_replaces_one_without_the_flag(tmp_path: Path, capsys) -> None:
    out = tmp_path / "standing"
    assert main(["--config", str(SMOKE), "--split", "train", "--duration", "2", "--out", str(out)]) == 0
    ds = Dataset.open(out)
    assert list(ds.splits) == ["test"] and len(ds.splits["test"]) == 1
    assert main(["--config", str(SMOKE), "--split", "train", "--duration", "2", "--out", str(out)]) == 0
    assert "NOTE:" in capsys.readouterr().out and (tmp_path / "standing_2" / "dataset.json").exists()
    # --with a dataset of another configuration: one line, exit 2
    assert main(["--config", str(SMOKE), "--with", str(out), "--out", str(tmp_path / "mixed")]) == 2
    assert "was not generated from" in capsys.readouterr().err
    assert main(["--config", str(SMOKE), "--duration", "0", "--out", str(tmp_path / "x")]) == 2


@pytest.mark.slow
def test_with_a_dataset_each_subject_stands_in_its_own_split(tmp_path: Path) -> None:
    from predictive.synth.pipeline import generate_dataset

    config = SynthConfig.from_yaml(SMOKE, cache_dir=str(tmp_path / "cache"))
    base = generate_dataset(config, tmp_path / "base", progress=False)
    assert main(["--config", str(SMOKE), "--with", str(tmp_path / "base"), "--duration", "2", "--out", str(tmp_path / "mixed")]) == 0
    mixed = Dataset.open(tmp_path / "mixed")
    for split, names in base.splits.items():
        subjects = {n.rsplit("_", 1)[0] for n in names}
        assert set(mixed.splits[split]) == set(names) | {f"{s}_stand" for s in subjects}
