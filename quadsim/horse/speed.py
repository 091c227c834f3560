"""Speed expansion of a gait clip with Hoyt's contact-time law.

The seed's Table 1 gives, per gait, ``Tc = a v^b`` (contact time of a foot,
seconds) and the step length ``D = v Tc`` -- how far the body travels while a
foot is on the ground.

The speed unit of Table 1
-------------------------
The table does not state it. With the walk's constants (a = 1.688057,
b = -0.71476) a horse walking at 1.4-1.8 m/s has stance times of

========  ============  ============  ============
unit      v = 1.4 m/s   v = 1.8 m/s   (real: 0.6-0.8 s)
========  ============  ============  ============
m/s       1.33 s        1.11 s
mph       0.75 s        0.62 s
km/h      0.53 s        0.44 s
========  ============  ============  ============

and only **miles per hour** fits; it also gives plausible trot (0.39 -> 0.19 s
over 2.5-6.5 m/s) and canter (0.22 -> 0.13 s over 4.4-7.5 m/s) stance times,
and the seed states its turning speeds in mph (Muybridge measured in feet and
inches). So ``v`` is in mph here (:data:`SPEED_UNIT`, :func:`contact_time`
converts from m/s). Two rows do not fit real horses in any unit: the gallop
gives 0.32 -> 0.24 s over 9-17 m/s in mph (real racehorses: 0.13 -> 0.08 s;
m/s and km/h are no closer), and the amble 0.73 -> 0.61 s over 2.7-3.8 m/s,
whose steps ``D = v Tc`` of 2.0-2.3 m a 1.3 m leg cannot make.

What a leg reaches
------------------
``D`` is the stance sweep: how far the body passes over a planted foot. The
horse's legs (hip height 1.28 m) sweep at most 0.93 m with the body lowered
by 5 % of the pelvis height (7.6 cm), 1.19 m at 10 %, 1.38 m at 15 % and
1.79 m even at 30 % (a 46 cm crouch; the procedural controller's measured
sweep table). The law asks for

========  ==================  ==============================
gait      speeds (m/s)        ``D`` (m)
========  ==================  ==============================
walk      1.4 -> 1.8          1.05 -> 1.12
trot      2.5 -> 6.5          0.97 -> 1.24
rack      2.9 -> 5.5          1.28 -> 1.37
canter    4.4 -> 7.5          0.98 -> 1.00
amble     2.7 -> 3.8          1.97 -> 2.33
gallop    9 -> 17             2.84 -> 4.08
========  ==================  ==============================

so the walk, trot, rack and canter are within reach with the body lowered
(the walk, trot and rack clips are baked with it, 8-16 % of the pelvis
height, and step within 3 % of the law at their own speeds: see
``tools/bake_horse_clips.py``), the amble and the gallop are not (their
baked clips' contact times are 49-53 % and 62 % under ``a v^b``: 0.36 s
against 0.70 s at 2.9 m/s, 0.11 s against 0.29 s at 11 m/s; the gallop
clip's 0.11 s is the racehorse's).

Two anchors
-----------
``anchor="law"`` makes the expanded clip's contact time ``a v^b`` itself.
``anchor="clip"`` applies the law relative to the clip,
``Tc' = Tc0 (v'/v0)^b`` and ``D'/D0 = (v'/v0)^(1+b)`` -- the exponent the seed
fitted, free of the speed unit and of ``a`` -- which is the same thing when the
clip obeys the law (the seed's clips were the data the law was fitted to) and
the usable choice for gaits whose absolute law the leg cannot reach (the amble
and the gallop, above). With clips that obey the law the step scale ``r``
below stays near 1 (with ``anchor="law"``: 0.92-1.05 for the walk at 1.3-1.8
m/s, the trot at 3-5, the rack at 3.5-5 and the canter at 5.2-7; 0.90-1.06
over these gaits' whole speed ranges: a foot is moved out by at most 6 %), so
the moved feet stay within the legs' reach.

Other characters' laws
----------------------
Table 1 is the horse's. A clip database gives each gait's own law in m/s
(its manifest's ``[laws.<gait>]``, fitted to the takes by ``quadsim
clips-from``: :class:`~quadsim.horse.database.SpeedLaw`), which
:func:`expand` takes as ``law``; :func:`hoyt_law` is Table 1's row in the same
form (``a MPH^-b``).

Method (the seed's equation 2, then time warping)
-------------------------------------------------
Each foot is moved about its hip/shoulder in the sagittal (forward-up) plane,
``P'f = (Pf - Sf) r + Sf`` with ``r = D'/D0``, and its height above the ground
scaled by ``r`` (the seed's ``G`` is the offset that keeps a stance foot on
the ground); an analytic two-bone IK puts the foot there, keeping the joints
below the pair as they were. The root's forward travel is scaled by ``r`` too,
so a planted foot stays planted. The cycle is then warped uniformly in time by
``k = Tc'/Tc0`` (resampled by slerp to a whole number of frames, ``k``
rounded to it and ``r = v' k / v0`` taken from the rounded ``k``), which makes
the contact time ``Tc'`` (within half a frame per cycle) and the speed
exactly ``r v0 / k = v'``. Planted feet are finally held still on the ground
by the same IK through their measured contacts, each from the frame it comes to
rest on in the clip (:func:`~quadsim.horse.database.settled_stance`; from its
refined touchdown, up to a frame earlier, a foot was held short of its place and
jumped there: the trot expanded to 4 m/s landed its left fore at 0.30 of the body's
speed, now 0.06), and a hoof that a frame resampled between its swing and its held
pose puts under the ground is set on it.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..skeleton.contacts import foot_contacts, stance_intervals
from ..errors import InputError
from ..skeleton.character import Character
from ..skeleton.motion import Motion
from .database import (Clip, SpeedLaw, contacts_from_stance, label_touchdowns, looped,
                       pin_cycle, rest_tolerance, sample_motion, settled_stance)
from .root import clip_stance_cycles
from .legs import keep_foot_attitude, place_feet

#: Table 1 of the seed: ``Tc = a v^b``, v in :data:`SPEED_UNIT`, Tc in seconds.
HOYT = {
    "walk": (1.688057, -0.71476),
    "amble": (1.826353, -0.51021),
    "trot": (1.407662, -0.74782),
    "rack": (2.386013, -0.90153),
    "canter": (2.005463, -0.96045),
    "gallop": (1.14589, -0.42978),
}
SPEED_UNIT = "mph"
MPH = 0.44704  # m/s per mile per hour
#: Exponent of a gait with neither a law of its own nor a row in :data:`HOYT`
#: (the mean of Table 1's exponents, rounded), used relative to the clip.
DEFAULT_EXPONENT = -0.7
FORWARD = 2
UP = 1
#: A leg whose top-to-foot distance is within this fraction of its pair's full
#: length keeps the pose's reach in :func:`expand` (see :func:`_keep_straight_reach`).
STRAIGHT_SLACK = 0.03


def contact_time(gait: str, speed) -> np.ndarray:
    """Hoyt's contact time ``a v^b`` (s) of a gait at ``speed`` (m/s, converted to mph)."""
    if gait not in HOYT:
        raise InputError(f"no contact-time law for gait {gait!r}; known: {', '.join(HOYT)}")
    a, b = HOYT[gait]
    return a * (np.asarray(speed, dtype=float) / MPH) ** b


def hoyt_law(gait: str, anchor: str = "law") -> SpeedLaw | None:
    """Table 1's row of a gait as a :class:`~quadsim.horse.database.SpeedLaw` in m/s
    (``a MPH^-b``), or None when the table has no row for it."""
    if gait not in HOYT:
        return None
    a, b = HOYT[gait]
    return SpeedLaw(a * MPH ** (-b), b, anchor)


def step_length(gait: str, speed) -> np.ndarray:
    """``D = v Tc`` (m) at ``speed`` (m/s)."""
    return np.asarray(speed, dtype=float) * contact_time(gait, speed)


def measure_contact_time(motion: Motion, skip: int = 0) -> np.ndarray:
    """Median measured stance time of each foot (s), shape (4,), from frame ``skip`` on."""
    feet = motion.foot_positions()[skip:]
    c = foot_contacts(feet, motion.fps)
    iv = stance_intervals(c, motion.fps, feet)
    out = np.full(4, np.nan)
    for i, s in enumerate(iv):
        d = s[:, 1] - s[:, 0]
        d = d[np.isfinite(d)]
        if len(d):
            out[i] = np.median(d)
    return out


def clip_contact_time(clip: Clip) -> float:
    """Mean measured stance time of a looped clip's feet (s)."""
    m = looped(clip.motion, 3, clip.speed)
    return float(np.nanmean(measure_contact_time(m)))


def _keep_straight_reach(character: Character, P: np.ndarray, tgt: np.ndarray) -> np.ndarray:
    """Swing foot targets (T, 4, 3) at the pose's own reach where a leg is nearly straight.

    A two-bone pair passing through straight (a fore leg reaching forward in its
    swing) flips the side it bends to, so a target nearer than the pose's foot
    bends it one way a frame and the other way the next: the elbow jumps (a
    canter's fore leg moved in by 6 % turned at 3,200 deg/s where the clip's
    turns at 1,300). Within :data:`STRAIGHT_SLACK` of full extension the target
    keeps its direction from the pair's top joint and takes the pose's
    distance, eased in by a smoothstep (:func:`expand` applies it to swinging feet
    only: a planted foot keeps its place). ``P`` (T, J, 3): the pose's joint
    positions (m), in the targets' frame.
    """
    legs = character.legs
    A = P[:, [leg.chain[leg.ik_start] for leg in legs]]
    B = P[:, [leg.chain[leg.ik_start + 1] for leg in legs]]
    F = P[:, [leg.foot for leg in legs]]
    full = np.linalg.norm(B - A, axis=-1) + np.linalg.norm(F - B, axis=-1)
    d0 = np.linalg.norm(F - A, axis=-1)
    d1 = np.maximum(np.linalg.norm(tgt - A, axis=-1), 1e-9)
    x = np.clip((1.0 - d0 / full) / STRAIGHT_SLACK, 0.0, 1.0)
    w = x * x * (3.0 - 2.0 * x)
    return A + (tgt - A) * ((d0 + w * (d1 - d0)) / d1)[..., None]


def expand(clip: Clip, character: Character, speed: float, *, anchor: str = "law",
           ground: float = 0.0, law: SpeedLaw | None = None) -> Clip:
    """The clip expanded to a new speed (m/s), one looped cycle.

    Parameters
    ----------
    clip : Clip
        A looped gait clip (not a leap).
    character : Character
    speed : float
        The new speed (m/s), > 0.
    anchor : {"law", "clip"}
        Make the contact time ``a v^b`` (``"law"``) or ``Tc0 (v/v0)^b``
        (``"clip"``); see the module notes.
    ground : float
        Height of the clip's ground (m).
    law : SpeedLaw, optional
        The gait's contact-time law (m/s); default Table 1's row of the gait
        (:data:`HOYT`).

    Returns
    -------
    Clip
        Same gait; ``speed`` the new one; ``frames`` the new cycle length at
        the clip's frame rate; touchdown frames scaled.
    """
    if law is None:
        law = hoyt_law(clip.gait)
    if law is None:
        raise InputError(f"clip {clip.name!r}: gait {clip.gait!r} has no speed law")
    if not speed > 0:
        raise InputError(f"speed must be > 0 m/s, got {speed!r}")
    if anchor not in ("law", "clip"):
        raise InputError(f"anchor must be 'law' or 'clip', got {anchor!r}")
    b = law.b
    tc0 = clip_contact_time(clip)
    if anchor == "law":
        tc1 = float(law.contact_time(speed))
    else:
        tc1 = tc0 * (speed / clip.speed) ** b
    m = clip.motion
    n = clip.frames
    # the cycle must hold a whole number of frames: round the warp, then take
    # the step scale that gives exactly the wanted speed (Tc' off by < 1/(2 n'))
    n1 = max(round(n * tc1 / tc0), 4)
    k = n1 / n
    r = speed * k / clip.speed
    # spatial: feet about the hip/shoulder (equation 2), root travel scaled
    Wp = m.world_positions()
    feet = Wp[:, [leg.foot for leg in character.legs]]
    S = Wp[:, [leg.chain[leg.ik_start] for leg in character.legs]]
    root = np.array(m.root_positions)
    root[:, FORWARD] = root[:, FORWARD] * r
    shift = np.zeros_like(Wp[:, :1])
    shift[:, 0, FORWARD] = root[:, FORWARD] - m.root_positions[:, FORWARD]
    tgt = feet + shift
    Sf = S[..., FORWARD] + shift[..., FORWARD]
    tgt[..., FORWARD] = (feet[..., FORWARD] + shift[..., FORWARD] - Sf) * r + Sf
    tgt[..., UP] = ground + (feet[..., UP] - ground) * r
    stance = [st * n for st in clip_stance_cycles(clip)]
    swing = ~contacts_from_stance(stance, n, 1)
    swing &= np.roll(swing, 1, axis=0) & np.roll(swing, -1, axis=0)   # a frame off contacts
    tgt = np.where(swing[..., None], _keep_straight_reach(character, Wp + shift, tgt), tgt)
    moved = Motion(m.skeleton, m.fps, root, m.rotations, foot_joints=m.foot_joints)
    # the hooves keep the clip's attitude (the IK alone tilts them with the lower leg: a
    # trot's hind toe tips 12 mm into the ground with its step shortened by 7 %)
    rot = keep_foot_attitude(character, moved, place_feet(character, moved, tgt))
    scaled = Motion(m.skeleton, m.fps, root, rot, foot_joints=m.foot_joints)
    # temporal: warp uniformly by k, resample the loop to a whole number of frames
    ext_root = np.concatenate([scaled.root_positions,
                               scaled.root_positions[:1] + [0.0, 0.0, r * clip.speed * n / m.fps]])
    ext = Motion(m.skeleton, m.fps, ext_root,
                 np.concatenate([scaled.rotations, scaled.rotations[:1]]),
                 foot_joints=m.foot_joints)
    src = np.arange(n1) * (n / n1)
    root1, rot1 = sample_motion(ext, src)
    out = Motion(m.skeleton, m.fps, root1, rot1, foot_joints=m.foot_joints)
    # the clip's contacts, warped: hold those feet still on the ground
    # ... each from the frame it comes to rest on in the clip (``settled_stance``)
    feet0 = looped(m, 3, clip.speed).foot_positions()
    stance = settled_stance(feet0, [st * n for st in clip_stance_cycles(clip)], n,
                            rest_tolerance(feet0))
    stance = [st * (n1 / n) for st in stance]
    out = pin_cycle(character, out, speed, stance)
    # a hoof resampled between its last swing pose and its held one may pass under
    # the ground (the joints' rotations interpolated, not its path): put it on it
    feet = out.foot_positions()
    low = feet[..., UP] < ground
    if low.any():
        tgt = feet.copy()
        tgt[..., UP] = np.maximum(tgt[..., UP], ground)
        legs = tuple(int(i) for i in np.nonzero(low.any(axis=0))[0])
        lifted = keep_foot_attitude(character, out, place_feet(character, out, tgt, legs))
        rot = np.array(out.rotations)
        frames = low.any(axis=1)
        rot[frames] = lifted[frames]
        out = Motion(m.skeleton, m.fps, out.root_positions, rot, foot_joints=m.foot_joints)
    td = label_touchdowns(out, speed)
    return replace(clip, name=f"{clip.name}@{speed:g}", speed=float(speed), frames=n1,
                   touchdown=td, motion=out,
                   source=f"{clip.name} expanded to {speed:g} m/s (anchor {anchor}, "
                          f"r = {r:.3f}, k = {k:.3f})")


__all__ = ["DEFAULT_EXPONENT", "HOYT", "MPH", "SPEED_UNIT", "clip_contact_time", "contact_time",
           "expand", "hoyt_law", "measure_contact_time", "step_length"]
