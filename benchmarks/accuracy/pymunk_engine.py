"""The seven-segment body rebuilt in pymunk (Chipmunk2D), an engine independent of our derivation.

Each segment of :class:`~sspinn.model.body.BodyParameters` becomes a pymunk ``Body(mass, moment)``
whose position is the segment's centre of mass (world frame, m) and whose angle is the segment's
global angle (rad); pymunk bodies rotate about their position, so the moment is the segment's
inertia about its centre of mass (kg·m²). ``PivotJoint``\\ s connect HAT–femur (hip, one per
side), femur–tibia (knee) and tibia–foot (ankle); the HAT segment floats freely under gravity
(0, −g). There is no ground and there are no shapes, hence no collisions.

The geometry is computed here from the segment parameters alone (origin at the proximal joint,
y along the segment pointing proximally, see :mod:`sspinn.model.conventions`), not from the generated
kinematics, so that the comparison also checks those.

Generalized coordinates are read back from the pymunk bodies: pelvis_tx/ty is the hip pivot on
the HAT body, pelvis_tilt the HAT angle, and the joint angles are differences of segment angles
(distal − proximal), which makes knee flexion negative as in the conventions.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pymunk

from sspinn.model.body import BodyParameters
from sspinn.model.conventions import N_Q, SEGMENTS, SIDES, index


@dataclass(frozen=True)
class SegmentState:
    """Planar state of one segment in the world frame.

    Attributes:
        origin: proximal joint position (x, y), m.
        origin_velocity: its velocity, m/s.
        angle: global segment angle, rad (counter-clockwise seen from the right).
        rate: angular velocity, rad/s.
        com: centre-of-mass position, m.
        com_velocity: centre-of-mass velocity, m/s.
    """

    origin: np.ndarray
    origin_velocity: np.ndarray
    angle: float
    rate: float
    com: np.ndarray
    com_velocity: np.ndarray


def _rotate(angle: float, v: tuple[float, float] | np.ndarray) -> np.ndarray:
    """Rotate the 2-vector ``v`` by ``angle`` (rad) counter-clockwise."""
    c, s = np.cos(angle), np.sin(angle)
    return np.array([c * v[0] - s * v[1], s * v[0] + c * v[1]])


def _cross_z(omega: float, r: np.ndarray) -> np.ndarray:
    """ω ẑ × r for a planar vector r (m) and angular rate ω (rad/s), in m/s."""
    return np.array([-omega * r[1], omega * r[0]])


def segment_states(body: BodyParameters, q: np.ndarray, u: np.ndarray) -> dict[str, SegmentState]:
    """World-frame states of the seven segments for coordinates ``q`` and speeds ``u = dq/dt``.

    Plain forward kinematics from the segment parameters: HAT angle = pelvis_tilt, femur = HAT +
    hip, tibia = femur + knee, foot = tibia + ankle; the knee lies ``femur.length`` below the hip
    along the femur's −y axis, the ankle ``tibia.length`` below the knee.
    """
    q = np.asarray(q, dtype=float)
    u = np.asarray(u, dtype=float)
    if q.shape != (N_Q,) or u.shape != (N_Q,):
        raise ValueError(f"q and u must have shape ({N_Q},), got {q.shape} and {u.shape}")
    hip, hip_velocity = q[0:2].copy(), u[0:2].copy()

    def make(name: str, origin: np.ndarray, origin_velocity: np.ndarray, angle: float, rate: float) -> SegmentState:
        r_com = _rotate(angle, getattr(body, name).com)
        return SegmentState(
            origin=origin,
            origin_velocity=origin_velocity,
            angle=angle,
            rate=rate,
            com=origin + r_com,
            com_velocity=origin_velocity + _cross_z(rate, r_com),
        )

    states = {"pelvis": make("pelvis", hip, hip_velocity, float(q[2]), float(u[2]))}
    for side in SIDES:
        angle, rate = float(q[2]), float(u[2])
        origin, origin_velocity = hip, hip_velocity
        previous: str | None = None
        for seg, joint in (("femur", "hip"), ("tibia", "knee"), ("foot", "ankle")):
            name = f"{seg}_{side}"
            if previous is not None:  # the distal joint of the previous segment
                r = _rotate(angle, (0.0, -getattr(body, previous).length))
                origin, origin_velocity = origin + r, origin_velocity + _cross_z(rate, r)
            j = index(f"{joint}_{side}")
            angle, rate = angle + float(q[j]), rate + float(u[j])
            states[name] = make(name, origin, origin_velocity, angle, rate)
            previous = name
    return states


#: (name, proximal segment, distal segment) of each pivot joint; the pivot is the distal
#: segment's origin.
JOINT_PAIRS: tuple[tuple[str, str, str], ...] = tuple(
    (f"{joint}_{side}", proximal, f"{distal}_{side}")
    for side in SIDES
    for joint, proximal, distal in (
        ("hip", "pelvis", "femur"),
        ("knee", f"femur_{side}", "tibia"),
        ("ankle", f"tibia_{side}", "foot"),
    )
)


def build_pymunk_body(
    body: BodyParameters,
    q0: np.ndarray,
    u0: np.ndarray,
    *,
    iterations: int = 100,
    error_bias: float = 1e-6,
    max_bias: float = float("inf"),
) -> tuple[pymunk.Space, dict[str, pymunk.Body], dict[str, pymunk.PivotJoint]]:
    """A pymunk space holding the body in state (q0, u0) (conventions of :mod:`sspinn.model.conventions`).

    Args:
        body: segment parameters (SI units).
        q0, u0: generalized coordinates (m, rad) and speeds (m/s, rad/s), shape (9,).
        iterations: constraint-solver iterations per step (``Space.iterations``).
        error_bias: fraction of a joint's positional error left uncorrected after one second
            (``Constraint.error_bias``; pymunk's default is 0.9⁶⁰ ≈ 1.8e-3).
        max_bias: largest speed (m/s) at which joint errors are corrected (``Constraint.max_bias``).

    Returns:
        ``(space, bodies, joints)``: the space with gravity (0, −g), the pymunk bodies keyed by
        segment name (:data:`~sspinn.model.conventions.SEGMENTS`) and the pivot joints keyed by joint
        name (hip_r, knee_r, ...).
    """
    space = pymunk.Space()
    space.gravity = (0.0, -body.gravity)
    space.iterations = iterations
    space.damping = 1.0  # no velocity damping
    states = segment_states(body, q0, u0)
    bodies: dict[str, pymunk.Body] = {}
    for name in SEGMENTS:
        seg, st = getattr(body, name), states[name]
        b = pymunk.Body(mass=seg.mass, moment=seg.inertia)
        b.position = (float(st.com[0]), float(st.com[1]))
        b.angle = st.angle
        b.velocity = (float(st.com_velocity[0]), float(st.com_velocity[1]))
        b.angular_velocity = st.rate
        space.add(b)
        bodies[name] = b
    joints: dict[str, pymunk.PivotJoint] = {}
    for joint, proximal, distal in JOINT_PAIRS:
        # anchors in the bodies' local frames (origin at the CoM, axes of the segment frame)
        pivot_in_proximal = _pivot_in_segment_frame(body, proximal, distal)
        anchor_a = tuple(np.subtract(pivot_in_proximal, getattr(body, proximal).com))
        anchor_b = tuple(-np.asarray(getattr(body, distal).com))
        pj = pymunk.PivotJoint(bodies[proximal], bodies[distal], anchor_a, anchor_b)
        pj.collide_bodies = False
        pj.error_bias = error_bias
        pj.max_bias = max_bias
        space.add(pj)
        joints[joint] = pj
    return space, bodies, joints


def _pivot_in_segment_frame(body: BodyParameters, proximal: str, distal: str) -> tuple[float, float]:
    """Position (m) of the distal segment's origin in the proximal segment's frame."""
    if proximal == "pelvis":
        return (0.0, 0.0)  # both hips lie at the HAT origin
    return (0.0, -getattr(body, proximal).length)


def read_state(
    body: BodyParameters, bodies: dict[str, pymunk.Body], joints: dict[str, pymunk.PivotJoint]
) -> tuple[np.ndarray, np.ndarray, float]:
    """Generalized coordinates (9,), speeds (9,) and the largest joint gap (m) of a pymunk body.

    pelvis_tx/ty and their rates are the hip pivot point on the HAT body; pelvis_tilt is the HAT
    angle; joint angles/rates are differences of the bodies' angles/angular velocities. The gap
    is the largest distance between the two anchor points of any pivot joint (zero when the
    constraints hold exactly).
    """
    hat = bodies["pelvis"]
    hip = hat.local_to_world(tuple(-np.asarray(body.pelvis.com)))
    hip_velocity = hat.velocity_at_world_point(hip)
    q = np.empty(N_Q)
    u = np.empty(N_Q)
    q[0:2] = hip.x, hip.y
    u[0:2] = hip_velocity.x, hip_velocity.y
    q[2], u[2] = hat.angle, hat.angular_velocity
    gap = 0.0
    for joint, proximal, distal in JOINT_PAIRS:
        a, b = bodies[proximal], bodies[distal]
        j = index(joint)
        q[j] = b.angle - a.angle
        u[j] = b.angular_velocity - a.angular_velocity
        pj = joints[joint]
        gap = max(gap, (a.local_to_world(pj.anchor_a) - b.local_to_world(pj.anchor_b)).length)
    return q, u, gap


def simulate_pymunk(
    body: BodyParameters,
    q0: np.ndarray,
    u0: np.ndarray,
    *,
    duration: float,
    dt: float = 1e-4,
    sample_dt: float = 0.01,
    iterations: int = 100,
    error_bias: float = 1e-6,
    max_bias: float = float("inf"),
) -> dict[str, np.ndarray]:
    """Release the pymunk body from (q0, u0) without torques or ground, sampled like :func:`sspinn.model.simulation.simulate`.

    Args:
        body, q0, u0, iterations, error_bias, max_bias: as in :func:`build_pymunk_body`.
        duration: simulated time, s.
        dt: pymunk time step, s (Chipmunk integrates with first-order semi-implicit Euler).
        sample_dt: output interval, s; must be a whole multiple of ``dt``.

    Returns:
        ``{"t": (n,) s, "q": (n, 9), "u": (n, 9), "joint_gap": (n,) m}`` with n = duration /
        sample_dt + 1 samples; q and u follow :data:`~sspinn.model.conventions.COORDINATES`.
    """
    if duration <= 0 or dt <= 0 or sample_dt <= 0:
        raise ValueError(f"need duration, dt, sample_dt > 0; got {duration}, {dt}, {sample_dt}")
    steps_per_sample = int(round(sample_dt / dt))
    if steps_per_sample < 1 or not np.isclose(steps_per_sample * dt, sample_dt, rtol=1e-9, atol=0.0):
        raise ValueError(f"sample_dt ({sample_dt} s) must be a whole multiple of dt ({dt} s)")
    n = int(round(duration / sample_dt))
    space, bodies, joints = build_pymunk_body(
        body, q0, u0, iterations=iterations, error_bias=error_bias, max_bias=max_bias
    )
    q = np.empty((n + 1, N_Q))
    u = np.empty((n + 1, N_Q))
    gap = np.empty(n + 1)
    for k in range(n + 1):
        q[k], u[k], gap[k] = read_state(body, bodies, joints)
        if k < n:
            for _ in range(steps_per_sample):
                space.step(dt)
    return {"t": np.arange(n + 1) * sample_dt, "q": q, "u": u, "joint_gap": gap}
