"""Sloped ground for the data-driven horse: a height field built as the horse goes.

The seed climbs and descends slopes by pitching the body the way turning
yaws it. Here the ground is a height field ``y = h(x, z)`` made of planar
*ramps*: each ramp starts on a straight boundary line across the horse's
path, rises with a constant gradient ``tan(slope)`` along a horizontal
direction ``u`` (the heading when the slope was asked for), and covers the
half-plane ahead of its boundary. Later ramps override earlier ones where
they apply; the ground before the first ramp is the plane ``y = 0``.

A ramp starts at the height the ground already has at its origin, so the
ground is continuous along the path (it may have a crease there, as a real
foot of a hill has).
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import InputError
from .ground_kernel import ground_heights

#: Steepest slope allowed (rad): the legs of a pitched horse reach about 20 degrees.
MAX_SLOPE = math.radians(20.0)


class Ground:
    """A height field of planar ramps.

    Attributes
    ----------
    ramps : list of tuple
        ``(origin (2,) [x, z] m, height m, direction (2,) unit [x, z], slope rad)``,
        oldest first.
    table : ndarray, shape (R, 6)
        The ramps packed for the compiled placement
        (:func:`quadsim.horse.place_kernel.ground_height`): origin x, z,
        height, direction x, z and ``tan(slope)``, one row per ramp.
    """

    def __init__(self) -> None:
        self.ramps: list[tuple[np.ndarray, float, np.ndarray, float]] = []
        self.table = np.zeros((0, 6))

    @property
    def slope(self) -> float:
        """The slope of the newest ramp (rad), 0 on flat ground."""
        return self.ramps[-1][3] if self.ramps else 0.0

    def add_ramp(self, origin_xz, heading: float, slope: float) -> None:
        """Start a ramp at ``origin_xz`` (m), rising by ``slope`` (rad) along ``heading`` (rad).

        Raises
        ------
        InputError
            When ``|slope|`` exceeds :data:`MAX_SLOPE`.
        """
        if not (math.isfinite(slope) and abs(slope) <= MAX_SLOPE + 1e-12):
            raise InputError(f"command slope = {math.degrees(slope):.3g} deg is out of range; "
                             f"allowed -{math.degrees(MAX_SLOPE):g} to "
                             f"{math.degrees(MAX_SLOPE):g} deg (slope_deg)")
        o = np.asarray(origin_xz, dtype=float).reshape(2)
        h = float(self.height(o[None])[0])
        u = np.array([math.sin(heading), math.cos(heading)])
        self.ramps.append((o, h, u, float(slope)))
        self.table = np.vstack([self.table, [o[0], o[1], h, u[0], u[1], math.tan(slope)]])

    def height(self, xz) -> np.ndarray:
        """Ground height (m) at horizontal points ``xz`` of shape (..., 2) -> (...): the
        newest ramp whose half-plane holds a point, else 0 (compiled:
        :func:`~quadsim.horse.place_kernel.ground_height`, as the placement reads it)."""
        p = np.asarray(xz, dtype=float)
        flat = np.ascontiguousarray(p.reshape(-1, 2))
        out = np.empty(len(flat))
        ground_heights(self.table, flat, out)
        return out.reshape(p.shape[:-1])


__all__ = ["Ground", "MAX_SLOPE"]
