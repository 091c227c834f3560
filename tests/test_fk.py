"""Forward kinematics and the Skeleton's validation.

The hand-written skeleton used throughout (offsets in metres, +Y up, +Z
forward, +X left)::

    root  (rest position (0, 1, 0))
    +-- spine  offset (0, 0, 1)
    |   +-- head   offset (0, 1, 0), end site (0, 0, 0.5)
    +-- leg    offset (1, 0, 0)
        +-- foot   offset (0, -1, 0)
"""

from __future__ import annotations

import numpy as np
import pytest

from quadsim.kinematics.rotations import matrices_about_axis, matrices_from_quaternions
from quadsim.skeleton import Skeleton, forward_kinematics
from quadsim.skeleton.fk import end_site_positions

X, Y, Z = 0, 1, 2
ROOT, SPINE, HEAD, LEG, FOOT = range(5)


@pytest.fixture
def skel():
    return Skeleton(
        names=("root", "spine", "head", "leg", "foot"),
        parents=np.array([-1, 0, 1, 0, 3]),
        offsets=np.array([[0, 1, 0], [0, 0, 1], [0, 1, 0], [1, 0, 0], [0, -1, 0]], float),
        end_sites={"head": [0.0, 0.0, 0.5]},
    )


def identity(J, batch=()):
    return np.broadcast_to(np.eye(3), batch + (J, 3, 3)).copy()


def random_rotations(rng, shape):
    q = rng.normal(size=shape + (4,))
    return matrices_from_quaternions(q)


# ------------------------------------------------------------ exact positions
def test_rest_positions_add_up_the_offsets(skel):
    expected = [[0, 1, 0], [0, 1, 1], [0, 2, 1], [1, 1, 0], [1, 0, 0]]
    np.testing.assert_array_equal(skel.rest_positions, expected)
    _, P = forward_kinematics(skel, identity(5), [0, 1, 0])
    np.testing.assert_array_equal(P, expected)


def test_quarter_turns_at_root_and_spine(skel):
    """Root turned 90 deg about +Y (Z -> X, X -> -Z), spine 90 deg about +X (Y -> Z).

    By hand, with the root at (2, 0, 3):
    spine = root + Ry (0,0,1) = (3, 0, 3); head = spine + Ry Rx (0,1,0) = (4, 0, 3);
    leg = root + Ry (1,0,0) = (2, 0, 2); foot = leg + Ry (0,-1,0) = (2, -1, 2);
    head end site = head + Ry Rx (0, 0, 0.5) = (4, -0.5, 3).
    """
    L = identity(5)
    L[ROOT] = matrices_about_axis(Y, np.pi / 2)
    L[SPINE] = matrices_about_axis(X, np.pi / 2)
    G, P = forward_kinematics(skel, L, [2.0, 0.0, 3.0])
    expected = [[2, 0, 3], [3, 0, 3], [4, 0, 3], [2, 0, 2], [2, -1, 2]]
    np.testing.assert_allclose(P, expected, atol=1e-15)
    np.testing.assert_allclose(G[HEAD], L[ROOT] @ L[SPINE], atol=1e-15)
    np.testing.assert_allclose(G[FOOT], L[ROOT], atol=1e-15)
    ends = end_site_positions(skel, G, P)
    np.testing.assert_allclose(ends["head"], [4.0, -0.5, 3.0], atol=1e-15)


def test_rotation_of_one_branch_leaves_the_other_alone(skel):
    """Leg turned -90 deg about +Z (-Y -> -X): the foot swings in to (0, 1, 0), the spine
    branch stays put."""
    L = identity(5)
    L[LEG] = matrices_about_axis(Z, -np.pi / 2)
    G, P = forward_kinematics(skel, L, [0.0, 1.0, 0.0])
    np.testing.assert_allclose(P[FOOT], [0.0, 1.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(P[[ROOT, SPINE, HEAD, LEG]], skel.rest_positions[[0, 1, 2, 3]],
                               atol=1e-15)
    np.testing.assert_allclose(G[FOOT], L[LEG], atol=1e-15)


def test_a_joints_own_rotation_moves_only_its_children(skel):
    """Rotating the head (a leaf) changes its orientation and end site, not its position."""
    L = identity(5)
    L[HEAD] = matrices_about_axis(Y, np.pi / 2)
    G, P = forward_kinematics(skel, L, [0.0, 1.0, 0.0])
    np.testing.assert_allclose(P, skel.rest_positions, atol=1e-15)
    np.testing.assert_allclose(end_site_positions(skel, G, P)["head"], [0.5, 2.0, 1.0],
                               atol=1e-15)


def test_bone_lengths_are_kept_under_any_rotation(skel):
    rng = np.random.default_rng(20)
    L = random_rotations(rng, (10, 5))
    _, P = forward_kinematics(skel, L, rng.normal(size=(10, 3)))
    lengths = np.linalg.norm(P[:, 1:] - P[:, skel.parents[1:]], axis=-1)
    np.testing.assert_allclose(lengths, np.broadcast_to(
        np.linalg.norm(skel.offsets[1:], axis=-1), lengths.shape), atol=1e-12)


# ------------------------------------------------------------------- batches
def test_batch_over_frames_equals_frame_by_frame(skel):
    rng = np.random.default_rng(21)
    T = 7
    L = random_rotations(rng, (T, 5))
    root = rng.normal(size=(T, 3))
    G, P = forward_kinematics(skel, L, root)
    assert G.shape == (T, 5, 3, 3) and P.shape == (T, 5, 3)
    for t in range(T):
        Gt, Pt = forward_kinematics(skel, L[t], root[t])
        np.testing.assert_allclose(G[t], Gt, atol=1e-14)
        np.testing.assert_allclose(P[t], Pt, atol=1e-14)


def test_two_batch_dimensions_and_broadcast_root(skel):
    """(characters, frames) batches work, and one pose broadcasts against many root positions."""
    rng = np.random.default_rng(22)
    L = random_rotations(rng, (3, 4, 5))
    _, P = forward_kinematics(skel, L, rng.normal(size=(3, 4, 3)))
    assert P.shape == (3, 4, 5, 3)
    pose = random_rotations(rng, (5,))
    roots = rng.normal(size=(6, 3))
    _, Pb = forward_kinematics(skel, pose, roots)
    assert Pb.shape == (6, 5, 3)
    _, P0 = forward_kinematics(skel, pose, roots[0])
    np.testing.assert_allclose(Pb[0], P0, atol=1e-14)


def test_root_translation_shifts_every_joint(skel):
    rng = np.random.default_rng(23)
    L = random_rotations(rng, (5,))
    r = rng.normal(size=3)
    d = np.array([0.5, -2.0, 3.25])
    G1, P1 = forward_kinematics(skel, L, r)
    G2, P2 = forward_kinematics(skel, L, r + d)
    np.testing.assert_allclose(P2 - P1, np.broadcast_to(d, P1.shape), atol=1e-14)
    np.testing.assert_array_equal(G1, G2)
    np.testing.assert_allclose(P2[ROOT], r + d)


def test_fk_rejects_wrong_rotation_shape(skel):
    with pytest.raises(ValueError, match=r"`local_rotations` has shape \(4, 3, 3\), "
                                         r"expected \(\.\.\., 5, 3, 3\)"):
        forward_kinematics(skel, identity(4), [0, 0, 0])


# ------------------------------------------------------------ the Skeleton
def test_skeleton_arrays_are_read_only_copies():
    parents = np.array([-1, 0])
    offsets = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    s = Skeleton(("a", "b"), parents, offsets)
    offsets[1, 2] = 5.0
    assert s.offsets[1, 2] == 1.0
    with pytest.raises(ValueError, match="read-only"):
        s.offsets[0, 0] = 1.0
    with pytest.raises(ValueError, match="read-only"):
        s.parents[1] = 0
    with pytest.raises(ValueError, match="read-only"):
        s.rest_positions[0, 0] = 1.0


def test_skeleton_lookups(skel):
    assert skel.n_joints == 5
    assert skel.index("foot") == FOOT
    np.testing.assert_array_equal(skel.indices(["leg", "root"]), [LEG, ROOT])
    assert skel.children[ROOT] == (SPINE, LEG)
    assert skel.chain("head", "root") == ["root", "spine", "head"]
    assert [lvl.tolist() for lvl in skel.depth_levels] == [[0], [1, 3], [2, 4]]
    with pytest.raises(KeyError, match="no joint named 'tail'"):
        skel.index("tail")
    with pytest.raises(ValueError, match="'head' is not below 'leg'"):
        skel.chain("head", "leg")


def test_scaled_skeleton_scales_positions(skel):
    big = skel.scaled(2.5)
    np.testing.assert_allclose(big.rest_positions, 2.5 * skel.rest_positions)
    np.testing.assert_allclose(big.end_sites["head"], [0.0, 0.0, 1.25])


OFF3 = np.zeros((3, 3))


@pytest.mark.parametrize("names, parents, offsets, message", [
    (("a", "b", "c"), [-1, 2, 0], OFF3,
     r"parent must come before it \(parents\[j\] < j\); out of order: b"),
    (("a", "b", "c"), [-1, 0, 3], OFF3, r"out of order: c"),
    (("a", "b", "a"), [-1, 0, 1], OFF3, r"joint names must be unique; repeated: a"),
    (("a", "b", "c"), [-1, 0], OFF3, r"`parents` has shape \(2,\), expected \(3,\)"),
    (("a", "b", "c"), [-1, 0, 1], np.zeros((3, 2)),
     r"`offsets` has shape \(3, 2\), expected \(3, 3\)"),
    (("a", "b", "c"), [-1, 0, 1], np.zeros(9), r"`offsets` has shape \(9,\)"),
    (("a", "b", "c"), [0, 0, 1], OFF3, r"joint 0 must be the root \(parent -1\)"),
    ((), [], np.zeros((0, 3)), r"at least one joint"),
])
def test_skeleton_validation(names, parents, offsets, message):
    with pytest.raises(ValueError, match=message):
        Skeleton(names, np.array(parents), offsets)


def test_skeleton_rejects_end_site_of_unknown_joint():
    with pytest.raises(ValueError, match="end site given for unknown joint 'tip'"):
        Skeleton(("a",), [-1], np.zeros((1, 3)), {"tip": [0, 0, 1]})
