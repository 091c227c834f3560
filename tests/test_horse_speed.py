"""Speed expansion: Hoyt's law on the produced motion, measured from joint positions."""

import numpy as np
import pytest

from quadsim.analysis.appearance import appearance_report, toe_positions
from quadsim.analysis.metrics import angular_velocity, foot_contacts, foot_slide, stance_intervals
from quadsim.errors import InputError
from quadsim.horse.database import looped
from quadsim.horse.speed import HOYT, MPH, clip_contact_time, contact_time, expand

#: three speeds (m/s) across each gait's range; the gallop stays within the
#: reach of its single clip (11 m/s) -- see the speed module's notes
SPEEDS = {
    "walk": (1.4, 1.6, 1.8),
    "amble": (2.7, 3.2, 3.8),
    "trot": (2.5, 4.5, 6.5),
    "rack": (2.9, 4.2, 5.5),
    "canter": (4.4, 6.0, 7.5),
    "gallop": (9.0, 10.5, 12.0),
}



def test_table_1_speed_unit_is_mph():
    # a walking horse stands on each foot 0.6-0.8 s: only mph gives that
    for v in (1.4, 1.8):
        assert 0.6 <= contact_time("walk", v) <= 0.8
        a, b = HOYT["walk"]
        assert a * v ** b > 1.0            # v taken in m/s: far too long
        assert a * (v * 3.6) ** b < 0.55   # km/h: too short
    assert np.isclose(contact_time("trot", 4 * MPH), 1.407662 * 4 ** -0.74782)


@pytest.mark.parametrize("gait", list(SPEEDS))
def test_contact_time_and_step_follow_the_law(horse, db, gait):
    b = HOYT[gait][1]
    for v in SPEEDS[gait]:
        clip = db.nearest(gait, v)
        tc_want = clip_contact_time(clip) * (v / clip.speed) ** b
        e = expand(clip, horse, v, anchor="clip")
        assert e.speed == v and e.gait == gait
        m = looped(e.motion, 6, e.speed)
        feet = m.foot_positions()
        con = foot_contacts(feet, m.fps)
        iv = stance_intervals(con, m.fps, feet)
        root = m.root_positions
        for i in range(4):
            s = iv[i][np.isfinite(iv[i]).all(axis=1)][1:-1]  # whole contacts inside
            assert len(s) >= 2, (gait, v, i)
            tc = s[:, 1] - s[:, 0]
            assert np.all(np.abs(tc / tc_want - 1) < 0.10), (gait, v, i, tc, tc_want)
            # step length: body travel while the foot is down, vs D = v Tc
            z = np.interp(s * m.fps, np.arange(len(m)), root[:, 2])
            d = z[:, 1] - z[:, 0]
            assert np.all(np.abs(d / (v * tc_want) - 1) < 0.10), (gait, v, i, d)
        _, slide = foot_slide(feet, con)
        assert slide < 0.005, (gait, v, slide)
        # the footfall order is the clip's: each foot's touchdown phase after the left
        # hind's within 0.05 of a stride of the clip's, feet landing together in the clip
        # (a trot's diagonal pair: labels at most a frame apart, the frames' resolution)
        # together within 0.05, the others in the clip's order
        # (phases on the circle: a foot labelled a frame before the left hind is at -1/n,
        # not at 1 - 1/n)
        want = (clip.touchdown - clip.touchdown[2]) / clip.frames % 1.0
        ph = (e.touchdown - e.touchdown[2]) / e.frames % 1.0
        ph = want + (ph - want + 0.5) % 1.0 - 0.5
        assert np.all(np.abs(ph - want) < 0.05), (gait, v, ph, want)
        for i in range(4):
            for j in range(i + 1, 4):
                if abs(want[i] - want[j]) < 1.0 / clip.frames + 1e-9:
                    assert abs(ph[i] - ph[j]) < 0.05, (gait, v, i, j, ph)
                else:
                    assert np.sign(ph[i] - ph[j]) == np.sign(want[i] - want[j]), (gait, v, ph)


def test_expand_rejects_bad_input(horse, db):
    clip = db.nearest("walk", 1.5)
    with pytest.raises(InputError, match="anchor"):
        expand(clip, horse, 1.5, anchor="nope")
    with pytest.raises(InputError, match="speed"):
        expand(clip, horse, 0.0)
    with pytest.raises(InputError, match="no speed law"):
        expand(db.by_gait("leap")[0], horse, 11.0)


def _anchor(gait):
    return "clip" if gait in ("amble", "gallop") else "law"


def _peak_speed(motion):
    """Largest joint angular speed (deg/s) of a looped clip, across its seam too."""
    q = np.concatenate([motion.rotations, motion.rotations[:2]])
    return float(np.degrees(angular_velocity(q, motion.fps)).max())


@pytest.mark.parametrize("gait", list(SPEEDS))
def test_expanded_hooves_keep_their_toe_tips_on_the_ground(horse, db, gait):
    """Moving the feet in or out (equation 2) swings each leg's pair; the hooves keep the
    clip's attitude, so the toe tips neither sink nor slide (issue 13's contact figures:
    at most 3 mm below the ground, at most 5 mm of slide in 90 % of stances; the IK alone
    tipped a trot's hind toe 12 mm into the ground at 4 m/s)."""
    for v in SPEEDS[gait]:
        e = expand(db.nearest(gait, v), horse, v, anchor=_anchor(gait))
        m = looped(e.motion, 6, e.speed)
        r = appearance_report(m, start=0.3)
        assert r["toe_below_ground_mm"] <= 3.0, (gait, v, r["toe_below_ground_mm"])
        assert r["toe_slide_mm_p90"] <= 5.0, (gait, v, r["toe_slide_mm_p90"])
        assert toe_positions(m)[..., 1].min() > -0.003


@pytest.mark.parametrize("gait", list(SPEEDS))
def test_expansion_does_not_whip_a_straightening_leg(horse, db, gait):
    """A swinging leg passing through straight keeps the pose's reach, so the two-bone IK
    does not flip its bend from one frame to the next: no joint of the expanded clip turns
    much faster than the clip's fastest (measured up to 1.27x; a canter's fore leg moved in
    by 6 % had whipped its elbow at 2.6x, 3,300 deg/s)."""
    for v in SPEEDS[gait]:
        clip = db.nearest(gait, v)
        e = expand(clip, horse, v, anchor=_anchor(gait))
        assert _peak_speed(e.motion) <= 1.4 * _peak_speed(clip.motion), (gait, v)
