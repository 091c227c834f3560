"""A robot's four legs found in its URDF tree, their kinematics and inverse kinematics.

Legs are the chains from the base to the tree's leaves that hold at least two
movable joints of their own (joints no other leg shares); with more than four,
leaves named like a foot (``toe``, ``foot``, ``paw``) are preferred. A leg's
foot point is its leaf link's origin, or the centre of the leaf's collision
sphere when it has one (the usual toe), and its radius is that sphere's.

The *body frame* is the base frame turned so that x is forward, y left and z
up (the URDF convention, REP 103): up is the normal of the plane of the four
leg roots, pointing away from the feet; forward is the long axis of the roots'
rectangle (the base's x axis for a square one), snapped to the nearest base
axis and taken positive along it. Front and rear, left and right follow from
the roots' positions in it. For most robots the body frame is the base frame.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from quadsim.errors import InputError
from quadsim.frames import LEGS
from quadsim.kinematics.rotations import matrices_from_axis_angles
from quadsim.robots.urdf import Urdf, UrdfJoint

__all__ = ["RobotLeg", "RobotLegs", "find_legs"]

_FOOT_WORDS = ("toe", "foot", "feet", "paw")


@dataclass(frozen=True, eq=False)
class RobotLeg:
    """One leg: its own movable joints from the body down, and its foot point.

    Attributes
    ----------
    name : str
        ``"LF"``, ``"RF"``, ``"LH"`` or ``"RH"``.
    foot_link : str
    joints : tuple of UrdfJoint
        The leg's own movable joints, body first.
    columns : ndarray of int, shape (n,)
        Their positions in :attr:`RobotLegs.joint_names`.
    base_to_first : ndarray, shape (4, 4)
        The frame the first joint's origin is given in, in the base frame (the
        joints above, fixed or shared with another leg, held at zero).
    steps : ndarray, shape (n, 4, 4)
        Each joint's origin in the frame of the joint before (fixed joints between
        folded in).
    tail : ndarray, shape (4,)
        The foot point in the last joint's frame (homogeneous).
    foot_radius : float
        Radius of the foot's collision sphere (m), 0 without one.
    lower, upper : ndarray, shape (n,)
        Joint limits (``-inf``/``inf`` when none).
    """

    name: str
    foot_link: str
    joints: tuple[UrdfJoint, ...]
    columns: np.ndarray
    base_to_first: np.ndarray
    steps: np.ndarray
    tail: np.ndarray
    foot_radius: float
    lower: np.ndarray
    upper: np.ndarray

    @property
    def n(self) -> int:
        return len(self.joints)

    def frames(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Joint frames and the foot point in the base frame.

        Parameters
        ----------
        q : ndarray, shape (N, n)
            Joint positions (rad, m).

        Returns
        -------
        T : ndarray, shape (N, n, 4, 4)
            Each joint's frame after its motion, in the base frame.
        foot : ndarray, shape (N, 3)
            The foot point (m).
        """
        q = np.asarray(q, dtype=float)
        N = q.shape[0]
        T = np.empty((N, self.n, 4, 4))
        cur = np.broadcast_to(self.base_to_first, (N, 4, 4))
        for i, j in enumerate(self.joints):
            M = np.broadcast_to(self.steps[i], (N, 4, 4)).copy()
            if j.type == "prismatic":
                M[:, :3, 3] += M[:, :3, :3] @ j.axis * q[:, i, None]
            else:
                M[:, :3, :3] = M[:, :3, :3] @ matrices_from_axis_angles(j.axis, q[:, i])
            cur = cur @ M
            T[:, i] = cur
        foot = (cur @ self.tail)[:, :3]
        return T, foot

    def foot_and_jacobian(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The foot point, shape (N, 3), and its Jacobian, shape (N, 3, n), in the base frame."""
        T, foot = self.frames(q)
        axes = np.stack([T[:, i, :3, :3] @ j.axis for i, j in enumerate(self.joints)], axis=1)
        J = np.empty((q.shape[0], 3, self.n))
        for i, j in enumerate(self.joints):
            if j.type == "prismatic":
                J[:, :, i] = axes[:, i]
            else:
                J[:, :, i] = np.cross(axes[:, i], foot - T[:, i, :3, 3])
        return foot, J

    def solve(self, target: np.ndarray, seed: np.ndarray, *, iterations: int = 60,
              damping: float = 1e-3, margin: float = 1e-4) -> tuple[np.ndarray, np.ndarray]:
        """Damped least-squares IK for many targets at once, limits enforced.

        Parameters
        ----------
        target : ndarray, shape (N, 3)
            Foot points in the base frame (m).
        seed : ndarray, shape (n,) or (N, n)
            Start (sets the knee's branch).
        iterations : int
        damping : float
            Damping (m) of the least-squares step.
        margin : float
            Distance (rad, m) kept inside every limit.

        Returns
        -------
        q : ndarray, shape (N, n)
            Within ``[lower + margin, upper - margin]``; continuous joints wrapped
            to [-pi, pi).
        residual : ndarray, shape (N,)
            Distance from the foot reached to the target (m).
        """
        target = np.asarray(target, dtype=float)
        N = target.shape[0]
        lo, hi = self.lower + margin, self.upper - margin
        q = np.clip(np.broadcast_to(seed, (N, self.n)).astype(float), lo, hi)
        eye = np.eye(3) * damping ** 2
        for _ in range(iterations):
            foot, J = self.foot_and_jacobian(q)
            e = target - foot
            step = np.einsum("nai,na->ni", J, np.linalg.solve(J @ J.transpose(0, 2, 1) + eye,
                                                               e[..., None])[..., 0])
            big = np.abs(step).max(axis=1, keepdims=True)
            step *= np.minimum(1.0, 0.4 / np.maximum(big, 1e-12))
            q = np.clip(q + step, lo, hi)
        cont = np.array([j.type == "continuous" for j in self.joints])
        q[:, cont] = (q[:, cont] + np.pi) % (2 * np.pi) - np.pi
        foot = self.frames(q)[1]
        return q, np.linalg.norm(target - foot, axis=1)


@dataclass(frozen=True, eq=False)
class RobotLegs:
    """A quadruped robot read from a URDF.

    Attributes
    ----------
    urdf : Urdf
    legs : tuple of RobotLeg
        In leg order LF, RF, LH, RH.
    joint_names : tuple of str
        Every movable joint, in file order: the columns of a pose.
    lower, upper : ndarray, shape (J,)
        Their limits.
    body : ndarray, shape (3, 3)
        Columns: the body frame's forward, left and up axes in the base frame.
    """

    urdf: Urdf
    legs: tuple[RobotLeg, ...]
    joint_names: tuple[str, ...]
    lower: np.ndarray
    upper: np.ndarray
    body: np.ndarray

    def rest_angles(self) -> np.ndarray:
        """Zero for every joint, or its nearest limit, shape (J,)."""
        return np.clip(np.zeros(len(self.joint_names)), self.lower, self.upper)

    def feet(self, angles: np.ndarray) -> np.ndarray:
        """Foot points in the base frame for poses ``angles`` (N, J), shape (N, 4, 3)."""
        return np.stack([leg.frames(angles[:, leg.columns])[1] for leg in self.legs], axis=1)

    def hips(self) -> np.ndarray:
        """Each leg's hip (its last joint but one) at zero in the base frame, shape (4, 3)."""
        out = []
        for leg in self.legs:
            T = leg.frames(np.zeros((1, leg.n)))[0][0]
            out.append(T[max(leg.n - 2, 0), :3, 3])
        return np.array(out)


def _leg_candidates(urdf: Urdf) -> list[tuple[str, list[UrdfJoint]]]:
    """Base-to-leaf chains with two or more movable joints no other chain holds.

    Leaves below the same last movable joint (a toe and a sensor link on one shank)
    are one chain: the leaf named like a foot, else the one farthest from that joint.
    """
    pose = urdf.zero_pose()
    groups: dict[tuple, list] = {}
    for leaf in urdf.leaves():
        p = urdf.path_to(leaf)
        key = tuple(j.name for j in p if j.movable)
        if len(key) >= 2:
            groups.setdefault(key, []).append((leaf, p))

    def rank(item):
        leaf, p = item
        last = [j for j in p if j.movable][-1].child
        reach = np.linalg.norm(pose[leaf][:3, 3] - pose[last][:3, 3])
        return (any(w in leaf.lower() for w in _FOOT_WORDS), reach)

    out = [max(g, key=rank) for g in groups.values()]
    shared: dict[str, int] = {}
    for key in groups:
        for name in key:
            shared[name] = shared.get(name, 0) + 1
    return [(leaf, p) for leaf, p in out
            if sum(j.movable and shared[j.name] == 1 for j in p) >= 2]


def _pick_four(urdf: Urdf, cands, src: str):
    if len(cands) > 4:
        named = [c for c in cands if any(w in c[0].lower() for w in _FOOT_WORDS)]
        if len(named) == 4:
            cands = named
    if len(cands) != 4:
        found = ", ".join(leaf for leaf, _ in cands) or "none"
        raise InputError(f"{src}: found {len(cands)} leg chain(s) ({found}), a quadruped "
                         "needs four: chains from the base to a foot or toe link with at "
                         "least two movable joints each; give a URDF of a four-legged robot")
    return cands


def _snap(v: np.ndarray) -> np.ndarray:
    """``v`` turned onto the nearest signed base axis when within about 18 degrees."""
    k = int(np.argmax(np.abs(v)))
    if abs(v[k]) > 0.95 * np.linalg.norm(v):
        out = np.zeros(3)
        out[k] = np.sign(v[k])
        return out
    return v / np.linalg.norm(v)


def _body_frame(roots: np.ndarray, feet: np.ndarray) -> np.ndarray:
    c = roots - roots.mean(axis=0)
    _, sv, vt = np.linalg.svd(c)
    up = vt[2]
    if up @ (feet - roots).mean(axis=0) > 0:
        up = -up
    up = _snap(up)
    if sv[0] > 1.2 * sv[1]:
        fwd = vt[0]
    else:
        fwd = np.array([1.0, 0.0, 0.0])
    fwd = fwd - (fwd @ up) * up
    if np.linalg.norm(fwd) < 1e-6:
        fwd = vt[1] - (vt[1] @ up) * up
    fwd = _snap(fwd)
    k = int(np.argmax(np.abs(fwd)))
    if fwd[k] < 0:
        fwd = -fwd
    left = np.cross(up, fwd)
    return np.stack([fwd, left, up], axis=1)


def _make_leg(urdf: Urdf, name: str, leaf: str, path, own: set, columns: dict) -> RobotLeg:
    first = next(i for i, j in enumerate(path) if j.name in own)
    pre = np.eye(4)
    for j in path[:first]:
        pre = pre @ j.origin
    steps, joints, acc = [], [], np.eye(4)
    for j in path[first:]:
        acc = acc @ j.origin
        if j.name in own:
            steps.append(acc)
            joints.append(j)
            acc = np.eye(4)
    link = urdf.links[leaf]
    point = np.zeros(3) if link.sphere_center is None else link.sphere_center
    tail = acc @ np.append(point, 1.0)
    return RobotLeg(name, leaf, tuple(joints), np.array([columns[j.name] for j in joints]),
                    pre, np.array(steps), tail, float(link.sphere_radius),
                    np.array([j.lower for j in joints]), np.array([j.upper for j in joints]))


def find_legs(urdf: Urdf) -> RobotLegs:
    """The four legs of ``urdf`` in leg order LF, RF, LH, RH, and its body frame.

    Raises
    ------
    InputError
        When the tree does not hold exactly four leg chains, or their roots do not
        make two front and two rear, two left and two right.
    """
    src = str(urdf.path or urdf.name)
    cands = _pick_four(urdf, _leg_candidates(urdf), src)
    movable = urdf.movable_joints
    columns = {j.name: i for i, j in enumerate(movable)}
    on = {}
    for _, p in cands:
        for j in p:
            on[j.name] = on.get(j.name, 0) + 1
    own = {n for n, k in on.items() if k == 1 and columns.get(n) is not None}
    legs = [_make_leg(urdf, "?", leaf, p, own, columns) for leaf, p in cands]
    zero = [leg.frames(np.zeros((1, leg.n))) for leg in legs]
    roots = np.array([T[0, 0, :3, 3] for T, _ in zero])
    feet = np.array([f[0] for _, f in zero])
    body = _body_frame(roots, feet)
    rc = (roots - roots.mean(axis=0)) @ body
    front = rc[:, 0] > 0
    left = rc[:, 1] > 0
    names = [("L" if lf else "R") + ("F" if fr else "H") for fr, lf in zip(front, left)]
    if sorted(names) != sorted(LEGS):
        raise InputError(f"{src}: the four legs ({', '.join(c[0] for c in cands)}) do not "
                         "stand two in front and two behind, two left and two right of the "
                         "base; give a URDF of a quadruped")
    order = [names.index(n) for n in LEGS]
    legs = [legs[i] for i in order]
    legs = tuple(replace(leg, name=n) for n, leg in zip(LEGS, legs))
    return RobotLegs(urdf, legs, tuple(j.name for j in movable),
                     np.array([j.lower for j in movable]),
                     np.array([j.upper for j in movable]), body)
