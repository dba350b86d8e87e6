"""Properties of generated gaits (one forward pass): Kane residual and swing-foot clearance.

For every generator and speed: the cycle's RMS pelvis residual (BW, translational rows, analytic
q̈ — :meth:`predictive.generator.GaitGenerator.predict`'s ``kane_rms_bw``) and the lowest point
(heel or toe, m above the ground) of the right foot while it swings — while its contact point
moves forward more than 0.5 m/s faster than the pelvis. No simulation, no controller.

Usage: ``python -m benchmarks.accuracy.generator_gaits runs/generator_s0/generator.pt [...] [--speeds 1.3 2.2 3.5]``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("generators", type=Path, nargs="+")
    parser.add_argument("--speeds", type=float, nargs="+", default=[1.3, 2.2, 3.5])
    args = parser.parse_args(argv)

    from predictive.generator.gait_generator import GaitGenerator
    from sspinn.model import dynamics, kinematics
    from sspinn.model.body import BodyParameters
    from sspinn.model.contact import ContactParameters

    body = BodyParameters.from_anthropometry()
    print("| generator | " + " | ".join(f"{v} m/s: Kane (BW), clearance (mm)" for v in args.speeds) + " |")
    print("|---|" + "---|" * len(args.speeds))
    for path in args.generators:
        generator = GaitGenerator.load(path)
        cells = []
        for speed in args.speeds:
            gait = generator.predict(speed, body)
            _, w = dynamics.contact_forces(gait.q, gait.u, body, ContactParameters(**gait.contact))
            points = np.asarray(kinematics.point_kinematics(gait.q, gait.u, gait.qdd, np.asarray(w), body))
            swing = points[:, kinematics.point_index("contact_r"), 2] > gait.u[:, 0] + 0.5
            lowest = np.minimum(points[:, kinematics.point_index("heel_r"), 1], points[:, kinematics.point_index("toe_r"), 1])
            cells.append(f"{gait.settings['kane_rms_bw']:.3f}, {1000 * lowest[swing].min():.0f}")
        print(f"| {path} | " + " | ".join(cells) + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
