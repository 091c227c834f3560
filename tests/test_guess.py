"""What a motion file leaves unsaid: its length unit and its feet (quadsim.io.guess)."""

import warnings

import numpy as np
import pytest

import quadsim
from quadsim.io.bvh import BvhUnitsWarning, read_bvh, write_bvh
from quadsim.io.guess import (
    CM_ABOVE,
    feet_from_structure,
    guess_units,
    rest_hip_height,
)
from quadsim.skeleton.character import list_characters
from quadsim.skeleton.skeleton import Skeleton


def anonymous(skel: Skeleton) -> Skeleton:
    """The same skeleton with joint names that say nothing."""
    return Skeleton(tuple(f"j{k}" for k in range(skel.n_joints)), skel.parents, skel.offsets,
                    {f"j{skel.names.index(n)}": v for n, v in skel.end_sites.items()})


@pytest.mark.parametrize("cid", list_characters())
def test_the_feet_found_from_the_shape_are_the_named_ones(cid):
    ch = quadsim.load_character(cid)
    found = feet_from_structure(anonymous(ch.skeleton))
    assert found == tuple(f"j{ch.skeleton.names.index(n)}" for n in ch.foot_joints)


@pytest.mark.parametrize("cid", list_characters())
def test_every_shipped_character_stands_between_0_1_and_3_m(cid):
    skel = quadsim.load_character(cid).skeleton
    ends = [(skel.names.index(n), v) for n, v in skel.end_sites.items()]
    h = rest_hip_height(skel.offsets, skel.parents, ends)
    assert 0.1 < h < CM_ABOVE
    assert guess_units(h) == "m" and guess_units(100 * h) == "cm"


def test_no_four_legs_no_feet():
    chain = Skeleton(("a", "b", "c"), [-1, 0, 1], np.array([[0, 0, 0], [0, -1, 0], [0, -1, 0]]))
    assert feet_from_structure(chain) is None


def test_read_bvh_detects_centimetres_and_says_so(tmp_path):
    from quadsim.locomotion import Command, simulate

    m = simulate(quadsim.load_character("dog_cub"), Command(speed=1.0), 0.5, 30.0)
    cm = write_bvh(m, tmp_path / "cm.bvh", units="cm")
    metres = write_bvh(m, tmp_path / "m.bvh")
    with pytest.warns(BvhUnitsWarning, match=r"cm\.bvh: read as centimetres.*--units m"):
        a = read_bvh(cm)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        b = read_bvh(metres)
        c = read_bvh(cm, units="cm")                  # given: no guess, no warning
    np.testing.assert_allclose(a.world_positions(), b.world_positions(), atol=1e-6)
    np.testing.assert_allclose(c.world_positions(), b.world_positions(), atol=1e-6)
