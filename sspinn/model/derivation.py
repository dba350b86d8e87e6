"""Equations of motion of the sagittal 9-DOF model, derived once with Kane's method.

This module reads like the textbook page: symbols, frames, points, bodies, loads, then
``KanesMethod``. All body parameters stay symbolic (one derivation serves every body); the
backends in ``sspinn/model/_generated`` are written from these expressions by :mod:`sspinn.model.codegen`.
Conventions: :mod:`sspinn.model.conventions`.

Outputs (all as plain SymPy symbols, no dynamicsymbols):

* ``mass_matrix`` M(q) (9×9) and ``forcing`` f(q, u, τ, F, w) (9) with M·q̈ = f,
* ``kane_residual`` r = M·q̈ − f (what SSPINNpose's L_K penalises),
* global kinematics of the named points and segments, virtual IMU signals, energies, and the
  contact model of :mod:`sspinn.model.contact` evaluated at the forward-kinematics contact points.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cache

import sympy as sp
import sympy.physics.mechanics as me

from sspinn.model import contact
from sspinn.model.body import PARAMETERS
from sspinn.model.conventions import COORDINATES, GRF, JOINTS, POINTS, SEGMENTS, SIDES


@dataclass
class SymbolicModel:
    """The derived model: input symbol groups and output expressions."""

    inputs: dict[str, list[sp.Symbol]]
    outputs: dict[str, sp.Matrix] = field(default_factory=dict)


def _plain(name: str) -> sp.Symbol:
    return sp.Symbol(name, real=True)


@cache
def derive() -> SymbolicModel:
    """Derive the model (takes a few seconds; cached per process)."""
    t = me.dynamicsymbols._t

    # ---------------------------------------------------------------- symbols
    q = me.dynamicsymbols(" ".join(COORDINATES), real=True)
    u = me.dynamicsymbols(" ".join(f"d_{c}" for c in COORDINATES), real=True)
    tau = dict(zip(JOINTS, sp.symbols([f"tau_{j}" for j in JOINTS], real=True)))
    grf = sp.symbols(list(GRF), real=True)
    w = dict(zip(SIDES, sp.symbols([f"w_{s}" for s in SIDES], real=True)))
    par = {name: _plain(name) for name in PARAMETERS}
    g = par["gravity"]
    coord = dict(zip(COORDINATES, q))

    # ---------------------------------------------------------------- frames
    # Every segment frame is oriented directly from N by its global angle (a sum of
    # coordinates), which keeps the expressions compact.
    N = me.ReferenceFrame("N")
    angle = {"pelvis": coord["pelvis_tilt"]}
    for s in SIDES:
        angle[f"femur_{s}"] = angle["pelvis"] + coord[f"hip_{s}"]
        angle[f"tibia_{s}"] = angle[f"femur_{s}"] + coord[f"knee_{s}"]
        angle[f"foot_{s}"] = angle[f"tibia_{s}"] + coord[f"ankle_{s}"]
    frame = {}
    for seg in SEGMENTS:
        frame[seg] = me.ReferenceFrame(f"F_{seg}")
        frame[seg].orient_axis(N, N.z, angle[seg])

    # ---------------------------------------------------------------- points
    O = me.Point("O")
    O.set_vel(N, 0)
    hip = O.locatenew("hip", coord["pelvis_tx"] * N.x + coord["pelvis_ty"] * N.y)
    origin = {"pelvis": hip}
    points = {"hip": hip}
    for s in SIDES:
        femur, tibia, foot = frame[f"femur_{s}"], frame[f"tibia_{s}"], frame[f"foot_{s}"]
        knee = hip.locatenew(f"knee_{s}", -par[f"femur_{s}_length"] * femur.y)
        ankle = knee.locatenew(f"ankle_{s}", -par[f"tibia_{s}_length"] * tibia.y)
        heel_v = par[f"foot_{s}_heel_x"] * foot.x + par[f"foot_{s}_heel_y"] * foot.y
        toe_v = par[f"foot_{s}_toe_x"] * foot.x + par[f"foot_{s}_toe_y"] * foot.y
        origin |= {f"femur_{s}": hip, f"tibia_{s}": knee, f"foot_{s}": ankle}
        points |= {
            f"knee_{s}": knee,
            f"ankle_{s}": ankle,
            f"heel_{s}": ankle.locatenew(f"heel_{s}", heel_v),
            f"toe_{s}": ankle.locatenew(f"toe_{s}", toe_v),
            # contact point: a foot-fixed point at fraction w from toe to heel
            f"contact_{s}": ankle.locatenew(f"contact_{s}", toe_v + w[s] * (heel_v - toe_v)),
        }
    assert tuple(points) == POINTS

    # ---------------------------------------------------------------- bodies
    bodies = []
    com = {}
    for seg in SEGMENTS:
        com[seg] = origin[seg].locatenew(
            f"com_{seg}", par[f"{seg}_com_x"] * frame[seg].x + par[f"{seg}_com_y"] * frame[seg].y
        )
        inertia = (me.inertia(frame[seg], 0, 0, par[f"{seg}_inertia"]), com[seg])
        bodies.append(me.RigidBody(seg, com[seg], frame[seg], par[f"{seg}_mass"], inertia))

    # velocities: every point's velocity is the time derivative of its position in N
    for p in (*points.values(), *com.values()):
        p.set_vel(N, p.pos_from(O).dt(N))

    # ---------------------------------------------------------------- loads
    loads = [(com[seg], -par[f"{seg}_mass"] * g * N.y) for seg in SEGMENTS]
    for s in SIDES:
        for joint, proximal, distal in (
            (f"hip_{s}", "pelvis", f"femur_{s}"),
            (f"knee_{s}", f"femur_{s}", f"tibia_{s}"),
            (f"ankle_{s}", f"tibia_{s}", f"foot_{s}"),
        ):
            loads += [(frame[distal], tau[joint] * N.z), (frame[proximal], -tau[joint] * N.z)]
    fx = dict(zip(SIDES, grf[0::2]))
    fy = dict(zip(SIDES, grf[1::2]))
    for s in SIDES:
        loads.append((points[f"contact_{s}"], fx[s] * N.x + fy[s] * N.y))

    # ---------------------------------------------------------------- Kane's method
    kd = [qi.diff(t) - ui for qi, ui in zip(q, u)]
    kane = me.KanesMethod(N, q_ind=q, u_ind=u, kd_eqs=kd)
    kane.kanes_equations(bodies, loads)
    M = kane.mass_matrix
    f = kane.forcing

    # ---------------------------------------------------------------- plain symbols
    qs = [_plain(c) for c in COORDINATES]
    us = [_plain(f"d_{c}") for c in COORDINATES]
    qdds = [_plain(f"dd_{c}") for c in COORDINATES]
    to_plain = {}
    for qi, ui, qsi, usi, qddi in zip(q, u, qs, us, qdds):
        to_plain |= {qi.diff(t, 2): qddi, ui.diff(t): qddi, qi.diff(t): usi, ui: usi, qi: qsi}

    def plain(expr):
        return sp.Matrix(expr).xreplace(to_plain) if isinstance(expr, sp.MatrixBase) else expr.xreplace(to_plain)

    def kinematics(position_xy: list[sp.Expr]) -> list[sp.Expr]:
        """[x, y, vx, vy, ax, ay] of a position given in dynamicsymbols."""
        vel = [c.diff(t) for c in position_xy]
        acc = [c.diff(t) for c in vel]
        return [plain(e) for e in (*position_xy, *vel, *acc)]

    def xy(p: me.Point) -> list[sp.Expr]:
        v = p.pos_from(O)
        return [v.dot(N.x), v.dot(N.y)]

    M_plain = plain(M)
    f_plain = plain(f)
    residual = M_plain * sp.Matrix(qdds) - f_plain

    point_kin = sp.Matrix([kinematics(xy(p)) for p in points.values()])
    seg_kin = sp.Matrix([[plain(a), plain(a.diff(t)), plain(a.diff(t, 2))] for a in angle.values()])

    # ---------------------------------------------------------------- virtual IMUs
    imu = {seg: sp.symbols(f"imu_{seg}_x imu_{seg}_y imu_{seg}_angle", real=True) for seg in SEGMENTS}
    imu_rows, imu_kin = [], []
    for seg in SEGMENTS:
        px, py, phi = imu[seg]
        sensor = origin[seg].locatenew(f"imu_{seg}", px * frame[seg].x + py * frame[seg].y)
        sensor_kin = kinematics(xy(sensor))
        imu_kin.append(sensor_kin)
        ax, ay = sensor_kin[4:]
        th = plain(angle[seg]) + phi  # sensor-frame angle in N
        # specific force a − g (g = −g·N.y) in the sensor frame
        fxs, fys = ax, ay + g
        acc_x = fxs * sp.cos(th) + fys * sp.sin(th)
        acc_y = -fxs * sp.sin(th) + fys * sp.cos(th)
        imu_rows.append([acc_x, acc_y, plain(angle[seg].diff(t))])
    virtual_imu = sp.Matrix(imu_rows)

    # ---------------------------------------------------------------- energy
    kinetic = sum(b.kinetic_energy(N) for b in bodies)
    potential = sum(par[f"{seg}_mass"] * g * com[seg].pos_from(O).dot(N.y) for seg in SEGMENTS)
    energy = sp.Matrix([plain(kinetic), plain(potential)])

    # ---------------------------------------------------------------- contact model
    cpar = {name: _plain(f"contact_{name}") for name in contact.CONTACT_PARAMETERS}
    mu_hat = [_plain(f"mu_hat_{s}") for s in SIDES]
    body_weight = g * sum(par[f"{seg}_mass"] for seg in SEGMENTS)
    w_of_q = {s: contact.contact_fraction(plain(angle[f"foot_{s}"]), cpar["sharpness"]) for s in SIDES}
    forces_learned, forces_sim = [], []
    for i, s in enumerate(SIDES):
        x, y, vx, vy, _, _ = (e.xreplace({w[s]: w_of_q[s]}) for e in kinematics(xy(points[f"contact_{s}"])))
        fy_s = contact.vertical_force(y, vy, body_weight, cpar)
        forces_learned += [contact.friction_learned(fy_s, mu_hat[i], cpar), fy_s]
        forces_sim += [contact.friction_simulation(fy_s, vx, cpar), fy_s]

    # SSPINNpose's variant: the contact point hangs off *separately estimated* ankle kinematics
    # (global x, y, vx, vy per foot); only the foot angle and rate come from q, u.
    ankle = {s: sp.symbols(f"ankle_x_{s} ankle_y_{s} ankle_vx_{s} ankle_vy_{s}", real=True) for s in SIDES}
    from_ankles = []
    for i, s in enumerate(SIDES):
        foot = frame[f"foot_{s}"]
        offset = points[f"contact_{s}"].pos_from(points[f"ankle_{s}"])  # foot-fixed, at fraction w
        rx, ry = (plain(offset.dot(N.x)), plain(offset.dot(N.y)))
        rate = plain(foot.ang_vel_in(N).dot(N.z))
        ax_, ay_, avx, avy = ankle[s]
        xc, yc = ax_ + rx, ay_ + ry
        vxc, vyc = avx - rate * ry, avy + rate * rx  # v_ankle + ω ẑ × r
        sub = {w[s]: w_of_q[s]}
        xc, yc, vxc, vyc = (e.xreplace(sub) for e in (xc, yc, vxc, vyc))
        fy_s = contact.vertical_force(yc, vyc, body_weight, cpar)
        from_ankles.append([contact.friction_learned(fy_s, mu_hat[i], cpar), fy_s, xc, yc, vxc, vyc])

    return SymbolicModel(
        inputs={
            "q": qs,
            "u": us,
            "qdd": qdds,
            "tau": [tau[j] for j in JOINTS],
            "grf": list(grf),
            "w": [w[s] for s in SIDES],
            "p": [par[n] for n in PARAMETERS],
            "imu": [s for seg in SEGMENTS for s in imu[seg]],
            "c": [cpar[n] for n in contact.CONTACT_PARAMETERS],
            "mu_hat": mu_hat,
            "ankle": [a for s in SIDES for a in ankle[s]],
        },
        outputs={
            "mass_matrix": M_plain,
            "forcing": f_plain,
            "kane_residual": residual,
            "point_kinematics": point_kin,
            "segment_kinematics": seg_kin,
            "virtual_imu": virtual_imu,
            "imu_kinematics": sp.Matrix(imu_kin),
            "energy": energy,
            "contact_fraction": sp.Matrix([w_of_q[s] for s in SIDES]),
            "contact_forces_learned": sp.Matrix(forces_learned),
            "contact_forces_simulation": sp.Matrix(forces_sim),
            "contact_from_ankles": sp.Matrix(from_ankles),
        },
    )


if __name__ == "__main__":  # pragma: no cover - a quick look at the model size
    import time

    t0 = time.perf_counter()
    model = derive()
    print(f"derived in {time.perf_counter() - t0:.1f} s")
    for name, expr in model.outputs.items():
        print(f"{name:28s} shape {expr.shape}  ops {sp.count_ops(expr)}")
