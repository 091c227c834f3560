"""Sliding, penetration and speed, and the whole quality report of a motion.

:func:`motion_report` gathers every figure of :mod:`quadsim.analysis`
(footfalls, strides, sliding, penetration, speed, smoothness) into one
JSON-serialisable dict; :func:`format_report` prints it as a table.
Positions are ``(..., 3)`` in metres with +Y up (the ground is ``y = 0``,
or the ground a motion carries in ``extras["ground"]``).
"""

from __future__ import annotations

import math

import numpy as np

from quadsim.analysis.smoothness import angular_velocity_vectors
from quadsim.analysis.strides import _duty, _frequency, _length, _phases, _table
from quadsim.frames import LEGS, Y
from quadsim.skeleton.contacts import (
    _LH,
    MIN_FRAMES,
    _check_contacts,
    _check_feet,
    _check_fps,
    _events,
    _horizontal,
    _runs,
    _tolerance,
    default_contact_thresholds,
    foot_contacts,
)

__all__ = ["feet_over_ground", "foot_slide", "format_report", "ground_penetration",
           "motion_report", "penetration_depth", "report_from_arrays", "report_from_positions",
           "root_speed"]


# ------------------------------------------------- sliding and penetration
def foot_slide(feet, contacts) -> tuple[list[np.ndarray], float]:
    """How far each foot slides on the ground during each of its contacts.

    The slide of a contact is the largest horizontal distance of the foot from
    where it was on the contact's first frame, over the contact's frames (not
    the path length: jitter back and forth does not add up).

    Parameters
    ----------
    feet : array-like, shape (T, 4, 3)
    contacts : array-like of bool, shape (T, 4)

    Returns
    -------
    slides : list of 4 ndarrays, shape (n_i,)
        Per contact, in time order (m).
    max_slide : float
        The largest over all feet (m), 0 without contacts.
    """
    f = _check_feet(feet)
    c = _check_contacts(contacts, len(f))
    T = len(f)
    slides = []
    for i in range(4):
        s, _ = _runs(c[:, i])
        if len(s) == 0:
            slides.append(np.zeros(0))
            continue
        start = s[np.maximum(np.searchsorted(s, np.arange(T), side="right") - 1, 0)]
        d = np.linalg.norm(_horizontal(f[:, i] - f[start, i]), axis=-1)
        slides.append(np.maximum.reduceat(np.where(c[:, i], d, 0.0), s))
    top = max((float(x.max()) for x in slides if len(x)), default=0.0)
    return slides, top


def penetration_depth(positions, *, ground: float = 0.0) -> np.ndarray:
    """Depth of each point below the ground (m, 0 above it).

    Parameters
    ----------
    positions : array-like, shape (..., 3)

    Returns
    -------
    depth : ndarray, shape (...)
    """
    p = np.asarray(positions, dtype=float)
    if p.shape[-1:] != (3,):
        raise ValueError(f"`positions` has shape {p.shape}, expected (..., 3)")
    return np.maximum(ground - p[..., Y], 0.0)


def ground_penetration(positions, *, ground: float = 0.0) -> float:
    """Deepest any of the given points goes below the ground (m, >= 0)."""
    d = penetration_depth(positions, ground=ground)
    return float(d.max()) if d.size else 0.0


def root_speed(root_positions, fps) -> tuple[float, np.ndarray]:
    """Horizontal speed of the root.

    Parameters
    ----------
    root_positions : array-like, shape (T, 3)
    fps : float

    Returns
    -------
    mean : float
        Horizontal path length over the duration (m/s); NaN for T < 2.
    speeds : ndarray, shape (T - 1,)
        Speed over each frame step (m/s).
    """
    r = np.asarray(root_positions, dtype=float)
    if r.ndim != 2 or r.shape[1] != 3:
        raise ValueError(f"`root_positions` has shape {r.shape}, expected (T, 3)")
    v = np.linalg.norm(np.diff(_horizontal(r), axis=0), axis=-1) * _check_fps(fps)
    return (float(v.mean()) if len(v) else float("nan")), v


# ------------------------------------------------------------------ report
def _num(x) -> float | None:
    x = float(x)
    return x if math.isfinite(x) else None


def report_from_positions(feet, root_positions, fps, *, rotations=None, joint_names=None,
                          start: float = 0.0, height: float | None = None,
                          speed: float | None = None, min_frames: int = MIN_FRAMES) -> dict:
    """The quality figures of a motion given as positions (see :func:`motion_report`).

    Parameters
    ----------
    feet : array-like, shape (T, 4, 3)
        Foot joint world positions (m), leg order LF, RF, LH, RH.
    root_positions : array-like, shape (T, 3)
        Root world positions (m).
    fps : float
    rotations : array-like, shape (T, J, 4), optional
        Local joint quaternions ``(w, x, y, z)`` for the smoothness figures
        (None in the report without them).
    joint_names : sequence of str, length J, optional
        Names the joints with the largest angular velocity and acceleration.
    start : float
        Seconds to skip at the beginning (settling).
    height, speed, min_frames
        Contact detection, see :func:`foot_contacts`.

    Returns
    -------
    report : dict
        Plain JSON-serialisable values; figures that cannot be measured are None.
    """
    fps = _check_fps(fps)
    f = _check_feet(feet)
    root = np.asarray(root_positions, dtype=float)
    if root.shape != (len(f), 3):
        raise ValueError(f"`root_positions` has shape {root.shape}, expected ({len(f)}, 3)")
    if rotations is not None:
        rotations = np.asarray(rotations, dtype=float)
        if rotations.ndim != 3 or rotations.shape[0] != len(f) or rotations.shape[2] != 4:
            raise ValueError(f"`rotations` has shape {rotations.shape}, "
                             f"expected ({len(f)}, J, 4)")
    if not (math.isfinite(start) and start >= 0):
        raise ValueError(f"`start` must be a non-negative number of seconds, got {start!r}")
    i0 = math.ceil(start * fps - 1e-9)
    if len(f) - i0 < 3:
        raise ValueError(f"need at least 3 frames after `start` = {start} s; "
                         f"the motion has {len(f)} frames at {fps:g} fps")
    f, root = f[i0:], root[i0:]
    h_used, v_used = default_contact_thresholds(f)
    h_used = h_used if height is None else float(height)
    v_used = v_used if speed is None else float(speed)
    contacts = foot_contacts(f, fps, height=h_used, speed=v_used, min_frames=min_frames,
                             tolerance=_tolerance(h_used))
    omega = None if rotations is None else angular_velocity_vectors(rotations[i0:], fps)
    return report_from_arrays(f, root, fps, contacts, omega, start=i0 / fps,
                              joint_names=joint_names, height=h_used, speed=v_used)


def report_from_arrays(feet, root_positions, fps, contacts, omega=None, *, start=0.0,
                       joint_names=None, height: float | None = None,
                       speed: float | None = None, joint_speed=None,
                       joint_accel=None, events=None, slides=None) -> dict:
    """:func:`report_from_positions` of the part measured, its contacts already found.

    For callers that measure a motion several ways and compute what the
    figures share once (:func:`quadsim.analysis.measure.measure_motion`).

    Parameters
    ----------
    feet : ndarray, shape (T, 4, 3)
        Foot world positions (m) of the frames measured.
    root_positions : ndarray, shape (T, 3)
    fps : float
    contacts : ndarray of bool, shape (T, 4)
        :func:`foot_contacts` of ``feet`` with the thresholds ``height``,
        ``speed`` (and the tolerance that goes with ``height``).
    omega : ndarray, shape (T - 1, J, 3), optional
        :func:`~quadsim.analysis.smoothness.angular_velocity_vectors` of the
        frames measured (rad/s); None leaves the smoothness figures out.
    start : float
        Seconds the part measured starts at (reported).
    joint_names : sequence of str, length J, optional
    height, speed : float, optional
        The contact thresholds used (m, m/s); default
        :func:`default_contact_thresholds` of ``feet``.
    joint_speed : ndarray, shape (T - 1, J), optional
        The norms of ``omega`` when already computed.
    joint_accel : ndarray, shape (T - 2, J), optional
        ``|omega[t + 1] - omega[t]| * fps`` (rad/s^2) when already computed.
    events : list of 4 dict, optional
        The feet's touchdowns and lift-offs (``contacts._events`` of
        ``contacts``, ``feet`` and the tolerance of ``height``) when already
        found (:func:`quadsim.skeleton.contacts_many.events`).
    slides : list of 4 ndarrays, optional
        :func:`foot_slide` of ``feet`` and ``contacts`` (m) when already found
        (:func:`quadsim.skeleton.contacts_many.slides`).

    Returns
    -------
    dict
        As :func:`report_from_positions`.
    """
    fps = _check_fps(fps)
    f = _check_feet(feet)
    root = np.asarray(root_positions, dtype=float)
    T = len(f)
    if height is None or speed is None:
        h0, v0 = default_contact_thresholds(f)
        height = h0 if height is None else height
        speed = v0 if speed is None else speed
    h_used, v_used = float(height), float(speed)
    tol = _tolerance(h_used)
    evs = _events(contacts, fps, f, tol) if events is None else events
    table = _table(evs, f)
    duty = _duty(table)
    t_lh = evs[_LH]["on"][np.isfinite(evs[_LH]["on"])]
    phase = _phases([ev["on"][np.isfinite(ev["on"])] for ev in evs])
    if slides is None:
        slides, max_slide = foot_slide(f, contacts)
    else:  # as foot_slide finds the largest
        max_slide = max((float(x.max()) for x in slides if len(x)), default=0.0)
    depth = penetration_depth(f).max(axis=0)  # (4,), each foot's deepest
    strides = np.bincount(table["leg"], minlength=4)
    stance = np.bincount(table["leg"], table["stance"], minlength=4)  # summed in order
    legs = {}
    for i, name in enumerate(LEGS):
        slid = slides[i]
        legs[name] = {
            "duty_factor": _num(duty[i]),
            "phase": _num(phase[i]),
            "strides": int(strides[i]),
            "contact_time": _num(stance[i] / strides[i]) if strides[i] else None,
            "max_slide_mm": float(slid.max() * 1e3) if len(slid) else None,
            "mean_slide_mm": float(slid.mean() * 1e3) if len(slid) else None,
            "max_penetration_mm": float(depth[i] * 1e3),
        }
    report = {
        "fps": fps, "frames": T, "duration": (T - 1) / fps, "start": start,
        "legs": legs,
        "stride_frequency": _num(_frequency(t_lh)),
        "stride_length": _num(_length(root, t_lh, fps)),
        "mean_speed": _num(root_speed(root, fps)[0]),
        "max_slide_mm": max_slide * 1e3,
        "max_penetration_mm": float(depth.max() * 1e3),
        "max_angular_velocity": None, "max_angular_velocity_joint": None,
        "max_angular_acceleration": None, "max_angular_acceleration_joint": None,
        "contact_height": h_used, "contact_speed": v_used,
    }
    if omega is not None:
        w = omega
        speeds = np.linalg.norm(w, axis=-1) if joint_speed is None else joint_speed
        accel = np.linalg.norm(np.diff(w, axis=0), axis=-1) * fps if joint_accel is None \
            else joint_accel
        for key, val in (("max_angular_velocity", speeds), ("max_angular_acceleration", accel)):
            if val.size:
                t, j = np.unravel_index(np.argmax(val), val.shape)
                report[key] = float(val[t, j])
                report[key + "_joint"] = (str(joint_names[j]) if joint_names is not None
                                          else int(j))
    return report


def feet_over_ground(motion) -> np.ndarray:
    """The feet's ground points (T, 4, 3) (m) with their height taken above the ground
    under them.

    On flat ground (``y = 0``) they are the toe tips
    (:meth:`~quadsim.skeleton.motion.Motion.contact_points`): a paw rolling over
    its toe at push-off lifts its joint while the tip stays planted. A motion
    made on uneven ground carries the ground's height under each foot *joint*
    on each frame as ``extras["ground"]`` (T, 4), and may carry it under each toe
    tip as ``extras["toe_ground"]`` (the data-driven horse does); its toe tips are
    then measured from the ground under them, or else its foot joints from the
    ground under those, so contacts on a ramp count as on the ground.
    """
    extras = getattr(motion, "extras", None) or {}
    key = "toe_ground" if extras.get("toe_ground") is not None else "ground"
    if extras.get(key) is None:
        return motion.contact_points()
    feet = motion.contact_points() if key == "toe_ground" else motion.foot_positions()
    ground = np.asarray(extras[key], dtype=float)
    if ground.shape != feet.shape[:2]:
        raise ValueError(f"extras[{key!r}] has shape {ground.shape}, expected "
                         f"{feet.shape[:2]} (the ground height under each foot, per frame)")
    out = np.array(feet)
    out[..., Y] -= ground
    return out


def motion_report(motion, *, start: float = 0.0, height: float | None = None,
                  speed: float | None = None, min_frames: int = MIN_FRAMES) -> dict:
    """Footfalls, sliding, penetration, speed and smoothness of a motion.

    Parameters
    ----------
    motion : Motion
        Must name its four foot joints (``foot_joints``).
    start : float
        Seconds to skip at the beginning (settling).
    height, speed, min_frames
        Contact detection, see :func:`foot_contacts`.

    Returns
    -------
    report : dict
        ``fps``, ``frames``, ``duration`` (s) and ``start`` (s) of the part
        measured; ``legs``: for LF, RF, LH, RH the ``duty_factor``, ``phase``
        (stride fraction after LH's touchdown), ``strides`` (whole strides),
        ``contact_time`` (mean stance, s), ``max_slide_mm``, ``mean_slide_mm``,
        ``max_penetration_mm``; then ``stride_frequency`` (Hz, LH),
        ``stride_length`` (m of root travel per LH stride), ``mean_speed``
        (root, m/s), ``max_slide_mm``, ``max_penetration_mm`` (feet),
        ``max_angular_velocity`` (rad/s) and ``max_angular_acceleration``
        (rad/s^2) with the joint names, and the ``contact_height`` (m) and
        ``contact_speed`` (m/s) thresholds used. Unmeasurable figures are None.

    Raises
    ------
    ValueError
        When the motion does not name its foot joints, or is too short.
    """
    if getattr(motion, "foot_joints", None) is None:
        raise ValueError("motion_report needs the motion's foot joints: build the Motion "
                         "with foot_joints=(LF, RF, LH, RH joint names)")
    return report_from_positions(
        feet_over_ground(motion), motion.root_positions, motion.fps,
        rotations=motion.rotations, joint_names=motion.skeleton.names, start=start,
        height=height, speed=speed, min_frames=min_frames)


def format_report(report: dict) -> str:
    """A plain-text table of a :func:`motion_report`: one row per foot, then totals."""
    def fmt(x, spec):
        return "-" if x is None else format(x, spec)

    lines = [(f"{report['frames']} frames at {report['fps']:g} fps "
              f"({report['duration']:.2f} s from {report['start']:.2f} s)"), ""]
    head = (f"{'leg':<4}{'duty':>7}{'phase':>7}{'strides':>9}{'contact s':>11}"
            f"{'slide max mm':>14}{'slide mean mm':>15}{'below ground mm':>17}")
    lines += [head, "-" * len(head)]
    for name, leg in report["legs"].items():
        lines.append(
            f"{name:<4}{fmt(leg['duty_factor'], '.3f'):>7}{fmt(leg['phase'], '.3f'):>7}"
            f"{leg['strides']:>9d}{fmt(leg['contact_time'], '.3f'):>11}"
            f"{fmt(leg['max_slide_mm'], '.1f'):>14}{fmt(leg['mean_slide_mm'], '.1f'):>15}"
            f"{fmt(leg['max_penetration_mm'], '.1f'):>17}")

    def joint(key):
        j = report.get(key + "_joint")
        return "" if j is None else f"  ({j})"

    lines += [
        "",
        f"stride frequency          {fmt(report['stride_frequency'], '.3f')} Hz",
        f"stride length             {fmt(report['stride_length'], '.3f')} m",
        f"mean root speed           {fmt(report['mean_speed'], '.3f')} m/s",
        f"max foot slide            {fmt(report['max_slide_mm'], '.1f')} mm",
        f"max foot penetration      {fmt(report['max_penetration_mm'], '.1f')} mm",
        f"max angular velocity      {fmt(report['max_angular_velocity'], '.2f')} rad/s"
        + joint("max_angular_velocity"),
        f"max angular acceleration  {fmt(report['max_angular_acceleration'], '.1f')} rad/s^2"
        + joint("max_angular_acceleration"),
        (f"contact thresholds        {report['contact_height'] * 1e3:.1f} mm, "
         f"{report['contact_speed']:.2f} m/s"),
    ]
    return "\n".join(lines)
