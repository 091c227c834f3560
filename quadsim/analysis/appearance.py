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
  locked straight (interior angle at least :data:`STRAIGHT_DEG`).

Stance comes from :func:`~quadsim.skeleton.contacts.foot_contacts` on the foot
joints (measured from the ground under them when the motion carries it);
strides run from one left-hind touchdown to the next. Angles are reported
in degrees, lengths in metres unless named ``_mm``.
"""

from __future__ import annotations

import math

import numpy as np

from quadsim.frames import GRAVITY, LEGS, X, Y, Z
from quadsim.skeleton.anatomy import Anatomy, find_anatomy
from quadsim.skeleton.contacts import foot_contacts

__all__ = ["ALEXANDER", "MIN_FLIGHT_FRAMES", "STRAIGHT_DEG", "appearance_report",
           "format_appearance", "spine_flexion", "toe_positions", "trunk_pitch"]

#: Alexander's dynamic-similarity stride law ``lambda / h = a Fr^b`` (1976).
ALEXANDER = (2.3, 0.3)
#: Shortest flight phase (frames) whose vertical acceleration is measured.
MIN_FLIGHT_FRAMES = 4
#: A joint this straight (interior angle, degrees) or straighter is locked.
STRAIGHT_DEG = 177.0
#: Leg joints bent less than this at rest (interior angle, degrees) are the
#: hinges checked for locking (a joint straight at rest, like a horse's
#: carpus, is left out).
BENT_AT_REST_DEG = 170.0
_LH = LEGS.index("LH")


def _ground(motion) -> np.ndarray:
    g = (getattr(motion, "extras", None) or {}).get("ground")
    T = motion.n_frames
    return np.zeros((T, 4)) if g is None else np.asarray(g, dtype=float).reshape(T, 4)


def toe_positions(motion, anatomy: Anatomy | None = None) -> np.ndarray:
    """World positions of the four toe tips (the feet's end sites), shape (T, 4, 3) (m)."""
    a = anatomy or find_anatomy(motion.skeleton, motion.foot_joints)
    G = motion.world_rotations()[:, list(a.feet)]
    P = motion.world_positions()[:, list(a.feet)]
    return P + np.einsum("tlij,lj->tli", G, a.toe_offsets)


def trunk_pitch(positions: np.ndarray, anatomy: Anatomy) -> np.ndarray:
    """Nose-up pitch of the pelvis-to-withers line, shape (T,) (rad)."""
    d = positions[:, anatomy.withers] - positions[:, anatomy.pelvis]
    return np.arctan2(d[:, Y], np.hypot(d[:, X], d[:, Z]))


def spine_flexion(positions: np.ndarray, anatomy: Anatomy) -> np.ndarray:
    """Angle between the pelvis-to-mid-spine and mid-spine-to-withers chords, (T,) (rad).

    Signed: positive while the back arches (the mid-spine above the
    pelvis-to-withers line, flexion), negative while it sags (extension),
    so that a stride's range spans both (an unsigned angle would fold an
    extension onto a flexion of the same size).
    """
    a = positions[:, anatomy.mid_spine] - positions[:, anatomy.pelvis]
    b = positions[:, anatomy.withers] - positions[:, anatomy.mid_spine]
    # the body's left: up x forward, forward the pelvis-to-withers line
    fwd = positions[:, anatomy.withers] - positions[:, anatomy.pelvis]
    left = np.stack([fwd[:, Z], np.zeros(len(fwd)), -fwd[:, X]], axis=-1)
    # an arch turns the chords from rising to falling: a x b points to the left
    sign = np.where(np.einsum("ti,ti->t", np.cross(a, b), left) > 0.0, 1.0, -1.0)
    return sign * _angle(a, b)


def _angle(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    cross = np.linalg.norm(np.cross(a, b), axis=-1)
    return np.arctan2(cross, np.einsum("...i,...i->...", a, b))


def _head_pitch(motion, positions: np.ndarray, a: Anatomy) -> np.ndarray:
    if a.head_from_parent:
        d = positions[:, a.head] - positions[:, motion.skeleton.parents[a.head]]
    else:
        d = np.einsum("tij,j->ti", motion.world_rotations()[:, a.head], a.head_tip)
    return np.arctan2(d[:, Y], np.hypot(d[:, X], d[:, Z]))


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    m = np.concatenate([[False], np.asarray(mask, bool), [False]])
    d = np.diff(m.astype(np.int8))
    return list(zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1)))


def _per_stride_range(x: np.ndarray, bounds: list[tuple[int, int]]) -> np.ndarray:
    return np.array([np.ptp(x[s:e + 1]) for s, e in bounds]) if bounds else np.array([])


def _median(x) -> float | None:
    x = np.asarray(x, dtype=float)
    x = x[np.isfinite(x)]
    return float(np.median(x)) if x.size else None


def _pct(x, q) -> float | None:
    x = np.asarray(x, dtype=float)
    x = x[np.isfinite(x)]
    return float(np.percentile(x, q)) if x.size else None


def _hinges(motion, a: Anatomy) -> list[tuple[int, int, int, int]]:
    """(leg, parent, joint, child) of every leg joint bent at rest."""
    P = motion.skeleton.rest_positions
    out = []
    for leg, chain in enumerate(a.legs):
        for k in range(1, len(chain) - 1):
            p, j, c = chain[k - 1], chain[k], chain[k + 1]
            inner = math.degrees(math.pi - _angle(P[j] - P[p], P[c] - P[j]))
            if inner < BENT_AT_REST_DEG:
                out.append((leg, p, j, c))
    return out


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
        ``head_pitch_range_deg``, ``toe_below_ground_mm`` (deepest),
        ``toe_slide_mm_p90``, ``touchdown_speed_ratio_p90``,
        ``touchdown_descent_ratio_p90``, ``liftoff_speed_ratio_p90``, ``flights``, ``flight_accel_g`` (list, one
        per flight phase; -1 is a ballistic fall), ``peak_joint_speed_deg_s``
        and its ``peak_joint``, ``locked_swing_fraction`` (worst hinge) and its
        ``locked_joint``.
    """
    a = anatomy or find_anatomy(motion.skeleton, motion.foot_joints)
    fps = float(motion.fps)
    k0 = int(math.ceil(start * fps - 1e-9))
    Pall = motion.world_positions()
    if k0 >= len(Pall) - 2:
        raise ValueError(f"`start` = {start:g} s leaves fewer than three frames of the "
                         f"{motion.duration:.3g} s motion")
    P = Pall[k0:]
    ground = _ground(motion)[k0:]
    feet = P[:, list(a.feet)].copy()
    feet[..., Y] -= ground
    contacts = foot_contacts(feet, fps)
    toes = toe_positions(motion, a)[k0:].copy()
    toes[..., Y] -= ground
    h = a.hip_height
    root = P[:, 0]
    vel = np.gradient(root[:, [X, Z]], 1.0 / fps, axis=0)
    body_speed = np.linalg.norm(vel, axis=1)

    # strides: left-hind touchdown to the next
    td = [s for s, _ in _runs(contacts[:, _LH]) if s > 0]
    bounds = list(zip(td[:-1], td[1:]))
    lengths, cadence, froude, law = [], [], [], []
    for s, e in bounds:
        dur = (e - s) / fps
        dist = float(np.linalg.norm(root[e, [X, Z]] - root[s, [X, Z]]))
        v = dist / dur
        fr = v * v / (GRAVITY * h)
        lengths.append(dist / h)
        cadence.append(math.sqrt(h / GRAVITY) / dur)
        froude.append(fr)
        law.append(ALEXANDER[0] * fr ** ALEXANDER[1] if fr > 0 else np.nan)

    mid = 0.5 * (P[:, a.pelvis] + P[:, a.withers])
    pitch = trunk_pitch(P, a)
    flex = spine_flexion(P, a)
    head = _head_pitch(motion, Pall, a)[k0:]

    # contacts: toe tips and foot speeds at the events
    slides, below, td_ratio, td_down, lo_ratio = [], [], [], [], []
    fvel = np.linalg.norm(np.diff(feet[..., [X, Z]], axis=0), axis=-1) * fps  # (T-1, 4)
    fdown = -np.diff(feet[..., Y], axis=0) * fps  # (T-1, 4), descent speed
    for i in range(4):
        for s, e in _runs(contacts[:, i]):
            tip = toes[s:e, i]
            below.append(-float(np.min(tip[:, Y])))
            slides.append(float(np.max(np.linalg.norm(tip[:, [X, Z]] - tip[0, [X, Z]],
                                                      axis=1))))
            if s > 0 and body_speed[s] > 0.05:
                td_ratio.append(fvel[s - 1, i] / body_speed[s])
                td_down.append(max(fdown[s - 1, i], 0.0) / body_speed[s])
            if e < len(P) and body_speed[e - 1] > 0.05:
                lo_ratio.append(fvel[e - 1, i] / body_speed[e - 1])

    # flight: no foot down
    accel = []
    for s, e in _runs(~contacts.any(axis=1)):
        if e - s >= MIN_FLIGHT_FRAMES and s > 0 and e < len(P):
            t = np.arange(s, e) / fps
            c2 = np.polyfit(t - t.mean(), mid[s:e, Y], 2)[0]
            accel.append(2.0 * c2 / GRAVITY)

    # joints: angular speed from the positions' local frames, hinge locking in swing
    from quadsim.analysis.metrics import angular_velocity

    w = np.degrees(angular_velocity(motion))[k0:]
    peak_j = int(np.argmax(w.max(axis=0))) if w.size else 0
    locked, locked_name = None, None
    for leg, p, j, c in _hinges(motion, a):
        swing = ~contacts[:, leg]
        if not swing.any():
            continue
        inner = 180.0 - np.degrees(_angle(P[:, j] - P[:, p], P[:, c] - P[:, j]))
        frac = float(np.mean(inner[swing] >= STRAIGHT_DEG))
        if locked is None or frac > locked:
            locked, locked_name = frac, a.names[j]

    return {
        "strides": len(bounds),
        "hip_height": h,
        "stride_over_h": _median(lengths),
        "alexander_over_h": _median(law),
        "froude": _median(froude),
        "cadence": _median(cadence),
        "trunk_pitch_range_deg": _median(np.degrees(_per_stride_range(pitch, bounds))),
        "trunk_heave_over_h": _median(_per_stride_range(mid[:, Y], bounds) / h),
        "spine_flexion_range_deg": _median(np.degrees(_per_stride_range(flex, bounds))),
        "head_pitch_range_deg": _median(np.degrees(_per_stride_range(head, bounds))),
        "toe_below_ground_mm": 1000.0 * max(below) if below else None,
        "toe_slide_mm_p90": None if not slides else 1000.0 * _pct(slides, 90),
        "touchdown_speed_ratio_p90": _pct(td_ratio, 90),
        "touchdown_descent_ratio_p90": _pct(td_down, 90),
        "liftoff_speed_ratio_p90": _pct(lo_ratio, 90),
        "flights": len(accel),
        "flight_accel_g": [float(x) for x in accel],
        "peak_joint_speed_deg_s": float(w.max()) if w.size else None,
        "peak_joint": a.names[peak_j],
        "locked_swing_fraction": locked,
        "locked_joint": locked_name,
    }


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
        f"toe tip: deepest {f(report['toe_below_ground_mm'], '.1f')} mm below ground, slide p90 "
        f"{f(report['toe_slide_mm_p90'], '.1f')} mm; foot speed / body speed at touchdown p90 "
        f"{f(report['touchdown_speed_ratio_p90'], '.2f')} (descending "
        f"{f(report['touchdown_descent_ratio_p90'], '.2f')}), after lift-off "
        f"{f(report['liftoff_speed_ratio_p90'], '.2f')}",
        f"flight phases {report['flights']}: vertical acceleration "
        + (", ".join(f"{x:+.2f}" for x in acc[:8]) + (" ..." if len(acc) > 8 else "") + " g"
           if acc else "-"),
        f"peak joint speed {f(report['peak_joint_speed_deg_s'], '.0f')} deg/s "
        f"({report['peak_joint']}); locked straight in swing "
        f"{f(None if report['locked_swing_fraction'] is None else 100 * report['locked_swing_fraction'], '.1f')} %"
        f" ({report['locked_joint'] or '-'})",
    ]
    return "\n".join(lines)
