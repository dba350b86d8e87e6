"""Command-line interface: ``sspinn <command>`` (or ``python -m sspinn <command>``)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="sspinn", description="Sagittal gait dynamics from IMUs, self-supervised.")
    sub = parser.add_subparsers(dest="command", required=True)
    demo = sub.add_parser("demo", help="the main job on the embedded default (for now: a physics showcase)")
    demo.add_argument("--out", type=Path, default=Path("results/demo"), help="output folder")
    demo.add_argument("--body", type=Path, default=None, help="body YAML (default: 1.75 m, 70 kg)")
    args = parser.parse_args(argv)

    if args.command == "demo":
        from sspinn import demo as demo_mod
        from sspinn.body import BodyParameters

        body = BodyParameters.from_yaml(args.body) if args.body else None
        demo_mod.main(args.out, body)
    return 0


if __name__ == "__main__":
    sys.exit(main())
