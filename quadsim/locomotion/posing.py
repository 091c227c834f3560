"""From a body plan to joint rotations: spine, neck, tail and leg IK.

The controller decides, per frame, where the pelvis is, how the back bends,
where each foot must be and how folded each swinging leg is (a *plan*). This
module turns plans into local joint rotations, vectorised over any number
of frames at once: the spine, neck and tail are set directly, forward
kinematics gives each leg's girdle, and the leg IK places the feet.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from quadsim.kinematics.ik import LegGeometry, leg_geometry, solve_leg, stack_leg_geometries
from quadsim.kinematics.rotations import matrices_about_axis
from quadsim.skeleton.character import Character
from quadsim.skeleton.fk import forward_kinematics

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
    "tail": (None, 2),     # tail joint (pitch, yaw) local angles (rad)
    "look": (),            # head yaw relative to the thorax (rad)
}


@dataclass(frozen=True, eq=False)
class Poser:
    """Precomputed posing data for one character.

    ``groups`` gathers the legs the IK solves together, as one stacked
    geometry each (:func:`~quadsim.kinematics.ik.stack_leg_geometries`):
    legs with the same number of bones, pair bone and joint limits' use
    (a left leg and its right partner, or all four), with their leg indices.
    """

    character: Character
    legs: tuple[LegGeometry, ...]
    groups: tuple[tuple[np.ndarray, LegGeometry], ...] = ()

    @classmethod
    def for_character(cls, character: Character) -> Poser:
        legs = tuple(leg_geometry(character, leg) for leg in character.legs)
        keys: dict[tuple, list[int]] = {}
        for i, g in enumerate(legs):
            keys.setdefault((g.n_bones, g.pair, g.limited), []).append(i)
        groups = tuple((np.array(idx), stack_leg_geometries([legs[i] for i in idx]))
                       for idx in keys.values())
        return cls(character, legs, groups)

    def pose(self, plan: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Local rotations for plans of T frames.

        Parameters
        ----------
        plan : dict
            Arrays with the shapes of :data:`PLAN_FIELDS`, each with a
            leading frame axis T.

        Returns
        -------
        local : ndarray, shape (T, J, 3, 3)
        root : ndarray, shape (T, 3)
        ik_error : ndarray, shape (T, 4)
            Distance between each foot target and the foot reached (m).
        """
        ch = self.character
        sk = ch.skeleton
        root = np.asarray(plan["root"], dtype=float)
        T = root.shape[0]
        J = sk.n_joints
        L = np.broadcast_to(np.eye(3), (T, J, 3, 3)).copy()
        rx = lambda a: matrices_about_axis(0, a)
        ry = lambda a: matrices_about_axis(1, a)

        spine = ch.spine[1:]
        K = len(spine)
        flex = plan["bend_pitch"]
        sway = plan["sway"]
        # pelvis: heading plus hind sway, tilted back by half the flexion
        L[:, 0] = ry(plan["heading"] + sway[:, 0]) @ rx(plan["pitch"] - 0.5 * flex)
        per_yaw = plan["bend_yaw"][:, None] / K * np.ones(K)
        per_pitch = flex[:, None] / K * np.ones(K)
        per_yaw[:, 0] -= sway[:, 0]
        per_yaw[:, -1] += sway[:, 1]
        L[:, spine] = ry(per_yaw) @ rx(per_pitch)

        # tail: lagged angles computed by the controller
        if len(ch.tail):
            tail = np.asarray(plan["tail"])
            L[:, ch.tail] = ry(tail[..., 1]) @ rx(tail[..., 0])

        G, P = forward_kinematics(sk, L, root)
        # neck and head: keep the head level, look into the turn
        if len(ch.neck):
            thorax = G[:, ch.spine[-1]]
            fwd = thorax[:, :, 2]
            pitch = np.arcsin(np.minimum(np.maximum(-fwd[:, 1], -1), 1))  # nose-down positive
            n = len(ch.neck)
            L[:, ch.neck] = (ry(plan["look"][:, None] / n * np.ones(n))
                             @ rx(-pitch[:, None] / n * np.ones(n)))

        err = np.zeros((T, 4))
        for idx, geom in self.groups:
            local, err[:, idx] = solve_leg(geom, G[:, geom.parent], P[:, geom.parent],
                                           plan["feet"][:, idx], plan["fold"][:, idx],
                                           plan["toe"][:, idx])
            L[:, geom.chain] = local
        return L, root, err
