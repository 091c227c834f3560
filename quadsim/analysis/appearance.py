"""What a viewer sees of a gait, measured from joint world positions.

The footfall metrics (:mod:`quadsim.analysis.metrics`) check the pattern of
contacts at the foot joints. This module measures the rest of what makes a
gait read as an animal's -- from the produced motion only, with the
structure found from the skeleton (:func:`~quadsim.skeleton.anatomy.find_anatomy`),
so it works on any quadruped BVH:

- **strides**: stride length over hip height and scaled cadence
  ``f sqrt(h / g)`` at the stride's Froude number ``Fr = v^2 / (g h)``,
  against Alexander's ``lambda / h = 2.3 Fr^0.3``;
- **trunk**: pitch of the pelvis-to-withers line (range per stride), the
  trunk's vertical excursion (range of the girdles' mid-point height per
  stride, over ``h``), spine flexion (the angle between the
  pelvis-to-mid-spine and mid-spine-to-withers chords; range per stride) and
  the head's pitch (range per stride);
- **contacts**: the toe tip (the foot bone's end) below the ground and its
  sliding during stance, the foot's ground speed on the touchdown frame and
  on the first frame after lift-off, relative to the body's speed, and its
  descent speed on the touchdown frame (a foot dropped onto the ground from
  out of reach), relative to the body's speed too;
- **flight**: the trunk's vertical acceleration in every flight phase (no
  foot down) of at least :data:`MIN_FLIGHT_FRAMES` frames, from a parabola
  fitted to the girdles' mid-point height, in units of g;
- **joints**: peak angular speed of every joint, and the share of swing
  frames in which a leg joint bent at rest (the elbows, knees, hocks) is
  locked straight (interior angle at least :data:`STRAIGHT_DEG`): the worst
  of them, and the worst elbow or knee (in each leg the hinge between its
  two longest bones), locked and nearly straight (:data:`NEAR_STRAIGHT_DEG`).

Stance comes from :func:`~quadsim.skeleton.contacts.foot_contacts` on the toe
tips (on the foot joints measured from the ground under them when the motion
carries it, :func:`ground_points`);
strides run from one left-hind touchdown to the next. Angles are reported
in degrees, lengths in metres unless named ``_mm``.
"""

from __future__ import annotations

import math

import numpy as np

from quadsim.analysis.appearance_kernels import (
    STRIDE_MEDIANS,
    flexion_rows,
    flight_accels,
    pitch_rows,
    series_rows,
    stride_medians,
)
from quadsim.frames import GRAVITY, LEGS, X, Y, Z
from quadsim.skeleton.anatomy import Anatomy, find_anatomy
from quadsim.skeleton.contacts import _split_at, foot_contacts

__all__ = ["ALEXANDER", "MIN_FLIGHT_FRAMES", "NEAR_STRAIGHT_DEG", "STRAIGHT_DEG", "appearance_from_arrays",
           "appearance_many", "appearance_report",
           "format_appearance", "spine_flexion", "toe_positions", "trunk_pitch"]

#: Alexander's dynamic-similarity stride law ``lambda / h = a Fr^b`` (1976).
ALEXANDER = (2.3, 0.3)
#: Shortest flight phase (frames) whose vertical acceleration is measured.
MIN_FLIGHT_FRAMES = 4
#: A joint this straight (interior angle, degrees) or straighter is locked.
STRAIGHT_DEG = 177.0
#: An elbow or knee this straight or straighter is nearly straight: the leg IK
#: keeps a pair about 7 degrees from straight (173 degrees), which
#: :data:`STRAIGHT_DEG` cannot see, so a leg reaching as far as it goes shows here.
NEAR_STRAIGHT_DEG = 170.0
#: Leg joints bent less than this at rest (interior angle, degrees) are the
#: hinges checked for locking (a joint straight at rest, like a horse's
#: carpus, is left out).
BENT_AT_REST_DEG = 170.0
_LH = LEGS.index("LH")


def _ground(motion) -> np.ndarray:
    """Ground height (T, 4) (m) under each toe tip where recorded, else each foot joint."""
    extras = getattr(motion, "extras", None) or {}
    g = extras["toe_ground"] if extras.get("toe_ground") is not None else extras.get("ground")
    T = motion.n_frames
    return np.zeros((T, 4)) if g is None else np.asarray(g, dtype=float).reshape(T, 4)


def ground_points(motion, anatomy: Anatomy) -> np.ndarray:
    """Where the anatomy's feet meet the ground, heights over the ground under them,
    shape (T, 4, 3) (m): the toe tips on flat ground or over ``extras["toe_ground"]``,
    the foot joints over ``extras["ground"]`` on uneven ground without it (as
    :func:`~quadsim.analysis.report.feet_over_ground`)."""
    extras = getattr(motion, "extras", None) or {}
    if extras.get("toe_ground") is None and extras.get("ground") is not None:
        feet = motion.world_positions()[:, list(anatomy.feet)].copy()
    else:
        feet = toe_positions(motion, anatomy)
    feet[..., Y] -= _ground(motion)
    return feet


def toe_positions(motion, anatomy: Anatomy | None = None) -> np.ndarray:
    """World positions of the four toe tips (the feet's end sites), shape (T, 4, 3) (m)."""
    a = anatomy or find_anatomy(motion.skeleton, motion.foot_joints)
    G = motion.world_rotations_of(a.feet)
    P = motion.world_positions()[:, list(a.feet)]
    return P + np.einsum("tlij,lj->tli", G, a.toe_offsets)


def _frames(positions: np.ndarray) -> np.ndarray:
    """Joint world positions (..., J, 3) as (K, J, 3), float and C-ordered."""
    P = np.ascontiguousarray(positions, dtype=float)
    return P.reshape((-1,) + P.shape[-2:])


def trunk_pitch(positions: np.ndarray, anatomy: Anatomy) -> np.ndarray:
    """Nose-up pitch of the pelvis-to-withers line, shape (T,) (rad), from joint world
    positions (T, J, 3) (m); any leading axes are kept."""
    P = _frames(positions)
    out = np.empty(len(P))
    pitch_rows(P, anatomy.pelvis, anatomy.withers, out)
    return out.reshape(np.shape(positions)[:-2])


def spine_flexion(positions: np.ndarray, anatomy: Anatomy) -> np.ndarray:
    """Angle between the pelvis-to-mid-spine and mid-spine-to-withers chords, (T,) (rad),
    from joint world positions (T, J, 3) (m); any leading axes are kept.

    Signed: positive while the back arches (the mid-spine above the
    pelvis-to-withers line, flexion), negative while it sags (extension),
    so that a stride's range spans both (an unsigned angle would fold an
    extension onto a flexion of the same size): the sign of ``a x b`` along
    the body's left (up x forward, forward the pelvis-to-withers line), for
    the chords ``a`` and ``b``.
    """
    P = _frames(positions)
    out = np.empty(len(P))
    flexion_rows(P, anatomy.pelvis, anatomy.mid_spine, anatomy.withers, out)
    return out.reshape(np.shape(positions)[:-2])


def _angle(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    cross = np.linalg.norm(np.cross(a, b), axis=-1)
    return np.arctan2(cross, np.einsum("...i,...i->...", a, b))


def _touchdowns(mask: np.ndarray) -> np.ndarray:
    """The first frames (int64, ascending) of the True runs of a 1-D bool array, but
    frame 0 (a contact already under way)."""
    m = np.asarray(mask, bool)
    return np.flatnonzero(m[1:] & ~m[:-1]).astype(np.int64) + 1


def _num(x: float) -> float | None:
    """``x`` as a float, None for NaN."""
    return None if math.isnan(x) else float(x)


def _finite_sorted(x) -> np.ndarray:
    x = np.asarray(x, dtype=float)
    return np.sort(x[np.isfinite(x)])


def _pct(x, q) -> float | None:
    """``np.percentile(x, q)`` (linear) of the finite values (None without any), from one
    sort, with numpy's interpolation step for step."""
    s = _finite_sorted(x)
    n = s.size
    if not n:
        return None
    v = (n - 1) * (q / 100.0)
    i = math.floor(v)
    j = min(i + 1, n - 1)
    g = v - i
    a, b = float(s[i]), float(s[j])
    d = b - a
    return b - d * (1.0 - g) if g >= 0.5 else a + d * g


_HINGES: dict[tuple[int, int], tuple] = {}  # each (skeleton, anatomy)'s hinges, found once


def _hinges(motion, a: Anatomy) -> list[tuple[int, int, int, int]]:
    """(leg, parent, joint, child) of every leg joint bent at rest."""
    key = (id(motion.skeleton), id(a))
    hit = _HINGES.get(key)
    if hit is not None and hit[0] is motion.skeleton and hit[1] is a:
        return hit[2]
    P = motion.skeleton.rest_positions
    out = []
    for leg, chain in enumerate(a.legs):
        for k in range(1, len(chain) - 1):
            p, j, c = chain[k - 1], chain[k], chain[k + 1]
            inner = math.degrees(math.pi - _angle(P[j] - P[p], P[c] - P[j]))
            if inner < BENT_AT_REST_DEG:
                out.append((leg, p, j, c))
    if len(_HINGES) > 64:
        _HINGES.clear()
    _HINGES[key] = (motion.skeleton, a, out)
    return out


def _elbows_knees(motion, hinges) -> list[int]:
    """Which of ``hinges`` (:func:`_hinges`) are the elbows and knees: in each
    leg, the hinge between the two longest bones (at rest) of any hinge's pair."""
    P = motion.skeleton.rest_positions
    best: dict[int, tuple[float, int]] = {}
    for k, (leg, p, j, c) in enumerate(hinges):
        span = float(np.linalg.norm(P[j] - P[p]) + np.linalg.norm(P[c] - P[j]))
        if leg not in best or span > best[leg][0]:
            best[leg] = (span, k)
    return sorted(k for _, k in best.values())


def appearance_report(motion, *, start: float = 0.0, anatomy: Anatomy | None = None) -> dict:
    """Measure what a viewer sees of ``motion`` (see the module notes).

    Parameters
    ----------
    motion : Motion
    start : float
        Seconds at the start left out (a start-up transient).
    anatomy : Anatomy, optional
        Default: found from the skeleton (and the motion's foot joints).

    Returns
    -------
    report : dict
        Plain floats (None where nothing was measured): ``strides``,
        ``stride_over_h`` and ``alexander_over_h`` (medians), ``cadence``
        (scaled), ``froude``, ``trunk_pitch_range_deg``,
        ``trunk_heave_over_h``, ``spine_flexion_range_deg``,
        ``head_pitch_range_deg``, ``toe_below_ground_mm`` (deepest in stance),
        ``toe_below_ground_any_frame_mm`` (deepest on any frame, swing included),
        ``toe_slide_mm_p90``, ``touchdown_speed_ratio_p90``,
        ``touchdown_descent_ratio_p90``, ``liftoff_speed_ratio_p90``,
        ``fore_touchdown_angle_deg``, ``fore_liftoff_angle_deg``,
        ``hind_touchdown_angle_deg`` and ``hind_liftoff_angle_deg`` (medians of the
        line from a leg's top joint to its toe tip from the vertical on the first and
        last frame of each contact, positive with the toe ahead of the top along the
        trunk's forward direction over the ground: where a stance sits under its
        girdle), ``flights``, ``flight_accel_g`` (list, one
        per flight phase; -1 is a ballistic fall), ``trunk_jolt_g`` (the pelvis's
        or withers' largest vertical acceleration, either way, in g: a trunk
        dropped onto its landing legs in one frame shows here),
        ``peak_joint_speed_deg_s``
        and its ``peak_joint``, ``locked_swing_fraction`` (worst hinge) and its
        ``locked_joint``, and the same of the elbows and knees alone
        (``elbow_knee_locked_fraction``, ``elbow_knee_locked_joint``; in each
        leg the hinge between its two longest bones), and their worst share of
        swing frames at :data:`NEAR_STRAIGHT_DEG` or straighter
        (``elbow_knee_near_straight_fraction``).
    """
    from quadsim.analysis.smoothness import angular_velocity

    a = anatomy or find_anatomy(motion.skeleton, motion.foot_joints)
    fps = float(motion.fps)
    k0 = int(math.ceil(start * fps - 1e-9))
    Pall = motion.world_positions()
    if k0 >= len(Pall) - 2:
        raise ValueError(f"`start` = {start:g} s leaves fewer than three frames of the "
                         f"{motion.duration:.3g} s motion")
    # stance is where the toe tips are planted (a foot rolling over its toe lifts
    # its joint while the tip stays put)
    feet = ground_points(motion, a)[k0:]
    return appearance_from_arrays(motion, a, k0, foot_contacts(feet, fps),
                                  angular_velocity(motion)[k0:])


def _series(P, Gfeet, Ghead, ground, a: Anatomy, head_parent: int, fps: float) -> dict:
    """The per-frame arrays the figures are read from, of a batch (compiled,
    :func:`~quadsim.analysis.appearance_kernels.series_rows`).

    ``P`` (N, T, J, 3) joint world positions (m), ``Gfeet`` (N, T, 4, 3, 3)
    the world rotations of ``a.feet``, ``Ghead`` (N, T, 3, 3) that of the
    head (None when its pitch comes from its parent's position,
    ``head_parent``), ``ground`` (N, T, 4) the ground under the feet (m).
    Each clip's arrays are found from its own alone.
    """
    N, T = P.shape[:2]
    P = np.ascontiguousarray(P, dtype=float)
    from_parent = a.head_from_parent
    Gh = np.zeros((1, 1, 3, 3)) if from_parent else np.ascontiguousarray(Ghead, dtype=float)
    out = {"toes": np.empty((N, T, 4, 3)), "root": P[:, :, 0, :],
           "body_speed": np.empty((N, T)), "mid": np.empty((N, T, 3)),
           "girdles_y": np.empty((N, T, 2)), "pitch": np.empty((N, T)),
           "flex": np.empty((N, T)), "head": np.empty((N, T)),
           "fvel": np.empty((N, T - 1, 4)), "fdown": np.empty((N, T - 1, 4)), "inner": None}
    series_rows(P, np.ascontiguousarray(Gfeet, dtype=float), Gh,
                np.ascontiguousarray(ground, dtype=float), np.asarray(a.feet, dtype=np.int64),
                np.ascontiguousarray(a.toe_offsets, dtype=float),
                np.array([a.pelvis, a.mid_spine, a.withers, a.head,
                          int(head_parent) if from_parent else -1], dtype=np.int64),
                np.ascontiguousarray(a.head_tip, dtype=float), float(fps),
                tuple(out[k] for k in ("toes", "body_speed", "mid", "girdles_y", "pitch",
                                       "flex", "head", "fvel", "fdown")))
    # the legs' top joints, and the trunk's forward direction over the ground (the
    # pelvis to the withers), for the legs' angles at their contacts
    out["tops"] = P[:, :, [leg[0] for leg in a.legs]]
    ahead = P[:, :, a.withers] - P[:, :, a.pelvis]
    ahead[..., Y] = 0.0
    out["ahead"] = ahead / np.maximum(np.linalg.norm(ahead, axis=-1, keepdims=True), 1e-12)
    return out


def _contact_arrays(s: dict, contacts: np.ndarray) -> list[tuple]:
    """Per motion of a batch, at every contact of its feet: the toe tip's depth below
    the ground and its slide (m), and the foot's ground and descent speed over the
    body's at touchdown and its ground speed over the body's after lift-off; and the
    leg's angle from the vertical on the contact's first and last frame
    (:func:`_leg_angle`), rows of (degrees, foot index).

    ``s``: :func:`_series` with a leading batch axis; ``contacts`` (N, T, 4). Each
    list per foot in time order, the feet one after another (LF, RF, LH, RH).
    """
    from quadsim.skeleton import contacts_many as many

    toes, body_speed, fvel, fdown = s["toes"], s["body_speed"], s["fvel"], s["fdown"]
    N, T = contacts.shape[:2]
    found = many.runs(contacts)
    flat, st, e, leg = found
    tip_y = many._legs_end_to_end(toes[..., Y], 0.0)
    below = -np.minimum.reduceat(np.where(flat, tip_y, np.inf), st) if len(st) else \
        np.zeros(0)
    slides = many.slides(toes, contacts, found)
    clip, foot, first = leg // 4, leg % 4, st - leg * (T + 1)  # first: the clip's frame
    last = e - leg * (T + 1)
    on = (first > 0) & (body_speed[clip, np.maximum(first, 1) % T] > 0.05)
    k, f, i = clip[on], first[on], foot[on]
    td = fvel[k, f - 1, i] / body_speed[k, f]
    down = fdown[k, f - 1, i]
    tdd = np.where(0.0 > down, 0.0, down) / body_speed[k, f]
    off = (last < T) & (body_speed[clip, np.maximum(last - 1, 0)] > 0.05)
    k2, f2, i2 = clip[off], last[off], foot[off]
    lo = fvel[k2, f2 - 1, i2] / body_speed[k2, f2 - 1]

    # the leg's angle from the vertical on its first and last frame down
    at_td = first > 0
    at_lo = last < T
    td_angle = _leg_angle(s, clip[at_td], first[at_td], foot[at_td])
    lo_angle = _leg_angle(s, clip[at_lo], last[at_lo] - 1, foot[at_lo])

    def split(x, which):
        return _split_at(x, np.searchsorted(which, np.arange(1, N)))

    return list(zip(split(below, clip), split(slides, clip), split(td, k), split(tdd, k),
                    split(lo, k2), split(np.stack([td_angle, foot[at_td]]).T, clip[at_td]),
                    split(np.stack([lo_angle, foot[at_lo]]).T, clip[at_lo])))


def _leg_angle(s: dict, clip: np.ndarray, frame: np.ndarray, foot: np.ndarray) -> np.ndarray:
    """Angle (degrees) of the line from each leg's top joint to its toe tip from the
    vertical, positive with the toe ahead along the trunk's forward direction, at the
    given (clip, frame, foot) triples of :func:`_series`' arrays ``s``."""
    d = s["toes"][clip, frame, foot] - s["tops"][clip, frame, foot]
    along = np.einsum("ij,ij->i", d, s["ahead"][clip, frame])
    return np.degrees(np.arctan2(along, -d[:, Y]))


def _inner_angles(P, hinges) -> np.ndarray | None:
    """Interior angle (degrees) of every hinge, (..., T, H), from positions (..., T, J, 3)."""
    if not hinges:
        return None
    from quadsim.analysis.angular import hinge_angles

    _, p, j, c = (list(x) for x in zip(*hinges))
    return hinge_angles(P, p, j, c)  # 180 - _angle(P[j] - P[p], P[c] - P[j]), in degrees


def appearance_from_arrays(motion, anatomy: Anatomy, k0: int, contacts: np.ndarray,
                           joint_speed: np.ndarray) -> dict:
    """:func:`appearance_report` of ``motion`` from its contacts and joint speeds.

    For callers that measure a motion several ways and compute what the
    figures share once (:func:`quadsim.analysis.measure.measure_motion`).

    Parameters
    ----------
    motion : Motion
    anatomy : Anatomy
    k0 : int
        First frame measured (``ceil(start * fps)``), leaving at least three.
    contacts : ndarray of bool, shape (T - k0, 4)
        :func:`~quadsim.skeleton.contacts.foot_contacts` of the feet
        ``anatomy.feet`` from frame ``k0`` on, measured from the ground under
        them (default thresholds).
    joint_speed : ndarray, shape (T - 1 - k0, J)
        :func:`~quadsim.analysis.smoothness.angular_velocity` of the motion
        from frame ``k0`` on (rad/s).

    Returns
    -------
    dict
        As :func:`appearance_report`.
    """
    a = anatomy
    fps = float(motion.fps)
    P = motion.world_positions()[k0:]
    Gf = motion.world_rotations_of(a.feet)[k0:]
    Gh = motion.world_rotations_of(a.head)[k0:, 0]
    hinges = _hinges(motion, a)
    batch = _series(P[None], Gf[None], Gh[None], _ground(motion)[k0:][None], a,
                    int(motion.skeleton.parents[a.head]), fps)
    batch["inner"] = _inner_angles(P[None], hinges)
    s = {k: None if v is None else v[0] for k, v in batch.items()}
    (s["contacts"],) = _contact_arrays(batch, np.asarray(contacts, dtype=bool)[None])
    return _figures(a, fps, s, contacts, joint_speed, hinges, _elbows_knees(motion, hinges))


def _stacked(arrays) -> np.ndarray:
    """``np.stack(arrays)``, shape (N, ...): or, when the N arrays are already the
    consecutive rows of one C-ordered array (a batch's motions' forward kinematics,
    :func:`quadsim.dataset.clips.generate`), a read-only view of that array: the same
    values, not copied."""
    first = arrays[0]
    b = first.base
    if (isinstance(b, np.ndarray) and b.flags.c_contiguous and b.dtype == first.dtype
            and b.shape == (len(arrays),) + first.shape):
        at = b.__array_interface__["data"][0]
        if all(x.base is b and x.shape == first.shape and x.strides == b.strides[1:]
               and x.__array_interface__["data"][0] == at + i * b.strides[0]
               for i, x in enumerate(arrays)):
            out = b.view()
            out.setflags(write=False)
            return out
    return np.stack(arrays)


def appearance_many(motions, anatomy: Anatomy, contacts, joint_speeds) -> list[dict]:
    """:func:`appearance_from_arrays` of each motion from its first frame, their
    per-frame arrays found together.

    Parameters
    ----------
    motions : sequence of Motion, length N
        Of one skeleton, frame rate and length (a sweep's batch).
    anatomy : Anatomy
    contacts : sequence of N ndarrays of bool, shape (T, 4)
        Each motion's contacts of the feet ``anatomy.feet``, as
        :func:`appearance_from_arrays` takes them.
    joint_speeds : sequence of N ndarrays, shape (T - 1, J)
        Each motion's joints' angular speeds (rad/s).

    Returns
    -------
    list of dict
        What :func:`appearance_from_arrays` gives each motion with ``k0 = 0``,
        to the last bit: the batch's arrays are made by the same operations,
        element by element, and each motion's figures read from its own.
    """
    a = anatomy
    m0 = motions[0]
    fps = float(m0.fps)
    feet = list(a.feet)
    P = _stacked([m.world_positions() for m in motions])
    Gf = np.stack([m.world_rotations_of(feet) for m in motions])
    Gh = None if a.head_from_parent else np.stack([m.world_rotations_of(a.head)[:, 0]
                                                   for m in motions])
    ground = np.stack([_ground(m) for m in motions])
    hinges = _hinges(m0, a)
    s = _series(P, Gf, Gh, ground, a, int(m0.skeleton.parents[a.head]), fps)
    s["inner"] = _inner_angles(P, hinges)
    main = _elbows_knees(m0, hinges)
    at_contacts = _contact_arrays(s, np.asarray(np.stack(contacts), dtype=bool))
    out = []
    for i in range(len(motions)):
        mine = {k: None if v is None else v[i] for k, v in s.items()}
        mine["contacts"] = at_contacts[i]
        out.append(_figures(a, fps, mine, contacts[i], joint_speeds[i], hinges, main))
    return out


def _figures(a: Anatomy, fps: float, s: dict, contacts: np.ndarray, joint_speed: np.ndarray,
             hinges, main) -> dict:
    """The figures of one motion from its per-frame arrays (:func:`_series`)."""
    root, mid, pitch, flex, head = (s[k] for k in ("root", "mid", "pitch", "flex", "head"))
    h = a.hip_height
    T = len(mid)

    # strides: left-hind touchdown to the next, their figures' medians compiled
    td = _touchdowns(contacts[:, _LH])
    medians = np.empty(len(STRIDE_MEDIANS))
    stride_medians(td, root[:, X], root[:, Z], pitch, mid[:, Y], flex, head, fps, h, GRAVITY,
                   ALEXANDER[0], ALEXANDER[1], medians)
    strides = {k: _num(x) for k, x in zip(STRIDE_MEDIANS, medians)}

    # contacts: toe tips and foot speeds at the events (every contact of the batch at once)
    below, slides, td_ratio, td_down, lo_ratio, td_angle, lo_angle = s["contacts"]
    # and the toe tips on every frame: a swinging toe that dips under the ground does not
    # stand still, so it is no contact and the contacts' figure cannot see it
    tips_y = s["toes"][..., Y]
    anywhere = max(-float(tips_y.min()), 0.0) if tips_y.size else None

    # flight: no foot down
    found = np.empty(T)
    accel = found[:flight_accels(~contacts.any(axis=1), mid[:, Y], fps, MIN_FLIGHT_FRAMES,
                                 GRAVITY, found)]

    # the trunk's jolts: the girdles' largest vertical acceleration (second differences)
    gy = s["girdles_y"]
    jolt = (float(np.abs(np.diff(gy, 2, axis=0)).max()) * fps * fps / GRAVITY
            if len(gy) >= 3 else None)

    # joints: angular speed from the local rotations, hinge locking in swing
    w = np.degrees(joint_speed)
    peak_j = int(np.argmax(w.max(axis=0))) if w.size else 0
    locked, locked_name = None, None
    main_locked, main_name, main_near = None, None, None
    if hinges:
        leg = [x[0] for x in hinges]
        inner = s["inner"]  # (T, H)
        swing = ~contacts[:, leg]
        n_swing = swing.sum(axis=0)
        n_straight = (swing & (inner >= STRAIGHT_DEG)).sum(axis=0)
        n_near = (swing & (inner >= NEAR_STRAIGHT_DEG)).sum(axis=0)
        for k in range(len(hinges)):
            if not n_swing[k]:
                continue
            frac = float(n_straight[k] / n_swing[k])
            if locked is None or frac > locked:
                locked, locked_name = frac, a.names[hinges[k][2]]
            if k in main:
                if main_locked is None or frac > main_locked:
                    main_locked, main_name = frac, a.names[hinges[k][2]]
                near = float(n_near[k] / n_swing[k])
                main_near = near if main_near is None else max(main_near, near)

    return {
        "strides": max(len(td) - 1, 0),
        "hip_height": h,
        **strides,
        "toe_below_ground_mm": 1000.0 * float(below.max()) if below.size else None,
        "toe_below_ground_any_frame_mm": None if anywhere is None else 1000.0 * anywhere,
        "toe_slide_mm_p90": None if not slides.size else 1000.0 * _pct(slides, 90),
        "touchdown_speed_ratio_p90": _pct(td_ratio, 90),
        "touchdown_descent_ratio_p90": _pct(td_down, 90),
        "liftoff_speed_ratio_p90": _pct(lo_ratio, 90),
        **_leg_angles(td_angle, lo_angle),
        "flights": len(accel),
        "flight_accel_g": [float(x) for x in accel],
        "trunk_jolt_g": jolt,
        "peak_joint_speed_deg_s": float(w.max()) if w.size else None,
        "peak_joint": a.names[peak_j],
        "locked_swing_fraction": locked,
        "locked_joint": locked_name,
        "elbow_knee_locked_fraction": main_locked,
        "elbow_knee_locked_joint": main_name,
        "elbow_knee_near_straight_fraction": main_near,
    }


def _leg_angles(td_angle: np.ndarray, lo_angle: np.ndarray) -> dict:
    """The fore and hind legs' median angles at touchdown and lift-off, from the
    contacts' (angle, foot) rows."""
    out = {}
    for event, rows in (("touchdown", td_angle), ("liftoff", lo_angle)):
        rows = np.asarray(rows, dtype=float).reshape(-1, 2)
        for pair, feet in (("fore", (0, 1)), ("hind", (2, 3))):
            x = rows[np.isin(rows[:, 1], feet), 0]
            out[f"{pair}_{event}_angle_deg"] = float(np.median(x)) if x.size else None
    return out


def format_appearance(report: dict) -> str:
    """The report as a short table of text lines."""
    def f(x, fmt):
        return "-" if x is None else format(x, fmt)

    acc = report["flight_accel_g"]
    lines = [
        f"strides {report['strides']}  (hip height {report['hip_height']:.2f} m)",
        f"stride / h {f(report['stride_over_h'], '.2f')} (Alexander {f(report['alexander_over_h'], '.2f')}"
        f" at Fr {f(report['froude'], '.2f')}); cadence f*sqrt(h/g) {f(report['cadence'], '.3f')}",
        f"trunk pitch range {f(report['trunk_pitch_range_deg'], '.1f')} deg; heave "
        f"{f(report['trunk_heave_over_h'], '.3f')} h; spine flexion range "
        f"{f(report['spine_flexion_range_deg'], '.1f')} deg; head pitch range "
        f"{f(report['head_pitch_range_deg'], '.1f')} deg",
        f"toe tip: deepest {f(report['toe_below_ground_mm'], '.1f')} mm below ground in stance "
        f"({f(report['toe_below_ground_any_frame_mm'], '.1f')} on any frame), slide p90 "
        f"{f(report['toe_slide_mm_p90'], '.1f')} mm; foot speed / body speed at touchdown p90 "
        f"{f(report['touchdown_speed_ratio_p90'], '.2f')} (descending "
        f"{f(report['touchdown_descent_ratio_p90'], '.2f')}), after lift-off "
        f"{f(report['liftoff_speed_ratio_p90'], '.2f')}",
        f"legs from the vertical (toe ahead +): fore at touchdown "
        f"{f(report['fore_touchdown_angle_deg'], '+.1f')}, at lift-off "
        f"{f(report['fore_liftoff_angle_deg'], '+.1f')} deg; hind "
        f"{f(report['hind_touchdown_angle_deg'], '+.1f')}, "
        f"{f(report['hind_liftoff_angle_deg'], '+.1f')} deg",
        f"flight phases {report['flights']}: vertical acceleration "
        + (", ".join(f"{x:+.2f}" for x in acc[:8]) + (" ..." if len(acc) > 8 else "") + " g"
           if acc else "-")
        + f"; trunk jolts up to {f(report['trunk_jolt_g'], '.1f')} g",
        f"peak joint speed {f(report['peak_joint_speed_deg_s'], '.0f')} deg/s "
        f"({report['peak_joint']}); locked straight in swing "
        f"{f(None if report['locked_swing_fraction'] is None else 100 * report['locked_swing_fraction'], '.1f')} %"
        f" ({report['locked_joint'] or '-'}); elbows and knees "
        f"{f(None if report['elbow_knee_locked_fraction'] is None else 100 * report['elbow_knee_locked_fraction'], '.1f')} %"
        f" ({report['elbow_knee_locked_joint'] or '-'}), nearly straight "
        f"{f(None if report['elbow_knee_near_straight_fraction'] is None else 100 * report['elbow_knee_near_straight_fraction'], '.1f')} %",
    ]
    return "\n".join(lines)
