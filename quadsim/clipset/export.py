"""Writing a clip set: one ``.glb`` (or ``.fbx``) of named animations and its ``.json`` sidecar.

- ``.glb``: quadsim's own characters as :func:`quadsim.io.gltf.write_glb` writes them
  (skinned body, one animation per clip) with a ``root`` node on the ground for the
  engines' root motion (``ground_root``); a character adopted from the user's own
  glTF model (``quadsim rig``) as that model with every clip added as an animation
  (:func:`quadsim.io.adopt.write_for_character`).
- ``.fbx``: the ``.glb`` opened by Blender (its Python module ``bpy``, the
  ``blender`` extra) and exported with every animation baked as a take (Blender
  names a take ``<armature>|<clip>``).
- The sidecar, ``SET.json`` beside ``SET.glb``: the set (character, frame rate, axes,
  joints, conventions) and per clip what it is and what was measured of it
  (:mod:`quadsim.clipset.measure`), in the file's animation order.

Both files are written whole or not at all.
"""

from __future__ import annotations

import json
import math
import os
import sys
from contextlib import contextmanager
import tempfile
from pathlib import Path

from quadsim.errors import InputError

__all__ = ["FORMATS", "sidecar", "write_clip_set"]

#: What ``write_clip_set`` writes, by extension.
FORMATS = (".glb", ".fbx")

#: The node that carries a clip's travel in quadsim's own characters' files.
_GROUND = "root"

_CONVENTIONS = {
    "root_motion": "quadsim's own characters: the node 'root' (the scene root, on the "
                   "ground under the root joint, turned to the heading) carries each clip's "
                   "travel and turn; the root joint below it bobs and sways. A user's "
                   "model: its own top joint carries them.",
    "axes": "+Y up, +Z forward (the character faces +Z at frame 0 of every clip), metres",
    "legs": ["LF", "RF", "LH", "RH"],
    "phase_origin": "frame 0 of every loop, start, stop and transition is a left hind (LH) "
                    "touchdown; phases are stride fractions after it",
    "loops": "frames 0..N: frame N is frame 0 carried on by the loop's travel (in place: "
             "frame 0 itself); play 0..N-1 and wrap, or hold the last key as the wrap",
    "speeds": "clip names carry the commanded speed (m/s, one decimal); native_speed_mps "
              "is measured from the clip: time-scale a clip by (speed wanted) / "
              "native_speed_mps",
}


def _number(x):
    if isinstance(x, float):
        return round(x, 6) if math.isfinite(x) else None
    return x


def _clean(d: dict) -> dict:
    out = {}
    for k, v in d.items():
        if isinstance(v, dict):
            out[k] = _clean(v)
        elif v is not None:
            out[k] = _number(v)
    return out


def _entry(index: int, clip, figures: dict, fps: float) -> dict:
    info = dict(clip.info)
    T = clip.frames
    e = {"index": index, "name": clip.name, "kind": clip.kind, "gait": info.pop("gait"),
         "to_gait": info.pop("to_gait", None), "speed_mps": info.pop("speed"),
         "to_speed_mps": info.pop("to_speed", None),
         "turn_rate_deg_s": info.pop("turn_rate_deg_s", 0.0), "loop": clip.loop,
         "root_motion": clip.root_motion, "frame_range": [0, T - 1], "frames": T,
         "duration_s": (T - 1) / fps}
    figures = dict(figures)
    e["native_speed_mps"] = figures.pop("mean_speed_mps", None)
    for k in ("stride_length_m", "stride_frequency_hz", "duty_factors", "phases"):
        e[k] = figures.pop(k, None)
    e.update(figures)
    e.update(info)
    return _clean(e)


def sidecar(character, plan, made, file_name: str) -> dict:
    """The sidecar of a set (see the module's notes)."""
    from quadsim.api import model_of
    from quadsim.io.gltf import _generator

    model = model_of(character)
    own = model is None or model.suffix.lower() == ".bvh"
    return {
        "generator": _generator(), "character": character.id,
        "model": None if model is None else str(model), "file": file_name,
        "fps": plan.fps, "root_joint": character.skeleton.names[0],
        "root_motion_node": _GROUND if own else character.skeleton.names[0],
        "foot_joints": list(character.foot_joints), **_CONVENTIONS,
        "clips": [_entry(i, c, f, plan.fps) for i, (c, f) in enumerate(made)],
    }


def _write_glb(character, motions, names, path: Path) -> None:
    from quadsim.api import model_of

    model = model_of(character)
    if model is not None and model.suffix.lower() != ".bvh":
        from quadsim.io.adopt import write_for_character

        write_for_character(character, motions, path, names=names)
    else:
        from quadsim.io.gltf import write_glb

        write_glb(motions, path, names=names, ground_root=True)


def require_bpy():
    """Blender's Python module, or an InputError saying how to get it."""
    from quadsim._optional import require

    return require("bpy", "`quadsim clips` to .fbx (through Blender)", extra="blender")


@contextmanager
def _quiet():
    """Blender's own printing (to the process's standard output) kept off ours."""
    sys.stdout.flush()
    try:
        fd = sys.stdout.fileno()
    except (AttributeError, OSError, ValueError):   # no real file (captured): leave it
        yield
        return
    saved = os.dup(fd)
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), fd)
            yield
    finally:
        sys.stdout.flush()
        os.dup2(saved, fd)
        os.close(saved)


def _write_fbx(character, motions, names, path: Path, fps: float) -> None:
    bpy = require_bpy()
    from quadsim.io.atomic import atomic_write_bytes

    with tempfile.TemporaryDirectory(prefix="quadsim-clips-") as d, _quiet():
        glb, fbx = Path(d) / "set.glb", Path(d) / "set.fbx"
        _write_glb(character, motions, names, glb)
        bpy.ops.wm.read_factory_settings(use_empty=True)
        scene = bpy.context.scene
        scene.render.fps = max(int(round(fps)), 1)
        scene.render.fps_base = scene.render.fps / fps
        if bpy.ops.import_scene.gltf(filepath=str(glb)) != {"FINISHED"}:
            raise InputError(f"{path}: Blender could not read the clip set it was given")
        for action in bpy.data.actions:
            action.use_fake_user = True
        result = bpy.ops.export_scene.fbx(
            filepath=str(fbx), bake_anim=True, bake_anim_use_all_actions=True,
            bake_anim_use_nla_strips=False, bake_anim_force_startend_keying=True,
            bake_anim_simplify_factor=0.0, add_leaf_bones=False, axis_forward="-Z",
            axis_up="Y")
        if result != {"FINISHED"} or not fbx.is_file():
            raise InputError(f"{path}: Blender's FBX exporter failed")
        atomic_write_bytes(path, fbx.read_bytes())


def write_clip_set(character, plan, made, path) -> tuple[Path, Path]:
    """Write the clips ``made`` (:func:`~quadsim.clipset.build.make_clip_set`) to ``path``
    (``.glb`` or ``.fbx``) and the sidecar beside it (``.json``).

    Returns
    -------
    (Path, Path)
        The animation file and the sidecar.

    Raises
    ------
    InputError
        Another extension, a folder as ``path``, ``.fbx`` without Blender's module.
    """
    from quadsim.io.atomic import atomic_write

    path = Path(path)
    ext = path.suffix.lower()
    if ext not in FORMATS:
        raise InputError(f"`--out` {str(path)!r}: a clip set is written as "
                         f"{' or '.join(FORMATS)}")
    if path.is_dir():
        raise InputError(f"`--out` {str(path)!r} is a folder; give a file name")
    motions = [c.motion for c, _ in made]
    names = [c.name for c, _ in made]
    path.parent.mkdir(parents=True, exist_ok=True)
    if ext == ".fbx":
        _write_fbx(character, motions, names, path, plan.fps)
    else:
        _write_glb(character, motions, names, path)
    side = path.with_suffix(".json")
    text = json.dumps(sidecar(character, plan, made, path.name), indent=1,
                      allow_nan=False) + "\n"
    atomic_write(side, lambda f: f.write(text))
    return path, side

