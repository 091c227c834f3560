"""Turning, slopes, the leap and standing still in the data-driven horse, measured on its joints.

Every figure is taken from the produced joint positions: the heading from the
hip joints, contacts from the feet's height above the ground and their speed,
slide from the feet's horizontal travel during those contacts.
"""

import math

import numpy as np
import pytest

from quadsim.analysis.metrics import angular_acceleration, foot_contacts, foot_slide
from quadsim.config import parse_config
from quadsim.errors import InputError
from quadsim.horse.controller import HorseDataController
from quadsim.horse.slope import Ground
from quadsim.kinematics.rotations import quaternions_from_matrices
from quadsim.commands import Command, Script
from quadsim.skeleton.motion import Motion

FPS = 60


def _ground(ctl):
    """The controller's ground as a height field (the flat plane while it has no ramp)."""
    return ctl.ground if ctl.ground is not None else Ground()


def _run(horse, db, script, seconds, rotations=None):
    """Step a controller; world joint positions (T, J, 3), labels, controller.

    ``rotations``, a list, receives each frame's local rotations (J, 4).
    """
    if isinstance(script, Command):
        script = Script.constant(script)
    ctl = HorseDataController(horse, db, dt=1 / FPS)
    pos, labels = [], []
    for i in range(int(round(seconds * FPS))):
        out = ctl.step(script.command_at(i / FPS))
        pos.append(out.positions)
        labels.append(out.gait)
        if rotations is not None:
            rotations.append(quaternions_from_matrices(out.local_rotations))
    return np.array(pos), labels, ctl


def _feet(horse, P):
    return P[:, [leg.foot for leg in horse.legs]]


def _measure(horse, P, ground):
    """Feet (T, 4, 3), their height above the ground (T, 4) and measured contacts (T, 4)."""
    feet = _feet(horse, P)
    above = feet[..., 1] - ground.height(feet[..., [0, 2]])
    rel = np.array(feet)
    rel[..., 1] = above
    return feet, above, foot_contacts(rel, FPS)


def _heading(horse, P):
    """The pelvis's heading (rad) from its two hip joints (T,)."""
    names = horse.skeleton.names
    left = P[:, names.index("LH_hip")] - P[:, names.index("RH_hip")]
    return np.arctan2(-left[:, 2], left[:, 0])


def _cycle_mean(x, n):
    """Moving mean over ``n`` frames (one stride: removes the gait's own sway), (T - n + 1,)."""
    c = np.concatenate([[0.0], np.cumsum(x)])
    return (c[n:] - c[:-n]) / n


def _yaw(P, a, b):
    d = P[:, b] - P[:, a]
    return np.arctan2(d[:, 0], d[:, 2])


def _wrap(x):
    return (np.asarray(x) + np.pi) % (2 * np.pi) - np.pi


def _ok_feet(horse, P, ground, skip=FPS):
    feet, above, c = _measure(horse, P, ground)
    _, slide = foot_slide(feet[skip:], c[skip:])
    assert c[skip:].any(axis=0).all()
    err = np.abs(above[skip:][c[skip:]]).max()
    # no joint below the ground
    under = (P[..., 1] - ground.height(P[..., [0, 2]])).min()
    return slide, err, under


# ------------------------------------------------------------------ turning
@pytest.mark.parametrize("speed,rate_deg", [(1.5, 15.0), (3.5, 30.0), (6.0, -40.0), (11.0, 25.0)])
def test_heading_follows_the_turn_rate(horse, db, speed, rate_deg):
    rate = math.radians(rate_deg)
    t0, t1 = 1.5, 4.5
    script = Script((0.0, t0, t1), (Command(speed=speed), Command(speed=speed, turn_rate=rate),
                                    Command(speed=speed)))
    P, labels, ctl = _run(horse, db, script, 7.0)
    L = ctl.clip.frames                              # one stride, in frames at 60 fps
    t = np.arange(len(P)) / FPS
    want = rate * np.clip(t - t0, 0.0, t1 - t0)
    psi = _cycle_mean(np.unwrap(_heading(horse, P)), L)
    psi = psi - psi[int(t0 * FPS) - L]               # a lead gait's sway is not symmetric
    want = _cycle_mean(want, L)
    err = np.abs(psi - want)
    assert err.max() < math.radians(3.0), math.degrees(err.max())
    assert err[-FPS:].max() < math.radians(0.5), math.degrees(err[-FPS:].max())
    # the body travels the way it faces (over whole strides, after the turn)
    r = P[:, 0]
    k = np.arange(int(t1 * FPS) + FPS // 2, len(P) - L, 5)
    d = r[k + L] - r[k]
    travel = np.arctan2(d[:, 0], d[:, 2])
    assert np.abs(_wrap(travel - want[-1])).max() < math.radians(2.0), np.degrees(travel)
    slide, ground_err, under = _ok_feet(horse, P, _ground(ctl))
    assert slide < 0.005, slide
    assert ground_err < 0.005 and under > -0.001, (ground_err, under)


def test_heading_command_is_reached(horse, db):
    P, _, ctl = _run(horse, db, Command(speed=6.0, heading=math.radians(-70.0)), 5.0)
    psi = _cycle_mean(np.unwrap(_heading(horse, P)), ctl.clip.frames)
    assert abs(math.degrees(psi[-1]) + 70.0) < 0.5, math.degrees(psi[-1])
    assert np.all(np.diff(psi) <= 1e-9)          # turns right only, no overshoot
    slide, ground_err, _ = _ok_feet(horse, P, _ground(ctl))
    assert slide < 0.005 and ground_err < 0.005


def test_head_turns_first_and_most(horse, db):
    rate = math.radians(30.0)
    script = Script((0.0, 1.5), (Command(speed=3.5), Command(speed=3.5, turn_rate=rate)))
    P, _, ctl = _run(horse, db, script, 4.0)
    L = ctl.clip.frames                              # one stride: the sway repeats
    n = horse.skeleton.names
    pelvis = np.unwrap(_heading(horse, P))
    back = np.unwrap(_yaw(P, n.index("spine2"), n.index("spine4")))
    neck = np.unwrap(_yaw(P, n.index("neck1"), n.index("neck3")))
    head = np.unwrap(_yaw(P, n.index("neck3"), n.index("head")))
    i = int(1.5 * FPS)
    # 0.15 s into the turn the head has turned more than the neck, the neck than the back,
    # each against the same moment of the stride before (the gait's own sway cancels)
    k = i + 9
    lead = [np.degrees(x[k] - x[k - L]) for x in (head, neck, back, pelvis)]
    assert lead[0] > lead[1] > lead[2] > lead[3] >= 0.0, lead
    # turning steadily, the head leads the pelvis by several degrees, the back by less
    s = slice(i + FPS, i + FPS + L)
    b = slice(i - L, i)
    assert s.stop <= len(P)                          # whole strides: the sway cancels
    rel_head = np.degrees(np.mean(head[s] - pelvis[s]) - np.mean(head[b] - pelvis[b]))
    rel_back = np.degrees(np.mean(back[s] - pelvis[s]) - np.mean(back[b] - pelvis[b]))
    assert 5.0 < rel_head < 35.0 and 0.2 < rel_back < rel_head, (rel_head, rel_back)


def test_turning_through_a_transition_and_a_leap(horse, db):
    rate = math.radians(20.0)
    script = Script((0.0, 1.0), (Command(speed=3.5),
                                 Command(speed=6.0, turn_rate=rate, leap=True)))
    P, labels, ctl = _run(horse, db, script, 6.0)
    # the body's heading, hips to shoulders (the pelvis alone sways through the stride)
    n = horse.skeleton.names
    hips = P[:, [n.index("LH_hip"), n.index("RH_hip")]].mean(axis=1)
    shoulders = P[:, [n.index("LF_shoulder"), n.index("RF_shoulder")]].mean(axis=1)
    d = shoulders - hips
    psi = np.unwrap(np.arctan2(d[:, 0], d[:, 2]))
    trans = [i for i, g in enumerate(labels) if "->" in g]
    leap = [i for i, g in enumerate(labels) if g == "leap"]
    assert trans and leap
    for idx in (trans, leap):
        turned = psi[idx[-1]] - psi[idx[0]]
        want = rate * (idx[-1] - idx[0]) / FPS
        assert abs(turned - want) < math.radians(3.0), (math.degrees(turned), math.degrees(want))
    slide, ground_err, under = _ok_feet(horse, P, _ground(ctl))
    assert slide < 0.005 and ground_err < 0.005 and under > -0.001


# ------------------------------------------------------------------ slopes
@pytest.mark.parametrize("gait,speed,slope_deg", [("walk", 1.5, 10.0), ("trot", 3.5, -10.0),
                                                  ("canter", 6.0, 15.0), ("gallop", 11.0, -8.0)])
def test_feet_on_a_sloped_ground(horse, db, gait, speed, slope_deg):
    a = math.radians(slope_deg)
    P, labels, ctl = _run(horse, db, Command(speed=speed, gait=gait, slope=a), 5.0)
    assert set(labels) == {gait}
    # the ground asked for: a ramp ahead of the fore feet along the heading, independently rebuilt
    (o, h0, u, s), = ctl.ground.ramps
    assert h0 == 0.0 and s == a and np.allclose(u, [0.0, 1.0])
    feet0 = _feet(horse, P)[0, :, 2].max()
    assert feet0 < o[1] < feet0 + 1.0
    ground = Ground()
    ground.add_ramp(o, 0.0, a)
    slide, ground_err, under = _ok_feet(horse, P, ground, skip=FPS // 2)
    assert slide < 0.005, slide
    assert ground_err < 0.005, ground_err
    assert under > -0.001, under
    # the body is pitched with the ground once on it (pelvis -> withers line), by the
    # slope from its pitch in the same gait on level ground (a gallop's trunk is
    # itself 1-2 degrees nose-up over a stride)
    n = horse.skeleton.names
    rest = horse.skeleton.rest_positions
    d0 = rest[n.index("spine4")] - rest[n.index("pelvis")]

    def pitch(P):
        d = P[-FPS:, n.index("spine4")] - P[-FPS:, n.index("pelvis")]
        return np.median(np.arctan2(d[:, 1], np.hypot(d[:, 0], d[:, 2]))) - math.atan2(
            d0[1], d0[2])

    level, _, _ = _run(horse, db, Command(speed=speed, gait=gait), 5.0)
    assert abs(np.degrees(pitch(level))) < 3.0, np.degrees(pitch(level))
    assert np.abs(np.degrees(pitch(P) - pitch(level) - a)) < 1.0, (
        np.degrees(pitch(P)), np.degrees(pitch(level)))
    # it climbs (or descends) as far as the slope says
    dz = P[-1, 0, 2] - P[FPS, 0, 2]
    dy = P[-1, 0, 1] - P[FPS, 0, 1]
    assert abs(dy / dz - math.tan(a)) < 0.02, (dy / dz, math.tan(a))


def test_slope_up_then_down_with_a_turn(horse, db):
    script = Script((0.0, 1.0, 3.5, 6.0),
                    (Command(speed=3.5), Command(speed=3.5, slope=math.radians(8.0)),
                     Command(speed=3.5, slope=math.radians(-6.0), turn_rate=math.radians(25.0)),
                     Command(speed=3.5)))
    P, _, ctl = _run(horse, db, script, 8.0)
    assert len(ctl.ground.ramps) == 3
    slide, ground_err, under = _ok_feet(horse, P, _ground(ctl))
    assert slide < 0.005 and ground_err < 0.005 and under > -0.001, (slide, ground_err, under)
    y = P[:, 0, 1]
    assert y.max() - y[0] > 0.3                     # went up, then down again
    assert y[-1] < y.max() - 0.2


def test_bad_slopes_are_rejected(horse, db, tmp_path):
    ctl = HorseDataController(horse, db)
    with pytest.raises(InputError, match=r"slope.*out of range.*-20 to 20 deg"):
        ctl.step(Command(speed=3.0, slope=math.radians(35.0)))
    base = {"character": "horse", "duration": 2.0, "fps": 30, "mode": "data",
            "command": [{"at": 0.0, "speed": 2.0, "slope_deg": 25.0}]}
    with pytest.raises(InputError, match=r"command\[0\]\.slope_deg.*-20 to 20"):
        parse_config(base)
    base["command"][0]["slope_deg"] = 5.0
    assert parse_config(base).commands.commands[0].slope == pytest.approx(math.radians(5.0))
    base["mode"] = "procedural"
    with pytest.raises(InputError, match=r"slope_deg.*mode.*'data'"):
        parse_config(base)


# ------------------------------------------------------------------ leap
def test_leap_clears_the_clip_height_and_lands_still(horse, db):
    rots = []
    P, labels, ctl = _run(horse, db, Script((0.0, 1.0), (Command(speed=6.0),
                                                         Command(speed=6.0, leap=True))), 7.0,
                          rots)
    leap = [i for i, g in enumerate(labels) if g == "leap"]
    assert leap and labels[-1] == "canter"
    feet, above, c = _measure(horse, P, _ground(ctl))
    # clearance: the highest point of the lowest foot (and of every joint) in the leap
    assert above[leap].min(axis=1).max() >= ctl.leap_clip.height - 1e-3
    joints = P[leap][..., 1].min(axis=1).max()
    assert joints >= ctl.leap_clip.height - 1e-3
    # a flight with no foot on the ground, then the landing contacts hold still
    assert (~c[leap]).all(axis=1).sum() >= 0.3 * FPS
    a, b = leap[0] - FPS // 2, leap[-1] + FPS
    _, slide = foot_slide(feet[a:b], c[a:b])
    assert slide < 0.005, slide
    # the body carries on from the leap without a jump (the leap is played at 11 m/s)
    step = np.linalg.norm(np.diff(P[:, 0, [0, 2]], axis=0), axis=1)
    assert step.max() < 1.2 * ctl.leap_clip.speed / FPS, step.max()
    # into and out of the leap without a pop: joint angular acceleration around the
    # leap's first and last frames no higher than 1.5 x its peak in the canter and the
    # canter -> gallop transition before it
    rot = np.array(rots)
    acc = angular_acceleration(Motion(horse.skeleton, FPS, P[:, 0], rot)).max(axis=1)
    steady = acc[FPS // 2:leap[0] - 3].max()
    for k in (leap[0], leap[-1]):
        assert acc[k - 3:k + 4].max() < 1.5 * steady, (k, acc[k - 3:k + 4].max(), steady)


# ------------------------------------------------------------------ standing
def test_stand_still_set_off_and_stop_again(horse, db):
    script = Script((0.0, 1.0, 4.0, 7.5),
                    (Command(speed=0.0), Command(speed=1.5), Command(speed=0.0),
                     Command(speed=3.5)))
    P, labels, ctl = _run(horse, db, script, 9.5)
    feet, above, c = _measure(horse, P, _ground(ctl))
    # standing at the start: nothing moves, all four feet down
    assert np.abs(P[:FPS] - P[0]).max() < 1e-6
    assert np.abs(above[:FPS]).max() < 0.005 and c[5:FPS - 5].all()
    # it sets off and walks
    assert P[int(3.5 * FPS), 0, 2] - P[FPS, 0, 2] > 2.0
    # it stops within 2 s of being told to, and then stands: all feet planted, no joint moving
    i = labels.index("stand", int(4.0 * FPS))
    assert i < int(6.0 * FPS)
    still = slice(i + 10, int(7.5 * FPS))
    assert np.abs(P[still] - P[still.start]).max() < 0.001
    assert np.abs(above[still]).max() < 0.005 and c[still].all()
    _, slide = foot_slide(feet, c)
    assert slide < 0.005, slide
    step = np.linalg.norm(np.diff(P[:, 0, [0, 2]], axis=0), axis=1)
    assert step.max() < 1.2 * 3.5 / FPS, step.max()
    # and sets off again, at a trot
    assert labels[-1] == "trot" and P[-1, 0, 2] - P[int(7.5 * FPS), 0, 2] > 2.0


def test_a_report_of_a_climb_measures_the_feet_from_the_slope(horse, db):
    """On a ramp the feet stand metres above y = 0: measured from the ground under them
    (their toe tips from ``extras["toe_ground"]``), a climbing trot shows the same
    footfalls as on the level, its toe tips as deep (0.34 mm, a hoof's strike turned
    toe down onto the ground) and as still."""
    from quadsim.analysis.metrics import feet_over_ground, foot_contacts, motion_report
    from quadsim.horse.controller import simulate

    climb = simulate(horse, Command(speed=4.0, slope=math.radians(8.0)), 8.0, 60, database=db)
    level = simulate(horse, Command(speed=4.0), 8.0, 60, database=db)
    assert climb.extras["ground"][180:].min() > 1.0          # well up the ramp
    # measured from y = 0 no foot would ever touch down
    assert not foot_contacts(climb.foot_positions()[180:], 60).any()
    up, flat = motion_report(climb, start=3.0), motion_report(level, start=3.0)
    for leg in up["legs"]:
        assert up["legs"][leg]["strides"] >= 5
        assert up["legs"][leg]["duty_factor"] == pytest.approx(
            flat["legs"][leg]["duty_factor"], abs=0.01)
        assert up["legs"][leg]["max_slide_mm"] < 1.0
        assert up["legs"][leg]["max_penetration_mm"] < 0.5
        assert up["legs"][leg]["max_penetration_mm"] == pytest.approx(
            flat["legs"][leg]["max_penetration_mm"], abs=0.05)
    lowered = feet_over_ground(climb)
    np.testing.assert_allclose(lowered[..., 1] + climb.extras["toe_ground"],
                               climb.contact_points()[..., 1])
    # the ground under a toe tip (its end site ahead of the hoof joint, 8 cm) on an
    # 8 degree climb: higher than under the joint by that times the slope (11 mm)
    toe = float(horse.skeleton.end_sites[horse.foot_joints[0]][2])
    rise = climb.extras["toe_ground"][180:] - climb.extras["ground"][180:]
    assert np.median(rise) == pytest.approx(toe * math.tan(math.radians(8.0)), abs=0.003)


def test_a_malformed_ground_record_is_named_in_the_error(horse, db):
    """A motion whose recorded ground does not match its frames is refused with the
    key at fault named, not measured against the wrong frames."""
    from quadsim.analysis.metrics import feet_over_ground
    from quadsim.horse.controller import simulate

    m = simulate(horse, Command(speed=4.0), 0.5, 60, database=db)
    m.extras["toe_ground"] = np.zeros((3, 4))
    with pytest.raises(ValueError, match=r"extras\['toe_ground'\] has shape \(3, 4\)"):
        feet_over_ground(m)
