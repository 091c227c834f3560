"""Packed plans moved as a whole: placing a clip, taking out its travel, closing its loop.

A packed plan row (:mod:`quadsim.locomotion.pose_kernel`) holds the world
positions of the root and the four foot targets and the heading; every other
value is relative to the body. The posing is the same for a plan turned about
+Y and moved along the ground, so a clip is placed, or its travel taken out,
on the plans before they are posed -- the legs' IK then meets the moved foot
targets exactly, and root motion and in-place twins come from one simulation.

Rotations are about +Y (heading 0 faces +Z, positive turns towards +X); lengths in
metres, angles in radians.
"""

from __future__ import annotations

import numpy as np

from quadsim.locomotion.pose_kernel import FEET, FOOT_YAW, HEADING, ROOT
from quadsim.skeleton.motion import Motion

__all__ = ["close_loop", "closure", "in_place", "on_path", "place", "pose_rows", "turn"]

_X = [ROOT] + [FEET + 3 * i for i in range(4)]
_Z = [c + 2 for c in _X]


def turn(rows: np.ndarray, angle, shift=(0.0, 0.0)) -> np.ndarray:
    """Plans turned by ``angle`` (rad, scalar or per row) about +Y through the origin, then
    moved by ``shift`` (x, z) (m, or per row (T, 2)); a new array."""
    rows = np.array(rows, dtype=float)
    a = np.broadcast_to(np.asarray(angle, dtype=float), rows.shape[:1])[:, None]
    s = np.broadcast_to(np.asarray(shift, dtype=float), rows.shape[:1] + (2,))
    c, n = np.cos(a), np.sin(a)
    x, z = rows[:, _X], rows[:, _Z]
    rows[:, _X] = c * x + n * z + s[:, :1]
    rows[:, _Z] = -n * x + c * z + s[:, 1:]
    rows[:, HEADING] += a[:, 0]
    rows[:, FOOT_YAW:FOOT_YAW + 4] += a
    return rows


def place(rows: np.ndarray, frame: int = 0) -> np.ndarray:
    """Plans moved so that ``frame``'s root stands above the origin facing +Z."""
    r = rows[frame]
    back = turn(rows, 0.0, (-r[ROOT], -r[ROOT + 2]))
    return turn(back, -r[HEADING])


def in_place(rows: np.ndarray) -> np.ndarray:
    """Every row seen from its own root and heading: the root above the origin facing
    +Z in every frame, the feet where they stand relative to it (a treadmill)."""
    back = turn(rows, 0.0, -rows[:, [ROOT, ROOT + 2]])
    return turn(back, -rows[:, HEADING])


def on_path(local: np.ndarray, path: np.ndarray) -> np.ndarray:
    """In-place plans (:func:`in_place`) put back on the root path and headings of
    ``path`` (plans of the same frames)."""
    return turn(local, path[:, HEADING], path[:, [ROOT, ROOT + 2]])


def closure(rows: np.ndarray) -> float:
    """How far a loop's last plan is from its first once the travel is taken out: the
    largest change of any value (m or rad)."""
    ip = in_place(rows[[0, -1]])
    return float(np.abs(ip[-1] - ip[0]).max())


def close_loop(local: np.ndarray) -> tuple[np.ndarray, float]:
    """In-place plans of a loop (first and last rows one loop apart) with the gap between
    the last and the first spread evenly over the loop, the last row then exactly the
    first; and the gap (the largest value, m or rad)."""
    local = np.array(local, dtype=float)
    gap = local[0] - local[-1]
    k = np.linspace(0.0, 1.0, len(local))[:, None]
    local += k * gap
    local[-1] = local[0]
    return local, float(np.abs(gap).max())


def pose_rows(character, rows: np.ndarray, fps: float, *, contacts=None, gaits=None,
              extras=None) -> Motion:
    """The :class:`~quadsim.skeleton.motion.Motion` of packed plans, a frame per row at
    ``fps``, posed by the character's posing kernel."""
    from quadsim.kinematics.rotations import quaternions_from_matrices
    from quadsim.locomotion.tables import character_plan

    poser = character_plan(character).poser
    local, _, err = poser.pose_packed(np.ascontiguousarray(rows))
    ex = {"ik_error": err}
    ex.update(extras or {})
    return Motion(character.skeleton, fps, rows[:, ROOT:ROOT + 3].copy(),
                  quaternions_from_matrices(local), contacts=contacts, gaits=gaits,
                  foot_joints=character.foot_joints, extras=ex)
