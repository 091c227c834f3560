"""Small compiled helpers the stage kernels of the plan share.

Each works on one row ``n`` of whole arrays rather than on a view of the row
(``keys[n]``), and is a :data:`plan_inner`: compiled without reference
counts, as the plan is, so that no stage allocates or counts (with them,
each bundle taken apart or view made cost atomic counts, which the threads
of a batch's blocks of rows contend for). Units are SI (m, s, rad); legs
LF, RF, LH, RH.
"""

from __future__ import annotations

import math

from numba import njit

from quadsim.frames import GRAVITY

#: Decorator of a compiled function only other compiled functions call:
#: numba builds it no Python entry point (the entry of a function of large
#: bundles costs more to compile than its body), so calling it from Python
#: crashes. The posing's helpers are ones; the plan's are :data:`plan_inner`.
inner = njit(no_cpython_wrapper=True, no_cfunc_wrapper=True)

#: Decorator of the plan's stages and their helpers (an :data:`inner`
#: compiled without numba's reference counting, NRT): the plan
#: (:func:`~quadsim.locomotion.plan_kernels.plan_rows`) borrows its caller's
#: arrays for the step and allocates none (its scratch is the caller's
#: :class:`~quadsim.locomotion.bundles.StepScratch`), so counting references
#: buys nothing -- and each bundle taken apart counted every array in it
#: twice, atomically: most of a one-row step. An allocation in one of these
#: is a compile error.
plan_inner = njit(no_cpython_wrapper=True, no_cfunc_wrapper=True, _nrt=False)
#: ... inlined into its callers (numba's ``inline="always"``): a helper called
#: per row and leg whose arguments cost more to pass than its body.
plan_inline = njit(inline="always", no_cpython_wrapper=True, no_cfunc_wrapper=True, _nrt=False)

#: Shortest swing, as a fraction of the stride, worth lifting a foot for.
MIN_SWING = 0.12
#: Exponent of the Froude number in Alexander's stride law
#: ``lambda = h * coefficient * Fr^STRIDE_EXPONENT``.
STRIDE_EXPONENT = 0.3


@plan_inner
def frac(x):
    """``x % 1.0`` (Python's float modulo) as ``x - floor(x)``: the same value
    for every float (the difference is exact, or rounds the same sum as the
    modulo's), without the library ``fmod`` call."""
    return x - math.floor(x)


@plan_inner
def smooth_min(a, b, k):
    """``min(a, b)`` rounded over ``|a - b| < k``: at most ``k / 4`` lower, its slope
    continuous (``b`` may be infinite; ``k`` of 0 is the plain minimum)."""
    d = abs(a - b)
    if d >= k:
        return min(a, b)
    e = (k - d) / k
    return min(a, b) - 0.25 * k * e * e


@plan_inner
def interp_knot(x, xp):
    """Where ``numpy.interp(x, xp, fp)`` reads ``fp`` for one ``x``: ``(j, 0)``
    for ``fp[j]`` itself, ``(j, 1)`` for the line from knot ``j`` to ``j + 1``
    (its search and special cases, for :func:`interp1` and its row forms)."""
    n = xp.shape[0]
    if x > xp[n - 1]:
        return n - 1, 0
    if x < xp[0]:
        return 0, 0
    if x == xp[n - 1]:
        return n - 1, 0
    j = 0
    while j + 1 < n and xp[j + 1] <= x:
        j += 1
    if j >= n - 1:
        return n - 1, 0
    if xp[j] == x:
        return j, 0
    return j, 1


@njit(cache=True)
def interp1(x, xp, fp):
    """``numpy.interp(x, xp, fp)`` for one ``x`` (the formula and order of
    operations of ``numpy.interp``)."""
    j, line = interp_knot(x, xp)
    if not line:
        return fp[j]
    slope = (fp[j + 1] - fp[j]) / (xp[j + 1] - xp[j])
    return slope * (x - xp[j]) + fp[j]


@plan_inner
def interp_row(x, xp, fp, n):
    """:func:`interp1` of ``x`` on row ``n`` of ``fp`` (N, D)."""
    j, line = interp_knot(x, xp)
    if not line:
        return fp[n, j]
    slope = (fp[n, j + 1] - fp[n, j]) / (xp[j + 1] - xp[j])
    return slope * (x - xp[j]) + fp[n, j]


@plan_inner
def interp_col(x, xp, fp, n, i):
    """:func:`interp1` of ``x`` on ``fp[n, :, i]`` (``fp`` (N, D, C))."""
    j, line = interp_knot(x, xp)
    if not line:
        return fp[n, j, i]
    slope = (fp[n, j + 1, i] - fp[n, j, i]) / (xp[j + 1] - xp[j])
    return slope * (x - xp[j]) + fp[n, j, i]


@plan_inline
def interp_leg(x, xp, fp, n, i):
    """:func:`interp1` of ``x`` on ``fp[n, i, :]`` (``fp`` (N, 4, D)), the
    knots searched from the top as the body stage always did."""
    D = xp.shape[0]
    j = -1
    for k in range(D):
        if fp[n, i, k] <= x:
            j += 1
    if j < 0:
        return xp[0]
    if j >= D - 1:
        return xp[D - 1]
    x0 = fp[n, i, j]
    return (xp[j + 1] - xp[j]) / (fp[n, i, j + 1] - x0) * (x - x0) + xp[j]


@plan_inner
def keys_row(root_xz, heading, bend, hind_z, body_length, keys, kh, cs, n):
    """Row ``n``'s hind and fore key points ``keys[n]`` (m), their headings
    ``kh[n]`` (rad) and the headings' cosines and sines ``cs[n]`` ((hind,
    fore) x (cos, sin)), from the pelvis on the ground ``root_xz[n]``."""
    fh = heading + 0.5 * bend
    c0, s0 = math.cos(heading), math.sin(heading)
    hx = root_xz[n, 0] + s0 * hind_z
    hy = root_xz[n, 1] + 0.0
    hz = root_xz[n, 2] + c0 * hind_z
    keys[n, 0, 0], keys[n, 0, 1], keys[n, 0, 2] = hx, hy, hz
    keys[n, 1, 0] = hx + math.sin(fh) * body_length
    keys[n, 1, 1] = hy + 0.0
    keys[n, 1, 2] = hz + math.cos(fh) * body_length
    kh[n, 0] = heading
    kh[n, 1] = heading + bend
    cs[n, 0, 0], cs[n, 0, 1] = c0, s0
    cs[n, 1, 0], cs[n, 1, 1] = math.cos(kh[n, 1]), math.sin(kh[n, 1])


@plan_inner
def ahead_of_mid(keys, offset, points, n, i, c0, s0, c1, s1):
    """How far (m) ``points[n, i]`` lies ahead of foot ``i``'s mid-stance point
    (its girdle's key plus the foot's offset turned to the girdle's heading),
    along the girdle's forward vector; ``c0, s0`` / ``c1, s1`` are the cosine
    and sine of the hind / fore girdle's heading."""
    g = 1 if i < 2 else 0
    c, sn = (c1, s1) if g else (c0, s0)
    ox, oy, oz = offset[n, i, 0], offset[n, i, 1], offset[n, i, 2]
    mx = c * ox + sn * oz + keys[n, g, 0]
    my = oy + keys[n, g, 1]
    mz = -sn * ox + c * oz + keys[n, g, 2]
    return (points[n, i, 0] - mx) * sn + (points[n, i, 1] - my) * 0.0 \
        + (points[n, i, 2] - mz) * c


@plan_inline
def room_row(keys, cs, offset, planted, base, room, n):
    """Trailing room ``room[n]`` (m) of each foot of row ``n``: ``base`` plus
    how far its planted point is ahead of its mid-stance point along the
    girdle's forward vector (``cs[n]``, the key headings' cosines and sines
    of :func:`keys_row`)."""
    c0, s0, c1, s1 = cs[n, 0, 0], cs[n, 0, 1], cs[n, 1, 0], cs[n, 1, 1]
    for i in range(4):
        room[n, i] = base + ahead_of_mid(keys, offset, planted, n, i, c0, s0, c1, s1)


@plan_inner
def stride_length(minv, coef, speed, h):
    """Natural stride length (m) at ``speed`` by Alexander's law, for the
    parameters' least speed ``minv`` and stride coefficient ``coef``, hip
    height ``h`` (m); below ``minv`` the stride shortens with the speed."""
    vc = max(max(speed, minv), 1e-3)
    lam = h * coef * (vc * vc / (GRAVITY * h)) ** STRIDE_EXPONENT
    return lam * speed / vc if speed < vc else lam
