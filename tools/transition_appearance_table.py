"""What a viewer sees through every ordered gait change, both modes, measured from the motion.

::

    python tools/transition_appearance_table.py [--character ID ...] [--json FILE]

Each procedural character runs gait A at its preferred speed, is asked for gait
B (at B's preferred speed) after 4 s plus a step through the stride (0.137 s
times the pair's index modulo 7, as tests/test_locomotion_quality.py asks its
changes), and runs 6 s more; the data-driven horse does the same between its
clip gaits at the mean speed of each gait's clips. Every ordered pair of a
character's gaits is measured (:func:`quadsim.analysis.appearance.appearance_report`)
over the motion from 0.5 s before the request to its end -- the change and
the new gait settling -- on the issue's figures: peak joint speed (deg/s),
foot speed over body speed at touchdown and in the first frame after
lift-off (90th percentiles), the deepest toe tip below the ground and the toe
tips' slide in stance (90th percentile, mm), and the elbows' and knees' share
of swing frames locked straight (>= 177 deg).

The table lists per character the worst pair for each figure and how many
pairs stay within the issue's bounds (:data:`BOUNDS`) on each; ``--json``
writes every pair's figures.
"""

from __future__ import annotations

import argparse
import itertools
import json
import sys
import warnings

import numpy as np

#: The issue's bounds (figure, largest allowed): joint speed 2,000 deg/s, touchdown
#: 0.3 and lift-off 0.6 of the body speed, toe tip 3 mm deep, slide 5 mm, elbows and
#: knees straight in under 5 % of swing frames.
BOUNDS = {"peak_joint_speed_deg_s": 2000.0, "touchdown_speed_ratio_p90": 0.3,
          "liftoff_speed_ratio_p90": 0.6, "toe_below_ground_any_frame_mm": 3.0,
          "toe_slide_mm_p90": 5.0, "elbow_knee_locked_fraction": 0.05}
SHORT = {"peak_joint_speed_deg_s": ("w max", ".0f"), "touchdown_speed_ratio_p90": ("td", ".2f"),
         "liftoff_speed_ratio_p90": ("lo", ".2f"),
         "toe_below_ground_any_frame_mm": ("toe-", ".1f"),
         "toe_slide_mm_p90": ("slide", ".1f"), "elbow_knee_locked_fraction": ("ek", ".3f")}
#: Seconds in the old gait before the request (plus the pair's step through the stride).
BEFORE = 4.0
#: Seconds run after the request.
AFTER = 6.0
FPS = 60.0
CHARACTERS = ("leopard", "leopard_cub", "dog_cub", "horse")


def _procedural_pairs(cid: str):
    from quadsim import load_character
    from quadsim.locomotion.gaits import gait_table

    table = gait_table(load_character(cid))
    return [(a, b, table[a].preferred_speed, table[b].preferred_speed)
            for a, b in itertools.permutations(list(table), 2)]


def _data_pairs():
    from quadsim import load_character
    from quadsim.io.clips import load_default_database

    db = load_default_database(load_character("horse"))
    speed = {g: float(np.mean([c.speed for c in db.by_gait(g)])) for g in db.gaits
             if g != "leap"}
    return [(a, b, speed[a], speed[b]) for a, b in itertools.permutations(list(speed), 2)]


def measure_pair(cid: str, mode: str, k: int, a: str, b: str, va: float, vb: float) -> dict:
    """The figures of one ordered change ``a -> b`` (the ``k``-th pair)."""
    from quadsim import load_character, simulate
    from quadsim.analysis.appearance import appearance_report
    from quadsim.commands import Command, Script

    t_req = BEFORE + 0.137 * (k % 7)
    script = Script((0.0, t_req), (Command(speed=va, gait=a), Command(speed=vb, gait=b)))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m = simulate(load_character(cid), script, seconds=t_req + AFTER, fps=FPS, mode=mode)
        r = appearance_report(m, start=t_req - 0.5)
    out = {"character": cid, "mode": mode, "from": a, "to": b, "request_s": t_req}
    out.update({key: r.get(key) for key in BOUNDS})
    out["peak_joint"] = r.get("peak_joint")
    return out


def cases(characters) -> list[tuple]:
    """(character, mode, k, a, b, speed a, speed b) of every pair measured."""
    out = []
    for cid in characters:
        out += [(cid, "procedural", k, *p) for k, p in enumerate(_procedural_pairs(cid))]
    if "horse" in characters:
        out += [("horse", "data", k, *p) for k, p in enumerate(_data_pairs())]
    return out


def _within(row: dict, key: str) -> bool:
    v = row[key]
    return v is not None and v <= BOUNDS[key]


def table(rows: list[dict]) -> str:
    """Per character and mode: the worst pair of each figure, and the pairs within bounds."""
    lines = [f"{'character':22s} {'pairs':>5s} " + " ".join(
        f"{SHORT[k][0]:>24s}" for k in BOUNDS) + "   all in"]
    groups: dict[tuple, list] = {}
    for r in rows:
        groups.setdefault((r["character"], r["mode"]), []).append(r)
    for (cid, mode), rs in groups.items():
        cells = []
        for key in BOUNDS:
            vals = [r for r in rs if r[key] is not None]
            if not vals:
                cells.append(f"{'-':>24s}")
                continue
            worst = max(vals, key=lambda r: r[key])
            n_in = sum(_within(r, key) for r in rs)
            txt = f"{format(worst[key], SHORT[key][1])} {worst['from'][:5]}>{worst['to'][:5]} {n_in}/{len(rs)}"
            cells.append(f"{txt:>24s}")
        all_in = sum(all(_within(r, k) for k in BOUNDS) for r in rs)
        name = cid if mode == "procedural" else f"{cid} (data)"
        lines.append(f"{name:22s} {len(rs):5d} " + " ".join(cells) + f"   {all_in}/{len(rs)}")
    return "\n".join(lines)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--character", nargs="*", default=list(CHARACTERS))
    p.add_argument("--json", help="write every pair's figures here")
    args = p.parse_args(argv)
    rows = [measure_pair(*c) for c in cases(args.character)]
    print(table(rows))
    print("cells: the worst pair's figure, the pair, and pairs within the bound "
          + ", ".join(f"{SHORT[k][0]} <= {v:g}" for k, v in BOUNDS.items()))
    if args.json:
        with open(args.json, "w", encoding="utf-8") as f:
            json.dump(rows, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
