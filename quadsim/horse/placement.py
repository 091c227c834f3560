"""Putting the data-driven horse's clip pose in the world, every frame, every mode.

:class:`Placement` holds what the compiled
:func:`~quadsim.horse.place_kernel.place_row` reads and carries from frame to
frame (:mod:`quadsim.horse.bundles`) and calls it once per frame:

* **Heading.** The heading change turns the body about its middle; the clip's
  travel goes along the new heading.
* **Head to root.** The body joints lead the root towards the turn (and
  towards the slope ahead): the head first and most, the neck, then the back
  (:class:`~quadsim.horse.turning.BodyLead`), as the seed's head-down turning.
* **Slopes.** The body pitches with the ground between the hips and the
  shoulders (time constant :data:`PITCH_TAU`) -- the seed's "turning in the
  vertical" -- and is lifted so the clip's feet meet the slope.
* **Planted feet.** A foot on the ground (the clip's contact, or at the clip's
  ground) is held where it struck, on the ground; between two clip frames a
  foot counts as down only if it is down on both (the clip's own foot is
  lifting or landing there). The root moves by the mean offset of the planted
  feet the clip holds within :data:`ROOT_BAND` of its ground (equation 11 in
  the world, at most :data:`SHIFT_SPEED`), the legs reach the plants by
  two-bone IK, and when a planted foot is beyond its leg's reach the body is
  lowered a little (:data:`REACH`, recovering over :data:`SAG_TAU`). A lifted
  foot's offset from the clip (the IK's correction on its last planted frame)
  fades over its first :data:`~quadsim.horse.turning.SWING_FADE` s of swing,
  and a swing foot keeps the clip's height above the ground (high up over
  ground rising above the body's plane it follows the pose). Where the clip's
  own feet stay put (a steady gait, straight on), the legs thus replay the
  clip's rotations: no joint turns faster in a frame than in the clip
  (``tests/test_horse_smoothness.py``).
"""

from __future__ import annotations

import numpy as np

from ..skeleton.character import Character
from .bundles import PlacedPose, PlaceFrame, PlaceRig, PlaceState, PlaceTuning
from ..kinematics.compiled import FixedEntry
from ..kinematics.legs import leg_geometry
from .place_kernel import LEG_VECTORS, WORK_MATRICES, place_row
from .turning import (
    GROUND_BAND,
    MAX_PITCH_LEAD,
    MAX_YAW_LEAD,
    SWING_FADE,
    SWING_HIGH,
    SWING_LOW,
    BodyLead,
    FootPlanter,
)

#: Fastest the root is moved onto the planted feet (m/s), over the clip's own travel.
SHIFT_SPEED = 1.0
#: A planted foot at most this high (m) above the clip's ground moves the root (equation 11).
ROOT_BAND = 0.01
#: Fraction of a leg's two-bone reach a planted foot may use before the body is lowered.
REACH = 0.995
#: Time constant (s) of the body rising again after it was lowered.
SAG_TAU = 0.25
#: Time constant (s) of the body's pitch following the ground.
PITCH_TAU = 0.12
#: How far ahead of the shoulders (m) the head looks for the slope.
LOOK_DISTANCE = 1.0

#: The placement's constants, as the kernel reads them.
TUNING = PlaceTuning(
    look_distance=LOOK_DISTANCE, pitch_tau=PITCH_TAU, sag_tau=SAG_TAU, reach=REACH,
    shift_speed=SHIFT_SPEED, root_band=ROOT_BAND, ground_band=GROUND_BAND,
    swing_fade=SWING_FADE, swing_low=SWING_LOW, swing_high=SWING_HIGH,
    max_yaw_lead=MAX_YAW_LEAD, max_pitch_lead=MAX_PITCH_LEAD)


class Placement:
    """The world placement of one character's clip poses, frame after frame.

    Parameters
    ----------
    character : Character

    Attributes
    ----------
    lead : BodyLead
    planter : FootPlanter
    rig : PlaceRig
    state : PlaceState
    girdles : tuple of float
        The hips' and the shoulders' distance ahead of the root at rest (m).
    rest_height : float
        The root's height over the feet at rest (m).
    """

    def __init__(self, character: Character):
        skel = character.skeleton
        self.lead = BodyLead(character)
        self.planter = FootPlanter()
        feet = np.array([leg.foot for leg in character.legs], dtype=np.int64)
        tops = np.array([leg.chain[leg.ik_start] for leg in character.legs], dtype=np.int64)
        mids = np.array([leg.chain[leg.ik_start + 1] for leg in character.legs], dtype=np.int64)
        rest = skel.rest_positions
        ahead = rest[tops, 2] - rest[0, 2]
        self.girdles = (float(ahead[2:].mean()), float(ahead[:2].mean()))
        centre = 0.5 * sum(self.girdles)
        self.rest_height = float(rest[0, 1] - rest[feet, 1].mean())
        self.rig = PlaceRig(np.ascontiguousarray(skel.parents, dtype=np.int64),
                            np.ascontiguousarray(skel.offsets, dtype=float),
                            self.lead.chain, self.lead.share, self.lead.tau, feet, tops, mids,
                            float(centre), self.girdles[0], self.girdles[1],
                            _below(skel.parents, feet),
                            np.array([skel.end_sites.get(skel.names[f], np.zeros(3))
                                      for f in feet], dtype=float).reshape(4, 3),
                            *_tucks(character))
        self.state = PlaceState(np.zeros(3), np.zeros(1), np.zeros(1), self.lead.state,
                                self.planter.state)
        self._place_row = FixedEntry(place_row)
        self._scratch = np.empty((skel.n_joints + WORK_MATRICES, 3, 3))
        self._legs = np.empty((LEG_VECTORS, 4, 3))
        self._clearance = np.empty(4)
        self._n_joints = skel.n_joints

    @property
    def pitch(self) -> float:
        """Body pitch (rad), nose up: follows the ground between the hips and the shoulders."""
        return float(self.state.pitch[0])

    @property
    def sag(self) -> float:
        """How far the body is lowered for its planted legs (m)."""
        return float(self.state.sag[0])

    @property
    def position(self) -> np.ndarray:
        """World position (3,) of the root on the ground plane ``(x, 0, z)`` (m)."""
        return self.state.position

    def place(self, local, local_prev, q, contacts, first: bool, dt: float, yaw: float,
              yaw_prev: float, yaw_lead: float, ramps: np.ndarray) -> PlacedPose:
        """Place a clip-local pose (see :class:`~quadsim.horse.bundles.PlaceFrame` for
        the arguments; ``ramps`` the ground's ramp table); returns fresh output arrays.

        The compiled kernel is called through its entry point (:class:`FixedEntry`):
        the arguments must have the same types every frame -- C-contiguous float64
        arrays ``local``, ``local_prev`` (3,), ``q`` (J, 4) and ``ramps`` (R, 6), a
        C-contiguous bool array ``contacts`` (4,), a bool ``first`` and floats -- as
        :class:`~quadsim.horse.controller.HorseDataController` passes them
        (``tests/test_horse_controller.py`` checks it over a tour of every mode).
        """
        J = self._n_joints
        empty = np.empty
        out = PlacedPose(empty((J, 3, 3)), empty((J, 4)), empty((J, 3)), empty(3),
                         empty(4, dtype=np.bool_), empty(4), self._scratch, self._legs,
                         self._clearance, empty(4))
        self._place_row(PlaceFrame(local, local if first else local_prev, q, contacts, first,
                                   dt, yaw, yaw_prev, yaw_lead),
                        self.rig, TUNING, self.state, ramps, out)
        return out


def _tucks(character: Character) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:class:`PlaceRig`'s ``tuck_joints``, ``tuck_turns`` and ``tuck_scales``: for each
    leg whose digit the procedural IK carries in swing (:func:`leg_geometry`'s
    ``carry``), the turns of the digit's joints and of the foot joint about +X that
    carry makes at a full fold (a joint's turn is its bone's change of angle less the
    bone above's, negated: a turn about +X swings a bone back), the first digit
    joint's turn at a full fold in an untucked clip (its bone's fold less the bone
    above's, negated), the tuck's full height and the foot joint's standing height."""
    rest = character.skeleton.rest_positions
    rows = []
    for leg in character.legs:
        geom = leg_geometry(character, leg)
        d0, n = leg.ik_start + 3, len(geom.lengths)
        if not geom.carry.any() or d0 >= n:
            rows.append(([], [], (1.0, 1.0, 0.0)))
            continue
        phi = np.append(geom.carry[d0:], geom.foot_carry)  # the bones' and the foot's
        turns = -np.diff(np.concatenate([[0.0], phi]))
        scales = (-(geom.fold[d0] - geom.fold[d0 - 1]), geom.tuck_height,
                  float(rest[leg.foot, 1]))
        rows.append((list(leg.chain[d0:n + 1]), list(turns), scales))
    k = max(1, max(len(r[0]) for r in rows))
    joints = np.full((4, k), -1, dtype=np.int64)
    turns = np.zeros((4, k))
    scales = np.array([r[2] for r in rows], dtype=float)
    for i, (js, ts, _) in enumerate(rows):
        joints[i, :len(js)] = js
        turns[i, :len(ts)] = ts
    return joints, turns, scales


def _below(parents, feet) -> np.ndarray:
    """Per foot joint, the joints below it in joint order, shape (4, K), padded with -1."""
    parents = np.asarray(parents)
    rows = []
    for f in feet:
        inside, row = {int(f)}, []
        for j in range(int(f) + 1, len(parents)):  # a parent comes before its children
            if int(parents[j]) in inside:
                inside.add(j)
                row.append(j)
        rows.append(row)
    out = np.full((4, max(1, max(len(r) for r in rows))), -1, dtype=np.int64)
    for i, r in enumerate(rows):
        out[i, :len(r)] = r
    return out


__all__ = ["LOOK_DISTANCE", "PITCH_TAU", "REACH", "ROOT_BAND", "SAG_TAU", "SHIFT_SPEED",
           "TUNING", "Placement"]
