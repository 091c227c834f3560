"""Quality measured from a produced motion: footfalls, sliding, penetration, smoothness.

Everything here is computed from joint world positions and local rotations,
never from a generator's own contact flags. Arrays follow the package
conventions: time leads, legs are ordered LF, RF, LH, RH, positions are
``(..., 3)`` in metres with +Y up (the ground is ``y = 0``), quaternions are
``(w, x, y, z)``. Times are seconds from the first frame given.

Contacts and their timing
-------------------------
Defined in :mod:`quadsim.skeleton.contacts`.

A *stride* of a foot runs from one of its touchdowns to the next. Duty
factors, stride frequencies and phases use whole strides only.
"""

from __future__ import annotations

import math

import numpy as np

from quadsim.frames import LEGS, Y
from quadsim.skeleton.contacts import (  # noqa: F401  (re-exported)
    MIN_FRAMES,
    _LH,
    _check_fps,
    _check_feet,
    _check_contacts,
    body_span,
    contact_intervals,
    _horizontal,
    default_contact_thresholds,
    _runs,
    _tolerance,
    foot_contacts,
    _events,
    stance_intervals,
)

__all__ = [
    "angular_acceleration", "angular_velocity", "angular_velocity_vectors",
    "body_span", "contact_intervals", "default_contact_thresholds", "duty_factors",
    "feet_over_ground", "foot_contacts", "foot_slide", "format_report", "ground_penetration",
    "motion_report",
    "penetration_depth", "phases", "report_from_positions", "root_speed",
    "stance_intervals", "stride_frequency", "stride_length", "stride_table",
    "strides_to_pattern",
    "touchdown_times",
]

def touchdown_times(contacts, fps, feet=None, *, tolerance=None) -> list[np.ndarray]:
    """Observed touchdown times (s) of each foot, a list of 4 ascending arrays."""
    return [iv[np.isfinite(iv[:, 0]), 0]
            for iv in stance_intervals(contacts, fps, feet, tolerance=tolerance)]


# ---------------------------------------------------------- stride figures
def stride_table(contacts, fps, feet=None, *, tolerance=None) -> dict[str, np.ndarray]:
    """One row per whole stride of every foot.

    Parameters
    ----------
    contacts : array-like of bool, shape (T, 4)
    fps : float
    feet : array-like, shape (T, 4, 3), optional
        Refines the timing and gives the stride lengths.

    Returns
    -------
    table : dict of str to ndarray, shape (n,)
        ``leg`` (index into LF, RF, LH, RH), ``touchdown``, ``liftoff`` and
        ``next_touchdown`` (s), ``period`` (s), ``stance`` (s), ``duty``, and
        ``length`` (m): the horizontal distance between the foot's planted
        positions (at the middle frame of each contact) of this contact and the
        next (NaN without ``feet``). Rows are sorted by leg, then time.
    """
    evs = _events(contacts, fps, feet, tolerance)
    return _table(evs, None if feet is None else _check_feet(feet))


def _table(evs: list[dict], f: np.ndarray | None) -> dict[str, np.ndarray]:
    rows = []
    for i, ev in enumerate(evs):
        on, off = ev["on"], ev["off"]
        k = np.flatnonzero(np.isfinite(on[:-1]))
        mid = (ev["s"] + ev["e"]) // 2
        if f is None:
            length = np.full(len(k), np.nan)
        else:
            p = _horizontal(f[mid, i])
            length = np.linalg.norm(p[k + 1] - p[k], axis=-1)
        rows.append((np.full(len(k), i), on[k], off[k], on[k + 1], length))
    leg, td, lo, nxt, length = (np.concatenate(col) for col in zip(*rows))
    period = nxt - td
    stance = lo - td
    return {"leg": leg.astype(np.int64), "touchdown": td, "liftoff": lo,
            "next_touchdown": nxt, "period": period, "stance": stance,
            "duty": stance / period, "length": length}


def duty_factors(contacts, fps, feet=None, *, tolerance=None) -> np.ndarray:
    """Duty factor of each foot over its whole strides.

    The stance time summed over the strides from the foot's first to its last
    observed touchdown, divided by that span (the duration-weighted mean of
    the per-stride duty factors in :func:`stride_table`).

    Returns
    -------
    duty : ndarray, shape (4,)
        NaN for a foot without one whole stride.
    """
    return _duty(stride_table(contacts, fps, feet, tolerance=tolerance))


def _duty(t: dict) -> np.ndarray:
    stance = np.bincount(t["leg"], t["stance"], minlength=4)
    period = np.bincount(t["leg"], t["period"], minlength=4)
    return np.divide(stance, period, out=np.full(4, np.nan), where=period > 0)


def phases(contacts, fps, feet=None, *, tolerance=None) -> np.ndarray:
    """Mean touchdown phase of each foot relative to the left hind.

    For each stride ``[t0, t1)`` of the left hind (LH), each touchdown ``t`` of
    another foot inside it gives ``(t - t0) / (t1 - t0)``; the phases of a foot
    are averaged on the unit circle (so 0.98 and 0.02 average to 0).

    Returns
    -------
    phase : ndarray, shape (4,)
        In [0, 1), leg order LF, RF, LH, RH; LH is 0. NaN for a foot with no
        touchdown inside a whole LH stride (or all LH without one).
    """
    return _phases(touchdown_times(contacts, fps, feet, tolerance=tolerance))


def _phases(td: list[np.ndarray]) -> np.ndarray:
    ref = td[_LH]
    out = np.full(4, np.nan)
    if len(ref) < 2:
        return out
    for i, t in enumerate(td):
        k = np.searchsorted(ref, t, side="right") - 1
        ok = (k >= 0) & (k < len(ref) - 1)
        if not ok.any():
            continue
        k, t = k[ok], t[ok]
        ph = (t - ref[k]) / (ref[k + 1] - ref[k])
        ang = np.angle(np.mean(np.exp(2j * np.pi * ph)))
        out[i] = (ang / (2 * np.pi)) % 1.0
    out[_LH] = 0.0
    return np.where(out > 1.0 - 1e-9, 0.0, out)


def strides_to_pattern(contacts, fps, want, *, feet=None, start: float = 0.0,
                       tol: float = 0.06, tolerance=None) -> int | None:
    """Left-hind strides from ``start`` until the footfall pattern ``want`` holds for good.

    Each whole left-hind (LH) stride ``[t0, t1)`` that begins at or after
    ``start`` matches when every other foot touches down inside it at phase
    ``(t - t0) / (t1 - t0)`` within ``tol`` (a fraction of the stride, taken
    round the circle) of ``want`` (its first touchdown in the stride counts).

    Parameters
    ----------
    contacts : array-like of bool, shape (T, 4)
    fps : float
    want : array-like, shape (4,)
        Wanted touchdown phase of each foot after LH, leg order LF, RF, LH, RH.
    feet : array-like, shape (T, 4, 3), optional
        Refines the touchdown times (see :func:`stance_intervals`).
    start : float
        Time (s) from which strides are counted.
    tol : float
        Largest phase error (fraction of a stride).

    Returns
    -------
    int or None
        The number of strides from ``start`` before the first of the
        unbroken run of matching strides that ends with the last whole stride;
        None when the last stride does not match (or there is none).
    """
    td = touchdown_times(contacts, fps, feet, tolerance=tolerance)
    want = np.asarray(want, dtype=float)
    ref = td[_LH][td[_LH] >= start - 1e-9]
    ok = []
    for a, b in zip(ref[:-1], ref[1:]):
        err = 0.0
        for i in range(4):
            if i == _LH:
                continue
            x = td[i][(td[i] >= a) & (td[i] < b)]
            err = max(err, abs(((x[0] - a) / (b - a) - want[i] + 0.5) % 1.0 - 0.5)
                      if len(x) else 1.0)
        ok.append(err < tol)
    if not ok or not ok[-1]:
        return None
    bad = [k for k, v in enumerate(ok) if not v]
    return bad[-1] + 1 if bad else 0


def stride_frequency(contacts, fps, feet=None, *, tolerance=None) -> float:
    """Strides per second (Hz) from the left hind's touchdowns (NaN if < 2)."""
    return _frequency(touchdown_times(contacts, fps, feet, tolerance=tolerance)[_LH])


def _frequency(t: np.ndarray) -> float:
    if len(t) < 2:
        return float("nan")
    return float((len(t) - 1) / (t[-1] - t[0]))


def stride_length(root_positions, contacts, fps, feet=None, *, tolerance=None) -> float:
    """Mean horizontal distance the root travels per left-hind stride (m).

    The root's horizontal path length between consecutive left-hind
    touchdowns (interpolated between frames), averaged; on a curve this is the
    distance along the path. NaN with fewer than two touchdowns.

    Parameters
    ----------
    root_positions : array-like, shape (T, 3)
    contacts : array-like of bool, shape (T, 4)
    fps : float
    feet : array-like, shape (T, 4, 3), optional
    """
    root = np.asarray(root_positions, dtype=float)
    c = _check_contacts(contacts)
    if root.shape != (len(c), 3):
        raise ValueError(f"`root_positions` has shape {root.shape}, expected ({len(c)}, 3)")
    fps = _check_fps(fps)
    return _length(root, touchdown_times(c, fps, feet, tolerance=tolerance)[_LH], fps)


def _length(root: np.ndarray, t: np.ndarray, fps: float) -> float:
    if len(t) < 2:
        return float("nan")
    step = np.linalg.norm(np.diff(_horizontal(root), axis=0), axis=-1)
    path = np.concatenate([[0.0], np.cumsum(step)])
    s = np.interp(t * fps, np.arange(len(root)), path)
    return float((s[-1] - s[0]) / (len(t) - 1))


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


# -------------------------------------------------------------- smoothness
def _quaternions_fps(motion, fps) -> tuple[np.ndarray, float]:
    if hasattr(motion, "rotations") and hasattr(motion, "fps"):
        q, fps = motion.rotations, motion.fps if fps is None else fps
    else:
        q = motion
        if fps is None:
            raise ValueError("`fps` is required when rotations are given as an array")
    q = np.asarray(q, dtype=float)
    if q.ndim < 2 or q.shape[-1] != 4:
        raise ValueError(f"`rotations` has shape {q.shape}, expected (T, J, 4)")
    return q, _check_fps(fps)


def angular_velocity_vectors(motion, fps: float | None = None) -> np.ndarray:
    """Angular velocity of each joint relative to its parent, as vectors.

    Between frames t and t+1 the local rotation changes by
    ``dq = q[t+1] * conj(q[t])`` (expressed in the parent's frame); the vector
    is its axis times its angle (the shorter way round) times ``fps``.

    Parameters
    ----------
    motion : Motion or array-like, shape (T, J, 4)
        A motion, or local quaternions ``(w, x, y, z)``.
    fps : float, optional
        Required with an array; overrides the motion's.

    Returns
    -------
    omega : ndarray, shape (T - 1, J, 3)
        rad/s.
    """
    q, fps = _quaternions_fps(motion, fps)
    q = q / np.sqrt(np.einsum("...i,...i->...", q, q))[..., None]
    aw, ax, ay, az = np.moveaxis(q[:-1], -1, 0)
    bw, bx, by, bz = np.moveaxis(q[1:], -1, 0)
    # dq = b * conj(a) = (w, v)
    w = aw * bw + ax * bx + ay * by + az * bz
    v = np.stack([aw * bx - bw * ax - (by * az - bz * ay),
                  aw * by - bw * ay - (bz * ax - bx * az),
                  aw * bz - bw * az - (bx * ay - by * ax)], axis=-1)
    n = np.sqrt(np.einsum("...i,...i->...", v, v))
    angle = 2.0 * np.arctan2(n, np.abs(w))           # the shorter way round
    scale = np.divide(angle, n, out=np.full_like(n, 2.0), where=n > 1e-12)
    scale *= np.where(w < 0, -fps, fps)
    return v * scale[..., None]


def angular_velocity(motion, fps: float | None = None) -> np.ndarray:
    """Local angular speed of each joint between consecutive frames.

    ``2 arccos(|<q_t, q_t+1>|) * fps``, computed stably as the norm of
    :func:`angular_velocity_vectors`.

    Returns
    -------
    speed : ndarray, shape (T - 1, J)
        rad/s.
    """
    return np.linalg.norm(angular_velocity_vectors(motion, fps), axis=-1)


def angular_acceleration(motion, fps: float | None = None) -> np.ndarray:
    """Magnitude of the change of each joint's angular velocity vector.

    ``|omega[t+1] - omega[t]| * fps`` with the vectors of
    :func:`angular_velocity_vectors`, so a joint that reverses its swing shows
    up even when its angular speed does not change.

    Returns
    -------
    accel : ndarray, shape (T - 2, J)
        rad/s^2.
    """
    q, fps = _quaternions_fps(motion, fps)
    w = angular_velocity_vectors(q, fps)
    return np.linalg.norm(np.diff(w, axis=0), axis=-1) * fps


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
    T = len(f)
    h_used, v_used = default_contact_thresholds(f)
    h_used = h_used if height is None else float(height)
    v_used = v_used if speed is None else float(speed)
    tol = _tolerance(h_used)
    contacts = foot_contacts(f, fps, height=h_used, speed=v_used, min_frames=min_frames,
                             tolerance=tol)
    evs = _events(contacts, fps, f, tol)
    table = _table(evs, f)
    duty = _duty(table)
    t_lh = evs[_LH]["on"][np.isfinite(evs[_LH]["on"])]
    phase = _phases([ev["on"][np.isfinite(ev["on"])] for ev in evs])
    slides, max_slide = foot_slide(f, contacts)
    depth = penetration_depth(f)
    legs = {}
    for i, name in enumerate(LEGS):
        rows = table["leg"] == i
        st = table["stance"][rows]
        legs[name] = {
            "duty_factor": _num(duty[i]),
            "phase": _num(phase[i]),
            "strides": int(rows.sum()),
            "contact_time": _num(st.mean()) if len(st) else None,
            "max_slide_mm": float(slides[i].max() * 1e3) if len(slides[i]) else None,
            "mean_slide_mm": float(slides[i].mean() * 1e3) if len(slides[i]) else None,
            "max_penetration_mm": float(depth[:, i].max() * 1e3),
        }
    report = {
        "fps": fps, "frames": T, "duration": (T - 1) / fps, "start": i0 / fps,
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
    if rotations is not None:
        w = angular_velocity_vectors(rotations[i0:], fps)
        for key, val in (("max_angular_velocity", np.linalg.norm(w, axis=-1)),
                         ("max_angular_acceleration",
                          np.linalg.norm(np.diff(w, axis=0), axis=-1) * fps)):
            if val.size:
                t, j = np.unravel_index(np.argmax(val), val.shape)
                report[key] = float(val[t, j])
                report[key + "_joint"] = (str(joint_names[j]) if joint_names is not None
                                          else int(j))
    return report


def feet_over_ground(motion) -> np.ndarray:
    """Foot positions (T, 4, 3) (m) with their height taken above the ground under them.

    A motion made on uneven ground carries the ground's height under each foot
    on each frame as ``extras["ground"]`` (T, 4) (the data-driven horse on
    slopes); its feet are then measured from that ground, so contacts on a
    ramp count as on the ground. Without it the ground is ``y = 0`` and the
    positions are returned as they are.
    """
    feet = motion.foot_positions()
    ground = (getattr(motion, "extras", None) or {}).get("ground")
    if ground is None:
        return feet
    ground = np.asarray(ground, dtype=float)
    if ground.shape != feet.shape[:2]:
        raise ValueError(f"extras['ground'] has shape {ground.shape}, expected "
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
