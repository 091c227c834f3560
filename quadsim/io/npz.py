"""Joint positions and foot contacts as NumPy ``.npz`` and ``.csv`` files.

For robotics and machine-learning users who want arrays, not a rig. Both
formats hold world positions in metres, +Y up, +Z the character's rest
forward, legs in the order LF, RF, LH, RH. Contacts are *measured* from the
foot positions by :func:`quadsim.analysis.metrics.foot_contacts` (the same
test ``quadsim metrics`` uses); the generator's planned contacts are stored
beside them in the ``.npz`` when the motion has them.

``.npz`` contents (load with ``np.load(path)``; no pickled objects, so
``allow_pickle=False`` works):

==================  ==================  =============================================
key                 shape, dtype        meaning
==================  ==================  =============================================
format              () str              ``"quadsim-npz"``
format_version      () int              :data:`FORMAT_VERSION`
units               () str              length unit, ``"m"``
fps                 () float            frames per second
times               (T,) float          seconds from the first frame
joint_names         (J,) str            in joint order
parents             (J,) int            parent of each joint, -1 for the root
offsets             (J, 3) float        rest offset of each joint from its parent (m)
positions           (T, J, 3) float     joint world positions (m)
root_positions      (T, 3) float        root joint world position (m)
rotations           (T, J, 4) float     local rotations, unit quaternions
quaternion_order    () str              ``"wxyz"``
legs                (4,) str            ``LF RF LH RH``
foot_joints         (4,) str            foot joint names in leg order (when known)
contacts            (T, 4) bool         measured contacts (when the feet are known)
planned_contacts    (T, 4) bool         the generator's contacts (when present)
gaits               (T,) str            gait label per frame (when present)
==================  ==================  =============================================

``.csv``: a header row, then one row per frame: ``time`` (s), then
``<joint>_x, <joint>_y, <joint>_z`` (m) for every joint in joint order, then
``contact_LF, contact_RF, contact_LH, contact_RH`` (1 in contact, 0 not)
when the motion names its feet. Numbers have nine decimals (nanometres).
"""

from __future__ import annotations

import io
import os
from pathlib import Path

import numpy as np

from quadsim.errors import InputError
from quadsim.frames import LEGS
from quadsim.io.atomic import atomic_write_bytes
from quadsim.skeleton.motion import Motion

__all__ = ["FORMAT_VERSION", "write_csv", "write_npz"]

#: Version of the ``.npz`` layout; raised when a key changes meaning.
FORMAT_VERSION = 1
#: Decimal places of every number in a ``.csv`` file.
CSV_DECIMALS = 9


def _measured_contacts(motion: Motion) -> np.ndarray | None:
    if motion.foot_joints is None:
        return None
    from quadsim.analysis.metrics import foot_contacts

    return foot_contacts(motion.contact_points(), motion.fps)


def npz_arrays(motion: Motion, contacts: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """The arrays :func:`write_npz` stores, by key (see the module notes).

    Parameters
    ----------
    motion : Motion
    contacts : ndarray of bool, shape (T, 4), optional
        The measured contacts when already found (``foot_contacts`` of the
        motion's foot positions, default thresholds); found here otherwise.
    """
    skel = motion.skeleton
    out = {
        "format": np.array("quadsim-npz"),
        "format_version": np.array(FORMAT_VERSION),
        "units": np.array("m"),
        "fps": np.array(motion.fps),
        "times": motion.times,
        "joint_names": np.array(skel.names, dtype=str),
        "parents": np.asarray(skel.parents),
        "offsets": np.asarray(skel.offsets),
        "positions": np.asarray(motion.world_positions()),
        "root_positions": np.asarray(motion.root_positions),
        "rotations": np.asarray(motion.rotations),
        "quaternion_order": np.array("wxyz"),
        "legs": np.array(LEGS, dtype=str),
    }
    if motion.foot_joints is not None:
        out["foot_joints"] = np.array(motion.foot_joints, dtype=str)
        out["contacts"] = _measured_contacts(motion) if contacts is None else \
            np.asarray(contacts, dtype=bool)
    if motion.contacts is not None:
        out["planned_contacts"] = np.asarray(motion.contacts, dtype=bool)
    if motion.gaits is not None:
        out["gaits"] = np.array([str(g) for g in motion.gaits], dtype=str).reshape(len(motion))
    return out


def write_npz(motion: Motion, path: str | os.PathLike) -> Path:
    """Write a motion's joint positions, rotations and contacts as a ``.npz`` file.

    Parameters
    ----------
    motion : Motion
    path : str or path-like
        Destination, used as given (NumPy's habit of appending ``.npz`` is
        avoided). Written to a temporary file first, then moved into place.

    Returns
    -------
    Path
        The path written.

    Raises
    ------
    InputError
        When the destination cannot be written.
    """
    buf = io.BytesIO()
    np.savez_compressed(buf, **npz_arrays(motion))
    path = Path(path)
    atomic_write_bytes(path, buf.getvalue())
    return path


def csv_header(motion: Motion) -> list[str]:
    """Column names of :func:`write_csv`'s file."""
    cols = ["time"]
    for n in motion.skeleton.names:
        cols += [f"{n}_x", f"{n}_y", f"{n}_z"]
    if motion.foot_joints is not None:
        cols += [f"contact_{leg}" for leg in LEGS]
    return cols


def write_csv(motion: Motion, path: str | os.PathLike) -> Path:
    """Write joint world positions (and measured contacts) as a ``.csv`` file.

    Parameters
    ----------
    motion : Motion
    path : str or path-like
        Destination; written to a temporary file first, then moved into place.

    Returns
    -------
    Path
        The path written.

    Raises
    ------
    InputError
        A joint name with a comma, quote or line break, or a destination that
        cannot be written.
    """
    bad = [n for n in motion.skeleton.names if any(c in n for c in ',"\r\n')]
    if bad:
        raise InputError("CSV column names come from the joint names, which may not hold "
                         f"commas, quotes or line breaks; rename: {', '.join(map(repr, bad))}")
    T = len(motion)
    cols = [motion.times[:, None], np.asarray(motion.world_positions()).reshape(T, -1)]
    contacts = _measured_contacts(motion)
    fmt = [f"%.{CSV_DECIMALS}f"] * (1 + 3 * motion.skeleton.n_joints)
    if contacts is not None:
        cols.append(contacts.astype(float))
        fmt += ["%d"] * 4
    table = np.concatenate(cols, axis=1)
    buf = io.StringIO()
    np.savetxt(buf, table + 0.0, fmt=fmt, delimiter=",",
               header=",".join(csv_header(motion)), comments="")
    path = Path(path)
    atomic_write_bytes(path, buf.getvalue().encode("utf-8"))
    return path
