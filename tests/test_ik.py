"""Leg inverse kinematics, checked through forward kinematics.

Specification (DESIGN.md, "Foot paths, turning and IK"): for every shipped
character and every leg, a reachable target is reached exactly, the two-bone
pair bends the right way (knee or stifle forward, elbow back), and an
unreachable target gives a finite pose and reports how far off it is.

Every check poses the whole skeleton with
:func:`quadsim.skeleton.fk.forward_kinematics`: all joints at rest except the
leg's chain (the solved local rotations) and, in the tilted cases, the leg's
parent joint (a random rotation of up to 20 degrees; its ancestors stay at
rest, so that is also its world rotation).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from quadsim import list_characters, load_character
from quadsim.frames import FORWARD, LEGS, UP
from quadsim.kinematics.ik import leg_geometry, solve_leg
from quadsim.kinematics.rotations import matrices_from_axis_angles
from quadsim.skeleton.fk import forward_kinematics

CASES = [(c, leg) for c in list_characters() for leg in LEGS]
IDS = [f"{c}-{leg}" for c, leg in CASES]
N_TARGETS = 500


def test_every_character_is_covered():
    assert {"leopard", "leopard_cub", "dog_cub", "horse"} <= set(list_characters())


# ------------------------------------------------------------------ helpers
def setup(name, leg_name):
    ch = load_character(name)
    leg = ch.legs[LEGS.index(leg_name)]
    return ch, leg, leg_geometry(ch, leg)


def pose(ch, geom, local, parent_rot=None):
    """World joint positions (..., J, 3) with the leg's chain set to ``local``."""
    sk = ch.skeleton
    batch = local.shape[:-3]
    L = np.broadcast_to(np.eye(3), batch + (sk.n_joints, 3, 3)).copy()
    if parent_rot is not None:
        L[..., geom.parent, :, :] = parent_rot
    L[..., geom.chain, :, :] = local
    _, P = forward_kinematics(sk, L, sk.offsets[0])
    return P


def random_tilts(rng, n, max_deg=20.0):
    axis = rng.normal(size=(n, 3))
    return matrices_from_axis_angles(axis, np.radians(max_deg) * rng.uniform(0, 1, n))


def reachable_targets(rng, ch, geom, parent_rot):
    """``N_TARGETS`` targets around the rest foot that the solver reports reached."""
    rest = ch.skeleton.rest_positions
    foot = rest[geom.chain[-1]]
    n = 4 * N_TARGETS
    box = ch.hip_height * np.array([0.3, 0.35, 0.5])
    targets = foot + rng.uniform(-1, 1, (n, 3)) * box
    R = np.broadcast_to(parent_rot, (n, 3, 3))
    _, reached = solve_leg(geom, R, rest[geom.parent], targets)
    ok = np.flatnonzero(reached == 0)
    assert len(ok) >= N_TARGETS, f"only {len(ok)} of {n} sampled targets are reachable"
    ok = ok[:N_TARGETS]
    return targets[ok], R[ok]


# ------------------------------------------------------------------ rest pose
@pytest.mark.parametrize("name, leg_name", CASES, ids=IDS)
def test_rest_foot_gives_the_rest_pose(name, leg_name):
    ch, leg, geom = setup(name, leg_name)
    rest = ch.skeleton.rest_positions
    local, reached = solve_leg(geom, np.eye(3), rest[geom.parent], rest[leg.foot])
    assert reached == 0
    np.testing.assert_allclose(local, np.broadcast_to(np.eye(3), local.shape), atol=1e-9)
    P = pose(ch, geom, local)
    np.testing.assert_allclose(P[leg.foot], rest[leg.foot], atol=1e-9)


# ------------------------------------------------------------- reachable
@pytest.mark.parametrize("tilted", [False, True], ids=["rest-parent", "tilted-parent"])
@pytest.mark.parametrize("name, leg_name", CASES, ids=IDS)
def test_reachable_targets_are_reached_exactly(name, leg_name, tilted):
    rng = np.random.default_rng(10 + 2 * CASES.index((name, leg_name)) + tilted)
    ch, leg, geom = setup(name, leg_name)
    Rp = random_tilts(rng, 1)[0] if tilted else np.eye(3)
    targets, R = reachable_targets(rng, ch, geom, Rp)
    local, reached = solve_leg(geom, R, ch.skeleton.rest_positions[geom.parent], targets)
    assert np.all(reached == 0)
    # local rotations are proper rotations
    np.testing.assert_allclose(local @ np.swapaxes(local, -1, -2),
                               np.broadcast_to(np.eye(3), local.shape), atol=1e-12)
    P = pose(ch, geom, local, R if tilted else None)
    err = np.linalg.norm(P[:, leg.foot] - targets, axis=-1)
    assert err.max() < 1e-9, f"worst miss {err.max():.2e} m"


@pytest.mark.parametrize("name, leg_name", CASES, ids=IDS)
def test_tilted_parents_one_each_are_reached_exactly(name, leg_name):
    """Each target with its own random parent rotation (up to 20 degrees)."""
    rng = np.random.default_rng(100 + CASES.index((name, leg_name)))
    ch, leg, geom = setup(name, leg_name)
    rest = ch.skeleton.rest_positions
    n = 4 * N_TARGETS
    R = random_tilts(rng, n)
    targets = rest[leg.foot] + rng.uniform(-1, 1, (n, 3)) * ch.hip_height * np.array(
        [0.3, 0.35, 0.5])
    local, reached = solve_leg(geom, R, rest[geom.parent], targets)
    ok = reached == 0
    assert ok.sum() >= N_TARGETS
    P = pose(ch, geom, local[ok], R[ok])
    err = np.linalg.norm(P[:, leg.foot] - targets[ok], axis=-1)
    assert err.max() < 1e-9, f"worst miss {err.max():.2e} m"


@pytest.mark.parametrize("name, leg_name", CASES, ids=IDS)
def test_middle_joint_bends_the_right_way(name, leg_name):
    """Knee or stifle forward of the line from the pair's top joint to its lower
    joint, elbow behind it -- measured in the leg plane against the body's
    forward axis, for every reachable target under a tilted parent."""
    rng = np.random.default_rng(200 + CASES.index((name, leg_name)))
    ch, leg, geom = setup(name, leg_name)
    rest = ch.skeleton.rest_positions
    Rp = random_tilts(rng, 1)[0]
    targets, R = reachable_targets(rng, ch, geom, Rp)
    local, _ = solve_leg(geom, R, rest[geom.parent], targets)
    P = pose(ch, geom, local, R)
    k = leg.ik_start
    top, mid, low = (P[:, leg.chain[k + i]] for i in range(3))
    line = (low - top) / np.linalg.norm(low - top, axis=-1, keepdims=True)

    def across(v):  # the part of v perpendicular to the line
        return v - np.sum(v * line, axis=-1, keepdims=True) * line

    fwd = across(R @ FORWARD)  # body forward, in the leg plane across the line
    assert np.linalg.norm(fwd, axis=-1).min() > 1e-3
    side = np.sum(across(mid - top) * fwd, axis=-1)
    expected = +1.0 if leg_name.endswith("H") else -1.0  # hind: knee forward; fore: elbow back
    assert np.all(expected * side > 0), (
        f"{np.sum(expected * side <= 0)} of {len(side)} poses bend the wrong way")
    # the rest pose bends the same way (the character file agrees)
    assert leg.bend == expected


# ------------------------------------------------------------ unreachable
def true_miss(ch, leg, geom, targets, parent_rot=None):
    rest = ch.skeleton.rest_positions
    R = np.eye(3) if parent_rot is None else parent_rot
    local, reached = solve_leg(geom, R, rest[geom.parent], targets)
    assert np.all(np.isfinite(local)) and np.all(np.isfinite(reached))
    P = pose(ch, geom, local, parent_rot)
    return reached, np.linalg.norm(P[..., leg.foot, :] - targets, axis=-1)


@pytest.mark.parametrize("name, leg_name", CASES, ids=IDS)
def test_unreachable_targets_below_report_the_true_miss(name, leg_name):
    """Far targets in the half-space below the top joint (in the parent's frame),
    with and without a parent tilt: no NaN, and ``reached`` is the real
    foot-target distance."""
    rng = np.random.default_rng(300 + CASES.index((name, leg_name)))
    ch, leg, geom = setup(name, leg_name)
    rest = ch.skeleton.rest_positions
    n = 500
    d = rng.normal(size=(n, 3))
    d[:, 1] = -np.abs(d[:, 1])
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    d *= ch.hip_height * rng.uniform(3, 10, (n, 1))
    for R in (np.broadcast_to(np.eye(3), (n, 3, 3)), random_tilts(rng, n)):
        top = rest[geom.parent] + R @ geom.top_offset
        targets = top + np.einsum("nij,nj->ni", R, d)
        reached, miss = true_miss(ch, leg, geom, targets, R)
        assert reached.min() > 0.5 * ch.hip_height
        np.testing.assert_allclose(reached, miss, rtol=0, atol=1e-9)


@pytest.mark.parametrize("name, leg_name", CASES, ids=IDS)
def test_degenerate_targets_straight_up_and_at_the_top_joint(name, leg_name):
    ch, leg, geom = setup(name, leg_name)
    top = ch.skeleton.rest_positions[leg.top]
    targets = np.stack([top + 5 * ch.hip_height * UP, top + 0.5 * ch.hip_height * UP,
                        top.copy()])
    reached, miss = true_miss(ch, leg, geom, targets)
    assert reached[0] > 3 * ch.hip_height
    np.testing.assert_allclose(reached, miss, rtol=0, atol=1e-9)


@pytest.mark.parametrize("name, leg_name", CASES, ids=IDS)
def test_unreachable_targets_in_any_direction_give_a_finite_pose(name, leg_name):
    rng = np.random.default_rng(400 + CASES.index((name, leg_name)))
    ch, leg, geom = setup(name, leg_name)
    top = ch.skeleton.rest_positions[leg.top]
    d = rng.normal(size=(500, 3))
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    targets = top + d * ch.hip_height * rng.uniform(3, 10, (500, 1))
    _, miss = true_miss(ch, leg, geom, targets, random_tilts(rng, 500))
    assert np.all(miss > 0.5 * ch.hip_height)


@pytest.mark.parametrize("name, leg_name", [("horse", "LF"), ("leopard", "RH")],
                         ids=["horse-LF", "leopard-RH"])
def test_unreachable_targets_above_and_aside_report_the_true_miss(name, leg_name):
    ch, leg, geom = setup(name, leg_name)
    top = ch.skeleton.rest_positions[leg.top]
    h = ch.hip_height
    targets = top + h * np.array([[0.5, 3.0, 0.0], [-0.5, 3.0, 0.0], [2.0, 1.0, 1.0],
                                  [-3.0, 0.2, -2.0]])
    reached, miss = true_miss(ch, leg, geom, targets)
    np.testing.assert_allclose(reached, miss, rtol=0, atol=1e-9)


# ------------------------------------------------------------------ batch
@pytest.mark.parametrize("name, leg_name", CASES, ids=IDS)
def test_batch_equals_one_by_one(name, leg_name):
    rng = np.random.default_rng(500 + CASES.index((name, leg_name)))
    ch, leg, geom = setup(name, leg_name)
    rest = ch.skeleton.rest_positions
    n = 100
    R = random_tilts(rng, n)
    pos = rest[geom.parent] + rng.normal(scale=0.01, size=(n, 3))
    targets = rest[leg.foot] + rng.uniform(-1, 1, (n, 3)) * ch.hip_height * 0.6
    fold = rng.uniform(0, 1, n)
    toe = rng.uniform(-0.5, 0.5, n)
    local, reached = solve_leg(geom, R, pos, targets, fold, toe)
    assert local.shape == (n, len(geom.chain), 3, 3) and reached.shape == (n,)
    for i in range(n):
        li, ri = solve_leg(geom, R[i], pos[i], targets[i], fold[i], toe[i])
        np.testing.assert_allclose(li, local[i], rtol=0, atol=1e-12)
        np.testing.assert_allclose(ri, reached[i], rtol=0, atol=1e-12)


@pytest.mark.parametrize("name, leg_name", CASES, ids=IDS)
def test_fold_and_toe_pitch_keep_the_foot_on_target(name, leg_name):
    """The swing fold and toe pitch reshape the leg but not where its foot joint is;
    a digit that tucks up in swing (the horse's fore pasterns, below a cannon the
    carpus folds back: ``digit_flex_deg``) is drawn folded further, the fetlock left
    where the pair put it and the foot carried with the digit."""
    rng = np.random.default_rng(600 + CASES.index((name, leg_name)))
    ch, leg, geom = setup(name, leg_name)
    rest = ch.skeleton.rest_positions
    targets, R = reachable_targets(rng, ch, geom, np.eye(3))
    fold = rng.uniform(0, 1, len(targets))
    toe = rng.uniform(-0.5, 0.5, len(targets))
    flat = replace(geom, carry=np.zeros_like(geom.carry), foot_carry=0.0)
    local, reached = solve_leg(flat, R, rest[geom.parent], targets, fold, toe)
    ok = reached == 0
    assert ok.mean() > 0.8
    P = pose(ch, geom, local[ok])
    np.testing.assert_allclose(P[:, leg.foot], targets[ok], rtol=0, atol=1e-9)
    drawn, _ = solve_leg(geom, R, rest[geom.parent], targets, fold, toe)
    Q = pose(ch, geom, drawn[ok])
    # the horse's fore legs: a digit below a cannon its carpus folds back
    tucks = name == "horse" and leg_name in ("LF", "RF")
    assert geom.carry.any() == tucks
    if tucks:
        fetlock = leg.chain[leg.ik_start + 3]
        np.testing.assert_allclose(Q[:, fetlock], P[:, fetlock], rtol=0, atol=1e-9)
        carried = np.linalg.norm(Q[:, leg.foot] - P[:, leg.foot], axis=-1)
        assert carried.max() > 0.05 and carried[fold[ok] < 1e-3].max(initial=0.0) < 1e-6
    else:
        np.testing.assert_allclose(Q, P, rtol=0, atol=1e-12)


# ------------------------------------------------------------------ what a viewer sees
@pytest.mark.parametrize("name, leg_name", CASES, ids=IDS)
@pytest.mark.parametrize("pitch_deg", [-15.0, 15.0])
def test_a_pitched_trunk_leaves_the_planted_foot_level(name, leg_name, pitch_deg):
    """A trunk pitched nose up or down does not tip the foot: with no toe pitch the
    foot bone's end (the toe tip) stands level with its joint in the world, as at
    rest. (World down was once read from the wrong axis of the parent's frame,
    and every pitched trunk tipped paws and hooves by twice its pitch.)"""
    ch, leg, geom = setup(name, leg_name)
    rest = ch.skeleton.rest_positions
    R = matrices_from_axis_angles(np.array([1.0, 0.0, 0.0]), np.radians(pitch_deg))
    top = rest[geom.parent] + R @ geom.top_offset
    target = rest[leg.foot] + (top - (rest[geom.parent] + geom.top_offset))  # below the top
    local, reached = solve_leg(geom, R, rest[geom.parent], target)
    assert reached == 0.0
    sk = ch.skeleton
    L = np.broadcast_to(np.eye(3), (sk.n_joints, 3, 3)).copy()
    L[geom.parent] = R
    L[geom.chain] = local
    G, P = forward_kinematics(sk, L, sk.offsets[0])
    end = G[leg.foot] @ sk.end_sites[sk.names[leg.foot]]
    G0, _ = forward_kinematics(sk, np.broadcast_to(np.eye(3), L.shape), sk.offsets[0])
    end0 = G0[leg.foot] @ sk.end_sites[sk.names[leg.foot]]
    np.testing.assert_allclose(P[leg.foot], target, atol=1e-9)
    np.testing.assert_allclose(end[1], end0[1], atol=1e-9)


@pytest.mark.parametrize("name, leg_name", CASES, ids=IDS)
def test_the_pair_keeps_a_bend_for_targets_out_of_reach(name, leg_name):
    """Straight below the top joint and far out of reach, the elbow or knee still
    bends by at least 5 degrees (it never locks straight), and the miss is
    reported."""
    ch, leg, geom = setup(name, leg_name)
    rest = ch.skeleton.rest_positions
    top = rest[geom.parent] + geom.top_offset
    targets = top + np.array([0.0, -3.0, 0.0]) * ch.hip_height * np.linspace(1, 2, 5)[:, None]
    reached, miss = true_miss(ch, leg, geom, targets)
    assert (reached > 0).all()
    local, _ = solve_leg(geom, np.eye(3), rest[geom.parent], targets)
    P = pose(ch, geom, local)
    k = geom.pair
    a, b, c = (P[:, geom.chain[k + d]] for d in range(3))
    u, w = a - b, c - b
    inner = np.degrees(np.arccos(np.einsum("ni,ni->n", u, w)
                                 / np.linalg.norm(u, axis=1) / np.linalg.norm(w, axis=1)))
    assert inner.max() <= 175.0, inner
