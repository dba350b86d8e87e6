"""Ship a trained model as ``models/pretrained/``: the model file, a 10-s example recording
without labels, the model's outputs on it (the reference that ``tests/test_pretrained.py``
reproduces) and a README with the model's provenance (command, commit, metrics).

    python scripts/ship_pretrained.py --model results/demo/run/model.pt --data data/synth_default \\
        --metrics results/demo/test/metrics.json --command "make demo" --out models/pretrained

The example is the first 10 s of the first recording of the dataset's test split (a synthetic
subject the model never saw), its labels dropped: a user's recording has none.
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
from pathlib import Path

import numpy as np

import sspinn
from sspinn.data.dataset import Recording
from sspinn.run_folder import atomic_path, atomic_write_text

EXAMPLE_SECONDS = 10.0
#: the outputs stored as the reference (GaitEstimate fields)
REFERENCE_FIELDS = ("q", "u", "tau", "grf")


def example_recording(data: Path) -> Recording:
    rec = sspinn.open_recordings(data, "test")[0]
    n = int(EXAMPLE_SECONDS * 100)
    return Recording(name="example_walk" if "walk" in rec.name or "run" not in rec.name else "example_run",
                     imu=rec.imu[:n], segments=rec.segments, height=rec.height, mass=rec.mass, subject=rec.subject,
                     placement=rec.placement, labels=None,
                     provenance={"source": f"first {EXAMPLE_SECONDS:g} s of {rec.name} (test split of {data.name}), labels dropped"})


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--model", type=Path, required=True)
    p.add_argument("--data", type=Path, required=True, help="the dataset whose test split gives the example")
    p.add_argument("--metrics", type=Path, action="append", default=[], help="metrics.json of its evaluations (repeatable)")
    p.add_argument("--command", required=True, help="the command that trained the model")
    p.add_argument("--commit", default=None, help="the commit whose code trained the model (default: HEAD)")
    p.add_argument("--out", type=Path, default=Path("models/pretrained"))
    args = p.parse_args()

    args.out.mkdir(parents=True, exist_ok=True)
    with atomic_path(args.out / "model.pt") as tmp:
        shutil.copyfile(args.model, tmp)
    rec = example_recording(args.data)
    rec.save(args.out)
    est = sspinn.SSPINNpose.load(args.out / "model.pt").predict(sspinn.open_recordings(args.out / f"{rec.name}.csv")[0])
    with atomic_path(args.out / "reference_outputs.npz") as tmp, open(tmp, "wb") as fh:
        np.savez(fh, **{k: getattr(est, k) for k in REFERENCE_FIELDS})
    commit = args.commit or subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip() or "unknown"
    lines = [
        "# The pretrained model", "",
        "`model.pt` is the model that `make demo` trains on the default synthetic dataset (no labels used), shipped so",
        "that a recording can be estimated without training first:", "",
        f"- trained by: `{args.command}`",
        f"- code: commit `{commit}` (the model file format and these outputs are checked by `tests/test_pretrained.py`)",
        f"- trained on the IMU signals of: {', '.join(sspinn.load_model(args.out / 'model.pt').trained_on or ())}",
        f"- `{rec.name}.csv` / `.json`: {rec.provenance['source']}",
        "- `reference_outputs.npz`: its estimates (q, u, tau, grf) from this model; the test reproduces them.", "",
    ]
    for path in args.metrics:
        result = json.loads(path.read_text())
        split = "held-out test split" if "(test)" in result["title"] else "evaluated recordings"
        lines += [f"## Its figures on the dataset's {split} (`sspinn evaluate`), beside the trivial predictors", "", "| gait | JAE (deg) | JTE (%BW·BH) | GRFE (%BW) | speed error (m/s) |", "|---|---|---|---|---|"]
        for program, c in result.get("by_program", {}).items():
            m, b = c["model"], c["baseline"]
            lines.append(f"| {program} | {m['jae_deg']:.2f} (trivial {b['jae_deg']:.2f}) | {m['jte_pct_bwbh']:.2f} ({b['jte_pct_bwbh']:.2f}) "
                         f"| {m['grfe_pct_bw']:.2f} ({b['grfe_pct_bw']:.2f}) | {m['speed_error_mps']:.3f} ({b['speed_error_mps']:.3f}) |")
        lines.append("")
    atomic_write_text(args.out / "README.md", "\n".join(lines))
    print(f"shipped {args.model} → {args.out}")


if __name__ == "__main__":
    main()
