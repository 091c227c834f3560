"""Swing-foot paths: Catmull-Rom splines from lift-off to touchdown.

:func:`swing_into` is the compiled swing path the feet stage
(:func:`quadsim.locomotion.feet.feet_rows`) runs; :func:`swing_position` is
its face for arrays. :func:`catmull_rom` is the general spline.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from quadsim.frames import UP
from quadsim.locomotion.rowmath import plan_inline


def catmull_rom(points: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Uniform Catmull-Rom spline through ``points[1:-1]``.

    Parameters
    ----------
    points : array-like, shape (..., K, 3)
        Control points; the curve passes through ``points[1]`` ...
        ``points[K-2]`` (``K >= 4``), the end points only shape the tangents.
    s : array-like, shape (...)
        Curve parameter in [0, 1] over the whole curve (each of the
        ``K - 3`` segments takes an equal share).

    Returns
    -------
    p : ndarray, shape (..., 3)
    """
    P = np.asarray(points, dtype=float)
    K = P.shape[-2]
    if K < 4:
        raise ValueError(f"`points` needs at least 4 control points, got {K}")
    nseg = K - 3
    s = np.minimum(np.maximum(np.asarray(s, dtype=float), 0.0), 1.0)
    s = np.broadcast_to(s, np.broadcast_shapes(s.shape, P.shape[:-2]))
    x = s * nseg
    i = np.minimum(np.floor(x).astype(int), nseg - 1)
    t = (x - i)[..., None]
    # the four control points of each point's segment, gathered row by row
    Pb = np.broadcast_to(P, s.shape + P.shape[-2:]).reshape((-1,) + P.shape[-2:])
    rows = np.arange(Pb.shape[0])
    i = i.reshape(-1)
    p0, p1, p2, p3 = (Pb[rows, i + k].reshape(s.shape + (3,)) for k in range(4))
    return _segment(p0, p1, p2, p3, t)


def _segment(p0, p1, p2, p3, t):
    """Uniform Catmull-Rom segment from ``p1`` to ``p2`` at ``t`` in [0, 1]."""
    t2, t3 = t * t, t * t * t
    return 0.5 * ((2 * p1) + (-p0 + p2) * t + (2 * p0 - 5 * p1 + 4 * p2 - p3) * t2
                  + (-p0 + 3 * p1 - 3 * p2 + p3) * t3)


#: Knots of the swing path: fraction of the step covered and fraction of the
#: clearance, first and last only shaping the end tangents. The slow gaits'
#: (duty factor :data:`SLOW_DUTY` and more) cover most of the step early and
#: come down almost straight onto the ground ...
SWING_KNOTS = np.array([
    [0.20, 0.00],
    [0.00, 0.00],
    [0.20, 0.75],
    [0.58, 1.00],
    [0.93, 0.60],
    [1.00, 0.00],
    [0.93, 0.20],
])
#: ... the fast gaits' that do not bound (duty factor :data:`FAST_DUTY` and
#: less: the trot, pace and rack) spread the swing forward more evenly and ease
#: the foot's forward speed out over the whole last quarter: their swings are
#: short, and a foot braking over the last eighth swung its knee or elbow at up
#: to 2,300 deg/s (the cubs' trot and pace). The bounding gaits take
#: :data:`SWING_KNOTS_BOUND` (on this path the cubs' and the dog's rotary gallops
#: swung their knees and elbows at up to 3,600 deg/s, from 3,300) ...
SWING_KNOTS_FAST = np.array([
    [0.16, 0.00],
    [0.00, 0.00],
    [0.16, 0.75],
    [0.52, 1.00],
    [0.88, 0.60],
    [1.00, 0.00],
    [0.88, 0.20],
])
#: ... blended in between by the duty factor (and the bound). Only the forward
#: fractions differ: the clearance is the slow path's.
SLOW_DUTY, FAST_DUTY = 0.6, 0.4
assert np.array_equal(SWING_KNOTS_FAST[:, 1], SWING_KNOTS[:, 1])
#: The bounding gaits' (the canter and gallops) is the slow path but for its
#: last quarter, which covers more of the step: the foot comes back onto its
#: touchdown point from less far ahead. On the slow path a galloping foot,
#: still at 0.93 of its step three quarters into the swing while the body
#: covers three quarters of a step a swing, had gone 0.12 of the step past its
#: touchdown point (now 0.09; the horse's fore hoof about 0.65 m, beyond its leg's reach)
#: and came back onto it with the leg locking straight, then snapping bent: the
#: horse's gallops turned their elbows at 3,681-4,070 deg/s, then 3,308-3,310;
#: the leopard's rotary gallop 3,135 -> 2,341, the leopard cub's 3,315 -> 2,957
#: (with the fore girdle guided onto a second fore foot's landing, body.py; with
#: the first's guided too, and landing legs that give, 2,576-2,589, 2,106, 2,814).
#: At 0.88 (the fast path's) the horse's fell further (3,000-3,042) but the cubs'
#: and the dog's feet landed at 0.30-0.31 of the body's speed (from 0.18-0.27);
#: the fast path's earlier knots too bent the horse's elbow past its limit
#: (94 degrees against 90) as a hoof left the ground further behind.
SWING_KNOTS_BOUND = SWING_KNOTS.copy()
SWING_KNOTS_BOUND[[4, 6], 0] = 0.90
#: The walk's path (duty factor :data:`SLOW_DUTY` and more) is the slow path but
#: for its first quarter, which covers less of the step: the foot peels off the
#: ground nearly straight up (on the slow path it left at 0.7-0.9 of the body's
#: speed in the first frame of a walk's swing, the cubs' and the dog's at 60 fps;
#: the bounding gaits keep the slow path's, their knees and elbows otherwise
#: opening faster in mid-swing) ...
SWING_KNOTS_WALK = np.array([
    [0.12, 0.00],
    [0.00, 0.00],
    [0.12, 0.75],
    [0.58, 1.00],
    [0.93, 0.60],
    [1.00, 0.00],
    [0.93, 0.20],
])
#: ... taken fully from this duty factor, none below :data:`SLOW_DUTY` minus this.
WALK_BLEND = 0.05
assert np.array_equal(SWING_KNOTS_WALK[:, 1], SWING_KNOTS[:, 1])


@njit(cache=True, inline="always")
def walk_share(duty: float) -> float:
    """How much of :data:`SWING_KNOTS_WALK` a swing takes in a gait of duty factor
    ``duty``: 1 at :data:`SLOW_DUTY` and above, 0 at :data:`WALK_BLEND` below it."""
    return min(max((duty - SLOW_DUTY + WALK_BLEND) / WALK_BLEND, 0.0), 1.0)


@njit(cache=True, inline="always")
def quick_share(duty: float) -> float:
    """How far a gait of duty factor ``duty`` is from the slow path towards the quick
    gaits' knots: 0 at :data:`SLOW_DUTY` and above, 1 at :data:`FAST_DUTY` and below."""
    return min(max((SLOW_DUTY - duty) / (SLOW_DUTY - FAST_DUTY), 0.0), 1.0)


@njit(cache=True, inline="always")
def fast_share(duty: float, bound: float) -> float:
    """How much of :data:`SWING_KNOTS_FAST` a swing takes in a gait of duty factor
    ``duty`` that bounds by ``bound`` (0 to 1): :func:`quick_share` times
    ``1 - bound`` (the feet stage's, compiled)."""
    return quick_share(duty) * (1.0 - bound)


@njit(cache=True, inline="always")
def bound_share(duty: float, bound: float) -> float:
    """How much of :data:`SWING_KNOTS_BOUND` a swing takes in a gait of duty factor
    ``duty`` that bounds by ``bound`` (0 to 1): :func:`quick_share` times ``bound``
    (the feet stage's, compiled)."""
    return quick_share(duty) * bound


def swing_control_points(liftoff: np.ndarray, touchdown: np.ndarray,
                         height: np.ndarray, fast: float = 0.0,
                         walk: float = 0.0, bounding: float = 0.0) -> np.ndarray:
    """Control points of a swing path, shape (..., 7, 3).

    The foot peels off the ground straight up, its forward speed rising from
    nothing (the end knots mirror their neighbours' forward fraction, so the
    path's forward tangent is zero at both ends), swings through the
    clearance ``height`` past the middle of the step, and comes down with its
    forward speed easing to nothing at touchdown (the limb retracts: the
    foot lands at ground speed, without skidding). Each of the four
    segments between the knots :data:`SWING_KNOTS` takes a quarter of the
    swing.

    Parameters
    ----------
    liftoff, touchdown : array-like, shape (..., 3)
    height : array-like, shape (...)
        Clearance at mid-swing above the straight line between the two (m).
    fast, walk, bounding : float
        The shares of :data:`SWING_KNOTS_FAST` (:func:`fast_share`),
        :data:`SWING_KNOTS_WALK` (:func:`walk_share`) and :data:`SWING_KNOTS_BOUND`
        (:func:`bound_share`).
    """
    knots = SWING_KNOTS.copy()
    knots[:, 0] += fast * (SWING_KNOTS_FAST[:, 0] - SWING_KNOTS[:, 0]) \
        + walk * (SWING_KNOTS_WALK[:, 0] - SWING_KNOTS[:, 0]) \
        + bounding * (SWING_KNOTS_BOUND[:, 0] - SWING_KNOTS[:, 0])
    a = np.asarray(liftoff, dtype=float)
    b = np.asarray(touchdown, dtype=float)
    h = np.asarray(height, dtype=float)[..., None, None] * UP
    d = (b - a)[..., None, :]
    return a[..., None, :] + knots[:, :1] * d + knots[:, 1:] * h


def swing_position(liftoff, touchdown, height, s, fast=0.0, walk=0.0,
                   bounding=0.0) -> np.ndarray:
    """Foot position along its swing path at progress ``s`` in [0, 1], shape (..., 3).

    ``catmull_rom(swing_control_points(liftoff, touchdown, height, fast, walk,
    bounding), s)``, by the feet stage's own compiled :func:`swing_into`; ``fast``,
    ``walk`` and ``bounding`` (array-like, broadcast with the rest) are the shares
    of :data:`SWING_KNOTS_FAST`, :data:`SWING_KNOTS_WALK` and :data:`SWING_KNOTS_BOUND`.
    """
    a = np.asarray(liftoff, dtype=float)
    b = np.asarray(touchdown, dtype=float)
    h = np.asarray(height, dtype=float)
    s = np.asarray(s, dtype=float)
    shares = [np.asarray(x, dtype=float) for x in (fast, walk, bounding)]
    batch = np.broadcast_shapes(a.shape[:-1], b.shape[:-1], h.shape, s.shape,
                                *(x.shape for x in shares))

    def rows(x, tail=()):
        return np.ascontiguousarray(np.broadcast_to(x, batch + tail)).reshape((-1,) + tail)

    out = np.empty((math.prod(batch), 1, 3))
    _swing_rows(rows(a, (3,)), rows(b, (3,)), rows(h), rows(s), *(rows(x) for x in shares),
                out)
    return out.reshape(batch + (3,))


@plan_inline
def _knot(fast, walk, bounding, k):
    """Knot ``k``'s forward fraction of the step, the shares ``fast``, ``walk`` and
    ``bounding`` of the fast gaits', the walk's and the bounding gaits' knots taken."""
    return _KNOTS[k, 0] + fast * _TURN[k] + walk * _EASE[k] + bounding * _REACH[k]


@plan_inline
def swing_into(a, b, height, s, fast, walk, bounding, out, n, i):
    """The swing path from ``a`` to ``b`` (3-tuples, m) with clearance
    ``height`` (m) at progress ``s`` into ``out[n, i]`` (the knots
    :data:`SWING_KNOTS` with the shares ``fast`` of :data:`SWING_KNOTS_FAST`,
    ``walk`` of :data:`SWING_KNOTS_WALK` and ``bounding`` of
    :data:`SWING_KNOTS_BOUND`, each of the four segments a quarter of the swing)."""
    x = min(max(s, 0.0), 1.0) * 4
    j = min(math.floor(x), 3)
    t = x - j
    t2, t3 = t * t, t * t * t
    for c in range(3):
        ac = a[c]
        dc = b[c] - ac
        up = height if c == 1 else 0.0
        p0 = ac + _knot(fast, walk, bounding, j) * dc + _KNOTS[j, 1] * up
        p1 = ac + _knot(fast, walk, bounding, j + 1) * dc + _KNOTS[j + 1, 1] * up
        p2 = ac + _knot(fast, walk, bounding, j + 2) * dc + _KNOTS[j + 2, 1] * up
        p3 = ac + _knot(fast, walk, bounding, j + 3) * dc + _KNOTS[j + 3, 1] * up
        out[n, i, c] = 0.5 * ((2 * p1) + (-p0 + p2) * t + (2 * p0 - 5 * p1 + 4 * p2 - p3) * t2
                              + (-p0 + 3 * p1 - 3 * p2 + p3) * t3)


@njit(cache=True)
def _swing_rows(a, b, h, s, f, w, r, out):
    for n in range(a.shape[0]):
        swing_into((a[n, 0], a[n, 1], a[n, 2]), (b[n, 0], b[n, 1], b[n, 2]), h[n], s[n], f[n],
                   w[n], r[n], out, n, 0)


_KNOTS = np.ascontiguousarray(SWING_KNOTS, dtype=float)
_TURN = np.ascontiguousarray(SWING_KNOTS_FAST[:, 0] - SWING_KNOTS[:, 0], dtype=float)
_EASE = np.ascontiguousarray(SWING_KNOTS_WALK[:, 0] - SWING_KNOTS[:, 0], dtype=float)
_REACH = np.ascontiguousarray(SWING_KNOTS_BOUND[:, 0] - SWING_KNOTS[:, 0], dtype=float)
