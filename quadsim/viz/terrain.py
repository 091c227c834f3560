"""The ground a recorded motion walks on, rebuilt from the heights under its feet.

A motion made on uneven ground (the data-driven horse on ramps) carries
``extras["ground"]`` (T, 4): the ground's height under each foot on every
frame. :func:`motion_ground` turns those samples into a height field the
:class:`~quadsim.viz.scene.Scene` can draw (``height(xz) -> y``), so a video
shows the ramps under the hooves instead of a flat plane far below them.

How: the root's horizontal path is a polyline (knots every
:data:`KNOT_SPACING` m); every foot sample is projected onto it, giving a
height profile along the path (the mean of the samples in each
``KNOT_SPACING`` bin, linear in between); a point anywhere takes the profile's
height at its own projection onto the path. Ramps laid across the path (as
the horse's are, started along its heading) are therefore reproduced
exactly along the path and extended sideways; the ground beyond the ends of
the path is level. Heights are evaluated on a lattice (the scene's sample
spacing) in tiles, lazily, and interpolated bilinearly between its nodes.
"""

from __future__ import annotations

import numpy as np

from quadsim.frames import X, Z

__all__ = ["KNOT_SPACING", "TrackGround", "motion_ground"]

#: Spacing (m) of the path knots and of the bins of the height profile.
KNOT_SPACING = 0.1
#: Lattice nodes along each side of a cached tile.
_TILE = 32


def _segments(path: np.ndarray):
    """Knots every :data:`KNOT_SPACING` along a path (T, 2): (knots (M, 2), arc length (M,))."""
    step = np.linalg.norm(np.diff(path, axis=0), axis=-1)
    arc = np.concatenate([[0.0], np.cumsum(step)])
    if arc[-1] < KNOT_SPACING:
        return path[:1], np.zeros(1)
    s = np.arange(0.0, arc[-1], KNOT_SPACING)
    s = np.append(s, arc[-1]) if arc[-1] - s[-1] > 1e-9 else s
    keep = np.concatenate([[True], step > 1e-12])      # arc strictly increasing for interp
    knots = np.stack([np.interp(s, arc[keep], path[keep, 0]),
                      np.interp(s, arc[keep], path[keep, 1])], axis=-1)
    return knots, s


def _project(q: np.ndarray, a: np.ndarray, d: np.ndarray, s0: np.ndarray,
             chunk: int = 2048) -> np.ndarray:
    """Arc length of the nearest point of the polyline to each point ``q`` (N, 2).

    Segments start at ``a`` (M, 2) with direction vectors ``d`` (M, 2) and
    arc lengths ``s0`` (M,) at their starts.
    """
    dd = np.maximum(np.einsum("mi,mi->m", d, d), 1e-18)
    out = np.empty(len(q))
    for k in range(0, len(q), chunk):
        p = q[k:k + chunk, None, :] - a[None]                     # (n, M, 2)
        t = np.clip(np.einsum("nmi,mi->nm", p, d) / dd, 0.0, 1.0)
        r = p - t[..., None] * d
        best = np.argmin(np.einsum("nmi,nmi->nm", r, r), axis=1)
        rows = np.arange(len(best))
        out[k:k + chunk] = s0[best] + t[rows, best] * np.sqrt(dd[best])
    return out


class TrackGround:
    """A height field rebuilt from ground heights sampled along a path.

    Parameters
    ----------
    path : array-like, shape (T, 2)
        Horizontal positions ``[x, z]`` (m) of the body along the motion.
    points : array-like, shape (N, 2)
        Where the ground was sampled ``[x, z]`` (m): the feet.
    heights : array-like, shape (N,)
        The ground's height there (m).
    cell : float
        Lattice spacing (m) of the cached heights; the scene passes its grid
        spacing over :data:`~quadsim.viz.scene.GROUND_SUB`, so its vertices
        fall on the nodes.

    Attributes
    ----------
    ramps : tuple
        Empty: the field never changes (the scene redraws a height field
        when ``len(ramps)`` changes).
    """

    ramps = ()

    def __init__(self, path, points, heights, cell: float = 0.25):
        path = np.asarray(path, dtype=float).reshape(-1, 2)
        points = np.asarray(points, dtype=float).reshape(-1, 2)
        heights = np.asarray(heights, dtype=float).reshape(-1)
        if len(points) != len(heights) or len(points) == 0:
            raise ValueError(f"`points` ({len(points)}) and `heights` ({len(heights)}) "
                             "must be as many samples, at least one")
        self.cell = float(cell)
        knots, arc = _segments(path)
        self._a, self._d, self._s0 = knots[:-1], np.diff(knots, axis=0), arc[:-1]
        self._tiles: dict[tuple[int, int], np.ndarray] = {}
        if len(self._a) == 0:                      # the body stayed in one place
            self._flat = float(np.median(heights))
            return
        self._flat = None
        s = _project(points, self._a, self._d, self._s0)
        b = np.floor(s / KNOT_SPACING).astype(np.int64)
        n = np.bincount(b)
        tot = np.bincount(b, heights)
        has = np.flatnonzero(n)
        self._bin_s = (has + 0.5) * KNOT_SPACING
        self._bin_h = tot[has] / n[has]

    def _profile(self, q: np.ndarray, a: np.ndarray, d: np.ndarray, s0: np.ndarray):
        return np.interp(_project(q, a, d, s0), self._bin_s, self._bin_h)

    def _tile(self, key: tuple[int, int]) -> np.ndarray:
        got = self._tiles.get(key)
        if got is not None:
            return got
        i = (key[0] * _TILE + np.arange(_TILE)) * self.cell
        j = (key[1] * _TILE + np.arange(_TILE)) * self.cell
        q = np.stack(np.meshgrid(i, j, indexing="ij"), axis=-1).reshape(-1, 2)
        # only segments that can hold the nearest point of some node of the tile
        centre = q.mean(axis=0)
        radius = 0.5 * np.sqrt(2.0) * (_TILE - 1) * self.cell
        t = np.clip(np.einsum("mi,mi->m", centre - self._a, self._d)
                    / np.maximum(np.einsum("mi,mi->m", self._d, self._d), 1e-18), 0.0, 1.0)
        dist = np.linalg.norm(centre - self._a - t[:, None] * self._d, axis=-1)
        near = dist <= dist.min() + 2.0 * radius + 1e-9
        h = self._profile(q, self._a[near], self._d[near], self._s0[near])
        tile = h.reshape(_TILE, _TILE)
        self._tiles[key] = tile
        return tile

    def _block(self, i0: int, i1: int, j0: int, j1: int) -> np.ndarray:
        """Node values for ``i0 <= I < i1``, ``j0 <= J < j1``, assembled from tiles."""
        out = np.empty((i1 - i0, j1 - j0))
        for ti in range(i0 // _TILE, (i1 - 1) // _TILE + 1):
            a, b = max(i0, ti * _TILE), min(i1, (ti + 1) * _TILE)
            for tj in range(j0 // _TILE, (j1 - 1) // _TILE + 1):
                c, d = max(j0, tj * _TILE), min(j1, (tj + 1) * _TILE)
                tile = self._tile((ti, tj))
                out[a - i0:b - i0, c - j0:d - j0] = tile[a - ti * _TILE:b - ti * _TILE,
                                                         c - tj * _TILE:d - tj * _TILE]
        return out

    def _nodes(self, I: np.ndarray, J: np.ndarray) -> np.ndarray:
        """Node values at integer lattice coordinates ``I``, ``J`` (same shape)."""
        if I.size == 0:
            return np.zeros(I.shape)
        i0, i1, j0, j1 = int(I.min()), int(I.max()) + 1, int(J.min()), int(J.max()) + 1
        if (i1 - i0) * (j1 - j0) <= 4 * I.size + 4 * _TILE * _TILE:
            # a compact set (the scene's window): one block covering it
            return self._block(i0, i1, j0, j1)[I - i0, J - j0]
        # scattered points: tile by tile
        key = np.floor_divide(I, _TILE) * (1 << 32) + np.floor_divide(J, _TILE)
        out = np.empty(I.shape)
        flat_k, flat_i, flat_j = key.ravel(), I.ravel(), J.ravel()
        res = out.reshape(-1)
        order = np.argsort(flat_k, kind="stable")
        ks = flat_k[order]
        starts = np.flatnonzero(np.r_[True, ks[1:] != ks[:-1]])
        for a, b in zip(starts, np.r_[starts[1:], len(ks)]):
            sel = order[a:b]
            ti, tj = int(flat_i[sel[0]] // _TILE), int(flat_j[sel[0]] // _TILE)
            res[sel] = self._tile((ti, tj))[flat_i[sel] - ti * _TILE, flat_j[sel] - tj * _TILE]
        return out

    def height(self, xz) -> np.ndarray:
        """Ground height (m) at horizontal points ``xz`` of shape (..., 2) -> (...)."""
        p = np.asarray(xz, dtype=float)
        if self._flat is not None:
            return np.full(p.shape[:-1], self._flat)
        u = p / self.cell
        # a point within 1e-6 of a node takes the node's value (the scene's vertices)
        base = np.floor(u + 1e-6)
        f = np.clip(u - base, 0.0, 1.0)
        I, J = base[..., 0].astype(np.int64), base[..., 1].astype(np.int64)
        corners = self._nodes(np.stack([I, I + 1, I, I + 1]), np.stack([J, J, J + 1, J + 1]))
        fx, fz = f[..., 0], f[..., 1]
        return (corners[0] * (1 - fx) * (1 - fz) + corners[1] * fx * (1 - fz)
                + corners[2] * (1 - fx) * fz + corners[3] * fx * fz)


def motion_ground(motion, cell: float = 0.25) -> TrackGround | None:
    """The ground under a motion, or None when it walks on the plane ``y = 0``.

    Parameters
    ----------
    motion : Motion
        Uses ``extras["ground"]`` (T, 4), the ground height (m) under each
        foot per frame, with the foot positions (``foot_joints``) and the
        root's path. A motion without it, or whose ground is level at 0
        everywhere, gives None.
    cell : float
        Lattice spacing (m) of the field, see :class:`TrackGround`.

    Raises
    ------
    ValueError
        When ``extras["ground"]`` has the wrong shape.
    """
    ground = (getattr(motion, "extras", None) or {}).get("ground")
    if ground is None or getattr(motion, "foot_joints", None) is None or len(motion) == 0:
        return None
    ground = np.asarray(ground, dtype=float)
    if ground.shape != (len(motion), 4):
        raise ValueError(f"extras['ground'] has shape {ground.shape}, expected "
                         f"({len(motion)}, 4) (the ground height under each foot, per frame)")
    if not np.any(np.abs(ground) > 1e-9):
        return None
    feet = motion.foot_positions()[..., [X, Z]]
    return TrackGround(motion.root_positions[:, [X, Z]], feet.reshape(-1, 2),
                       ground.reshape(-1), cell=cell)
