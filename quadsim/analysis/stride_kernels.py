"""Compiled stride figures: the stride table of the four feet and their phases.

A motion's report reads its strides from every foot's contacts
(:mod:`quadsim.analysis.strides`). Done with NumPy, each foot's handful of
strides costs a dozen small array operations, which on a sweep's clips
(a few hundred frames each) take longer than the figures' arithmetic;
here the four feet's contacts come as one array each, concatenated in leg
order (LF, RF, LH, RH), and one loop finds what those operations found.

The stride table's rows are the same numbers to the last bit (the same
subtractions, divisions and square roots); the means of the phases'
unit vectors and of the stance times are summed in order, which may round
the last bit differently from NumPy's pairwise sums.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = ["leg_starts", "phase_means", "stride_rows"]


def leg_starts(counts) -> np.ndarray:
    """Where each leg's items start in the concatenated arrays, and their end: (5,) int64."""
    out = np.zeros(5, dtype=np.int64)
    out[1:] = np.cumsum(np.asarray(counts, dtype=np.int64))
    return out


@njit(cache=True)
def stride_rows(on, off, s, e, first, fx, fz, with_length, leg, td, lo, nxt, length):
    """The whole strides of the four feet: one row each, leg by leg, in time order.

    Parameters
    ----------
    on, off : ndarray, shape (n,)
        Every contact's touchdown and lift-off time (s; NaN where unobserved),
        the legs' contacts one after another.
    s, e : ndarray of int64, shape (n,)
        Every contact's first and (exclusive) last frame.
    first : ndarray of int64, shape (5,)
        Where each leg's contacts start in those arrays, then ``n``
        (:func:`leg_starts`).
    fx, fz : ndarray, shape (T, 4)
        The feet's ground-plane coordinates (X, Z) (m); read only with
        ``with_length``.
    with_length : bool
        Whether to measure the stride lengths (NaN otherwise).
    leg, td, lo, nxt, length : ndarray, shape (n,)
        Written, a row per stride: its leg, touchdown, lift-off and next
        touchdown (s), and the distance between the foot's planted positions
        (the middle frames of the contact and the next) (m).

    Returns
    -------
    int
        The number of rows written.
    """
    r = 0
    for i in range(4):
        for k in range(first[i], first[i + 1] - 1):
            if not np.isfinite(on[k]):
                continue
            leg[r], td[r], lo[r], nxt[r] = i, on[k], off[k], on[k + 1]
            if with_length:
                m0, m1 = (s[k] + e[k]) // 2, (s[k + 1] + e[k + 1]) // 2
                dx, dz = fx[m1, i] - fx[m0, i], fz[m1, i] - fz[m0, i]
                length[r] = np.sqrt(dx * dx + dz * dz)
            else:
                length[r] = np.nan
            r += 1
    return r


@njit(cache=True)
def phase_means(t, first, ref_leg, out):
    """Each foot's mean touchdown phase in the strides of the reference foot.

    Parameters
    ----------
    t : ndarray, shape (n,)
        Every foot's observed touchdown times (s), ascending per foot, the
        feet one after another.
    first : ndarray of int64, shape (5,)
        Where each foot's times start in ``t``, then ``n``.
    ref_leg : int
        The reference foot (the left hind): its phase is 0.
    out : ndarray, shape (4,)
        Written: for each foot, the circular mean (in [0, 1)) of
        ``(t - t0) / (t1 - t0)`` over its touchdowns inside a whole stride
        ``[t0, t1)`` of the reference foot; NaN without any.
    """
    a, b = first[ref_leg], first[ref_leg + 1]
    ref = t[a:b]
    two_pi = 2.0 * np.pi
    for i in range(4):
        out[i] = np.nan
    if b - a < 2:
        return
    for i in range(4):
        c = 0.0
        sn = 0.0
        n = 0
        for m in range(first[i], first[i + 1]):
            k = np.searchsorted(ref, t[m], side="right") - 1
            if k < 0 or k >= b - a - 1:
                continue
            ph = (t[m] - ref[k]) / (ref[k + 1] - ref[k])
            c += math.cos(two_pi * ph)
            sn += math.sin(two_pi * ph)
            n += 1
        if n:
            out[i] = (math.atan2(sn / n, c / n) / two_pi) % 1.0
    out[ref_leg] = 0.0
    for i in range(4):
        if out[i] > 1.0 - 1e-9:
            out[i] = 0.0
