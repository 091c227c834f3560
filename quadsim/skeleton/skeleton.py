"""The immutable skeleton: joint names, parents and rest offsets."""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np


@dataclass(frozen=True, eq=False)
class Skeleton:
    """A tree of joints in topological order.

    Parameters
    ----------
    names : tuple of str, length J
        Unique joint names; joint 0 is the root.
    parents : ndarray of int, shape (J,)
        Parent index of each joint, ``-1`` for the root, ``parents[j] < j``.
    offsets : ndarray, shape (J, 3)
        Rest offset of each joint from its parent, in the parent's frame (m).
        The root's offset is its rest position in the world.
    end_sites : dict of str to ndarray, shape (3,)
        Offset of the tip of each leaf joint's bone (BVH "End Site"), in the
        leaf's frame (m).

    Notes
    -----
    At rest every local rotation is the identity, so offsets are also the
    rest-pose bone vectors in world axes.
    """

    names: tuple[str, ...]
    parents: np.ndarray
    offsets: np.ndarray
    end_sites: dict[str, np.ndarray] = field(default_factory=dict)

    def __post_init__(self) -> None:
        names = tuple(str(n) for n in self.names)
        parents = np.asarray(self.parents, dtype=np.int64).copy()
        offsets = np.asarray(self.offsets, dtype=float).copy()
        J = len(names)
        if J == 0:
            raise ValueError("a skeleton needs at least one joint")
        if len(set(names)) != J:
            dup = sorted({n for n in names if names.count(n) > 1})
            raise ValueError(f"joint names must be unique; repeated: {', '.join(dup)}")
        if parents.shape != (J,):
            raise ValueError(f"`parents` has shape {parents.shape}, expected ({J},)")
        if offsets.shape != (J, 3):
            raise ValueError(f"`offsets` has shape {offsets.shape}, expected ({J}, 3)")
        if parents[0] != -1:
            raise ValueError("joint 0 must be the root (parent -1)")
        bad = [names[j] for j in range(1, J) if not 0 <= parents[j] < j]
        if bad:
            raise ValueError(
                "each joint's parent must come before it (parents[j] < j); "
                f"out of order: {', '.join(bad)}")
        ends = {}
        for k, v in dict(self.end_sites).items():
            if k not in names:
                raise ValueError(f"end site given for unknown joint {k!r}")
            ends[k] = np.asarray(v, dtype=float).reshape(3)
        parents.setflags(write=False)
        offsets.setflags(write=False)
        object.__setattr__(self, "names", names)
        object.__setattr__(self, "parents", parents)
        object.__setattr__(self, "offsets", offsets)
        object.__setattr__(self, "end_sites", ends)

    @property
    def n_joints(self) -> int:
        return len(self.names)

    def index(self, name: str) -> int:
        """Index of a joint by name (``KeyError`` naming the joint if absent)."""
        try:
            return self._index[name]
        except KeyError:
            raise KeyError(f"no joint named {name!r} in this skeleton") from None

    def indices(self, names) -> np.ndarray:
        """Indices of several joints, shape (len(names),)."""
        return np.array([self.index(n) for n in names], dtype=np.int64)

    @cached_property
    def _index(self) -> dict[str, int]:
        return {n: i for i, n in enumerate(self.names)}

    @cached_property
    def children(self) -> tuple[tuple[int, ...], ...]:
        """Child indices of each joint."""
        ch: list[list[int]] = [[] for _ in self.names]
        for j in range(1, self.n_joints):
            ch[self.parents[j]].append(j)
        return tuple(tuple(c) for c in ch)

    @cached_property
    def depth_levels(self) -> tuple[np.ndarray, ...]:
        """Joint indices grouped by depth below the root (level 0 is the root).

        Forward kinematics processes one level at a time, vectorised over the
        level's joints, so the Python loop runs over the tree's depth, not its
        joint count.
        """
        depth = np.zeros(self.n_joints, dtype=np.int64)
        for j in range(1, self.n_joints):
            depth[j] = depth[self.parents[j]] + 1
        return tuple(np.flatnonzero(depth == d) for d in range(depth.max() + 1))

    @cached_property
    def rest_positions(self) -> np.ndarray:
        """World positions of the joints at rest, shape (J, 3): each joint at its
        parent's position plus its offset (no rotation anywhere), the root at
        its own offset."""
        P = np.empty((self.n_joints, 3))
        P[0] = self.offsets[0]
        for j in range(1, self.n_joints):
            P[j] = P[self.parents[j]] + self.offsets[j]
        P.setflags(write=False)
        return P

    def chain(self, tip: str, base: str) -> list[str]:
        """Names from ``base`` down to ``tip`` inclusive (``tip`` below ``base``)."""
        j, b = self.index(tip), self.index(base)
        out = [j]
        while j != b:
            j = int(self.parents[j])
            if j < 0:
                raise ValueError(f"{tip!r} is not below {base!r}")
            out.append(j)
        return [self.names[i] for i in reversed(out)]

    def scaled(self, factor: float) -> Skeleton:
        """The same skeleton uniformly scaled by ``factor``."""
        return Skeleton(self.names, self.parents, self.offsets * factor,
                        {k: v * factor for k, v in self.end_sites.items()})
