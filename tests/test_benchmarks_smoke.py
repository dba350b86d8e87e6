"""Smoke runs of the benchmarks in ``benchmarks/``: each quick run completes and prints its tables.

No timing assertions: speed targets belong in the benchmarks' output (ratios against a baseline
measured in the same run), never in tests. The benchmarks set torch's thread count; the
``torch_threads`` fixture (conftest) restores it.
"""

from __future__ import annotations

import dataclasses
import json
import re
import runpy
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import torch

from sspinn.data.dataset import Dataset, Labels, Recording
from tests.conftest import SHARED_DATA, shared_data

#: every test here runs a benchmark end to end (training, compilation, real data): the quick loop skips them
pytestmark = pytest.mark.slow

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"


def run_quick(name: str, json_path: Path) -> tuple[dict[str, Any], Any]:
    """(the benchmark module's globals, what its ``main`` returned) for ``--quick --json``."""
    bench = runpy.run_path(str(BENCHMARKS / "speed" / f"{name}.py"), run_name=name)
    return bench, bench["main"](["--quick", "--json", str(json_path)])


def test_bench_dynamics(tmp_path: Path, capsys: pytest.CaptureFixture[str], torch_threads) -> None:
    bench, results = run_quick("bench_dynamics", tmp_path / "bench.json")
    out = capsys.readouterr().out
    for text in ("Kane residual", "naive [states/s]", "ours/naive", "target: ours ≥ 3× naive", "evals/s"):
        assert text in out
    for label in bench["LABELS"].values():
        assert label in out
    assert all(row.rate > 0 for row in results.rows)
    # the fast paths compute the same thing as the naive baselines
    assert all(row.max_deviation is None or row.max_deviation < 1e-4 for row in results.rows)
    saved = json.loads((tmp_path / "bench.json").read_text())
    assert saved["settings"]["mode"] == "quick"
    assert {row["method"] for row in saved["rows"]} >= {"naive", "ours", "forward_dynamics"}


def test_bench_imu_tracking(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    _, rows = run_quick("bench_imu_tracking", tmp_path / "bench.json")
    out = capsys.readouterr().out
    assert "faster than the baseline" in out and "angles" in out
    assert [(r["case"], r["path"]) for r in rows] == [("synthetic", p) for p in ("independent", "all starts", "one process", "default")]
    assert all(r["status"] == "Solve_Succeeded" and r["wall_s"] > 0 for r in rows)
    # every path reports the same optimum and accuracy, side by side
    for row in rows[1:]:
        assert row["objective"] == pytest.approx(rows[0]["objective"], rel=1e-6)
        assert row["angle_rmsd_deg"] == pytest.approx(rows[0]["angle_rmsd_deg"], abs=0.01)
    # the baseline and "all starts" run every start; the default may stop after two agree
    assert "-" not in rows[0]["iterations"] + rows[1]["iterations"] and len(rows[2]["iterations"]) == 3
    assert rows[3]["iterations"] == rows[2]["iterations"] and rows[3]["objective"] == rows[2]["objective"]  # a worker changes nothing
    assert json.loads((tmp_path / "bench.json").read_text())[3]["path"] == "default"


def test_bench_env(tmp_path: Path, capsys: pytest.CaptureFixture[str], torch_threads) -> None:
    _, results = run_quick("bench_env", tmp_path / "bench.json")
    out = capsys.readouterr().out
    for text in ("Environment steps/s", "SagittalWalker-v0 (gymnasium.make)", "vector env, N = 512", "DummyVecEnv",
                 "Walker2d-v5", "roofline", "PPO end-to-end", "Batched torch environment", "≥ 100×",
                 "sspinn.model.simulation.advance"):
        assert text in out
    assert results["single"]["rates"]["SagittalWalker-v0 (gymnasium.make)"] > 0
    assert results["single"]["rates"]["vector env, N = 64"] > 0 and results["roofline"]["evaluations_per_s"] > 0
    assert [r["config"] for r in results["ppo"]] == ["ppo.yaml", "ppo_clock_walk_256envs.yaml"]
    for ppo in results["ppo"]:  # one rollout of each recipe, the same steps through both kinds of environment
        assert ppo["native"]["steps"] == ppo["dummy"]["steps"] == ppo["total_steps"] > 0
        assert 0 < ppo["dummy"]["env_share"] <= 1 and ppo["native"]["env_only_steps_per_s"] > 0
    assert all(r["env_steps_per_s"] > 0 for r in results["batched"].values())
    assert json.loads((tmp_path / "bench.json").read_text())["batch"] == results["batch"]


def test_bench_sspinn(tmp_path: Path, capsys: pytest.CaptureFixture[str], torch_threads) -> None:
    _, result = run_quick("bench_sspinn", tmp_path / "r.json")
    out = capsys.readouterr().out
    assert "streaming latency" in out and "training throughput" in out
    assert result["streaming"]["ours_ms"][0] > 0 and result["training"]["sspinn_windows_per_s"] > 0
    assert "one training step" in out and "after/before" in out and len(result["profile"]) == 4
    assert sorted(p["compiled"] for p in result["profile"].values()) == [False, False, True, True]
    for prof in result["profile"].values():  # the phases partition the step
        assert sum(prof["share"].values()) == pytest.approx(1.0) and min(prof["ms"].values()) > 0
    sharing = result["sharing"]  # alone and beside a busy process, fixed and automatic thread counts
    assert set(sharing) == {"2", "1", "auto"} and sharing["1"]["threads_beside"] == 1
    assert all(r["alone"] > 0 and r["beside"] > 0 for r in sharing.values()) and "training beside a busy neighbour" in out
    assert json.loads((tmp_path / "r.json").read_text())["quick"] is True


def test_bench_synth(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Both arms solve the same strides from the same periodic gaits: identical labels, one solver
    build per stride in the baseline, fewer with the shared solvers."""
    _, result = run_quick("bench_synth", tmp_path / "synth.json")
    out = capsys.readouterr().out
    before, after = result["arms"]["one solver per stride"], result["arms"]["shared solvers"]
    assert before["strides"] == after["strides"] >= 1 and before["builds"] == before["strides"]
    assert 1 <= after["builds"] <= before["builds"] and result["label_difference"] == 0.0
    assert "| shared solvers |" in out and "strides/s" in out
    assert json.loads((tmp_path / "synth.json").read_text())["subjects"] == 1


def test_grf_lowpass(capsys: pytest.CaptureFixture[str], tiny_run, torch_threads) -> None:
    """The offline low-pass table on the tiny dataset: one row per gait, the estimate's error and the
    labels' spectrum per cut-off; a cut-off above the Nyquist frequency is a one-line error."""
    _, data, _, _, run = tiny_run
    bench = runpy.run_path(str(BENCHMARKS / "studies" / "grf_lowpass.py"), run_name="grf_lowpass")
    out = bench["main"](["--data", str(data), "--model", str(run / "model.pt"), "--split", "train", "--cutoffs", "10", "3", "--skip", "10"])
    assert out and all(len(row["grfe"]) == 3 and len(row["share_above"]) == 2 for row in out.values())
    assert all(row["grfe"][1] != row["grfe"][0] for row in out.values())  # the low-pass changes the estimate
    assert "labels' vertical GRF RMS above 10 / 3 Hz" in capsys.readouterr().out
    # the spectrum share: equal sines at 2 and 15 Hz put 1/√2 of the RMS above 10 Hz, none above 20 Hz
    t = np.arange(2000) / 100.0
    grf = np.zeros((2000, 4))
    grf[:, 1] = 70 * 9.81 * (1 + 0.3 * np.sin(2 * np.pi * 2 * t) + 0.3 * np.sin(2 * np.pi * 15 * t))
    imu = np.random.default_rng(0).normal(0.0, 0.1, (2000, 1, 3)) + [0.0, 9.81, 0.0]  # a pelvis sensor at rest
    rec = Recording("sines", imu, ("pelvis",), 1.75, 70.0, labels=Labels(grf=grf))
    assert bench["share_above"](rec, 10.0) == pytest.approx(2**-0.5, abs=0.02) and bench["share_above"](rec, 20.0) < 0.02
    # the pelvis coherence: a sensor that moves with the 2-Hz part of the force and only wobbles at 15 Hz
    imu[:, 0, 1] = 9.81 * (1 + 0.3 * np.sin(2 * np.pi * 2 * t)) + np.random.default_rng(1).normal(0.0, 0.5, 2000)
    near, far = bench["pelvis_coherence"](bench["pelvis_force"](dataclasses.replace(rec, imu=imu)), [2.0, 15.0])
    assert near > 0.9 and far < 0.3
    assert np.isnan(bench["pelvis_coherence"](bench["pelvis_force"](dataclasses.replace(rec, segments=("foot_r",))), [2.0])[0])
    with pytest.raises(SystemExit):
        bench["main"](["--data", str(data), "--model", str(run / "model.pt"), "--cutoffs", "60"])
    assert "a cut-off must lie between 0 and 40.1 Hz" in capsys.readouterr().err


def test_load_transfer(capsys: pytest.CaptureFixture[str], tiny_run, torch_threads) -> None:
    """The load-transfer table on the tiny dataset: one row per gait with the errors before and
    after, and the share profiles of labels, estimate and transferred estimate."""
    _, data, _, _, run = tiny_run
    bench = runpy.run_path(str(BENCHMARKS / "studies" / "load_transfer.py"), run_name="load_transfer")
    out = bench["main"](["--data", str(data), "--model", str(run / "model.pt"), "--split", "train", "--skip", "10"])
    assert out and all(len(row["grfe"]) == 2 and np.isfinite(row["grfe"]).all() and len(row["share_labels"]) == 10
                       for row in out.values())
    assert "| gait | source |" in capsys.readouterr().out
    with pytest.raises(SystemExit):
        bench["main"](["--data", str(data.parent / "missing"), "--model", str(run / "model.pt")])
    assert "not a dataset folder" in capsys.readouterr().err


def test_sensor_rates(capsys: pytest.CaptureFixture[str], tiny_run) -> None:
    """The fast content per segment of a dataset: one row per gait, finite RMS per channel; the
    strap wobble of the error model raises the rates it adds; a folder that is not a dataset and a
    cut-off above Nyquist are one-line errors."""
    _, data, _, _, _ = tiny_run
    bench = runpy.run_path(str(BENCHMARKS / "studies" / "sensor_rates.py"), run_name="sensor_rates")
    out = bench["main"](["--data", str(data), "--above", "10"])
    assert out and all(np.isfinite(v).all() and len(v) == 3 for row in out.values() for v in row.values())
    assert "| pelvis | thighs | shanks | feet |" in capsys.readouterr().out
    rec = Dataset.open(data).load("train")[0]
    wobbly = dataclasses.replace(rec, imu=rec.imu + np.random.default_rng(0).normal(0.0, 0.5, rec.imu.shape))
    assert all((bench["fast_rms"](wobbly, 10.0)[k] > bench["fast_rms"](rec, 10.0)[k]).all() for k in ("pelvis", "feet"))
    for argv, message in ((["--data", str(data.parent)], "no dataset.json"), (["--data", str(data), "--above", "60"], "--above 60")):
        with pytest.raises(SystemExit):
            bench["main"](argv)
        assert message in capsys.readouterr().err


def test_bench_cmu_continuous(tmp_path: Path, capsys: pytest.CaptureFixture[str], tiny_run, torch_threads) -> None:
    """Real CMU data (skipped without it): import, both trainings, zero-shot, adaptation to the
    test trials, report, plots."""
    source = shared_data("cmu_treadmill_imu_grf")
    _, _, cfg, _, run = tiny_run
    bench = runpy.run_path(str(BENCHMARKS / "accuracy" / "bench_cmu_continuous.py"), run_name="bench_cmu_continuous")
    common = ["--quick", "--out", str(tmp_path / "cmu"), "--config", str(cfg), "--pretrained", str(run / "model.pt"), "--source", str(source)]
    results = bench["main"]([*common, "--grf-lowpass", "10", "--load-transfer", "--arms", *bench["ARMS"]])
    out = capsys.readouterr().out
    assert set(results) == {"Sub05_CSBaseline", "Sub05_CSStiffKnee"}
    row = results["Sub05_CSBaseline"]
    assert {"scratch", "zero_shot", "finetune", "adapted", "constant mean GRF / mean speed", "mean GRF profile (measured timing)"} <= set(row)
    # the baselines are what they claim: the profile at measured timing beats the constant mean GRF
    assert row["mean GRF profile (measured timing)"]["all"] < row["constant mean GRF / mean speed"]["all"]
    assert row["mean GRF profile (measured timing)"]["hs_ms"] == 0.0 and row["belt_speed"] == pytest.approx(0.7791, abs=1e-3)
    froude = row["Froude speed"]  # a speed only, at the test subject's leg length
    assert 0.3 < froude["speed"] < 2.0 and np.isnan(froude["all"]) and "Froude speed" in out
    assert "per condition" in out.lower() and (tmp_path / "cmu" / "plots" / "Sub05_CSBaseline.png").exists()
    saved = json.loads((tmp_path / "cmu" / "metrics.json").read_text())
    assert saved["training"]["scratch"]["steps"] == 3 and saved["training"]["adapted"]["steps"] == 3
    assert torch.load(tmp_path / "cmu" / "adapted_all" / "checkpoint.pt", weights_only=False)["recordings"] == [
        "Sub01_CSBaseline", "Sub01_CSStiffKnee", "Sub05_CSBaseline", "Sub05_CSStiffKnee"]  # every trial's IMU
    assert torch.load(tmp_path / "cmu" / "adapted" / "checkpoint.pt", weights_only=False)["recordings"] == ["Sub05_CSBaseline", "Sub05_CSStiffKnee"]
    # the offline low-pass rows: the same speed, another GRF error
    smooth = row["zero_shot, GRF low-passed 10 Hz"]
    assert smooth["speed"] == row["zero_shot"]["speed"] and np.isfinite(smooth["all"]) and smooth["all"] != row["zero_shot"]["all"]
    assert "zero_shot, GRF low-passed 10 Hz" in out
    shared = row["zero_shot, linear load transfer"]  # the offline load transfer: the same speed and heel strikes
    np.testing.assert_equal([shared["speed"], shared["hs_ms"]], [row["zero_shot"]["speed"], row["zero_shot"]["hs_ms"]])
    assert np.isfinite(shared["all"])
    assert "`<arm>, linear load transfer`" in out
    # an arm adapted with other settings does not reuse this folder's
    with pytest.raises(SystemExit, match="trained with other settings"):
        bench["main"]([*common, "--arms", "adapted", "--adapt-set", "weights.temporal=10"])


def test_bench_cmu_continuous_finds_trials_by_pattern(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Argument parsing and file discovery on a made-up folder (no import, no training): other
    subjects, conditions and file patterns, raw and gzipped files; missing files are one-line errors."""
    bench = runpy.run_path(str(BENCHMARKS / "accuracy" / "bench_cmu_continuous.py"), run_name="bench_cmu_continuous")
    source = tmp_path / "lab"
    for subject in ("P1", "P2", "P3"):
        for condition in ("slow", "fast"):
            folder = source / subject
            folder.mkdir(parents=True, exist_ok=True)
            (folder / f"{subject}_{condition}_imu_Accel.trc{'.gz' if subject == 'P2' else ''}").write_text("")
            (folder / f"{subject}_{condition}_forces.mot").write_text("")
    (source / "people.csv").write_text("subject,height_m,mass_kg,treadmill_speed_mps\nP1,1.70,60,1.0\nP2,1.80,80,1.1\nP3,1.75,70,1.2\n")
    argv = ["--source", str(source), "--train-subjects", "P1", "P2", "--test-subjects", "P3", "--conditions", "slow", "fast",
            "--imu-pattern", "{subject}/{subject}_{condition}_*_Accel.trc", "--grf-pattern", "{subject}/*_{condition}_forces.mot",
            "--subjects-csv", str(source / "people.csv"), "--arms", "scratch", "--out", str(tmp_path / "out")]
    args, protocol = bench["parse_args"](argv)
    trials = bench["discover_trials"](protocol)
    assert [t.name for t in trials] == ["P1_slow", "P1_fast", "P2_slow", "P2_fast", "P3_slow", "P3_fast"]
    assert trials[2].imu.name == "P2_slow_imu_Accel.trc.gz" and trials[5].grf.name == "P3_fast_forces.mot"
    assert (trials[3].height_m, trials[3].mass_kg, trials[3].speed_mps) == (1.80, 80.0, 1.1)
    assert protocol.label("slow") == "slow" and args.steps == 6000
    # the defaults are the CMU protocol
    default = bench["Protocol"](source)
    assert default.train_subjects == ("Sub01", "Sub02", "Sub03", "Sub04") and default.test_subjects == ("Sub05", "Sub06")
    assert default.conditions == ("CSBaseline", "CSStiffKnee") and default.label("CSStiffKnee") == "stiff-knee walking"
    for bad, message in (
        (["--conditions", "slow", "medium"], r"no GRF file\(s\) match P1/\*_medium_forces\.mot\[\.gz\]|no IMU file\(s\) match P1/P1_medium"),
        (["--test-subjects", "P4"], r"people\.csv: no row for subject 'P4'"),
        (["--test-subjects", "P2"], r"subjects \['P2'\] are in both"),
        (["--imu-pattern", "{subj}/x"], r"--imu-pattern '\{subj\}/x': only \{subject\} and \{condition\}"),
        (["--grf-lowpass", "60"], r"--grf-lowpass 60: a cut-off must lie between 0 and 40.1 Hz"),
    ):
        with pytest.raises(SystemExit) as exit_info:
            bench["parse_args"](argv + bad)
        assert exit_info.value.code == 2
        err = capsys.readouterr().err.strip().splitlines()[-1]
        assert re.search(message, err), err
    # a folder imported with another choice of test subjects is not reused for this one
    data = tmp_path / "out" / "data"
    data.mkdir(parents=True)
    splits = {t.name: ("train" if t.subject in ("P1", "P2", "P3") else "test") for t in trials}  # P3 trained on before
    for name in splits:
        (data / f"{name}.json").write_text(json.dumps({"provenance": {"importer_version": bench["IMPORTER_VERSION"]}}))
    (data / "dataset.json").write_text(json.dumps({"info": {"imported": {n: {"split": sp} for n, sp in splits.items()}}}))
    with pytest.raises(SystemExit, match="P3_slow was imported into the 'train' split, this run puts it into 'test'"):
        bench["import_trials"](protocol, data, ("P1", "P2"), ("P3",))


def test_standing_signals(capsys: pytest.CaptureFixture[str]) -> None:
    """Synthetic standing with the artefact off at rest is found still, with it left on never; the
    real Xsens static trial is read when the shared data are there."""
    bench = runpy.run_path(str(BENCHMARKS / "studies" / "standing_signals.py"), run_name="standing_signals")
    config = Path(__file__).resolve().parents[1] / "configs" / "synth" / "smoke.yaml"
    assert bench["main"](["--config", str(config), "--seconds", "2"]) == 0
    out = capsys.readouterr().out
    off = next(line for line in out.splitlines() if "artefact off at rest" in line)
    on = next(line for line in out.splitlines() if "left on" in line)
    assert off.endswith("| 100%–100% |") and on.endswith("| 0%–0% |")
    if (SHARED_DATA / "xsens_mt_static_S01").is_dir():
        assert "11 sensors" in out
