"""Predict a walking gait by optimal control (direct collocation, CasADi + IPOPT), no data used.

    python examples/solve_gait.py [--quick] [--speed 1.3]
"""

import argparse

import numpy as np

import predictive

parser = argparse.ArgumentParser()
parser.add_argument("--quick", action="store_true", help="10 nodes per half cycle, one start (seconds)")
parser.add_argument("--speed", type=float, default=1.3, help="average speed, m/s")
args = parser.parse_args()

options = {"n_nodes": 10, "starts": predictive.DEFAULT_STARTS[:1]} if args.quick else {}
solution = predictive.solve_predictive(args.speed, **options)

print(f"{solution.status} after {solution.iterations} IPOPT iterations, stride {solution.duration:.2f} s")
print(f"hip flexion range: {np.degrees(np.ptp(solution.q[:, 3])):.1f}°, "
      f"peak vertical GRF {solution.grf[:, 1].max() / (9.81 * 70):.2f} BW (70 kg)")
