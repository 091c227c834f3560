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


# ------------------------------------------------------ writing into the model
@pytest.fixture(scope="module")
def fox_motion(fox):
    """Two seconds of the fox skeleton: legs swinging, the trunk rocking, moving forward."""
    from quadsim.skeleton.motion import Motion
    from quadsim.kinematics.rotations import quaternions_from_matrices

    sk = fox.skeleton()
    T, J, fps = 48, sk.n_joints, 24.0
    t = np.arange(T) / fps
    axes = np.zeros((T, J, 3))
    axes[..., 0] = 1.0
    angles = 0.4 * np.sin(2 * np.pi * 1.5 * t[:, None] + np.arange(J)[None, :])
    local = matrices_from_axis_angles(axes, angles)
    root = np.stack([np.zeros(T), 0.02 * np.sin(4 * t), 1.2 * t], axis=1)
    return Motion(sk, fps, root, quaternions_from_matrices(local))


def _node_world(g, node_rot, node_trans):
    """World matrices of every node with some rotations/translations replaced."""
    from quadsim.io.rig import _node_matrix

    parent = {c: i for i, n in enumerate(g.nodes) for c in (n.children or [])}
    out = {}

    def world(i):
        if i not in out:
            M = _node_matrix(g.nodes[i])
            if i in node_rot:
                x, y, z, w = node_rot[i]
                from quadsim.kinematics.rotations import matrices_from_quaternions

                s = np.linalg.norm(M[:3, :3], axis=0)
                M[:3, :3] = matrices_from_quaternions(np.array([w, x, y, z])) * s
            if i in node_trans:
                M[:3, 3] = node_trans[i]
            p = parent.get(i)
            out[i] = M if p is None else world(p) @ M
        return out[i]

    return {i: world(i) for i in range(len(g.nodes))}


@needs_fox
def test_the_motion_is_written_into_the_users_own_model(fox, fox_motion, tmp_path):
    import pygltflib

    from quadsim.io.rig_export import write_into_model

    out = write_into_model(fox, fox_motion, tmp_path / "fox_quadsim.glb")
    src = pygltflib.GLTF2().load(str(FOX))
    g = pygltflib.GLTF2().load(str(out))
    # the user's model untouched: nodes, names, skin, mesh, materials, its own animations
    assert [n.name for n in g.nodes] == [n.name for n in src.nodes]
    assert g.skins[0].joints == src.skins[0].joints
    pos = g.meshes[0].primitives[0].attributes.POSITION
    assert g.accessors[pos].count == 1728
    assert len(g.materials) == len(src.materials) and len(g.images) == len(src.images)
    assert [a.name for a in g.animations] == ["Survey", "Walk", "Run", "quadsim"]
    # the added animation puts every joint where quadsim's skeleton has it
    rot, trans = _channels(g, g.animations[-1])
    hip = int(fox.nodes[fox.names.index("b_Hip_01")])
    assert set(rot) == set(int(n) for n in fox.nodes)
    assert sorted(trans) == [int(fox.nodes[0]), hip]
    # the Fox's own animations move its hip: quadsim's holds the hip's rest translation,
    # or a viewer switching from Survey keeps Survey's hip (Blender did: 2.9 cm off)
    np.testing.assert_array_equal(trans[hip], np.tile(np.float32(src.nodes[hip].translation),
                                                      (fox_motion.n_frames, 1)))
    P = fox_motion.world_positions()
    for k in (0, 17, 47):
        got = _animated_positions(g, rot, trans, fox, k)
        np.testing.assert_allclose(got, P[k], atol=2e-5)  # float32 keys


def _channels(g, anim):
    """Rotation and translation keys of an animation, by node."""
    blob = g.binary_blob()

    def read(acc_index, width):
        acc = g.accessors[acc_index]
        view = g.bufferViews[acc.bufferView]
        start = view.byteOffset + (acc.byteOffset or 0)
        return np.frombuffer(blob[start:start + 4 * width * acc.count],
                             dtype=np.float32).reshape(acc.count, width)

    rot, trans = {}, {}
    for ch in anim.channels:
        s = anim.samplers[ch.sampler]
        if ch.target.path == "rotation":
            rot[ch.target.node] = read(s.output, 4)
        else:
            trans[ch.target.node] = read(s.output, 3)
    return rot, trans


def _animated_positions(g, rot, trans, rig, k):
    """World positions (m) of the rig's joints at key ``k``."""
    W = _node_world(g, {n: q[k] for n, q in rot.items()}, {n: v[k] for n, v in trans.items()})
    return np.array([W[int(n)][:3, 3] for n in rig.nodes]) * rig.scale


@needs_fox
def test_the_written_model_passes_the_khronos_validator(fox, fox_motion, tmp_path):
    """The Fox's own file has byteStride where the specification forbids it; the file
    quadsim writes from it must not inherit that."""
    from gltf_tools import validate

    from quadsim.io.rig_export import write_into_model

    out = write_into_model(fox, [fox_motion, fox_motion[:10]], tmp_path / "fox2.glb",
                           names=["trot", "Walk"])
    source, ours = validate(FOX, out)
    assert source["issues"]["numErrors"] > 0      # the model as it came
    issues = ours["issues"]
    errors = [m for m in issues["messages"] if m["severity"] == 0]
    assert issues["numErrors"] == 0, errors
    # warnings only where the user's own data has them (zero-weight joint indices)
    codes = {m["code"] for m in issues["messages"] if m["severity"] == 1}
    assert codes <= {m["code"] for m in source["issues"]["messages"]
                     if m["severity"] == 1}, codes
    import pygltflib

    names = [a.name for a in pygltflib.GLTF2().load(str(out)).animations]
    assert names == ["Survey", "Walk", "Run", "trot", "Walk_2"]


@needs_fox
def test_a_motion_of_another_skeleton_is_refused(fox, tmp_path):
    import quadsim
    from quadsim.io.rig_export import write_into_model

    m = quadsim.run("leopard", gait="walk", seconds=0.2)
    with pytest.raises(InputError, match="another skeleton"):
        write_into_model(fox, m, tmp_path / "x.glb")


# ------------------------------------------------------------------ adoption
@needs_fox
def test_the_fox_is_adopted_with_its_chains_and_a_report():
    import tomllib

    from quadsim.io.adopt import adopt

    a = adopt(FOX)
    assert a.spine == ("b_Hip_01", "b_Spine01_02", "b_Spine02_03")
    assert (a.neck, a.head) == (("b_Neck_04",), "b_Head_05")
    assert a.tail == ("b_Tail01_012", "b_Tail02_013", "b_Tail03_014")
    assert a.legs["LF"][-2] == "b_LeftHand_011" and a.legs["RH"][-1] == "b_RightFoot02_022"
    assert set(a.ignored) == {"_rootJoint", "b_Root_00"}
    # 22 rig joints from the pelvis down, and a toe of quadsim's own under each fore
    # "hand" (the wrist: 6.7 cm above the ground)
    assert a.skeleton.names[0] == "b_Hip_01" and a.skeleton.n_joints == 24
    assert a.legs["LF"][-1] == "b_LeftHand_011_toe"
    # the kept joints stand where the rig's stand, the ground (its lowest toe) at y = 0;
    # leg joints put in their leg's plane move by at most a few millimetres
    kept = a.skeleton.rest_positions[:len(a.rig_index)]
    rig = a.rig.rest_positions[a.rig_index] - [0.0, a.ground, 0.0]
    assert np.abs(kept - rig).max() < 0.003
    report = a.report()
    assert "leg LH (3 bones" in report and "unit cm" in report and "ignored (2)" in report
    data = tomllib.loads(a.character_toml("fox", name="Fox"))
    assert len(data["joints"]) == 24 and data["legs"]["LF"]["bend"] == "back"
    assert data["legs"]["LH"]["ik"] == "b_LeftLeg01_015"


@needs_fox
def test_the_fox_trots_in_its_own_model(tmp_path):
    """Adopted, run as a character, written into the user's own file: the Fox's mesh and
    every joint kept, trotting with planted feet, travelling forward, validating."""
    import pygltflib

    import quadsim
    from gltf_tools import validate
    from quadsim.io.adopt import adopt
    from quadsim.skeleton.contacts import foot_contacts

    a = adopt(FOX)
    path = tmp_path / "fox.toml"
    path.write_text(a.character_toml("fox", name="Fox"), encoding="utf-8")
    fox = quadsim.load_character(path)
    motion = quadsim.run(fox, gait="trot", seconds=6)
    # trotting from the feet: diagonal pairs down together, the pairs alternating
    c = foot_contacts(motion.foot_positions(), motion.fps)[120:]
    lf, rf, lh, rh = c.T
    assert (lf == rh).mean() > 0.8 and (rf == lh).mean() > 0.8 and (lf != rf).mean() > 0.5
    feet = motion.foot_positions()[120:]
    slide = max(np.ptp(feet[s:e, i][:, [0, 2]], axis=0).max()
                for i in range(4) for s, e in _runs(c[:, i]))
    height = float(np.ptp(a.rig.rest_positions[:, 1]))
    assert slide < 0.01 * height
    assert motion.root_positions[-1, 2] - motion.root_positions[0, 2] > 5.0
    out = a.write(motion, tmp_path / "fox_trot.glb", names=["trot"])
    g = pygltflib.GLTF2().load(str(out))
    src = pygltflib.GLTF2().load(str(FOX))
    assert [n.name for n in g.nodes] == [n.name for n in src.nodes]
    assert g.accessors[g.meshes[0].primitives[0].attributes.POSITION].count == 1728
    assert [an.name for an in g.animations] == ["Survey", "Walk", "Run", "trot"]
    # the rig's own joints follow: where quadsim put them (legs projected into their
    # planes by millimetres), the ground back at the rig's own height
    rot, trans = _channels(g, g.animations[-1])
    P = motion.world_positions()
    mine = [motion.skeleton.names.index(n) for n in a.rig.names if n in motion.skeleton.names]
    theirs = [j for j, n in enumerate(a.rig.names) if n in motion.skeleton.names]
    for k in (0, 150, 359):
        got = _animated_positions(g, rot, trans, a.rig, k)[theirs]
        np.testing.assert_allclose(got - [0.0, a.ground, 0.0], P[k, mine], atol=0.005)
    assert validate(out)[0]["issues"]["numErrors"] == 0


def _runs(mask):
    m = np.concatenate([[False], mask, [False]]).astype(np.int8)
    return list(zip(np.flatnonzero(np.diff(m) == 1), np.flatnonzero(np.diff(m) == -1)))


@needs_fox
def test_quadsim_rig_then_run_writes_into_the_users_model(tmp_path, capsys):
    """`quadsim rig` writes a character referring to the model; `quadsim run` of it to a
    .glb gives the model with a trot added."""
    import pygltflib

    from quadsim.cli import main

    char = tmp_path / "chars" / "fox.toml"
    assert main(["rig", str(FOX), "--out", str(char)]) == 0
    out = capsys.readouterr().out
    assert "leg LH (3 bones" in out and f"wrote {char}" in out
    glb = tmp_path / "fox_trot.glb"
    assert main(["run", str(char), "--gait", "trot", "--seconds", "2", "--out", str(glb)]) == 0
    g = pygltflib.GLTF2().load(str(glb))
    assert len(g.nodes) == 26 and [a.name for a in g.animations][-1] == "trot"
    assert g.accessors[g.meshes[0].primitives[0].attributes.POSITION].count == 1728


def test_quadsim_rig_refuses_what_it_cannot_adopt(tmp_path, capsys):
    from quadsim.cli import main

    assert main(["rig", str(tmp_path / "none.glb")]) == 2
    assert "no such file" in capsys.readouterr().err
    assert main(["rig", str(tmp_path / "x.fbx")]) == 2
    assert "reads .gltf, .glb or .bvh" in capsys.readouterr().err
