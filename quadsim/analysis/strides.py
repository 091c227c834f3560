"""Stride figures measured from contacts: touchdowns, duty factors, phases, frequency, length.

A *stride* of a foot runs from one of its touchdowns to the next. Duty
factors, stride frequencies and phases use whole strides only. Contacts and
their sub-frame timing are defined in :mod:`quadsim.skeleton.contacts`; legs
are ordered LF, RF, LH, RH, times are seconds from the first frame given.
"""

from __future__ import annotations

import numpy as np

from quadsim.analysis.stride_kernels import leg_starts, phase_means, stride_rows
from quadsim.frames import X, Z
from quadsim.skeleton.contacts import (
    _LH,
    _check_contacts,
    _check_feet,
    _check_fps,
    _events,
    _horizontal,
    stance_intervals,
)

__all__ = ["duty_factors", "phases", "stride_frequency", "stride_length", "stride_table",
           "strides_to_pattern", "touchdown_times"]


def touchdown_times(contacts, fps, feet=None, *, tolerance=None) -> list[np.ndarray]:
    """Observed touchdown times (s) of each foot, a list of 4 ascending arrays."""
    return [iv[np.isfinite(iv[:, 0]), 0]
            for iv in stance_intervals(contacts, fps, feet, tolerance=tolerance)]


# ---------------------------------------------------------- stride figures
def stride_table(contacts, fps, feet=None, *, tolerance=None) -> dict[str, np.ndarray]:
    """One row per whole stride of every foot.

    Parameters
    ----------
    contacts : array-like of bool, shape (T, 4)
    fps : float
    feet : array-like, shape (T, 4, 3), optional
        Refines the timing and gives the stride lengths.

    Returns
    -------
    table : dict of str to ndarray, shape (n,)
        ``leg`` (index into LF, RF, LH, RH), ``touchdown``, ``liftoff`` and
        ``next_touchdown`` (s), ``period`` (s), ``stance`` (s), ``duty``, and
        ``length`` (m): the horizontal distance between the foot's planted
        positions (at the middle frame of each contact) of this contact and the
        next (NaN without ``feet``). Rows are sorted by leg, then time.
    """
    evs = _events(contacts, fps, feet, tolerance)
    return _table(evs, None if feet is None else _check_feet(feet))


def _table(evs: list[dict], f: np.ndarray | None) -> dict[str, np.ndarray]:
    first = leg_starts([len(ev["on"]) for ev in evs])
    on, off, s, e = (np.concatenate([ev[k] for ev in evs]) for k in ("on", "off", "s", "e"))
    with_length = f is not None
    fx, fz = (f[..., X], f[..., Z]) if with_length else (np.zeros((1, 4)),) * 2
    n = len(on)
    leg, td, lo, nxt, length = np.empty(n, dtype=np.int64), *(np.empty(n) for _ in range(4))
    r = stride_rows(on, off, s.astype(np.int64), e.astype(np.int64), first, fx, fz,
                    with_length, leg, td, lo, nxt, length)
    leg, td, lo, nxt, length = leg[:r], td[:r], lo[:r], nxt[:r], length[:r]
    period = nxt - td
    stance = lo - td
    return {"leg": leg, "touchdown": td, "liftoff": lo,
            "next_touchdown": nxt, "period": period, "stance": stance,
            "duty": stance / period, "length": length}


def duty_factors(contacts, fps, feet=None, *, tolerance=None) -> np.ndarray:
    """Duty factor of each foot over its whole strides.

    The stance time summed over the strides from the foot's first to its last
    observed touchdown, divided by that span (the duration-weighted mean of
    the per-stride duty factors in :func:`stride_table`).

    Returns
    -------
    duty : ndarray, shape (4,)
        NaN for a foot without one whole stride.
    """
    return _duty(stride_table(contacts, fps, feet, tolerance=tolerance))


def _duty(t: dict) -> np.ndarray:
    stance = np.bincount(t["leg"], t["stance"], minlength=4)
    period = np.bincount(t["leg"], t["period"], minlength=4)
    return np.divide(stance, period, out=np.full(4, np.nan), where=period > 0)


def phases(contacts, fps, feet=None, *, tolerance=None) -> np.ndarray:
    """Mean touchdown phase of each foot relative to the left hind.

    For each stride ``[t0, t1)`` of the left hind (LH), each touchdown ``t`` of
    another foot inside it gives ``(t - t0) / (t1 - t0)``; the phases of a foot
    are averaged on the unit circle (so 0.98 and 0.02 average to 0).

    Returns
    -------
    phase : ndarray, shape (4,)
        In [0, 1), leg order LF, RF, LH, RH; LH is 0. NaN for a foot with no
        touchdown inside a whole LH stride (or all LH without one).
    """
    return _phases(touchdown_times(contacts, fps, feet, tolerance=tolerance))


def _phases(td: list[np.ndarray]) -> np.ndarray:
    out = np.empty(4)
    phase_means(np.concatenate(td).astype(float), leg_starts([len(t) for t in td]), _LH, out)
    return out


def strides_to_pattern(contacts, fps, want, *, feet=None, start: float = 0.0,
                       tol: float = 0.06, tolerance=None) -> int | None:
    """Left-hind strides from ``start`` until the footfall pattern ``want`` holds for good.

    Each whole left-hind (LH) stride ``[t0, t1)`` that begins at or after
    ``start`` matches when every other foot touches down inside it at phase
    ``(t - t0) / (t1 - t0)`` within ``tol`` (a fraction of the stride, taken
    round the circle) of ``want`` (its first touchdown in the stride counts).

    Parameters
    ----------
    contacts : array-like of bool, shape (T, 4)
    fps : float
    want : array-like, shape (4,)
        Wanted touchdown phase of each foot after LH, leg order LF, RF, LH, RH.
    feet : array-like, shape (T, 4, 3), optional
        Refines the touchdown times (see :func:`stance_intervals`).
    start : float
        Time (s) from which strides are counted.
    tol : float
        Largest phase error (fraction of a stride).

    Returns
    -------
    int or None
        The number of strides from ``start`` before the first of the
        unbroken run of matching strides that ends with the last whole stride;
        None when the last stride does not match (or there is none).
    """
    td = touchdown_times(contacts, fps, feet, tolerance=tolerance)
    want = np.asarray(want, dtype=float)
    ref = td[_LH][td[_LH] >= start - 1e-9]
    ok = []
    for a, b in zip(ref[:-1], ref[1:]):
        err = 0.0
        for i in range(4):
            if i == _LH:
                continue
            x = td[i][(td[i] >= a) & (td[i] < b)]
            err = max(err, abs(((x[0] - a) / (b - a) - want[i] + 0.5) % 1.0 - 0.5)
                      if len(x) else 1.0)
        ok.append(err < tol)
    if not ok or not ok[-1]:
        return None
    bad = [k for k, v in enumerate(ok) if not v]
    return bad[-1] + 1 if bad else 0


def stride_frequency(contacts, fps, feet=None, *, tolerance=None) -> float:
    """Strides per second (Hz) from the left hind's touchdowns (NaN if < 2)."""
    return _frequency(touchdown_times(contacts, fps, feet, tolerance=tolerance)[_LH])


def _frequency(t: np.ndarray) -> float:
    if len(t) < 2:
        return float("nan")
    return float((len(t) - 1) / (t[-1] - t[0]))


def stride_length(root_positions, contacts, fps, feet=None, *, tolerance=None) -> float:
    """Mean horizontal distance the root travels per left-hind stride (m).

    The root's horizontal path length between consecutive left-hind
    touchdowns (interpolated between frames), averaged; on a curve this is the
    distance along the path. NaN with fewer than two touchdowns.

    Parameters
    ----------
    root_positions : array-like, shape (T, 3)
    contacts : array-like of bool, shape (T, 4)
    fps : float
    feet : array-like, shape (T, 4, 3), optional
    """
    root = np.asarray(root_positions, dtype=float)
    c = _check_contacts(contacts)
    if root.shape != (len(c), 3):
        raise ValueError(f"`root_positions` has shape {root.shape}, expected ({len(c)}, 3)")
    fps = _check_fps(fps)
    return _length(root, touchdown_times(c, fps, feet, tolerance=tolerance)[_LH], fps)


def _length(root: np.ndarray, t: np.ndarray, fps: float) -> float:
    if len(t) < 2:
        return float("nan")
    step = np.linalg.norm(np.diff(_horizontal(root), axis=0), axis=-1)
    path = np.concatenate([[0.0], np.cumsum(step)])
    s = np.interp(t * fps, np.arange(len(root)), path)
    return float((s[-1] - s[0]) / (len(t) - 1))
