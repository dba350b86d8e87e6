"""Fuzzing of the recording readers with hypothesis; the property is "loads with
finite values, or a DataFormatError naming the file, on one line". The cases it found are kept as
explicit ``@example``s (see docs/bad_input.md)."""

from __future__ import annotations

import json
import os
import string
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("hypothesis")  # in the dev extra
from hypothesis import HealthCheck, example, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from sspinn.data.csv_readers import read_averaged_stride, read_csv_recording  # noqa: E402
from sspinn.data.dataset import DataFormatError, Recording  # noqa: E402
from sspinn.model.conventions import SEGMENTS  # noqa: E402
from sspinn.testing import walking_recording  # noqa: E402

#: 60 fixed examples per reader in the suite; SSPINN_FUZZ_EXAMPLES=5000 runs a longer random campaign.
_CAMPAIGN = int(os.environ.get("SSPINN_FUZZ_EXAMPLES", "0"))
FUZZ = settings(max_examples=_CAMPAIGN or 60, deadline=None, derandomize=not _CAMPAIGN, database=None,
                suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])


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
    csv = walking_recording(120).save(folder)
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
    csv = walking_recording(120).save(folder)
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
    imu = walking_recording(150).imu.copy()
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
    rec = walking_recording(200)
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
    _read_or_name_the_folder(folder)


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
    _read_or_name_the_folder(folder)


def _read_or_name_the_folder(folder) -> None:
    """A mutated averaged stride is read with finite signals, or rejected naming its folder."""
    try:
        rec = read_averaged_stride(folder, periods=2)
    except DataFormatError as exc:
        assert str(folder) in str(exc)
        return
    assert np.isfinite(rec.imu).all()
