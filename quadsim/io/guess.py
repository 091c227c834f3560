"""What a motion file does not say: its length unit and which joints are the feet.

- :func:`guess_units`: a quadruped's hip height is 0.1 to 3 m; a skeleton
  whose rest pose stands more than :data:`CM_ABOVE` file units tall at the
  hips is in centimetres.
- :func:`guess_foot_joints`: the feet by quadsim's naming convention
  (``LF_``, ``RF_``, ``LH_``, ``RH_`` prefixes).
- :func:`feet_from_structure`: the feet of any quadruped skeleton, from its
  shape: the four lowest end joints of the rest pose, one in each quarter
  (left/right by the sign of +X, fore/hind by +Z, the way it faces).
"""

from __future__ import annotations

import numpy as np

from quadsim.errors import InputError
from quadsim.frames import LEGS, Y
from quadsim.skeleton.skeleton import Skeleton

__all__ = ["CM_ABOVE", "feet_from_structure", "guess_foot_joints", "guess_units",
           "rest_hip_height", "with_feet"]

#: A rest pose taller than this at the hips (in the file's unit) is read as centimetres.
CM_ABOVE = 3.0


def _rest_positions(offsets: np.ndarray, parents) -> np.ndarray:
    """World positions (J, 3) of the rest pose (no rotations); parents before children."""
    P = np.zeros((len(offsets), 3))
    for j, p in enumerate(parents):
        P[j] = offsets[j] + (P[p] if p >= 0 else 0.0)
    return P


def rest_hip_height(offsets, parents, end_sites=()) -> float:
    """Height of the root above the lowest joint or end site of the rest pose.

    Parameters
    ----------
    offsets : array-like, shape (J, 3)
        Bone offsets (any unit), the root's first.
    parents : sequence of int, length J
        Parent indices (-1 for the root), parents before children.
    end_sites : iterable of (int, array-like (3,))
        ``(joint index, offset)`` of each end site.

    Returns
    -------
    float
        In the offsets' unit; 0 when the root is the lowest point (the size
        of such a skeleton tells nothing about its unit).
    """
    P = _rest_positions(np.asarray(offsets, dtype=float), list(parents))
    pts = [P] + [np.asarray(P[j] + np.asarray(o, dtype=float))[None] for j, o in end_sites]
    allp = np.concatenate(pts)
    return max(float(P[0, Y] - allp[:, Y].min()), 0.0)


def guess_units(hip_height: float) -> str:
    """``"cm"`` for a rest hip height above :data:`CM_ABOVE` (file units), else ``"m"``."""
    return "cm" if hip_height > CM_ABOVE else "m"


def guess_foot_joints(skeleton: Skeleton) -> tuple[str, ...] | None:
    """The four foot joints of a skeleton named in quadsim's convention.

    For each leg in the order LF, RF, LH, RH: the deepest joint whose name
    starts with the leg's prefix and an underscore (``LF_paw``, ``RH_hoof``);
    among equally deep ones, the first in the skeleton's order.

    Parameters
    ----------
    skeleton : Skeleton

    Returns
    -------
    tuple of str, length 4, or None
        ``None`` when some leg has no such joint.
    """
    depth = np.zeros(skeleton.n_joints, dtype=int)
    for d, idx in enumerate(skeleton.depth_levels):
        depth[idx] = d
    feet = []
    for leg in LEGS:
        cands = [j for j, n in enumerate(skeleton.names) if n.startswith(leg + "_")]
        if not cands:
            return None
        feet.append(skeleton.names[max(cands, key=lambda j: (depth[j], -j))])
    return tuple(feet)


def feet_from_structure(skeleton: Skeleton) -> tuple[str, ...] | None:
    """The four foot joints of a quadruped skeleton whatever their names.

    The structure is read from the tree and the rest pose by
    :func:`quadsim.skeleton.anatomy.find_anatomy`: the four lowest end joints
    near the ground, fore and hind by their girdles, left on +X.

    Parameters
    ----------
    skeleton : Skeleton

    Returns
    -------
    tuple of str, length 4, or None
        In leg order LF, RF, LH, RH; None when the skeleton does not have a
        quadruped's structure.
    """
    from quadsim.skeleton.anatomy import find_anatomy

    try:
        feet = find_anatomy(skeleton).feet
    except ValueError:
        return None
    return tuple(skeleton.names[j] for j in feet)


def with_feet(motion, source="the motion"):
    """The motion with its four foot joints named, found from the skeleton if need be.

    Parameters
    ----------
    motion : Motion
    source : str or path-like
        Names the motion in the error message (its file).

    Returns
    -------
    motion : Motion
        ``motion`` itself when it names its feet, else a copy whose
        ``foot_joints`` are :func:`feet_from_structure`'s.
    by_shape : bool
        True when the feet were found from the skeleton's shape.

    Raises
    ------
    InputError
        When the shape does not show four legs either; the message lists
        what is expected and the skeleton's end joints.
    """
    if motion.foot_joints is not None:
        return motion, False
    skel = motion.skeleton
    feet = feet_from_structure(skel)
    if feet is None:
        ends = [n for j, n in enumerate(skel.names) if not skel.children[j]]
        raise InputError(
            f"{source}: cannot tell which joints are the feet: expected the four legs' end "
            "joints named with the prefixes LF_, RF_, LH_ and RH_ (left fore, right fore, left "
            "hind, right hind, e.g. LF_hoof), or a rest pose whose four lowest end joints "
            "stand left and right, fore and hind of the body; the file's end joints are "
            f"{', '.join(ends) or 'none'}")
    from dataclasses import replace

    return replace(motion, foot_joints=tuple(feet)), True
