"""Axes, leg order and unit helpers shared by every layer.

World frame: right-handed, +Y up, the ground is the XZ plane. A character at
rest faces +Z and its left is +X (the glTF frame). Heading is the angle about
+Y measured from +Z towards +X.
"""

from __future__ import annotations

import numpy as np

#: Index of each axis in a position ``(..., 3)``.
X, Y, Z = 0, 1, 2
UP = np.array([0.0, 1.0, 0.0])
FORWARD = np.array([0.0, 0.0, 1.0])
LEFT = np.array([1.0, 0.0, 0.0])

#: Legs in the order used by every per-leg array ``(..., 4, ...)``.
LEGS: tuple[str, ...] = ("LF", "RF", "LH", "RH")
FORE = np.array([True, True, False, False])
LEFT_SIDE = np.array([True, False, True, False])

GRAVITY = 9.81  # m/s^2

MPH = 0.44704  # m/s per mile per hour
KMH = 1.0 / 3.6  # m/s per km/h


def heading_vector(heading: np.ndarray | float) -> np.ndarray:
    """Unit forward vector on the ground for a heading.

    Parameters
    ----------
    heading : array-like, shape (...)
        Angle about +Y in radians, 0 facing +Z, positive towards +X.

    Returns
    -------
    v : ndarray, shape (..., 3)
    """
    h = np.asarray(heading, dtype=float)
    return np.stack([np.sin(h), np.zeros_like(h), np.cos(h)], axis=-1)


def wrap_angle(a: np.ndarray | float) -> np.ndarray:
    """Wrap angles to [-pi, pi)."""
    return (np.asarray(a) + np.pi) % (2.0 * np.pi) - np.pi
