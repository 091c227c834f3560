"""Plain-float helpers for one character's step.

A single character's per-frame state is a handful of numbers per leg; numpy
calls on arrays of 2 to 16 numbers cost far more in call overhead than the
arithmetic, so :class:`~quadsim.locomotion.controller.ProceduralController`
plans with Python floats and these ``math``-module helpers. The heavy stages
are compiled kernels shared with the batch: the CPG step
(:func:`quadsim.locomotion.cpg.cpg_step_rows`), the feet
(:func:`quadsim.locomotion.plan_kernels.feet_rows`) and the posing
(:mod:`quadsim.locomotion.pose_kernel`).

:func:`interp` computes what ``numpy.interp`` does for one ``x`` (same
formula, same order of operations).
"""

from __future__ import annotations

import math
from bisect import bisect_right

TWO_PI = 2.0 * math.pi


def interp(x: float, xp, fp) -> float:
    """``numpy.interp(x, xp, fp)`` for one ``x`` (``xp`` non-decreasing)."""
    n = len(xp)
    if x > xp[-1]:
        return fp[-1]
    if x < xp[0]:
        return fp[0]
    if x == xp[-1]:
        return fp[-1]
    j = bisect_right(xp, x) - 1
    if j >= n - 1:
        return fp[n - 1]
    if xp[j] == x:
        return fp[j]
    slope = (fp[j + 1] - fp[j]) / (xp[j + 1] - xp[j])
    return slope * (x - xp[j]) + fp[j]
