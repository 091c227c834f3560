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
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

TWO_PI = 2.0 * np.pi
#: legs driving the spine oscillator (LF and LH), see module docstring; the
#: derivatives take them as the slice ``[..., ::2]``
_SPINE_DRIVERS = np.array([0, 2])


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


def amplitude_after(r, t, p: CPGParams):
    """Exact solution of ``dr/dt = a (mu - r^2) r`` after ``t`` seconds.

    ``r(t)^2 = mu / (1 + (mu / r0^2 - 1) exp(-2 a mu t))``; ``r0 = 0`` stays 0
    (the unstable fixed point), any ``r0 > 0`` tends to ``sqrt(mu)``.
    """
    r = np.asarray(r, dtype=float)
    r2 = r * r
    safe = np.where(r2 > 0, r2, 1.0)
    decay = np.exp(-2.0 * p.gain * p.mu * t)
    out = np.sqrt(p.mu / (1.0 + (p.mu / safe - 1.0) * decay))
    return np.where(r2 > 0, out, 0.0)


def _phase_derivatives(theta, r, theta_s, omega, phi, psi_s, p: CPGParams):
    # theta (..., 4), r (..., 4), theta_s (...), omega (...), phi (..., 4, 4) the
    # offsets phi_ij, psi_s (..., 2) the spine drivers' 2 pi psi_j
    diff = theta[..., None, :] - theta[..., :, None] - phi  # theta_j - theta_i - phi_ij
    dtheta = omega[..., None] + p.coupling * (r[..., None, :] * np.sin(diff)).sum(axis=-1)
    # spine follows LF and LH: locked at theta_s = theta_j + 2 pi psi_j (i.e. theta_LH)
    drv = theta[..., ::2] + psi_s
    dtheta_s = omega + p.spine_coupling * (
        r[..., ::2] * np.sin(drv - theta_s[..., None])).sum(axis=-1)
    return dtheta, dtheta_s


def cpg_step(theta, r, theta_s, r_s, omega, psi, dt, params: CPGParams = CPGParams()):
    """Advance the network by ``dt`` seconds.

    Parameters
    ----------
    theta : ndarray, shape (..., 4)
        Unwrapped leg phases (rad), leg order LF, RF, LH, RH.
    r : ndarray, shape (..., 4)
        Leg oscillator amplitudes.
    theta_s, r_s : ndarray, shape (...)
        Spine oscillator phase (rad) and amplitude.
    omega : ndarray, shape (...)
        Stride angular frequency ``2 pi f`` (rad/s).
    psi : ndarray, shape (..., 4)
        Target touchdown phases (fractions of a stride after LH's).
    dt : float
        Step (s).

    Returns
    -------
    theta, r, theta_s, r_s : ndarrays
        The advanced state (new arrays).
    """
    omega = np.asarray(omega, dtype=float)
    psi = np.asarray(psi, dtype=float)
    h = dt / params.substeps
    theta = np.asarray(theta, dtype=float)
    theta_s = np.asarray(theta_s, dtype=float)
    # constant over the step: the offsets phi_ij and the spine drivers' phases
    phi = TWO_PI * (psi[..., :, None] - psi[..., None, :])
    psi_s = TWO_PI * psi[..., _SPINE_DRIVERS]
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
