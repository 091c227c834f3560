"""Compiled stride figures of the appearance: stride laws and per-stride ranges, as medians.

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

__all__ = ["STRIDE_MEDIANS", "stride_medians"]

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
