"""Central pattern generator: coupled Hopf oscillators in polar form.

One oscillator per leg (at the shoulder or hip) and one at mid-spine. Each
has an amplitude ``r`` that converges to ``sqrt(mu)`` and a phase ``theta``
advanced by a shared clock ``omega`` plus diffusive coupling towards the
gait's phase offsets (DESIGN.md, "polar form with a uniform clock"):

``dr_i/dt = a (mu - r_i^2) r_i``

``dtheta_i/dt = omega + w sum_j r_j sin(theta_j - theta_i - phi_ij)``,
``phi_ij = 2 pi (psi_i - psi_j)``

where ``psi`` are the footfall table's touchdown phases. At the locked state
``theta_i = theta_LH - 2 pi psi_i``: a leg touches down when its phase
crosses a multiple of ``2 pi`` and is in stance while the stride fraction
``u_i = frac(theta_i / 2 pi)`` is below the duty factor. The spine
oscillator is driven one way by the two left legs, so it follows the legs
and never perturbs them.

The state arrays may carry any leading batch shape (many characters).
The amplitude equation has a closed-form solution, used exactly (so any
starting amplitude converges, however stiff the gain); the phases are
integrated by fixed-step RK4 with sub-steps.

:func:`cpg_step_rows` is the step, compiled (numba), looping over rows of
networks; the controllers step with it -- one row for a lone character, N
for :class:`~quadsim.locomotion.batch.BatchController` -- and
:func:`cpg_step` is its face for arrays of any batch shape.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from quadsim.locomotion.rowmath import plan_inner

TWO_PI = 2.0 * np.pi


@dataclass(frozen=True)
class CPGParams:
    """Constants of the oscillator network.

    Attributes
    ----------
    mu : float
        Squared limit-cycle amplitude.
    gain : float
        Amplitude convergence rate ``a`` (1/s).
    coupling : float
        Leg-to-leg phase coupling ``w`` (rad/s).
    spine_coupling : float
        Leg-to-spine coupling (rad/s), one way.
    substeps : int
        RK4 sub-steps per call of :func:`cpg_step`.
    """

    mu: float = 1.0
    gain: float = 8.0
    coupling: float = 4.0
    spine_coupling: float = 6.0
    substeps: int = 2


def cpg_step(theta, r, theta_s, r_s, omega, psi, dt, params: CPGParams = CPGParams()):
    """Advance the network by ``dt`` seconds (:func:`cpg_step_rows` on any batch shape).

    Parameters
    ----------
    theta : array-like, shape (..., 4)
        Unwrapped leg phases (rad), leg order LF, RF, LH, RH.
    r : array-like, shape (..., 4)
        Leg oscillator amplitudes.
    theta_s, r_s : array-like, shape (...)
        Spine oscillator phase (rad) and amplitude.
    omega : array-like, shape (...)
        Stride angular frequency ``2 pi f`` (rad/s).
    psi : array-like, shape (..., 4)
        Target touchdown phases (fractions of a stride after LH's).
    dt : float
        Step (s).

    Returns
    -------
    theta, r, theta_s, r_s : ndarrays
        The advanced state (new arrays).
    """
    theta = np.asarray(theta, dtype=float)
    r = np.asarray(r, dtype=float)
    psi = np.asarray(psi, dtype=float)
    batch = np.broadcast_shapes(theta.shape[:-1], r.shape[:-1], np.shape(theta_s),
                                np.shape(r_s), np.shape(omega), psi.shape[:-1])

    def rows(x, tail=()):
        return np.ascontiguousarray(np.broadcast_to(x, batch + tail), dtype=float).reshape(
            (-1,) + tail)

    th, rr, ts, rs = cpg_step_rows(rows(theta, (4,)), rows(r, (4,)), rows(theta_s), rows(r_s),
                                   rows(omega), rows(psi, (4,)), float(dt), params.mu,
                                   params.gain, params.coupling, params.spine_coupling,
                                   int(params.substeps))
    return (th.reshape(batch + (4,)), rr.reshape(batch + (4,)), ts.reshape(batch),
            rs.reshape(batch))


@plan_inner
def _rates(t, r, omega, w, ws, p):
    """The phase derivatives of one network: legs then spine (5 floats).
    ``t`` (t0, t1, t2, t3, spine) phases, ``r`` (r0..r3) amplitudes,
    ``w`` and ``ws`` the leg and spine couplings, ``p`` the offsets
    (p01, p02, p03, p12, p13, p23) of the pairs ``i < j`` and the spine
    drivers' phases (q0, q2)."""
    t0, t1, t2, t3, ts = t
    r0, r1, r2, r3 = r
    p01, p02, p03, p12, p13, p23, q0, q2 = p
    # phi is antisymmetric and sin odd, so the (j, i) term is minus the (i, j)
    # one: six sines per network, not sixteen (the diagonal's sin(0) adds nothing)
    s01 = math.sin(t1 - t0 - p01)
    s02 = math.sin(t2 - t0 - p02)
    s03 = math.sin(t3 - t0 - p03)
    s12 = math.sin(t2 - t1 - p12)
    s13 = math.sin(t3 - t1 - p13)
    s23 = math.sin(t3 - t2 - p23)
    # the spine follows LF and LH: locked at theta_s = theta_j + 2 pi psi_j (theta_LH)
    return (omega + w * (r1 * s01 + r2 * s02 + r3 * s03),
            omega + w * (r0 * -s01 + r2 * s12 + r3 * s13),
            omega + w * (r0 * -s02 + r1 * -s12 + r3 * s23),
            omega + w * (r0 * -s03 + r1 * -s13 + r2 * -s23),
            omega + ws * (r0 * math.sin(t0 + q0 - ts) + r2 * math.sin(t2 + q2 - ts)))


@plan_inner
def _amplitude(x, mu, decay):
    """The exact solution of ``dr/dt = a (mu - r^2) r`` for one amplitude:
    ``r(t)^2 = mu / (1 + (mu / r0^2 - 1) decay)`` with ``decay =
    exp(-2 a mu t)``; ``r0 = 0`` stays 0 (the unstable fixed point), any
    ``r0 > 0`` tends to ``sqrt(mu)``."""
    x2 = x * x
    return math.sqrt(mu / (1.0 + (mu / x2 - 1.0) * decay)) if x2 > 0 else 0.0


@njit(cache=True)
def cpg_step_rows(theta, r, theta_s, r_s, omega, psi, dt, mu, gain, coupling,
                  spine_coupling, substeps):
    """One step of ``N`` oscillator networks (:func:`cpg_step_into` on copies).

    Parameters
    ----------
    theta, r : ndarray, shape (N, 4)
        Unwrapped leg phases (rad) and leg amplitudes, legs LF, RF, LH, RH.
    theta_s, r_s : ndarray, shape (N,)
        Spine oscillator phase (rad) and amplitude.
    omega : ndarray, shape (N,)
        Stride angular frequency (rad/s).
    psi : ndarray, shape (N, 4)
        Target touchdown phases (fractions of a stride after LH's).
    dt : float
        Step (s).
    mu, gain, coupling, spine_coupling : float
    substeps : int
        The :class:`CPGParams`.

    Returns
    -------
    theta, r : ndarray, shape (N, 4)
    theta_s, r_s : ndarray, shape (N,)
        The advanced state (new arrays).
    """
    th, rr, ts, rs = theta.copy(), r.copy(), theta_s.copy(), r_s.copy()
    cpg_step_into(th, rr, ts, rs, omega, psi, dt, mu, gain, coupling, spine_coupling, substeps)
    return th, rr, ts, rs


@plan_inner
def cpg_step_into(theta, r, theta_s, r_s, omega, psi, dt, mu, gain, coupling,
                  spine_coupling, substeps):
    """:func:`cpg_step_rows` in place: ``theta``, ``r`` (N, 4), ``theta_s``
    and ``r_s`` (N,) advance by ``dt`` (s); the plan's CPG stage."""
    N = theta.shape[0]
    h = dt / substeps
    hh = 0.5 * h
    h6 = h / 6.0
    decay_mid = math.exp(-2.0 * gain * mu * (0.5 * h))
    decay_end = math.exp(-2.0 * gain * mu * h)
    for n in range(N):
        # the offsets phi_ij of the pairs i < j and the spine drivers' phases
        p01 = TWO_PI * (psi[n, 0] - psi[n, 1])
        p02 = TWO_PI * (psi[n, 0] - psi[n, 2])
        p03 = TWO_PI * (psi[n, 0] - psi[n, 3])
        p12 = TWO_PI * (psi[n, 1] - psi[n, 2])
        p13 = TWO_PI * (psi[n, 1] - psi[n, 3])
        p23 = TWO_PI * (psi[n, 2] - psi[n, 3])
        q0 = TWO_PI * psi[n, 0]
        q2 = TWO_PI * psi[n, 2]
        om = omega[n]
        t0, t1, t2, t3 = theta[n, 0], theta[n, 1], theta[n, 2], theta[n, 3]
        r0, r1, r2, r3 = r[n, 0], r[n, 1], r[n, 2], r[n, 3]
        ts = theta_s[n]
        rs = r_s[n]
        for _ in range(substeps):
            m0, m1 = _amplitude(r0, mu, decay_mid), _amplitude(r1, mu, decay_mid)
            m2, m3 = _amplitude(r2, mu, decay_mid), _amplitude(r3, mu, decay_mid)
            e0, e1 = _amplitude(r0, mu, decay_end), _amplitude(r1, mu, decay_end)
            e2, e3 = _amplitude(r2, mu, decay_end), _amplitude(r3, mu, decay_end)
            p = (p01, p02, p03, p12, p13, p23, q0, q2)
            rm = (m0, m1, m2, m3)
            a = _rates((t0, t1, t2, t3, ts), (r0, r1, r2, r3), om, coupling, spine_coupling, p)
            b = _rates((t0 + hh * a[0], t1 + hh * a[1], t2 + hh * a[2], t3 + hh * a[3],
                        ts + hh * a[4]), rm, om, coupling, spine_coupling, p)
            c = _rates((t0 + hh * b[0], t1 + hh * b[1], t2 + hh * b[2], t3 + hh * b[3],
                        ts + hh * b[4]), rm, om, coupling, spine_coupling, p)
            d = _rates((t0 + h * c[0], t1 + h * c[1], t2 + h * c[2], t3 + h * c[3],
                        ts + h * c[4]), (e0, e1, e2, e3), om, coupling, spine_coupling, p)
            t0 = t0 + h6 * (a[0] + 2 * b[0] + 2 * c[0] + d[0])
            t1 = t1 + h6 * (a[1] + 2 * b[1] + 2 * c[1] + d[1])
            t2 = t2 + h6 * (a[2] + 2 * b[2] + 2 * c[2] + d[2])
            t3 = t3 + h6 * (a[3] + 2 * b[3] + 2 * c[3] + d[3])
            ts = ts + h6 * (a[4] + 2 * b[4] + 2 * c[4] + d[4])
            r0, r1, r2, r3 = e0, e1, e2, e3
            rs = _amplitude(rs, mu, decay_end)
        theta[n, 0], theta[n, 1], theta[n, 2], theta[n, 3] = t0, t1, t2, t3
        r[n, 0], r[n, 1], r[n, 2], r[n, 3] = r0, r1, r2, r3
        theta_s[n] = ts
        r_s[n] = rs


def stride_fraction(theta):
    """``u = frac(theta / 2 pi)`` in [0, 1): 0 at touchdown."""
    return np.mod(np.asarray(theta) / TWO_PI, 1.0)


def locked_phases(theta):
    """Phase of each leg relative to LH's as a touchdown fraction in [0, 1).

    At the locked state this equals the gait's ``psi``.
    """
    theta = np.asarray(theta)
    return np.mod((theta[..., 2:3] - theta) / TWO_PI, 1.0)


def oscillator_outputs(theta, r):
    """The seed's ``(x, z) = r (sin theta, cos theta)`` per oscillator.

    ``z >= 0`` is the seed's stance half-cycle for a duty factor of 0.5.
    """
    theta = np.asarray(theta)
    r = np.asarray(r)
    return r * np.sin(theta), r * np.cos(theta)
