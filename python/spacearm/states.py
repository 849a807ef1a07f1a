"""A free-floating base's state in other tools' conventions, and back.

spacearm's (MuJoCo's free joint): q = [p_o (base frame origin, world), w x y z, joints],
v = [dp_o/dt (world), omega (base frame), joint rates]. The others:

- Pinocchio (JointModelFreeFlyer): q = [p_o, x y z w, joints], v = [R^T dp_o/dt, omega (base
  frame), joint rates]: both velocities in the base frame.
- SpaceDyn (Yoshida): the base's centre of mass R0 (world), its attitude as a quaternion (here
  w x y z), v0 = dR0/dt (world), w0 = omega in the world frame, joint angles and rates.
- SPART: r0 = the base's centre of mass (world), R0 its rotation matrix, u0 = [omega (base
  frame), dr0/dt (world)], joint angles qm and rates um.

Joint coordinates: spacearm's slot of a rigidly geared joint is its motor angle qm = p q; the
others take link angles. Give `ratios` (one per joint, 1 where the slot holds the link angle:
Model.motor_angle_slots says which) to convert them; without it the joint values pass unchanged.
`base_com` is the base's centre of mass in the base frame (the scene's base com; a URDF's root
inertial origin). Each function takes one state (1-D arrays) and returns numpy arrays; every
pair round-trips to rounding (tests/python/test_states.py).
"""
import numpy as _np

__all__ = [
    "to_pinocchio",
    "from_pinocchio",
    "to_spacedyn",
    "from_spacedyn",
    "to_spart",
    "from_spart",
]


def _rotation(w, x, y, z):
    """The rotation matrix of a quaternion (normalized first, as spacearm's model does)."""
    n = _np.sqrt(w * w + x * x + y * y + z * z)
    if not (n > 0):
        raise ValueError("the base's quaternion is zero")
    w, x, y, z = w / n, x / n, y / n, z / n
    return _np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def _quaternion(R):
    """A rotation matrix's quaternion (w x y z, w >= 0), by the largest of four pivots."""
    t = _np.trace(R)
    if t > 0:
        s = 2 * _np.sqrt(1 + t)
        q = [s / 4, (R[2, 1] - R[1, 2]) / s, (R[0, 2] - R[2, 0]) / s, (R[1, 0] - R[0, 1]) / s]
    else:
        i = int(_np.argmax(_np.diag(R)))
        j, k = (i + 1) % 3, (i + 2) % 3
        s = 2 * _np.sqrt(1 + R[i, i] - R[j, j] - R[k, k])
        q = [0.0, 0.0, 0.0, 0.0]
        q[0] = (R[k, j] - R[j, k]) / s
        q[1 + i] = s / 4
        q[1 + j] = (R[j, i] + R[i, j]) / s
        q[1 + k] = (R[k, i] + R[i, k]) / s
    q = _np.array(q)
    return -q if q[0] < 0 else q


def _state(q, v):
    q = _np.asarray(q, dtype=float)
    v = _np.asarray(v, dtype=float)
    if q.ndim != 1 or v.ndim != 1 or q.size < 7 or v.size != q.size - 1:
        raise ValueError(
            "expected a free base's state: q of size 7 + N and v of size 6 + N, got %d and %d"
            % (q.size, v.size)
        )
    return q, v


def _joints(values, ratios, inverse):
    if ratios is None:
        return _np.array(values, dtype=float)
    r = _np.asarray(ratios, dtype=float)
    if r.shape != values.shape:
        raise ValueError("ratios: expected %d values, got %d" % (values.size, r.size))
    return values * r if inverse else values / r


def to_pinocchio(q, v, ratios=None):
    """spacearm's (q, v) as Pinocchio's free-flyer (q, v)."""
    q, v = _state(q, v)
    R = _rotation(*q[3:7])
    qp = _np.concatenate([q[0:3], q[4:7], q[3:4], _joints(q[7:], ratios, False)])
    vp = _np.concatenate([R.T @ v[0:3], v[3:6], _joints(v[6:], ratios, False)])
    return qp, vp


def from_pinocchio(q, v, ratios=None):
    """Pinocchio's free-flyer (q, v) as spacearm's."""
    q, v = _state(q, v)
    R = _rotation(q[6], q[3], q[4], q[5])
    qs = _np.concatenate([q[0:3], q[6:7], q[3:6], _joints(q[7:], ratios, True)])
    vs = _np.concatenate([R @ v[0:3], v[3:6], _joints(v[6:], ratios, True)])
    return qs, vs


def to_spacedyn(q, v, base_com, ratios=None):
    """spacearm's (q, v) as SpaceDyn's: a dict of R0, Q0 (w x y z), q, v0, w0, qd."""
    q, v = _state(q, v)
    c = _np.asarray(base_com, dtype=float)
    R = _rotation(*q[3:7])
    w_world = R @ v[3:6]
    return {
        "R0": q[0:3] + R @ c,
        "Q0": q[3:7] / _np.linalg.norm(q[3:7]),
        "q": _joints(q[7:], ratios, False),
        "v0": v[0:3] + _np.cross(w_world, R @ c),
        "w0": w_world,
        "qd": _joints(v[6:], ratios, False),
    }


def from_spacedyn(state, base_com, ratios=None):
    """SpaceDyn's dict (R0, Q0 w x y z, q, v0, w0, qd) as spacearm's (q, v)."""
    c = _np.asarray(base_com, dtype=float)
    Q0 = _np.asarray(state["Q0"], dtype=float)
    R = _rotation(*Q0)
    w_world = _np.asarray(state["w0"], dtype=float)
    p_o = _np.asarray(state["R0"], dtype=float) - R @ c
    dp_o = _np.asarray(state["v0"], dtype=float) - _np.cross(w_world, R @ c)
    qj = _np.asarray(state["q"], dtype=float)
    qd = _np.asarray(state["qd"], dtype=float)
    return (
        _np.concatenate([p_o, Q0, _joints(qj, ratios, True)]),
        _np.concatenate([dp_o, R.T @ w_world, _joints(qd, ratios, True)]),
    )


def to_spart(q, v, base_com, ratios=None):
    """spacearm's (q, v) as SPART's: a dict of R0 (3x3), r0, qm, u0 ([omega body, dr0/dt]), um."""
    q, v = _state(q, v)
    c = _np.asarray(base_com, dtype=float)
    R = _rotation(*q[3:7])
    return {
        "R0": R,
        "r0": q[0:3] + R @ c,
        "qm": _joints(q[7:], ratios, False),
        "u0": _np.concatenate([v[3:6], v[0:3] + R @ _np.cross(v[3:6], c)]),
        "um": _joints(v[6:], ratios, False),
    }


def from_spart(state, base_com, ratios=None):
    """SPART's dict (R0, r0, qm, u0 = [omega body, dr0/dt], um) as spacearm's (q, v)."""
    c = _np.asarray(base_com, dtype=float)
    R = _np.asarray(state["R0"], dtype=float)
    u0 = _np.asarray(state["u0"], dtype=float)
    w_body = u0[0:3]
    p_o = _np.asarray(state["r0"], dtype=float) - R @ c
    dp_o = u0[3:6] - R @ _np.cross(w_body, c)
    qm = _np.asarray(state["qm"], dtype=float)
    um = _np.asarray(state["um"], dtype=float)
    return (
        _np.concatenate([p_o, _quaternion(R), _joints(qm, ratios, True)]),
        _np.concatenate([dp_o, w_body, _joints(um, ratios, True)]),
    )
