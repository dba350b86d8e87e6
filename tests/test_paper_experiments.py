"""``sspinn experiment``: each of the paper's experiments runs end to end on a tiny dataset (two
arms, a few steps), writes its report and JSON with finite numbers, skips finished arms on a
rerun and replaces them only with ``--overwrite``."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from sspinn.cli import main
from sspinn.data.dataset import Dataset, Labels
from sspinn.estimator.paper_experiments import EXPERIMENTS, list_arms, true_placement
from sspinn.model.body import IMUPlacement
from sspinn.model.conventions import COORDINATES, JOINTS, SEGMENTS
from sspinn.testing import make_recording
from sspinn.yaml_config import shipped_path


def _truth(rng: np.random.Generator) -> dict:
    """A true placement as the synthetic data store it: the nominal one plus a few cm and degrees."""
    nominal = IMUPlacement.default(1.75)
    return {s: {"position_m": [v + 0.02 * rng.normal() for v in nominal.positions[s]], "angle_rad": 0.05 * rng.normal()}
            for s in SEGMENTS}


@pytest.fixture(scope="module")
def tiny(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """A dataset with walking and running programs and stored true placements, and a tiny config."""
    root = tmp_path_factory.mktemp("paper")
    rng = np.random.default_rng(4)
    recs = {}
    for split, names in (("train", ("a_walk", "b_run")), ("test", ("c_walk", "d_run"))):
        recs[split] = []
        for name in names:
            rec = make_recording(name, name[0], 140, rng)
            columns = {c: rec.labels.column(c) for c in rec.labels.columns()}
            t = np.arange(140) / 100  # smooth coordinates: their derivatives are gait-sized (misplacement)
            columns |= {c: 0.2 * np.sin(2 * np.pi * t + k) for k, c in enumerate(COORDINATES)}
            rec.labels = Labels.from_columns({**columns, **{f"tau_{j}": rng.normal(scale=20.0, size=140) for j in JOINTS}}, 140)
            rec.provenance = {"program": {"name": name.split("_")[1]}, "ground_truth": {"imu_placement": _truth(rng)}}
            recs[split].append(rec)
    data = root / "data"
    Dataset.write(data, recs)
    cfg = root / "tiny.yaml"
    cfg.write_text(yaml.safe_dump({"train": {
        "network": {"hidden": 8, "layers": 1, "dropout": 0.0, "dense": 8}, "batch_size": 2, "window": 32,
        "log_every": 1, "checkpoint_every": 2, "device": "cpu", "threads": 1, "compile": False,
    }}))
    return data, cfg


def _run(tiny, out: Path, name: str, arms: str, *extra: str) -> int:
    data, cfg = tiny
    return main(["experiment", name, "--data", str(data), "--config", str(cfg), "--out", str(out), "--arms", arms, *extra])


def _finite_metrics(results: dict, arms: list[str]) -> None:
    for arm in arms:
        entry = results["arms"][arm]
        assert entry["status"] == "finished", entry
        assert set(entry["by_program"]) == {"walk", "run", "all"}
        for program in entry["by_program"].values():
            for key in ("jae_deg", "jte_pct_bwbh", "grfe_pct_bw", "speed_error_mps"):
                assert math.isfinite(program["model"][key]) and math.isfinite(program["baseline"][key]), (arm, key)


def test_sensor_sets_run_resume_and_overwrite(tiny, tmp_path, capsys):
    out = tmp_path / "sets"
    assert _run(tiny, out, "sensor-sets", "all,feet_shanks", "--steps", "2") == 0
    results = json.loads((out / "results.json").read_text())
    _finite_metrics(results, ["all", "feet_shanks"])
    assert results["arms"]["shanks_pelvis"]["status"] == "not run"
    assert results["arms"]["feet"]["status"] == "not run"  # the single-segment sets are arms too
    text = (out / "report.md").read_text()
    assert "## walk" in text and "## run" in text and "trivial predictors" in text and "9.1" in text  # the paper's row
    assert "the Froude speed (the same data's mean Froude number" in text
    assert (out / "sensor_sets.png").stat().st_size > 0
    stamp = (out / "all" / "arm.json").stat().st_mtime_ns
    capsys.readouterr()

    assert _run(tiny, out, "sensor-sets", "all,feet_shanks", "--steps", "2") == 0  # finished arms are skipped
    assert "all: finished, skipped" in capsys.readouterr().out
    assert (out / "all" / "arm.json").stat().st_mtime_ns == stamp

    assert _run(tiny, out, "sensor-sets", "all", "--steps", "3") == 2  # another budget: refused, nothing replaced
    assert "--overwrite" in capsys.readouterr().err
    assert (out / "all" / "arm.json").stat().st_mtime_ns == stamp

    assert _run(tiny, out, "sensor-sets", "all", "--steps", "3", "--overwrite") == 0
    results = json.loads((out / "results.json").read_text())
    assert results["arms"]["all"]["steps"] == 3 and results["steps_in_all_per_arm"] == 3
    assert results["arms"]["feet_shanks"]["status"] == "not run"  # made with the old budget: removed


def test_one_model_for_every_sensor_set_is_scored_on_each_set(tiny, tmp_path):
    out = tmp_path / "any"
    assert _run(tiny, out, "sensor-sets", "feet_shanks,any_subset", "--steps", "2") == 0
    results = json.loads((out / "results.json").read_text())
    arm = results["arms"]["any_subset"]
    # the budget of the paper's five sets' models together (the tiny config has one start)
    assert arm["steps"] == 10 and arm["settings"] == ["imus=all", "sensor_dropout=0.5"]
    assert set(arm["by_subset"]) == {"all", "feet_thighs", "feet_shanks", "shanks_pelvis", "shanks_thighs", "pelvis", "thighs",
                                     "shanks", "feet"}
    for subset in arm["by_subset"].values():
        for key in ("jae_deg", "jte_pct_bwbh", "grfe_pct_bw", "speed_error_mps"):
            assert math.isfinite(subset["walk"]["model"][key])
    text = (out / "report.md").read_text()
    assert "## One model for every sensor set (`any_subset`)" in text
    own = results["arms"]["feet_shanks"]["by_program"]["walk"]["model"]["jae_deg"]
    assert f"| feet_shanks | {own:.3g} / " in text  # beside the per-set model
    assert "| pelvis | not run / " in text


def test_an_interrupted_arm_resumes_from_its_checkpoint(tiny, tmp_path, capsys):
    out = tmp_path / "ft"
    assert _run(tiny, out, "finetune", "base", "--steps", "2") == 0
    (out / "base" / "arm.json").unlink()  # as if stopped after training, before scoring
    capsys.readouterr()
    assert _run(tiny, out, "finetune", "base,finetuned", "--steps", "2") == 0
    assert "base: resuming 2 steps" in capsys.readouterr().out
    results = json.loads((out / "results.json").read_text())
    _finite_metrics(results, ["base", "finetuned"])
    assert "Change against `base`" in (out / "report.md").read_text()


def test_placement_reports_errors_against_the_stored_truth(tiny, tmp_path):
    out = tmp_path / "place"
    assert _run(tiny, out, "placement", "nominal,learned", "--steps", "3", "--set", "lr=0.05") == 0
    results = json.loads((out / "results.json").read_text())
    _finite_metrics(results, ["nominal", "learned"])
    nominal, learned = results["arms"]["nominal"]["placement"], results["arms"]["learned"]["placement"]
    assert nominal["truth_stored"] and nominal["recordings"] == 2
    for s in SEGMENTS:
        assert nominal["after"][s] == pytest.approx(nominal["nominal"][s])  # not learned: unchanged
        assert all(math.isfinite(v) for v in learned["after"][s].values())
    assert any(learned["after"][s] != pytest.approx(learned["nominal"][s]) for s in SEGMENTS)  # learned: moved
    assert "IMU placement against the truth" in (out / "report.md").read_text()


def test_misplaced_sensors_change_the_signals_by_the_placement_alone(tiny):
    from sspinn.estimator.paper_experiments import misplaced

    data, _ = tiny
    [rec, _] = Dataset.open(data).load("test")
    same = misplaced(rec, 0.0, 0.0)
    np.testing.assert_allclose(same.imu, rec.imu, atol=1e-12)
    moved = misplaced(rec, 0.05, 0.0, seed=3)
    assert moved.labels is rec.labels and not np.allclose(moved.imu, rec.imu)
    # a pure rotation leaves the gyroscopes alone (the segment's rate is the sensor's)
    turned = misplaced(rec, 0.0, np.radians(20))
    np.testing.assert_allclose(turned.imu[..., 2], rec.imu[..., 2], atol=1e-9)
    assert not np.allclose(turned.imu[..., :2], rec.imu[..., :2])


def test_the_misplaced_placement_is_the_truth_moved_along_each_segment(tiny):
    from sspinn.estimator.paper_experiments import misplaced_placement, true_placement

    data, _ = tiny
    [rec, _] = Dataset.open(data).load("test")
    start = true_placement(rec)
    start = rec.placement.vector().reshape(len(SEGMENTS), 3) if start is None else start
    np.testing.assert_allclose(misplaced_placement(rec, 0.0, 0.0), start)
    moved = misplaced_placement(rec, 0.05, np.radians(10), seed=3) - start
    for k, s in enumerate(SEGMENTS):
        along = 0 if s.startswith("foot") else 1
        np.testing.assert_allclose(abs(moved[k, along]), 0.05)
        np.testing.assert_allclose(moved[k, 1 - along], 0.0)
        np.testing.assert_allclose(abs(moved[k, 2]), np.radians(10))


def test_the_misplacement_experiment_scores_every_misplacement(tiny, tmp_path):
    out = tmp_path / "mis"
    assert _run(tiny, out, "misplacement", "nominal", "--steps", "2") == 0
    results = json.loads((out / "results.json").read_text())
    by = results["arms"]["nominal"]["by_misplacement"]
    assert list(by) == ["none", "2 cm", "5 cm", "10 cm", "20 cm", "10°", "20°", "30°"]
    assert by["none"]["walk"]["model"] == results["arms"]["nominal"]["by_program"]["walk"]["model"]
    assert "## Sensors misplaced on the test recordings" in (out / "report.md").read_text()
    assert (out / "misplacement.png").stat().st_size > 0


def test_the_two_contact_point_arm_trains_with_direct_forces(tiny, tmp_path):
    out = tmp_path / "two"
    assert _run(tiny, out, "ablations", "two_contact_points", "--steps", "2", "--set", "network.grf=direct") == 0
    results = json.loads((out / "results.json").read_text())
    _finite_metrics(results, ["two_contact_points"])


@pytest.mark.parametrize("name, arms", [("ablations", "full,no_bounds"), ("loss-weights", "base,imu_half")])
def test_ablations_and_loss_weights_run(tiny, tmp_path, name, arms):
    out = tmp_path / name
    assert _run(tiny, out, name, arms, "--steps", "2") == 0
    results = json.loads((out / "results.json").read_text())
    _finite_metrics(results, arms.split(","))
    if name == "ablations":
        assert results["arms"]["two_contact_points"]["status"] == "not built"
        assert "not built" in (out / "report.md").read_text()


def test_arms_are_overrides_of_the_shipped_config():
    ablations = {a.name: a for a in list_arms("ablations")}
    assert ablations["no_input_noise"].settings == ("input_noise=0",)
    assert ablations["no_bounds"].settings[0] == "weights.bounds=0"
    assert ablations["two_contact_points"].settings == ("network.grf=two_point",)  # demo.yaml's direct GRFs
    weights = {a.name: a for a in list_arms("loss-weights")}
    assert weights["imu_half"].settings == ("weights.imu=1",) and weights["imu_double"].settings == ("weights.imu=4",)
    assert "gyro_half" not in weights and "slide_half" not in weights  # off, or zero with demo.yaml's direct GRFs
    assert ablations["no_slide"].settings == ("weights.stance=0",)  # L_S carries the no-sliding condition there
    paper = {a.name: a for a in list_arms("ablations", config=shipped_path("configs/sspinn/paper.yaml"))}
    assert paper["no_slide"].settings == ("weights.slide=0",)  # the paper's contact model
    assert not paper["two_contact_points"].built  # two points exist for force outputs only
    assert [a.name for a in list_arms("finetune", steps=4000)] == ["base", "finetuned"]
    assert "finetune_last=1000" in list_arms("finetune", steps=4000)[1].settings
    assert set(EXPERIMENTS) == {"sensor-sets", "finetune", "placement", "ablations", "loss-weights", "misplacement"}


def test_bad_requests_are_one_line_errors(tiny, tmp_path, capsys):
    assert _run(tiny, tmp_path / "x", "sensor-sets", "all,nine_imus") == 2
    assert "nine_imus" in capsys.readouterr().err
    assert _run(tiny, tmp_path / "x", "ablations", "two_contact_points") == 2
    assert "not built" in capsys.readouterr().err
    assert main(["experiment", "placement", "--data", str(tmp_path), "--out", str(tmp_path / "y"), "--steps", "600"]) == 2
    assert "no dataset.json" in capsys.readouterr().err
    assert not (tmp_path / "y").exists()  # a wrong --data claims no folder
    assert main(["experiment", "finetune", "--out", str(tmp_path / "z"), "--steps", "100"]) == 2  # demo.yaml's 500-step starts
    assert "--set starts=1" in capsys.readouterr().err


def test_true_placement_is_read_from_the_provenance():
    rec = make_recording()
    assert true_placement(rec) is None
    rec.provenance = {"ground_truth": {"imu_placement": _truth(np.random.default_rng(0))}}
    assert true_placement(rec).shape == (len(SEGMENTS), 3)


def test_a_partly_trained_arm_continues_from_its_step(tiny, tmp_path, capsys):
    """An arm stopped at step 2 of 4 (its checkpoint) resumes there: 4 steps in all, not 2 + 4."""
    import dataclasses

    from sspinn.estimator.paper_experiments import Request, base_config, load_splits
    from sspinn.estimator.sspinnpose import SSPINNpose

    data, cfg = tiny
    out = tmp_path / "partial"
    request = Request("placement", out, data, cfg, steps=4, arms=("learned",))
    arm = next(a for a in list_arms("placement", cfg, 4) if a.name == "learned")
    config = dataclasses.replace(base_config(request, arm), steps=2)
    SSPINNpose(config).fit(load_splits(data)[0], out / "learned")
    capsys.readouterr()
    assert _run(tiny, out, "placement", "learned", "--steps", "4") == 0
    assert "learned: resuming 4 steps" in capsys.readouterr().out
    results = json.loads((out / "results.json").read_text())
    assert results["arms"]["learned"]["steps"] == 4
    summary = json.loads((out / "learned" / "training_summary.json").read_text())
    assert summary["steps"] == 4
