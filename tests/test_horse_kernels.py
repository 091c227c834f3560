"""The data-driven horse's compiled pieces agree with formulas written another way.

:mod:`quadsim.horse.place_kernel` and :mod:`quadsim.kinematics.chains` hold
the one implementation of each stage (forward kinematics, the two-bone IK,
the ramp ground, the clip's contact test, the pose sampler); the vectorised
public functions (:func:`~quadsim.horse.legs.two_bone`,
:meth:`~quadsim.horse.slope.Ground.height`,
:func:`~quadsim.horse.root.in_stance`,
:func:`~quadsim.horse.database.sample_motion`) wrap them. Each is checked
here against a pure-numpy oracle (``tests/horse_oracles.py``) on many
random or real inputs. (The quaternion pieces are
:mod:`quadsim.kinematics.rotations`' own, tested against transforms3d in
``test_rotations.py``.) What the whole placement does to the motion is
measured on joint positions in ``test_horse_turning.py`` and
``test_horse_smoothness.py``.
"""

import math

import numpy as np
import pytest

from horse_oracles import (
    in_stance_reference,
    ramp_height_reference,
    sample_reference,
    two_bone_reference,
)
from quadsim.horse.controller import HorseDataController
from quadsim.horse.database import sample_motion
from quadsim.horse.legs import two_bone
from quadsim.horse.place_kernel import (
    ground_height,
    ground_heights,
    sample_row,
    stance_row,
)
from quadsim.kinematics.chains import fk_row, two_bone_row
from quadsim.kinematics.compiled import FixedEntry
from quadsim.horse.root import clip_stance_cycles, in_stance
from quadsim.horse.slope import Ground
from quadsim.skeleton.fk import forward_kinematics


def test_forward_kinematics_of_one_pose(horse, db):
    m = db.by_gait("canter")[0].motion
    skel = horse.skeleton
    L = m.local_matrices[7]
    root = m.root_positions[7] + [0.4, 0.0, -1.2]
    G = np.empty((skel.n_joints, 3, 3))
    P = np.empty((skel.n_joints, 3))
    fk_row(skel.parents.astype(np.int64), skel.offsets, np.ascontiguousarray(L), root, G, P)
    W_want, P_want = forward_kinematics(skel, L, root)
    np.testing.assert_allclose(G, W_want, atol=1e-12)
    np.testing.assert_allclose(P, P_want, atol=1e-12)


def test_two_bone_matches_the_numpy_formula_for_reachable_and_unreachable_targets(horse, db):
    m = db.by_gait("trot")[0].motion
    skel = horse.skeleton
    W, P = m.world_rotations(), m.world_positions()
    rng = np.random.default_rng(3)
    n_checked = 0
    for leg in horse.legs:
        top, mid = leg.chain[leg.ik_start], leg.chain[leg.ik_start + 1]
        par = skel.parents[top]
        # targets near the foot, and far beyond the leg's reach (approached, not reached)
        targets = P[:, leg.foot] + rng.normal(scale=0.06, size=(len(m), 3))
        targets[::5] += [0.0, -2.0, 1.0]
        args = (P[:, top], P[:, mid], P[:, leg.foot], W[:, par], W[:, top], W[:, mid], targets)
        Lt, Lm = two_bone_reference(*args)
        batch_t, batch_m = two_bone(*args)
        np.testing.assert_allclose(batch_t, Lt, atol=1e-10)
        np.testing.assert_allclose(batch_m, Lm, atol=1e-10)
        got_t, got_m, work = np.empty((3, 3)), np.empty((3, 3)), np.empty((4, 3, 3))
        for f in range(len(m)):
            two_bone_row(P[f, top], P[f, mid], P[f, leg.foot], W[f, par], W[f, top],
                         W[f, mid], targets[f], got_t, got_m, work)
            np.testing.assert_allclose(got_t, Lt[f], atol=1e-10)
            np.testing.assert_allclose(got_m, Lm[f], atol=1e-10)
            n_checked += 1
    assert n_checked == 4 * len(m)


def test_ground_height_matches_the_ramp_field():
    g = Ground()
    g.add_ramp([0.0, 2.0], 0.0, math.radians(8.0))
    g.add_ramp([1.0, 6.0], math.radians(30.0), math.radians(-5.0))
    g.add_ramp([-2.0, 9.0], math.radians(-90.0), math.radians(12.0))
    rng = np.random.default_rng(4)
    xz = rng.uniform(-6.0, 14.0, size=(400, 2))
    want = ramp_height_reference(g.table, xz)
    got = np.array([ground_height(g.table, x, z) for x, z in xz])
    np.testing.assert_allclose(got, want, atol=1e-12)
    np.testing.assert_allclose(g.height(xz.reshape(20, 20, 2)), want.reshape(20, 20), atol=1e-12)
    assert np.ptp(want) > 0.5              # the points cover the ramps, not only flat ground
    assert ground_height(Ground().table, 3.0, 4.0) == 0.0


@pytest.mark.parametrize("gait", ["walk", "canter", "gallop"])
def test_stance_row_holds_a_foot_only_when_down_on_both_frames_about_the_time(horse, db, gait):
    ctl = HorseDataController(horse, db)
    clip = ctl.expanded(gait, db.by_gait(gait)[0].speed)
    pk = ctl.player._pack(clip)
    stance = clip_stance_cycles(clip)
    rng = np.random.default_rng(5)
    times = np.concatenate([rng.uniform(0.0, 3.0, 300), np.arange(clip.frames) / clip.frames])
    got = np.empty(4, dtype=bool)
    n_edge = 0
    for t in times:
        stance_row(pk.on_off, pk.count, clip.frames, t, got)
        f = t * clip.frames
        want = in_stance_reference(stance, np.full((1, 4), t))[0]
        np.testing.assert_array_equal(in_stance(stance, np.full((1, 4), t))[0], want)
        if f - math.floor(f) > 1e-9:
            k = math.floor(f)
            both = in_stance_reference(stance, np.array([[k / clip.frames] * 4,
                                                         [(k + 1) / clip.frames] * 4])).all(axis=0)
            n_edge += int((want & ~both).any())
            want = want & both
        np.testing.assert_array_equal(got, want)
    assert n_edge > 0                       # some times fall in a contact's end frames


def test_sample_row_matches_the_slerp_formula(horse, db):
    m = db.by_gait("amble")[0].motion
    root, q = np.empty(3), np.empty((horse.skeleton.n_joints, 4))
    for f in np.linspace(0.0, len(m) - 1.0, 57):
        i0 = int(math.floor(f))
        sample_row(m.root_positions, m.rotations, i0, min(i0 + 1, len(m) - 1), f - i0, root, q)
        want_root, want_q = sample_reference(m, [f])
        np.testing.assert_allclose(root, want_root[0], atol=1e-12)
        np.testing.assert_allclose(q, want_q[0], atol=1e-12)
    frames = np.linspace(-1.0, len(m) + 1.0, 31)          # clipped to the motion's ends
    got_root, got_q = sample_motion(m, frames)
    want_root, want_q = sample_reference(m, frames)
    np.testing.assert_allclose(got_root, want_root, atol=1e-12)
    np.testing.assert_allclose(got_q, want_q, atol=1e-12)


def test_fixed_entry_dispatches_once_then_calls_the_compiled_code():
    g = Ground()
    g.add_ramp([0.0, 1.0], 0.3, math.radians(6.0))
    xz = np.random.default_rng(6).uniform(-3.0, 5.0, size=(50, 2))
    call = FixedEntry(ground_heights)
    first, again = np.empty(50), np.empty(50)
    call(g.table, xz, first)
    assert call._entry is not None                  # bound to the compiled signature
    call(g.table, xz, again)
    np.testing.assert_array_equal(again, first)
    np.testing.assert_allclose(first, ramp_height_reference(g.table, xz), atol=1e-12)


def test_fixed_entry_of_an_uncompiled_function_calls_it_as_it_is():
    """Without a compiled signature (``NUMBA_DISABLE_JIT``: a plain function) every call
    goes through the function itself."""
    calls = []
    call = FixedEntry(lambda *a: calls.append(a) or len(calls))
    assert call(1, 2) == 1 and call(3) == 2 and call._entry is None
    assert calls == [(1, 2), (3,)]
