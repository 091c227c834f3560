"""Compiled figures of the appearance: its per-frame series, and its stride medians.

:func:`series_rows` finds the per-frame arrays the appearance's figures are
read from (:func:`quadsim.analysis.appearance._series`: the toe tips, the
body's speed, the trunk's pitch, the spine's flexion, the head's pitch, the
feet's speeds) in one pass over each clip's joint positions, where NumPy
walks the batch's arrays a dozen times; :func:`pitch_rows` and
:func:`flexion_rows` are the trunk's pitch and the spine's flexion alone
(:func:`quadsim.analysis.appearance.trunk_pitch`,
:func:`~quadsim.analysis.appearance.spine_flexion`), the same code;
:func:`flight_accels` fits every flight phase's parabola.

:func:`quadsim.analysis.appearance.appearance_report` reads eight of its
figures from the strides (left-hind touchdown to the next): the stride
length over hip height, Alexander's law at the stride's Froude number, the
Froude number and the scaled cadence, and the ranges of the trunk's pitch,
its heave, the spine's flexion and the head's pitch per stride, each the
median over the strides. Found with NumPy, every stride costs several small
array operations; :func:`stride_medians` finds all eight in one loop.

The ranges and medians are exact (maxima, minima, one sort, the mean of
the middle two); the stride lengths' square roots may round the last bit
differently from :func:`numpy.linalg.norm`'s dot product.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = ["STRIDE_MEDIANS", "flexion_rows", "flight_accels", "pitch_rows", "quadratic_coefficient",
           "series_rows", "stride_medians"]

#: The figures :func:`stride_medians` writes, in order.
STRIDE_MEDIANS = ("stride_over_h", "alexander_over_h", "froude", "cadence",
                  "trunk_pitch_range_deg", "trunk_heave_over_h", "spine_flexion_range_deg",
                  "head_pitch_range_deg")


@njit(cache=True)
def _finite_median(x, n):
    """The median of the finite values of ``x[:n]`` (NaN without any): the mean of the
    middle two of an even count."""
    v = np.empty(n)
    m = 0
    for i in range(n):
        if np.isfinite(x[i]):
            v[m] = x[i]
            m += 1
    if m == 0:
        return np.nan
    s = np.sort(v[:m])
    k = m // 2
    return s[k] if m % 2 else (s[k - 1] + s[k]) / 2.0


@njit(cache=True)
def _range(x, a, b):
    """``max - min`` of ``x[a..b]``, both ends in."""
    hi, lo = x[a], x[a]
    for t in range(a + 1, b + 1):
        if x[t] > hi:
            hi = x[t]
        if x[t] < lo:
            lo = x[t]
    return hi - lo


@njit(cache=True)
def stride_medians(td, rx, rz, pitch, heave, flex, head, fps, h, g, law_a, law_b, out):
    """The eight stride figures of :data:`STRIDE_MEDIANS`, medians over the strides.

    Parameters
    ----------
    td : ndarray of int64, shape (S + 1,)
        The frames of the left hind's touchdowns (ascending): ``S`` strides.
    rx, rz : ndarray, shape (T,)
        The root's ground-plane coordinates (X, Z) (m).
    pitch, heave, flex, head : ndarray, shape (T,)
        The trunk's pitch (rad), the girdles' mid-point height (m), the spine's
        flexion (rad) and the head's pitch (rad).
    fps : float
        Frames per second.
    h : float
        Hip height (m).
    g : float
        Gravity (m/s^2).
    law_a, law_b : float
        Alexander's law ``lambda / h = a Fr^b``.
    out : ndarray, shape (8,)
        Written: the medians (NaN where no stride gives a finite value) of the
        stride length over ``h``, the law's length over ``h`` (NaN for a
        stride of no speed), the Froude number ``v^2 / (g h)``, the cadence
        ``sqrt(h / g) / duration``, and the per-stride ranges (both
        touchdowns in) of the pitch (degrees), the heave over ``h``, the
        flexion (degrees) and the head's pitch (degrees).
    """
    S = max(td.shape[0] - 1, 0)
    rows = np.empty((8, max(S, 1)))
    deg = 180.0 / math.pi
    for k in range(S):
        s0, e = td[k], td[k + 1]
        dur = (e - s0) / fps
        dx, dz = rx[e] - rx[s0], rz[e] - rz[s0]
        dist = math.sqrt(dx * dx + dz * dz)
        v = dist / dur
        fr = v * v / (g * h)
        rows[0, k] = dist / h
        rows[1, k] = law_a * fr ** law_b if fr > 0 else np.nan
        rows[2, k] = fr
        rows[3, k] = math.sqrt(h / g) / dur
        rows[4, k] = _range(pitch, s0, e) * deg
        rows[5, k] = _range(heave, s0, e) / h
        rows[6, k] = _range(flex, s0, e) * deg
        rows[7, k] = _range(head, s0, e) * deg
    for i in range(8):
        out[i] = _finite_median(rows[i], S)


@njit(cache=True, inline="always")
def _pitch_of(dx, dy, dz):
    """Nose-up pitch (rad) of the direction ``(dx, dy, dz)``."""
    return math.atan2(dy, math.hypot(dx, dz))


@njit(cache=True, inline="always")
def _flexion_of(P, p, m, w):
    """The signed angle (rad) between the chords ``p -> m`` and ``m -> w`` of one frame's
    positions ``P`` (J, 3): positive while the back arches (see
    :func:`quadsim.analysis.appearance.spine_flexion`)."""
    a0, a1, a2 = P[m, 0] - P[p, 0], P[m, 1] - P[p, 1], P[m, 2] - P[p, 2]
    b0, b1, b2 = P[w, 0] - P[m, 0], P[w, 1] - P[m, 1], P[w, 2] - P[m, 2]
    f0, f2 = P[w, 0] - P[p, 0], P[w, 2] - P[p, 2]  # forward; the body's left (f2, 0, -f0)
    c0, c1, c2 = a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0  # a x b
    angle = math.atan2(math.sqrt(c0 * c0 + c1 * c1 + c2 * c2), a0 * b0 + a1 * b1 + a2 * b2)
    return angle if c0 * f2 - c2 * f0 > 0.0 else -angle


@njit(cache=True)
def pitch_rows(P, p, w, out):
    """``out[k]`` = the pitch (rad) of the chord ``p -> w`` of ``P[k]`` (K, J, 3)."""
    for k in range(P.shape[0]):
        out[k] = _pitch_of(P[k, w, 0] - P[k, p, 0], P[k, w, 1] - P[k, p, 1],
                           P[k, w, 2] - P[k, p, 2])


@njit(cache=True)
def flexion_rows(P, p, m, w, out):
    """``out[k]`` = the spine's signed flexion (rad) of ``P[k]`` (K, J, 3), joints pelvis
    ``p``, mid-spine ``m``, withers ``w``."""
    for k in range(P.shape[0]):
        out[k] = _flexion_of(P[k], p, m, w)


@njit(cache=True)
def series_rows(P, Gf, Gh, ground, feet, toe_off, joints, head_tip, fps, out):
    """The per-frame arrays the appearance's figures are read from, of N clips.

    Parameters
    ----------
    P : ndarray, shape (N, T, J, 3)
        Joint world positions (m), ``T >= 2``.
    Gf : ndarray, shape (N, T, 4, 3, 3)
        World rotations of the four feet ``feet`` (4,).
    Gh : ndarray, shape (N, T, 3, 3)
        World rotation of the head; read only when ``head_parent < 0``.
    ground : ndarray, shape (N, T, 4)
        The ground's height under each foot (m).
    toe_off : ndarray, shape (4, 3)
        The toe tips in their feet's frames (m).
    joints : ndarray of int64, shape (5,)
        The pelvis, mid-spine, withers and head joints, and the joint whose
        chord to the head gives the head's pitch, or -1 for the head's own
        direction ``head_tip`` (3,) in its frame.
    fps : float
    out : tuple of ndarrays
        Written, in this order:
    toes : ndarray, shape (N, T, 4, 3)
        Written: the toe tips' positions, heights over the ground (m).
    body_speed : ndarray, shape (N, T)
        Written: the root's horizontal speed (m/s), central differences
        inside, one-sided at the ends (:func:`numpy.gradient`).
    mid : ndarray, shape (N, T, 3)
        Written: the girdles' mid-point (m).
    girdles_y : ndarray, shape (N, T, 2)
        Written: the pelvis's and withers' heights (m).
    pitch, flex, head_pitch : ndarray, shape (N, T)
        Written: the trunk's pitch, the spine's flexion, the head's pitch (rad).
    fvel, fdown : ndarray, shape (N, T - 1, 4)
        Written: each foot's horizontal speed over each frame step (m/s), and
        its speed down (m/s, over the ground under it).
    """
    toes, body_speed, mid, girdles_y, pitch, flex, head_pitch, fvel, fdown = out
    pelvis, mid_spine, withers, head, head_parent = (joints[0], joints[1], joints[2],
                                                     joints[3], joints[4])
    N, T = P.shape[0], P.shape[1]
    for n in range(N):
        for t in range(T):
            Pt = P[n, t]
            for l in range(4):
                f = feet[l]
                for r in range(3):
                    toes[n, t, l, r] = Pt[f, r] + (Gf[n, t, l, r, 0] * toe_off[l, 0]
                                                   + Gf[n, t, l, r, 1] * toe_off[l, 1]
                                                   + Gf[n, t, l, r, 2] * toe_off[l, 2])
                toes[n, t, l, 1] -= ground[n, t, l]
            a, b = (t - 1, t + 1) if 0 < t < T - 1 else ((0, 1) if t == 0 else (T - 2, T - 1))
            step = (b - a) * (1.0 / fps)  # numpy.gradient's spacing, 1 / fps
            vx, vz = (P[n, b, 0, 0] - P[n, a, 0, 0]) / step, (P[n, b, 0, 2] - P[n, a, 0, 2]) / step
            body_speed[n, t] = math.sqrt(vx * vx + vz * vz)
            for r in range(3):
                mid[n, t, r] = 0.5 * (Pt[pelvis, r] + Pt[withers, r])
            girdles_y[n, t, 0], girdles_y[n, t, 1] = Pt[pelvis, 1], Pt[withers, 1]
            pitch[n, t] = _pitch_of(Pt[withers, 0] - Pt[pelvis, 0], Pt[withers, 1] - Pt[pelvis, 1],
                                    Pt[withers, 2] - Pt[pelvis, 2])
            flex[n, t] = _flexion_of(Pt, pelvis, mid_spine, withers)
            if head_parent >= 0:
                d0, d1, d2 = (Pt[head, 0] - Pt[head_parent, 0], Pt[head, 1] - Pt[head_parent, 1],
                              Pt[head, 2] - Pt[head_parent, 2])
            else:
                G = Gh[n, t]
                d0 = G[0, 0] * head_tip[0] + G[0, 1] * head_tip[1] + G[0, 2] * head_tip[2]
                d1 = G[1, 0] * head_tip[0] + G[1, 1] * head_tip[1] + G[1, 2] * head_tip[2]
                d2 = G[2, 0] * head_tip[0] + G[2, 1] * head_tip[1] + G[2, 2] * head_tip[2]
            head_pitch[n, t] = _pitch_of(d0, d1, d2)
        for t in range(T - 1):
            for l in range(4):
                f = feet[l]
                dx = P[n, t + 1, f, 0] - P[n, t, f, 0]
                dz = P[n, t + 1, f, 2] - P[n, t, f, 2]
                fvel[n, t, l] = math.sqrt(dx * dx + dz * dz) * fps
                y0 = P[n, t, f, 1] - ground[n, t, l]
                y1 = P[n, t + 1, f, 1] - ground[n, t + 1, l]
                fdown[n, t, l] = -(y1 - y0) * fps


@njit(cache=True)
def quadratic_coefficient(y, fps):
    """``c2`` of the least-squares fit ``y ~ c0 + c1 t + c2 t^2`` of samples ``y`` (n >= 3)
    taken ``1 / fps`` s apart: with ``t`` centred on the middle sample, the odd sums
    of ``t`` vanish and the normal equations give ``c2 = (n S(t^2 y) - S(t^2) S(y)) /
    (n S(t^4) - S(t^2)^2)`` (``np.polyfit(t, y, 2)[0]``, without its solver; the
    sums taken in order)."""
    n = y.shape[0]
    s2 = s4 = s2y = sy = 0.0
    for i in range(n):
        t2 = ((i - 0.5 * (n - 1)) / fps) ** 2
        s2 += t2
        s4 += t2 * t2
        s2y += t2 * y[i]
        sy += y[i]
    return (n * s2y - s2 * sy) / (n * s4 - s2 * s2)


@njit(cache=True)
def flight_accels(flying, y, fps, min_frames, g, out):
    """The vertical acceleration (in ``g``) of every flight phase, from a parabola fitted
    to the height ``y`` (T,) (m) over its frames.

    A flight phase is a run of ``flying`` (T,) bool frames (no foot down) of at
    least ``min_frames`` frames that neither starts on the first frame nor ends
    on the last. ``out`` (T,) is written with the accelerations in time order
    (``2 c2 / g``, :func:`quadratic_coefficient`); returns how many.
    """
    T = flying.shape[0]
    k, t = 0, 0
    while t < T:
        if not flying[t]:
            t += 1
            continue
        s0 = t
        while t < T and flying[t]:
            t += 1
        if t - s0 >= min_frames and s0 > 0 and t < T:
            out[k] = 2.0 * quadratic_coefficient(y[s0:t], fps) / g
            k += 1
    return k
