"""A sweep's batches are measured together and still give every clip exactly its own
figures, contacts and bytes: whatever other clips share its batch, and the same as a
lone motion measured by ``quadsim.analysis.measure.measure_motion``."""

from __future__ import annotations

import json
import platform
import subprocess
import sys

import numpy as np
import pytest

import quadsim
from quadsim.analysis.angular import _compiled, _numpy, angular_figures, compiled_path
from quadsim.analysis.measure import measure_motion, measure_motions
from quadsim.analysis.report import foot_slide
from quadsim.analysis.smoothness import angular_acceleration, angular_velocity_vectors
from quadsim.dataset import generate, npz_bytes, parse_grid
from quadsim.dataset.clips import make_clips
from quadsim.skeleton import contacts_many
from quadsim.skeleton.contacts import _events, _tolerance, foot_contacts
from quadsim.skeleton.motion import Motion

GRID = {"characters": ["dog_cub"], "gaits": ["walk", "trot", "canter"],
        "turn_rates_deg_s": [0, 20], "seeds": [0, 1], "seconds": 2}


def _same(a: dict, b: dict) -> bool:
    """Equal to the last bit (NaN-free JSON: the manifest's own test of sameness)."""
    return json.dumps(a, sort_keys=True) == json.dumps(b, sort_keys=True)


def _fresh(m: Motion) -> Motion:
    """The same motion, its forward kinematics not yet found."""
    return Motion(m.skeleton, m.fps, m.root_positions, m.rotations, contacts=m.contacts,
                  gaits=m.gaits, foot_joints=m.foot_joints, extras=m.extras)


@pytest.fixture(scope="module")
def clips():
    return parse_grid(GRID).clips()


@pytest.fixture(scope="module")
def batch(clips):
    return generate(clips)


def test_a_batch_hands_each_motion_the_forward_kinematics_of_its_own_rotations(batch):
    for m in batch:
        alone = _fresh(m)
        assert np.array_equal(m.world_positions(), alone.world_positions())
        assert np.array_equal(m.world_rotations(), alone.world_rotations())
        assert not m.world_positions().flags.writeable


def test_a_batchs_motions_hold_what_a_checked_motion_holds(batch):
    for m in batch[:3]:
        checked = _fresh(m)
        for k in ("root_positions", "rotations", "contacts", "gaits"):
            mine, want = getattr(m, k), getattr(checked, k)
            assert mine.dtype == want.dtype and np.array_equal(mine, want)
            assert not mine.flags.writeable and mine.flags.c_contiguous
        assert set(m.extras) == set(checked.extras) and m.foot_joints == checked.foot_joints
        assert all(not v.flags.writeable and np.array_equal(v, checked.extras[k])
                   for k, v in m.extras.items())
        assert m.fps == 60.0 and isinstance(m.fps, float)


def test_a_batch_measured_together_gives_each_clip_the_figures_it_has_alone(batch):
    together = measure_motions(batch)
    assert len(together) == len(batch)
    for m, got in zip(batch, together):
        want = measure_motion(_fresh(m))
        assert _same(got.report, want.report)
        assert np.array_equal(got.contacts, want.contacts)
        # laid out alike too: a .npz file stores the layout
        assert got.contacts.strides == want.contacts.strides
        assert got.report["appearance"]["strides"] > 0


def test_motions_that_are_not_alike_are_measured_one_by_one(batch):
    short = batch[1][:90]  # another length: not one batch
    got = measure_motions([batch[0], short])
    assert _same(got[1].report, measure_motion(short).report)
    assert _same(got[0].report, measure_motion(batch[0]).report)


def _feet(rng, N: int, T: int) -> np.ndarray:
    """Feet that step: each leg low and still for a while, then up and moving."""
    t = np.arange(T)[None, :, None]
    phase = rng.uniform(0, 2 * np.pi, (N, 1, 4))
    swing = np.sin(2 * np.pi * t / rng.integers(20, 40, (N, 1, 1)) + phase)
    feet = np.zeros((N, T, 4, 3))
    feet[..., 1] = np.where(swing > 0, 0.05 * swing, 0.0) + rng.normal(0, 2e-4, (N, T, 4))
    feet[..., 2] = np.cumsum(np.where(swing > 0, 0.02, 0.0), axis=1) + \
        rng.normal(0, 1e-4, (N, T, 4))
    feet[1, :, 0] = 0.0       # a foot down from the first frame to the last
    feet[2, :, 3, 1] = 0.2    # a foot never down
    return feet


def test_contacts_of_many_clips_are_each_clips_own_contacts():
    rng = np.random.default_rng(7)
    feet = _feet(rng, 5, 150)
    heights, speeds = contacts_many.default_thresholds(feet)
    heights[3] *= 1.7  # each clip its own thresholds
    speeds[4] *= 0.5
    got = contacts_many.foot_contacts(feet, 60.0, heights, speeds)
    evs = contacts_many.events(got, 60.0, feet, heights)
    for i in range(len(feet)):
        want = foot_contacts(feet[i], 60.0, height=heights[i], speed=speeds[i])
        assert np.array_equal(got[i], want)
        alone = _events(want, 60.0, feet[i], _tolerance(float(heights[i])))
        for a, b in zip(evs[i], alone):
            for k in ("s", "e", "on", "off"):
                assert np.array_equal(a[k], b[k], equal_nan=True), (i, k)
    assert got[1][:, 0].all() and not got[2][:, 3].any()
    found = contacts_many.runs(got)
    slid = contacts_many.per_foot(contacts_many.slides(feet, got, found), found[3], len(feet))
    for i in range(len(feet)):
        for a, b in zip(slid[i], foot_slide(feet[i], got[i])[0]):
            assert np.array_equal(a, b)
    assert len(slid[2][3]) == 0 and len(slid[1][0]) == 1


def test_the_compiled_angular_figures_are_numpys_to_the_last_bit(batch):
    q = batch[0].rotations
    omega, speed, accel = angular_figures(q, 60.0)
    assert np.array_equal(omega, angular_velocity_vectors(q, 60.0))
    assert np.array_equal(speed, np.linalg.norm(omega, axis=-1))
    assert np.array_equal(accel, angular_acceleration(q, 60.0))
    if not compiled_path():
        pytest.skip("NumPy sums differently here: the NumPy code runs instead")
    for m in batch[:4]:
        for a, b in zip(_compiled(m.rotations, 30.0), _numpy(m.rotations, 30.0)):
            assert np.array_equal(a, b)


def test_the_compiled_hinge_angles_are_numpys_to_the_last_bit(batch):
    from quadsim.analysis.angular import _hinges_compiled, _hinges_numpy, hinge_angles

    P = np.stack([m.world_positions() for m in batch[:3]])
    p, j, c = [1, 2, 5, 6], [2, 3, 6, 7], [3, 4, 7, 8]
    assert np.array_equal(hinge_angles(P, p, j, c), _hinges_numpy(P, p, j, c))
    flat = np.zeros((4, 6, 3))  # chords of zero length: arctan2(0, +0), not (0, -0)
    flat[:, 1] = flat[:, 2] = [-1.0, -2.0, -3.0]
    assert np.array_equal(_hinges_compiled(flat, [0], [1], [2]),
                          _hinges_numpy(flat, [0], [1], [2]))


def test_a_clip_gives_the_same_bytes_and_figures_whatever_shares_its_batch(clips):
    """A resumed run batches other clips together: each clip must not notice."""
    together = {e["id"]: e for e in make_clips(clips)}
    others = make_clips(clips[5:12][::-1])  # another batch, another order
    few = make_clips(clips[2:4])  # too few to batch: simulated one by one
    for e in others + few:
        want = together[e["id"]]
        assert e["data"] == want["data"]
        assert _same(e["metrics"], want["metrics"])
    # and the file of a lone simulation, its contacts measured alone
    c = clips[7]
    alone = quadsim.simulate(c.character, quadsim.Command(
        speed=c.speed, gait=c.gait, turn_rate=np.radians(c.turn_rate_deg_s)),
        seconds=c.seconds, fps=c.fps, seed=c.seed)
    assert together[c.id]["data"] == npz_bytes(alone)


@pytest.mark.skipif(platform.system() != "Linux" or platform.libc_ver()[0] != "glibc",
                    reason="glibc's allocator only")
def test_a_worker_can_keep_the_memory_it_frees():
    code = "from quadsim.dataset.sweep import keep_freed_memory as k; print(k())"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    assert out.strip() == "True"


def test_group_medians_pick_what_one_sort_by_group_and_value_picks():
    from quadsim.skeleton.contacts import _group_medians

    rng = np.random.default_rng(3)
    sizes = rng.integers(1, 120, 400)
    sizes[::40] = 500  # long blocks: sorted another way
    v = np.round(rng.standard_normal(sizes.sum()), 1)  # ties, and 0.0 beside -0.0
    zero = v == 0
    v[zero] = np.where(rng.random(zero.sum()) < 0.5, -0.0, 0.0)
    groups = np.repeat(np.arange(len(sizes)), sizes)

    def by_lexsort(x):
        first = np.concatenate([[0], np.cumsum(sizes)[:-1]])
        return x[np.lexsort((x, groups))][first + (sizes - 1) // 2]

    got = _group_medians(v, groups, sizes)
    want = by_lexsort(v)
    assert np.array_equal(got, want) and np.array_equal(np.signbit(got), np.signbit(want))
    v[5] = np.nan  # NaN: the one sort still decides
    assert np.array_equal(_group_medians(v, groups, sizes), by_lexsort(v), equal_nan=True)


def test_a_batchs_contacts_are_cut_as_numpy_cuts_them():
    from quadsim.skeleton.contacts import _split_at

    x = np.arange(40.0).reshape(20, 2)
    for cuts in ([], [0], [3, 3, 7], [5, 20], np.array([1, 19])):
        got, want = _split_at(x, cuts), np.split(x, cuts)
        assert len(got) == len(want)
        for a, b in zip(got, want):
            assert np.array_equal(a, b) and a.shape == b.shape
            assert a.base is x or a.base is x.base  # views, not copies
