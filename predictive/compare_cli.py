"""``python -m predictive compare --config configs/predictive/compare.yaml --out results/compare``:
the comparison harness of :mod:`predictive.comparison` (table, learning curves, gait cycles,
stick figures in ``<out>/report.md``)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

COMMAND = "compare"


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(COMMAND, help="self-supervised generator vs SB3 agents vs OCP on the same env and metrics")
    p.add_argument("--config", type=Path, default=Path("configs/predictive/compare.yaml"))
    p.add_argument("--out", type=Path, required=True, help="report folder")
    p.add_argument("--seeds", type=int, default=None, help="use only the first N seeds (quick runs)")


def run(args: argparse.Namespace) -> int:
    from predictive.comparison import ComparisonConfig, run_comparison

    try:
        config = ComparisonConfig.from_yaml(args.config)
        if args.seeds is not None:
            config.seeds = config.seeds[: max(1, args.seeds)]
        run_comparison(config, args.out)
    except (ValueError, FileNotFoundError) as exc:
        print(f"python -m predictive compare: error: {exc}", file=sys.stderr)
        return 2
    print(f"report: {args.out / 'report.md'}")
    return 0
