"""spacearm.states: a free base's state in Pinocchio's, SpaceDyn's and SPART's conventions. Each
pair round-trips to 1e-14, and each converted quantity means what its tool says: the centre of
mass's velocity is the time derivative of its position, found by moving spacearm's state a
small step along its own velocity (central differences), and Pinocchio's linear velocity is the
world one seen from the base."""
import numpy as np
import pytest

from spacearm import states

COM = np.array([0.12, -0.05, 0.3])
RATIOS = np.array([100.0, 1.0, 50.0])


def random_state(rng):
    quat = rng.normal(size=4)
    q = np.concatenate([rng.uniform(-2, 2, 3), quat / np.linalg.norm(quat), rng.uniform(-3, 3, 3)])
    v = rng.uniform(-1, 1, 9)
    return q, v


def moved(q, v, h):
    """spacearm's state after h along its velocity: p += h dp, the quaternion turned by omega
    (base frame) over h, the joints by their rates."""
    w = v[3:6]
    angle = np.linalg.norm(w) * h
    axis = w / np.linalg.norm(w)
    dq = np.concatenate([[np.cos(angle / 2)], np.sin(angle / 2) * axis])
    a, b = q[3:7], dq
    turned = np.array(
        [
            a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
            a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
            a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
            a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
        ]
    )
    return np.concatenate([q[0:3] + h * v[0:3], turned, q[7:] + h * v[6:]])


@pytest.mark.parametrize("seed", range(5))
def test_round_trips(seed):
    q, v = random_state(np.random.default_rng(seed))
    for ratios in (None, RATIOS):
        qp, vp = states.to_pinocchio(q, v, ratios)
        q2, v2 = states.from_pinocchio(qp, vp, ratios)
        assert np.max(np.abs(q2 - q)) < 1e-14 and np.max(np.abs(v2 - v)) < 1e-14
        q2, v2 = states.from_spacedyn(states.to_spacedyn(q, v, COM, ratios), COM, ratios)
        assert np.max(np.abs(q2 - q)) < 1e-14 and np.max(np.abs(v2 - v)) < 1e-14
        q2, v2 = states.from_spart(states.to_spart(q, v, COM, ratios), COM, ratios)
        sign = 1 if q[3] >= 0 else -1  # SPART keeps a matrix: the quaternion comes back w >= 0
        assert np.max(np.abs(q2[3:7] - sign * q[3:7])) < 1e-14
        q2[3:7] = q[3:7]
        assert np.max(np.abs(q2 - q)) < 1e-14 and np.max(np.abs(v2 - v)) < 1e-14


def test_meanings():
    q, v = random_state(np.random.default_rng(7))
    h = 1e-6
    ahead, behind = moved(q, v, h), moved(q, v, -h)
    sd = states.to_spacedyn(q, v, COM, RATIOS)
    rate = (states.to_spacedyn(ahead, v, COM)["R0"] - states.to_spacedyn(behind, v, COM)["R0"]) / (
        2 * h
    )
    assert np.max(np.abs(rate - sd["v0"])) < 1e-8
    spart = states.to_spart(q, v, COM, RATIOS)
    assert np.max(np.abs(spart["u0"][3:6] - sd["v0"])) < 1e-14
    assert np.max(np.abs(spart["R0"] @ spart["u0"][0:3] - sd["w0"])) < 1e-14
    assert np.max(np.abs(sd["q"] - q[7:] / RATIOS)) < 1e-15  # link angles
    qp, vp = states.to_pinocchio(q, v)
    R = spart["R0"]
    assert np.max(np.abs(R @ vp[0:3] - v[0:3])) < 1e-14
    assert list(qp[3:7]) == list(q[4:7]) + [q[3]]  # x y z w


def test_bad_sizes_are_named():
    with pytest.raises(ValueError, match="q of size 7 \\+ N and v of size 6 \\+ N, got 7 and 5"):
        states.to_pinocchio(np.zeros(7), np.zeros(5))
    with pytest.raises(ValueError, match="ratios: expected 3 values, got 2"):
        states.to_pinocchio(np.r_[0, 0, 0, 1, 0, 0, 0, 1, 2, 3], np.zeros(9), [1, 2])
