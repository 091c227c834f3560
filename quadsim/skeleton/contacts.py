"""Foot contacts measured from foot positions: the definitions both engines use.

Below both engines (the data-driven horse cuts and times its clips with
them) and below :mod:`quadsim.analysis` (which measures produced motion with
them). Arrays: time leads, legs ordered LF, RF, LH, RH, positions ``(..., 3)``
in metres with +Y up.

Contacts and their timing
-------------------------
A foot is *in contact* on a frame when it is low (``y - ground <= height``) and
still (horizontal speed ``<= speed``, the smaller of the speeds to the previous
and to the next frame, so that the touchdown frame and the last stance frame
both count as still). Runs shorter than ``min_frames`` are then cleaned: interior
gaps shorter than ``min_frames`` are filled first, then contacts shorter than
``min_frames`` are dropped. The default thresholds scale with the animal (see
:func:`default_contact_thresholds`).

Each contact is finally trimmed to the frames on which the foot is *on the
ground*: at its planted height (the median of the contact's heights) within a
band of three times their median absolute deviation -- the foot's jitter --
bounded to [10 micrometres, ``tolerance``]. A foot that is low and slow but still
descending or already rising is thus not in contact, and its travel is not
counted as sliding; a clean planted foot is in contact exactly while it sits
at its planted height.

Touchdown and lift-off times refine the contact frames when the foot positions
are given: the touchdown is extrapolated from the last frame above the band,
in a straight line at the foot's descent rate, to the instant it reaches the
planted height (at most two frames on); lift-off likewise, backwards from the
first frame above the band. On smooth swing arcs this is within a few
hundredths of a frame, and within a quarter of a frame when a swing lasts only
four frames. From a contact array alone, touchdown is ``start / fps`` and
lift-off ``end / fps`` (``end`` exclusive), which overstates each stance by up
to a frame. A contact already under way at the first frame has an
unknown touchdown (NaN), and one still under way at the last frame an unknown
lift-off.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from quadsim.frames import GRAVITY, LEGS, X, Y, Z

__all__ = ["body_span", "contact_intervals", "default_contact_thresholds", "foot_contacts",
           "stance_intervals"]

#: Contact height threshold as a fraction of the body span, and its bounds (m).
HEIGHT_FRACTION = 0.02
HEIGHT_BOUNDS = (0.005, 0.03)
#: Contact speed threshold as a multiple of sqrt(g * span) (a Froude-scaled speed).
SPEED_FROUDE = 0.25
#: On-ground band above a contact's planted height: a fraction of the height
#: threshold, at least TOLERANCE_FLOOR (m).
TOLERANCE_FRACTION = 0.1
TOLERANCE_FLOOR = 0.001
#: Narrowest on-ground band (m): numerical noise of a planted foot.
GROUND_BAND_FLOOR = 1e-5
#: Shortest contact (and shortest gap inside one) kept, in frames.
MIN_FRAMES = 2
_LH = LEGS.index("LH")


# ------------------------------------------------------------- validation
def _check_fps(fps) -> float:
    f = float(fps)
    if not np.isfinite(f) or f <= 0:
        raise ValueError(f"`fps` must be a positive number, got {fps!r}")
    return f


def _check_feet(feet, name: str = "feet") -> np.ndarray:
    a = np.asarray(feet, dtype=float)
    if a.ndim != 3 or a.shape[1:] != (4, 3):
        raise ValueError(f"`{name}` has shape {a.shape}, expected (T, 4, 3)")
    return a


def _check_contacts(contacts, T: int | None = None) -> np.ndarray:
    c = np.asarray(contacts)
    if c.ndim != 2 or c.shape[1] != 4 or (T is not None and c.shape[0] != T):
        want = "T" if T is None else str(T)
        raise ValueError(f"`contacts` has shape {c.shape}, expected ({want}, 4)")
    return c.astype(bool)


def _horizontal(p: np.ndarray) -> np.ndarray:
    """The ground-plane components (X, Z) of positions ``(..., 3)``."""
    return p[..., [X, Z]]


# ---------------------------------------------------------------- contacts
def body_span(feet) -> float:
    """Typical horizontal distance between the fore and the hind feet (m).

    The median over frames of the distance between the midpoint of the fore
    feet (LF, RF) and that of the hind feet (LH, RH): about the body length,
    which for quadrupeds is close to the hip height. It sets the scale of the
    default contact thresholds.

    Parameters
    ----------
    feet : array-like, shape (T, 4, 3)
    """
    f = _check_feet(feet)
    if len(f) == 0:
        return 0.0
    fore = _horizontal(f[:, :2].mean(axis=1))
    hind = _horizontal(f[:, 2:].mean(axis=1))
    return float(np.median(np.linalg.norm(fore - hind, axis=-1)))


def default_contact_thresholds(feet) -> tuple[float, float]:
    """The contact thresholds :func:`foot_contacts` uses when none are given.

    With ``s`` the :func:`body_span`: height ``0.02 s`` bounded to
    [5 mm, 30 mm] (12 mm for the leopard, whose feet are 0.63 m apart; about
    25 mm for a horse; the 5 mm floor for a cub), well under any swing
    clearance (about a tenth of the hip height); speed
    ``0.25 sqrt(g max(s, 0.1 m))`` (0.62 m/s for the leopard, about 0.9 m/s for
    a horse): Froude-scaled like the gaits, far above a planted foot's speed
    (~0) and below a swinging foot's (its mean is the body speed / (1 - duty)).

    Returns
    -------
    height : float
        Metres above the ground.
    speed : float
        Horizontal speed (m/s).
    """
    s = body_span(feet)
    height = float(np.clip(HEIGHT_FRACTION * s, *HEIGHT_BOUNDS))
    speed = SPEED_FROUDE * math.sqrt(GRAVITY * max(s, 0.1))
    return height, speed


def _split_at(x: np.ndarray, cuts) -> list[np.ndarray]:
    """``np.split(x, cuts)`` along the first axis, ``cuts`` ascending indices (ints
    array-like): the same views, cut by plain slicing (``np.split`` costs a few
    microseconds a piece, and a batch's contacts are cut into hundreds)."""
    ends = [0, *np.asarray(cuts, dtype=np.int64).tolist(), len(x)]
    return [x[a:b] for a, b in zip(ends[:-1], ends[1:])]


def _runs(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Starts and (exclusive) ends of the True runs of a 1-D bool array."""
    d = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    return np.flatnonzero(d == 1), np.flatnonzero(d == -1)


def _ranges_mask(starts: np.ndarray, ends: np.ndarray, T: int) -> np.ndarray:
    """Bool (T,) true on every frame of the half-open ranges [start, end)."""
    delta = np.zeros(T + 1, dtype=np.int64)
    np.add.at(delta, starts, 1)
    np.add.at(delta, ends, -1)
    return np.cumsum(delta[:-1]) > 0


def _debounce(c: np.ndarray, min_frames: int) -> np.ndarray:
    """Fill interior gaps, then drop contacts, shorter than ``min_frames``."""
    T = len(c)
    s, e = _runs(~c)
    short = (s > 0) & (e < T) & (e - s < min_frames)
    c = c | _ranges_mask(s[short], e[short], T)
    s, e = _runs(c)
    short = e - s < min_frames
    return c & ~_ranges_mask(s[short], e[short], T)


def _tolerance(height: float) -> float:
    return max(TOLERANCE_FRACTION * height, TOLERANCE_FLOOR)


def foot_contacts(feet, fps, *, height: float | None = None, speed: float | None = None,
                  min_frames: int = MIN_FRAMES, tolerance: float | None = None,
                  ground: float = 0.0) -> np.ndarray:
    """Which feet touch the ground on each frame, from their positions.

    Parameters
    ----------
    feet : array-like, shape (T, 4, 3)
        World positions of the foot contact joints (m), legs LF, RF, LH, RH.
    fps : float
        Frames per second.
    height : float, optional
        A foot is low when ``y - ground <= height`` (m). Default: see
        :func:`default_contact_thresholds`.
    speed : float, optional
        A foot is still when its horizontal speed is ``<= speed`` (m/s); the
        speed of a frame is the smaller of the speeds over the step before and
        the step after it. Default: see :func:`default_contact_thresholds`.
    min_frames : int
        Interior gaps shorter than this are filled, then contacts shorter than
        this removed (default 2: one-frame blips and gaps). 1 keeps the raw test.
    tolerance : float, optional
        Widest on-ground band (m): each contact is then trimmed at both ends
        to the frames within a band above its planted height (the median of
        its heights, their minimum for a contact cut by the clip's first or
        last frame) of three times the heights' median absolute deviation,
        bounded to [10 micrometres, ``tolerance``] (see the module notes).
        Default ``max(0.1 * height, 1 mm)``. Contacts shorter than
        ``min_frames`` after trimming are removed.
    ground : float
        Height of the ground (m).

    Returns
    -------
    contacts : ndarray of bool, shape (T, 4)
    """
    f = _check_feet(feet)
    fps = _check_fps(fps)
    if int(min_frames) < 1:
        raise ValueError(f"`min_frames` must be at least 1, got {min_frames!r}")
    T = len(f)
    if T == 0:
        return np.zeros((0, 4), dtype=bool)
    if height is None or speed is None:
        h0, v0 = default_contact_thresholds(f)
        height = h0 if height is None else height
        speed = v0 if speed is None else speed
    height, speed = float(height), float(speed)
    low = f[..., Y] - ground <= height
    step = np.linalg.norm(np.diff(_horizontal(f), axis=0), axis=-1) * fps  # (T-1, 4)
    inf = np.full((1, 4), np.inf)
    v = np.minimum(np.concatenate([inf, step]), np.concatenate([step, inf]))
    c = low & (v <= speed)
    tol = _tolerance(height) if tolerance is None else float(tolerance)
    min_frames = int(min_frames)
    # the four legs one after the other, each followed by a frame out of contact:
    # runs never cross from one leg to the next, and every step is done once
    L = T + 1
    flat = np.zeros((4, L), dtype=bool)
    flat[:, :T] = c.T
    flat = flat.reshape(-1)
    if min_frames > 1:
        flat = _debounce_legs(flat, T, min_frames)
    s, e = _runs(flat)
    out = np.zeros(4 * L, dtype=bool)
    if len(s):
        y = np.zeros((4, L))
        y[:, :T] = f[..., Y].T
        _, _, k0, k1 = _planted(y.reshape(-1), s, e, tol, cut=(s % L == 0) | (e % L == T))
        keep = k1 + 1 - k0 >= min_frames
        out = _ranges_mask(k0[keep], k1[keep] + 1, 4 * L)
    result = np.empty_like(c)  # laid out as c (and so as the feet): the same bytes as ever
    result[...] = out.reshape(4, L)[:, :T].T
    return result


def _debounce_legs(flat: np.ndarray, T: int, min_frames: int) -> np.ndarray:
    """:func:`_debounce` of each leg of ``flat`` (legs of ``T`` frames, each followed by
    one frame out of contact)."""
    L, N = T + 1, len(flat)
    s, e = _runs(~flat)
    # interior: not at a leg's first frame, not running into the frame after its last
    short = (s > 0) & (e <= (s // L) * L + T) & (e - s < min_frames)
    flat = flat | _ranges_mask(s[short], e[short], N)
    s, e = _runs(flat)
    short = e - s < min_frames
    return flat & ~_ranges_mask(s[short], e[short], N)


def contact_intervals(contacts) -> list[list[tuple[int, int]]]:
    """Contact intervals of each foot as ``(start_frame, end_frame_exclusive)``.

    Parameters
    ----------
    contacts : array-like of bool, shape (T, 4)

    Returns
    -------
    intervals : list of 4 lists of (int, int)
        In leg order LF, RF, LH, RH.
    """
    c = _check_contacts(contacts)
    out = []
    for i in range(4):
        s, e = _runs(c[:, i])
        out.append([(int(a), int(b)) for a, b in zip(s, e)])
    return out


def _events(contacts, fps, feet=None, tolerance=None) -> list[dict]:
    """Per foot: contact frames ``s``, ``e`` and times ``on``, ``off`` (s)."""
    c = _check_contacts(contacts)
    fps = _check_fps(fps)
    T = len(c)
    if feet is not None:
        f = _check_feet(feet)
        if len(f) != T:
            raise ValueError(f"`feet` has {len(f)} frames but `contacts` has {T}")
        if tolerance is None:
            tolerance = _tolerance(default_contact_thresholds(f)[0])
    if feet is None:
        out = []
        for i in range(4):
            s, e = _runs(c[:, i])
            on = np.where(s == 0, np.nan, s / fps)
            off = np.where(e == T, np.nan, e / fps)
            out.append({"s": s, "e": e, "on": on, "off": off})
        return out
    # the four legs one after the other, each followed by a frame out of contact
    L = T + 1
    flat = np.zeros((4, L), dtype=bool)
    flat[:, :T] = c.T
    s, e = _runs(flat.reshape(-1))
    lo = s - s % L  # each contact's leg's first frame
    y = np.zeros((4, L))
    y[:, :T] = f[..., Y].T
    if len(s):
        on, off = _refine(y.reshape(-1), s, e, float(tolerance), lo, lo + T)
    else:
        on = off = np.zeros(0)
    s, e = s - lo, e - lo
    on = np.where(s == 0, np.nan, on / fps)
    off = np.where(e == T, np.nan, off / fps)
    cuts = np.searchsorted(lo, np.arange(1, 4) * L)
    return [{"s": a, "e": b, "on": p, "off": q} for a, b, p, q in
            zip(*(_split_at(x, cuts) for x in (s, e, on, off)))]


def _group_medians(values: np.ndarray, groups: np.ndarray, sizes: np.ndarray) -> np.ndarray:
    """Lower median of ``values`` per group; ``groups`` ascending ids 0..n-1 of the given sizes.

    Each group's values are sorted by themselves, stably (compiled,
    :func:`_block_medians`): the same pick as sorting all of them at once by group
    and value (``np.lexsort``, still used where a value is NaN or a group empty).
    """
    values = np.ascontiguousarray(values, dtype=float)
    sizes = np.asarray(sizes, dtype=np.int64)
    if len(sizes) and sizes.min() >= 1 and sizes.sum() == len(values) \
            and not np.isnan(values).any():
        out = np.empty(len(sizes))
        _block_medians(values, sizes, out)
        return out
    order = np.lexsort((values, groups))
    first = np.concatenate([[0], np.cumsum(sizes)[:-1]])
    return values[order][first + (sizes - 1) // 2]


@njit(cache=True)
def _block_medians(values, sizes, out):
    """``out[g]`` = the lower median of the ``g``-th block of ``values`` (``sizes[g]`` long)."""
    scratch = np.empty(64)
    i = 0
    for g in range(sizes.shape[0]):
        n = sizes[g]
        if n > 64:  # stable, as lexsort: of equal values (0.0 and -0.0) the same one
            part = values[i:i + n]
            block = part[np.argsort(part, kind="mergesort")]
        else:  # short: a (stable) insertion sort in place of a new array
            block = scratch
            for a in range(n):
                x = values[i + a]
                b = a
                while b > 0 and block[b - 1] > x:
                    block[b] = block[b - 1]
                    b -= 1
                block[b] = x
        out[g] = block[(n - 1) // 2]
        i += n


def _planted(y: np.ndarray, s: np.ndarray, e: np.ndarray, tol, cut=None):
    """Planted height and first/last on-ground frame of the contacts [s, e) of one foot.

    The planted height is the (lower) median of the contact's heights -- or
    their minimum when the clip cuts the contact, which may then hold little
    besides a foot still descending or already rising. A frame is on the
    ground within a band above it of three times the median absolute
    deviation of the contact's heights (the foot's jitter), at least
    ``GROUND_BAND_FLOOR`` and at most ``tol`` (m; a float, or one per contact).

    Returns
    -------
    base, band : ndarray, shape (n,)
        Planted height and on-ground band (m).
    k0, k1 : ndarray of int, shape (n,)
        First and last on-ground frame.
    """
    T = len(y)
    frame = np.arange(T)
    contact = _ranges_mask(s, e, T)
    ids = np.maximum(np.searchsorted(s, frame, side="right") - 1, 0)
    cf = frame[contact]
    sizes = e - s
    base = _group_medians(y[cf], ids[cf], sizes)
    if cut is None:  # contacts the clip cuts (else given: several feet one after another)
        cut = (s == 0) | (e == T)
    if cut.any():
        base = np.where(cut, np.minimum.reduceat(np.where(contact, y, np.inf), s), base)
    mad = _group_medians(np.abs(y[cf] - base[ids[cf]]), ids[cf], sizes)
    band = np.clip(3.0 * mad, GROUND_BAND_FLOOR, np.maximum(tol, GROUND_BAND_FLOOR))
    on = contact & (y <= (base + band)[ids])
    k0 = np.minimum.reduceat(np.where(on, frame, T), s)
    k1 = np.maximum.reduceat(np.where(on, frame, -1), s)
    return base, band, k0, k1


def _refine(y: np.ndarray, s: np.ndarray, e: np.ndarray, tol, lo=0, hi=None):
    """Sub-frame touchdown and lift-off (in frames) of the contacts [s, e) of one foot.

    Touchdown: from the last frame ``a`` above the on-ground band, the foot
    descends in a straight line to its planted height at the faster of its
    descent rates over the step before ``a`` and the step after it; the result
    is kept within ``[a, a + 2]``. Lift-off is the mirror image.

    ``lo`` and ``hi`` (per contact, default 0 and ``len(y)``) bound the frames of
    the contact's foot when several feet are given one after another; the
    frames returned count from ``lo``.
    """
    hi = len(y) if hi is None else hi
    base, band, k0, k1 = _planted(y, s, e, tol, cut=(s == lo) | (e == hi))
    on, off = (k0 - lo).astype(float), (k1 - lo).astype(float)
    # touchdown
    a = k0 - 1
    ok = (a >= lo) & (y[np.maximum(a, lo)] > base + band)
    a = np.maximum(a, lo)
    rate = y[a] - y[k0]
    rate = np.where(a >= lo + 1, np.maximum(rate, y[np.maximum(a - 1, lo)] - y[a]), rate)
    frac = np.divide(y[a] - base, rate, out=np.ones_like(rate), where=rate > 0)
    on = np.where(ok, (a - lo) + np.clip(frac, 0.0, 2.0), on)
    # lift-off
    b = k1 + 1
    ok = (b < hi) & (y[np.minimum(b, hi - 1)] > base + band)
    b = np.minimum(b, hi - 1)
    rate = y[b] - y[k1]
    rate = np.where(b + 1 < hi, np.maximum(rate, y[np.minimum(b + 1, hi - 1)] - y[b]), rate)
    frac = np.divide(y[b] - base, rate, out=np.ones_like(rate), where=rate > 0)
    off = np.where(ok, (b - lo) - np.clip(frac, 0.0, 2.0), off)
    return on, off


def stance_intervals(contacts, fps, feet=None, *, tolerance: float | None = None
                     ) -> list[np.ndarray]:
    """Touchdown and lift-off time of every contact of each foot.

    Parameters
    ----------
    contacts : array-like of bool, shape (T, 4)
    fps : float
    feet : array-like, shape (T, 4, 3), optional
        Foot positions; when given, times are refined below a frame (see the
        module notes), otherwise they are contact frame boundaries / fps.
    tolerance : float, optional
        Widest on-ground band (m), as in :func:`foot_contacts` (same default).

    Returns
    -------
    intervals : list of 4 ndarrays, shape (n_i, 2)
        ``[touchdown, liftoff]`` in seconds; NaN where the clip cuts the contact.
    """
    return [np.stack([ev["on"], ev["off"]], axis=-1)
            for ev in _events(contacts, fps, feet, tolerance)]
