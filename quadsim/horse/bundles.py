"""The named bundles the data-driven horse's placement kernel reads and updates.

:func:`quadsim.horse.place_kernel.place_row` takes its inputs and state as
``typing.NamedTuple`` s of arrays and scalars (numba compiles and caches them
like arrays): the character's :class:`PlaceRig`, the constants
:class:`PlaceTuning`, the frame-to-frame :class:`PlaceState` (with the body
lead's :class:`LeadState` and the feet's :class:`FeetState`), one frame's
:class:`PlaceFrame` and the output buffers :class:`PlacedPose`. Booleans are
bool arrays or bools; every field is named.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


class PlaceRig(NamedTuple):
    """A character's joints and body geometry, as the placement reads them (constant).

    Attributes
    ----------
    parents : ndarray of int64, shape (J,)
        Parent of each joint (``parents[j] < j``).
    offsets : ndarray, shape (J, 3)
        Each joint's offset in its parent's frame (m).
    chain : ndarray of int64, shape (n,)
        The body lead's joints, root (pelvis) first, head last.
    share : ndarray, shape (n,)
        Fraction of the full lead each chain joint takes (0 at the root, 1 at the head).
    tau : ndarray, shape (n,)
        Follow time constant of each chain joint (s).
    feet, tops, mids : ndarray of int64, shape (4,)
        Per leg (LF, RF, LH, RH): the foot joint and the two-bone pair's top and middle joints.
    centre : float
        The body's middle ahead of the root along the heading (m): it turns about it.
    hind, fore : float
        The hips' and the shoulders' distance ahead of the root (m), where the ground
        pitch is measured.
    below : ndarray of int64, shape (4, K)
        Per leg, the joints below its foot joint in joint order, padded with -1.
    toes : ndarray, shape (4, 3)
        Per leg, the toe tip (the foot joint's end site) in the foot's frame (m);
        zeros without one.
    tuck_joints : ndarray of int64, shape (4, K)
        Per leg whose hoof tucks in swing (``[locomotion] digit_flex_deg``, the
        procedural IK's carried digit): the digit's joints from its first (the
        fetlock) down to the foot joint, padded with -1; a row of -1 for a leg that
        does not tuck.
    tuck_turns : ndarray, shape (4, K)
        Each of those joints' turn about its +X axis (rad) at a full tuck: the
        procedural IK's carry at a full fold.
    tuck_scales : ndarray, shape (4, 3)
        Per leg: the first digit joint's turn about +X (rad) at a full swing fold in
        the clips (baked untucked), which gives the fold from a clip's pose; the
        height over the ground (m) from which the tuck is full; and the foot joint's
        height standing (m).
    """

    parents: np.ndarray
    offsets: np.ndarray
    chain: np.ndarray
    share: np.ndarray
    tau: np.ndarray
    feet: np.ndarray
    tops: np.ndarray
    mids: np.ndarray
    centre: float
    hind: float
    fore: float
    below: np.ndarray
    toes: np.ndarray
    tuck_joints: np.ndarray
    tuck_turns: np.ndarray
    tuck_scales: np.ndarray


class PlaceTuning(NamedTuple):
    """The placement's constants (see :mod:`quadsim.horse.controller` and
    :mod:`quadsim.horse.turning` for their meaning and values).

    Attributes
    ----------
    look_distance : float
        How far ahead of the shoulders (m) the head looks for the slope.
    pitch_tau, sag_tau : float
        Time constants (s) of the body's pitch and of its rising after a sag.
    reach : float
        Fraction of a leg's two-bone reach a planted foot may use.
    shift_speed : float
        Fastest the root is moved onto the planted feet (m/s).
    root_band, ground_band : float
        Heights (m) over the clip's ground below which a planted foot moves the root,
        and a foot counts as on the ground.
    swing_fade : float
        Time (s) over which a lifted foot's planted offset fades.
    swing_low, swing_high : float
        Swing heights (m) between which a foot goes from keeping the clip's clearance
        to following the pose.
    max_yaw_lead, max_pitch_lead : float
        Largest yaw and pitch leads of the head over the root (rad).
    """

    look_distance: float
    pitch_tau: float
    sag_tau: float
    reach: float
    shift_speed: float
    root_band: float
    ground_band: float
    swing_fade: float
    swing_low: float
    swing_high: float
    max_yaw_lead: float
    max_pitch_lead: float


class LeadState(NamedTuple):
    """How far each body-lead joint leads the root (updated each frame).

    Attributes
    ----------
    yaw, pitch : ndarray, shape (n,)
        Yaw lead and nose-up pitch lead (rad) of each chain joint.
    """

    yaw: np.ndarray
    pitch: np.ndarray


class FeetState(NamedTuple):
    """The four feet's planting state (updated each frame), legs LF, RF, LH, RH.

    Attributes
    ----------
    planted : ndarray of bool, shape (4,)
        The foot is held on its plant.
    plant : ndarray, shape (4, 3)
        Where each planted foot struck, on the ground (m).
    offset : ndarray, shape (4, 2)
        Horizontal offset [x, z] (m) of a lifted foot's target from its pose, fading.
    hold : ndarray, shape (4, 2)
        Horizontal correction [x, z] (m) of each planted foot this frame.
    air : ndarray, shape (4,)
        Time since lift-off (s), infinite before the first.
    drop : ndarray, shape (4,)
        How far each striking foot was put down onto the ground this frame (m).
    struck : ndarray of bool, shape (4,)
        The foot struck the ground this frame.
    attitude : ndarray, shape (4, 4)
        The world rotation ``(w, x, y, z)`` each foot struck with: a planted foot
        keeps it, a lifted one eases from it to the pose's as its offset fades.
    """

    planted: np.ndarray
    plant: np.ndarray
    offset: np.ndarray
    hold: np.ndarray
    air: np.ndarray
    drop: np.ndarray
    struck: np.ndarray
    attitude: np.ndarray


class PlaceState(NamedTuple):
    """What the placement carries from frame to frame.

    Attributes
    ----------
    position : ndarray, shape (3,)
        World position of the root on the ground plane ``(x, 0, z)`` (m).
    pitch : ndarray, shape (1,)
        Body pitch (rad), nose up.
    sag : ndarray, shape (1,)
        How far the body is lowered for its planted legs (m).
    lead : LeadState
    feet : FeetState
    """

    position: np.ndarray
    pitch: np.ndarray
    sag: np.ndarray
    lead: LeadState
    feet: FeetState


class PlaceFrame(NamedTuple):
    """One frame's input to :func:`place_row`.

    Attributes
    ----------
    local, local_prev : ndarray, shape (3,)
        The clip's root this frame and last frame (m, clip frame, travel unwrapped).
    rotations : ndarray, shape (J, 4)
        The clip's local rotations, quaternions ``(w, x, y, z)``.
    contacts : ndarray of bool, shape (4,)
        Feet the clip holds on the ground.
    first : bool
        The first frame: the horse is put at the origin, leads and pitch set at once.
    dt : float
        Time since the last frame (s), 0 on the first.
    yaw, yaw_prev : float
        The heading this frame and last frame (rad).
    yaw_lead : float
        How far the head should lead the root in yaw (rad).
    """

    local: np.ndarray
    local_prev: np.ndarray
    rotations: np.ndarray
    contacts: np.ndarray
    first: bool
    dt: float
    yaw: float
    yaw_prev: float
    yaw_lead: float


class PlacedPose(NamedTuple):
    """The output buffers of :func:`place_row` (overwritten each frame).

    Attributes
    ----------
    local_rotations : ndarray, shape (J, 3, 3)
    rotations : ndarray, shape (J, 4)
        The same as quaternions.
    positions : ndarray, shape (J, 3)
        World joint positions (m).
    root : ndarray, shape (3,)
        World root position (m).
    contacts : ndarray of bool, shape (4,)
        The planted feet.
    ground : ndarray, shape (4,)
        Ground height under each foot (m).
    scratch : ndarray, shape (J + WORK_MATRICES, 3, 3)
        Work space (:data:`~quadsim.horse.place_kernel.WORK_MATRICES`).
    legs : ndarray, shape (LEG_VECTORS, 4, 3)
        Work space of the legs (:data:`~quadsim.horse.place_kernel.LEG_VECTORS`):
        the feet, their targets, the legs' top and middle joints, one spare point each.
    clearance : ndarray, shape (4,)
        Work space: each foot's height over the clip's ground (m).
    toe_ground : ndarray, shape (4,)
        Ground height under each foot's toe tip (m).
    """

    local_rotations: np.ndarray
    rotations: np.ndarray
    positions: np.ndarray
    root: np.ndarray
    contacts: np.ndarray
    ground: np.ndarray
    scratch: np.ndarray
    legs: np.ndarray
    clearance: np.ndarray
    toe_ground: np.ndarray


__all__ = ["FeetState", "LeadState", "PlaceFrame", "PlaceRig", "PlaceState", "PlaceTuning",
           "PlacedPose"]
