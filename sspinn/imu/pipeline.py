"""``sspinn import``: vendor IMU files + a sensor map + the subject → a calibrated
:class:`sspinn.data.dataset.Recording` in a dataset folder that ``sspinn train/evaluate/infer`` read
unchanged, plus a calibration report.

Pipeline (:func:`import_imu`):

1. read the files (:func:`sspinn.imu.vendor_readers.read_imu_files`: OpenSense ``_Accel/_Gyro.trc``,
   OpenSim's ``_linear_accelerations/_angular_velocity.sto`` or Xsens MT Manager ``.txt``; Xsens
   sensors are named as the map names them: file stem or device ID), check them against the sensor map
   (:class:`sspinn.imu.sensor_map.SensorMap`), crop to ``start_s``/``end_s`` (seconds from the start
   of the files), check units and gaps and resample to 100 Hz (:func:`sspinn.imu.stream.resample`);
2. calibrate each sensor onto its segment's sagittal plane from the data
   (:func:`sspinn.imu.calibration.calibrate`) and project: ``acc_x, acc_y, gyr_z`` in the
   segment frame (placement angle 0; positions: the project's default, the map's forefoot or
   explicit ones); check the sensors against each other (:func:`sspinn.imu.cross_sensor_checks.check_mounting`:
   a sensor upside down compared with the others, legs mixed up in the map; and
   :func:`~sspinn.imu.cross_sensor_checks.pelvis_candidate_warnings`: an ignored sensor that fits
   the hips better than the mapped pelvis sensor) — warnings, printed and stored in the provenance
   and the report;
3. optionally read the GRF (``.mot``; :func:`sspinn.imu.vendor_readers.read_treadmill_grf_columns`;
   above 100 Hz low-pass filtered at 40 Hz first), check it against the subject
   (:mod:`sspinn.imu.grf_checks`: the vertical force's sign and unit are errors, a mean away from body
   weight and both feet unloaded for long are warnings), align it
   (:func:`sspinn.imu.time_alignment.align_to_grf`: files that start together and last equally
   long, or ``same_clock=True``, keep their shared clock unless the evidence against it is
   decisive; ``align="per-foot"`` labels each foot's force with its own lag; an ambiguous lag,
   force channels offset in time, sides swapped against the IMUs and lag jumps are warnings), orient its horizontal axis along the walking
   direction (:func:`sspinn.imu.time_alignment.walking_direction_sign`), resample it onto the IMU
   samples (linear) and store ``grf_x_r, grf_y_r, grf_x_l, grf_y_l`` (N) as labels — the
   recording is cropped to the samples the GRF covers; the lag is in the provenance;
4. optionally a constant ``speed`` label (m/s; the treadmill belt speed);
5. write ``<out>/<name>.csv`` + ``.json`` (:meth:`Recording.save`), add the recording to
   ``<out>/dataset.json`` and write ``<name>_calibration.md``, ``.png`` and ``.json``.

``dataset.json`` splits: by default (``split="all"``) the recording is listed in train, val and
test alike — self-supervised training needs no labels and estimating on the training data is
how a self-supervised estimator is used; for a held-out evaluation import the test subjects
with ``split="test"`` into the same folder.
"""

from __future__ import annotations

import argparse
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Final

import numpy as np
from scipy.signal import butter, sosfiltfilt

from sspinn.data.dataset import (
    FORMAT,
    RESERVED_SUFFIX,
    SPLITS,
    DataFormatError,
    Dataset,
    Labels,
    Recording,
    check_name,
    holds_recording,
)
from sspinn.data.signal_checks import label_findings, recording_findings
from sspinn.errors import UserError
from sspinn.imu.calibration import Calibration, calibrate
from sspinn.imu.calibration_report import calibration_markdown, plot_calibration
from sspinn.imu.cross_sensor_checks import check_mounting, pelvis_candidate_warnings
from sspinn.imu.grf_checks import check_vertical_force, unloaded_share_warning
from sspinn.imu.sensor_map import SensorMap
from sspinn.imu.stream import ANTI_ALIAS_HZ, DEFAULT_MAX_GAP_S, RATE_HZ, IMUImportError, IMUStream, resample
from sspinn.imu.time_alignment import (
    CLOCK_SOURCES,
    Alignment,
    align_to_grf,
    files_share_clock,
    imu_signals,
    walking_direction_sign,
)
from sspinn.imu.vendor_readers import read_imu_files, read_treadmill_grf_columns
from sspinn.model.conventions import GRF
from sspinn.run_folder import atomic_write_text, output_target
from sspinn.yaml_config import read_yaml

#: Version of the import procedure, stored in the provenance.
IMPORTER_VERSION: Final = 7
#: ``align`` modes of :func:`import_imu`: one lag for both feet, or each foot's own.
ALIGN_MODES: Final = ("common", "per-foot")


@dataclass
class ImportResult:
    """What :func:`import_imu` made: the recording, its calibration and alignment, and the files."""

    recording: Recording
    calibration: Calibration
    alignment: Alignment | None
    csv: Path
    report: Path
    figure: Path


def default_name(files: list[Path]) -> str:
    """The recording name from the first file: OpenSense ``<stem>_Accel.trc[.gz]`` → ``<stem>``."""
    name = files[0].name
    for suffix in (".gz", ".trc", ".txt", ".csv", "_Accel", "_Gyro"):
        name = name.removesuffix(suffix)
    name = "".join(ch if ch.isalnum() or ch in "-_." else "_" for ch in name).lstrip(".").removesuffix(RESERVED_SUFFIX)
    return name or "imported"


def _report_paths(out: Path, name: str) -> tuple[Path, Path, Path]:
    """The calibration report, its JSON and its figure beside recording ``name``."""
    stem = f"{name}{RESERVED_SUFFIX}"
    return out / f"{stem}.md", out / f"{stem}.json", out / f"{stem}.png"


def recording_target(out: Path, name: str, overwrite: bool) -> str:
    """The name a recording is imported under: ``name``, or — when the dataset folder already
    holds a recording (or calibration report) of that name and ``overwrite`` is false — the first
    free ``name_2``, ``name_3``, … announced on a ``NOTE`` line (:func:`sspinn.run_folder.output_target`)."""
    check_name(name, out)

    def taken(path: Path) -> bool:
        return holds_recording(out, path.name) or any(p.exists() for p in _report_paths(out, path.name))

    return output_target(out / name, taken, overwrite, "a recording", "give another --name, ").name


def ignored_signals(ignored: IMUStream, grid: np.ndarray) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """The sensors the map ignores on the imported ``grid`` (s), for
    :func:`~sspinn.imu.cross_sensor_checks.pelvis_candidate_warnings`; a sensor that cannot be
    resampled there (gaps, a dead axis, a shorter span) is left out: it is not imported."""
    out = {}
    margin = 0.05  # s of samples kept around the grid for the spline
    for name, sensor in ignored.sensors.items():
        t0 = float(sensor.time[0])
        try:
            one = IMUStream({name: sensor}, ignored.source).crop(max(0.0, grid[0] - t0 - margin), grid[-1] - t0 + margin)
            _, one = resample(one, grid=grid)
        except UserError:
            continue
        out[name] = (one.sensors[name].acc, one.sensors[name].gyr)
    return out


def _read_sensor_map(path: Path) -> SensorMap:
    """The sensor map at ``path``, read through :func:`sspinn.yaml_config.read_yaml` (a regular
    UTF-8 file of bounded size, no duplicate keys: errors name the file)."""
    if not path.exists():
        return SensorMap.from_yaml(path)  # its own "not found" message
    return SensorMap.from_dict(read_yaml(path), source=str(path))


def import_imu(
    imu_files: list[str | Path],
    sensor_map: SensorMap | str | Path,
    height: float,
    mass: float,
    out: str | Path,
    *,
    subject: str = "unknown",
    name: str | None = None,
    grf: str | Path | None = None,
    speed: float | None = None,
    start_s: float | None = None,
    end_s: float | None = None,
    standing: bool = True,
    max_gap_s: float = DEFAULT_MAX_GAP_S,
    split: str = "all",
    imu_rate_hz: float | None = None,
    same_clock: bool | None = None,
    align: str = "common",
    overwrite: bool = False,
) -> ImportResult:
    """Import one trial (module docstring). ``height`` m, ``mass`` kg, ``speed`` m/s, times s;
    ``imu_rate_hz``: the update rate of Xsens files whose header lacks one (Hz); ``same_clock``:
    True if the IMU and GRF files share a clock, False if not, None to tell from their starts and
    durations; ``align``: ``"common"`` (one lag) or ``"per-foot"`` (each foot's own lag). A
    recording of the same name already in ``out`` is replaced only with ``overwrite`` (and only by
    the same subject's); else this one is imported as ``<name>_2``, … with a ``NOTE``."""
    if align not in ALIGN_MODES:
        raise IMUImportError(f"align must be one of {list(ALIGN_MODES)}, got {align!r}")
    files = [Path(f) for f in imu_files]
    smap = sensor_map if isinstance(sensor_map, SensorMap) else _read_sensor_map(Path(sensor_map))
    if split not in (*SPLITS, "all"):
        raise IMUImportError(f"split must be one of {[*SPLITS, 'all']}, got {split!r}")
    name = recording_target(Path(out), default_name(files) if name is None else name, overwrite)
    stream = read_imu_files(files, imu_rate_hz, known=(*smap.assignments, *smap.ignore))
    smap.check_sensors(stream.names, stream.source)
    ignored = IMUStream({s: stream.sensors[s] for s in stream.names if s in smap.ignore}, stream.source)
    stream.sensors = {s: stream.sensors[s] for s in stream.names if s in smap.assignments}
    t_file0 = min(float(s.time[0]) for s in stream.sensors.values())
    t_file1 = max(float(s.time[-1]) for s in stream.sensors.values())
    if start_s is not None or end_s is not None:
        stream = stream.crop(start_s, end_s)
    grid, stream = resample(stream, max_gap_s=max_gap_s)
    by_segment = smap.by_segment()
    signals = {seg: (stream.sensors[a.sensor].acc, stream.sensors[a.sensor].gyr) for seg, a in by_segment.items()}
    cal = calibrate(signals, by_segment, RATE_HZ, standing="auto" if standing else None, source=stream.source)
    sources = {seg: stream.sensors[a.sensor].source for seg, a in by_segment.items()}
    legs_mixed = check_mounting(signals, cal, by_segment, sources)
    cal.warnings += pelvis_candidate_warnings(ignored_signals(ignored, grid), signals, cal, by_segment, sources)
    cal.warnings[:0] = stream.warnings
    projected = {seg: cal.sensors[seg].project(*signals[seg]) for seg in by_segment}
    imu = np.stack([projected[seg] for seg in smap.segments], axis=1)
    times = grid - t_file0  # s from the start of the IMU files
    keep = np.ones(len(grid), dtype=bool)
    labels: dict[str, np.ndarray] = {}
    alignment = None
    notes = list(stream.notes)
    if grf is not None:
        alignment, grf_labels, keep, grf_notes, grf_warnings = _grf_labels(Path(grf), signals, cal, times, mass,
                                                                           (t_file0, t_file1), same_clock, align)
        labels.update(grf_labels)
        notes += grf_notes
        cal.warnings += grf_warnings
    if speed is not None:
        if not np.isfinite(speed) or not 0 <= speed <= 12:
            raise IMUImportError(f"speed {speed} m/s is outside 0–12 m/s (give m/s)")
        labels["speed"] = np.full(len(grid), float(speed))
    if keep.sum() < 2:
        raise IMUImportError(f"{stream.source}: no IMU sample is covered by the GRF file {grf}")
    labels = {k: v[keep] for k, v in labels.items()}
    provenance: dict[str, Any] = {
        "kind": "imported IMU recording", "importer_version": IMPORTER_VERSION, "imu_files": [str(f) for f in files],
        "sensor_map": smap.source, "start_s_in_files": round(float(times[keep][0]), 4),
        "end_s_in_files": round(float(times[keep][-1]), 4), "imu_frame": "segment frame (calibrated; placement angle 0)",
        "calibration": {seg: c.to_dict() for seg, c in cal.sensors.items()},
        "standing_s": None if cal.standing is None else [round((cal.standing[0]) / RATE_HZ + float(times[0]), 3),
                                                         round(cal.standing[1] / RATE_HZ + float(times[0]), 3)],
        "turning_s": [[round(t.start / RATE_HZ + float(times[0]), 3), round(t.stop / RATE_HZ + float(times[0]), 3),
                       round(t.heading_change_deg, 1)] for t in cal.turns],
        "stride_period_s": round(cal.stride_period_s, 3), "warnings": list(cal.warnings), "notes": cal.notes + notes,
        "gaps": [g.describe() for g in stream.gaps],
    }
    if grf is not None and alignment is not None:
        provenance.update(grf_file=str(grf), grf_alignment=alignment.to_dict(),
                          grf_misaligned_s=[[round(float(times[a]), 3), round(float(times[b - 1]) + 1 / RATE_HZ, 3), round(d, 3)]
                                            for a, b, d in alignment.lag_jumps])
    if speed is not None:
        provenance["speed_source"] = "given (constant, m/s)"
    try:
        rec = Recording(
            name=name, imu=imu[keep], segments=smap.segments, height=height, mass=mass, subject=subject,
            placement=smap.placement(height), labels=Labels.from_columns(labels, int(keep.sum())) if labels else None,
            provenance=provenance,
        )
        # the signal checks of every path into the estimator (leg pairing: check_mounting above)
        findings = recording_findings(rec, stream.source, leg_pairing=False, joints_judged=not legs_mixed) + label_findings(rec, f"{stream.source} + {grf}", mean_check=False)
    except DataFormatError as exc:
        raise IMUImportError(f"{stream.source} after calibration: {exc}") from None
    cal.warnings += findings
    provenance["warnings"] += findings
    out = Path(out)
    csv = add_to_index(out, rec, split, overwrite)
    context = {"files": ", ".join(str(f) for f in files), "sensor map": smap.source,
               "subject": f"{subject}, {height} m, {mass} kg", "recording": f"{csv} ({rec.n_samples} samples, {rec.duration:.2f} s)"}
    report, report_json, report_png = _report_paths(out, name)
    atomic_write_text(report, calibration_markdown(name, cal, alignment, context, notes))
    atomic_write_text(report_json, json.dumps(
        {"sensors": provenance["calibration"], "alignment": provenance.get("grf_alignment"), "warnings": provenance["warnings"],
         "notes": provenance["notes"]}, indent=2))
    figure = plot_calibration(report_png, name, cal, projected, {s: v[1] for s, v in signals.items()})
    return ImportResult(rec, cal, alignment, csv, report, figure)


def _grf_labels(path: Path, signals: dict[str, tuple[np.ndarray, np.ndarray]], cal: Calibration, times: np.ndarray,
                mass: float, imu_span: tuple[float, float], same_clock: bool | None = None,
                align: str = "common") -> tuple[Alignment, dict[str, np.ndarray], np.ndarray, list[str], list[str]]:
    """(alignment, GRF label columns on the IMU samples, mask of the samples the GRF covers, notes,
    warnings: :mod:`sspinn.imu.grf_checks` and the alignment's); ``imu_span``: the IMU files' first
    and last times (s, before any crop), for the shared-clock test."""
    t_grf, forces, columns = read_treadmill_grf_columns(path)
    warnings = check_vertical_force(path, forces, columns, mass)
    t_grf0 = float(t_grf[0])
    shared = files_share_clock(imu_span[0], imu_span[1], t_grf0, float(t_grf[-1])) if same_clock is None else same_clock
    # on a shared clock the GRF grid (from its first sample) reads the IMU grid's first time + this
    clock_lag = float(times[0]) + imu_span[0] - t_grf0 if shared else None
    t_grf = t_grf - t_grf0
    rate = 1.0 / float(np.median(np.diff(t_grf)))
    notes = []
    if rate > 1.01 * RATE_HZ:  # force plates often run at 1 kHz: anti-alias before going to 100 Hz
        sos = butter(4, ANTI_ALIAS_HZ, fs=rate, output="sos")
        forces = {s: sosfiltfilt(sos, f, axis=0) for s, f in forces.items()}
        notes.append(f"GRF {path.name}: {rate:.4g} Hz low-pass filtered at {ANTI_ALIAS_HZ:g} Hz before resampling to 100 Hz")
    grid = np.arange(int(np.floor(t_grf[-1] * RATE_HZ + 1e-9)) + 1) / RATE_HZ
    on_grid = {s: np.column_stack([np.interp(grid, t_grf, f[:, k]) for k in range(2)]) for s, f in forces.items()}
    unloaded = unloaded_share_warning(path, on_grid["r"][:, 1], on_grid["l"][:, 1], mass)
    warnings += [unloaded] if unloaded else []
    inputs = imu_signals(signals)
    if inputs is None:
        raise IMUImportError(f"{path}: aligning the GRF needs a foot or shank sensor on each side with a force plate; the map has none")
    still, hit, activity, names = inputs
    alignment = align_to_grf(still, hit, {s: f[:, 1] for s, f in on_grid.items()}, activity, cal.stride_period_s, RATE_HZ,
                             max_lag_s=max(grid[-1], times[-1] - times[0]) + 1.0, names=names, clock_lag_s=clock_lag, clock_source="files" if same_clock is None else "given",
                             per_foot=align == "per-foot")
    warnings += [f"{path}: {w}" for w in alignment.warnings]
    # the alignment's lag is between the two grids' first samples: grid time = (IMU sample time − first IMU time) + lag
    t_on_grf = {side: times - times[0] + lag for side, lag in alignment.label_lags.items()}
    keep = np.logical_and.reduce([(t >= 0) & (t <= grid[-1]) for t in t_on_grf.values()])
    notes.append(f"GRF {path.name}: {alignment_note(alignment, float(times[0]) + imu_span[0] - t_grf0)}; "
                 f"{int((~keep).sum())} IMU samples outside the GRF dropped")
    labels = {}
    for side in ("r", "l"):
        sign = walking_direction_sign(on_grid[side][:, 0], on_grid[side][:, 1], RATE_HZ)
        if sign < 0:
            notes.append(f"GRF {path.name}, side {side}: the force x axis points against the walking direction; flipped")
        labels[f"grf_x_{side}"] = sign * np.interp(t_on_grf[side], grid, on_grid[side][:, 0])
        labels[f"grf_y_{side}"] = np.interp(t_on_grf[side], grid, on_grid[side][:, 1])
    assert set(labels) == set(GRF)
    return alignment, labels, keep, notes, warnings


def alignment_note(alignment: Alignment, grid_offset_s: float) -> str:
    """One line on the lag used between the files' starts (t_GRF = t_IMU + lag, s) and where it
    came from: the shared clock kept, overruled, or measured; per foot with ``--align per-foot``.
    ``grid_offset_s``: the alignment's lag minus the files' lag (the import's crop)."""
    lags = alignment.label_lags
    used = (f"lag {alignment.lag_s - grid_offset_s:+.3f} s" if not alignment.per_foot else
            "lags per foot " + ", ".join(f"{s} {v - grid_offset_s:+.3f} s" for s, v in lags.items())
            + f" (common {alignment.lag_s - grid_offset_s:+.3f} s)")
    text = f"{used} between the files' starts (t_GRF = t_IMU + lag), from {CLOCK_SOURCES[alignment.clock]}"
    if alignment.clock in ("files", "given") and alignment.measured_lag_s is not None:
        text += (f"; measured {alignment.measured_lag_s - grid_offset_s:+.3f} s within ±{alignment.window_s:.2f} s "
                 "(--separate-clocks to use it)")
    return text


def add_to_index(folder: Path, rec: Recording, split: str, overwrite: bool = False) -> Path:
    """Save ``rec`` into the dataset folder and list it in ``split`` of its ``dataset.json``
    (``"all"``: train, val and test) through the dataset's one writer
    (:meth:`sspinn.data.dataset.Dataset.add`: locked, atomic); a recording of the same name is
    replaced only with ``overwrite``. Returns the CSV path."""

    def note(info: dict[str, Any]) -> None:
        info.setdefault("imported", {})[rec.name] = {"subject": rec.subject, "split": split, "format": FORMAT}
        info["note"] = ("recordings imported with `sspinn import`; split 'all' lists a recording in train, val and test "
                        "(self-supervised use on the same data)")

    Dataset.add(folder, rec, SPLITS if split == "all" else (split,), note, overwrite)
    return folder / f"{rec.name}.csv"


# ---------------------------------------------------------------------------------- command line
def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register ``sspinn import``."""
    from sspinn.errors import bounded

    p = sub.add_parser("import", help="vendor IMU files (OpenSense .trc, Xsens .txt) + sensor map → calibrated recording")
    p.add_argument("--imu", type=Path, nargs="+", required=True, help="IMU files: one OpenSense _Accel.trc[.gz] or Xsens .txt per sensor")
    p.add_argument("--sensor-map", type=Path, required=True, help="YAML sensor → segment map (configs/sensor_maps/)")
    p.add_argument("--height", type=bounded(float, 0.5, 2.5, " m"), required=True, help="subject height, m")
    p.add_argument("--mass", type=bounded(float, 10.0, 300.0, " kg"), required=True, help="subject mass, kg")
    p.add_argument("--out", type=Path, required=True, help="dataset folder (created; dataset.json updated)")
    p.add_argument("--subject", default="unknown", help="subject id (splits are by subject)")
    p.add_argument("--name", default=None, help="recording name (default: from the file name)")
    p.add_argument("--grf", type=Path, default=None, help="GRF .mot[.gz] to align and store as grf_* labels (N)")
    p.add_argument("--speed", type=bounded(float, 0.0, 12.0, " m/s"), default=None, help="constant speed label, m/s (treadmill)")
    p.add_argument("--start", type=bounded(float, 0.0, 1e6, " s"), default=None, help="import from this time, s from the files' start")
    p.add_argument("--end", type=bounded(float, 0.0, 1e6, " s"), default=None, help="import up to this time, s")
    p.add_argument("--no-standing", action="store_true", help="ignore quiet standing (in-plane angles from walking alone)")
    p.add_argument("--max-gap", type=bounded(float, 0.0, 10.0, " s"), default=DEFAULT_MAX_GAP_S, help="longest gap interpolated, s")
    p.add_argument("--split", default="all", choices=[*SPLITS, "all"], help="split of dataset.json (all: train, val and test)")
    clock = p.add_mutually_exclusive_group()
    clock.add_argument("--same-clock", dest="same_clock", action="store_const", const=True, default=None,
                       help="the IMU and GRF files share a clock: keep it unless the evidence against it is decisive "
                       "(default: when they start together and last equally long)")
    clock.add_argument("--separate-clocks", dest="same_clock", action="store_const", const=False,
                       help="the files' clocks are unrelated: search the lag (ambiguous by whole strides without a change of activity)")
    p.add_argument("--align", choices=ALIGN_MODES, default="common",
                   help="GRF alignment: one lag for both feet (common) or each foot's own (per-foot: force plates on separate clocks)")
    p.add_argument("--imu-rate", type=bounded(float, 1.0, 2000.0, " Hz"), default=None,
                   help="update rate of the Xsens files, Hz: needed where PacketCounter times the samples and no "
                   "'// Update Rate' header line gives it (a header that disagrees is an error)")
    p.add_argument("--overwrite", action="store_true",
                   help="replace a recording of the same --name (same subject) in --out (else a NOTE and <name>_2, …)")


def run(args: argparse.Namespace) -> int:
    """Run ``sspinn import`` and print a summary."""
    result = import_imu(
        args.imu, args.sensor_map, args.height, args.mass, args.out, subject=args.subject, name=args.name, grf=args.grf,
        speed=args.speed, start_s=args.start, end_s=args.end, standing=not args.no_standing, max_gap_s=args.max_gap,
        split=args.split, imu_rate_hz=args.imu_rate, same_clock=args.same_clock, align=args.align,
        overwrite=args.overwrite,
    )
    rec, cal = result.recording, result.calibration
    print(f"{rec.name}: {rec.n_samples} samples ({rec.duration:.1f} s), IMUs {list(rec.segments)} → {result.csv}")
    for seg, c in cal.sensors.items():
        print(f"  {c.sensor} → {seg}: out-of-plane {c.out_of_plane_fraction:.1%}, φ {c.angle_deg:+.1f}°, sign margin {c.sign_margin:.2f}")
    if result.alignment is not None:
        print(f"  GRF: {result.alignment.describe()}")
        line = next((n for n in rec.provenance["notes"] if n.startswith("GRF ") and "between the files' starts" in n), None)
        if line is not None:
            print(f"  NOTE: time alignment: {line}")
    if rec.provenance["gaps"]:
        print(f"  {len(rec.provenance['gaps'])} gap(s) interpolated (listed in the report), the first: {rec.provenance['gaps'][0]}")
    for warning in cal.warnings:
        print(f"  WARNING: {warning}")
    print(f"calibration report: {result.report} (+ {result.figure.name})")
    return 0
