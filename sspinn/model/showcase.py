"""`sspinn showcase`: a short physics showcase of the model (a drop landing).

The body starts 5 cm in the air in a slightly crouched pose, lands on the spring-damper ground
and is held by joint-space PD torques around that pose for 0.8 s (there is no balance
controller: left alone longer, it slowly topples); the contact model, the numba stepper and the
energy bookkeeping are all exercised. Writes a PNG (stick figures, GRF, joint angles,
energy) and a CSV of the motion.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from sspinn.model import dynamics, simulation
from sspinn.model.body import BodyParameters
from sspinn.model.contact import ContactParameters
from sspinn.model.conventions import COORDINATES, GRF, JOINTS
from sspinn.model.drawing import draw_stick_figure, save_figure, stick_points


def run_drop_landing(
    body: BodyParameters,
    contact: ContactParameters,
    duration: float = 0.8,
    drop_height: float = 0.05,
    control_dt: float = 0.001,
    sim_dt: float = 1e-4,
    stiffness: float = 8.0,
    damping: float = 0.2,
) -> simulation.Rollout:
    """Drop the body from ``drop_height`` m with PD joint control (gains in N·m/rad and
    N·m·s/rad per kg body mass) holding the initial crouch; returns the sampled trajectory.
    The PD torque is held over each ``control_dt``; with these gains that interval must stay
    near 1 ms (a zero-order-held damper of gain k_d on the foot's ~0.025 kg·m² is unstable once
    k_d·dt/I > 2)."""
    q_ref = np.array([0.0, 0.0, 0.1, 0.25, -0.45, 0.2, 0.25, -0.45, 0.2])
    # lift so the lowest foot point is drop_height above ground
    zeros = np.zeros(9)
    pts = stick_points(q_ref, body)
    lowest = min(pts[f"{p}_{s}"][1] for p in ("heel", "toe") for s in "rl")
    q_ref[1] = drop_height - lowest
    q, u = q_ref.copy(), zeros.copy()
    p, c = body.vector(), contact.vector()
    kp, kd = stiffness * body.mass, damping * body.mass
    n = int(round(duration / control_dt))
    substeps = int(round(control_dt / sim_dt))
    Q, U, G, T = [q], [u], [dynamics.contact_forces(q, u, p, c)[0]], []
    for _ in range(n):
        tau = -kp * (q[3:] - q_ref[3:]) - kd * u[3:]
        # the hips also keep the trunk's global angle (their reaction acts on the HAT)
        trunk = -2 * kp * (q[2] - q_ref[2]) - 2 * kd * u[2]
        tau[[0, 3]] -= 0.5 * trunk
        q, u, grf = simulation.step(q, u, tau, p, c, sim_dt, substeps, method="rk4")
        Q.append(q)
        U.append(u)
        G.append(grf)
        T.append(tau)
    T.append(np.zeros(6))
    return simulation.Rollout(t=np.arange(n + 1) * control_dt, q=np.array(Q), u=np.array(U), grf=np.array(G), tau=np.array(T))


def plot_trajectory(traj: simulation.Rollout, body: BodyParameters, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    kin, pot = dynamics.energy(traj.q, traj.u, body)
    fig, axes = plt.subplots(2, 2, figsize=(11, 7))
    ax = axes[0, 0]
    for i, k in enumerate(np.linspace(0, len(traj.t) - 1, 6).astype(int)):
        draw_stick_figure(ax, traj.q[k] + np.eye(9)[0] * 0.35 * i, body, alpha=0.9, grf=traj.grf[k])
    ax.axhline(0, color="0.5")
    ax.set_aspect("equal")
    ax.set_title("poses at 6 instants (shifted right for clarity)")
    ax = axes[0, 1]
    ax.plot(traj.t, traj.grf[:, 1] / body.body_weight, label="F_y right")
    ax.plot(traj.t, traj.grf[:, 3] / body.body_weight, label="F_y left")
    ax.set_ylabel("vertical GRF (BW)")
    ax.legend()
    ax = axes[1, 0]
    for j, name in enumerate(JOINTS[:3]):
        ax.plot(traj.t, np.degrees(traj.q[:, 3 + j]), label=name)
    ax.set_ylabel("joint angle (deg)")
    ax.set_xlabel("time (s)")
    ax.legend()
    ax = axes[1, 1]
    ax.plot(traj.t, kin, label="kinetic")
    ax.plot(traj.t, pot - pot[-1], label="potential (rel. to end)")
    ax.set_ylabel("energy (J)")
    ax.set_xlabel("time (s)")
    ax.legend()
    fig.suptitle(f"sspinn drop landing: {body.height} m, {body.mass} kg")
    save_figure(fig, path, dpi=110)


def main(out: Path, body: BodyParameters | None = None) -> dict[str, float]:
    out.mkdir(parents=True, exist_ok=True)
    body = body or BodyParameters.from_anthropometry()
    contact = ContactParameters()
    t0 = time.perf_counter()
    traj = run_drop_landing(body, contact)
    wall = time.perf_counter() - t0
    plot_trajectory(traj, body, out / "drop_landing.png")
    header = ",".join(["time", *COORDINATES, *(f"d_{c}" for c in COORDINATES), *GRF, *(f"tau_{j}" for j in JOINTS)])
    np.savetxt(out / "drop_landing.csv", np.column_stack([traj.t, traj.q, traj.u, traj.grf, traj.tau]), delimiter=",", header=header, comments="")
    summary = {
        "simulated_s": float(traj.t[-1]),
        "wall_s": wall,
        "peak_vertical_grf_bw": float(traj.grf[:, 1::2].sum(axis=1).max() / body.body_weight),
        "final_vertical_grf_bw": float(traj.grf[-1, 1::2].sum() / body.body_weight),
        "final_hip_height_m": float(traj.q[-1, 1]),
    }
    for k, v in summary.items():
        print(f"{k:24s} {v:.3f}")
    print(f"wrote {out / 'drop_landing.png'} and {out / 'drop_landing.csv'}")
    return summary
