"""Foot contacts of many clips at once: :mod:`quadsim.skeleton.contacts` over a batch.

A sweep measures dozens of clips of one character, length and frame rate
together. :func:`foot_contacts` here gives each clip exactly what
:func:`quadsim.skeleton.contacts.foot_contacts` gives it alone, and
:func:`events` exactly the touchdowns and lift-offs the reports find
(``contacts._events``), with one pass of array operations for the whole
batch instead of one per clip. It lays every clip's four legs end to end,
each followed by a frame out of contact -- as the single-clip code already
lays out one clip's legs -- so no run of contact crosses from one leg or
clip to the next, and each clip's thresholds are carried to its own legs.
Every number comes from the same operations on the same values (medians
are picked, not averaged), so the results are the same to the last bit
(tests hold it).

Arrays: clips lead, then frames, then legs LF, RF, LH, RH; positions in
metres with +Y up.
"""

from __future__ import annotations

import numpy as np

from quadsim.frames import X, Y, Z
from quadsim.skeleton.contacts import (
    MIN_FRAMES,
    _debounce_legs,
    _planted,
    _ranges_mask,
    _refine,
    _runs,
    _split_at,
    _tolerance,
    default_contact_thresholds,
)

__all__ = ["default_thresholds", "events", "foot_contacts", "laid_out_as", "per_foot", "runs",
           "slides"]


def _check(feet) -> np.ndarray:
    f = np.asarray(feet, dtype=float)
    if f.ndim != 4 or f.shape[2:] != (4, 3) or f.shape[1] == 0:
        raise ValueError(f"`feet` has shape {f.shape}, expected (N, T, 4, 3) with T >= 1")
    return f


def default_thresholds(feet) -> tuple[np.ndarray, np.ndarray]:
    """:func:`~quadsim.skeleton.contacts.default_contact_thresholds` of each clip.

    Parameters
    ----------
    feet : array-like, shape (N, T, 4, 3)

    Returns
    -------
    heights, speeds : ndarray, shape (N,)
        Metres above the ground; horizontal speeds (m/s).
    """
    f = _check(feet)
    pairs = [default_contact_thresholds(x) for x in f]
    return np.array([p[0] for p in pairs]), np.array([p[1] for p in pairs])


def _legs_end_to_end(values: np.ndarray, fill) -> np.ndarray:
    """(N, T, 4, ...) per-frame values as one flat array of N * 4 legs of T + 1 frames,
    each leg followed by one frame of ``fill``: shape (N * 4 * (T + 1), ...)."""
    N, T = values.shape[:2]
    rest = values.shape[3:]
    flat = np.full((N, 4, T + 1) + rest, fill, dtype=values.dtype)
    flat[:, :, :T] = np.moveaxis(values, 2, 1)
    return flat.reshape((-1,) + rest)


def runs(contacts) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Every contact of every clip's feet, laid end to end (see the module notes).

    Parameters
    ----------
    contacts : array-like of bool, shape (N, T, 4)

    Returns
    -------
    flat : ndarray of bool, shape (N * 4 * (T + 1),)
        The contacts, leg after leg, each leg followed by a frame out of contact.
    s, e : ndarray of int, shape (n,)
        Each contact's first and (exclusive) last frame in ``flat``, in order.
    leg : ndarray of int, shape (n,)
        Each contact's clip and foot, ``4 * clip + foot``.
    """
    c = np.asarray(contacts, dtype=bool)
    flat = _legs_end_to_end(c, False)
    s, e = _runs(flat)
    return flat, s, e, s // (c.shape[1] + 1)


def slides(points, contacts, found=None) -> np.ndarray:
    """How far a point of each foot slides during each of its contacts (m).

    The figure of :func:`quadsim.analysis.report.foot_slide` (and of the toe
    tips' slide in :mod:`quadsim.analysis.appearance`): the largest horizontal
    distance of the point from where it was on the contact's first frame,
    over the contact's frames -- here of every contact of every clip at once.

    Parameters
    ----------
    points : array-like, shape (N, T, 4, 3)
        The points of the four feet (m).
    contacts : array-like of bool, shape (N, T, 4)
    found : tuple, optional
        :func:`runs` of ``contacts`` when already found.

    Returns
    -------
    ndarray, shape (n,)
        One per contact, in the order of :func:`runs`.
    """
    flat, s, _, _ = runs(contacts) if found is None else found
    if not len(s):
        return np.zeros(0)
    p = _legs_end_to_end(np.asarray(points, dtype=float), 0.0)
    start = s[np.maximum(np.searchsorted(s, np.arange(len(flat)), side="right") - 1, 0)]
    d = np.linalg.norm((p - p[start])[:, [X, Z]], axis=-1)
    return np.maximum.reduceat(np.where(flat, d, 0.0), s)


def per_foot(values: np.ndarray, leg: np.ndarray, n_clips: int) -> list[list[np.ndarray]]:
    """Per-contact ``values`` in the order of :func:`runs`, split per clip and foot."""
    cuts = np.searchsorted(leg, np.arange(1, 4 * n_clips))
    feet = _split_at(np.asarray(values), cuts)
    return [feet[4 * i:4 * i + 4] for i in range(n_clips)]


def foot_contacts(feet, fps: float, heights, speeds, *,
                  min_frames: int = MIN_FRAMES) -> np.ndarray:
    """Which feet of each clip touch the ground on each frame.

    Parameters
    ----------
    feet : array-like, shape (N, T, 4, 3)
        World positions of the foot contact joints (m), legs LF, RF, LH, RH,
        ground at ``y = 0``.
    fps : float
        Frames per second.
    heights, speeds : array-like, shape (N,)
        Each clip's thresholds (m, m/s), as
        :func:`~quadsim.skeleton.contacts.foot_contacts` takes them; each clip's
        on-ground tolerance is the default that goes with its height.
    min_frames : int
        As :func:`~quadsim.skeleton.contacts.foot_contacts`.

    Returns
    -------
    contacts : ndarray of bool, shape (N, T, 4)
        ``contacts[i]`` is ``foot_contacts(feet[i], fps, height=heights[i],
        speed=speeds[i], min_frames=min_frames)``.
    """
    f = _check(feet)
    N, T = f.shape[:2]
    fps = float(fps)
    heights = np.asarray(heights, dtype=float).reshape(N)
    speeds = np.asarray(speeds, dtype=float).reshape(N)
    if int(min_frames) < 1:
        raise ValueError(f"`min_frames` must be at least 1, got {min_frames!r}")
    low = f[..., Y] <= heights[:, None, None]
    step = np.linalg.norm(np.diff(f[..., [X, Z]], axis=1), axis=-1) * fps  # (N, T-1, 4)
    inf = np.full((N, 1, 4), np.inf)
    v = np.minimum(np.concatenate([inf, step], axis=1), np.concatenate([step, inf], axis=1))
    c = low & (v <= speeds[:, None, None])
    L = T + 1
    flat = _legs_end_to_end(c, False)
    if int(min_frames) > 1:
        flat = _debounce_legs(flat, T, int(min_frames))
    s, e = _runs(flat)
    out = np.zeros(N * 4 * L, dtype=bool)
    if len(s):
        y = _legs_end_to_end(f[..., Y], 0.0)
        tol = np.array([_tolerance(float(h)) for h in heights])[s // (4 * L)]
        _, _, k0, k1 = _planted(y, s, e, tol, cut=(s % L == 0) | (e % L == T))
        keep = k1 + 1 - k0 >= int(min_frames)
        out = _ranges_mask(k0[keep], k1[keep] + 1, N * 4 * L)
    return np.ascontiguousarray(out.reshape(N, 4, L)[:, :, :T].transpose(0, 2, 1))


def laid_out_as(contacts, feet) -> np.ndarray:
    """``contacts`` (T, 4) in the memory layout
    :func:`~quadsim.skeleton.contacts.foot_contacts` gives its result for ``feet``
    (T, 4, 3): that of its first test on them (which follows the feet's own
    layout), so that a file storing the contacts has the same bytes either way."""
    f = np.asarray(feet, dtype=float)
    # foot_contacts' own expression, thresholds aside: its result is laid out as this
    low = f[..., Y] - 0.0 <= 0.0
    step = np.linalg.norm(np.diff(f[..., [X, Z]], axis=0), axis=-1)
    inf = np.full((1, 4), np.inf)
    like = low & (np.minimum(np.concatenate([inf, step]), np.concatenate([step, inf])) <= 0.0)
    out = np.empty_like(like)
    out[...] = contacts
    return out


def events(contacts, fps: float, feet, heights) -> list[list[dict]]:
    """Each clip's contacts per foot: frames ``s``, ``e`` and refined times ``on``, ``off``.

    Parameters
    ----------
    contacts : array-like of bool, shape (N, T, 4)
    fps : float
    feet : array-like, shape (N, T, 4, 3)
        The foot positions the contacts were measured from (m).
    heights : array-like, shape (N,)
        Each clip's contact height threshold (m): its on-ground tolerance is the
        default that goes with it.

    Returns
    -------
    list of N lists of 4 dicts
        What ``quadsim.skeleton.contacts._events(contacts[i], fps, feet[i],
        tolerance)`` gives each clip, with that tolerance.
    """
    f = _check(feet)
    c = np.asarray(contacts, dtype=bool)
    N, T = f.shape[:2]
    if c.shape != (N, T, 4):
        raise ValueError(f"`contacts` has shape {c.shape}, expected {(N, T, 4)}")
    fps = float(fps)
    L = T + 1
    s, e = _runs(_legs_end_to_end(c, False))
    lo = s - s % L  # each contact's leg's first frame
    if len(s):
        tol = np.array([_tolerance(float(h)) for h in np.asarray(heights, dtype=float)])
        y = _legs_end_to_end(f[..., Y], 0.0)
        on, off = _refine(y, s, e, tol[s // (4 * L)], lo, lo + T)
    else:
        on = off = np.zeros(0)
    s, e = s - lo, e - lo
    on = np.where(s == 0, np.nan, on / fps)
    off = np.where(e == T, np.nan, off / fps)
    cuts = np.searchsorted(lo, np.arange(1, 4 * N) * L)
    legs = [{"s": a, "e": b, "on": p, "off": q} for a, b, p, q in
            zip(*(_split_at(x, cuts) for x in (s, e, on, off)))]
    return [legs[4 * i:4 * i + 4] for i in range(N)]

