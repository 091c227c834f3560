"""Blender opens a clip set (`quadsim clips`) with every clip as an action (needs ``bpy``).

Skipped without Blender's Python module (the ``blender`` extra, Python 3.11; see
tests/test_blender.py). The dog cub's and the horse's sets, the Khronos Fox adopted
with `quadsim rig` (when ``../shared/assets/fox`` is there) and a set written as
``.fbx`` through Blender and read back.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from quadsim.cli import main  # noqa: E402

FOX = Path(__file__).resolve().parents[2] / "shared" / "assets" / "fox" / "Fox.gltf"


def _open(path, fps):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.context.scene.render.fps = int(fps)   # the glTF importer keys seconds at this rate
    importer = bpy.ops.import_scene.fbx if str(path).endswith(".fbx") else \
        bpy.ops.import_scene.gltf
    assert importer(filepath=str(path)) == {"FINISHED"}
    return {a.name: tuple(a.frame_range) for a in bpy.data.actions}


def _sidecar(path):
    return json.loads(Path(path).with_suffix(".json").read_text())["clips"]


@pytest.mark.slow
@pytest.mark.parametrize("character", ["dog_cub", "horse"])
def test_blender_opens_every_clip_of_the_set_as_an_action(character, tmp_path):
    out = tmp_path / f"{character}.glb"
    assert main(["clips", character, "--out", str(out)]) == 0
    actions = _open(out, 60)
    clips = _sidecar(out)
    assert set(actions) == {c["name"] for c in clips}
    for c in clips:
        # key times are float32 seconds: frame 254 comes back as 253.99998
        assert actions[c["name"]] == pytest.approx((0.0, c["frames"] - 1), abs=1e-3), \
            c["name"]
    arm = [o for o in bpy.data.objects if o.type == "ARMATURE"]
    assert len(arm) == 1


def test_a_loop_as_blender_plays_it_ends_where_it_began_carried_on(tmp_path):
    """The walk loops, posed by Blender at their first and last frames: every bone's head
    at the last frame is the first frame's moved by the loop's travel (in place, the
    same within 0.1 mm), the travel carried by the ``root`` bone on the ground."""
    out = tmp_path / "walk.glb"
    assert main(["clips", "dog_cub", "--gaits", "walk", "--turn-rates", "30",
                 "--out", str(out)]) == 0
    clips = {c["name"]: c for c in _sidecar(out)}
    _open(out, 60)
    arm = [o for o in bpy.data.objects if o.type == "ARMATURE"][0]
    scene = bpy.context.scene
    for name in ("walk_0.5_inplace", "walk_turn_left_30"):
        arm.animation_data.action = bpy.data.actions[name]
        last = clips[name]["frames"] - 1
        heads = []
        for f in (0, last):
            scene.frame_set(f)
            heads.append(np.array([list(arm.matrix_world @ b.head) for b in arm.pose.bones]))
        first, end = heads
        ground = [b.name for b in arm.pose.bones].index("root")   # carries the travel
        assert abs(first[ground, 2]) < 1e-5 and abs(end[ground, 2]) < 1e-5, name
        if name.endswith("_inplace"):
            assert np.abs(end[ground]).max() < 1e-5, name
            assert np.abs(end - first).max() < 1e-4, name
        else:
            # Blender is Z-up: quadsim's turn about +Y is a turn about +Z here
            a = np.radians(clips[name]["turn_rate_deg_s"]) * clips[name]["duration_s"] \
                * clips[name]["time_scale"]
            c, s = np.cos(a), np.sin(a)
            rot = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
            r0, r1 = first[0].copy(), end[0].copy()
            r0[2] = r1[2] = 0.0
            # the root joint's head is the first bone's: compare every joint relative to it
            moved = (first - r0) @ rot.T + r1
            assert np.abs(moved[:, :2] - end[:, :2]).max() < 2e-3, name


@pytest.mark.skipif(not FOX.is_file(), reason="the Fox test rig is not on this machine "
                    "(../shared/assets/fox/Fox.gltf)")
def test_the_fox_clip_set_opens_in_blender_as_the_fox_with_every_clip(tmp_path):
    fox = tmp_path / "fox.toml"
    assert main(["rig", str(FOX), "--out", str(fox)]) == 0
    out = tmp_path / "fox_clips.glb"
    assert main(["clips", str(fox), "--gaits", "walk,trot", "--out", str(out)]) == 0
    actions = _open(out, 60)
    clips = _sidecar(out)
    assert set(actions) == {"Survey", "Walk", "Run"} | {c["name"] for c in clips}
    meshes = [o for o in bpy.data.objects if o.type == "MESH"]
    assert meshes, "the Fox's own mesh"


def test_a_set_written_as_fbx_reads_back_with_every_clip_as_a_take(tmp_path):
    out = tmp_path / "cub.fbx"
    assert main(["clips", "dog_cub", "--gaits", "walk", "--out", str(out)]) == 0
    actions = _open(out, 60)
    clips = _sidecar(out)
    # Blender names a take <armature>|<action>; reading it back adds the armature again
    taken = {name.rsplit("|", 1)[-1]: rng for name, rng in actions.items()}
    assert set(taken) == {c["name"] for c in clips}
    for c in clips:
        lo, hi = taken[c["name"]]
        assert hi - lo == pytest.approx(c["frames"] - 1, abs=1.0), c["name"]
