"""A small URDF reader: the kinematic tree, joint origins, axes and limits.

Only what retargeting needs is read -- links (with the first collision sphere of
each, the usual toe), and joints of the types ``revolute``, ``continuous``,
``prismatic`` and ``fixed`` (``floating`` and ``planar`` joints are refused),
their ``origin xyz rpy``, ``axis`` and ``limit lower upper velocity``. Meshes,
inertias and materials are ignored, so no mesh library is needed.

Frames are the URDF's: a joint's origin places its child link's frame in its
parent link's frame, with ``rpy`` fixed-axis roll, pitch, yaw (``R = Rz(yaw)
Ry(pitch) Rx(roll)``); lengths in metres, angles in radians.
"""

from __future__ import annotations

import math
import os
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from quadsim.errors import InputError

__all__ = ["JOINT_TYPES", "Urdf", "UrdfJoint", "UrdfLink", "read_urdf", "rpy_matrix",
           "transform"]

#: Joint types the reader accepts.
JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed")


@dataclass(frozen=True, eq=False)
class UrdfLink:
    """A link.

    Attributes
    ----------
    name : str
    sphere_center : ndarray, shape (3,) or None
        Centre of the link's first spherical collision shape in the link frame (m).
    sphere_radius : float
        Its radius (m); 0 without one.
    """

    name: str
    sphere_center: np.ndarray | None = None
    sphere_radius: float = 0.0


@dataclass(frozen=True, eq=False)
class UrdfJoint:
    """A joint.

    Attributes
    ----------
    name, type, parent, child : str
    origin : ndarray, shape (4, 4)
        The child frame in the parent frame at zero joint position.
    axis : ndarray, shape (3,)
        Unit axis in the child frame (the joint frame).
    lower, upper : float
        Position limits (rad or m); ``-inf``/``inf`` for a continuous joint or an
        absent limit.
    velocity : float
        Speed limit (rad/s or m/s); ``inf`` when not given.
    """

    name: str
    type: str
    parent: str
    child: str
    origin: np.ndarray
    axis: np.ndarray
    lower: float = -math.inf
    upper: float = math.inf
    velocity: float = math.inf

    @property
    def movable(self) -> bool:
        return self.type != "fixed"


@dataclass(frozen=True, eq=False)
class Urdf:
    """A robot's kinematic tree.

    Attributes
    ----------
    name : str
    path : Path or None
    links : dict of str to UrdfLink
    joints : tuple of UrdfJoint
        In file order.
    root : str
        The link that is no joint's child (the base).
    """

    name: str
    path: Path | None
    links: dict
    joints: tuple[UrdfJoint, ...]
    root: str

    @property
    def label(self) -> str:
        """The file's name, or the robot's name when not read from a file."""
        return self.path.name if self.path is not None else self.name

    @property
    def movable_joints(self) -> tuple[UrdfJoint, ...]:
        """Joints other than fixed ones, in file order."""
        return tuple(j for j in self.joints if j.movable)

    def joint_to(self, link: str) -> UrdfJoint | None:
        """The joint whose child is ``link`` (None for the root)."""
        for j in self.joints:
            if j.child == link:
                return j
        return None

    def children(self, link: str) -> list[UrdfJoint]:
        """Joints whose parent is ``link``, in file order."""
        return [j for j in self.joints if j.parent == link]

    def path_to(self, link: str) -> list[UrdfJoint]:
        """Joints from the root down to ``link``, root first."""
        out = []
        j = self.joint_to(link)
        while j is not None:
            out.append(j)
            j = self.joint_to(j.parent)
        return out[::-1]

    def leaves(self) -> list[str]:
        """Links without children, in file order of their joints."""
        parents = {j.parent for j in self.joints}
        return [j.child for j in self.joints if j.child not in parents]

    def zero_pose(self) -> dict:
        """World (root-frame) transform of every link at zero joint positions, shape (4, 4)."""
        out = {self.root: np.eye(4)}
        stack = [self.root]
        while stack:
            link = stack.pop()
            for j in self.children(link):
                out[j.child] = out[link] @ j.origin
                stack.append(j.child)
        return out


def rpy_matrix(rpy) -> np.ndarray:
    """Rotation matrix of URDF fixed-axis roll, pitch, yaw (rad), shape (3, 3)."""
    r, p, y = (float(v) for v in rpy)
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), \
        math.cos(y), math.sin(y)
    return np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                     [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                     [-sp, cp * sr, cp * cr]])


def transform(xyz, rpy) -> np.ndarray:
    """The homogeneous transform of an ``origin`` element, shape (4, 4)."""
    T = np.eye(4)
    T[:3, :3] = rpy_matrix(rpy)
    T[:3, 3] = np.asarray(xyz, dtype=float)
    return T


def _floats(text: str | None, n: int, where: str, default) -> list[float]:
    if text is None:
        return list(default)
    try:
        vals = [float(v) for v in text.split()]
    except ValueError:
        vals = []
    if len(vals) != n or not all(math.isfinite(v) for v in vals):
        raise InputError(f"{where}: expected {n} numbers, got {text!r}; fix the URDF")
    return vals


def _number(el, key: str, where: str, default: float) -> float:
    text = el.get(key) if el is not None else None
    if text is None:
        return default
    return _floats(text, 1, f"{where} {key}", (default,))[0]


def _link(el, src: str) -> UrdfLink:
    name = el.get("name")
    for col in el.findall("collision"):
        sphere = col.find("geometry/sphere")
        if sphere is None:
            continue
        where = f"{src}: link {name!r} collision sphere"
        o = col.find("origin")
        T = transform(_floats(o.get("xyz") if o is not None else None, 3, where, (0, 0, 0)),
                      _floats(o.get("rpy") if o is not None else None, 3, where, (0, 0, 0)))
        return UrdfLink(name, T[:3, 3].copy(), _number(sphere, "radius", where, 0.0))
    return UrdfLink(name)


def _joint(el, src: str, links: dict) -> UrdfJoint:
    name = el.get("name")
    where = f"{src}: joint {name!r}"
    kind = el.get("type")
    if kind not in JOINT_TYPES:
        raise InputError(f"{where}: type {kind!r} is not read; allowed: "
                         f"{', '.join(JOINT_TYPES)}")
    parent, child = el.find("parent"), el.find("child")
    if parent is None or child is None or parent.get("link") not in links \
            or child.get("link") not in links:
        raise InputError(f"{where}: needs <parent link=...> and <child link=...> naming "
                         "links of the file")
    o = el.find("origin")
    T = transform(_floats(o.get("xyz") if o is not None else None, 3, f"{where} origin xyz",
                          (0, 0, 0)),
                  _floats(o.get("rpy") if o is not None else None, 3, f"{where} origin rpy",
                          (0, 0, 0)))
    a = el.find("axis")
    axis = np.array(_floats(a.get("xyz") if a is not None else None, 3, f"{where} axis",
                            (1, 0, 0)))
    if kind != "fixed":
        n = np.linalg.norm(axis)
        if n < 1e-9:
            raise InputError(f"{where}: axis is zero; give a direction such as '0 1 0'")
        axis = axis / n
    lim = el.find("limit")
    lower, upper = -math.inf, math.inf
    if kind in ("revolute", "prismatic") and lim is not None and \
            (lim.get("lower") is not None or lim.get("upper") is not None):
        lower = _number(lim, "lower", f"{where} limit", 0.0)
        upper = _number(lim, "upper", f"{where} limit", 0.0)
        if lower > upper:
            raise InputError(f"{where}: limit lower {lower} is above upper {upper}; fix the "
                             "URDF")
        if lower == upper:  # a degenerate limit in some files: read as no limit
            lower, upper = -math.inf, math.inf
    velocity = _number(lim, "velocity", f"{where} limit", math.inf)
    return UrdfJoint(name, kind, parent.get("link"), child.get("link"), T, axis,
                     lower, upper, velocity if velocity > 0 else math.inf)


def read_urdf(path: str | os.PathLike) -> Urdf:
    """Read a URDF file.

    Raises
    ------
    InputError
        For a missing or unreadable file, a malformed element, a joint type not
        read, or a tree that is not a tree (several roots, a link with two parents).
    """
    path = Path(path)
    src = str(path)
    if not path.is_file():
        raise InputError(f"`--robot` {src!r}: no such URDF file; give the path of a "
                         "robot's .urdf")
    try:
        root = ET.parse(path).getroot()
    except (ET.ParseError, OSError, UnicodeDecodeError) as e:
        raise InputError(f"{src}: not a readable URDF ({e}); give a robot's .urdf file") \
            from None
    return urdf_from_element(root, src, path)


def urdf_from_element(root, src: str = "<urdf>", path: Path | None = None) -> Urdf:
    """A :class:`Urdf` from the parsed ``<robot>`` element (see :func:`read_urdf`)."""
    if root.tag != "robot":
        raise InputError(f"{src}: the top element is <{root.tag}>, not <robot>; give a URDF")
    links = {}
    for el in root.findall("link"):
        if not el.get("name"):
            raise InputError(f"{src}: a <link> without a name; name every link")
        links[el.get("name")] = _link(el, src)
    joints = tuple(_joint(el, src, links) for el in root.findall("joint"))
    children = [j.child for j in joints]
    twice = sorted({c for c in children if children.count(c) > 1})
    if twice:
        raise InputError(f"{src}: link {twice[0]!r} is the child of two joints; a URDF is a "
                         "tree")
    roots = [n for n in links if n not in set(children)]
    if len(roots) != 1:
        raise InputError(f"{src}: {len(roots)} root links ({', '.join(roots[:5])}); a URDF "
                         "has one base link that is no joint's child")
    return Urdf(root.get("name") or (path.stem if path else "robot"), path, links, joints,
                roots[0])
