"""The ``Motion`` container: a skeleton animated over frames."""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from quadsim.kinematics.rotations import (
    matrices_from_quaternions,
    quaternion_slerp,
    quaternions_from_matrices,
)
from quadsim.skeleton.fk import forward_kinematics
from quadsim.skeleton.skeleton import Skeleton


@dataclass(frozen=True, eq=False)
class Motion:
    """An animation of a skeleton sampled at a fixed frame rate.

    Parameters
    ----------
    skeleton : Skeleton
    fps : float
        Frames per second (> 0).
    root_positions : ndarray, shape (T, 3)
        World position of the root joint per frame (m).
    rotations : ndarray, shape (T, J, 4)
        Local joint rotations as unit quaternions ``(w, x, y, z)``.
    contacts : ndarray of bool, shape (T, 4), optional
        Planned foot contacts in leg order LF, RF, LH, RH (what the generator
        intended; measure the realised ones with :mod:`quadsim.analysis`).
    gaits : ndarray of str, shape (T,), optional
        Gait label per frame (``"walk"``, ``"trot->canter"``, ...).
    foot_joints : tuple of str, optional
        Names of the four foot (contact) joints in leg order, when known.
    extras : dict, optional
        Further per-frame arrays (shape (T, ...)), e.g. CPG phases, spine angle.

    All arrays are read-only.
    """

    skeleton: Skeleton
    fps: float
    root_positions: np.ndarray
    rotations: np.ndarray
    contacts: np.ndarray | None = None
    gaits: np.ndarray | None = None
    foot_joints: tuple[str, ...] | None = None
    extras: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        J = self.skeleton.n_joints
        fps = float(self.fps)
        if not np.isfinite(fps) or fps <= 0:
            raise ValueError(f"`fps` must be a positive number, got {self.fps!r}")
        root = np.array(self.root_positions, dtype=float)
        rot = np.array(self.rotations, dtype=float)
        if rot.ndim != 3 or rot.shape[1:] != (J, 4):
            raise ValueError(f"`rotations` has shape {rot.shape}, expected (T, {J}, 4)")
        T = rot.shape[0]
        if root.shape != (T, 3):
            raise ValueError(f"`root_positions` has shape {root.shape}, expected ({T}, 3)")
        norms = np.linalg.norm(rot, axis=-1)
        if T and not np.all(np.abs(norms - 1.0) < 1e-6):
            rot = rot / norms[..., None]
        arrays = {"root_positions": root, "rotations": rot}
        if self.contacts is not None:
            c = np.array(self.contacts, dtype=bool)
            if c.shape != (T, 4):
                raise ValueError(f"`contacts` has shape {c.shape}, expected ({T}, 4)")
            arrays["contacts"] = c
        if self.gaits is not None:
            g = np.array(self.gaits, dtype=object)
            if g.shape != (T,):
                raise ValueError(f"`gaits` has shape {g.shape}, expected ({T},)")
            arrays["gaits"] = g
        if self.foot_joints is not None:
            feet = tuple(self.foot_joints)
            if len(feet) != 4:
                raise ValueError("`foot_joints` must name four joints (LF, RF, LH, RH)")
            for f in feet:
                self.skeleton.index(f)
            object.__setattr__(self, "foot_joints", feet)
        extras = {}
        for k, v in dict(self.extras).items():
            v = np.array(v)
            if v.shape[:1] != (T,):
                raise ValueError(f"extra {k!r} has shape {v.shape}, expected ({T}, ...)")
            v.setflags(write=False)
            extras[k] = v
        object.__setattr__(self, "extras", extras)
        object.__setattr__(self, "fps", fps)
        for k, v in arrays.items():
            v.setflags(write=False)
            object.__setattr__(self, k, v)

    @classmethod
    def _of_checked_arrays(cls, skeleton: Skeleton, fps: float, root_positions: np.ndarray,
                           rotations: np.ndarray, contacts: np.ndarray, gaits: np.ndarray,
                           foot_joints: tuple[str, ...], extras: dict) -> Motion:
        """A motion of arrays its maker already holds in the checked form (float
        ``(T, 3)`` and unit ``(T, J, 4)``, bool ``(T, 4)``, object ``(T,)``, extras
        ``(T, ...)``, foot joints of the skeleton): kept as they are, made read-only,
        not copied nor checked again. For a batch that builds many motions of one
        skeleton at once (:func:`quadsim.dataset.clips.generate`); anyone else
        builds a ``Motion(...)``."""
        m = object.__new__(cls)
        arrays = {"root_positions": root_positions, "rotations": rotations,
                  "contacts": contacts, "gaits": gaits}
        for k, v in arrays.items():
            v = v.view()
            v.setflags(write=False)
            object.__setattr__(m, k, v)
        frozen = {}
        for k, v in extras.items():
            v = v.view()
            v.setflags(write=False)
            frozen[k] = v
        for k, v in (("skeleton", skeleton), ("fps", float(fps)),
                     ("foot_joints", tuple(foot_joints)), ("extras", frozen)):
            object.__setattr__(m, k, v)
        return m

    # ------------------------------------------------------------------ basics
    @classmethod
    def from_matrices(cls, skeleton: Skeleton, fps: float, root_positions, matrices, **kw):
        """Build from local rotation matrices of shape (T, J, 3, 3)."""
        return cls(skeleton, fps, root_positions, quaternions_from_matrices(matrices), **kw)

    def __len__(self) -> int:
        return self.rotations.shape[0]

    @property
    def n_frames(self) -> int:
        return len(self)

    @property
    def duration(self) -> float:
        """Time between the first and the last frame (s)."""
        return max(len(self) - 1, 0) / self.fps

    @property
    def times(self) -> np.ndarray:
        """Time of each frame from the first (s), shape (T,)."""
        return np.arange(len(self)) / self.fps

    @cached_property
    def local_matrices(self) -> np.ndarray:
        """Local rotation matrices, shape (T, J, 3, 3)."""
        m = matrices_from_quaternions(self.rotations)
        m.setflags(write=False)
        return m

    @cached_property
    def _fk(self) -> tuple[np.ndarray, np.ndarray]:
        G, P = forward_kinematics(self.skeleton, self.local_matrices, self.root_positions)
        G.setflags(write=False)
        P.setflags(write=False)
        return G, P

    def _given_kinematics(self, world_positions: np.ndarray, joints=(),
                          world_rotations: np.ndarray | None = None) -> None:
        """Hand the motion its forward kinematics, computed elsewhere *from its own
        rotations* (by the same kernels, so the same bits :meth:`world_positions`
        and :meth:`world_rotations` would find): a batch that found them for many
        motions at once (:func:`quadsim.dataset.clips.generate`). The world
        positions of every joint, shape (T, J, 3), and the world rotations of the
        joints ``joints`` (indices, length K), shape (T, K, 3, 3) (those of other
        joints are found when asked, from the rotations); kept read-only."""
        shape = self.rotations.shape[:2]
        joints = tuple(int(j) for j in joints)
        P = np.asarray(world_positions)
        G = np.empty(shape[:1] + (0, 3, 3)) if world_rotations is None else \
            np.asarray(world_rotations)
        if P.shape != shape + (3,) or G.shape != (shape[0], len(joints), 3, 3):
            raise ValueError(f"forward kinematics of shapes {P.shape}, {G.shape}; expected "
                             f"{shape + (3,)}, {(shape[0], len(joints), 3, 3)}")
        P, G = P.view(), G.view()
        P.setflags(write=False)
        G.setflags(write=False)
        self.__dict__["_given_fk"] = (P, joints, G)

    def world_positions(self) -> np.ndarray:
        """World positions of every joint, shape (T, J, 3) (m)."""
        given = self.__dict__.get("_given_fk")
        return self._fk[1] if given is None else given[0]

    def world_rotations(self) -> np.ndarray:
        """World rotation matrices of every joint, shape (T, J, 3, 3)."""
        return self._fk[0]

    def world_rotations_of(self, joints) -> np.ndarray:
        """World rotation matrices of the joints ``joints`` (indices, length K), shape
        (T, K, 3, 3): :meth:`world_rotations` of those, without finding every
        joint's when only these were handed over."""
        joints = [int(j) for j in np.atleast_1d(joints)]
        given = self.__dict__.get("_given_fk")
        if given is not None and "_fk" not in self.__dict__ and set(joints) <= set(given[1]):
            return given[2][:, [given[1].index(j) for j in joints]]
        return self.world_rotations()[:, joints]

    def foot_positions(self) -> np.ndarray:
        """World positions of the four foot joints, shape (T, 4, 3)."""
        if self.foot_joints is None:
            raise ValueError("this motion does not name its foot joints")
        return self.world_positions()[:, self.skeleton.indices(self.foot_joints)]

    def contact_points(self) -> np.ndarray:
        """World positions of the four feet's ground points, shape (T, 4, 3) (m): each
        foot's toe tip (its joint's end site) where the skeleton gives one, else the
        foot joint. A paw rolling over its toe at push-off lifts its joint while the
        toe tip stays planted, so stance, slide and penetration are measured here."""
        if self.foot_joints is None:
            raise ValueError("this motion does not name its foot joints")
        feet = self.skeleton.indices(self.foot_joints)
        P = self.world_positions()[:, feet]
        ends = np.array([self.skeleton.end_sites.get(n, np.zeros(3)) for n in self.foot_joints],
                        dtype=float)
        if not np.any(ends):
            return P
        return P + np.einsum("tlij,lj->tli", self.world_rotations_of(feet), ends)

    # --------------------------------------------------------------- editing
    def _replace(self, index, **kw) -> Motion:
        def pick(a):
            return None if a is None else a[index]

        args = dict(
            skeleton=self.skeleton, fps=self.fps,
            root_positions=self.root_positions[index], rotations=self.rotations[index],
            contacts=pick(self.contacts), gaits=pick(self.gaits),
            foot_joints=self.foot_joints,
            extras={k: v[index] for k, v in self.extras.items()},
        )
        args.update(kw)
        return Motion(**args)

    def __getitem__(self, index) -> Motion:
        """Frames selected by a slice (or index array), keeping the frame rate."""
        if isinstance(index, (int, np.integer)):
            index = slice(int(index), int(index) + 1 if index != -1 else None)
        return self._replace(index)

    def time_slice(self, start: float, stop: float) -> Motion:
        """Frames with ``start <= t < stop`` (seconds from the first frame)."""
        i0 = int(np.ceil(start * self.fps - 1e-9))
        i1 = int(np.ceil(stop * self.fps - 1e-9))
        return self[max(i0, 0):max(i1, 0)]

    def resample(self, fps: float) -> Motion:
        """The same motion at another frame rate.

        Root positions are interpolated linearly and rotations by slerp;
        contacts, gait labels and extras take the nearest earlier frame.
        The duration is kept: the last new frame is at or before the last old one.
        """
        fps = float(fps)
        if not np.isfinite(fps) or fps <= 0:
            raise ValueError(f"`fps` must be a positive number, got {fps!r}")
        T = len(self)
        if T < 2:
            return Motion(self.skeleton, fps, self.root_positions, self.rotations,
                          self.contacts, self.gaits, self.foot_joints, self.extras)
        n = int(np.floor(self.duration * fps + 1e-9)) + 1
        src = np.arange(n) * (self.fps / fps)
        i0 = np.clip(np.floor(src).astype(int), 0, T - 1)
        i1 = np.clip(i0 + 1, 0, T - 1)
        a = src - i0
        root = self.root_positions[i0] * (1 - a[:, None]) + self.root_positions[i1] * a[:, None]
        rot = quaternion_slerp(self.rotations[i0], self.rotations[i1],
                               np.broadcast_to(a[:, None], (n, self.skeleton.n_joints)))
        near = i0
        return Motion(
            self.skeleton, fps, root, rot,
            None if self.contacts is None else self.contacts[near],
            None if self.gaits is None else self.gaits[near],
            self.foot_joints,
            {k: v[near] for k, v in self.extras.items()},
        )

    @staticmethod
    def concatenate(motions: list[Motion]) -> Motion:
        """Join motions of the same skeleton and frame rate end to end."""
        if not motions:
            raise ValueError("nothing to concatenate")
        m0 = motions[0]
        for m in motions[1:]:
            if m.skeleton is not m0.skeleton or m.fps != m0.fps:
                raise ValueError("motions must share their skeleton and frame rate")

        def cat(attr):
            vals = [getattr(m, attr) for m in motions]
            return None if any(v is None for v in vals) else np.concatenate(vals)

        keys = set.intersection(*(set(m.extras) for m in motions))
        return Motion(m0.skeleton, m0.fps, cat("root_positions"), cat("rotations"),
                      cat("contacts"), cat("gaits"), m0.foot_joints,
                      {k: np.concatenate([m.extras[k] for m in motions]) for k in keys})
