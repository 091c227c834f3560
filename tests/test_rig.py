"""A user's rig read from glTF, and its structure found without its names.

Uses the Khronos Fox from the shared test assets when present (it is not
part of the project); skips otherwise.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from quadsim.errors import InputError
from quadsim.io.rig import guess_unit, read_gltf_rig
from quadsim.kinematics.rotations import matrices_from_axis_angles
from quadsim.skeleton.anatomy import find_anatomy
from quadsim.skeleton.fk import forward_kinematics

#: ../shared/assets/fox beside the checkout
FOX = Path(__file__).resolve().parents[2] / "shared" / "assets" / "fox" / "Fox.gltf"

needs_fox = pytest.mark.skipif(not FOX.is_file(), reason="the Fox test rig is not on this "
                               "machine (../shared/assets/fox/Fox.gltf)")


@pytest.fixture(scope="module")
def fox():
    return read_gltf_rig(FOX)


@needs_fox
def test_the_fox_rig_is_read_with_its_joints_unit_and_mesh(fox):
    assert len(fox.names) == 24 and fox.vertex_count == 1728
    assert fox.unit == "cm"
    assert all(fox.parents[j] < j for j in range(1, 24))
    head = fox.names.index("b_Head_05")
    np.testing.assert_allclose(fox.rest_positions[head], [0.0, 0.6073, 0.3615], atol=1e-3)


@needs_fox
def test_the_fox_legs_are_mapped_left_right_fore_hind_from_geometry_alone(fox):
    a = find_anatomy(fox.skeleton())
    n = fox.names
    assert [n[f] for f in a.feet] == ["b_LeftHand_011", "b_RightHand_08",
                                      "b_LeftFoot02_018", "b_RightFoot02_022"]
    assert [len(leg) for leg in a.legs] == [3, 3, 4, 4]
    assert (n[a.pelvis], n[a.withers], n[a.head]) == ("b_Hip_01", "b_Spine02_03", "b_Head_05")
    assert 0.4 < a.hip_height < 0.55


@needs_fox
def test_a_pose_carries_over_to_the_rig_as_world_rotation_changes(fox):
    """Rig forward kinematics with the rig's own rest translations and the local
    rotations :meth:`Rig.local_rotations` gives puts every joint where the quadsim
    skeleton's forward kinematics puts it."""
    rng = np.random.default_rng(7)
    sk = fox.skeleton()
    J = sk.n_joints
    local = matrices_from_axis_angles(rng.normal(size=(J, 3)), rng.uniform(-0.6, 0.6, J))
    root = np.array([0.3, 0.1, -0.2])
    G, P = forward_kinematics(sk, local, root)
    L = fox.local_rotations(G)
    t = fox.rest_local[:, :3, 3] * fox.scale
    W = np.empty((J, 3, 3))
    Q = np.empty((J, 3))
    W[0], Q[0] = L[0], root
    for j in range(1, J):
        p = fox.parents[j]
        W[j] = W[p] @ L[j]
        Q[j] = Q[p] + W[p] @ t[j]
    np.testing.assert_allclose(Q, P, atol=1e-9)
    np.testing.assert_allclose(fox.local_rotations(np.broadcast_to(np.eye(3), (J, 3, 3))),
                               fox.rest_local[:, :3, :3], atol=1e-9)


def test_the_unit_is_judged_from_the_standing_height():
    assert guess_unit(0.8) == "m" and guess_unit(79.0) == "cm" and guess_unit(1600.0) == "mm"
    with pytest.raises(InputError, match="no quadruped"):
        guess_unit(1e7)


def test_files_that_are_no_rig_are_refused(tmp_path):
    with pytest.raises(InputError, match="no such file"):
        read_gltf_rig(tmp_path / "missing.glb")
    bad = tmp_path / "bad.gltf"
    bad.write_text("{ not json")
    with pytest.raises(InputError, match="not a readable glTF file"):
        read_gltf_rig(bad)
    empty = tmp_path / "empty.gltf"
    empty.write_text('{"asset": {"version": "2.0"}, "nodes": [{"name": "a"}]}')
    with pytest.raises(InputError, match="has no skin"):
        read_gltf_rig(empty)
