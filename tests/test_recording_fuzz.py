"""Issue #12 item 3: bad recordings get a DataFormatError naming the file, the column and the
value — the reported cases one by one, and fuzzing of the readers (hypothesis) with the cases it
found kept as explicit examples."""

from __future__ import annotations

import json
import os
import string
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from sspinn.body import IMUPlacement
from sspinn.conventions import SEGMENTS
from sspinn.dataset import DataFormatError, Recording
from sspinn.readers import read_averaged_stride, read_csv_recording
from tests.test_dataset import make_recording

#: 60 fixed examples per reader in the suite; SSPINN_FUZZ_EXAMPLES=5000 runs a longer random campaign.
_CAMPAIGN = int(os.environ.get("SSPINN_FUZZ_EXAMPLES", "0"))
FUZZ = settings(max_examples=_CAMPAIGN or 60, deadline=None, derandomize=not _CAMPAIGN, database=None,
                suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])


def _walking(n: int = 300, seed: int = 0) -> Recording:
    """A recording whose channels move like walking (gyro ±1–8 rad/s per segment, acc ≈ g)."""
    rec = make_recording("walk", "s1", n, np.random.default_rng(seed))
    t = np.arange(n) / 100.0
    for i, s in enumerate(SEGMENTS):
        amp = {"pelvis": 1.0, "femur": 3.0, "tibia": 5.0, "foot": 8.0}[s.split("_")[0]]
        rec.imu[:, i, 2] = amp * np.sin(2 * np.pi * t / 1.1 + i)
    return rec


@pytest.fixture()
def saved(tmp_path: Path) -> Path:
    return _walking().save(tmp_path)


def _edit_csv(csv: Path, column: str, fn) -> None:
    lines = csv.read_text().splitlines()
    k = lines[0].split(",").index(column)
    out = [lines[0]]
    for line in lines[1:]:
        v = line.split(",")
        v[k] = repr(float(fn(float(v[k]))))
        out.append(",".join(v))
    csv.write_text("\n".join(out) + "\n")


def _edit_sidecar(csv: Path, fn) -> None:
    path = csv.with_suffix(".json")
    meta = json.loads(path.read_text())
    path.write_text(json.dumps(fn(meta)) if not isinstance(fn(meta), str) else fn(meta))


# ------------------------------------------------------------------------- the reported cases
def test_pelvis_gyroscope_in_deg_per_s(saved: Path) -> None:
    _edit_csv(saved, "pelvis_gyr_z", lambda v: np.degrees(v) * 0.6)  # peak ≈ 35 "rad/s"
    with pytest.raises(DataFormatError, match=r"walk.csv: column 'pelvis_gyr_z' reaches .*looks like deg/s"):
        Recording.load(saved)


@pytest.mark.parametrize(("fn", "message"), [
    (lambda v: v * 100.0, r"column 'pelvis_acc_y' reaches 10\d\d at sample \d+, beyond 490 m/s² .* \(cm/s² or mm/s²\?\)"),
    (lambda v: v * 6.0, r"pelvis_acc_x/y median magnitude 5\d(\.\d+)? m/s² is 6(\.\d+)? g, far above"),
    (lambda v: 1e308, r"column 'pelvis_acc_x' reaches 1e\+308 at sample 0, beyond 490 m/s²"),
])
def test_accelerometers_in_cm_per_s2_or_absurd(saved: Path, fn, message) -> None:
    _edit_csv(saved, "pelvis_acc_x", fn)
    _edit_csv(saved, "pelvis_acc_y", fn)
    with pytest.raises(DataFormatError, match=message):
        Recording.load(saved)


def test_a_dead_gyroscope(saved: Path) -> None:
    _edit_csv(saved, "tibia_l_gyr_z", lambda v: 0.0)
    with pytest.raises(DataFormatError, match=r"walk.csv: column 'tibia_l_gyr_z' is constant \(0\) over all 300 samples: a dead"):
        Recording.load(saved)


def test_a_saturated_gyroscope(saved: Path) -> None:
    _edit_csv(saved, "foot_r_gyr_z", lambda v: min(v, 6.0))
    with pytest.raises(DataFormatError, match=r"column 'foot_r_gyr_z' is clipped at 6 \(\d+ flat episodes"):
        Recording.load(saved)


def test_gravity_missing_in_the_low_frequency_specific_force(tmp_path: Path) -> None:
    rec = _walking()
    phase = 2 * np.pi * np.arange(300) / 25.0  # |a| = 12 m/s² rotating: no constant part (gravity)
    rec.imu[:, 0, 0], rec.imu[:, 0, 1] = 12.0 * np.sin(phase), 12.0 * np.cos(phase)
    with pytest.raises(DataFormatError, match=r"low-frequency specific force of pelvis_acc_x/y .* median magnitude 0\.00 g"):
        Recording(name="x", imu=rec.imu, segments=rec.segments, height=1.75, mass=70.0)


def test_imu_placement_in_cm(saved: Path) -> None:
    def cm(meta):
        meta["imu"]["placement"]["tibia_r"]["position_m"] = [0.0, -22.5]
        return meta

    _edit_sidecar(saved, cm)
    with pytest.raises(DataFormatError, match=r"walk.csv: IMU placement of tibia_r \(0, -22.5\) is 22.5 m .* in metres"):
        Recording.load(saved)
    with pytest.raises(DataFormatError, match="placement of foot_l"):
        Recording(name="x", imu=_walking().imu, segments=SEGMENTS, height=1.75, mass=70.0,
                  placement=IMUPlacement(positions={**IMUPlacement().positions, "foot_l": (12.0, 0.0)}))


def test_last_line_cut_inside_its_final_field(saved: Path) -> None:
    text = saved.read_text()
    saved.write_text(text[:-3])  # the newline and two digits gone
    with pytest.raises(DataFormatError, match=r"walk.csv: the last line \(row 301\) does not end with a newline"):
        Recording.load(saved)


def test_time_column_at_100_9_hz(saved: Path) -> None:
    lines = saved.read_text().splitlines()
    out = [lines[0]] + [f"{k / 100.9!r}," + line.split(",", 1)[1] for k, line in enumerate(lines[1:])]
    saved.write_text("\n".join(out) + "\n")
    with pytest.raises(DataFormatError, match=r"column 'time' must advance by 0.01 s.* drift from the 100 Hz grid .*100.9 Hz"):
        Recording.load(saved)


@pytest.mark.parametrize(("edit", "message"), [
    (lambda m: m["subject"].update(height_m=None) or m, r"walk.json: subject.height_m must be a number .* got None"),
    (lambda m: m["subject"].update(height_m="1.75 m") or m, r"subject.height_m must be a number \(SI units, no unit text\), got '1.75 m'"),
    (lambda m: [m], r"walk.json: expected a JSON object .* got a list"),
    (lambda m: m["imu"].update(segments="pelvis") or m, r"imu.segments must be a list of segment names"),
    (lambda m: m.update(sample_rate_hz="100") or m, r"sample_rate_hz must be a number"),
    (lambda m: m["imu"].update(placement={"pelvis": 3}) or m, r"bad imu.placement"),
    (lambda m: m.update(labels="q") or m, r"labels must be a list of column names"),
])
def test_sidecar_edge_cases(saved: Path, edit, message) -> None:
    _edit_sidecar(saved, edit)
    with pytest.raises(DataFormatError, match=message):
        Recording.load(saved)


def test_a_utf8_byte_order_mark_is_accepted(saved: Path) -> None:
    saved.write_bytes(b"\xef\xbb\xbf" + saved.read_bytes())
    sidecar = saved.with_suffix(".json")
    sidecar.write_bytes(b"\xef\xbb\xbf" + sidecar.read_bytes())
    assert Recording.load(saved).n_samples == 300


def test_non_numbers_and_ragged_rows_name_row_and_column(saved: Path) -> None:
    lines = saved.read_text().splitlines()
    fields = lines[5].split(",")
    fields[3] = "12,5"  # a decimal comma
    saved.write_text("\n".join([*lines[:5], ",".join(fields), *lines[6:]]) + "\n")
    with pytest.raises(DataFormatError, match=r"row 6 has \d+ values but the header has \d+ columns"):
        Recording.load(saved)
    fields[3] = "1.2.3"
    saved.write_text("\n".join([*lines[:5], ",".join(fields), *lines[6:]]) + "\n")
    with pytest.raises(DataFormatError, match=r"row 6, column 'pelvis_gyr_z': '1.2.3' is not a number"):
        Recording.load(saved)


# ------------------------------------------------------------------------- fuzzing
_mutation = st.one_of(
    st.tuples(st.just("cut"), st.integers(0, 10**6)),
    st.tuples(st.just("delete"), st.integers(0, 10**6), st.integers(1, 40)),
    st.tuples(st.just("insert"), st.integers(0, 10**6), st.text(string.printable + "\ufeff€é", min_size=1, max_size=8)),
    st.tuples(st.just("swap_line"), st.integers(0, 10**6), st.integers(0, 10**6)),
)


def _mutate(text: str, mutation: tuple) -> str:
    kind, at, *rest = mutation
    at %= len(text) + 1
    if kind == "cut":
        return text[:at]
    if kind == "delete":
        return text[:at] + text[at + rest[0]:]
    if kind == "insert":
        return text[:at] + rest[0] + text[at:]
    lines = text.splitlines(keepends=True)
    if not lines:
        return text
    i, j = at % len(lines), rest[0] % len(lines)
    lines[i], lines[j] = lines[j], lines[i]
    return "".join(lines)


def _loads_or_clear_error(csv: Path) -> None:
    try:
        rec = Recording.load(csv)
    except DataFormatError as exc:
        assert str(csv.with_suffix("")) in str(exc) or csv.stem in str(exc), exc
        assert "\n" not in str(exc).strip()
        return
    assert np.isfinite(rec.imu).all()


@FUZZ
@given(mutations=st.lists(_mutation, min_size=1, max_size=3))
@example(mutations=[("insert", 0, "\ufeff")])
@example(mutations=[("cut", 7)])  # header cut: no 'time'
@example(mutations=[("delete", 0, 5)])  # header starts 'time,' gone
@example(mutations=[("insert", 40, ",")])  # an empty column name
@example(mutations=[("cut", 0), ("swap_line", 0, 0)])  # an empty file
def test_fuzz_the_recording_csv(tmp_path_factory, mutations) -> None:
    folder = tmp_path_factory.mktemp("fuzz_csv")
    csv = _walking(120).save(folder)
    text = csv.read_text()
    for m in mutations:
        text = _mutate(text, m)
    csv.write_text(text, encoding="utf-8")
    _loads_or_clear_error(csv)


_json_value = st.recursive(
    st.none() | st.booleans() | st.integers(-10**6, 10**6) | st.floats(allow_nan=False) | st.text(max_size=5),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=4), inner, max_size=3),
    max_leaves=6,
)


def _paths(meta, prefix=()):
    if isinstance(meta, dict):
        for k, v in meta.items():
            yield (*prefix, k)
            yield from _paths(v, (*prefix, k))
    elif isinstance(meta, list):
        for i, v in enumerate(meta):
            yield (*prefix, i)
            yield from _paths(v, (*prefix, i))


@FUZZ
@given(choice=st.integers(0, 10**6), value=_json_value)
@example(choice=0, value=None)
@example(choice=110, value=[])  # found: a placement position_m of [] (not [x, y]) crashed
def test_fuzz_the_sidecar(tmp_path_factory, choice, value) -> None:
    folder = tmp_path_factory.mktemp("fuzz_json")
    csv = _walking(120).save(folder)
    sidecar = csv.with_suffix(".json")
    meta = json.loads(sidecar.read_text())
    paths = list(_paths(meta))
    *parents, leaf = paths[choice % len(paths)]
    node = meta
    for p in parents:
        node = node[p]
    node[leaf] = value
    sidecar.write_text(json.dumps(meta))
    _loads_or_clear_error(csv)


_channel_value = st.floats(allow_nan=True, allow_infinity=True) | st.floats(-50, 50)


@FUZZ
@given(values=st.lists(_channel_value, min_size=1, max_size=6), where=st.integers(0, 10**6),
       scale=st.sampled_from([1.0, 0.0, 1 / 9.81, 9.81, 57.3, 100.0, -1.0, 1e-6]))
def test_fuzz_recording_values(values, where, scale) -> None:
    imu = _walking(150).imu.copy()
    flat = imu.reshape(-1)
    for k, v in enumerate(values):
        flat[(where + 7919 * k) % flat.size] = v
    imu[:, where % 7] *= scale
    try:
        rec = Recording(name="fuzz", imu=imu, segments=SEGMENTS, height=1.75, mass=70.0)
    except DataFormatError as exc:
        assert str(exc).startswith("fuzz: ")
        return
    assert np.isfinite(rec.imu).all() and np.abs(rec.imu).max() < 500


@FUZZ
@given(mutations=st.lists(_mutation, min_size=1, max_size=2), rate=st.sampled_from([50.0, 100.0, 200.0]))
@example(mutations=[("delete", 1558, 3)], rate=50.0)  # found: see docs/bad_input.md
@example(mutations=[("delete", 9, 3)], rate=50.0)
def test_fuzz_the_plain_csv_reader(tmp_path_factory, mutations, rate) -> None:
    folder = tmp_path_factory.mktemp("fuzz_plain")
    rec = _walking(200)
    path = folder / "raw.csv"
    np.savetxt(path, rec.imu[:, 3], delimiter=",", header="ax,ay,gz", comments="", fmt="%.9g")
    text = path.read_text()
    for m in mutations:
        text = _mutate(text, m)
    path.write_text(text)
    try:
        out = read_csv_recording(path, {"foot_r_acc_x": "ax", "foot_r_acc_y": "ay", "foot_r_gyr_z": "gz"}, rate, 1.75, 70.0)
    except DataFormatError as exc:
        assert "raw.csv" in str(exc)
        return
    assert np.isfinite(out.imu).all()


SHARED = Path(__file__).resolve().parents[2] / "shared" / "data" / "dorschky_P03_walking"


@pytest.mark.skipif(not SHARED.exists(), reason="../shared/data/dorschky_P03_walking not present")
@FUZZ
@given(mutation=_mutation)
@example(mutation=("delete", 21521, 3))  # found: a plausibility error naming the folder only
def test_fuzz_the_averaged_stride_reader(tmp_path_factory, mutation) -> None:
    folder = tmp_path_factory.mktemp("fuzz_avg")
    (folder / "meta.json").write_text((SHARED / "meta.json").read_text())
    (folder / "signals.csv").write_text(_mutate((SHARED / "signals.csv").read_text(), mutation))
    try:
        rec = read_averaged_stride(folder, periods=2)
    except DataFormatError as exc:
        assert str(folder) in str(exc)
        return
    assert np.isfinite(rec.imu).all()


@pytest.mark.skipif(not SHARED.exists(), reason="../shared/data/dorschky_P03_walking not present")
@FUZZ
@given(choice=st.integers(0, 10**6), value=_json_value)
def test_fuzz_the_averaged_stride_meta(tmp_path_factory, choice, value) -> None:
    folder = tmp_path_factory.mktemp("fuzz_meta")
    (folder / "signals.csv").write_text((SHARED / "signals.csv").read_text())
    meta = json.loads((SHARED / "meta.json").read_text())
    paths = list(_paths(meta))
    *parents, leaf = paths[choice % len(paths)]
    node = meta
    for p in parents:
        node = node[p]
    node[leaf] = value
    (folder / "meta.json").write_text(json.dumps(meta))
    try:
        rec = read_averaged_stride(folder, periods=2)
    except DataFormatError as exc:
        assert str(folder) in str(exc)
        return
    assert np.isfinite(rec.imu).all()
