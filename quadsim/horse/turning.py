"""Turning and pitching the horse's body from the head down, and keeping stance feet planted.

The seed (section 6.2) turns the horse by turning "the global orientation of
the bones on the Body ... from the head joint to the root": the head turns
first, the neck follows, then the back and the root, and the turning angle per
frame grows with speed. A striking foot's landing point is recorded and kept
while the foot is in stance, by adjusting the root's position and then IK.

:class:`BodyLead` holds how far each body joint (pelvis, spine, neck, head)
leads the root in yaw (towards the wanted heading) and in pitch (towards the
slope ahead); the joints nearer the head lead by more and follow faster, so a
turn or a change of slope shows first in the head and passes down the body.
Chain joint ``k``'s world rotation ``W_k`` becomes ``A_k W_k``, with
``A_k = Y(yaw_k) Xh(-pitch_k)`` (a yaw about world +Y and a nose-up pitch about
the horizontal lateral axis of the heading); everything below a chain joint
turns with it.

:class:`FootPlanter` keeps every stance foot where it struck the ground: each
frame the root moves by the mean offset between the stance feet's recorded
positions and where the pose would put them (the seed's equation 11, the
"adjust the position of the root" step), and the remaining per-foot offsets are
closed by the two-bone IK (:func:`quadsim.kinematics.chains.two_bone_row`). When a foot lifts off,
the correction it had on its last planted frame (its plant minus where the pose
put it) is faded out over the first :data:`SWING_FADE` seconds of its swing, so
the foot does not jump; swing feet keep the clip's height above the (possibly
sloped) ground (a foot the pose puts higher is eased down onto it, its height
keeping a continuous velocity) -- except that a high foot over ground rising above the body's
plane (the level after a descent) follows the pose (:data:`SWING_LOW`,
:data:`SWING_HIGH`): reaching up for it would swing the leg through straight,
where the two-bone IK's bend flips side. The correction is the one of the
last planted frame, not the plant against the first lifted pose: a clip's foot
may leave the ground at twice the body's speed (a canter's fore foot moves
0.19 m in its first frame of swing at 6 m/s), and holding it back at the plant
for a fade would stretch the leg nearly straight and let it snap back a frame
later.

The classes here hold the state and its meaning; the per-frame work on it is
compiled in :mod:`quadsim.horse.place_kernel`.
"""

from __future__ import annotations

import math

import numpy as np

from ..skeleton.character import Character
from .bundles import FeetState, LeadState

#: Time (s) over which a lifted foot's planted offset fades out.
SWING_FADE = 0.2
#: A swing foot up to this high (m) keeps the clip's clearance over ground rising above the
#: body's plane; from :data:`SWING_HIGH` up it follows the pose (at least 30 % of its
#: clearance over the ground, :data:`~quadsim.horse.place_kernel.MIN_CLEARANCE_FRACTION`).
SWING_LOW = 0.03
SWING_HIGH = 0.12
#: A foot this close to the ground in the clip (m) counts as planted.
GROUND_BAND = 1e-4
#: Largest yaw lead of the head over the root (rad).
MAX_YAW_LEAD = math.radians(35.0)
#: Largest pitch lead of the head over the root (rad).
MAX_PITCH_LEAD = math.radians(15.0)
#: How long ahead (s) the head looks along the current turn.
LOOK_AHEAD = 0.5


class BodyLead:
    """Yaw and pitch leads of the body joints over the root, head first.

    The leads move each frame in :func:`quadsim.horse.place_kernel.place_row`:
    each joint towards its :attr:`share` of the wanted leads (clipped to
    :data:`MAX_YAW_LEAD` and :data:`MAX_PITCH_LEAD`), by ``1 - exp(-dt / tau)``
    of the way.

    Parameters
    ----------
    character : Character
        Its ``spine`` (root first), ``neck`` and ``head`` joints form the chain.

    Attributes
    ----------
    chain : ndarray of int64, shape (n,)
        Joint indices, root (pelvis) first, head last.
    share : ndarray, shape (n,)
        Fraction of the full lead each joint takes (0 at the root, 1 at the head).
    tau : ndarray, shape (n,)
        Follow time constant of each joint (s): the head is quickest.
    state : LeadState
        The leads (rad, global, relative to the root's orientation), moved by the
        placement: :attr:`yaw` and :attr:`pitch` are its fields.
    """

    def __init__(self, character: Character):
        self.chain = np.concatenate([np.asarray(character.spine, dtype=np.int64),
                                     np.asarray(character.neck, dtype=np.int64),
                                     [int(character.head)]]).astype(np.int64)
        n = len(self.chain)
        ns = len(character.spine)
        # the back takes a fifth of the lead (a horse's back bends little), neck and head the rest
        back = np.linspace(0.0, 0.2, ns)
        front = np.linspace(0.2, 1.0, n - ns + 1)[1:]
        self.share = np.concatenate([back, front])
        # the head follows in 0.08 s, the joints towards the root more slowly (0.3 s)
        self.tau = np.linspace(0.3, 0.08, n)
        self.state = LeadState(np.zeros(n), np.zeros(n))

    @property
    def yaw(self) -> np.ndarray:
        """Yaw leads (n,) (rad)."""
        return self.state.yaw

    @property
    def pitch(self) -> np.ndarray:
        """Pitch leads (n,) (rad), nose up."""
        return self.state.pitch


class FootPlanter:
    """Plant each stance foot where it struck and fade out its offset in the swing.

    The state of the four feet, moved each frame by
    :func:`quadsim.horse.place_kernel.place_row`: a foot the clip puts on the
    ground (or within :data:`GROUND_BAND` of it) is planted; on its strike its
    target (the pose's foot plus any fading offset, on the ground) becomes its
    plant, held while it stays down; at lift-off its last planted correction
    becomes its offset, faded out over :data:`SWING_FADE` s of swing; a swing
    foot keeps the clip's clearance over the ground under it (see the module
    notes).

    Attributes
    ----------
    state : FeetState
        Per leg (LF, RF, LH, RH): planted, plant, offset, hold, air, drop, struck and
        attitude
        (:class:`~quadsim.horse.bundles.FeetState`); the properties below are its fields.
    """

    def __init__(self) -> None:
        self.state = FeetState(np.zeros(4, dtype=np.bool_), np.zeros((4, 3)), np.zeros((4, 2)),
                               np.zeros((4, 2)), np.full(4, np.inf), np.zeros(4),
                               np.zeros(4, dtype=np.bool_), np.tile([1.0, 0, 0, 0], (4, 1)))

    @property
    def planted(self) -> np.ndarray:
        """Whether each foot is planted (on the ground this frame), (4,) bool."""
        return self.state.planted

    @property
    def plant(self) -> np.ndarray:
        """World position (4, 3) of each planted foot (m), on the ground."""
        return self.state.plant

    @property
    def offset(self) -> np.ndarray:
        """Horizontal offset [x, z] (4, 2) (m) of a lifted foot's target from its pose
        position: its :attr:`hold` at lift-off, faded out over :data:`SWING_FADE`."""
        return self.state.offset

    @property
    def hold(self) -> np.ndarray:
        """Horizontal correction [x, z] (4, 2) (m) of each planted foot this frame (its
        plant minus where the pose puts it), 0 for the others."""
        return self.state.hold

    @property
    def air(self) -> np.ndarray:
        """Time since lift-off (4,) (s); infinite before the first."""
        return self.state.air

    @property
    def drop(self) -> np.ndarray:
        """How far each striking foot was put down onto the ground this frame (4,) (m)."""
        return self.state.drop


__all__ = ["BodyLead", "FootPlanter", "GROUND_BAND", "LOOK_AHEAD", "MAX_PITCH_LEAD",
           "MAX_YAW_LEAD", "SWING_FADE", "SWING_HIGH", "SWING_LOW"]
