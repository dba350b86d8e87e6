"""Recordings that start and end standing (predictive.synth.start_stop, the chain's start state,
targets and standing plans, python -m predictive synth-standing --start-stop): exact labels over the whole
recording, standing at 0 m/s on both feet, the walking speed reached, the same file from the same
seed, and one-line refusals.

The slow tests solve one smoke subject's periodic gaits at 1.2 m/s cold (about 16 s) and two
stand–walk–stand recordings (about 25 s each on an idle core)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from predictive.__main__ import main as predictive_main
from predictive.ocp.stride_nlp import StridePlan, StrideSettings, StrideSolverCache
from predictive.synth.cache import SynthCache
from predictive.synth.chain import simulate_chain
from predictive.synth.config import SynthConfig
from predictive.synth.gait_library import RUN_SPEED
from predictive.synth.standing import standing_trajectory
from predictive.synth.start_stop import (
    RAMP,
    RUN_UP_STEP_MPS,
    SETTLE_NODES,
    contact_height,
    ramp_speeds,
    start_stop_recording,
)
from predictive.synth.subjects import sample_subjects
from sspinn.data.dataset import Dataset
from sspinn.model.contact import ContactParameters
from sspinn.model.dynamics import contact_forces

REPO = Path(__file__).resolve().parents[1]
SMOKE = REPO / "configs" / "synth" / "smoke.yaml"
SPEED = 1.2


def _main():
    """``python -m predictive synth-standing``'s entry point."""
    return lambda argv: predictive_main(["synth-standing", *argv])


# ------------------------------------------------------------------------------ refusals
@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"speed": 0.0}, "speed must be a finite number > 0 m/s, got 0.0"),
        ({"speed": float("nan")}, "speed must be a finite number > 0 m/s, got nan"),
        ({"stand_s": -1.0}, "stand_s must be a finite number > 0 s, got -1.0"),
        ({"walk_s": float("inf")}, "walk_s must be a finite number >= 0 s, got inf"),
    ],
)
def test_bad_arguments_are_refused_in_one_line_before_anything_is_solved(tmp_path: Path, kwargs, message) -> None:
    config = SynthConfig.from_yaml(SMOKE, cache_dir=str(tmp_path / "cache"))
    args = {"speed": SPEED, "stand_s": 1.0, "walk_s": 1.0} | kwargs
    with pytest.raises(ValueError) as info:
        start_stop_recording(config, sample_subjects(config)[0], **args)
    assert str(info.value) == message
    assert not (tmp_path / "cache").exists()


def test_the_chain_refuses_a_bad_start_target_or_step_in_one_line() -> None:
    config = SynthConfig.from_yaml(SMOKE)
    body = sample_subjects(config)[0].body
    solvers = StrideSolverCache(StrideSettings())
    plans = [StridePlan(1.0, 50)]
    reference = None  # never reached: the arguments are checked first
    with pytest.raises(ValueError, match=r"^start must be a pair of finite \(9,\) arrays"):
        simulate_chain(body, plans, reference, solvers, start=(np.zeros(8), np.zeros(9)))  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"^targets\[0\] must be a pair of finite \(9,\) arrays"):
        simulate_chain(body, plans, reference, solvers, targets={0: (np.full(9, np.nan), np.zeros(9))})  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"^targets must be indices of plans \(0 … 0\), got \[3\]$"):
        simulate_chain(body, plans, reference, solvers, targets={3: (np.zeros(9), np.zeros(9))})  # type: ignore[arg-type]
    other = StrideSolverCache(StrideSettings(h=0.02))
    with pytest.raises(ValueError, match=r"^rest_solvers must have the step of solvers \(0.01 s\), got 0.02 s$"):
        simulate_chain(body, plans, reference, solvers, rest_solvers=other)  # type: ignore[arg-type]


@pytest.mark.parametrize(("flag", "value"), [("--start-stop", "0"), ("--start-stop", "nan"), ("--walk", "-1")])
def test_the_command_refuses_a_bad_speed_or_walking_time(tmp_path: Path, capsys, flag: str, value: str) -> None:
    argv = ["--config", str(SMOKE), "--start-stop", "1.2", flag, value, "--out", str(tmp_path / "x")]
    try:
        code = _main()(argv)
    except SystemExit as exc:  # refused by the option's range, as a usage error
        code = int(exc.code)
    assert code == 2
    err = capsys.readouterr().err.strip()
    assert flag in err and value in err and "\n" not in err and "Traceback" not in err
    assert not (tmp_path / "x").exists()


def test_a_walk_ramps_by_fractions_and_a_run_starts_walking_then_gains_a_step_per_stride() -> None:
    assert ramp_speeds(1.2) == pytest.approx([f * 1.2 for f in RAMP])
    assert ramp_speeds(3.0) == pytest.approx([0.3, 0.72, 1.32, 1.92, 2.7])
    for speed in np.arange(RUN_SPEED, 6.01, 0.1):
        ramp = np.array(ramp_speeds(float(speed)))
        assert ramp[:2] == pytest.approx([0.3, 0.72])  # two walking strides first
        assert ramp[-1] == pytest.approx(RAMP[-1] * speed)
        steps = np.diff(ramp)
        assert steps.min() > 0 and steps.max() <= 1.5 * RUN_UP_STEP_MPS + 1e-9, (speed, ramp)


# ------------------------------------------------------------------------------ recordings
@pytest.fixture(scope="module")
def made(tmp_path_factory: pytest.TempPathFactory):
    """One smoke subject standing 1 s, walking 1.2 s at 1.2 m/s between the ramps, standing 1 s."""
    root = tmp_path_factory.mktemp("start_stop")
    config = SynthConfig.from_yaml(SMOKE, cache_dir=str(root / "cache"))
    subject = sample_subjects(config)[0]
    cache, solvers = SynthCache(config.cache_dir), StrideSolverCache(config.stride)
    rec = start_stop_recording(config, subject, SPEED, 1.0, 1.2, cache, solvers)
    return config, subject, cache, solvers, rec


@pytest.mark.slow
def test_every_sample_obeys_the_equations_of_motion(made) -> None:
    config, subject, _, _, rec = made
    res = rec.provenance["kane_residual"]
    assert res["samples"] == rec.n_samples
    assert max(res["max_trans_bw"], res["max_rot_bwh"]) <= config.stride.residual_tol
    # recomputed from the stored labels with the true body, not only the provenance
    r = rec.labels.trajectory(rec.time).kane_residual(subject.body)
    assert np.abs(r).max() <= config.stride.residual_tol
    # the end junction, the one that is not exact by construction, is close to the chain's own steps
    assert rec.provenance["junction"]["kinematic"] < 1e-2  # m/s, rad/s


@pytest.mark.slow
def test_it_stands_at_zero_speed_on_both_feet_then_walks_at_the_planned_speed_then_stands(made) -> None:
    _, subject, _, _, rec = made
    phases = rec.provenance["phases"]
    walk0, stand1 = phases["walk_start_sample"], phases["stand_start_sample"]
    assert walk0 == 101 and rec.n_samples - stand1 == 100  # 1 s of standing at each end
    speed = rec.labels.column("speed")
    tr = rec.labels.trajectory(rec.time)
    load = tr.grf[:, [1, 3]] / subject.body.body_weight
    for part in (slice(0, walk0), slice(stand1, None)):
        assert np.all(speed[part] == 0.0)
        assert np.abs(tr.u[part, 0]).max() < 0.05  # the pelvis sways by centimetres per second at most
        assert load[part].min() > 0.2  # both feet carry weight
        np.testing.assert_allclose(load[part].sum(axis=1), 1.0, atol=0.01)
    strides = rec.provenance["strides"]
    speeds = strides["speed_mps"]
    assert speeds[: len(RAMP)] == pytest.approx([f * SPEED for f in RAMP])
    assert speeds[-1] == 0.0 and strides["n_samples"][-1] == SETTLE_NODES
    steady = speeds[len(RAMP) : -len(RAMP) - 1]
    assert steady and all(abs(v - SPEED) < 0.1 * SPEED for v in steady)
    # the pelvis really travels at the labelled speed: distance over each stride / its duration
    x = tr.q[:, 0]
    start = walk0
    for v, n in zip(speeds, strides["n_samples"]):
        assert (x[start + n - 1] - x[start - 1]) / (n * 0.01) == pytest.approx(v, abs=1e-6)
        start += n
    assert start == stand1


@pytest.mark.slow
def test_the_same_seed_gives_the_same_file(made, tmp_path: Path) -> None:
    config, subject, cache, solvers, rec = made
    again = start_stop_recording(config, subject, SPEED, 1.0, 1.2, cache, solvers)
    paths = []
    for name, r in (("a", rec), ("b", again)):
        Dataset.write(tmp_path / name, {"test": [r]}, info={"kind": "test"})
        paths.append(tmp_path / name / f"{r.name}.csv")
    assert paths[0].read_bytes() == paths[1].read_bytes()
    assert (tmp_path / "a" / f"{rec.name}.json").read_bytes() == (tmp_path / "b" / f"{rec.name}.json").read_bytes()



@pytest.mark.parametrize("index", [0, 1])
def test_the_standing_posture_is_lowered_to_where_the_contact_model_carries_the_weight(index: int) -> None:
    subject = sample_subjects(SynthConfig.from_yaml(SMOKE))[index]
    body, contact = subject.body, ContactParameters()
    q = standing_trajectory(body, 0.5, np.random.default_rng(index)).q[-1]
    dy = contact_height(q, body, contact)
    assert -0.05 < dy < 0.0
    for shift, above in ((dy, None), (dy + 1e-3, False), (dy - 1e-3, True)):
        lowered = q.copy()
        lowered[1] += shift
        grf, _ = contact_forces(lowered, np.zeros(9), body, contact)
        load = float(np.asarray(grf)[[1, 3]].sum()) / body.body_weight
        if above is None:
            assert load == pytest.approx(1.0, abs=1e-4)
        else:
            assert (load > 1.0) is above
    # a shifted standing trajectory keeps its exact labels
    tr = standing_trajectory(body, 0.5, np.random.default_rng(index))
    tr.q[:, 1] += dy
    assert np.abs(tr.kane_residual(body)).max() < 1e-9
    with pytest.raises(ValueError, match="does not carry the body weight within ±5 cm"):
        contact_height(q + np.eye(9)[1] * 1.0, body, contact)  # a metre above the floor


@pytest.mark.slow
def test_a_run_starts_from_standing_walking_forward_then_runs(made) -> None:
    """At 3.0 m/s the first two strides walk (both feet never off the ground together) and the
    pelvis does not step back; then the chain runs (flight phases)."""
    config, subject, cache, solvers, _ = made
    speed = 3.0
    rec = start_stop_recording(config, subject, speed, 1.0, 0.8, cache, solvers)
    res = rec.provenance["kane_residual"]
    assert max(res["max_trans_bw"], res["max_rot_bwh"]) <= config.stride.residual_tol
    strides = rec.provenance["strides"]
    ramp = ramp_speeds(speed)
    assert strides["speed_mps"][: len(ramp)] == pytest.approx(ramp)
    tr = rec.labels.trajectory(rec.time)
    fy = (tr.grf[:, 1] + tr.grf[:, 3]) / subject.body.body_weight
    bounds = rec.provenance["phases"]["walk_start_sample"] + np.concatenate([[0], np.cumsum(strides["n_samples"])])
    first, second, steady = (slice(bounds[i], bounds[i + 1]) for i in (0, 1, len(ramp)))
    assert tr.u[first, 0].min() > -0.1  # no step back beyond the sway (ramped like a walk: -0.37 m/s)
    assert fy[first].min() > 0.2 and fy[second].min() > 0.2  # walking: no flight
    assert fy[steady].min() < 0.02  # running: flight
