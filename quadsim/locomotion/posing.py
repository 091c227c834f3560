"""From a body plan to joint rotations: spine, neck, tail and leg IK.

The controller decides, per frame, where the pelvis is, how the back bends,
where each foot must be and how folded each swinging leg is (a *plan*). This
module turns plans into local joint rotations and world joint positions,
for any number of frames (or characters of one kind) at once, with one
compiled kernel (:mod:`quadsim.locomotion.pose_kernel`): the spine, neck and
tail are set directly, forward kinematics gives each leg's girdle, the leg
IK places the feet, and forward kinematics of the whole skeleton follows.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from quadsim.kinematics.ik import LegGeometry, leg_geometry
from quadsim.locomotion.blocks import FixedEntry, run_blocks
from quadsim.locomotion.pose_kernel import (
    PARALLEL_ROWS,
    PoseRig,
    PoseScratch,
    pack_legs,
    pack_plan,
    plan_columns,
    pose_rig,
    pose_rows,
    pose_scratch,
)
from quadsim.skeleton.character import Character

#: Plan fields and their per-frame shapes (T leading).
PLAN_FIELDS = {
    "root": (3,),          # pelvis world position (m)
    "heading": (),         # pelvis heading (rad)
    "pitch": (),           # extra whole-body pitch, positive nose down (rad)
    "sway": (2,),          # hind and fore girdle yaw sway (rad)
    "bend_yaw": (),        # spine yaw bend, pelvis to thorax (rad), positive left
    "bend_pitch": (),      # spine flexion, positive arching (rad)
    "feet": (4, 3),        # foot targets (m)
    "fold": (4,),          # swing fold 0..1
    "toe": (4,),           # toe pitch (rad)
    "load": (4,),          # stance load over the body's weight (optional: else none)
    "tail": (None, 2),     # tail joint (pitch, yaw) local angles (rad)
    "look": (),            # head yaw relative to the thorax (rad)
    "foot_yaw": (4,),      # world yaw each foot keeps (rad; optional: else the heading's)
}


@dataclass(frozen=True, eq=False)
class Poser:
    """Precomputed posing data for one character.

    ``legs`` holds each leg's IK geometry (LF, RF, LH, RH); ``trunk`` the
    joints the legs hang from and the thorax, with their ancestors
    (increasing): all the first forward kinematics pass needs. The posing
    itself is the compiled :func:`~quadsim.locomotion.pose_kernel.pose_rows`.
    """

    character: Character
    legs: tuple[LegGeometry, ...]
    trunk: np.ndarray | None = None

    @classmethod
    def for_character(cls, character: Character) -> Poser:
        legs = tuple(leg_geometry(character, leg) for leg in character.legs)
        # the trunk: the joints the legs hang from and the thorax, with their ancestors
        sk = character.skeleton
        need = {int(g.parent) for g in legs} | {int(character.spine[-1])}
        trunk = set()
        for j in need:
            while j >= 0 and j not in trunk:
                trunk.add(j)
                j = int(sk.parents[j]) if j else -1
        return cls(character, legs, np.array(sorted(trunk)))

    def pose(self, plan: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Local rotations for plans of T frames.

        Parameters
        ----------
        plan : dict
            Arrays with the shapes of :data:`PLAN_FIELDS`, each with a
            leading frame axis T (``tail`` may carry extra zero-padded joints).

        Returns
        -------
        local : ndarray, shape (T, J, 3, 3)
        root : ndarray, shape (T, 3)
            Pelvis world position (m).
        ik_error : ndarray, shape (T, 4)
            Distance between each foot target and the foot reached (m).
        """
        rows = pack_plan(plan, len(self.character.tail))
        local, _, err = self.pose_packed(rows)
        return local, rows[:, :3].copy(), err

    def pose_packed(self, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Pose packed plans (:func:`~quadsim.locomotion.pose_kernel.pack_plan`)
        with the compiled kernel.

        Parameters
        ----------
        rows : ndarray, shape (T, F)
            F at least :func:`~quadsim.locomotion.pose_kernel.plan_columns`
            of the character's tail (extra columns are ignored).

        Returns
        -------
        local : ndarray, shape (T, J, 3, 3)
        positions : ndarray, shape (T, J, 3)
            World position of every joint (m).
        ik_error : ndarray, shape (T, 4)
            Distance between each foot target and the foot reached (m).
        """
        width = plan_columns(len(self.character.tail))
        if rows.ndim != 2 or rows.shape[1] < width:  # the kernel does not check bounds
            raise ValueError(f"`rows` has shape {rows.shape}, expected (T, >= {width})")
        T = rows.shape[0]
        J = self.character.skeleton.n_joints
        local = np.empty((T, J, 3, 3))
        positions = np.empty((T, J, 3))
        err = np.empty((T, 4))
        rows = np.ascontiguousarray(rows, dtype=float)
        if not rows.flags.writeable:  # the one array type the entry is called with
            rows = rows.copy()
        rig, kernel = self.rig, self.entry
        if T >= PARALLEL_ROWS:  # blocks of rows on threads: the same result
            run_blocks(lambda a, e: kernel(rows[a:e], rig, local[a:e], positions[a:e],
                                           err[a:e], pose_scratch(rig, e - a)), T)
        else:
            kernel(rows, rig, local, positions, err, pose_scratch(rig, T))
        return local, positions, err

    def pose_row(self, row: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`pose_packed` of one packed plan, into fresh arrays of one frame
        (the interactive step's fast way: no checks, no conversion).

        Parameters
        ----------
        row : ndarray, shape (1, F)
            A writable C-contiguous float64 packed plan, F at least
            :func:`~quadsim.locomotion.pose_kernel.plan_columns` of the
            character's tail (the caller's promise: it is not checked).

        Returns
        -------
        local : ndarray, shape (J, 3, 3)
        positions : ndarray, shape (J, 3)
            World position of every joint (m).
        ik_error : ndarray, shape (4,)
            Distance between each foot target and the foot reached (m).

        Each owns its data (the kernel writes through one-frame views of them).
        """
        J = self._n_joints
        local, positions, err = np.empty((J, 3, 3)), np.empty((J, 3)), np.empty(4)
        self.entry(row, self.rig, local.reshape(1, J, 3, 3), positions.reshape(1, J, 3),
                   err.reshape(1, 4), self._row_scratch)
        return local, positions, err

    @cached_property
    def _n_joints(self) -> int:
        return self.character.skeleton.n_joints

    @cached_property
    def _row_scratch(self) -> PoseScratch:
        """:meth:`pose_row`'s work space (one frame; the interactive step is one thread's)."""
        return pose_scratch(self.rig, 1)

    @cached_property
    def entry(self) -> FixedEntry:
        """:func:`pose_rows` called for this character's arrays, skipping the dispatch:
        ``entry(rows, rig, local, positions, err, scratch)`` with :attr:`rig`, the arrays
        of :meth:`pose_packed` (writable, C-contiguous, float64; not checked) and a
        :func:`~quadsim.locomotion.pose_kernel.pose_scratch` of the call's own."""
        return FixedEntry(pose_rows)

    @cached_property
    def rig(self) -> PoseRig:
        """The character's constants as :func:`pose_rows` takes them."""
        ch = self.character
        sk = ch.skeleton
        trunk = self.trunk if self.trunk is not None else np.arange(sk.n_joints)

        nod = math.radians(float(ch.locomotion.get("head_nod_deg", 0.0)))
        return pose_rig(sk.parents, sk.offsets, ch.spine[1:], ch.tail, ch.neck, trunk,
                        int(ch.spine[-1]), pack_legs(self.legs), nod)
