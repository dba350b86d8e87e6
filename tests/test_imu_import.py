"""``sspinn import``: synthetic Xsens files with random mountings end to end, one-line errors, and
a 10 s excerpt of a real CMU trial (with GRF) that ``Dataset``, ``load_recordings`` and
``sspinn infer`` read unchanged."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
import yaml

from sspinn.cli import load_recordings, main
from sspinn.conventions import SEGMENTS
from sspinn.dataset import Dataset, Recording
from sspinn.testing import walking_like_3d, write_xsens_txt
from sspinn.validation.sensor_mounting import OutOfPlane, embed_in_3d, random_mounting, read_gait_csv, synthetic_walk
from tests.conftest import shared_data

GAIT = Path(__file__).resolve().parent / "fixtures" / "predicted_walk_1.3.csv"
REPO = Path(__file__).resolve().parents[1]
IDS = {s: f"00B4{i:04X}" for i, s in enumerate(SEGMENTS)}


@pytest.fixture(scope="module")
def xsens_trial(tmp_path_factory):
    """Seven MT Manager files (random mountings on a predicted gait, 2 s standing + 20 strides),
    an eighth unused sensor, a sensor map; returns (folder, files, map path, 2D truth, mountings)."""
    folder = tmp_path_factory.mktemp("xsens")
    rng = np.random.default_rng(11)
    gait = read_gait_csv(GAIT)
    truth = synthetic_walk(gait.q, gait.u, gait.qdd, strides=20, standing_s=2.0)
    files, mountings = [], {s: random_mounting(rng) for s in SEGMENTS}
    for i, s in enumerate(SEGMENTS):
        acc, gyr = embed_in_3d(truth[:, i], mountings[s], rng, OutOfPlane(), still=200)
        files.append(write_xsens_txt(folder / f"MT_01200627_000-000_{IDS[s]}.txt", acc, gyr, counter0=100 * i))
    files.append(write_xsens_txt(folder / "MT_01200627_000-000_00B4FFFF.txt", *walking_like_3d(len(truth), rng)))
    names = {"pelvis": "pelvis", "femur_r": "thigh_r", "tibia_r": "shank_r", "femur_l": "thigh_l", "tibia_l": "shank_l"}
    sensors = {IDS[s]: names.get(s, {"segment": s, "position": "forefoot"}) for s in SEGMENTS}
    smap = folder / "map.yaml"
    smap.write_text(yaml.safe_dump({"sensors": sensors, "ignore": ["00B4FFFF"]}))
    return folder, files, smap, truth, mountings


def _import(files, smap, out, *extra) -> list[str]:
    return ["import", "--imu", *map(str, files), "--sensor-map", str(smap), "--height", "1.75", "--mass", "70",
            "--out", str(out), *extra]


def test_xsens_import_recovers_the_sagittal_signals(xsens_trial, tmp_path, capsys) -> None:
    folder, files, smap, truth, _ = xsens_trial
    out = tmp_path / "imported"
    assert main(_import(files, smap, out, "--subject", "s1", "--name", "walk", "--speed", "1.3")) == 0
    printed = capsys.readouterr().out
    assert "walk: 2480 samples" in printed and "calibration report" in printed
    rec = Recording.load(out / "walk.csv")
    assert rec.segments == SEGMENTS and rec.subject == "s1" and rec.n_samples == len(truth)
    assert rec.placement.positions["foot_r"] == pytest.approx((0.14, -0.03))
    rms = np.sqrt(np.mean((rec.imu - truth) ** 2, axis=0))  # (7, 3): out-of-plane motion and noise remain
    assert rms[:, 2].max() < 0.1 and rms[:, :2].max() < 1.0
    np.testing.assert_allclose(rec.labels.speed, 1.3)
    assert set(rec.provenance["calibration"]) == set(SEGMENTS) and rec.provenance["standing_s"] is not None
    index = json.loads((out / "dataset.json").read_text())
    assert index["splits"] == {"train": ["walk"], "val": ["walk"], "test": ["walk"]}
    for split in ("train", "test"):
        (again,) = load_recordings(out, split)
        np.testing.assert_allclose(again.imu, rec.imu)
    report = (out / "walk_calibration.md").read_text()
    assert "| 00B40003 | foot_r |" in report and (out / "walk_calibration.png").stat().st_size > 10_000
    # a second subject into the same folder, test split only
    assert main(_import(files, smap, out, "--subject", "s2", "--name", "walk2", "--split", "test")) == 0
    assert Dataset.open(out).splits == {"train": ["walk"], "val": ["walk"], "test": ["walk", "walk2"]}


def test_import_errors_are_one_line(xsens_trial, tmp_path, capsys) -> None:
    folder, files, smap, _, mountings = xsens_trial
    data = yaml.safe_load(smap.read_text())
    cases = []
    missing = dict(data, sensors={**data["sensors"], "00B4AAAA": "pelvis"})
    missing["sensors"].pop(IDS["pelvis"])
    cases.append((missing, [], r"sensor '00B4AAAA' \(mapped to pelvis\) is not in"))
    cases.append(({"sensors": data["sensors"]}, [], r"sensor '00B4FFFF' of .* is not in the map"))
    down = (-mountings["tibia_l"][:, 1]).tolist()  # the sensor-frame direction pointing down the shank
    upside = dict(data, sensors={**data["sensors"], IDS["tibia_l"]: {"segment": "tibia_l", "up_axis": down}})
    cases.append((upside, [], rf"sensor '{IDS['tibia_l']}' \(tibia_l\): mounted upside down"))
    cases.append((data, ["--end", "3"], r"s of walking found"))
    for k, (content, extra, message) in enumerate(cases):
        path = tmp_path / f"map{k}.yaml"
        path.write_text(yaml.safe_dump(content))
        status = main(_import(files, path, tmp_path / f"out{k}", *extra))
        err = capsys.readouterr().err
        assert status == 2 and len(err.strip().splitlines()) == 1, err
        assert err.startswith("sspinn: error: ") and re.search(message, err), err
    # a gap: drop 20 packets (0.2 s) from one sensor
    text = files[3].read_text().splitlines()
    gap_file = tmp_path / files[3].name
    gap_file.write_text("\n".join(text[:506] + text[526:]) + "\n")
    status = main(_import([*files[:3], gap_file, *files[4:]], smap, tmp_path / "gap"))
    err = capsys.readouterr().err
    assert status == 2 and f"sensor '{IDS['foot_r']}': 20 sample(s) missing" in err and "cannot be bridged" in err


def test_cmu_excerpt_imports_and_is_read_unchanged(tmp_path, tiny_run, capsys) -> None:
    folder = shared_data("cmu_treadmill_imu_grf") / "Sub01" / "CSBaseline"
    out = tmp_path / "cmu"
    args = ["import", "--imu", str(folder / "OpenSim_Sub01_CSBaseline_Accel.trc.gz"),
            "--sensor-map", str(REPO / "configs" / "sensor_maps" / "cmu_treadmill.yaml"),
            "--height", "1.81", "--mass", "66.7", "--subject", "Sub01", "--speed", "0.7692", "--end", "10",
            "--grf", str(folder / "OpenSim_Sub01_CSBaseline_GRF.mot.gz"), "--out", str(out)]
    assert main(args) == 0
    printed = capsys.readouterr().out
    assert "GRF: lag" in printed
    (rec,) = Dataset.open(out).load("train")
    assert rec.name == "OpenSim_Sub01_CSBaseline" and rec.segments == SEGMENTS and 990 <= rec.n_samples <= 1000
    assert np.isfinite(rec.imu).all() and rec.labels.grf is not None and np.isfinite(rec.labels.grf).all()
    weight = 66.7 * 9.81
    assert 0.8 < np.mean(rec.labels.grf[:, 1] + rec.labels.grf[:, 3]) / weight < 1.2
    lag = rec.provenance["grf_alignment"]["lag_s"]
    assert abs(lag) < 0.15 and rec.provenance["grf_alignment"]["convention"] == "t_reference = t_imu + lag_s"
    assert (out / "OpenSim_Sub01_CSBaseline_calibration.md").exists()
    (again,) = load_recordings(out, "test")
    np.testing.assert_allclose(again.imu, rec.imu)
    _, _, _, _, run = tiny_run
    assert main(["infer", "--model", str(run / "model.pt"), "--data", str(out), "--out", str(tmp_path / "inf")]) == 0
    assert (tmp_path / "inf" / "OpenSim_Sub01_CSBaseline_estimate.csv").exists()
