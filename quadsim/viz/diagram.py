"""Gait diagrams: footfalls, a Hildebrand plot, CPG phases and the spine.

The diagram is *measured* (see :mod:`quadsim.viz.footfalls`): stance bars
come from the motion's foot positions, never from the generator's planned
contacts.

Two layers:

- :func:`~quadsim.viz.footfalls.footfall_data` (in
  :mod:`quadsim.viz.footfalls`, re-exported here) is pure numpy: it returns a
  :class:`FootfallData`
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
from pathlib import Path

import numpy as np

from quadsim.frames import LEGS
from quadsim.io.atomic import atomic_output
from quadsim.viz.footfalls import (
    IRREGULAR,
    MATCH_LIMIT,
    FootfallData,
    Segment,
    _nanmean,
    classify_strides,
    footfall_data,
    phase_distance,
    reference_gaits,
)

__all__ = ["FORMATS", "IRREGULAR", "MATCH_LIMIT", "FootfallData", "Segment",
           "classify_strides", "footfall_data", "gait_diagram", "gait_figure", "phase_distance",
           "reference_gaits"]

_LH = LEGS.index("LH")
_LF = LEGS.index("LF")
#: File formats :func:`gait_diagram` writes, by extension.
FORMATS = {".png": "png", ".svg": "svg", ".pdf": "pdf"}
#: Bar colour of each leg (left legs warm, right legs cool; fore darker).
LEG_COLORS = ("#b5471b", "#1f5f8b", "#e08a3c", "#5b9bd5")
#: Colour of each gait in the plots.
GAIT_COLORS = {
    "walk": "#4c9f38", "amble": "#9bbb2f", "trot": "#2878b5", "rack": "#7a5cb0",
    "pace": "#b05c9a", "canter": "#e3a21a", "transverse_gallop": "#d1495b",
    "rotary_gallop": "#8c2d2d",
}


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
    InputError
        When the file cannot be written (a full disk, a read-only file); an
        existing file is left as it was. A symbolic link is written through.
    """
    path = Path(path)
    fmt = FORMATS.get(path.suffix.lower())
    if fmt is None:
        kind = f"{path.suffix} files" if path.suffix else "files without an extension"
        raise ValueError(f"cannot write a gait diagram to {kind} ({str(path)!r}); "
                         f"supported: {', '.join(FORMATS)}")
    fig = gait_figure(motion, start=start, stop=stop, title=title, gaits=gaits,
                      character=character, figsize=figsize)
    with atomic_output(path, make_folder=True) as tmp:
        fig.savefig(tmp, format=fmt, dpi=dpi, metadata=_metadata(fmt))
    return path


def _metadata(fmt: str) -> dict:
    """File metadata without dates, so the same motion gives the same file."""
    if fmt == "png":
        return {"Software": "quadsim"}
    if fmt == "pdf":
        return {"Creator": "quadsim", "Producer": "quadsim", "CreationDate": None}
    return {"Creator": "quadsim", "Date": None}
