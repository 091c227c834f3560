"""The Motion container: slicing, time slices, resampling, joining, validation."""

from __future__ import annotations

import numpy as np
import pytest

from quadsim.kinematics.rotations import (
    matrices_from_quaternions,
    quaternion_slerp,
    quaternions_from_matrices,
)
from quadsim.skeleton import Motion, Skeleton, forward_kinematics

FPS = 30.0
T = 31  # one second exactly


@pytest.fixture
def skel():
    return Skeleton(
        names=("root", "spine", "head", "LF", "RF"),
        parents=np.array([-1, 0, 1, 0, 0]),
        offsets=np.array([[0, 1, 0], [0, 0, 1], [0, 1, 0], [1, 0, 0], [-1, 0, 0]], float),
    )


def random_motion(skel, rng, n=T, fps=FPS, **kw):
    """A motion with random (unit) rotations, root path, contacts, labels and an extra."""
    q = rng.normal(size=(n, skel.n_joints, 4))
    q /= np.linalg.norm(q, axis=-1, keepdims=True)
    args = {
        "contacts": rng.uniform(size=(n, 4)) < 0.5,
        "gaits": np.array(["walk"] * (n // 2) + ["trot"] * (n - n // 2)),
        "foot_joints": ("LF", "RF", "LF", "RF"),
        "extras": {"phase": rng.uniform(size=(n, 4))},
    }
    args.update(kw)
    return Motion(skel, fps, rng.normal(size=(n, 3)), q, **args)


def same_rotation(q0, q1, atol=1e-10):
    """Quaternions equal up to sign, element-wise over the batch."""
    np.testing.assert_allclose(np.abs(np.sum(q0 * q1, axis=-1)), 1.0, atol=atol)


# ------------------------------------------------------------------ basics
def test_basic_properties(skel):
    rng = np.random.default_rng(30)
    m = random_motion(skel, rng)
    assert len(m) == m.n_frames == T
    assert m.duration == pytest.approx(1.0)
    np.testing.assert_allclose(m.times, np.arange(T) / FPS)
    assert m.world_positions().shape == (T, 5, 3)
    assert m.foot_positions().shape == (T, 4, 3)
    _, P = forward_kinematics(skel, matrices_from_quaternions(m.rotations), m.root_positions)
    np.testing.assert_allclose(m.world_positions(), P, atol=1e-14)


def test_from_matrices_round_trip(skel):
    rng = np.random.default_rng(31)
    m = random_motion(skel, rng)
    m2 = Motion.from_matrices(skel, FPS, m.root_positions, m.local_matrices)
    same_rotation(m2.rotations, m.rotations)
    np.testing.assert_allclose(m2.world_positions(), m.world_positions(), atol=1e-12)


def test_rotations_are_normalised(skel):
    rng = np.random.default_rng(32)
    q = rng.normal(size=(5, 5, 4)) * 3.0
    m = Motion(skel, FPS, np.zeros((5, 3)), q)
    np.testing.assert_allclose(np.linalg.norm(m.rotations, axis=-1), 1.0, atol=1e-12)


# ----------------------------------------------------------------- slicing
def test_slice_keeps_frame_rate_and_every_array(skel):
    rng = np.random.default_rng(33)
    m = random_motion(skel, rng)
    s = m[5:12]
    assert len(s) == 7 and s.fps == FPS and s.skeleton is skel
    np.testing.assert_array_equal(s.root_positions, m.root_positions[5:12])
    np.testing.assert_array_equal(s.rotations, m.rotations[5:12])
    np.testing.assert_array_equal(s.contacts, m.contacts[5:12])
    assert list(s.gaits) == list(m.gaits[5:12])
    np.testing.assert_array_equal(s.extras["phase"], m.extras["phase"][5:12])
    assert s.foot_joints == m.foot_joints
    np.testing.assert_allclose(s.world_positions(), m.world_positions()[5:12], atol=1e-14)


def test_integer_index_gives_one_frame_motion(skel):
    rng = np.random.default_rng(34)
    m = random_motion(skel, rng)
    for i in (0, 3, -1, -2):
        one = m[i]
        assert len(one) == 1
        np.testing.assert_array_equal(one.root_positions[0], m.root_positions[i])
    assert m[np.int64(4)].rotations.shape == (1, 5, 4)


def test_step_slice_and_index_array(skel):
    rng = np.random.default_rng(35)
    m = random_motion(skel, rng)
    np.testing.assert_array_equal(m[::2].root_positions, m.root_positions[::2])
    idx = np.array([0, 7, 3])
    np.testing.assert_array_equal(m[idx].contacts, m.contacts[idx])


@pytest.mark.parametrize("start, stop, first, count", [
    (0.1, 0.5, 3, 12),       # t = 0.1 .. 0.4667: 0.5 itself is excluded
    (0.0, 1.0, 0, 30),       # the last frame (t = 1.0) is excluded
    (0.0, 2.0, 0, 31),       # past the end: everything
    (0.11, 0.13, 4, 0),      # no frame time falls inside
    (0.45, 0.5, 14, 1),
])
def test_time_slice_is_half_open(skel, start, stop, first, count):
    rng = np.random.default_rng(36)
    m = random_motion(skel, rng)
    s = m.time_slice(start, stop)
    assert len(s) == count
    if count:
        np.testing.assert_array_equal(s.root_positions, m.root_positions[first:first + count])
        times = m.times[first:first + count]
        assert np.all((times >= start - 1e-12) & (times < stop))


# --------------------------------------------------------------- resampling
def test_resample_to_half_rate_takes_every_other_frame(skel):
    rng = np.random.default_rng(37)
    m = random_motion(skel, rng)
    h = m.resample(FPS / 2)
    assert h.fps == FPS / 2 and len(h) == 16
    assert h.duration == pytest.approx(m.duration)
    np.testing.assert_allclose(h.root_positions, m.root_positions[::2], atol=1e-14)
    same_rotation(h.rotations, m.rotations[::2])
    np.testing.assert_allclose(h.world_positions(), m.world_positions()[::2], atol=1e-12)
    np.testing.assert_array_equal(h.contacts, m.contacts[::2])
    assert list(h.gaits) == list(m.gaits[::2])


def test_resample_to_double_rate_interpolates_between_frames(skel):
    """Shared times keep their values; new frames sit halfway (linear root, slerp rotations)."""
    rng = np.random.default_rng(38)
    m = random_motion(skel, rng)
    d = m.resample(2 * FPS)
    assert d.fps == 2 * FPS and len(d) == 2 * T - 1
    assert d.duration == pytest.approx(m.duration)
    np.testing.assert_allclose(d.root_positions[::2], m.root_positions, atol=1e-14)
    same_rotation(d.rotations[::2], m.rotations)
    np.testing.assert_allclose(d.world_positions()[::2], m.world_positions(), atol=1e-12)
    np.testing.assert_allclose(d.root_positions[1::2],
                               0.5 * (m.root_positions[:-1] + m.root_positions[1:]), atol=1e-14)
    mid = quaternion_slerp(m.rotations[:-1], m.rotations[1:], np.full((T - 1, 5), 0.5))
    same_rotation(d.rotations[1::2], mid)
    # in-between frames take the nearest earlier frame's labels
    np.testing.assert_array_equal(d.contacts[1::2], m.contacts[:-1])


def test_resample_to_an_unrelated_rate_keeps_duration(skel):
    rng = np.random.default_rng(39)
    m = random_motion(skel, rng, n=61, fps=60.0)   # 1.0 s
    r = m.resample(24.0)
    assert len(r) == 25 and r.duration == pytest.approx(1.0)
    np.testing.assert_allclose(r.root_positions[[0, -1]], m.root_positions[[0, -1]], atol=1e-12)
    # t = 1/24 s lies at old frame 2.5: halfway between frames 2 and 3
    np.testing.assert_allclose(r.root_positions[1],
                               0.5 * (m.root_positions[2] + m.root_positions[3]), atol=1e-12)


def test_resample_round_trip_through_a_multiple(skel):
    """Up to four times the rate and back down returns the original frames."""
    rng = np.random.default_rng(40)
    m = random_motion(skel, rng)
    back = m.resample(4 * FPS).resample(FPS)
    assert len(back) == T
    np.testing.assert_allclose(back.root_positions, m.root_positions, atol=1e-12)
    same_rotation(back.rotations, m.rotations)


def test_resample_rejects_bad_rate(skel):
    m = random_motion(skel, np.random.default_rng(41))
    for bad in (0.0, -30.0, float("nan")):
        with pytest.raises(ValueError, match="`fps` must be a positive number"):
            m.resample(bad)


# -------------------------------------------------------------- concatenate
def test_concatenate_joins_end_to_end(skel):
    rng = np.random.default_rng(42)
    a, b = random_motion(skel, rng, n=10), random_motion(skel, rng, n=7)
    c = Motion.concatenate([a, b])
    assert len(c) == 17 and c.fps == FPS
    np.testing.assert_array_equal(c.root_positions[:10], a.root_positions)
    np.testing.assert_array_equal(c.root_positions[10:], b.root_positions)
    np.testing.assert_array_equal(c.contacts[10:], b.contacts)
    assert list(c.gaits) == list(a.gaits) + list(b.gaits)
    np.testing.assert_array_equal(c.extras["phase"][:10], a.extras["phase"])
    np.testing.assert_allclose(c[10:].world_positions(), b.world_positions(), atol=1e-14)


def test_concatenate_drops_what_not_every_part_has(skel):
    rng = np.random.default_rng(43)
    a = random_motion(skel, rng, n=4)
    b = random_motion(skel, rng, n=4, contacts=None, extras={"other": np.zeros(4)})
    c = Motion.concatenate([a, b])
    assert c.contacts is None
    assert c.extras == {}
    assert c.gaits is not None


def test_concatenate_rejects_mismatch_and_empty(skel):
    rng = np.random.default_rng(44)
    a = random_motion(skel, rng, n=4)
    with pytest.raises(ValueError, match="share their skeleton and frame rate"):
        Motion.concatenate([a, random_motion(skel, rng, n=4, fps=60.0)])
    other = Skeleton(skel.names, skel.parents, skel.offsets)
    with pytest.raises(ValueError, match="share their skeleton and frame rate"):
        Motion.concatenate([a, random_motion(other, rng, n=4)])
    with pytest.raises(ValueError, match="nothing to concatenate"):
        Motion.concatenate([])


# --------------------------------------------------------------- validation
@pytest.mark.parametrize("change, message", [
    ({"rotations": np.zeros((6, 4, 4)) + [1, 0, 0, 0]},
     r"`rotations` has shape \(6, 4, 4\), expected \(T, 5, 4\)"),
    ({"rotations": np.zeros((6, 5, 3))}, r"`rotations` has shape \(6, 5, 3\)"),
    ({"root_positions": np.zeros((5, 3))},
     r"`root_positions` has shape \(5, 3\), expected \(6, 3\)"),
    ({"root_positions": np.zeros((6, 2))}, r"`root_positions` has shape \(6, 2\)"),
    ({"contacts": np.zeros((6, 3), bool)}, r"`contacts` has shape \(6, 3\), expected \(6, 4\)"),
    ({"gaits": np.array(["walk"] * 5)}, r"`gaits` has shape \(5,\), expected \(6,\)"),
    ({"extras": {"phase": np.zeros((5, 4))}}, r"extra 'phase' has shape \(5, 4\)"),
    ({"foot_joints": ("LF", "RF", "LF")}, r"`foot_joints` must name four joints"),
    ({"fps": 0.0}, r"`fps` must be a positive number"),
    ({"fps": float("inf")}, r"`fps` must be a positive number"),
])
def test_shape_and_value_validation(skel, change, message):
    args = {"skeleton": skel, "fps": FPS, "root_positions": np.zeros((6, 3)),
            "rotations": np.zeros((6, 5, 4)) + [1.0, 0, 0, 0]}
    args.update(change)
    with pytest.raises(ValueError, match=message):
        Motion(**args)


def test_unknown_foot_joint_is_rejected(skel):
    with pytest.raises(KeyError, match="no joint named 'LH'"):
        Motion(skel, FPS, np.zeros((2, 3)), np.zeros((2, 5, 4)) + [1.0, 0, 0, 0],
               foot_joints=("LF", "RF", "LH", "RH"))


def test_foot_positions_need_foot_joints(skel):
    m = random_motion(skel, np.random.default_rng(45), foot_joints=None)
    with pytest.raises(ValueError, match="does not name its foot joints"):
        m.foot_positions()


# ---------------------------------------------------------------- read-only
def test_arrays_are_read_only(skel):
    m = random_motion(skel, np.random.default_rng(46))
    arrays = [m.root_positions, m.rotations, m.contacts, m.gaits, m.extras["phase"],
              m.local_matrices, m.world_positions(), m.world_rotations()]
    for a in arrays:
        assert not a.flags.writeable
        with pytest.raises(ValueError, match="read-only"):
            a[0] = a[1]


def test_motion_copies_its_inputs(skel):
    rng = np.random.default_rng(47)
    root = rng.normal(size=(4, 3))
    q = quaternions_from_matrices(np.broadcast_to(np.eye(3), (4, 5, 3, 3)))
    extra = np.zeros(4)
    m = Motion(skel, FPS, root, q, extras={"x": extra})
    root[0, 0] = 99.0
    q[0, 0] = [0.0, 1.0, 0.0, 0.0]
    extra[0] = 5.0
    assert m.root_positions[0, 0] != 99.0
    np.testing.assert_array_equal(m.rotations[0, 0], [1.0, 0.0, 0.0, 0.0])
    assert m.extras["x"][0] == 0.0
