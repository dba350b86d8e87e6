"""Read vendor IMU files as ``sspinn import`` does and print what the readers made of them: each
sensor's name and where it came from, the time source and rate, the gaps, the unit checks, and
— over a span in which the sensors are still (a static trial, or quiet standing) — the mean
|specific force| (≈ g) and the gyroscope bias per sensor. No sensor map, no calibration.

Usage::

    python scripts/check_imu_files.py ../shared/data/xsens_mt_static_S01/*.txt
    python scripts/check_imu_files.py FILES... [--imu-rate 100] [--still 0 3] [--map map.yaml]

Exit status 2 with one line on stderr when a file cannot be read (the readers' errors).
"""

from __future__ import annotations

import sys
from pathlib import Path

from sspinn.errors import ArgumentParser, run_cli
from sspinn.imu.sensor_map import SensorMap
from sspinn.imu.stream import IMUImportError, check_sensor, find_gaps, standing_statistics
from sspinn.imu.vendor_readers import read_imu_files


def report(files: list[Path], rate_hz: float | None = None, still: tuple[float, float] | None = None,
           known: tuple[str, ...] = ()) -> list[str]:
    """The lines printed for ``files`` (module docstring)."""
    stream = read_imu_files(files, rate_hz, known)
    lines = [f"{len(stream.sensors)} sensor(s) from {len(files)} file(s)"]
    lines += [f"  {n}" for n in stream.notes]
    lines += [f"WARNING: {w}" for w in stream.warnings]
    lines.append("standing statistics" + (f" ({still[0]:g}–{still[1]:g} s)" if still else " (whole files; assumes the sensors are still)"))
    for s in stream.sensors.values():
        try:
            check_sensor(s)
            gaps = find_gaps(s)
            verdict = f"units ok, {len(gaps)} gap(s)" + (f" (first: {gaps[0].describe()})" if gaps else "")
        except IMUImportError as exc:
            verdict = f"FAILS: {exc}"
        stats = standing_statistics(s, *(still or (None, None)))
        lines.append(f"  {stats.describe()}; {s.sample_rate_hz:.4g} Hz; {verdict}")
    return lines


def _main(argv: list[str]) -> int:
    parser = ArgumentParser(prog="check_imu_files", description=__doc__.splitlines()[0])
    parser.add_argument("files", type=Path, nargs="+", help="one OpenSense file, or Xsens MT Manager .txt files (one per sensor)")
    parser.add_argument("--imu-rate", type=float, default=None, help="update rate for Xsens files without a '// Update Rate' line, Hz")
    parser.add_argument("--still", type=float, nargs=2, default=None, metavar=("START", "END"),
                        help="the span in which the sensors are still, s from the start (default: the whole files)")
    parser.add_argument("--map", type=Path, default=None, help="sensor map whose names (file stems or device IDs) to use")
    args = parser.parse_args(argv)
    known: tuple[str, ...] = ()
    if args.map is not None:
        smap = SensorMap.from_yaml(args.map)
        known = (*smap.assignments, *smap.ignore)
    print("\n".join(report(args.files, args.imu_rate, tuple(args.still) if args.still else None, known)))
    return 0


def main(argv: list[str] | None = None) -> int:
    """Entry point: the exit status (2 and one line on stderr for a file that cannot be read)."""
    return run_cli(_main, "check_imu_files", argv)


if __name__ == "__main__":
    sys.exit(main())
