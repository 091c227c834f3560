"""Blender imports quadsim's BVH and GLB files (optional: needs Blender's ``bpy``).

``bpy`` is large (about 1 GB) and not in the test extra, so this module is
skipped without it. To run it::

    pip install bpy && pytest tests/test_blender.py

Blender is Z-up; both of its importers turn quadsim's Y-up, +Z-forward frame
into Blender's, so a quadsim point ``(x, y, z)`` lands at ``(x, -z, y)``.
"""

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
    path = write_glb([horse, horse[:10]], tmp_path / "horse.glb")
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
