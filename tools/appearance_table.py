"""Print what a viewer sees of every character and gait, measured from the motion.

::

    python tools/appearance_table.py [--seconds 10] [--fps 60] [--json FILE] [--markdown]

Each character runs each of its gaits at the gait's preferred speed (the
data-driven horse at four speeds); the first 3 s are left out. Columns (see
:mod:`quadsim.analysis.appearance`): stride over hip height against
Alexander's law, scaled cadence, trunk pitch, heave and spine flexion ranges,
head pitch range, the deepest toe tip and its slide, foot speed over body
speed at touchdown (ground and descent) and after lift-off, the fore and hind legs'
angles from the vertical at touchdown and lift-off (medians, toe ahead positive), the
flight phases' vertical
acceleration (median, g), peak joint speed and the worst hinge's locked share
of swing frames, and the worst elbow's or knee's, locked and at 170 degrees or more. ``--markdown`` also prints the README's table (the walk, trot
and rotary gallop of each character) from the same figures. ``--fps`` runs
and measures at another frame rate: a motion whose figures grow with it (a
joint's peak speed, the trunk's jolt) has a jump in rate the 60 fps frames
smear out.
"""

from __future__ import annotations

import argparse
import json
import sys
import warnings

import numpy as np

import quadsim
from quadsim.errors import InputError
from quadsim.analysis.appearance import appearance_report
from quadsim.locomotion.gaits import gait_table

COLUMNS = [("lam/h", "stride_over_h", ".2f"), ("Alex", "alexander_over_h", ".2f"),
           ("cad", "cadence", ".2f"), ("pitch", "trunk_pitch_range_deg", ".1f"),
           ("heave", "trunk_heave_over_h", ".3f"), ("spine", "spine_flexion_range_deg", ".1f"),
           ("head", "head_pitch_range_deg", ".1f"), ("toe-", "toe_below_ground_mm", ".1f"),
           ("slide", "toe_slide_mm_p90", ".1f"), ("td", "touchdown_speed_ratio_p90", ".2f"),
           ("tdv", "touchdown_descent_ratio_p90", ".2f"),
           ("lo", "liftoff_speed_ratio_p90", ".2f"),
           ("F td", "fore_touchdown_angle_deg", "+.0f"), ("F lo", "fore_liftoff_angle_deg", "+.0f"),
           ("H td", "hind_touchdown_angle_deg", "+.0f"), ("H lo", "hind_liftoff_angle_deg", "+.0f"),
           ("fl g", "flight_g", ".2f"),
           ("jolt", "trunk_jolt_g", ".1f"),
           ("w max", "peak_joint_speed_deg_s", ".0f"), ("lock%", "locked_pct", ".1f"),
           ("ek%", "elbow_knee_pct", ".1f"), ("ek170", "elbow_knee_near_pct", ".1f")]


def _cases(seconds: float, fps: int = 60):
    for cid in ("leopard", "leopard_cub", "dog_cub", "horse"):
        for g in gait_table(quadsim.load_character(cid)):  # every gait, the horse's amble and rack
            yield f"{cid} {g}", lambda cid=cid, g=g: quadsim.run(cid, gait=g, seconds=seconds,
                                                                 fps=fps)
    for v in (1.6, 4.0, 6.5, 12.0):
        yield f"horse data {v:g} m/s", lambda v=v: quadsim.run("horse", mode="data", speed=v,
                                                              seconds=seconds, fps=fps)


#: The README table's rows: each character's walk, trot and rotary gallop.
README_GAITS = ("walk", "trot", "rotary_gallop")


def _num(x, fmt: str) -> str:
    return "-" if x is None else format(x, fmt)


def markdown(rows: dict) -> str:
    """The README's table ("How the motion measures") of the measured ``rows``."""
    out = ["| character, gait | stride / h | pitch | spine | flight | touchdown | lift-off "
           "| joint speed | locked | elbows, knees at 170+ |",
           "|---|---|---|---|---|---|---|---|---|---|"]
    for name, r in rows.items():
        cid, _, gait = name.partition(" ")
        if gait not in README_GAITS:
            continue
        acc = r["flight_accel_g"]
        flight = "-" if not acc else (f"{min(acc):.2f}" if max(acc) - min(acc) < 0.005
                                      else f"{min(acc):.2f} to {max(acc):.2f}")
        out.append(
            f"| {cid} {gait.replace('_', ' ')} | {_num(r['stride_over_h'], '.2f')} "
            f"({_num(r['alexander_over_h'], '.2f')}) | {_num(r['trunk_pitch_range_deg'], '.1f')} "
            f"| {_num(r['spine_flexion_range_deg'], '.1f')} | {flight} "
            f"| {_num(r['touchdown_speed_ratio_p90'], '.2f')} / "
            f"{_num(r['touchdown_descent_ratio_p90'], '.2f')} "
            f"| {_num(r['liftoff_speed_ratio_p90'], '.2f')} "
            f"| {_num(r['peak_joint_speed_deg_s'], ',.0f')} | {_num(r['locked_pct'], '.1f')} "
            f"| {_num(r['elbow_knee_near_pct'], '.1f')} |")
    return "\n".join(out)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seconds", type=float, default=10.0)
    p.add_argument("--fps", type=int, default=60, help="frame rate of the runs (default 60)")
    p.add_argument("--json", metavar="FILE")
    p.add_argument("--markdown", action="store_true", help="also print the README's table")
    a = p.parse_args(argv)
    try:  # a run the engine refuses (say --fps 0) is a usage error, not a traceback
        quadsim.run("leopard", gait="walk", seconds=a.seconds, fps=a.fps)
    except InputError as e:
        p.error(str(e))
    rows = {}
    print(f"{'case':30s}" + "".join(f"{h:>7s}" for h, _, _ in COLUMNS))
    for name, make in _cases(a.seconds, a.fps):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            r = appearance_report(make(), start=3.0)
        acc = r["flight_accel_g"]
        r["flight_g"] = float(np.median(acc)) if acc else None
        r["locked_pct"] = None if r["locked_swing_fraction"] is None else \
            100 * r["locked_swing_fraction"]
        r["elbow_knee_pct"] = None if r["elbow_knee_locked_fraction"] is None else \
            100 * r["elbow_knee_locked_fraction"]
        r["elbow_knee_near_pct"] = None if r["elbow_knee_near_straight_fraction"] is None \
            else 100 * r["elbow_knee_near_straight_fraction"]
        rows[name] = r
        print(f"{name:30s}" + "".join(
            f"{'-' if r[k] is None else format(r[k], f):>7s}" for _, k, f in COLUMNS))
    if a.json:
        with open(a.json, "w") as fh:
            json.dump(rows, fh, indent=1)
    if a.markdown:
        print()
        print(markdown(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
