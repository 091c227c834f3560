"""Structure from the skeleton, and what a viewer sees measured from joint positions."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

import quadsim
from quadsim.analysis.appearance import (
    appearance_report,
    spine_flexion,
    toe_positions,
    trunk_pitch,
)
from quadsim.frames import GRAVITY
from quadsim.skeleton.anatomy import find_anatomy
from quadsim.skeleton.skeleton import Skeleton

CHARACTERS = ("leopard", "leopard_cub", "dog_cub", "horse")


def _anonymous(skeleton: Skeleton) -> Skeleton:
    """The same tree with meaningless joint names (a BVH of unknown naming)."""
    names = tuple(f"j{j:02d}" for j in range(skeleton.n_joints))
    ends = {names[skeleton.names.index(k)]: v for k, v in skeleton.end_sites.items()}
    return Skeleton(names, skeleton.parents, skeleton.offsets, ends)


@pytest.mark.parametrize("cid", CHARACTERS)
def test_anatomy_is_found_from_the_tree_and_rest_pose_alone(cid):
    ch = quadsim.load_character(cid)
    sk = ch.skeleton
    a = find_anatomy(_anonymous(sk))
    assert [sk.names[f] for f in a.feet] == list(ch.foot_joints)
    for leg, spec in zip(a.legs, ch.legs):
        assert leg[0] == spec.top and leg[-1] == spec.foot
    assert sk.names[a.pelvis] == "pelvis" and sk.names[a.head] == "head"
    assert a.withers == sk.parents[ch.legs[0].top]
    assert a.pelvis in a.spine and a.withers in a.spine and a.mid_spine in a.spine[1:-1]
    assert a.hip_height == pytest.approx(ch.hip_height, rel=1e-9)


def test_a_skeleton_with_three_legs_is_not_a_quadruped():
    sk = quadsim.load_character("leopard").skeleton
    drop = [j for j, n in enumerate(sk.names) if n.startswith("RH_")]
    keep = [j for j in range(sk.n_joints) if j not in drop]
    remap = {j: k for k, j in enumerate(keep)}
    three = Skeleton(tuple(sk.names[j] for j in keep),
                     [-1 if sk.parents[j] < 0 else remap[int(sk.parents[j])] for j in keep],
                     sk.offsets[keep], {k: v for k, v in sk.end_sites.items()
                                        if not k.startswith("RH_")})
    with pytest.raises(ValueError, match="needs four legs ending in feet near the ground at rest; this one has 3"):
        find_anatomy(three)


def test_trunk_pitch_and_spine_flexion_of_known_poses():
    a = find_anatomy(quadsim.load_character("leopard").skeleton)
    J = len(a.names)
    P = np.zeros((3, J, 3))
    # frame 0: the trunk raised 20 deg at the withers, straight;
    # frame 1: level girdles, the mid-spine dropped so the chords meet at 30 deg
    # (the back sags: extension, negative); frame 2: raised as far (it arches)
    P[0, a.pelvis] = [0, 0.5, 0]
    P[0, a.withers] = [0, 0.5 + math.sin(math.radians(20)), math.cos(math.radians(20))]
    P[0, a.mid_spine] = 0.5 * (P[0, a.pelvis] + P[0, a.withers])
    P[1, a.pelvis] = [0, 0.5, 0]
    P[1, a.withers] = [0, 0.5, 1.0]
    P[1, a.mid_spine] = [0, 0.5 - 0.5 * math.tan(math.radians(15)), 0.5]
    P[2] = P[1]
    P[2, a.mid_spine] = [0, 0.5 + 0.5 * math.tan(math.radians(15)), 0.5]
    np.testing.assert_allclose(np.degrees(trunk_pitch(P, a)), [20.0, 0.0, 0.0], atol=1e-9)
    np.testing.assert_allclose(np.degrees(spine_flexion(P, a)), [0.0, -30.0, 30.0], atol=1e-9)


def test_toe_tips_are_the_feet_end_sites_in_the_world():
    m = quadsim.run("leopard", gait="walk", seconds=0.5)
    a = find_anatomy(m.skeleton, m.foot_joints)
    toes = toe_positions(m, a)
    G = m.world_rotations()[:, list(a.feet)]
    feet = m.foot_positions()
    for i, name in enumerate(m.foot_joints):
        want = feet[:, i] + G[:, i] @ m.skeleton.end_sites[name]
        np.testing.assert_allclose(toes[:, i], want, atol=1e-12)


@pytest.fixture(scope="module")
def gallop():
    return quadsim.run("horse", gait="transverse_gallop", seconds=8)


def test_a_gallop_report_measures_strides_trunk_contacts_and_joints(gallop):
    r = appearance_report(gallop, start=2.0)
    assert r["strides"] >= 8
    assert 0 < r["stride_over_h"] < 10 and r["alexander_over_h"] > 0 and r["cadence"] > 0
    assert r["flights"] >= 8 and len(r["flight_accel_g"]) == r["flights"]
    assert r["peak_joint_speed_deg_s"] > 100
    assert 0.0 <= r["locked_swing_fraction"] <= 1.0
    assert r["toe_slide_mm_p90"] >= 0 and r["touchdown_speed_ratio_p90"] > 0


@pytest.mark.parametrize("cid,joints", [
    ("leopard", {"LF_elbow", "RF_elbow", "LH_knee", "RH_knee"}),
    ("horse", {"LF_elbow", "RF_elbow", "LH_stifle", "RH_stifle"})])
def test_the_elbows_and_knees_are_found_from_the_bones_lengths(cid, joints):
    """Of each leg's hinges, the one between its two longest bones is its elbow or
    knee (a horse's is its stifle), found from the skeleton alone."""
    from quadsim.analysis.appearance import _elbows_knees, _hinges

    m = quadsim.run(cid, gait="walk", seconds=0.5)
    a = find_anatomy(m.skeleton, m.foot_joints)
    hinges = _hinges(m, a)
    assert {a.names[hinges[k][2]] for k in _elbows_knees(m, hinges)} == joints


def test_a_straightened_elbow_is_counted_locked(gallop):
    """Turn the left fore elbow so that the forearm lies along the upper arm in
    every frame: the elbows-and-knees figure sees it locked straight in every swing
    frame (and in none before)."""
    a = find_anatomy(gallop.skeleton, gallop.foot_joints)
    chain = a.legs[0]
    elbow = chain[list(a.names[j] for j in chain).index("LF_elbow")]
    child = chain[chain.index(elbow) + 1]
    off = gallop.skeleton.offsets
    u = off[child] / np.linalg.norm(off[child])   # the forearm, in the elbow's frame
    v = off[elbow] / np.linalg.norm(off[elbow])   # the upper arm, in its parent's
    axis = np.cross(u, v)
    half = 0.5 * math.acos(float(np.clip(u @ v, -1.0, 1.0)))
    q = gallop.rotations.copy()
    q[:, elbow] = np.concatenate([[math.cos(half)], axis / np.linalg.norm(axis) * math.sin(half)])
    straight = type(gallop)(gallop.skeleton, gallop.fps, gallop.root_positions, q,
                            foot_joints=gallop.foot_joints)
    assert appearance_report(gallop, start=2.0)["elbow_knee_locked_fraction"] < 0.05
    r = appearance_report(straight, start=2.0, anatomy=a)
    assert r["elbow_knee_locked_fraction"] == 1.0 and r["elbow_knee_locked_joint"] == "LF_elbow"


def test_flight_acceleration_sees_a_ballistic_fall(gallop):
    """Lift the whole body along a parabola of -g in each flight phase: the measured
    flight acceleration drops by one g, whatever the motion did before."""
    r0 = appearance_report(gallop, start=2.0)
    root = np.array(gallop.root_positions)
    fps = gallop.fps
    from quadsim.skeleton.contacts import foot_contacts

    air = ~foot_contacts(gallop.contact_points(), fps).any(axis=1)  # as the report finds them
    m = np.concatenate([[False], air, [False]]).astype(np.int8)
    starts, ends = np.flatnonzero(np.diff(m) == 1), np.flatnonzero(np.diff(m) == -1)
    for s, e in zip(starts, ends):
        t = np.arange(s, e) / fps
        t0, t1 = (s - 1) / fps, e / fps
        root[s:e, 1] += 0.5 * GRAVITY * (t - t0) * (t1 - t)
    lifted = replace(gallop, root_positions=root)
    r1 = appearance_report(lifted, start=2.0)
    assert r1["flights"] == r0["flights"]
    np.testing.assert_allclose(np.array(r1["flight_accel_g"]) - r0["flight_accel_g"], -1.0,
                               atol=0.02)


def test_a_foot_dropped_onto_the_ground_is_seen_descending(gallop):
    """Lift the whole body 10 cm on the flight frame before each landing: the
    landing foot now falls 10 cm more in its last frame, which the descent
    ratio sees and the ground speed ratio does not (a vertical drop, not a
    skid). The p90 is taken over every touchdown, a quarter of them after a
    flight, so it is at least the drop's own ``0.1 fps / body speed`` (0.46;
    unlifted 0.27). (Lifted 4 cm, it rose by 0.07 of the drop's 0.18: the
    landings after a flight already held the largest unlifted descents.)"""
    from quadsim.skeleton.contacts import foot_contacts

    r0 = appearance_report(gallop, start=2.0)
    fps = gallop.fps
    con = foot_contacts(gallop.foot_positions(), fps)
    air = ~con.any(axis=1)
    before_landing = np.flatnonzero(air[:-1] & ~air[1:])
    root = np.array(gallop.root_positions)
    root[before_landing, 1] += 0.1
    r1 = appearance_report(replace(gallop, root_positions=root), start=2.0)
    speed = np.linalg.norm(np.diff(root[:, [0, 2]], axis=0), axis=1).max() * fps
    assert len(before_landing) >= 8
    drop = 0.1 * fps / speed
    assert drop > r0["touchdown_descent_ratio_p90"]
    assert r1["touchdown_descent_ratio_p90"] >= drop
    assert r1["touchdown_speed_ratio_p90"] == pytest.approx(r0["touchdown_speed_ratio_p90"])


def test_quadsim_metrics_reports_what_a_viewer_sees_from_a_bvh(gallop, tmp_path, capsys):
    """The same figures from the written file as from the motion in memory."""
    import json

    from quadsim.cli import main

    path = quadsim.save(gallop, tmp_path / "gallop.bvh")
    capsys.readouterr()
    assert main(["metrics", str(path), "--json", "--start", "2"]) == 0
    got = json.loads(capsys.readouterr().out)["appearance"]
    want = appearance_report(gallop, start=2.0)
    for key in ("strides", "flights"):
        assert got[key] == want[key]
    for key in ("stride_over_h", "cadence", "trunk_pitch_range_deg", "spine_flexion_range_deg",
                "toe_slide_mm_p90"):
        assert got[key] == pytest.approx(want[key], rel=1e-3, abs=1e-3), key
    assert main(["metrics", str(path), "--start", "2"]) == 0
    assert "what a viewer sees" in capsys.readouterr().out


@pytest.mark.parametrize("n", [3, 4, 7, 30])
def test_the_flight_fit_is_the_least_squares_parabola(n):
    """The flight's curvature is numpy's least-squares quadratic fit, found in closed
    form: a parabola of -g/2 comes back exactly, noise as polyfit sees it."""
    from quadsim.analysis.appearance_kernels import quadratic_coefficient

    fps = 60.0
    t = np.arange(n) / fps
    rng = np.random.default_rng(n)
    y = 0.3 + 1.5 * t - 0.5 * 9.81 * t * t
    assert quadratic_coefficient(y, fps) == pytest.approx(-0.5 * 9.81, rel=1e-9)
    noisy = y + rng.normal(scale=0.01, size=n)
    assert quadratic_coefficient(noisy, fps) == pytest.approx(
        np.polyfit(t - t.mean(), noisy, 2)[0], rel=1e-9, abs=1e-9)


def test_the_trunk_jolt_is_the_girdles_largest_vertical_acceleration():
    """A trunk carried smoothly shows its own acceleration; one lowered 5 cm in a
    single frame shows the step's second difference, ``0.05 fps^2 / g`` (18 g at
    60 fps), both measured from the joint positions. Carried level with its pose
    held, the trunk does not jolt at all."""
    m = quadsim.run("horse", gait="walk", seconds=4)
    fps = m.fps
    a = find_anatomy(m.skeleton, m.foot_joints)
    T = len(m.root_positions)
    root = np.array(m.root_positions)
    flat = root.copy()
    flat[:, 1] = root[0, 1]
    # a level, still trunk: a pose held in every frame
    q = np.repeat(m.rotations[:1], T, axis=0)
    still = replace(m, root_positions=flat, rotations=q)
    assert appearance_report(still, anatomy=a)["trunk_jolt_g"] == pytest.approx(0.0, abs=1e-9)
    # bobbing as a sine of 2 cm at 2 Hz: its peak acceleration (2 pi 2)^2 0.02 / g
    t = np.arange(T) / fps
    bob = flat.copy()
    bob[:, 1] += 0.02 * np.sin(2 * np.pi * 2.0 * t)
    want = (2 * np.pi * 2.0) ** 2 * 0.02 / GRAVITY
    got = appearance_report(replace(still, root_positions=bob), anatomy=a)["trunk_jolt_g"]
    assert got == pytest.approx(want, rel=0.02)
    # the same trunk dropped 5 cm from one frame to the next
    step = bob.copy()
    step[T // 2:, 1] -= 0.05
    got = appearance_report(replace(still, root_positions=step), anatomy=a)["trunk_jolt_g"]
    assert got >= 0.05 * fps * fps / GRAVITY - want


ANGLES = ("fore_touchdown_angle_deg", "fore_liftoff_angle_deg", "hind_touchdown_angle_deg",
          "hind_liftoff_angle_deg")


def test_the_legs_land_ahead_of_their_tops_and_leave_behind_them(gallop):
    """In a gallop every leg's line from its top joint to its toe tip leans forward
    on the first frame of a stance and back on the last (the planted foot stays while
    the top travels on with the trunk), by less than a right angle."""
    r = appearance_report(gallop, start=2.0)
    for pair in ("fore", "hind"):
        assert 0.0 < r[f"{pair}_touchdown_angle_deg"] < 90.0
        assert -90.0 < r[f"{pair}_liftoff_angle_deg"] < 0.0


def test_the_legs_angles_are_measured_along_the_trunk_not_a_world_axis(gallop):
    """Turn the whole motion a quarter turn about the vertical: it now runs along
    another world axis, and the legs' angles are the same."""
    from quadsim.kinematics.rotations import quaternion_multiply

    half = math.pi / 4.0
    yaw = np.array([math.cos(half), 0.0, math.sin(half), 0.0])  # (w, x, y, z)
    c, s = math.cos(2 * half), math.sin(2 * half)
    root = np.array(gallop.root_positions)
    turned_root = root.copy()
    turned_root[:, 0] = c * root[:, 0] + s * root[:, 2]
    turned_root[:, 2] = -s * root[:, 0] + c * root[:, 2]
    q = np.array(gallop.rotations)
    q[:, 0] = quaternion_multiply(np.broadcast_to(yaw, q[:, 0].shape), q[:, 0])
    turned = replace(gallop, root_positions=turned_root, rotations=q)
    P0, P1 = gallop.world_positions(), turned.world_positions()
    assert np.abs(P1[..., 0] - P0[..., 0]).max() > 1.0  # it does run elsewhere
    r0, r1 = appearance_report(gallop, start=2.0), appearance_report(turned, start=2.0)
    for k in ANGLES:
        assert r1[k] == pytest.approx(r0[k], abs=1e-6), k


def test_played_backwards_a_touchdown_is_the_lift_off_it_was(gallop):
    """Reverse the frames: each contact's first frame is its last before, with the
    same pose and the trunk facing the same way, so the touchdown angles are the
    lift-off angles of the motion played forwards and the other way round."""
    def motion(root, q):
        return type(gallop)(gallop.skeleton, gallop.fps, root, q,
                            foot_joints=gallop.foot_joints)

    root, q = np.array(gallop.root_positions), np.array(gallop.rotations)
    back = motion(root[::-1], q[::-1])
    k = int(2.0 * gallop.fps)  # what the reversed motion's first 2 s leave out
    fwd = appearance_report(motion(root[:len(root) - k], q[:len(q) - k]))
    rev = appearance_report(back, start=2.0)
    for pair in ("fore", "hind"):
        assert rev[f"{pair}_touchdown_angle_deg"] == pytest.approx(
            fwd[f"{pair}_liftoff_angle_deg"], abs=1.0)
        assert rev[f"{pair}_liftoff_angle_deg"] == pytest.approx(
            fwd[f"{pair}_touchdown_angle_deg"], abs=1.0)
