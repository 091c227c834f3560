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
:func:`apply_body_lead` puts those leads into a pose.

:class:`FootPlanter` keeps every stance foot where it struck the ground: each
frame the root moves by the mean offset between the stance feet's recorded
positions and where the pose would put them (the seed's equation 11, the
"adjust the position of the root" step), and the remaining per-foot offsets are
closed by IK (:func:`quadsim.horse.legs.two_bone`). When a foot lifts off,
the correction it had on its last planted frame (its plant minus where the pose
put it) is faded out over the first :data:`SWING_FADE` seconds of its swing, so
the foot does not jump; swing feet keep the clip's height above the (possibly
sloped) ground -- except that a high foot over ground rising above the body's
plane (the level after a descent) follows the pose (:data:`SWING_LOW`,
:data:`SWING_HIGH`): reaching up for it would swing the leg through straight,
where the two-bone IK's bend flips side. The correction is the one of the
last planted frame, not the plant against the first lifted pose: a clip's foot
may leave the ground at twice the body's speed (a canter's fore foot moves
0.19 m in its first frame of swing at 6 m/s), and holding it back at the plant
for a fade would stretch the leg nearly straight and let it snap back a frame
later.
"""

from __future__ import annotations

import math

import numpy as np

from ..kinematics.rotations import matrices_about_axis
from ..skeleton.character import Character
from .legs import two_bone
from .slope import Ground

#: Time (s) over which a lifted foot's planted offset fades out.
SWING_FADE = 0.2
#: A swing foot up to this high (m) keeps the clip's clearance over ground rising above the
#: body's plane; from :data:`SWING_HIGH` up it follows the pose (at least half its clearance
#: over the ground).
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


def _smoothstep(x):
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


class BodyLead:
    """Yaw and pitch leads of the body joints over the root, head first.

    Parameters
    ----------
    character : Character
        Its ``spine`` (root first), ``neck`` and ``head`` joints form the chain.

    Attributes
    ----------
    chain : ndarray of int, shape (n,)
        Joint indices, root (pelvis) first, head last.
    share : ndarray, shape (n,)
        Fraction of the full lead each joint takes (0 at the root, 1 at the head).
    tau : ndarray, shape (n,)
        Follow time constant of each joint (s): the head is quickest.
    yaw, pitch : ndarray, shape (n,)
        Current leads (rad), global, relative to the root's orientation.
    """

    def __init__(self, character: Character):
        self.chain = np.concatenate([np.asarray(character.spine, dtype=int),
                                     np.asarray(character.neck, dtype=int),
                                     [int(character.head)]])
        n = len(self.chain)
        ns = len(character.spine)
        # the back takes a fifth of the lead (a horse's back bends little), neck and head the rest
        back = np.linspace(0.0, 0.2, ns)
        front = np.linspace(0.2, 1.0, n - ns + 1)[1:]
        self.share = np.concatenate([back, front])
        # the head follows in 0.08 s, the joints towards the root more slowly (0.3 s)
        self.tau = np.linspace(0.3, 0.08, n)
        self.yaw = np.zeros(n)
        self.pitch = np.zeros(n)

    def update(self, yaw_lead: float, pitch_lead: float, dt: float) -> None:
        """Move each joint's leads towards its share of the wanted leads (rad) over ``dt`` (s)."""
        a = 1.0 - np.exp(-dt / self.tau)
        y = float(np.clip(yaw_lead, -MAX_YAW_LEAD, MAX_YAW_LEAD))
        p = float(np.clip(pitch_lead, -MAX_PITCH_LEAD, MAX_PITCH_LEAD))
        self.yaw += a * (self.share * y - self.yaw)
        self.pitch += a * (self.share * p - self.pitch)


def chain_world(chain: np.ndarray, local: np.ndarray) -> np.ndarray:
    """World rotations (n, 3, 3) of a root-first joint chain from the local ones (J, 3, 3)."""
    out = np.empty((len(chain), 3, 3))
    out[0] = local[chain[0]]
    for k in range(1, len(chain)):            # a chain of ~9 joints: cheaper than full FK
        out[k] = out[k - 1] @ local[chain[k]]
    return out


def apply_body_lead(chain: np.ndarray, local: np.ndarray, yaw: np.ndarray,
                    pitch: np.ndarray, heading: float) -> np.ndarray:
    """Local rotations with the chain joints turned by their global leads.

    Joint ``chain[k]``'s world rotation becomes ``A_k W_k``, with
    ``A_k = Y(yaw_k) Xh(-pitch_k)`` (a yaw about world +Y and a nose-up pitch
    about the horizontal lateral axis of ``heading``); everything below a
    chain joint turns with it.

    Parameters
    ----------
    chain : ndarray of int, shape (n,)
        Root first; each joint's parent is the previous one.
    local : ndarray, shape (J, 3, 3)
        Local rotation matrices (the root's is its world orientation).
    yaw, pitch : ndarray, shape (n,)
        Leads (rad); ``yaw[0]`` and ``pitch[0]`` should be 0.
    heading : float
        The root's heading (rad about +Y).

    Returns
    -------
    local : ndarray, shape (J, 3, 3)
    """
    Yh = matrices_about_axis(1, heading)
    X = matrices_about_axis(0, -np.asarray(pitch))                      # (n, 3, 3)
    A = matrices_about_axis(1, np.asarray(yaw)) @ (Yh @ X @ Yh.T)       # (n, 3, 3)
    out = np.array(local)
    k = chain[1:]
    Wp = chain_world(chain, local)[:-1]
    # L_k' = Wp^T A_par^T A_k Wp L_k
    rel = np.swapaxes(A[:-1], -1, -2) @ A[1:]
    out[k] = np.swapaxes(Wp, -1, -2) @ rel @ Wp @ local[k]
    return out


def place_feet_pose(parents: np.ndarray, pairs: tuple[np.ndarray, np.ndarray],
                    feet_idx: np.ndarray, local: np.ndarray, world: np.ndarray,
                    positions: np.ndarray, targets: np.ndarray) -> np.ndarray:
    """One pose's legs put on their targets at once (the four-leg batch of
    :func:`quadsim.horse.legs.place_feet`: the same :func:`~quadsim.horse.legs.two_bone`).

    Parameters
    ----------
    parents : ndarray of int, shape (J,)
    pairs : tuple of two ndarray of int, shape (4,)
        Each leg's two-bone pair: its top (hip/shoulder) and middle joints.
    feet_idx : ndarray of int, shape (4,)
        The foot joints.
    local : ndarray, shape (J, 3, 3)
        Local rotations of the pose.
    world, positions : ndarray, shapes (J, 3, 3) and (J, 3)
        Its forward kinematics.
    targets : ndarray, shape (4, 3)
        Wanted foot positions (m); unreachable ones are approached.

    Returns
    -------
    local : ndarray, shape (J, 3, 3)
        Only the pairs' two joints changed; the bones below keep their angles.
    """
    top, mid = pairs
    out = np.array(local)
    out[top], out[mid] = two_bone(positions[top], positions[mid], positions[feet_idx],
                                  world[parents[top]], world[top], world[mid], targets)
    return out


class FootPlanter:
    """Plant each stance foot where it struck and fade out its offset in the swing.

    Attributes
    ----------
    planted : ndarray of bool, shape (4,)
    plant : ndarray, shape (4, 3)
        World position of each planted foot (m), on the ground.
    offset : ndarray, shape (4, 2)
        Horizontal offset [x, z] (m) of a lifted foot's target from its pose
        position: its :attr:`hold` at lift-off, faded out over :data:`SWING_FADE`.
    hold : ndarray, shape (4, 2)
        Horizontal correction [x, z] (m) of each planted foot this frame (its
        plant minus where the pose puts it), 0 for the others.
    air : ndarray, shape (4,)
        Time since lift-off (s).
    """

    def __init__(self) -> None:
        self.planted = np.zeros(4, dtype=bool)
        self.plant = np.zeros((4, 3))
        self.offset = np.zeros((4, 2))
        self.hold = np.zeros((4, 2))
        self.air = np.full(4, np.inf)
        self.drop = np.zeros(4)
        self.started = False

    def root_shift(self, contacts: np.ndarray, feet: np.ndarray) -> np.ndarray:
        """Horizontal root move (3,) (m) putting the staying stance feet on their plants on average.

        Parameters
        ----------
        contacts : ndarray of bool, shape (4,)
            Feet on the ground this frame.
        feet : ndarray, shape (4, 3)
            Where the pose puts the feet (m).
        """
        stay = self.planted & contacts
        if not self.started or not stay.any():
            return np.zeros(3)
        d = self.plant[stay] - feet[stay]
        return np.array([d[:, 0].mean(), 0.0, d[:, 2].mean()])

    def targets(self, contacts: np.ndarray, feet: np.ndarray, clearance: np.ndarray,
                ground: Ground, dt: float) -> np.ndarray:
        """Foot targets (4, 3) (m) for this frame, updating the plants.

        Parameters
        ----------
        contacts : ndarray of bool, shape (4,)
            The clip's contacts; a foot whose clearance is within
            :data:`GROUND_BAND` counts as on the ground too (the planted set is
            then in :attr:`contacts`).
        feet : ndarray, shape (4, 3)
            Where the (root-shifted) pose puts the feet (m).
        clearance : ndarray, shape (4,)
            Each foot's height above the ground in the clip (m); swing feet keep it
            (a high one over ground rising above the body's plane follows the pose).
        ground : Ground
        dt : float
            Time since the previous frame (s).
        """
        # a foot the clip puts on the ground is planted even if not yet labelled
        contacts = np.asarray(contacts, dtype=bool) | (np.asarray(clearance) <= GROUND_BAND)
        if not self.started:
            self.started = True
            self.planted[:] = False
        lift = self.planted & ~contacts
        # the correction the foot had on its last planted frame (not its plant against the
        # lifted pose: the clip's foot may already be well on its way)
        self.offset[lift] = self.hold[lift]
        self.air[lift] = 0.0
        swing = ~contacts
        self.air[swing & ~lift] += dt
        fade = 1.0 - _smoothstep(self.air / SWING_FADE)
        tgt = np.array(feet, dtype=float)
        tgt[:, [0, 2]] += self.offset * np.where(np.isfinite(fade), fade, 0.0)[:, None]
        # a swing foot keeps the clip's clearance over the ground under it; where that ground
        # rises above the body's plane (the foot of a climb ahead), a foot higher than
        # SWING_LOW blends into the pose instead (at least half its clearance over the
        # ground), so a change of slope under a high foot does not bend the leg
        clear = np.maximum(clearance, 0.0)
        over = ground.height_at(tgt) + clear
        w = 1.0 - _smoothstep((clear - SWING_LOW) / (SWING_HIGH - SWING_LOW))
        tgt[:, 1] = np.maximum(np.minimum(over, feet[:, 1] + w * (over - feet[:, 1])),
                               over - 0.5 * clear)
        strike = contacts & ~self.planted
        self.plant[strike] = tgt[strike]
        self.plant[strike, 1] = ground.height_at(tgt[strike])
        # how far each striking foot was put down onto the ground (m), 0 for the others
        self.drop = np.where(strike, tgt[:, 1] - ground.height_at(tgt), 0.0)
        self.planted = contacts.copy()
        tgt[contacts] = self.plant[contacts]
        self.hold = np.where(contacts[:, None], tgt[:, [0, 2]] - feet[:, [0, 2]], 0.0)
        self.contacts = contacts
        return tgt


__all__ = ["BodyLead", "FootPlanter", "GROUND_BAND", "LOOK_AHEAD", "MAX_PITCH_LEAD",
           "MAX_YAW_LEAD", "SWING_FADE", "apply_body_lead", "chain_world", "place_feet_pose"]
