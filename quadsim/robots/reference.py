"""Writing a robot reference motion: the motion-imitation JSON layout, and NPZ.

JSON (the layout motion-imitation pipelines read)::

    {"LoopMode": "Clamp", "FrameDuration": 0.016667,
     "EnableCycleOffsetPosition": true, "EnableCycleOffsetRotation": true,
     "MotionWeight": 1.0,
     "JointNames": ["FR_hip_joint", ...],
     "Frames": [[x, y, z, qx, qy, qz, qw, q_1, ..., q_J], ...]}

Each frame row is the base position (m) and orientation (quaternion x, y, z, w)
in the URDF's world frame (+Z up, the robot starting at the origin facing +X),
then the joint angles (rad) in ``JointNames`` order (the URDF's movable joints
in file order). ``LoopMode`` is ``"Clamp"``: the reference is not cut to a
whole number of strides.

NPZ holds the same (``frames``, ``joint_names``, ``frame_duration``,
``loop_mode``) and, split out, ``base_position`` (T, 3), ``base_quaternion``
(T, 4, x y z w), ``joint_angles`` (T, J), and per foot in leg order
``leg_names`` (LF, RF, LH, RH): ``foot_links`` (4,), ``foot_positions`` and
``foot_velocities`` (T, 4, 3; the foot point: the toe sphere's centre),
``foot_radius`` (4,), ``contacts`` (T, 4, bool), ``gaits`` (T,), and the
retargeting figures as ``info_<name>`` scalars.
"""

from __future__ import annotations

import io
import json
import os
from pathlib import Path

import numpy as np

from quadsim.frames import LEGS
from quadsim.io.atomic import atomic_write, atomic_write_bytes
from quadsim.robots.retarget import Retargeted

__all__ = ["FORMATS", "frames_table", "write_reference"]

#: Extensions :func:`write_reference` writes.
FORMATS = (".json", ".npz")


def frames_table(ref: Retargeted) -> np.ndarray:
    """Rows of base position, quaternion (x y z w) and joint angles, shape (T, 7 + J)."""
    return np.concatenate([ref.base_position, ref.base_quaternion, ref.joint_angles], axis=1)


def _json_text(ref: Retargeted, digits: int = 6) -> str:
    rows = np.round(frames_table(ref), digits)
    head = {"LoopMode": "Clamp", "FrameDuration": round(1.0 / ref.fps, 9),
            "EnableCycleOffsetPosition": True, "EnableCycleOffsetRotation": True,
            "MotionWeight": 1.0, "JointNames": list(ref.joint_names)}
    body = ",\n".join("    " + json.dumps([float(v) for v in r]) for r in rows)
    text = json.dumps(head, indent=2)[:-2]
    return text + ',\n  "Frames": [\n' + body + "\n  ]\n}\n"


def _npz_bytes(ref: Retargeted) -> bytes:
    arrays = {"frames": frames_table(ref), "joint_names": np.array(ref.joint_names),
              "frame_duration": np.float64(1.0 / ref.fps), "loop_mode": np.array("Clamp"),
              "base_position": ref.base_position, "base_quaternion": ref.base_quaternion,
              "joint_angles": ref.joint_angles, "leg_names": np.array(LEGS),
              "foot_links": np.array(ref.foot_links), "foot_positions": ref.foot_positions,
              "foot_velocities": ref.foot_velocities, "foot_radius": ref.foot_radius,
              "contacts": ref.contacts, "gaits": np.array(ref.gaits, dtype=str)}
    for k, v in ref.info.items():
        if isinstance(v, (int, float, np.floating)):
            arrays[f"info_{k}"] = np.float64(v)
        elif isinstance(v, str):
            arrays[f"info_{k}"] = np.array(v)
    buf = io.BytesIO()
    np.savez_compressed(buf, **arrays)
    return buf.getvalue()


def write_reference(ref: Retargeted, path: str | os.PathLike) -> Path:
    """Write ``ref`` as ``.json`` or ``.npz`` (by extension), whole or not at all.

    Raises
    ------
    ValueError
        For another extension (the command checks it first, as an InputError).
    """
    path = Path(path)
    ext = path.suffix.lower()
    if ext == ".json":
        text = _json_text(ref)
        atomic_write(path, lambda f: f.write(text))
    elif ext == ".npz":
        atomic_write_bytes(path, _npz_bytes(ref))
    else:
        raise ValueError(f"{path}: a reference is written as {' or '.join(FORMATS)}")
    return path
