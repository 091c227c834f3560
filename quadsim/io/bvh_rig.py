"""A user's rig from a BVH hierarchy, and quadsim's motion written back in it.

:func:`read_bvh_rig` reads the ``HIERARCHY`` of a BVH file (with the parser
of :mod:`quadsim.io.bvh`; the ``MOTION`` section is not needed) into a
:class:`~quadsim.io.rig.Rig`: the joints in the file's order, their OFFSETs
as rest translations (BVH rest rotations are identity), end sites and each
joint's rotation channel order, in the file's own axes and unit. The up and
forward axes are found from the shape
(:func:`~quadsim.io.rig_structure.detect_frame`) and the unit from the hip
height along the up axis -- the root's, or half the rest pose's whole height
when a root bone lies on the ground (:func:`~quadsim.io.guess.guess_units`:
above :data:`~quadsim.io.guess.CM_ABOVE` file units it is centimetres).

:func:`write_rig_bvh` writes motions of an adopted skeleton as a BVH file of
the user's own hierarchy: every joint of the rig with its name, OFFSET and End
Site as the rig has them, in the rig's axes and unit, each joint's rotation
channels in its own order (``ZXY`` for joints that had fewer than three);
joints quadsim does not move keep their rest rotation relative to their
parent. A glTF rig written so gets its rest pose as OFFSETs (rest world
position differences) and its world rotation changes as rotations.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np

from quadsim.errors import InputError, read_text_lines
from quadsim.io.atomic import atomic_write
from quadsim.io.bvh import _AXES, _CHANNELS, _parse_hierarchy, _Tokens
from quadsim.io.guess import guess_units
from quadsim.io.rig import Rig, foot_indices
from quadsim.io.rig_structure import detect_frame
from quadsim.kinematics.rotations import euler_from_matrices

__all__ = ["read_bvh_rig", "write_rig_bvh"]

def read_bvh_rig(path, feet=None) -> Rig:
    """Read the hierarchy of a BVH file as a :class:`~quadsim.io.rig.Rig`.

    Parameters
    ----------
    path : str or path-like
    feet : sequence of str, length 4, optional
        The foot joints given by hand (they decide the axes).

    Raises
    ------
    InputError
        For a missing file or a malformed hierarchy (file and line named).
    """
    path = Path(path)
    lines = read_text_lines(path)
    tok = _Tokens(lines, str(path))
    if not any(s.strip() for s in lines):
        raise tok.error(1, "empty file, expected HIERARCHY")
    joints = _parse_hierarchy(tok)
    names = tuple(j.name for j in joints)
    if len(set(names)) != len(names):
        dup = sorted({n for n in names if names.count(n) > 1})
        raise InputError(f"{path}: joint names repeat ({', '.join(dup)}); a rig's joints "
                         "need names of their own")
    parents = np.array([j.parent for j in joints], dtype=np.int64)
    J = len(joints)
    L = np.broadcast_to(np.eye(4), (J, 4, 4)).copy()
    L[:, :3, 3] = [j.offset for j in joints]
    W = L.copy()
    for k in range(1, J):
        W[k, :3, 3] = W[parents[k], :3, 3] + L[k, :3, 3]
    P = W[:, :3, 3]
    frame = detect_frame(P, names, parents, foot_indices(names, feet, path))
    h = P @ frame.axes[1]
    tips = [P[k] + j.end_site for k, j in enumerate(joints) if j.end_site is not None]
    low = min(h.min(), *(t @ frame.axes[1] for t in tips)) if tips else h.min()
    # the root's height over the lowest point, or half the rest pose's whole height
    # where the root stands lower than that (a root bone on the ground says nothing)
    unit = guess_units(max(float(h[0] - low), 0.5 * float(h.max() - low), 0.0))
    orders = []
    for jt in joints:
        o = "".join(_AXES[_CHANNELS[c.lower()][1]] for c in jt.channels
                    if _CHANNELS[c.lower()][0] == "rotation")
        orders.append(o if len(o) == 3 else "ZXY")
    ends = {j.name: np.array(j.end_site, float) for j in joints if j.end_site is not None}
    return Rig(path=path, names=names, nodes=np.arange(J), parents=parents, rest_local=L,
               rest_world=W, unit=unit, vertex_count=0, above=np.eye(4), axes=frame.axes,
               up=frame.up, forward=frame.forward, frame_found=frame.found,
               end_sites=ends, rotation_orders=tuple(orders))


def _dfs(parents) -> list[int]:
    kids: list[list[int]] = [[] for _ in parents]
    for j in range(1, len(parents)):
        kids[int(parents[j])].append(j)
    out, stack = [], [0]
    while stack:
        j = stack.pop()
        out.append(j)
        stack.extend(reversed(kids[j]))
    return out


def _num(v) -> str:
    return " ".join(f"{x + 0.0:.6f}" for x in np.round(np.asarray(v, float), 6))


def _hierarchy(rig: Rig, orders) -> str:
    P = rig.rest_world[:, :3, 3]
    kids: list[list[int]] = [[] for _ in rig.names]
    for j in range(1, len(rig.names)):
        kids[int(rig.parents[j])].append(j)
    lines = ["HIERARCHY"]

    def emit(j: int, depth: int) -> None:
        ind = "\t" * depth
        rot = " ".join(f"{a}rotation" for a in orders[j])
        if j == 0:
            lines.extend([f"ROOT {rig.names[0]}", "{", f"\tOFFSET {_num(P[0])}",
                          f"\tCHANNELS 6 Xposition Yposition Zposition {rot}"])
        else:
            lines.extend([f"{ind}JOINT {rig.names[j]}", f"{ind}{{",
                          f"{ind}\tOFFSET {_num(P[j] - P[rig.parents[j]])}",
                          f"{ind}\tCHANNELS 3 {rot}"])
        for c in kids[j]:
            emit(c, depth + 1)
        if not kids[j] or rig.names[j] in rig.end_sites:
            tip = rig.end_sites.get(rig.names[j], np.zeros(3))
            lines.extend([f"{ind}\tEnd Site", f"{ind}\t{{", f"{ind}\t\tOFFSET {_num(tip)}",
                          f"{ind}\t}}"])
        lines.append(f"{ind}}}")

    emit(0, 0)
    return "\n".join(lines) + "\n"


def write_rig_bvh(rig: Rig, motion, path: str | os.PathLike, *,
                  root_offset=(0.0, 0.0, 0.0)) -> Path:
    """Write ``motion`` (of an adopted skeleton) as a BVH file of the rig's own hierarchy.

    Parameters
    ----------
    rig : Rig
    motion : Motion
        Its joints are rig joints by name (quadsim's own toe joints are not
        written).
    path : str or path-like
        The ``.bvh`` to write, whole or not at all.
    root_offset : array-like, shape (3,)
        Where the rig joint of the motion's root stands relative to the
        motion's root position (m, quadsim's frame).

    Returns
    -------
    Path
    """
    from quadsim.io.rig_export import world_changes

    bad = [n for n in rig.names if not re.match(r"^[^\s{}]+$", n)]
    if bad:
        raise InputError(f"{rig.path.name}: BVH joint names may not contain whitespace or "
                         f"braces: {', '.join(map(repr, bad))}")
    D, top = world_changes(rig, motion, np.asarray(root_offset, float))   # rig frame
    dfs = _dfs(rig.parents)
    orders = list(rig.rotation_orders) or ["ZXY"] * len(rig.names)
    L = D.copy()
    L[:, 1:] = np.swapaxes(D[:, rig.parents[1:]], -1, -2) @ D[:, 1:]
    T = motion.n_frames
    angles = np.empty((T, len(rig.names), 3))
    for order in set(orders):
        idx = [j for j in range(len(orders)) if orders[j] == order]
        angles[:, idx] = np.degrees(euler_from_matrices(L[:, idx], order))
    values = np.concatenate([top, angles[:, dfs].reshape(T, -1)], axis=1)
    header = _hierarchy(rig, orders)
    header += f"MOTION\nFrames: {T}\nFrame Time: {1.0 / motion.fps!r}\n"

    def write(f):
        f.write(header)
        np.savetxt(f, np.round(values, 6) + 0.0, fmt="%.6f", delimiter=" ")

    path = Path(path)
    atomic_write(path, write)
    return path
