"""Every figure of a motion measured once: exactly the figures of the separate reports."""

from __future__ import annotations

import json
import warnings
from dataclasses import replace

import numpy as np
import pytest

import quadsim
from quadsim.analysis.appearance import appearance_report
from quadsim.analysis.measure import measure_motion
from quadsim.analysis.metrics import foot_contacts, motion_report
from quadsim.io.npz import npz_arrays
from quadsim.skeleton.skeleton import Skeleton


def _separately(motion) -> dict:
    """The figures of ``quadsim metrics --json``, one report after the other."""
    report = motion_report(motion)
    try:
        report["appearance"] = appearance_report(motion)
    except ValueError:
        report["appearance"] = None
    return report


def _same(a: dict, b: dict) -> bool:
    """Equal to the last bit (NaN-free JSON: the manifest's own test of sameness)."""
    return json.dumps(a, sort_keys=True) == json.dumps(b, sort_keys=True)


@pytest.fixture(scope="module")
def motions():
    from quadsim.config import constant_command

    out = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # clamps
        for cid, gait, turn in (("leopard", "walk", 0.0), ("leopard", "canter", 20.0),
                                ("dog_cub", "trot", 20.0)):
            ch = quadsim.load_character(cid)
            cmd = constant_command(ch, gait=gait, turn_rate_deg_s=turn)
            out[f"{cid}-{gait}-{turn:g}"] = quadsim.simulate(ch, cmd, seconds=3.0, fps=60,
                                                             seed=1)
        out["horse-gallop"] = quadsim.run("horse", gait="transverse_gallop", seconds=3)
    return out


def test_the_shared_path_gives_exactly_the_figures_of_the_separate_reports(motions):
    for name, m in motions.items():
        got = measure_motion(m)
        assert _same(got.report, _separately(m)), name
        assert got.report["appearance"]["strides"] > 0, name


def test_its_contacts_are_those_a_npz_file_stores(motions):
    for name, m in motions.items():
        got = measure_motion(m)
        want = foot_contacts(m.contact_points(), m.fps)
        assert got.contacts.dtype == bool and np.array_equal(got.contacts, want), name
        a, b = npz_arrays(m, got.contacts), npz_arrays(m)
        assert list(a) == list(b)
        for key in a:
            assert np.array_equal(a[key], b[key]), (name, key)
            assert a[key].strides == np.asarray(b[key]).strides, (name, key)


def test_on_uneven_ground_the_figures_are_measured_from_the_ground_under_the_feet(motions):
    m = motions["leopard-walk-0"]
    T = len(m)
    ground = 0.01 * np.sin(np.linspace(0.0, 6.0, T))[:, None] * np.ones((1, 4))
    hilly = replace(m, extras=dict(m.extras, ground=ground))
    got = measure_motion(hilly)
    assert _same(got.report, _separately(hilly))
    # the file's contacts are of the feet as they are, not over the ground
    assert np.array_equal(got.contacts, foot_contacts(hilly.contact_points(), hilly.fps))


def test_without_the_appearance_the_footfalls_are_those_of_motion_report(motions):
    m = motions["dog_cub-trot-20"]
    sk = m.skeleton
    names = tuple(f"j{j:02d}" for j in range(sk.n_joints))  # a BVH of unknown naming
    anon = Skeleton(names, sk.parents, sk.offsets, {})
    feet = tuple(names[sk.names.index(f)] for f in m.foot_joints)
    other = replace(m, skeleton=anon, foot_joints=feet)
    got = measure_motion(other, appearance=False)
    want = motion_report(other)
    want["appearance"] = None
    assert _same(got.report, want)


def test_a_motion_without_foot_joints_is_refused(motions):
    m = motions["leopard-walk-0"]
    with pytest.raises(ValueError, match="foot joints"):
        measure_motion(replace(m, foot_joints=None))


def test_each_foots_contacts_and_touchdowns_are_those_found_for_it_alone(motions):
    """The four feet are measured in one pass: no foot's runs reach into the next's."""
    from quadsim.analysis.metrics import stance_intervals

    for name, m in motions.items():
        feet = m.foot_positions()
        both = foot_contacts(feet, m.fps, height=0.012, speed=0.6)
        times = stance_intervals(both, m.fps, feet, tolerance=0.0012)
        for i in range(4):
            alone = np.repeat(feet[:, i:i + 1], 4, axis=1)  # this foot as all four
            c = foot_contacts(alone, m.fps, height=0.012, speed=0.6)
            assert np.array_equal(c[:, 0], both[:, i]), (name, i)
            t = stance_intervals(c, m.fps, alone, tolerance=0.0012)[0]
            assert np.array_equal(t, times[i], equal_nan=True), (name, i)
