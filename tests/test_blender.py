"""Blender imports quadsim's BVH and GLB files (optional: needs Blender's ``bpy``).

``bpy`` is large (about 1 GB, Python 3.11) and not in the test extra, so this
module is skipped without it. To run it::

    pip install -e ".[test,blender]" && pytest tests/test_blender.py

Blender is Z-up; both of its importers turn quadsim's Y-up, +Z-forward frame
into Blender's, so a quadsim point ``(x, y, z)`` lands at ``(x, -z, y)``.

Besides quadsim's own characters, the user's own rigs: the Khronos Fox (when
``../shared/assets/fox`` is there), rigs of :mod:`rig_builders` (Blender names in
a +Z-up centimetre glTF; a cat under an armature node scaled by 0.01) and an
armature built with ``bpy`` and exported by Blender's glTF exporter are adopted
(`quadsim rig`) and run (`quadsim run ... --gait trot --seconds 4`); Blender opens
the ``.glb`` as the user's model with a ``trot`` action and the ``.bvh`` as the
user's hierarchy, the feet where quadsim's motion puts them.
"""

from pathlib import Path

import numpy as np
import pytest

from quadsim.io.bvh import write_bvh
from quadsim.io.gltf import write_glb
from quadsim.locomotion import Command, simulate
from quadsim.skeleton.character import load_character

bpy = pytest.importorskip("bpy")

#: Joint positions read back from Blender must match the motion within this (m).
TOL = 1e-4
FRAMES = (0, 17, 59)


@pytest.fixture(scope="module")
def horse():
    return simulate(load_character("horse"), Command(speed=1.0), 2.0, 30)


@pytest.fixture
def scene():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    return bpy.context.scene


def blender_point(p):
    """quadsim (x, y, z) in Blender's Z-up frame."""
    return np.array([p[0], -p[2], p[1]])


def armature():
    arms = [o for o in bpy.data.objects if o.type == "ARMATURE"]
    assert len(arms) == 1
    return arms[0]


def max_joint_error(scene, arm, motion, frame_of):
    P = motion.world_positions()
    err = 0.0
    for f in FRAMES:
        scene.frame_set(frame_of(f))
        for j, name in enumerate(motion.skeleton.names):
            head = np.array(arm.matrix_world @ arm.pose.bones[name].head)
            err = max(err, float(np.abs(head - blender_point(P[f, j])).max()))
    return err


@pytest.mark.parametrize("units, scale", [("m", 1.0), ("cm", 0.01)])
def test_blender_imports_the_bvh(horse, scene, tmp_path, units, scale):
    path = write_bvh(horse, tmp_path / "horse.bvh", units=units)
    result = bpy.ops.import_anim.bvh(filepath=str(path), global_scale=scale, frame_start=1,
                                     use_fps_scale=False, update_scene_fps=True,
                                     rotate_mode="NATIVE", axis_forward="-Z", axis_up="Y")
    assert result == {"FINISHED"}
    arm = armature()
    assert len(arm.data.bones) == horse.skeleton.n_joints
    assert {b.name for b in arm.data.bones} == set(horse.skeleton.names)
    assert tuple(arm.animation_data.action.frame_range) == (1.0, float(len(horse)))
    assert scene.render.fps / scene.render.fps_base == horse.fps
    assert max_joint_error(scene, arm, horse, lambda f: f + 1) < TOL


def test_blender_imports_the_glb(horse, scene, tmp_path):
    path = write_glb([horse, horse[-10:]], tmp_path / "horse.glb")   # both walk
    scene.render.fps = int(horse.fps)   # the glTF importer keys seconds at the scene's rate
    assert bpy.ops.import_scene.gltf(filepath=str(path)) == {"FINISHED"}
    arm = armature()
    assert len(arm.data.bones) == horse.skeleton.n_joints
    assert {b.name for b in arm.data.bones} == set(horse.skeleton.names)
    ranges = {a.name: tuple(a.frame_range) for a in bpy.data.actions}
    assert ranges == {"walk": (0.0, len(horse) - 1.0), "walk_2": (0.0, 9.0)}
    body = bpy.data.objects["body"]
    assert body.type == "MESH" and body.parent == arm
    assert any(mod.type == "ARMATURE" for mod in body.modifiers)
    assert len(body.vertex_groups) > 0
    assert arm.animation_data.action.name == "walk"
    assert max_joint_error(scene, arm, horse, lambda f: f) < TOL


# ------------------------------------------------------------ the user's own rig
#: ../shared/assets/fox beside the checkout (test material, not part of the project)
FOX = Path(__file__).resolve().parents[2] / "shared" / "assets" / "fox" / "Fox.gltf"

#: The feet, spine and head posed by Blender must stand where quadsim's motion puts
#: them within this (m). The file keeps the user's own bone offsets while quadsim's
#: adopted skeleton may set a leg's top in the leg's plane (the built dog's scapula
#: heads stand 8 mm apart in the rig and in quadsim's skeleton), so the
#: paws below differ by that difference turned with the leg: 0.7 mm measured. The
#: character file's offsets have six significant digits and the glTF file float32
#: (about 1e-6 m at 10 m from the origin in centimetres). 2 mm is still 14 times
#: finer than the 2.9 cm the Fox's hip was off before its held rest translation.
RIG_TOL = 2e-3
RIG_FRAMES = (0, 45, 130, 239)          # standing, starting, trotting, last frame


def blender_to_gltf(v):
    """A Blender (Z-up) point back in the glTF or BVH file's own frame (both of Blender's
    importers turn the file's +Y up into +Z: (x, y, z) -> (x, -z, y))."""
    v = np.asarray(v, float)
    return np.array([v[0], v[2], -v[1]])


def users_rig(model, folder):
    """`quadsim rig MODEL --out CHAR.toml`, `quadsim run CHAR.toml --gait trot
    --seconds 4 --out` both .glb and .bvh; the rig as quadsim read it and the motion
    (joint positions in the rig file's world frame and units) by joint name."""
    import quadsim
    from quadsim.cli import main
    from quadsim.io.adopt import adopt

    char = Path(folder) / f"{Path(model).stem}.toml"
    assert main(["rig", str(model), "--out", str(char)]) == 0
    out = {}
    for ext in (".glb", ".bvh"):
        out[ext] = folder / f"{Path(model).stem}_trot{ext}"
        assert main(["run", str(char), "--gait", "trot", "--seconds", "4",
                     "--out", str(out[ext])]) == 0
    a = adopt(model)
    rig = a.rig
    character = quadsim.load_character(char)
    motion = quadsim.run(character, gait="trot", seconds=4)
    sk = motion.skeleton
    off = rig.rest_positions[rig.names.index(sk.names[0])] - sk.rest_positions[0]
    P = (motion.world_positions() + off) @ rig.axes / rig.scale     # file frame and units
    tracked = [*a.spine, a.head, *users_feet(a)]
    where = {n: P[:, k] for k, n in enumerate(sk.names) if n in tracked}
    return rig, out, where, motion


def users_feet(adoption):
    """The rig's foot joint of each leg (LF, RF, LH, RH) as adopted."""
    from quadsim.io.adopt import rig_foot

    return [rig_foot(adoption.legs[leg]) for leg in ("LF", "RF", "LH", "RH")]


def max_position_error(scene, arm, rig, where, names, frame_of):
    """Largest distance (m, any axis) between a joint's head as Blender poses it and
    where quadsim's motion puts it, over RIG_FRAMES and ``names``."""
    err = 0.0
    for f in RIG_FRAMES:
        scene.frame_set(frame_of(f))
        for n in names:
            head = blender_to_gltf(arm.matrix_world @ arm.pose.bones[n].head)
            err = max(err, float(np.abs(head - where[n][f]).max()) * rig.scale)
    return err


def blender_model(path, fps=None):
    """Import a glTF file in an empty scene: its armature, mesh objects and materials."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    if fps is not None:
        bpy.context.scene.render.fps = int(fps)
    assert bpy.ops.import_scene.gltf(filepath=str(path)) == {"FINISHED"}
    arm = armature()
    meshes = {o.name: o for o in bpy.data.objects
              if o.type == "MESH" and o.find_armature() is not None}
    return arm, meshes


def rest_of(arm):
    """Every bone's rest matrix in the world and its parent's name."""
    return {b.name: (np.array(arm.matrix_world @ b.matrix_local),
                     b.parent.name if b.parent else None) for b in arm.data.bones}


def check_glb_is_the_users_model(model, out, rig, where, motion):
    """The output opened in Blender is the user's model (armature, bones, rest pose,
    meshes skinned to it, materials, its own actions) plus quadsim's trot, which puts
    every rig joint where the motion does. Returns the joint error (m)."""
    arm0, meshes0 = blender_model(model)
    rest0, actions0 = rest_of(arm0), {a.name for a in bpy.data.actions}
    verts0 = {n: np.array([v.co for v in o.data.vertices]) for n, o in meshes0.items()}
    mats0 = {n: [m.name for m in o.data.materials] for n, o in meshes0.items()}
    groups0 = {n: sorted(g.name for g in o.vertex_groups) for n, o in meshes0.items()}

    arm, meshes = blender_model(out, fps=motion.fps)
    assert sorted(b.name for b in arm.data.bones) == sorted(rig.names)   # all of them
    rest = rest_of(arm)
    assert rest.keys() == rest0.keys()
    for name, (M, parent) in rest.items():
        assert parent == rest0[name][1], name
        np.testing.assert_allclose(M, rest0[name][0], atol=1e-6 * max(1.0, 1 / rig.scale))
    assert meshes.keys() == meshes0.keys() and meshes
    for name, o in meshes.items():
        np.testing.assert_array_equal(np.array([v.co for v in o.data.vertices]), verts0[name])
        assert [m.name for m in o.data.materials] == mats0[name]
        assert sorted(g.name for g in o.vertex_groups) == groups0[name]
        assert set(groups0[name]) <= set(rig.names)
        assert [m.object for m in o.modifiers if m.type == "ARMATURE"] == [arm]
    added = {a.name for a in bpy.data.actions} - actions0
    assert added == {"trot"}
    # the importer leaves the model's first animation active; the user picks quadsim's
    arm.animation_data.action = bpy.data.actions["trot"]
    assert tuple(bpy.data.actions["trot"].frame_range) == (0.0, len(motion) - 1.0)
    moved = [n for n in rig.names if n in where]
    err = max_position_error(bpy.context.scene, arm, rig, where, moved, lambda f: f)
    # every joint, those quadsim does not move too (root, face, helpers), stands where
    # the file as read without Blender puts it
    from rig_builders import animated_positions

    index, P, _ = animated_positions(out)
    every = {n: P[:, index[n]] for n in rig.names}
    assert max_position_error(bpy.context.scene, arm, rig, every, rig.names,
                              lambda f: f) < 1e-5
    return err


def check_bvh_is_the_users_hierarchy(out, rig, where, motion):
    """The .bvh opened in Blender is one armature with the user's joints (names and
    parents) at their rest offsets, moving as the motion does. Returns the joint error (m)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    assert bpy.ops.import_anim.bvh(filepath=str(out), global_scale=1.0, frame_start=1,
                                   use_fps_scale=False, update_scene_fps=True,
                                   rotate_mode="NATIVE", axis_forward="-Z",
                                   axis_up="Y") == {"FINISHED"}
    arm = armature()
    bones = arm.data.bones
    assert len(bones) == len(rig.names)
    for j, name in enumerate(rig.names):
        p = rig.parents[j]
        assert (bones[name].parent.name if bones[name].parent else None) == \
            (rig.names[p] if p >= 0 else None), name
        rest = blender_to_gltf(arm.matrix_world @ bones[name].head_local)
        np.testing.assert_allclose(rest, rig.rest_world[j, :3, 3], atol=2e-6 / rig.scale)
    assert bpy.context.scene.render.fps / bpy.context.scene.render.fps_base == motion.fps
    moved = [n for n in rig.names if n in where]
    return max_position_error(bpy.context.scene, arm, rig, where, moved, lambda f: f + 1)


def feet_travel(rig, where, feet):
    """How far (m) each foot goes forward in the motion: posing must move them."""
    return [float(np.abs(where[f][-1] - where[f][0]).max()) * rig.scale for f in feet]


def _record(key, **values):
    """What Blender showed (printed; see it with ``pytest -s``)."""
    print(key, values)


@pytest.mark.skipif(not FOX.is_file(), reason="the Fox test rig is not on this machine "
                    "(../shared/assets/fox/Fox.gltf)")
def test_the_fox_run_by_quadsim_opens_in_blender_as_the_fox(tmp_path):
    """The Khronos Fox (24 bones, Survey/Walk/Run, one textured mesh), adopted and run:
    Blender opens the .glb as the Fox with a "trot" action whose every joint stands
    where quadsim's motion puts it -- also right after the Fox's own Survey (which keys
    the hip's translation) was playing -- and the .bvh as the Fox's 24-joint hierarchy."""
    rig, out, where, motion = users_rig(FOX, tmp_path)
    err = check_glb_is_the_users_model(FOX, out[".glb"], rig, where, motion)
    assert {a.name for a in bpy.data.actions} == {"Survey", "Walk", "Run", "trot"}
    assert err < RIG_TOL
    bvh = check_bvh_is_the_users_hierarchy(out[".bvh"], rig, where, motion)
    assert bvh < RIG_TOL
    from quadsim.io.adopt import adopt

    feet = users_feet(adopt(FOX))
    assert set(feet) <= set(where)
    assert min(feet_travel(rig, where, feet)) > 2.0       # ~3 m forward in 4 s
    _record("fox", bones=len(rig.names), glb_error_m=err, bvh_error_m=bvh)


#: Rigs of tests/rig_builders.py: Blender names in a +Z-up centimetre glTF, and a
#: cat with ``LeftThigh`` names under an armature node scaled by 0.01.
BUILT = [("blender_dog", dict(style="blender", hind_bones=3, scapula=True, whiskers=3),
          ".glb", "Z", "cm"),
         ("cat", dict(style="camel", hip=0.28, hind_bones=2, scapula=False, toes=3,
                      whiskers=6), ".gltf", "Z", "scale")]


@pytest.mark.parametrize("name, build, fmt, up, unit", BUILT, ids=[b[0] for b in BUILT])
def test_a_built_rig_run_by_quadsim_opens_in_blender_as_that_rig(tmp_path, name, build,
                                                                 fmt, up, unit):
    from rig_builders import quadruped, write_gltf

    spec = quadruped(name, **build)
    model = write_gltf(spec, tmp_path / f"{name}{fmt}", up=up, unit=unit)
    rig, out, where, motion = users_rig(model, tmp_path)
    assert set(rig.names) == set(spec.names)
    err = check_glb_is_the_users_model(model, out[".glb"], rig, where, motion)
    assert err < RIG_TOL
    bvh = check_bvh_is_the_users_hierarchy(out[".bvh"], rig, where, motion)
    assert bvh < RIG_TOL
    feet = [spec.expect[leg][1] for leg in ("LF", "RF", "LH", "RH")]
    assert min(feet_travel(rig, where, feet)) > 4.0 * build.get("hip", 0.5)
    _record(name, bones=len(rig.names), glb_error_m=err, bvh_error_m=bvh)


def build_armature_in_blender(spec, path):
    """A quadruped built the way a Blender user builds one, exported by Blender's glTF
    exporter: an armature of bones (head at each joint of ``spec``, tail at its first
    child's head, connected where they meet; a leaf's tail carries on from its parent,
    a foot's runs forward along the ground), Z-up, facing -Y, metres; a mesh of one
    box per bone with a vertex group per bone, an Armature modifier and a material."""
    from rig_builders import TO_Z_UP

    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    data = bpy.data.armatures.new("Armature")
    arm = bpy.data.objects.new("Armature", data)
    scene.collection.objects.link(arm)
    bpy.context.view_layer.objects.active = arm
    pos = {n: TO_Z_UP @ p for n, _, p in spec.joints}
    kids = {n: [c for c, p, _ in spec.joints if p == n] for n, _, _ in spec.joints}
    bpy.ops.object.mode_set(mode="EDIT")
    for n, parent, _ in spec.joints:
        b = data.edit_bones.new(n)
        b.head = pos[n]
        if kids[n]:
            tail = pos[kids[n][0]]
        elif pos[n][2] < 1e-6:
            tail = pos[n] + [0.0, -0.04, 0.0]                  # a toe along the ground
        else:
            tail = pos[n] + 0.5 * (pos[n] - pos[parent])
        b.tail = tail
        if parent is not None:
            b.parent = data.edit_bones[parent]
            b.use_connect = bool(np.allclose(data.edit_bones[parent].tail, b.head))
    bpy.ops.object.mode_set(mode="OBJECT")
    verts, faces, owner = [], [], []
    for b in data.bones:
        head, tail = np.array(b.head_local), np.array(b.tail_local)
        r = 0.1 * np.linalg.norm(tail - head)
        base = len(verts)
        for end in (head, tail):
            for dx, dy in ((-r, -r), (r, -r), (r, r), (-r, r)):
                verts.append(tuple(end + [dx, dy, 0.0]))
                owner.append(b.name)
        faces += [(base + a, base + b_, base + c, base + d) for a, b_, c, d in
                  ((0, 1, 2, 3), (4, 7, 6, 5), (0, 4, 5, 1), (1, 5, 6, 2), (2, 6, 7, 3),
                   (3, 7, 4, 0))]
    mesh = bpy.data.meshes.new("Body")
    mesh.from_pydata(verts, [], faces)
    mesh.materials.append(bpy.data.materials.new("Fur"))
    body = bpy.data.objects.new("Body", mesh)
    scene.collection.objects.link(body)
    for k, name in enumerate(owner):
        group = body.vertex_groups.get(name) or body.vertex_groups.new(name=name)
        group.add([k], 1.0, "REPLACE")
    body.parent = arm
    body.modifiers.new("Armature", "ARMATURE").object = arm
    assert bpy.ops.export_scene.gltf(filepath=str(path), export_format="GLB") == {"FINISHED"}
    return path


def test_an_armature_built_and_exported_in_blender_comes_back_trotting(tmp_path):
    """Bones made with bpy (``thigh.L``, ``spine.001``, ``f_toe.R``..., Z-up), exported
    by Blender as .glb, adopted by `quadsim rig` and run: re-imported, one armature
    with every bone the user made, the mesh on it, and the feet moving as quadsim's
    motion moves them."""
    from rig_builders import quadruped

    spec = quadruped("blender_made", style="blender", helpers=False, whiskers=2)
    model = build_armature_in_blender(spec, tmp_path / "blender_made.glb")
    rig, out, where, motion = users_rig(model, tmp_path)
    assert sorted(rig.names) == sorted(spec.names)
    err = check_glb_is_the_users_model(model, out[".glb"], rig, where, motion)
    assert err < RIG_TOL
    feet = [spec.expect[leg][1] for leg in ("LF", "RF", "LH", "RH")]
    assert set(feet) <= set(where)          # adopted as the feet, so compared above
    assert min(feet_travel(rig, where, feet)) > 2.0
    _record("blender_made", bones=len(rig.names), glb_error_m=err)
