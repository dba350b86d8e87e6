"""Command line: ``python -m predictive solve --speed 1.3 --out results/ocp/walk_1.3``.

The dispatcher of ``python -m predictive``; each sub-command lives next to what it drives:

* ``solve`` — one predictive gait by trajectory optimisation (:mod:`predictive.ocp.cli`);
* ``track-imu`` — IMU tracking of an averaged stride, compared with its labels
  (:mod:`predictive.experiments.cli`);
* ``synth`` — a physically exact synthetic dataset (:mod:`predictive.synth.cli`);
* ``synth-standing`` — quiet-standing or stand–walk–stand recordings of a synthetic
  configuration's subjects (:mod:`predictive.synth.standing_cli`);
* ``train-generator``, ``generate`` — the self-supervised gait generator (:mod:`predictive.generator.cli`);
* ``compare`` — generator vs SB3 agents vs OCP on the same environment (:mod:`predictive.experiments.cli`);
* ``robustness`` — falls of the generator's controllers under disturbances (:mod:`predictive.experiments.cli`).
"""

from __future__ import annotations

import argparse
import sys

from predictive.experiments import cli as experiments_cli
from predictive.generator import cli as generator_cli
from predictive.ocp import cli as ocp_cli
from predictive.synth import cli as synth_cli
from predictive.synth import standing_cli
from sspinn.errors import ArgumentParser, run_cli


def build_parser() -> argparse.ArgumentParser:
    """The command-line interface (every sub-command)."""
    parser = ArgumentParser(prog="python -m predictive", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    ocp_cli.add_parser(sub)  # solve
    experiments_cli.add_track_imu_parser(sub)  # track-imu
    synth_cli.add_parser(sub)  # synth
    standing_cli.add_parser(sub)  # synth-standing
    generator_cli.add_parsers(sub)  # train-generator, generate
    experiments_cli.add_compare_parser(sub)  # compare
    experiments_cli.add_robustness_parser(sub)  # robustness
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point: the exit status (2 and one line on stderr for a user error, ``--debug`` for
    the traceback; see :func:`sspinn.errors.run_cli`)."""
    return run_cli(_main, "python -m predictive", argv, user_errors=(ValueError,))


def _main(argv: list[str]) -> int:
    args = build_parser().parse_args(argv)
    if args.command == ocp_cli.COMMAND:
        return ocp_cli.run(args)
    if args.command == synth_cli.COMMAND:
        return synth_cli.run(args)
    if args.command == standing_cli.COMMAND:
        return standing_cli.run(args)
    if args.command in generator_cli.COMMANDS:
        return generator_cli.run(args)
    if args.command in experiments_cli.COMMANDS:
        return experiments_cli.run(args)
    raise AssertionError(args.command)  # argparse enforces the sub-commands


if __name__ == "__main__":
    sys.exit(main())
