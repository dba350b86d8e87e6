"""Synthetic gait data (predictive.synth, predictive.ocp.stride_nlp): a tiny dataset of two subjects
with two running strides each (~30 s cold on 2 CPU cores), plus fast unit tests."""

from __future__ import annotations

import dataclasses
import shutil
import time
from pathlib import Path

import numpy as np
import pytest
import yaml

from predictive.__main__ import main as cli_main
from predictive.ocp.stride_nlp import StridePlan, bucket_for
from predictive.synth.config import BodyVariation, SynthConfig, Variability
from predictive.synth.pipeline import generate_dataset
from predictive.synth.planning import plan_strides
from predictive.synth.recording import residual_stats
from predictive.synth.subjects import body_deviation, perturb_body, sample_subjects
from sspinn.data.dataset import Dataset, Recording
from sspinn.model.body import BodyParameters
from sspinn.model.conventions import N_Q, SEGMENTS

#: every test here solves optimal-control problems, generates data or trains: the quick loop skips them
pytestmark = pytest.mark.slow

CONFIGS = Path(__file__).resolve().parents[1] / "configs" / "synth"


def tiny_config(cache_dir: Path) -> SynthConfig:
    """Two subjects (one train, one test), one 1 s running recording each (two strides)."""
    return SynthConfig(
        name="tiny",
        seed=3,
        n_subjects=2,
        splits={"train": 1, "test": 1},
        programs=((3.5,),),
        program_names=("run",),
        duration_s=1.0,
        cache_dir=str(cache_dir),
    )


@pytest.fixture(scope="module")
def generated(tmp_path_factory: pytest.TempPathFactory) -> tuple[SynthConfig, Path, Dataset, float]:
    root = tmp_path_factory.mktemp("synth")
    config = tiny_config(root / "cache")
    t0 = time.perf_counter()
    dataset = generate_dataset(config, root / "out", progress=False)
    return config, root, dataset, time.perf_counter() - t0


def _true_body(rec: Recording) -> BodyParameters:
    return BodyParameters.from_dict(rec.provenance["ground_truth"]["body"])


# ------------------------------------------------------------------------------ the dataset
def test_labels_satisfy_the_equations_of_motion_after_a_round_trip(generated) -> None:
    config, root, dataset, _ = generated
    reopened = Dataset.open(root / "out")  # what a user reads: the CSV files
    recs = [r for split in reopened.splits for r in reopened.load(split)]
    assert len(recs) == 2
    for rec in recs:
        body = _true_body(rec)
        res = residual_stats(rec, body)
        assert res["max_trans_bw"] <= 1e-6 and res["max_rot_bwh"] <= 1e-6, res
        lab = rec.labels
        # backward Euler at every sample: u is the backward difference of q, q̈ that of u
        np.testing.assert_allclose(np.diff(lab.q, axis=0) / 0.01, lab.u[1:], atol=1e-5)
        np.testing.assert_allclose(np.diff(lab.u, axis=0) / 0.01, lab.qdd[1:], atol=1e-4)
        # ... also at the first sample, from the stored state before it
        u_prev = np.array(rec.provenance["state_before_first_sample"]["u"])
        np.testing.assert_allclose((lab.u[0] - u_prev) / 0.01, lab.qdd[0], atol=1e-4)
    assert dataset.info["kane_residual"]["max_trans_bw"] <= 1e-6


def _sliding_power(rec: Recording) -> float:
    """Mean power of the labels' friction forces on their sliding contact points, BW·m/s."""
    from sspinn.model import dynamics, kinematics

    lab, body = rec.labels, _true_body(rec)
    points = kinematics.point_kinematics(lab.q, lab.u, lab.qdd, dynamics.contact_fraction(lab.q), body.vector())
    slide = points[:, [kinematics.point_index("contact_r"), kinematics.point_index("contact_l")], 2]
    return float(np.abs(lab.grf[:, 0::2] * slide).sum(1).mean() / body.body_weight)


def test_the_sliding_power_term_stops_the_feet_skidding(generated, tmp_path: Path) -> None:
    """``stride.w_slip`` (default 100) penalises the power of friction on sliding contact points:
    the tiny dataset skids less than the same one made with ``w_slip = 0`` (the smooth contact model
    otherwise lets the optimiser brake a foot by dragging it), and its labels still satisfy the
    equations of motion."""
    from predictive.ocp.stride_nlp import StrideSettings

    config, root, dataset, _ = generated
    assert config.stride.w_slip == 100.0
    no_slip = dataclasses.replace(config, stride=StrideSettings(w_slip=0.0), cache_dir=str(tmp_path / "cache"))
    assert no_slip.key() != config.key()
    skidding = generate_dataset(no_slip, tmp_path / "out", progress=False)
    before = {r.name: _sliding_power(r) for split in ("train", "test") for r in skidding.load(split)}
    after = {r.name: _sliding_power(r) for split in ("train", "test") for r in Dataset.open(root / "out").load(split)}
    assert after.keys() == before.keys()
    for name in before:
        assert after[name] < 0.5 * before[name], (name, before[name], after[name])
    assert dataset.info["kane_residual"]["max_trans_bw"] <= 1e-6
    with pytest.raises(ValueError, match="w_slip"):
        StrideSettings(w_slip=-1.0)


def test_label_shapes_and_format(generated) -> None:
    config, root, dataset, _ = generated
    for split in dataset.splits:
        for rec in dataset.load(split):
            T = rec.n_samples
            assert T >= config.duration_s * 100
            assert rec.imu.shape == (T, len(SEGMENTS), 3) and rec.segments == SEGMENTS
            lab = rec.labels
            for group, width in (("q", N_Q), ("u", N_Q), ("qdd", N_Q), ("tau", 6), ("grf", 4), ("w", 2)):
                assert getattr(lab, group).shape == (T, width), group
            assert lab.speed.shape == (T,) and not lab.missing
            # each stride's average pelvis speed is exact by construction
            n_strides = rec.provenance["strides"]["n_samples"]
            start = 0
            x_prev = rec.provenance["state_before_first_sample"]["q"][0]
            for n, v in zip(n_strides, rec.provenance["strides"]["speed_mps"]):
                x_end = lab.q[start + n - 1, 0]
                assert (x_end - x_prev) / (n * 0.01) == pytest.approx(v, abs=1e-6)
                np.testing.assert_allclose(lab.speed[start : start + n], v, atol=1e-8)
                x_prev, start = x_end, start + n
            assert start == T
            # the estimator is told height and mass; the true body differs (no inverse crime)
            true = _true_body(rec)
            assert true.segment_mass_total == pytest.approx(rec.mass, rel=1e-9)
            nominal = BodyParameters.from_anthropometry(rec.height, rec.mass)
            assert max(abs(d) for d in body_deviation(true, nominal).values()) > 0.01
            placed = rec.provenance["ground_truth"]["imu_placement"]
            offsets = [np.subtract(placed[s]["position_m"], rec.placement.positions[s]) for s in SEGMENTS]
            assert np.abs(offsets).max() > 1e-4  # the sensors are not where the estimator is told


def test_subjects_do_not_cross_splits(generated) -> None:
    config, _, dataset, _ = generated
    seen: dict[str, str] = {}
    for split in dataset.splits:
        for rec in dataset.load(split):
            assert seen.setdefault(rec.subject, split) == split
    assert {s: len(n) for s, n in dataset.splits.items()} == {"train": 1, "test": 1}
    assert len(seen) == 2


def test_cache_hit_and_determinism(generated, tmp_path: Path) -> None:
    config, root, dataset, cold_time = generated
    # second run, same cache: nothing is solved, identical files
    t0 = time.perf_counter()
    again = generate_dataset(config, tmp_path / "again", progress=False)
    warm_time = time.perf_counter() - t0
    cache = again.info["cache"]
    assert cache["periodic_solved"] == 0 and cache["chain_solved"] == 0 and cache["recording_made"] == 0
    assert cache["chain_hits"] == 2 and cache["recording_hits"] == 2
    assert warm_time < max(5.0, 0.3 * cold_time)
    for name in dataset.splits["train"] + dataset.splits["test"]:
        assert (tmp_path / "again" / f"{name}.csv").read_bytes() == (root / "out" / f"{name}.csv").read_bytes()
    # determinism by seed: a fresh cache (periodic gaits copied to save time) re-solves the
    # chains and re-measures the IMUs with identical results
    fresh = tmp_path / "fresh_cache"
    shutil.copytree(Path(config.cache_dir) / "periodic", fresh / "periodic")
    redo = generate_dataset(dataclasses.replace(config, cache_dir=str(fresh)), tmp_path / "redo", progress=False)
    assert redo.info["cache"]["chain_solved"] == 2
    for split in dataset.splits:
        for a, b in zip(dataset.load(split), redo.load(split)):
            np.testing.assert_array_equal(a.imu, b.imu)
            for group in ("q", "u", "qdd", "tau", "grf", "w", "speed"):
                np.testing.assert_array_equal(getattr(a.labels, group), getattr(b.labels, group))
    # a different seed gives different data
    other = sample_subjects(dataclasses.replace(config, seed=4))
    assert [s.height for s in other] != [s.height for s in sample_subjects(config)]


def test_cli_reports_size_time_and_residual(generated, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    config, _, _, _ = generated
    path = tmp_path / "tiny.yaml"
    path.write_text(yaml.safe_dump(config.to_dict()))
    assert SynthConfig.from_yaml(path) == config
    args = ["synth", "--config", str(path), "--out", str(tmp_path / "cli"), "--no-progress"]
    code = cli_main(args)
    out = capsys.readouterr().out
    assert code == 0
    assert "Kane residual" in out and "MB" in out and "time" in out
    assert (tmp_path / "cli" / "dataset.json").exists()
    # every recording against the human norms, one line each
    assert "human gait norms" in out and all(f"{name} " in out for name in generated[2].info["recordings"])


def test_cli_refuses_a_dataset_outside_the_norms(generated, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    """With --require-norms, ``predictive synth`` writes nothing when a recording has too few
    stances inside the human ranges (here: a share above 100 % is asked, so every one fails)."""
    from predictive.synth import norms

    config, _, dataset, _ = generated
    for rec in dataset.info["recordings"].values():
        assert {"fraction_inside", "peak_median_bw", "passed", "line"} <= rec["norms"].keys()
    monkeypatch.setattr(norms, "MIN_INSIDE", 1.01)
    path = tmp_path / "tiny.yaml"
    path.write_text(yaml.safe_dump(config.to_dict()))
    code = cli_main(["synth", "--config", str(path), "--out", str(tmp_path / "refused"), "--no-progress", "--require-norms"])
    err = capsys.readouterr().err
    assert code != 0 and "human gait norms" in err and "nothing written" in err
    assert not (tmp_path / "refused" / "dataset.json").exists()


# ------------------------------------------------------------------------------ unit tests
def test_config_files_load() -> None:
    default = SynthConfig.from_yaml(CONFIGS / "default.yaml")
    full = SynthConfig.from_yaml(CONFIGS / "full.yaml")
    assert default.n_subjects == 20 and default.splits == {"train": 12, "val": 2, "test": 6} and default.duration_s >= 15
    assert sorted({v for p in full.programs for v in p}) == [0.9, 1.3, 1.8, 2.5, 3.0, 3.5]
    assert SynthConfig.from_dict(default.to_dict()) == default
    assert default.key() != full.key()
    with pytest.raises(ValueError, match="unknown setting"):
        SynthConfig.from_dict({"n_subject": 3})
    with pytest.raises(ValueError, match="add up"):
        SynthConfig(n_subjects=3)


def test_perturbed_body_keeps_mass_and_documented_spread() -> None:
    rng = np.random.default_rng(0)
    var = BodyVariation()
    nominal = BodyParameters.from_anthropometry(1.80, 80.0)
    for _ in range(20):
        body = perturb_body(1.80, 80.0, var, rng)
        assert body.segment_mass_total == pytest.approx(80.0, rel=1e-12)
        assert body.height == 1.80 and body.mass == 80.0
        for seg in ("femur_r", "tibia_l"):
            ratio = getattr(body, seg).length / getattr(nominal, seg).length
            assert (1 - var.length) * (1 - var.asymmetry) <= ratio <= (1 + var.length) * (1 + var.asymmetry)
        dev = body_deviation(body, nominal)
        assert max(abs(dev[f"{s}_mass"]) for s in SEGMENTS) < 0.3
    same = perturb_body(1.80, 80.0, BodyVariation(0, 0, 0, 0, 0, 0, 0), rng)
    np.testing.assert_allclose(same.vector(), nominal.vector(), rtol=1e-12)


def test_subjects_are_deterministic_and_split() -> None:
    config = SynthConfig(n_subjects=5, splits={"train": 3, "val": 1, "test": 1})
    a, b = sample_subjects(config), sample_subjects(config)
    assert [(s.id, s.split, s.height, s.mass) for s in a] == [(s.id, s.split, s.height, s.mass) for s in b]
    assert sorted(s.split for s in a) == ["test", "train", "train", "train", "val"]
    assert len({s.height for s in a}) == 5


def test_paces_scale_the_speeds_and_stratify_the_splits() -> None:
    """Each subject runs its program at its own pace; the test split of the default holds every
    gait at every pace once, so the training subjects' mean speed is no oracle for it."""
    default = SynthConfig.from_yaml(CONFIGS / "default.yaml")
    assert default.paces == (0.85, 1.0, 1.1)
    subjects = sample_subjects(default)
    cells = sorted((s.index % 2, default.pace(s.index)) for s in subjects if s.split == "test")
    assert cells == [(p, pace) for p in (0, 1) for pace in (0.85, 1.0, 1.1)]
    for s in subjects:
        program = s.index % 2
        assert default.speeds(s.index, program) == [round(v * default.pace(s.index), 2) for v in default.programs[program]]
    walking = {v for s in subjects if s.index % 2 == 0 for v in default.speeds(s.index, 0)}
    assert max(walking) < 2.0 <= min(v for v in default.all_speeds() if v not in walking)  # walks stay walks
    # one pace: the speeds are the program's and the splits those of the one-pace stratification
    one = dataclasses.replace(default, paces=(1.0,))
    assert {tuple(one.speeds(i, i % 2)) for i in range(20)} == {tuple(p) for p in one.programs}
    # ... the one-pace test split (S05, S09, S13 walking; S06, S08, S20 running)
    assert sorted(s.id[-3:] for s in sample_subjects(one) if s.split == "test") == ["S05", "S06", "S08", "S09", "S13", "S20"]
    with pytest.raises(ValueError, match="paces"):
        SynthConfig(paces=())
    with pytest.raises(ValueError, match="paces"):
        SynthConfig(paces=(0.0,))


class _FakeReference:
    """PeriodicReference stand-in: stride duration 1.4 − 0.2·v (s)."""

    def nominal_duration(self, speed: float) -> float:
        return 1.4 - 0.2 * speed


def test_stride_plans_cover_the_duration_with_bounded_speed_changes() -> None:
    var = Variability()
    plans = plan_strides([0.9, 1.3, 1.8], 20.0, _FakeReference(), var, 0.01, np.random.default_rng(1))
    assert sum(p.n_nodes for p in plans) * 0.01 >= 20.0
    assert all(isinstance(p, StridePlan) and len(p.effort_weights) == 6 for p in plans)
    speeds = np.array([p.speed for p in plans])
    assert speeds[0] == pytest.approx(0.9, rel=3 * var.speed_cv)
    assert speeds[-1] == pytest.approx(1.8, rel=3 * var.speed_cv)
    # target changes by at most max_speed_change per stride (plus the per-stride variability)
    assert np.abs(np.diff(speeds)).max() <= var.max_speed_change + 2 * var.clip * var.speed_cv * 1.8
    again = plan_strides([0.9, 1.3, 1.8], 20.0, _FakeReference(), var, 0.01, np.random.default_rng(1))
    assert again == plans
    assert bucket_for(70) == 78 and bucket_for(24) == 24


# ------------------------------------------------------------------------------ fallback ladder
@pytest.fixture(scope="module")
def running_chain_setup():
    """A nominal body's periodic 3.5 m/s gait (reference) and a shared solver cache."""
    from predictive.ocp.stride_nlp import StrideSettings, StrideSolverCache
    from predictive.synth.gait_library import _solve_periodic_ladder
    from predictive.synth.periodic_reference import PeriodicReference

    body = BodyParameters.from_anthropometry(1.75, 70.0)
    settings = StrideSettings()
    reference = PeriodicReference([_solve_periodic_ladder(3.5, body, settings, None)])
    return body, reference, StrideSolverCache(settings)


def _failing_solves(monkeypatch: pytest.MonkeyPatch, fail_calls: set[int]) -> list[int]:
    """Make the stride solves numbered ``fail_calls`` (0-based, in call order) fail as IPOPT's
    'Infeasible_Problem_Detected' would, without running IPOPT; returns the call log."""
    from predictive.ocp import stride_nlp

    real = stride_nlp.StrideProblem.solve
    calls: list[int] = []

    def solve(self, body, q_prev, u_prev, plans, *args, **kwargs):
        n = len(calls)
        calls.append(n)
        if n in fail_calls:
            nodes = sum(p.n_nodes for p in plans)
            z = np.zeros((nodes, N_Q))
            return stride_nlp.StrideResult(
                q=z, u=z, qdd=z, tau=np.zeros((nodes, 6)), node_counts=tuple(p.n_nodes for p in plans),
                status="Infeasible_Problem_Detected", iterations=3, solve_time=0.0, objective=float("nan"),
                max_residual=3.18,
            )
        return real(self, body, q_prev, u_prev, plans, *args, **kwargs)

    monkeypatch.setattr(stride_nlp.StrideProblem, "solve", solve)
    return calls


def _plans(reference) -> list[StridePlan]:
    n = round(reference.nominal_duration(3.5) / 0.01)
    return [StridePlan(3.5, n), StridePlan(3.57, n + 1, (1.2, 0.9, 1.1, 1.0, 0.8, 1.1)), StridePlan(3.5, n)]


def test_a_failed_stride_goes_down_the_ladder(running_chain_setup, monkeypatch: pytest.MonkeyPatch) -> None:
    from predictive.synth.chain import FALLBACKS, simulate_chain

    body, reference, solvers = running_chain_setup
    # stride 1 fails on warm, default, perturbed and nominal: solved on 'smaller_change'
    calls = _failing_solves(monkeypatch, {1, 2, 3, 4})
    chain = simulate_chain(body, _plans(reference), reference, solvers)
    assert [r.fallback for r in chain.strides] == ["warm", "smaller_change", "warm"]
    assert chain.strides[1].attempts == 5 and len(calls) == 7
    assert chain.strides[1].planned_speed == pytest.approx(3.57)
    assert chain.strides[1].speed == pytest.approx(0.5 * (3.57 + 3.5))  # half the planned change
    assert not chain.ended_early
    # the labels stay exact: Kane residual at every sample, speeds as solved
    assert np.abs(chain.kane_residual(body)).max() < 1e-6
    start = chain.strides[0].n_nodes
    x_prev = chain.q[start - 1, 0]
    n1 = chain.strides[1].n_nodes
    assert (chain.q[start + n1 - 1, 0] - x_prev) / (n1 * 0.01) == pytest.approx(chain.strides[1].speed, abs=1e-6)
    assert set(FALLBACKS) >= {r.fallback for r in chain.strides}


def test_a_stride_that_fails_every_rung_ends_the_recording_cleanly(
    running_chain_setup, monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    from predictive.synth.chain import FALLBACKS, ChainError, ChainResult, simulate_chain

    body, reference, solvers = running_chain_setup
    _failing_solves(monkeypatch, set(range(1, 1 + len(FALLBACKS))))
    chain = simulate_chain(body, _plans(reference), reference, solvers)
    assert len(chain.strides) == 1 and chain.n_samples == chain.strides[0].n_nodes
    assert chain.ended_early.startswith("ended after stride 0") and "Infeasible_Problem_Detected" in chain.ended_early
    saved = ChainResult.load(chain.save(tmp_path / "chain"))
    assert saved.ended_early == chain.ended_early and saved.strides == chain.strides
    # a first stride that fails every rung cannot start a recording
    _failing_solves(monkeypatch, set(range(len(FALLBACKS))))
    with pytest.raises(ChainError, match="stride 0 .* every rung"):
        simulate_chain(body, _plans(reference), reference, solvers)


class _MemoryCache:
    """SynthCache stand-in that stores nothing."""

    def periodic(self, key, solve):
        return solve()


def test_periodic_gaits_fall_back_without_aborting(monkeypatch: pytest.MonkeyPatch) -> None:
    from predictive.ocp.collocation import OCPError
    from predictive.ocp.stride_nlp import StrideSettings
    from predictive.synth import gait_library

    calls: list[tuple[float, object, object]] = []

    def fake_solve(speed, body, stride, guess, options=None):
        calls.append((speed, guess, options))
        # 2.5 m/s fails from 3.5 m/s and from the generic guess; from the midpoint 3.0 it works
        if speed == 2.5 and guess != "sol3.0":
            raise OCPError("Infeasible_Problem_Detected", "fails")
        if speed == 1.8 and guess is not None and guess != "sol1.3":  # the subject's own gait fails
            raise OCPError("Restoration_Failed", "fails")
        if speed == 1.8 and guess is None:
            raise OCPError("Restoration_Failed", "fails")
        return f"sol{speed}"

    monkeypatch.setattr(gait_library, "_solve_periodic", fake_solve)
    templates = gait_library.template_library([1.3, 1.8, 2.5, 3.5], StrideSettings(), _MemoryCache())
    assert templates[2.5][0] == "sol2.5" and templates[3.5][0] == "sol3.5"
    assert any(speed == 3.0 and guess == "sol3.5" for speed, guess, _ in calls)  # the midpoint
    events: list[dict[str, str]] = []
    body = BodyParameters.from_anthropometry(1.7, 65.0)
    fine = {v: (f"sol{v}", f"key{v}") for v in (1.3, 1.8)}
    library = gait_library.periodic_library(body, [1.3, 1.8], StrideSettings(), _MemoryCache(), fine, events, "S01")
    assert library[1.3] == ("sol1.3", library[1.3][1]) and library[1.8] == ("sol1.8", "key1.8")  # the template
    assert [e["event"] for e in events] == ["periodic_from_template"] and "1.8 m/s" in events[0]["detail"]
    # an anchor that fails on every rung is a clear error naming it
    monkeypatch.setattr(gait_library, "_solve_periodic", lambda *a, **k: (_ for _ in ()).throw(OCPError("X", "no")))
    with pytest.raises(OCPError, match="anchor"):
        gait_library.template_library([1.3], StrideSettings(), _MemoryCache())


def test_the_calibration_subjects_are_new_subjects_of_the_same_population_all_in_val():
    """configs/synth/calibration.yaml (`make intervals`): 8 walkers and 8 runners, none of them a
    subject of the default dataset, every one in the val split."""
    configs = Path(__file__).resolve().parents[1] / "configs" / "synth"
    default, calibration = SynthConfig.from_yaml(configs / "default.yaml"), SynthConfig.from_yaml(configs / "calibration.yaml")
    assert (calibration.programs, calibration.paces, calibration.subjects) == (default.programs, default.paces, default.subjects)
    subjects = sample_subjects(calibration)
    assert len(subjects) == 16 and {s.split for s in subjects} == {"val"}
    assert sorted(s.index % len(calibration.programs) for s in subjects) == [0] * 8 + [1] * 8  # first programs: walk, run
    _assert_none_is_a_subject_of(default, subjects)


@pytest.mark.parametrize(("name", "program"), [("long_walk.yaml", 0), ("long_run.yaml", 1)])
def test_the_minute_long_recordings_are_new_subjects_of_the_default_population(name: str, program: int):
    """configs/synth/long_walk.yaml and long_run.yaml (the placement fit on recordings no model was
    trained on): 8 subjects of the default population, every one in the val split and none a subject
    of the default dataset, each walking (running) the default's walking (running) programme for 60 s."""
    configs = Path(__file__).resolve().parents[1] / "configs" / "synth"
    default, long = SynthConfig.from_yaml(configs / "default.yaml"), SynthConfig.from_yaml(configs / name)
    assert (long.paces, long.subjects, long.duration_s) == (default.paces, default.subjects, 60.0)
    assert long.programs == (default.programs[program],) and long.program_names == (default.program_names[program],)
    subjects = sample_subjects(long)
    assert len(subjects) == 8 and {s.split for s in subjects} == {"val"}
    _assert_none_is_a_subject_of(default, subjects)


def _assert_none_is_a_subject_of(config: SynthConfig, subjects: list) -> None:
    """No subject of ``subjects`` has the height and mass of one of ``config``'s subjects."""
    known = {(round(s.height, 6), round(s.mass, 6)) for s in sample_subjects(config)}
    assert not known & {(round(s.height, 6), round(s.mass, 6)) for s in subjects}
