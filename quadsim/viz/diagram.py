"""Gait diagrams: footfalls, a Hildebrand plot, CPG phases and the spine.

The diagram is *measured*: stance bars come from the motion's foot positions
(:func:`quadsim.analysis.metrics.foot_contacts` and the sub-frame touchdown
and lift-off times of :func:`~quadsim.analysis.metrics.stance_intervals`),
never from the generator's planned contacts. Gait labels (``Motion.gaits``)
only name the segments; a motion without labels (a BVH file) has each stride
named by the nearest footfall pattern of the gait table.

Two layers:

- :func:`footfall_data` is pure numpy: it returns a :class:`FootfallData`
  holding the stance bars, one row per left-hind stride (duty factor and
  touchdown phase of every foot), and the segments with their measured duty
  factor and phase beside the gait table's values.
- :func:`gait_figure` draws it with matplotlib (no pyplot, no global state);
  :func:`gait_diagram` writes it to ``.png``, ``.svg`` or ``.pdf``.

Conventions: legs LF, RF, LH, RH; a stride runs from one left-hind touchdown
to the next; a foot's phase is the fraction of that stride after which it
touches down, in [0, 1).
"""

from __future__ import annotations

import os
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from quadsim.analysis.metrics import feet_over_ground, foot_contacts, stance_intervals
from quadsim.frames import LEGS

__all__ = ["IRREGULAR", "FootfallData", "Segment", "classify_strides", "footfall_data",
           "gait_diagram", "gait_figure", "phase_distance", "reference_gaits"]

_LH = LEGS.index("LH")
_LF = LEGS.index("LF")
#: File formats :func:`gait_diagram` writes, by extension.
FORMATS = {".png": "png", ".svg": "svg", ".pdf": "pdf"}
#: Bar colour of each leg (left legs warm, right legs cool; fore darker).
LEG_COLORS = ("#b5471b", "#1f5f8b", "#e08a3c", "#5b9bd5")
#: Label of strides that match no gait of the table (unlabelled motions).
IRREGULAR = "irregular"
#: Largest pattern distance (see :func:`classify_strides`) still named a gait.
MATCH_LIMIT = 0.3
#: Colour of each gait in the plots.
GAIT_COLORS = {
    "walk": "#4c9f38", "amble": "#9bbb2f", "trot": "#2878b5", "rack": "#7a5cb0",
    "pace": "#b05c9a", "canter": "#e3a21a", "transverse_gallop": "#d1495b",
    "rotary_gallop": "#8c2d2d",
}


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


# -------------------------------------------------------------- plotting
def _pretty(label: str) -> str:
    return " → ".join(p.replace("_", " ") for p in label.split("->"))


def _fmt_phase(x: float) -> str:
    if not np.isfinite(x):
        return "–"
    x = round(float(x), 2) % 1.0
    return f"{x:.2f}"[1:]


def gait_figure(motion_or_data, *, start: float = 0.0, stop: float | None = None,
                title: str | None = None, gaits: dict | None = None, character=None,
                figsize: tuple[float, float] | None = None):
    """Draw a gait diagram as a matplotlib figure (no pyplot involved).

    Panels: the footfall diagram (stance bars per foot, gait names and
    transitions along the top with each segment's measured duty factor
    ``β`` and phases of LF/RF/RH after LH, table values in brackets); the CPG
    stride fractions with the duty factor (stance below the line) and the
    spine angle, when the motion has them; and a Hildebrand plot of each
    stride's LH duty factor against the LF's phase after LH, with the gait
    table's values as bands.

    Parameters
    ----------
    motion_or_data : Motion or FootfallData
    start, stop, gaits, character
        See :func:`footfall_data` (ignored for a FootfallData).
    title : str, optional
    figsize : (float, float), optional
        Inches; by default it widens with the duration.

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D

    data = motion_or_data if isinstance(motion_or_data, FootfallData) else footfall_data(
        motion_or_data, start=start, stop=stop, gaits=gaits, character=character)
    t_lo, t_hi = float(data.times[0]), float(data.times[-1])
    span = max(t_hi - t_lo, 1e-6)
    has_cpg = data.cpg_phase is not None
    has_spine = data.spine is not None
    if figsize is None:
        figsize = (min(max(10.0, 4.0 + 1.1 * span), 26.0), 7.2 if (has_cpg or has_spine) else 5.0)
    fig = Figure(figsize=figsize, layout="constrained")
    rows = [3.2] + ([1.3] if has_cpg else []) + ([0.9] if has_spine else [])
    gs = fig.add_gridspec(len(rows), 2, height_ratios=rows, width_ratios=[3.4, 1.25])
    ax = fig.add_subplot(gs[0, 0])
    lower = []
    for r in range(1, len(rows)):
        lower.append(fig.add_subplot(gs[r, 0], sharex=ax))
    hax = fig.add_subplot(gs[:, 1])

    # ---- footfall bars: LF on top
    ypos = {0: 3, 1: 2, 2: 1, 3: 0}
    for i, b in enumerate(data.bars):
        if len(b):
            ax.broken_barh(list(zip(b[:, 0], b[:, 1] - b[:, 0])), (ypos[i] - 0.36, 0.72),
                           facecolors=LEG_COLORS[i], edgecolor="none")
    for t in data.stride_start:
        ax.axvline(t, color="0.85", lw=0.6, zorder=0)
    ax.set_yticks([ypos[i] for i in range(4)], list(LEGS))
    ax.set_ylim(-0.6, 5.25)
    ax.set_xlim(t_lo, t_hi)
    ax.spines[["top", "right"]].set_visible(False)
    # ---- gait names, transitions, per-segment figures
    for seg in data.segments:
        a, b = max(seg.start, t_lo), min(seg.stop, t_hi)
        if b <= a:
            continue
        color = "0.8" if seg.is_transition else GAIT_COLORS.get(seg.label, "0.6")
        ax.add_patch(_rect(a, 3.62, b - a, 0.36, color, hatch="///" if seg.is_transition
                           else None))
        if seg.start > t_lo:
            ax.axvline(seg.start, color="0.35", lw=0.9, ls="--", ymax=0.98)
        width = (b - a) / span  # fraction of the axis
        x = 0.5 * (a + b)
        if seg.is_transition:
            if width > 0.06:
                ax.text(x, 4.22, _pretty(seg.label), ha="center", va="bottom", fontsize=6.5,
                        color="0.3", style="italic")
            continue
        name = _pretty(seg.label) or "?"
        ax.text(x, 3.8, name, ha="center", va="center", fontsize=8.5, weight="bold",
                color="white", clip_on=True)
        if seg.strides:
            beta = float(_nanmean(seg.duty, axis=0))
            ph = "/".join(_fmt_phase(seg.phase[i]) for i in (0, 1, 3))
            txt = f"β {beta:.2f}  φ {ph}"
            if seg.table_phase is not None:
                tph = "/".join(_fmt_phase(seg.table_phase[i]) for i in (0, 1, 3))
                tb = f"{seg.table_duty[0]:.2f}-{seg.table_duty[1]:.2f}"
                txt2 = f"table β {tb}  φ {tph}"
            else:
                txt2 = ""
            txt3 = f"{seg.strides} stride{'s' if seg.strides != 1 else ''}"
            small = width < 0.16
            lines = [txt, txt2, txt3] if not small else [f"β {beta:.2f}", ph]
            ax.text(x, 4.12, "\n".join(s for s in lines if s), ha="center", va="bottom",
                    fontsize=6.3 if not small else 5.8, linespacing=1.15, color="0.15")
    ax.set_title(title or "Footfalls (measured from the foot positions)", fontsize=10,
                 loc="left")
    ax.text(1.0, 1.01, "φ: touchdown phase of LF/RF/RH after LH; β: stride duty factor",
            transform=ax.transAxes, ha="right", va="bottom", fontsize=7, color="0.35")
    for tick, i in zip(ax.get_yticklabels(), range(4)):
        tick.set_color(LEG_COLORS[i])
        tick.set_fontweight("bold")
    if not lower:
        ax.set_xlabel("time (s)")
    else:
        ax.tick_params(labelbottom=False)

    # ---- CPG phases and spine
    k = 0
    if has_cpg:
        cax = lower[k]
        k += 1
        ph = np.array(data.cpg_phase, dtype=float)
        wrap = np.abs(np.diff(ph, axis=0)) > 0.5
        ph[1:][wrap] = np.nan
        for i in range(4):
            cax.plot(data.times, ph[:, i], color=LEG_COLORS[i], lw=1.0, label=LEGS[i])
        if data.cpg_duty is not None:
            cax.plot(data.times, data.cpg_duty, color="k", lw=1.0, ls="--", label="duty")
        cax.set_ylim(0, 1)
        cax.set_ylabel("CPG stride\nfraction", fontsize=8)
        cax.legend(loc="lower right", bbox_to_anchor=(1.0, 0.97), ncol=5, fontsize=6.5,
                   frameon=False, handlelength=1.2, borderaxespad=0.0)
        cax.text(0.005, 0.02, "stance while below the dashed duty line", fontsize=6.5,
                 color="0.35", transform=cax.transAxes)
        cax.spines[["top", "right"]].set_visible(False)
    if has_spine:
        sax = lower[k]
        sax.plot(data.times, np.degrees(data.spine), color="#444444", lw=1.1)
        sax.axhline(0.0, color="0.7", lw=0.6)
        sax.set_ylabel("spine\n(deg)", fontsize=8)
        sax.spines[["top", "right"]].set_visible(False)
    if lower:
        for a_ in lower[:-1]:
            a_.tick_params(labelbottom=False)
        lower[-1].set_xlabel("time (s)")

    # ---- Hildebrand plot
    for name, (drange, tph) in data.gaits.items():
        c = GAIT_COLORS.get(name, "0.5")
        y = float(tph[_LF]) % 1.0
        hax.plot([min(drange), max(drange)], [y, y], color=c, lw=7, alpha=0.28,
                 solid_capstyle="round")
        hax.text(max(drange) + 0.012, y, _pretty(name), fontsize=6.5, color=c,
                 va="center", ha="left")
    x = data.stride_duty[:, _LH] if len(data.stride_duty) else np.zeros(0)
    y = data.stride_phase[:, _LF] if len(data.stride_phase) else np.zeros(0)
    y = np.where(y > 0.98, y - 1.0, y)  # keep a pace at 0 next to 0
    lab = np.asarray(data.stride_label, dtype=object)
    handles = []
    for name in dict.fromkeys(str(s) for s in lab):
        sel = lab == name
        trans = "->" in name or name == IRREGULAR
        c = "0.6" if trans else GAIT_COLORS.get(name, "0.3")
        hax.scatter(x[sel], y[sel], s=9 if trans else 16, color=c, marker="x" if trans else "o",
                    edgecolor="none" if not trans else None, alpha=0.9, zorder=3)
        if not trans:
            handles.append(Line2D([], [], ls="", marker="o", color=c, label=_pretty(name)))
    if any("->" in str(s) or s == IRREGULAR for s in lab):
        handles.append(Line2D([], [], ls="", marker="x", color="0.6",
                              label="transition" if data.labelled else IRREGULAR))
    hax.axvline(0.5, color="0.6", lw=0.7, ls=":")
    hax.text(0.49, 0.985, "← runs", fontsize=6.5, color="0.45", ha="right", va="top")
    hax.text(0.51, 0.985, "walks →", fontsize=6.5, color="0.45", ha="left", va="top")
    hax.set_xlim(0.0, 1.0)
    hax.set_ylim(-0.05, 1.0)
    hax.set_xlabel("duty factor of LH (per stride)", fontsize=8)
    hax.set_ylabel("touchdown phase of LF after LH", fontsize=8)
    hax.set_title("Hildebrand plot (bands: gait table)", fontsize=9, loc="left")
    hax.tick_params(labelsize=7)
    hax.grid(alpha=0.25)
    if handles:
        hax.legend(handles=handles, fontsize=6.5, loc="upper left", frameon=False)
    return fig


def _rect(x, y, w, h, color, hatch=None):
    from matplotlib.patches import Rectangle

    return Rectangle((x, y), w, h, facecolor=color, edgecolor="white" if hatch else "none",
                     hatch=hatch, lw=0.0, clip_on=True)


def gait_diagram(motion, path: str | os.PathLike, *, start: float = 0.0,
                 stop: float | None = None, title: str | None = None,
                 gaits: dict | None = None, character=None, dpi: int = 110,
                 figsize: tuple[float, float] | None = None) -> Path:
    """Write the gait diagram of a motion to an image file, atomically.

    Parameters
    ----------
    motion : Motion or FootfallData
    path : str or path-like
        ``.png``, ``.svg`` or ``.pdf`` (the format follows the extension).
    start, stop, title, gaits, character, figsize
        See :func:`gait_figure`.
    dpi : int
        Resolution of a PNG.

    Returns
    -------
    Path
        The file written.

    Raises
    ------
    ValueError
        For an unsupported extension (the message lists the supported ones).
    """
    path = Path(path)
    fmt = FORMATS.get(path.suffix.lower())
    if fmt is None:
        kind = f"{path.suffix} files" if path.suffix else "files without an extension"
        raise ValueError(f"cannot write a gait diagram to {kind} ({str(path)!r}); "
                         f"supported: {', '.join(FORMATS)}")
    fig = gait_figure(motion, start=start, stop=stop, title=title, gaits=gaits,
                      character=character, figsize=figsize)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as f:
            fig.savefig(f, format=fmt, dpi=dpi, metadata=_metadata(fmt))
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise
    return path


def _metadata(fmt: str) -> dict:
    """File metadata without dates, so the same motion gives the same file."""
    if fmt == "png":
        return {"Software": "quadsim"}
    if fmt == "pdf":
        return {"Creator": "quadsim", "Producer": "quadsim", "CreationDate": None}
    return {"Creator": "quadsim", "Date": None}
