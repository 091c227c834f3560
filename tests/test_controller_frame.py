"""The frame a controller step returns: frozen, its arrays read-only, built fast or checked."""

import numpy as np
import pytest

from quadsim.controller import Frame
from quadsim.skeleton import load_character


@pytest.fixture(scope="module")
def skeleton():
    return load_character("horse").skeleton


def _arrays(J, seed=0):
    rng = np.random.default_rng(seed)
    return (rng.normal(size=3), rng.normal(size=(J, 3, 3)), rng.normal(size=(J, 3)),
            rng.random(4) < 0.5, rng.normal(size=4))


def test_an_owned_frame_is_the_checked_frame_of_the_same_arrays(skeleton):
    J = skeleton.n_joints
    root, L, P, contacts, ground = _arrays(J)
    checked = Frame(skeleton, 0.5, root.copy(), L.copy(), P.copy(), 0.25, "trot",
                    contacts.copy(), 3.0, {"pitch": np.float64(0.1), "ground": ground.copy()})
    owned = Frame.owned(skeleton, 0.5, root, L, P, 0.25, "trot", contacts, 3.0,
                        {"pitch": np.array(0.1), "ground": ground})
    for name in ("time", "heading", "gait", "speed"):
        assert getattr(owned, name) == getattr(checked, name)
        assert type(getattr(owned, name)) is type(getattr(checked, name))
    for name in ("root", "local_rotations", "positions", "contacts"):
        a, b = getattr(owned, name), getattr(checked, name)
        np.testing.assert_array_equal(a, b)
        assert a.dtype == b.dtype and a.shape == b.shape
    assert owned.root is root and owned.local_rotations is L     # taken, not copied
    assert set(owned.extras) == set(checked.extras)
    for k in owned.extras:
        np.testing.assert_array_equal(owned.extras[k], checked.extras[k])
        assert owned.extras[k].shape == checked.extras[k].shape
    np.testing.assert_allclose(owned.world_rotations, checked.world_rotations)


def test_an_owned_frame_is_frozen_and_read_only(skeleton):
    J = skeleton.n_joints
    root, L, P, contacts, ground = _arrays(J, 1)
    f = Frame.owned(skeleton, 0.0, root, L, P, 0.0, "walk", contacts, 1.0,
                    {"pitch": np.array(0.0), "ground": ground})
    for a in (f.root, f.local_rotations, f.positions, f.contacts, f.extras["ground"],
              f.extras["pitch"]):
        with pytest.raises(ValueError):
            a[...] = 0
    with pytest.raises(AttributeError):
        f.gait = "trot"
    with pytest.raises(TypeError):
        f.extras["pitch"] = np.array(1.0)
