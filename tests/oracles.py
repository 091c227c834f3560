"""Pure-numpy oracles: the engine's stages written a second way, for the tests.

The engine runs compiled kernels only; these independent array forms are
what the tests hold the kernels to (to rounding, about 1e-12).
"""

from __future__ import annotations

import numpy as np

from quadsim.frames import UP
from quadsim.locomotion.cpg import TWO_PI, CPGParams
from quadsim.locomotion.footpath import SWING_KNOTS

#: the leg pairs (i, j), i < j, of the coupling terms
_PAIR_I = np.array([0, 0, 0, 1, 1, 2])
_PAIR_J = np.array([1, 2, 3, 2, 3, 3])


def amplitude_after(r, t, p: CPGParams):
    """Exact solution of ``dr/dt = a (mu - r^2) r`` after ``t`` seconds."""
    r = np.asarray(r, dtype=float)
    r2 = r * r
    safe = np.where(r2 > 0, r2, 1.0)
    decay = np.exp(-2.0 * p.gain * p.mu * t)
    out = np.sqrt(p.mu / (1.0 + (p.mu / safe - 1.0) * decay))
    return np.where(r2 > 0, out, 0.0)


def _phase_derivatives(theta, r, theta_s, omega, phi, psi_s, p: CPGParams):
    sn = np.sin(theta[..., _PAIR_J] - theta[..., _PAIR_I] - phi)
    s01, s02, s03, s12, s13, s23 = np.moveaxis(sn, -1, 0)
    r0, r1, r2, r3 = np.moveaxis(r, -1, 0)
    w = p.coupling
    dtheta = np.stack([omega + w * (r1 * s01 + r2 * s02 + r3 * s03),
                       omega + w * (r0 * -s01 + r2 * s12 + r3 * s13),
                       omega + w * (r0 * -s02 + r1 * -s12 + r3 * s23),
                       omega + w * (r0 * -s03 + r1 * -s13 + r2 * -s23)], axis=-1)
    dtheta_s = omega + p.spine_coupling * (r0 * np.sin(theta[..., 0] + psi_s[..., 0] - theta_s)
                                           + r2 * np.sin(theta[..., 2] + psi_s[..., 1] - theta_s))
    return dtheta, dtheta_s


def cpg_step(theta, r, theta_s, r_s, omega, psi, dt, params: CPGParams | None = None):
    """The polar Hopf network's step: exact amplitudes, RK4 phases."""
    params = params or CPGParams()
    omega = np.asarray(omega, dtype=float)
    psi = np.asarray(psi, dtype=float)
    h = dt / params.substeps
    theta = np.asarray(theta, dtype=float)
    theta_s = np.asarray(theta_s, dtype=float)
    phi = TWO_PI * (psi[..., _PAIR_I] - psi[..., _PAIR_J])
    psi_s = TWO_PI * psi[..., [0, 2]]
    for _ in range(params.substeps):
        r_mid = amplitude_after(r, 0.5 * h, params)
        r_end = amplitude_after(r, h, params)
        k1 = _phase_derivatives(theta, r, theta_s, omega, phi, psi_s, params)
        k2 = _phase_derivatives(theta + 0.5 * h * k1[0], r_mid, theta_s + 0.5 * h * k1[1],
                                omega, phi, psi_s, params)
        k3 = _phase_derivatives(theta + 0.5 * h * k2[0], r_mid, theta_s + 0.5 * h * k2[1],
                                omega, phi, psi_s, params)
        k4 = _phase_derivatives(theta + h * k3[0], r_end, theta_s + h * k3[1],
                                omega, phi, psi_s, params)
        theta = theta + (h / 6.0) * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0])
        theta_s = theta_s + (h / 6.0) * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1])
        r = r_end
        r_s = amplitude_after(r_s, h, params)
    return theta, r, theta_s, r_s


def swing_position(liftoff, touchdown, height, s):
    """The swing path at progress ``s``: the Catmull-Rom segment of the knots."""
    a = np.asarray(liftoff, dtype=float)
    b = np.asarray(touchdown, dtype=float)
    h = np.asarray(height, dtype=float)
    s = np.asarray(s, dtype=float)
    batch = np.broadcast_shapes(a.shape[:-1], b.shape[:-1], h.shape, s.shape)
    s = np.broadcast_to(np.clip(s, 0.0, 1.0), batch)
    nseg = len(SWING_KNOTS) - 3
    x = s * nseg
    i = np.minimum(np.floor(x).astype(int), nseg - 1)
    knots = SWING_KNOTS[i[..., None] + np.arange(4)]
    P = (a[..., None, :] + knots[..., :1] * (b - a)[..., None, :]
         + knots[..., 1:] * (h[..., None, None] * UP))
    p0, p1, p2, p3 = (P[..., k, :] for k in range(4))
    t = (x - i)[..., None]
    return 0.5 * ((2 * p1) + (-p0 + p2) * t + (2 * p0 - 5 * p1 + 4 * p2 - p3) * t * t
                  + (-p0 + 3 * p1 - 3 * p2 + p3) * t * t * t)


def arc_advance(position, heading, speed, yaw_rate, tau):
    """Position and heading after ``tau`` s on the arc, by the chord
    ``v tau sinc(dh / 2)`` along the mean heading (no switch to a line)."""
    p = np.asarray(position, dtype=float)
    h = np.asarray(heading, dtype=float)
    dh = np.asarray(yaw_rate, dtype=float) * tau
    chord = np.asarray(speed, dtype=float) * tau * np.sinc(dh / (2 * np.pi))
    mid = h + 0.5 * dh
    return p + np.stack([chord * np.sin(mid), 0 * chord, chord * np.cos(mid)], -1), h + dh
