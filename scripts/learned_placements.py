"""The IMU placements a training run with ``learn_placement`` recovered, per subject, with their
spread over the subject's recordings — for real recordings, whose true placement nobody knows.

Usage::

    sspinn train --config configs/sspinn/demo.yaml --data DATA --out RUN --set learn_placement=true
    python scripts/learned_placements.py RUN --data DATA [--split train] [--out RUN/placements.md]

Per subject and sensor: the nominal placement of the recording (what the estimator is told:
x, y in the segment frame, cm; y along the pelvis, thigh and shank, x along the foot; the angle,
°), the mean learned one over the subject's recordings and its range (max − min) over them. A
learned placement that differs between two recordings of one subject by more than the sensor
could have moved is not a recovered mounting.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from sspinn.data.dataset import Dataset
from sspinn.estimator.training import CHECKPOINT_ENTRIES
from sspinn.model.conventions import SEGMENTS
from sspinn.run_folder import atomic_write_text
from sspinn.torch_files import CHECKPOINT, load_torch_file


def learned_placements(run: Path, data: Path, split: str = "train") -> dict[str, dict[str, dict[str, list[float]]]]:
    """subject → sensor → {"nominal": [x cm, y cm, angle °] (mean), "learned": mean, "range": max − min}."""
    state = load_torch_file(run / "checkpoint.pt", (CHECKPOINT,), CHECKPOINT_ENTRIES, "rerun the training", "cpu")
    names = list(state["recordings"])
    learned = state["placement"].numpy().reshape(len(names), len(SEGMENTS), 3)
    recordings = {r.name: r for r in Dataset.open(data).load(split)}
    units = np.array([100.0, 100.0, 180.0 / np.pi])
    by_subject: dict[str, list[tuple[np.ndarray, np.ndarray]]] = {}
    for k, name in enumerate(names):
        rec = recordings.get(name)
        if rec is None:
            raise SystemExit(f"{run}: trained on {name!r}, which is not in the {split!r} split of {data}")
        nominal = rec.placement.vector().reshape(len(SEGMENTS), 3)
        by_subject.setdefault(rec.subject or name, []).append((nominal * units, learned[k] * units))
    out: dict[str, dict[str, dict[str, list[float]]]] = {}
    for subject, pairs in sorted(by_subject.items()):
        nominal = np.stack([p[0] for p in pairs])
        after = np.stack([p[1] for p in pairs])
        out[subject] = {s: {"recordings": len(pairs), "nominal": nominal[:, i].mean(0).tolist(), "learned": after[:, i].mean(0).tolist(),
                            "range": (after[:, i].max(0) - after[:, i].min(0)).tolist()}
                        for i, s in enumerate(SEGMENTS) if s in state["segments"]}
    return out


def report(placements: dict, run: Path) -> str:
    lines = [f"# IMU placements learned by {run}", "",
             "Per subject: nominal → learned (mean over the subject's recordings) [range over them]; x, y in cm in the "
             "segment frame (y along pelvis, thigh, shank; x along the foot), angle in °.", ""]
    for subject, sensors in placements.items():
        n = next(iter(sensors.values()))["recordings"]
        lines += [f"## {subject} ({n} recordings)", "", "| sensor | x (cm) | y (cm) | angle (°) |", "|---|---|---|---|"]
        for s, v in sensors.items():
            cells = [f"{v['nominal'][j]:.1f} → {v['learned'][j]:.1f} [{v['range'][j]:.1f}]" for j in range(3)]
            lines.append(f"| {s} | " + " | ".join(cells) + " |")
        lines.append("")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run", type=Path, help="a training run folder (learn_placement: true)")
    parser.add_argument("--data", type=Path, required=True, help="the dataset it was trained on")
    parser.add_argument("--split", default="train")
    parser.add_argument("--out", type=Path, default=None, help="Markdown report (default: RUN/placements.md)")
    args = parser.parse_args(argv)
    text = report(learned_placements(args.run, args.data, args.split), args.run)
    out = args.out or args.run / "placements.md"
    atomic_write_text(out, text + "\n")
    print(text)
    print(f"→ {out}")


if __name__ == "__main__":
    main()
