"""The offline double-support load transfer (sspinn.estimator.load_transfer): which samples it
changes, what it keeps, and that the joints' equations of motion still hold."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from sspinn.cli import main
from sspinn.data.dataset import DataFormatError
from sspinn.data.loading import labelled_recordings
from sspinn.estimator.load_transfer import double_supports, linear_load_transfer
from sspinn.model.body import BodyParameters
from sspinn.model.trajectory import Trajectory
from sspinn.testing import make_recording

BODY = BodyParameters.from_anthropometry(1.75, 70.0)
BW = BODY.body_weight


def walk(n_cycles: int = 3, double: int = 12, single: int = 48, flight: int = 0, seed: int = 0) -> Trajectory:
    """Vertical forces of a walk (or, with ``flight``, a run) whose double supports share the load
    along a bent curve, with random kinematics and torques (only the bookkeeping is tested)."""
    s = np.linspace(0.05, 0.95, double)
    trail = BW * (1 - s) ** 2 + 0.1 * BW  # bent: the trailing foot unloads early
    lead = BW * 1.1 - trail
    stance, gap = np.full(single, BW), np.zeros(flight)
    landing = np.concatenate([lead, stance, gap])  # the foot that lands, over one step
    leaving = np.concatenate([trail, np.zeros(single), gap])  # the other foot
    if flight:  # a run: no foot shares the load
        landing, leaving = np.concatenate([np.zeros(double), stance, gap]), np.zeros(double + single + flight)
    fy_r = np.tile(np.concatenate([leaving, landing]), n_cycles)
    fy_l = np.tile(np.concatenate([landing, leaving]), n_cycles)
    n = len(fy_r)
    rng = np.random.default_rng(seed)
    grf = np.stack([rng.normal(0, 50, n), fy_r, rng.normal(0, 50, n), fy_l], axis=1)
    q = np.zeros((n, 9))
    q[:, 1] = 0.95
    q[:, 2:] = rng.normal(0, 0.3, (n, 7))
    return Trajectory(time=0.01 * np.arange(n), q=q, u=rng.normal(0, 1, (n, 9)), qdd=rng.normal(0, 5, (n, 9)),
                      tau=rng.normal(0, 30, (n, 6)), grf=grf, w=np.full((n, 2), 0.5))


def test_the_trailing_share_becomes_a_line_between_the_double_supports_edges() -> None:
    before = walk()
    after = linear_load_transfer(before, BODY, 100.0)
    runs = double_supports(before.grf, BW, 100.0)
    assert len(runs) == 6 and [t for _, _, t in runs] == [0, 1, 0, 1, 0, 1]
    assert len(double_supports(before.grf[3:], BW, 100.0)) == 5  # one cut by the recording's start is left out
    inside = np.zeros(len(before.time), dtype=bool)
    for start, stop, trailing in runs:
        inside[start:stop] = True
        trail = 1 if trailing == 0 else 3
        total = before.grf[start:stop, 1] + before.grf[start:stop, 3]
        share = after.grf[start:stop, trail] / total
        np.testing.assert_allclose(np.diff(share, 2), 0, atol=1e-12)  # a straight line …
        np.testing.assert_allclose(after.grf[[start, stop - 1]], before.grf[[start, stop - 1]])  # … between the edges
        assert share[len(share) // 2] > before.grf[start + len(share) // 2, trail] / total[len(share) // 2] + 0.05
    np.testing.assert_allclose(after.grf[:, 1] + after.grf[:, 3], before.grf[:, 1] + before.grf[:, 3])
    np.testing.assert_array_equal(after.grf[:, [0, 2]], before.grf[:, [0, 2]])
    np.testing.assert_array_equal(after.grf[~inside], before.grf[~inside])
    np.testing.assert_array_equal(after.tau[~inside], before.tau[~inside])
    assert not np.allclose(after.tau[inside], before.tau[inside])


def test_the_joints_equations_of_motion_hold_as_before() -> None:
    before = walk(seed=1)
    after = linear_load_transfer(before, BODY, 100.0)
    r0, r1 = before.kane_residual(BODY), after.kane_residual(BODY)
    np.testing.assert_allclose(r1[:, [0, 1, *range(3, 9)]], r0[:, [0, 1, *range(3, 9)]], atol=1e-9)
    assert np.abs(r1[:, 2] - r0[:, 2]).max() > 1e-4  # the pelvis's rotation row is what changes


def test_a_run_and_standing_are_left_alone() -> None:
    run = walk(flight=10)
    assert double_supports(run.grf, BW, 100.0) == []
    same = linear_load_transfer(run, BODY, 100.0)
    np.testing.assert_array_equal(same.grf, run.grf)
    np.testing.assert_array_equal(same.tau, run.tau)
    standing = walk(double=80, single=40)  # both feet down 0.8 s at a time
    assert double_supports(standing.grf, BW, 100.0) == []


def test_infer_load_transfer_keeps_the_total_force(tiny_run, tmp_path) -> None:
    data, run = tiny_run[1], tiny_run[4]
    for name, extra in (("plain", []), ("shared", ["--load-transfer"])):
        assert main(["infer", "--model", str(run / "model.pt"), "--data", str(data), "--out", str(tmp_path / name), *extra]) == 0
    paths = sorted((tmp_path / "plain").glob("*_estimate.csv"))
    assert paths
    for path in paths:
        header = path.read_text().splitlines()[0].split(",")
        plain, shared = (np.loadtxt(p, delimiter=",", skiprows=1) for p in (path, tmp_path / "shared" / path.name))
        x_r, y_r, x_l, y_l = (header.index(c) for c in ("grf_x_r", "grf_y_r", "grf_x_l", "grf_y_l"))
        np.testing.assert_allclose(shared[:, y_r] + shared[:, y_l], plain[:, y_r] + plain[:, y_l], rtol=1e-5, atol=1e-2)
        np.testing.assert_array_equal(shared[:, [x_r, x_l]], plain[:, [x_r, x_l]])


def test_evaluate_load_transfer_says_so_in_the_report(tiny_run, tmp_path) -> None:
    data, run = tiny_run[1], tiny_run[4]
    assert main(["evaluate", "--model", str(run / "model.pt"), "--data", str(data), "--out", str(tmp_path / "ev"),
                 "--skip", "10", "--load-transfer"]) == 0
    assert "double-support load transferred linearly" in (tmp_path / "ev" / "report.md").read_text()


def test_labelled_recordings_names_the_recording_without_the_labels(tmp_path) -> None:
    with_grf = make_recording("walk")
    path = with_grf.save(tmp_path)
    assert [r.name for r in labelled_recordings(path, "test", "grf")] == ["walk"]
    with pytest.raises(DataFormatError, match="recording walk has no tau labels"):
        labelled_recordings(path, "test", "tau")
    bare = dataclasses.replace(with_grf, name="bare", labels=None).save(tmp_path)
    with pytest.raises(DataFormatError, match="recording bare has no grf labels"):
        labelled_recordings(bare, "test", "grf")
