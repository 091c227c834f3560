"""The data-driven horse's legs move as smoothly as its clips, with the stance feet planted.

Every figure is measured on produced joint rotations and positions: the
largest per-frame rotation change of any joint (after a settling second) is
compared with the expanded clip's own for the same gait and speed, each
joint's peak angular acceleration with the clip's for that joint, and the
feet's slide and height above the ground during contacts found from the joint
positions (:func:`quadsim.analysis.metrics.foot_contacts`).
"""

import math
import warnings

import numpy as np
import pytest

from quadsim.analysis.metrics import (
    angular_acceleration,
    angular_velocity,
    foot_contacts,
    foot_slide,
)
from quadsim.horse.slope import Ground
from quadsim.horse.controller import HorseDataController
from quadsim.horse.legs import place_feet, two_bone
from quadsim.kinematics.chains import two_bone_row
from quadsim.kinematics.rotations import quaternions_from_matrices
from quadsim.commands import Command, Script
from quadsim.errors import QuadsimClampWarning
from quadsim.skeleton.fk import forward_kinematics
from quadsim.skeleton.motion import Motion

FPS = 60
SETTLE = 1.0            # s left out at the start
SECONDS = 5.0
#: A mid-range speed of every gait (m/s).
GAITS = (("walk", 1.5), ("amble", 3.2), ("trot", 4.0), ("rack", 4.2), ("canter", 6.0),
         ("gallop", 11.0))
TURN = 0.3              # rad/s
SLOPE = math.radians(8.0)
#: Acceleration allowance (rad/s^2) for joints the clip holds still (the body joints
#: leading a turn or a slope): a quarter degree per frame squared.
ACCEL_FLOOR = math.radians(0.25) * FPS ** 2


def _ground(ctl):
    """The controller's ground as a height field (the flat plane while it has no ramp)."""
    return ctl.ground if ctl.ground is not None else Ground()


def _run(horse, db, command, fps=FPS):
    """Step a controller for :data:`SECONDS` at ``fps``; rotations (T, J, 4), positions
    (T, J, 3), controller. ``command`` may be a :class:`Script`."""
    script = Script.constant(command) if isinstance(command, Command) else command
    ctl = HorseDataController(horse, db, dt=1 / fps)
    rot, pos = [], []
    with warnings.catch_warnings():
        warnings.simplefilter("error", QuadsimClampWarning)     # the turn must be allowed
        for i in range(int(round(SECONDS * fps))):
            out = ctl.step(script.command_at(i / fps))
            rot.append(quaternions_from_matrices(out.local_rotations))
            pos.append(out.positions)
    return np.array(rot), np.array(pos), ctl


def _clip_rates(clip):
    """The looped clip's peak per-frame rotation change (deg, any joint) and per-joint peak
    angular acceleration (J,) (rad/s^2)."""
    q = clip.motion.rotations
    q = np.concatenate([q, q[:3]])                   # across the loop's seam too
    fps = clip.motion.fps
    step = np.degrees(angular_velocity(q, fps) / fps).max()
    return step, angular_acceleration(q, fps).max(axis=0)


def _cases():
    for gait, speed in GAITS:
        yield pytest.param(gait, speed, None, 0.0, id=f"{gait}-{speed:g}-straight")
        yield pytest.param(gait, speed, TURN, 0.0, id=f"{gait}-{speed:g}-turning")
        yield pytest.param(gait, speed, None, SLOPE, id=f"{gait}-{speed:g}-slope8")


@pytest.mark.parametrize("gait, speed, turn, slope", list(_cases()))
def test_legs_as_smooth_as_the_clip_and_feet_planted(horse, db, gait, speed, turn, slope):
    rot, pos, ctl = _run(horse, db, Command(speed=speed, gait=gait, turn_rate=turn, slope=slope))
    assert ctl.clip_gait == gait and ctl.playing == "steady"
    clip = ctl.expanded(gait, speed)
    assert clip.motion.fps == FPS
    clip_step, clip_acc = _clip_rates(clip)
    k = int(SETTLE * FPS)
    step = np.degrees(angular_velocity(rot[k:], FPS) / FPS)          # (T, J) deg per frame
    acc = angular_acceleration(rot[k:], FPS).max(axis=0)             # (J,) rad/s^2
    names = horse.skeleton.names
    j = int(np.argmax(step.max(axis=0)))
    assert step.max() <= 1.25 * clip_step, (
        f"{names[j]} turns {step.max():.1f} deg in a frame, the clip at most {clip_step:.1f}")
    over = acc - (1.5 * clip_acc + ACCEL_FLOOR)
    j = int(np.argmax(over))
    assert over.max() <= 0.0, (
        f"{names[j]} accelerates at {acc[j]:.0f} rad/s^2, the clip at {clip_acc[j]:.0f}")
    # the stance feet: still and on the ground (contacts measured on the joints)
    feet = pos[k:, [leg.foot for leg in horse.legs]]
    above = feet[..., 1] - _ground(ctl).height(feet[..., [0, 2]])
    rel = np.array(feet)
    rel[..., 1] = above
    c = foot_contacts(rel, FPS)
    assert c.any(axis=0).all()
    # (a stance cut by the window's start is left out: its touchdown unseen, it may be
    # its lift-off frame alone, the joint already rising as the hoof breaks over)
    for leg in range(4):
        c[:np.argmin(c[:, leg]), leg] = False
    _, slide = foot_slide(feet, c)
    assert slide < 0.005, slide
    assert np.abs(above[c]).max() < 0.005


@pytest.mark.parametrize("gait, speed", [("trot", 4.0), ("canter", 6.0), ("gallop", 11.0)])
def test_between_the_clip_frames(horse, db, gait, speed):
    """At 50 frames a second the clip is played between its frames (60 a second): a foot
    the clip lifts between two frames is lifted, not held back at its plant."""
    rot, pos, ctl = _run(horse, db, Command(speed=speed, gait=gait), fps=50)
    clip_q = ctl.expanded(gait, speed).motion.rotations
    clip_q = np.concatenate([clip_q, clip_q[:3]])
    k = int(SETTLE * 50)
    # joint by joint, no faster than the clip (rad/s; 0.1 rad/s for joints the clip holds still)
    w = angular_velocity(rot[k:], 50).max(axis=0)
    w_clip = angular_velocity(clip_q, FPS).max(axis=0)
    j = int(np.argmax(w - 1.1 * w_clip))
    assert (w <= 1.1 * w_clip + 0.1).all(), (horse.skeleton.names[j], w[j], w_clip[j])
    acc = angular_acceleration(rot[k:], 50).max(axis=0)
    acc_clip = angular_acceleration(clip_q, FPS).max(axis=0)
    assert (acc <= 1.5 * acc_clip + ACCEL_FLOOR).all(), (acc.max(), acc_clip.max())


@pytest.mark.parametrize("gait, speed, slope_deg", [("canter", 6.0, -6.7), ("gallop", 11.0, -8.0)])
def test_from_a_descent_onto_the_level(horse, db, gait, speed, slope_deg):
    """The ground rising ahead of the body's plane (the level after a descent) neither snaps
    a swinging fore leg through straight nor stretches a planted one; feet stay planted."""
    script = Script((0.0, 2.0), (Command(speed=speed, gait=gait, slope=math.radians(slope_deg)),
                                 Command(speed=speed, gait=gait)))
    rot, pos, ctl = _run(horse, db, script)
    clip_step, clip_acc = _clip_rates(ctl.expanded(gait, speed))
    k = int(SETTLE * FPS)
    step = np.degrees(angular_velocity(rot[k:], FPS) / FPS)
    assert step.max() <= 1.25 * clip_step, (step.max(), clip_step)
    acc = angular_acceleration(rot[k:], FPS).max(axis=0)
    assert (acc <= 1.5 * clip_acc + ACCEL_FLOOR).all()
    feet = pos[k:, [leg.foot for leg in horse.legs]]
    above = feet[..., 1] - _ground(ctl).height(feet[..., [0, 2]])
    rel = np.array(feet)
    rel[..., 1] = above
    c = foot_contacts(rel, FPS)
    _, slide = foot_slide(feet, c)
    assert slide < 0.005 and np.abs(above[c]).max() < 0.005
    assert above.min() > -0.001                       # no hoof under the ground


def test_a_foot_lifts_off_as_the_clip_lifts_it(horse, db):
    """In a straight steady canter the legs replay the clip: a lifted foot is not held back."""
    rot, _, ctl = _run(horse, db, Command(speed=6.0, gait="canter"))
    q = ctl.clip.motion.rotations
    elbow = horse.skeleton.names.index("RF_elbow")
    k = int(SETTLE * FPS)
    got = np.degrees(angular_velocity(rot[k:, elbow:elbow + 1], FPS)).max() / FPS
    want = np.degrees(angular_velocity(np.concatenate([q, q[:1]])[:, elbow:elbow + 1],
                                       FPS)).max() / FPS
    assert got == pytest.approx(want, rel=0.02)


def test_one_two_bone_ik_for_clips_and_poses(horse, db):
    """The controller's compiled IK of one pose's legs gives exactly the clip editor's."""
    clip = HorseDataController(horse, db).expanded("trot", 4.0)
    m = clip.motion
    targets = m.foot_positions() + np.array([0.03, -0.02, 0.05])
    want = place_feet(horse, m, targets)
    skel = horse.skeleton
    feet = np.array([leg.foot for leg in horse.legs])
    pairs = (np.array([leg.chain[leg.ik_start] for leg in horse.legs]),
             np.array([leg.chain[leg.ik_start + 1] for leg in horse.legs]))
    one = Motion(skel, m.fps, m.root_positions[5:6], m.rotations[5:6])
    got = np.array(one.local_matrices[0])
    W, P = forward_kinematics(skel, got, m.root_positions[5])
    work = np.empty((4, 3, 3))
    for i, (top, mid) in enumerate(zip(*pairs)):
        two_bone_row(P[top], P[mid], P[feet[i]], W[skel.parents[top]], W[top], W[mid],
                     targets[5, i], got[top], got[mid], work)
    moved = Motion(skel, m.fps, m.root_positions[5:6], want[5:6]).local_matrices[0]
    np.testing.assert_allclose(got, moved, atol=1e-9)
    # and the feet reach their (reachable) targets
    _, P2 = forward_kinematics(skel, got, m.root_positions[5])
    np.testing.assert_allclose(P2[feet], targets[5], atol=1e-6)
    # any leading axes: (frames, legs) at once
    top, mid = pairs
    Wr, Wp = m.world_rotations()[:4], m.world_positions()[:4]
    Lt, Lm = two_bone(Wp[:, top], Wp[:, mid], Wp[:, feet], Wr[:, skel.parents[top]],
                      Wr[:, top], Wr[:, mid], targets[:4])
    assert Lt.shape == Lm.shape == (4, 4, 3, 3)
