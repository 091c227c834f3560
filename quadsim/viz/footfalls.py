"""The measurements behind a gait diagram (pure numpy, no plotting).

Stance bars come from the motion's foot positions
(:func:`quadsim.analysis.metrics.foot_contacts` and the sub-frame touchdown
and lift-off times of :func:`~quadsim.analysis.metrics.stance_intervals`),
never from the generator's planned contacts. Gait labels (``Motion.gaits``)
only name the segments; a motion without labels (a BVH file) has each stride
named by the nearest footfall pattern of the gait table.

:func:`footfall_data` returns a :class:`FootfallData` holding the stance
bars, one row per left-hind stride (duty factor and touchdown phase of every
foot), and the segments with their measured duty factor and phase beside the
gait table's values. :mod:`quadsim.viz.diagram` draws it.

Conventions: legs LF, RF, LH, RH; a stride runs from one left-hind touchdown
to the next; a foot's phase is the fraction of that stride after which it
touches down, in [0, 1).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from quadsim.analysis.metrics import feet_over_ground, foot_contacts, stance_intervals
from quadsim.frames import LEGS

__all__ = ["IRREGULAR", "MATCH_LIMIT", "FootfallData", "Segment", "classify_strides",
           "footfall_data", "phase_distance", "reference_gaits"]

_LH = LEGS.index("LH")
#: Label of strides that match no gait of the table (unlabelled motions).
IRREGULAR = "irregular"
#: Largest pattern distance (see :func:`classify_strides`) still named a gait.
MATCH_LIMIT = 0.3


# ------------------------------------------------------------------ data
@dataclass(frozen=True)
class Segment:
    """A stretch of one gait (or of a transition) and what was measured in it.

    Attributes
    ----------
    label : str
        Gait name (``"trot"``) or transition (``"walk->trot"``).
    start, stop : float
        Time span (s).
    strides : int
        Whole left-hind strides inside the span, the ones measured.
    duty : ndarray, shape (4,)
        Mean stride duty factor of each foot (NaN without strides).
    phase : ndarray, shape (4,)
        Circular mean touchdown phase of each foot after LH's (LH is 0).
    table_duty : (float, float) or None
        The gait table's duty factor range (None for a transition or an
        unknown gait).
    table_phase : ndarray, shape (4,), or None
        The gait table's phases.
    """

    label: str
    start: float
    stop: float
    strides: int
    duty: np.ndarray
    phase: np.ndarray
    table_duty: tuple[float, float] | None = None
    table_phase: np.ndarray | None = None

    @property
    def is_transition(self) -> bool:
        """A gait transition, or strides that match no gait of the table."""
        return "->" in self.label or self.label == IRREGULAR

    @property
    def phase_error(self) -> float:
        """Largest circular distance between measured and table phases (NaN if unknown)."""
        if self.table_phase is None or self.strides == 0:
            return float("nan")
        return float(np.nanmax(phase_distance(self.phase, self.table_phase)))


@dataclass(frozen=True)
class FootfallData:
    """Everything a gait diagram shows, measured from one motion.

    Attributes
    ----------
    fps : float
    times : ndarray, shape (T,)
        Time of each frame (s).
    contacts : ndarray of bool, shape (T, 4)
        Measured contacts.
    bars : tuple of 4 ndarrays, shape (n_i, 2)
        Stance ``[touchdown, lift-off]`` times (s) of each foot, refined below
        a frame; a stance cut by the clip starts or ends at the clip's edge.
    stride_start, stride_stop : ndarray, shape (n,)
        Left-hind touchdowns bounding each whole stride (s).
    stride_duty : ndarray, shape (n, 4)
        Duty factor of each foot's stride that starts inside the LH stride
        (NaN if none).
    stride_phase : ndarray, shape (n, 4)
        Touchdown phase of each foot inside the LH stride (NaN if none).
    stride_label : ndarray of str, shape (n,)
        Gait of each stride (from the labels, else classified).
    segments : tuple of Segment
    gaits : dict of str to (duty_range, phases)
        The gait table the segments are compared with.
    cpg_phase : ndarray, shape (T, 4), or None
        The generator's oscillator stride fractions (``extras['phase']``).
    cpg_duty : ndarray, shape (T,), or None
        The generator's duty factor (``extras['duty']``).
    spine : ndarray, shape (T,), or None
        Spine angle (rad, ``extras['spine']``).
    labelled : bool
        True when segments come from the motion's gait labels.
    """

    fps: float
    times: np.ndarray
    contacts: np.ndarray
    bars: tuple[np.ndarray, ...]
    stride_start: np.ndarray
    stride_stop: np.ndarray
    stride_duty: np.ndarray
    stride_phase: np.ndarray
    stride_label: np.ndarray
    segments: tuple[Segment, ...]
    gaits: dict
    cpg_phase: np.ndarray | None = None
    cpg_duty: np.ndarray | None = None
    spine: np.ndarray | None = None
    labelled: bool = True

    def steady_segments(self, min_strides: int = 1) -> list[Segment]:
        """Segments of one gait (not transitions) with at least ``min_strides`` strides."""
        return [s for s in self.segments if not s.is_transition and s.strides >= min_strides]


def phase_distance(a, b) -> np.ndarray:
    """Distance between phases on the unit circle, in [0, 0.5].

    Parameters
    ----------
    a, b : array-like, broadcastable
        Phases (fractions of a stride).
    """
    d = np.mod(np.asarray(a, dtype=float) - np.asarray(b, dtype=float), 1.0)
    return np.minimum(d, 1.0 - d)


def _nanmean(a: np.ndarray, axis: int) -> np.ndarray:
    """Mean ignoring NaN, NaN (without a warning) where every value is NaN."""
    ok = np.isfinite(a)
    n = ok.sum(axis=axis)
    s = np.where(ok, a, 0.0).sum(axis=axis)
    return np.divide(s, n, out=np.full(np.shape(s), np.nan), where=n > 0)


def _circular_mean(ph: np.ndarray, axis: int = 0) -> np.ndarray:
    """Mean of phases on the unit circle, ignoring NaN (NaN where all are)."""
    z = np.exp(2j * np.pi * np.nan_to_num(ph))
    ok = np.isfinite(ph)
    s = np.sum(np.where(ok, z, 0.0), axis=axis)
    n = ok.sum(axis=axis)
    out = np.mod(np.angle(s) / (2 * np.pi), 1.0)
    out = np.where(out > 1.0 - 5e-4, 0.0, out)  # round 0.9996 to 0
    return np.where(n > 0, out, np.nan)


def reference_gaits(motion=None, character=None) -> dict:
    """The gait table a motion is compared with: ``{name: (duty_range, phases)}``.

    ``character`` (a :class:`~quadsim.skeleton.character.Character`) gives
    its table; otherwise the shipped character whose skeleton the motion has
    (the same object, or the same joint names), else the horse's, which has
    every gait.
    """
    from quadsim.locomotion.gaits import gait_table
    from quadsim.skeleton.character import list_characters, load_character

    if character is None:
        skel = getattr(motion, "skeleton", None)
        found = None
        if skel is not None:
            for cid in list_characters():
                try:
                    ch = load_character(cid)
                except ValueError:
                    continue
                if ch.skeleton is skel or sorted(ch.skeleton.names) == sorted(skel.names):
                    found = ch
                    break
        character = found or load_character("horse")
    return {g.name: (tuple(g.duty_range), np.asarray(g.phases, dtype=float))
            for g in gait_table(character).values()}


def classify_strides(duty, phase, gaits: dict) -> np.ndarray:
    """Name each stride by the nearest footfall pattern of a gait table.

    The distance of a stride to a gait is the sum of the circular phase
    distances of LF, RF and RH plus how far the stride's mean duty factor lies
    outside the gait's duty range. A missing phase counts 0.25. A stride
    farther than ``MATCH_LIMIT`` from every gait is ``"irregular"``.

    Parameters
    ----------
    duty : array-like, shape (n, 4)
    phase : array-like, shape (n, 4)
    gaits : dict of str to (duty_range, phases)

    Returns
    -------
    labels : ndarray of str, shape (n,)
    """
    duty = np.asarray(duty, dtype=float)
    phase = np.asarray(phase, dtype=float)
    names = list(gaits)
    if len(duty) == 0 or not names:
        return np.zeros(len(duty), dtype=object)
    lo = np.array([min(gaits[n][0]) for n in names])
    hi = np.array([max(gaits[n][0]) for n in names])
    ref = np.stack([gaits[n][1] for n in names])                      # (G, 4)
    legs = [i for i in range(4) if i != _LH]
    d = phase_distance(phase[:, None, legs], ref[None, :, legs])      # (n, G, 3)
    cost = np.where(np.isfinite(d), d, 0.25).sum(axis=-1)
    b = np.nan_to_num(_nanmean(duty, axis=1), nan=0.5)[:, None]
    cost = cost + np.maximum(lo - b, 0.0) + np.maximum(b - hi, 0.0)
    best = np.argmin(cost, axis=1)
    ok = cost[np.arange(len(best)), best] <= MATCH_LIMIT
    return np.array([names[k] if g else IRREGULAR for k, g in zip(best, ok)], dtype=object)


def _strides(bars_raw: list[np.ndarray]):
    """Per LH stride: bounds, each foot's duty and phase."""
    td = [iv[np.isfinite(iv[:, 0]), 0] for iv in bars_raw]
    ref = td[_LH]
    n = max(len(ref) - 1, 0)
    t0, t1 = ref[:-1], ref[1:]
    duty = np.full((n, 4), np.nan)
    phase = np.full((n, 4), np.nan)
    for i, iv in enumerate(bars_raw):
        # whole strides of foot i: touchdown, lift-off, next touchdown all known
        on, off = iv[:, 0], iv[:, 1]
        whole = np.isfinite(on[:-1]) & np.isfinite(off[:-1]) & np.isfinite(on[1:])
        s_on = on[:-1][whole]
        s_duty = ((off[:-1] - on[:-1]) / (on[1:] - on[:-1]))[whole]
        t = td[i]
        if n == 0 or len(t) == 0:
            continue
        # first touchdown of foot i at or after each LH touchdown
        k = np.searchsorted(t, t0, side="left")
        ok = k < len(t)
        tk = t[np.minimum(k, len(t) - 1)]
        inside = ok & (tk < t1)
        phase[inside, i] = (tk[inside] - t0[inside]) / (t1[inside] - t0[inside])
        if len(s_on):
            j = np.searchsorted(s_on, t0, side="left")
            sj = s_on[np.minimum(j, len(s_on) - 1)]
            has = (j < len(s_on)) & (sj < t1)
            duty[has, i] = s_duty[np.minimum(j, len(s_on) - 1)][has]
    phase[:, _LH] = 0.0
    return t0, t1, duty, phase


def _label_runs(labels: np.ndarray, times: np.ndarray, t_end: float):
    """Runs of equal labels as (label, start, stop)."""
    change = np.flatnonzero(labels[1:] != labels[:-1]) + 1
    starts = np.concatenate([[0], change])
    stops = np.concatenate([change, [len(labels)]])
    return [(str(labels[a]), float(times[a]), float(times[b]) if b < len(times) else t_end)
            for a, b in zip(starts, stops)]


def footfall_data(motion, *, start: float = 0.0, stop: float | None = None,
                  gaits: dict | None = None, character=None) -> FootfallData:
    """Measure what a gait diagram shows (pure numpy; no plotting).

    Parameters
    ----------
    motion : Motion
        Must name its four foot joints.
    start, stop : float, optional
        Time window (s from the motion's first frame); the default is all of it.
    gaits : dict, optional
        ``{name: (duty_range, phases)}`` to compare with; default
        :func:`reference_gaits` of the motion (or of ``character``).
    character : Character, optional
        Whose gait table to use when ``gaits`` is not given.

    Returns
    -------
    FootfallData

    Raises
    ------
    ValueError
        When the motion does not name its foot joints, or the window holds
        fewer than 3 frames.
    """
    if getattr(motion, "foot_joints", None) is None:
        raise ValueError("a gait diagram needs the motion's foot joints: build the Motion "
                         "with foot_joints=(LF, RF, LH, RH joint names)")
    fps = float(motion.fps)
    T_all = len(motion)
    i0 = max(int(np.ceil(start * fps - 1e-9)), 0)
    i1 = T_all if stop is None else min(int(np.ceil(stop * fps - 1e-9)), T_all)
    if i1 - i0 < 3:
        raise ValueError(f"the window [{start}, {stop}] s holds {max(i1 - i0, 0)} frames of "
                         f"{T_all}; a diagram needs at least 3")
    feet = feet_over_ground(motion)[i0:i1]
    T = len(feet)
    offset = i0 / fps
    times = offset + np.arange(T) / fps
    t_end = offset + (T - 1) / fps
    contacts = foot_contacts(feet, fps)
    raw = [iv + offset for iv in stance_intervals(contacts, fps, feet)]
    bars = []
    for iv in raw:
        b = iv.copy()
        if len(b):
            b[:, 0] = np.where(np.isfinite(b[:, 0]), b[:, 0], offset)
            b[:, 1] = np.where(np.isfinite(b[:, 1]), b[:, 1], t_end)
        b.setflags(write=False)
        bars.append(b)
    t0, t1, sduty, sphase = _strides(raw)
    if gaits is None:
        gaits = reference_gaits(motion, character)

    labelled = motion.gaits is not None
    if labelled:
        labels = np.asarray(motion.gaits, dtype=object)[i0:i1]
        labels = np.array([str(x) for x in labels], dtype=object)
        mid = np.clip(np.round(((t0 + t1) / 2 - offset) * fps).astype(int), 0, T - 1)
        slabel = labels[mid] if len(mid) else np.zeros(0, dtype=object)
        runs = _label_runs(labels, times, t_end)
    else:
        slabel = classify_strides(sduty, sphase, gaits)
        runs = []
        if len(slabel):
            change = np.flatnonzero(slabel[1:] != slabel[:-1]) + 1
            a = np.concatenate([[0], change])
            b = np.concatenate([change, [len(slabel)]])
            for k, (s, e) in enumerate(zip(a, b)):
                lo = offset if k == 0 else float(t0[s])
                hi = t_end if k == len(a) - 1 else float(t1[e - 1])
                runs.append((str(slabel[s]), lo, hi))
        else:
            runs = [("", offset, t_end)]

    segments = []
    for label, lo, hi in runs:
        inside = (t0 >= lo - 1e-9) & (t1 <= hi + 1e-9)
        if not labelled:
            inside &= slabel == label
        n = int(inside.sum())
        d = _nanmean(sduty[inside], axis=0)
        ph = _circular_mean(sphase[inside]) if n else np.full(4, np.nan)
        tab = gaits.get(label)
        segments.append(Segment(
            label=label, start=lo, stop=hi, strides=n, duty=d, phase=ph,
            table_duty=None if tab is None else tuple(float(x) for x in tab[0]),
            table_phase=None if tab is None else np.asarray(tab[1], dtype=float)))

    def extra(key, shape):
        v = getattr(motion, "extras", {}).get(key)
        if v is None:
            return None
        v = np.asarray(v, dtype=float)[i0:i1]
        return v if v.shape[1:] == shape else None

    return FootfallData(
        fps=fps, times=times, contacts=contacts, bars=tuple(bars),
        stride_start=t0, stride_stop=t1, stride_duty=sduty, stride_phase=sphase,
        stride_label=slabel, segments=tuple(segments), gaits=dict(gaits),
        cpg_phase=extra("phase", (4,)), cpg_duty=extra("duty", ()),
        spine=extra("spine", ()), labelled=labelled)
