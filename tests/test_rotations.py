"""Rotation conversions, checked against transforms3d.

Conventions under test: quaternions are ``(w, x, y, z)``; matrices act on
column vectors; ``matrices_from_euler(angles, "abc")`` is the intrinsic
product ``R_a(angles[0]) @ R_b(angles[1]) @ R_c(angles[2])``, which is
transforms3d's rotating-axes convention ``axes = "r" + "abc".lower()``.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from transforms3d import axangles, euler, quaternions

from quadsim.kinematics.rotations import (
    euler_from_matrices,
    matrices_about_axis,
    matrices_from_axis_angles,
    matrices_from_euler,
    matrices_from_quaternions,
    quaternion_multiply,
    quaternion_slerp,
    quaternions_from_matrices,
)

ORDERS = ["".join(p) for p in itertools.permutations("XYZ")]


def random_quaternions(rng, n):
    """``n`` uniformly random unit quaternions, shape (n, 4)."""
    q = rng.normal(size=(n, 4))
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def angle_between(q0, q1):
    """Rotation angle (rad) taking unit quaternion ``q0`` to ``q1``."""
    d = np.clip(np.abs(np.sum(q0 * q1, axis=-1)), 0.0, 1.0)
    return 2.0 * np.arccos(d)


# ------------------------------------------------------------- quaternions
def test_matrix_from_quaternion_matches_transforms3d():
    """Each matrix equals ``transforms3d.quaternions.quat2mat`` of the same (w, x, y, z)."""
    rng = np.random.default_rng(1)
    q = random_quaternions(rng, 50)
    R = matrices_from_quaternions(q)
    expected = np.array([quaternions.quat2mat(qi) for qi in q])
    np.testing.assert_allclose(R, expected, atol=1e-12)


def test_matrices_from_quaternions_are_rotations():
    """Orthonormal with determinant +1, also for non-unit input (normalised)."""
    rng = np.random.default_rng(2)
    q = random_quaternions(rng, 20) * rng.uniform(0.5, 3.0, size=(20, 1))
    R = matrices_from_quaternions(q)
    np.testing.assert_allclose(R @ np.swapaxes(R, -1, -2), np.broadcast_to(np.eye(3), R.shape),
                               atol=1e-12)
    np.testing.assert_allclose(np.linalg.det(R), 1.0, atol=1e-12)


def test_quaternion_from_matrix_matches_transforms3d():
    """Same rotation as ``mat2quat``, with the scalar part non-negative."""
    rng = np.random.default_rng(3)
    q = random_quaternions(rng, 50)
    R = np.array([quaternions.quat2mat(qi) for qi in q])
    got = quaternions_from_matrices(R)
    expected = np.array([quaternions.mat2quat(Ri) for Ri in R])
    expected = np.where(expected[:, :1] < 0, -expected, expected)
    assert np.all(got[:, 0] >= 0)
    np.testing.assert_allclose(got, expected, atol=1e-10)


@pytest.mark.parametrize("axis", [[1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 0], [1, -2, 3]])
def test_quaternion_from_matrix_near_half_turn(axis):
    """Rotations by pi (w = 0) and just under pi take the other branches and still round-trip."""
    for angle in (np.pi, np.pi - 1e-7, 2.5):
        R = axangles.axangle2mat(axis, angle)
        q = quaternions_from_matrices(R)
        np.testing.assert_allclose(np.linalg.norm(q), 1.0, atol=1e-12)
        np.testing.assert_allclose(matrices_from_quaternions(q), R, atol=1e-12)


def test_quaternion_matrix_round_trip():
    """quaternion -> matrix -> quaternion returns the input up to sign."""
    rng = np.random.default_rng(4)
    q = random_quaternions(rng, 200)
    back = quaternions_from_matrices(matrices_from_quaternions(q))
    sign = np.sign(np.sum(q * back, axis=-1, keepdims=True))
    np.testing.assert_allclose(back * sign, q, atol=1e-12)


def test_quaternion_multiply_matches_transforms3d_and_matrix_product():
    """Hamilton product equals ``qmult`` and composes like the matrices do."""
    rng = np.random.default_rng(5)
    a, b = random_quaternions(rng, 30), random_quaternions(rng, 30)
    ab = quaternion_multiply(a, b)
    np.testing.assert_allclose(ab, [quaternions.qmult(x, y) for x, y in zip(a, b)], atol=1e-12)
    np.testing.assert_allclose(matrices_from_quaternions(ab),
                               matrices_from_quaternions(a) @ matrices_from_quaternions(b),
                               atol=1e-12)


# --------------------------------------------------------------- axis-angle
@pytest.mark.parametrize("axis", [0, 1, 2])
def test_matrices_about_axis_are_right_handed(axis):
    """A quarter turn about X takes Y to Z, about Y takes Z to X, about Z takes X to Y."""
    R = matrices_about_axis(axis, np.pi / 2)
    e = np.eye(3)
    np.testing.assert_allclose(R @ e[(axis + 1) % 3], e[(axis + 2) % 3], atol=1e-15)
    rng = np.random.default_rng(6)
    angles = rng.uniform(-np.pi, np.pi, size=7)
    np.testing.assert_allclose(matrices_about_axis(axis, angles),
                               [axangles.axangle2mat(e[axis], a) for a in angles], atol=1e-12)


def test_matrices_from_axis_angles_matches_transforms3d():
    """Rodrigues' formula equals ``axangle2mat`` for random, unnormalised axes."""
    rng = np.random.default_rng(7)
    axes = rng.normal(size=(40, 3)) * 3.0
    angles = rng.uniform(-2 * np.pi, 2 * np.pi, size=40)
    R = matrices_from_axis_angles(axes, angles)
    np.testing.assert_allclose(R, [axangles.axangle2mat(k, a) for k, a in zip(axes, angles)],
                               atol=1e-12)


def test_zero_axis_gives_identity():
    np.testing.assert_array_equal(matrices_from_axis_angles([0.0, 0.0, 0.0], 1.3), np.eye(3))


# --------------------------------------------------------------------- Euler
@pytest.mark.parametrize("order", ORDERS)
def test_matrices_from_euler_is_transforms3d_rotating_axes(order):
    """Our intrinsic order "abc" is transforms3d's "rabc" with the angles in the same order."""
    rng = np.random.default_rng(8)
    angles = rng.uniform(-np.pi, np.pi, size=(25, 3))
    angles[:, 1] /= 2.0
    R = matrices_from_euler(angles, order)
    expected = [euler.euler2mat(*a, axes="r" + order.lower()) for a in angles]
    np.testing.assert_allclose(R, expected, atol=1e-12)


@pytest.mark.parametrize("order", ORDERS)
def test_matrices_from_euler_is_product_of_axis_rotations(order):
    """The definition written out: R = R_a(alpha) @ R_b(beta) @ R_c(gamma)."""
    rng = np.random.default_rng(9)
    alpha, beta, gamma = rng.uniform(-3, 3, size=3)
    ax = ["XYZ".index(c) for c in order]
    expected = (matrices_about_axis(ax[0], alpha) @ matrices_about_axis(ax[1], beta)
                @ matrices_about_axis(ax[2], gamma))
    np.testing.assert_allclose(matrices_from_euler([alpha, beta, gamma], order), expected,
                               atol=1e-14)


@pytest.mark.parametrize("order", ORDERS)
def test_euler_from_matrices_matches_transforms3d(order):
    """Away from gimbal lock the angles are unique and equal ``mat2euler``'s."""
    rng = np.random.default_rng(10)
    angles = rng.uniform(-np.pi, np.pi, size=(50, 3))
    angles[:, 1] = rng.uniform(-1.4, 1.4, size=50)
    R = matrices_from_euler(angles, order)
    got = euler_from_matrices(R, order)
    expected = [euler.mat2euler(Ri, axes="r" + order.lower()) for Ri in R]
    np.testing.assert_allclose(got, expected, atol=1e-10)
    np.testing.assert_allclose(got, angles, atol=1e-10)


@pytest.mark.parametrize("order", ORDERS)
def test_euler_round_trip_from_random_rotations(order):
    """matrix -> angles -> matrix is exact for any rotation; the middle angle lies in
    [-pi/2, pi/2]."""
    rng = np.random.default_rng(11)
    R = matrices_from_quaternions(random_quaternions(rng, 200))
    angles = euler_from_matrices(R, order)
    assert np.all(np.abs(angles[:, 1]) <= np.pi / 2 + 1e-12)
    np.testing.assert_allclose(matrices_from_euler(angles, order), R, atol=1e-12)


@pytest.mark.parametrize("order", ORDERS)
@pytest.mark.parametrize("distance", [0.0, 1e-12, 1e-9, 1e-7, 1e-6, 1e-4])
@pytest.mark.parametrize("side", [1.0, -1.0])
def test_euler_round_trip_at_and_near_gimbal_lock(order, distance, side):
    """At and near a middle angle of +-90 degrees the matrix still round-trips to 1e-12."""
    angles = np.array([0.7, side * (np.pi / 2 - distance), -0.4])
    R = matrices_from_euler(angles, order)
    back = euler_from_matrices(R, order)
    np.testing.assert_allclose(matrices_from_euler(back, order), R, atol=1e-12)
    assert np.all(np.isfinite(back))


def test_euler_rejects_repeated_axes():
    with pytest.raises(ValueError, match="three distinct axes"):
        euler_from_matrices(np.eye(3), "XYX")


# --------------------------------------------------------------------- slerp
def test_slerp_endpoints():
    """t = 0 gives q0 and t = 1 gives q1 (as a rotation: up to sign)."""
    rng = np.random.default_rng(12)
    q0, q1 = random_quaternions(rng, 40), random_quaternions(rng, 40)
    np.testing.assert_allclose(quaternion_slerp(q0, q1, np.zeros(40)), q0, atol=1e-12)
    end = quaternion_slerp(q0, q1, np.ones(40))
    np.testing.assert_allclose(matrices_from_quaternions(end), matrices_from_quaternions(q1),
                               atol=1e-12)


def test_slerp_midpoint_halves_the_angle():
    """The midpoint is half the shortest-path angle from each end."""
    rng = np.random.default_rng(13)
    q0, q1 = random_quaternions(rng, 40), random_quaternions(rng, 40)
    mid = quaternion_slerp(q0, q1, np.full(40, 0.5))
    total = angle_between(q0, q1)
    np.testing.assert_allclose(angle_between(q0, mid), total / 2, atol=1e-9)
    np.testing.assert_allclose(angle_between(mid, q1), total / 2, atol=1e-9)
    assert np.all(total <= np.pi + 1e-12)


def test_slerp_matches_axis_angle_construction():
    """slerp(q0, q1, t) = q0 * exp(t log(q0^-1 q1)), built with transforms3d."""
    rng = np.random.default_rng(14)
    for _ in range(20):
        q0, q1 = random_quaternions(rng, 2)
        t = rng.uniform(0, 1)
        rel = quaternions.qmult(quaternions.qinverse(q0), q1)
        if rel[0] < 0:
            rel = -rel
        axis, angle = quaternions.quat2axangle(rel)
        expected = quaternions.qmult(q0, quaternions.axangle2quat(axis, t * angle))
        np.testing.assert_allclose(quaternion_slerp(q0, q1, t), expected, atol=1e-10)


def test_slerp_takes_the_short_way_and_handles_equal_inputs():
    """q1 and -q1 give the same path; q0 == q1 gives q0 without NaN."""
    rng = np.random.default_rng(15)
    q0, q1 = random_quaternions(rng, 2)
    t = np.linspace(0, 1, 11)
    a = quaternion_slerp(q0, q1, t)
    b = quaternion_slerp(q0, -q1, t)
    np.testing.assert_allclose(a, b, atol=1e-12)
    same = quaternion_slerp(q0, q0, t)
    np.testing.assert_allclose(same, np.broadcast_to(q0, same.shape), atol=1e-12)


# --------------------------------------------------------------------- batch
def test_batch_results_equal_single_item_results():
    """Every conversion gives the same answer on a (4, 5, ...) batch as item by item."""
    rng = np.random.default_rng(16)
    q = random_quaternions(rng, 20).reshape(4, 5, 4)
    q2 = random_quaternions(rng, 20).reshape(4, 5, 4)
    t = rng.uniform(size=(4, 5))
    R = matrices_from_quaternions(q)
    ang = euler_from_matrices(R, "ZXY")
    qb = quaternions_from_matrices(R)
    sl = quaternion_slerp(q, q2, t)
    mul = quaternion_multiply(q, q2)
    assert R.shape == (4, 5, 3, 3) and ang.shape == (4, 5, 3) and qb.shape == (4, 5, 4)
    for i in range(4):
        for j in range(5):
            np.testing.assert_allclose(R[i, j], matrices_from_quaternions(q[i, j]), atol=1e-15)
            np.testing.assert_allclose(qb[i, j], quaternions_from_matrices(R[i, j]), atol=1e-15)
            np.testing.assert_allclose(ang[i, j], euler_from_matrices(R[i, j], "ZXY"),
                                       atol=1e-15)
            np.testing.assert_allclose(sl[i, j], quaternion_slerp(q[i, j], q2[i, j], t[i, j]),
                                       atol=1e-15)
            np.testing.assert_allclose(mul[i, j], quaternion_multiply(q[i, j], q2[i, j]),
                                       atol=1e-15)
    np.testing.assert_allclose(matrices_from_euler(ang, "ZXY"), R, atol=1e-12)
