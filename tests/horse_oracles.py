"""Pure-numpy oracles of the horse engine's compiled stages, for the tests only.

Each is the formula written a second way, with whole-array numpy operations,
so the compiled kernel that runs can be checked against it.
"""

import numpy as np

from quadsim.kinematics.rotations import matrices_from_axis_angles

LATERAL = np.array([1.0, 0.0, 0.0])


def two_bone_reference(A: np.ndarray, B: np.ndarray, F: np.ndarray, W_parent: np.ndarray,
             W_top: np.ndarray, W_mid: np.ndarray, targets: np.ndarray
             ) -> tuple[np.ndarray, np.ndarray]:
    """The two-bone IK written with numpy array operations (the compiled
    :func:`quadsim.kinematics.chains.two_bone_row` is checked against it).

    The middle joint bends about the pair's plane normal until the top-to-foot
    distance is the top-to-target distance (clamped to what the bones
    reach), then the top joint swings the whole pair onto the target. The
    bones below the middle joint keep their local angles. Every array has the
    same leading axes (frames, legs, or both), so one call moves any batch.

    Parameters
    ----------
    A, B, F : ndarray, shape (..., 3)
        World positions of the top joint, the middle joint and the foot (m).
    W_parent : ndarray, shape (..., 3, 3)
        World rotation of the top joint's parent.
    W_top, W_mid : ndarray, shape (..., 3, 3)
        World rotations of the top and middle joints.
    targets : ndarray, shape (..., 3)
        Wanted foot positions (m); unreachable ones are approached as far as the pair allows.

    Returns
    -------
    L_top, L_mid : ndarray, shape (..., 3, 3)
        New local rotations of the top and middle joints.

    Notes
    -----
    The pair bends about the normal of the top-middle-foot plane, on the side
    the pose bends to. A pose passing through straight (a fore leg reaching
    forward in its swing) flips that side: where the target then asks for
    another bend than the pose's, the result jumps by twice the change of bend,
    so callers keep such targets at the pose's own distance.
    """
    u, w = A - B, F - B
    l1 = np.linalg.norm(u, axis=-1)
    l2 = np.linalg.norm(w, axis=-1)
    d = np.clip(np.linalg.norm(targets - A, axis=-1), np.abs(l1 - l2) + 1e-6, l1 + l2 - 1e-6)
    n = np.cross(u, w)
    nn = np.linalg.norm(n, axis=-1, keepdims=True)
    n = np.where(nn > 1e-9, n / np.maximum(nn, 1e-12), LATERAL)
    beta0 = np.arccos(np.clip(np.sum(u * w, -1) / (l1 * l2), -1.0, 1.0))
    beta1 = np.arccos(np.clip((l1 ** 2 + l2 ** 2 - d ** 2) / (2 * l1 * l2), -1.0, 1.0))
    Rm = matrices_from_axis_angles(n, beta1 - beta0)
    a = np.einsum("...ij,...j->...i", Rm, w) + B - A
    b = targets - A
    a = a / np.linalg.norm(a, axis=-1, keepdims=True)
    b = b / np.maximum(np.linalg.norm(b, axis=-1, keepdims=True), 1e-12)
    ax = np.cross(a, b)
    s = np.linalg.norm(ax, axis=-1)
    ang = np.arctan2(s, np.sum(a * b, -1))
    ax = np.where(s[..., None] > 1e-12, ax / np.maximum(s, 1e-12)[..., None], n)
    Rs = matrices_from_axis_angles(ax, ang)
    Wtop = Rs @ W_top
    Wmid = Rs @ Rm @ W_mid
    return np.swapaxes(W_parent, -1, -2) @ Wtop, np.swapaxes(Wtop, -1, -2) @ Wmid


def ramp_height_reference(table: np.ndarray, xz: np.ndarray) -> np.ndarray:
    """Ground height (...) at points ``xz`` (..., 2) of a ramp table (R, 6): origin x, z,
    height, direction x, z, ``tan(slope)``; the newest ramp holding a point wins."""
    p = np.asarray(xz, dtype=float)
    out = np.zeros(p.shape[:-1])
    for ox, oz, h, ux, uz, grade in np.asarray(table).reshape(-1, 6):
        s = (p[..., 0] - ox) * ux + (p[..., 1] - oz) * uz
        out = np.where(s >= 0.0, h + grade * s, out)
    return out


def slerp_reference(q0: np.ndarray, q1: np.ndarray, a: np.ndarray) -> np.ndarray:
    """Shortest-path slerp of quaternions (..., 4) at ``a`` (...), by the sine formula."""
    d = np.sum(q0 * q1, axis=-1)
    q1 = np.where(d[..., None] < 0, -q1, q1)
    theta = np.arccos(np.clip(np.abs(d), 0.0, 1.0))
    s = np.sin(theta)
    small = s < 1e-6
    safe = np.where(small, 1.0, s)
    w0 = np.where(small, 1.0 - a, np.sin((1.0 - a) * theta) / safe)
    w1 = np.where(small, a, np.sin(a * theta) / safe)
    q = w0[..., None] * q0 + w1[..., None] * q1
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def sample_reference(motion, frames):
    """Root (n, 3) and rotations (n, J, 4) of ``motion`` at fractional frames (n,)."""
    f = np.clip(np.asarray(frames, dtype=float), 0, len(motion) - 1)
    i0 = np.floor(f).astype(int)
    i1 = np.minimum(i0 + 1, len(motion) - 1)
    a = f - i0
    R = motion.root_positions
    root = R[i0] * (1 - a[:, None]) + R[i1] * a[:, None]
    J = motion.rotations.shape[1]
    rot = slerp_reference(motion.rotations[i0], motion.rotations[i1],
                          np.broadcast_to(a[:, None], (len(f), J)))
    return root, rot


def in_stance_reference(stance_cycles, t: np.ndarray) -> np.ndarray:
    """Whether each leg (T, 4) is in one of its contacts ``[on, off]`` (cycles) at ``t``."""
    t = np.asarray(t, dtype=float)
    out = np.zeros(t.shape, dtype=bool)
    for j, s in enumerate(stance_cycles):
        x = t[:, j] % 1.0
        for on, off in s:
            out[:, j] |= ((x - on) % 1.0) <= (off - on) + 1e-9
    return out
