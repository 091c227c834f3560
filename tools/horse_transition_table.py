"""Asynchronous vs synchronous gait transitions of the data-driven horse, as a markdown table.

Every ordered pair of the six horse gaits (30 pairs), each transition started
at four phases of the old gait's cycle (t_start = 0, 0.25, 0.5, 0.75 cycles):
120 transitions per set, each made twice -- asynchronous time warping
(:func:`quadsim.horse.timewarp.transition_motion`) and the synchronous
baseline (:func:`~quadsim.horse.timewarp.synchronous_transition`) -- and
measured on the produced motion (:func:`~quadsim.analysis.transitions.transition_quality`):

* slide: largest horizontal travel of a foot from its touchdown place during
  a contact, contacts measured from the foot positions (low and slow, trimmed
  to the on-ground band), over the whole motion (mm);
* raw: the same on the blend before the stance feet are held by IK (root
  still moved by the landing feet, equation 11) -- how well the blend itself
  keeps its feet;
* accel: largest joint angular acceleration over the larger steady maximum
  of the two clips;
* strides: left-hind strides from the blend's start until the new gait's
  footfall pattern holds for good (phases within 0.06 of a stride);
* below each table: the deepest foot below the ground, and a stricter slide
  counting a foot as down whenever it is within 3 mm of the ground.

Two sets: ``db`` -- the database clips, the old gait's fastest clip to the new
gait's slowest; ``expanded`` -- clips expanded to speeds across each gait's
range (:func:`quadsim.horse.speed.expand`, as the controller does), the old
gait from slow to fast and the new one from fast to slow over the four
phases. Per pair the table shows the worst of the four phases.

Usage::

    python tools/horse_transition_table.py [--set db|expanded|both] [--out FILE.md]
"""

from __future__ import annotations

import argparse
import itertools
import sys
import time

import numpy as np

from quadsim.analysis.transitions import transition_quality
from quadsim.horse.speed import expand
from quadsim.horse.timewarp import transition_motion
from quadsim.io.clips import load_default_database
from quadsim.skeleton.character import load_character

GAITS = ("walk", "amble", "trot", "rack", "canter", "gallop")
PHASES = (0.0, 0.25, 0.5, 0.75)
#: Speed range (m/s) of each gait for the expanded set: GAITS.md's horse
#: speeds, the gallop capped at the controller's reach (1.4 x its 11 m/s clip).
RANGES = {"walk": (1.4, 1.8), "amble": (2.7, 3.8), "trot": (2.5, 6.5),
          "rack": (2.9, 5.5), "canter": (4.4, 7.5), "gallop": (9.0, 15.0)}
#: Gaits expanded relative to their clip (as the controller's CLIP_ANCHORED).
CLIP_ANCHORED = ("amble", "gallop")
SLIDE_MAX = 0.005
ACCEL_MAX = 3.0
STRIDES_MAX = 3


def cases(db, character, which: str):
    """Yield ``(g1, g2, t_start, clip1, clip2)`` for the 120 transitions of a set."""
    cache = {}

    def ex(g, v):
        if (g, v) not in cache:
            anchor = "clip" if g in CLIP_ANCHORED else "law"
            cache[(g, v)] = expand(db.nearest(g, v), character, float(v), anchor=anchor)
        return cache[(g, v)]

    for g1, g2 in itertools.permutations(GAITS, 2):
        for k, ph in enumerate(PHASES):
            if which == "db":
                c1, c2 = db.by_gait(g1)[-1], db.by_gait(g2)[0]
            else:
                c1 = ex(g1, np.linspace(*RANGES[g1], len(PHASES))[k])
                c2 = ex(g2, np.linspace(*RANGES[g2], len(PHASES))[len(PHASES) - 1 - k])
            yield g1, g2, ph, c1, c2


def measure(character, c1, c2, t_start: float) -> dict:
    """Quality of the asynchronous and synchronous transitions, pinned and raw."""
    out = {}
    for mode, sync in (("async", False), ("sync", True)):
        m = transition_motion(character, c1, c2, t_start=t_start, synchronous=sync)
        q = transition_quality(m, c1, c2)
        raw = transition_motion(character, c1, c2, t_start=t_start, synchronous=sync, pin=False)
        q["raw"] = transition_quality(raw, c1, c2)["slide"]
        out[mode] = q
    return out


def table(rows: list[dict], title: str) -> str:
    """Markdown: one row per ordered pair (worst of its phases), then summary rows."""
    lines = [f"### {title}", "",
             "| transition | speeds (m/s) | slide async | slide sync | raw async | raw sync "
             "| accel async | accel sync | strides async | strides sync |",
             "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    pairs = dict.fromkeys((r["g1"], r["g2"]) for r in rows)
    for g1, g2 in pairs:
        rs = [r for r in rows if (r["g1"], r["g2"]) == (g1, g2)]
        v1 = sorted({r["v1"] for r in rs})
        v2 = sorted({r["v2"] for r in rs})
        sp = (f"{v1[0]:.1f}" if len(v1) == 1 else f"{v1[0]:.1f}-{v1[-1]:.1f}") + " -> " + \
             (f"{v2[0]:.1f}" if len(v2) == 1 else f"{v2[0]:.1f}-{v2[-1]:.1f}")
        cell = []
        for key, scale, fmt in (("slide", 1000, "{:.1f}"), ("raw", 1000, "{:.0f}"),
                                ("accel_ratio", 1, "{:.2f}")):
            for mode in ("async", "sync"):
                cell.append(fmt.format(max(r[mode][key] for r in rs) * scale))
        for mode in ("async", "sync"):
            s = [r[mode]["strides"] for r in rs]
            cell.append("never" if any(x is None for x in s) else str(max(s)))
        lines.append(f"| {g1} -> {g2} | {sp} | " + " | ".join(cell) + " |")
    n = len(rows)

    def col(mode, key):
        return np.array([r[mode][key] for r in rows], dtype=float)

    summ = {}
    for mode in ("async", "sync"):
        sl, raw, acc = col(mode, "slide") * 1000, col(mode, "raw") * 1000, col(mode, "accel_ratio")
        st = [r[mode]["strides"] for r in rows]
        ok_st = [x for x in st if x is not None]
        summ[mode] = {
            "median": (f"{np.median(sl):.1f}", f"{np.median(raw):.0f}", f"{np.median(acc):.2f}",
                       str(int(np.median(ok_st))) if ok_st else "never"),
            "max": (f"{sl.max():.1f}", f"{raw.max():.0f}", f"{acc.max():.2f}",
                    "never" if len(ok_st) < n else str(max(ok_st))),
            "count": (f"{int((sl < SLIDE_MAX * 1000).sum())}/{n} < 5 mm",
                      f"{int((raw < SLIDE_MAX * 1000).sum())}/{n} < 5 mm",
                      f"{int((acc < ACCEL_MAX).sum())}/{n} < 3x",
                      f"{sum(x is not None and x <= STRIDES_MAX for x in st)}/{n} <= 3"),
        }
    for label, key in (("**median**", "median"), ("**max**", "max"), ("**passing**", "count")):
        a, s = summ["async"][key], summ["sync"][key]
        lines.append(f"| {label} (all {n}) | | {a[0]} | {s[0]} | {a[1]} | {s[1]} | {a[2]} | {s[2]} "
                     f"| {a[3]} | {s[3]} |")
    pa, ps = (max(r[mode]["penetration"] for r in rows) * 1000 for mode in ("async", "sync"))
    lines += ["", f"Deepest foot below the ground: {pa:.1f} mm asynchronous, {ps:.1f} mm "
              "synchronous."]
    sk = {mode: col(mode, "skim") * 1000 for mode in ("async", "sync")}
    lines += [f"Stricter slide (a foot counted as down whenever it is within 3 mm of the "
              f"ground, whatever its speed; catches a foot grazing the ground as it lands): "
              f"asynchronous median {np.median(sk['async']):.1f} mm, "
              f"max {sk['async'].max():.1f} mm, "
              f"{int((sk['async'] < 5).sum())}/{n} < 5 mm; synchronous median "
              f"{np.median(sk['sync']):.1f} mm, max {sk['sync'].max():.1f} mm, "
              f"{int((sk['sync'] < 5).sum())}/{n} < 5 mm.", ""]
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--set", choices=("db", "expanded", "both"), default="both")
    ap.add_argument("--out", help="also write the table to this file")
    args = ap.parse_args(argv)
    character = load_character("horse")
    db = load_default_database(character)
    sets = ("db", "expanded") if args.set == "both" else (args.set,)
    titles = {"db": "Database clips (old gait's fastest clip -> new gait's slowest), "
                    "4 start phases",
              "expanded": "Clips expanded across each gait's speed range, 4 start phases"}
    t0 = time.perf_counter()
    parts = ["## Horse gait transitions: asynchronous vs synchronous time warping", "",
             "slide: largest foot travel during a contact measured from the motion (mm); "
             "raw: the same before stance feet are held by IK (mm); accel: peak joint angular "
             "acceleration / larger steady-clip maximum; strides: left-hind strides from the "
             "blend's start to the new footfall pattern. Per pair: worst of the 4 start phases "
             "(t_start = 0, 0.25, 0.5, 0.75 cycles).", ""]
    for which in sets:
        rows = []
        for g1, g2, ph, c1, c2 in cases(db, character, which):
            r = measure(character, c1, c2, ph)
            rows.append({"g1": g1, "g2": g2, "t_start": ph, "v1": c1.speed, "v2": c2.speed, **r})
        parts.append(table(rows, titles[which]))
    parts.append(f"({time.perf_counter() - t0:.0f} s)")
    text = "\n".join(parts) + "\n"
    sys.stdout.write(text)
    if args.out:
        with open(args.out, "w", encoding="utf-8") as f:
            f.write(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
