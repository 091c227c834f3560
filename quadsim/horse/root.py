"""Foot phase and the root trajectory from the landing feet (the seed's section 6).

The clips carry no usable root translation of their own (the seed's
Muybridge clips ran on the spot), so the root is moved by the feet: on each
frame the root advances by the mean backward slip of the feet on the ground,

    p(i) = p(i - 1) + (1/N) sum_j d_j                         (equation 11)

where ``d_j`` is how far foot j moved backwards relative to the body since
the previous frame; with no foot on the ground (a flight phase) the root keeps
its last horizontal velocity, a ballistic flight.

Foot phase: a foot is in *stance* while its leg's generic time lies inside
one of the clip's measured contacts, *striking* on the first frame of a
contact (the labelled touchdown) and in *flight* otherwise. (The seed
thresholds the pastern angle of Muybridge's horses; the baked clips hold the
pastern at a constant angle through stance, so their measured contacts are
used instead.)
"""

from __future__ import annotations

import weakref

import numpy as np

from ..skeleton.motion import Motion
from .database import Clip, cycle_stance
from .place_kernel import contact_rows, pack_contacts

STANCE, STRIKING, FLIGHT = 0, 1, 2

#: Each clip's contacts in cycles, measured once per clip object (clips are immutable).
_STANCE: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def clip_stance_cycles(clip: Clip) -> list[np.ndarray]:
    """Each foot's contacts in generic time (cycles), list of 4 arrays (n_i, 2).

    Measured from the clip's foot positions (:func:`~quadsim.horse.database.cycle_stance`)
    on the first call for a clip and remembered for it; the arrays are read-only.
    """
    hit = _STANCE.get(clip)
    if hit is None:
        hit = [s / clip.frames for s in cycle_stance(clip.motion, clip.speed)]
        for s in hit:
            s.flags.writeable = False
        _STANCE[clip] = hit
    return list(hit)


def in_stance(stance_cycles: list[np.ndarray], t: np.ndarray) -> np.ndarray:
    """Whether each leg is on the ground at generic times ``t`` (T, 4) -> (T, 4) bool.

    A leg is down while ``t`` (cycles, looped) lies in one of its contacts
    ``stance_cycles[leg]`` (n, 2) ``[on, off]`` in cycles (compiled:
    :func:`~quadsim.horse.place_kernel.contact_rows`, the controller's contact test).
    """
    t = np.ascontiguousarray(t, dtype=float)
    on_off, count = pack_contacts(stance_cycles)
    out = np.empty(t.shape, dtype=bool)
    contact_rows(on_off, count, t.reshape(-1, 4), out.reshape(-1, 4))
    return out


def foot_phase(stance: np.ndarray) -> np.ndarray:
    """STANCE, STRIKING (first stance frame) or FLIGHT per frame and foot, (T, 4) int."""
    stance = np.asarray(stance, dtype=bool)
    ph = np.where(stance, STANCE, FLIGHT)
    strike = stance & ~np.concatenate([np.zeros((1, 4), dtype=bool), stance[:-1]])
    ph[strike] = STRIKING
    return ph


def root_from_feet(motion: Motion, stance: np.ndarray, v0: float) -> np.ndarray:
    """Root positions (T, 3) moved by the landing feet (equation 11).

    Parameters
    ----------
    motion : Motion
        Its root's horizontal position is ignored; its height is kept.
    stance : ndarray of bool, shape (T, 4)
    v0 : float
        Forward speed (m/s) before the first frame, used until a foot lands.
    """
    T = len(motion)
    feet = motion.foot_positions()
    rel = feet - motion.root_positions[:, None, :]
    slip = -(rel[1:] - rel[:-1])                    # (T-1, 4, 3)
    both = stance[1:] & stance[:-1]
    n = both.sum(axis=1)
    mean = np.where(n[:, None] > 0,
                    np.sum(np.where(both[..., None], slip, 0.0), axis=1) / np.maximum(n, 1)[:, None],
                    np.nan)
    step = np.zeros((T - 1, 3))
    last = np.array([0.0, 0.0, v0 / motion.fps])
    for i in range(T - 1):                          # flight carries the last velocity
        if n[i] > 0:
            last = np.array([mean[i, 0], 0.0, mean[i, 2]])
        step[i] = last
    root = np.zeros((T, 3))
    root[1:] = np.cumsum(step, axis=0)
    root[:, 1] = motion.root_positions[:, 1]
    return root


__all__ = ["FLIGHT", "STANCE", "STRIKING", "clip_stance_cycles", "foot_phase", "in_stance",
           "root_from_feet"]
