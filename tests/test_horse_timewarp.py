"""Asynchronous time warping: the seed's equations, and the new gait reached."""

import itertools

import numpy as np
import pytest

from quadsim.analysis.metrics import angular_acceleration, foot_contacts, stance_intervals
from quadsim.horse.timewarp import (
    REFERENCE,
    blend_frames,
    leg_times,
    synchronous_transition,
    transition_motion,
)


def test_blend_length_solves_equation_3():
    for L1, L2 in [(55, 23), (23, 55), (30, 30), (20, 45)]:
        B = blend_frames(L1, L2)
        i = np.arange(1, B + 1)
        total = np.sum((1 - i / B) / L1 + (i / B) / L2)
        assert abs(total - 2.5) < 0.6 / min(L1, L2) + 1e-9
        assert B == round((5 * L1 * L2 + L2 - L1) / (L1 + L2))


@pytest.mark.parametrize("t_start", [0.0, 0.3, 0.55, 0.8])
def test_leg_times_meet_the_end_posture(db, t_start):
    c1, c2 = db.by_gait("gallop")[0], db.by_gait("amble")[0]
    lt = leg_times(c1, c2, t_start)
    t1, t2 = lt["t1"], lt["t2"]
    assert t1.shape == (lt["B"], 4)
    assert np.all(np.diff(t1, axis=0) > 0) and np.all(np.diff(t2, axis=0) > 0)
    # the reference leg increments go linearly from 1/L1 to 1/L2
    d = np.diff(np.concatenate([[t_start], t1[:, REFERENCE]]))
    B = lt["B"]
    i = np.arange(1, B + 1)
    assert np.allclose(d, (1 - i / B) / c1.frames + (i / B) / c2.frames)
    # every leg ends at the end posture's generic time (modulo whole cycles)
    off = (t2[-1] - lt["end"] + 0.5) % 1.0 - 0.5
    assert np.allclose(off, 0.0, atol=1e-9)
    # other legs are the reference scaled by sigma_j / sigma*
    dj = np.diff(t1, axis=0)
    assert np.allclose(dj / dj[:, [REFERENCE]], lt["sigma"] / lt["sigma_star"])


def _strides_to_pattern(m, clip2, start, tol=0.06):
    feet = m.foot_positions()
    iv = stance_intervals(foot_contacts(feet, m.fps), m.fps, feet)
    on = [s[np.isfinite(s[:, 0]), 0] * m.fps for s in iv]
    want = ((clip2.touchdown - clip2.touchdown[REFERENCE]) / clip2.frames) % 1.0
    lh = on[REFERENCE][on[REFERENCE] >= start]
    ok = []
    for a, b in itertools.pairwise(lh):
        d = []
        for i in (0, 1, 3):
            x = on[i][(on[i] >= a) & (on[i] < b)]
            d.append(abs(((x[0] - a) / (b - a) - want[i] + 0.5) % 1.0 - 0.5) if len(x) else 1.0)
        ok.append(max(d) < tol)
    return next(k for k in range(len(ok) + 1) if all(ok[k:]))


@pytest.mark.parametrize("pair", [("gallop", "amble"), ("walk", "trot"), ("canter", "gallop"),
                                  ("trot", "rack")])
@pytest.mark.parametrize("t_start", [0.0, 0.5])
def test_new_footfall_pattern_within_three_strides(horse, db, pair, t_start):
    c1, c2 = db.by_gait(pair[0])[-1], db.by_gait(pair[1])[0]
    for make in (transition_motion, synchronous_transition):
        m = make(horse, c1, c2, t_start=t_start)
        bl = m.extras["blend"]
        s0, s1 = int(np.argmax(bl > 0)), int(np.argmax(bl >= 1))
        assert _strides_to_pattern(m, c2, s0) <= 3
        # no acceleration spike above 3x the steady maximum
        acc = angular_acceleration(m).max(axis=1)
        steady = max(acc[2:s0 - 2].max(), acc[s1 + 2:].max())
        assert acc[s0 - 2:s1 + 2].max() < 3 * steady


def test_root_from_landing_feet_keeps_the_clip_speed(db):
    from quadsim.horse.database import looped
    from quadsim.horse.root import (
        FLIGHT,
        STRIKING,
        clip_stance_cycles,
        foot_phase,
        in_stance,
        root_from_feet,
    )
    for gait in ("walk", "gallop"):
        c = db.by_gait(gait)[0]
        m = looped(c.motion, 3, c.speed)
        t = np.repeat((np.arange(len(m)) / c.frames)[:, None], 4, axis=1)
        st = in_stance(clip_stance_cycles(c), t)
        root = root_from_feet(m, st, c.speed)
        v = np.diff(root[:, 2]) * m.fps
        assert np.allclose(v, c.speed, rtol=0.02), gait
        ph = foot_phase(st)
        # one strike per foot per cycle, on the first frame of each contact
        assert np.all((ph == STRIKING).sum(axis=0) >= 2)
        assert np.all(ph[~st] == FLIGHT)
    if True:  # the gallop has a suspension: no foot down on some frames
        assert (~st).all(axis=1).any()


def test_asynchronous_warping_slides_less_than_synchronous(horse, db):
    """The blends themselves, before IK holds the stance feet (``pin=False``)."""
    from quadsim.analysis.metrics import foot_slide
    pairs = [("gallop", "amble"), ("canter", "trot"), ("amble", "canter"), ("rack", "walk")]
    res = {False: [], True: []}
    for g1, g2 in pairs:
        c1, c2 = db.by_gait(g1)[-1], db.by_gait(g2)[0]
        for sync in (False, True):
            m = transition_motion(horse, c1, c2, t_start=0.25, synchronous=sync, pin=False)
            bl = m.extras["blend"]
            s0, s1 = int(np.argmax(bl > 0)), int(np.argmax(bl >= 1))
            f = m.foot_positions()
            res[sync].append(foot_slide(f[s0:s1], foot_contacts(f, m.fps)[s0:s1])[1])
    assert np.median(res[False]) <= np.median(res[True])
