"""Which clips a character's set holds, and making them.

:func:`plan_clip_set` chooses, for a character:

- every gait it has (or those asked for), each at two speeds by default, a third and
  two thirds up its speed range rounded to 0.1 m/s (or the speeds asked for);
- turn loops left and right at two rates per gait by default, 40 % and 80 % of the
  gait's largest turn rate at its slower speed, rounded down to 5 deg/s (or the rates
  asked for that the gait can turn at);
- starts and stops for the walk and the trot (the slowest automatic gait when it has
  neither), at the gait's slower speed;
- transitions both ways between neighbouring automatic gaits (by speed), from the
  faster speed of the slower gait to the slower speed of the faster gait and back.

:func:`make_clip_set` makes the clips (:mod:`quadsim.clipset.clips`) and measures them
(:mod:`quadsim.clipset.measure`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from quadsim.clipset.clips import (
    Clip,
    cycle_clips,
    speed_label,
    start_clip,
    stop_clip,
    transition_clip,
)
from quadsim.errors import InputError

__all__ = ["ClipSetPlan", "make_clip_set", "parse_speeds", "plan_clip_set"]

#: Where the default speeds sit in a gait's speed range.
SPEED_FRACTIONS = (1.0 / 3.0, 2.0 / 3.0)
#: The default turn rates, fractions of the largest at the turn loops' speed.
TURN_FRACTIONS = (0.4, 0.8)
#: Gaits that start from and stop to standing.
START_GAITS = ("walk", "trot")


@dataclass(frozen=True)
class ClipSetPlan:
    """The clips a set will hold.

    Attributes
    ----------
    gaits : tuple of str
    speeds : dict of str to tuple of float
        Loop speeds per gait (m/s, one decimal), slowest first.
    turn_rates : dict of str to tuple of float
        Turn rates per gait (deg/s, > 0; each made left and right) at the gait's
        slowest speed.
    starts : tuple of str
        Gaits with a start and a stop clip.
    transitions : tuple of (str, str)
        Gait pairs with a transition clip, from the first to the second.
    fps : float
    left_out : tuple of str
        What was asked for and left out, and why (turn rates a gait cannot turn at).
    """

    gaits: tuple[str, ...]
    speeds: dict
    turn_rates: dict
    starts: tuple[str, ...]
    transitions: tuple[tuple[str, str], ...]
    fps: float
    left_out: tuple[str, ...] = ()

    def names(self) -> list[str]:
        """Every clip's name, in the set's order."""
        out = []
        for g in self.gaits:
            for v in self.speeds[g]:
                out += [f"{g}_{speed_label(v)}", f"{g}_{speed_label(v)}_inplace"]
            for r in self.turn_rates[g]:
                for side in ("left", "right"):
                    out += [f"{g}_turn_{side}_{round(r)}", f"{g}_turn_{side}_{round(r)}_inplace"]
        out += [f"{k}_{g}" for g in self.starts for k in ("start", "stop")]
        out += [f"{a}_to_{b}" for a, b in self.transitions]
        return out


def parse_speeds(items) -> dict[str, tuple[float, ...]]:
    """``["walk=0.6,1.0", "trot=2"]`` as ``{"walk": (0.6, 1.0), "trot": (2.0,)}``."""
    out: dict[str, tuple[float, ...]] = {}
    for item in items or ():
        gait, eq, values = str(item).partition("=")
        try:
            speeds = tuple(float(v) for v in values.split(",") if v.strip())
        except ValueError:
            speeds = ()
        if not eq or not gait.strip() or not speeds:
            raise InputError(f"`--speeds` {item!r}: give GAIT=SPEED[,SPEED...] in m/s, "
                             "for example walk=0.6,1.0")
        out[gait.strip()] = speeds
    return out


def _default_speeds(g) -> tuple[float, ...]:
    lo, hi = g.speed_range
    out: list[float] = []
    for f in SPEED_FRACTIONS:
        v = round(lo + f * (hi - lo), 1)
        while out and v <= out[-1]:
            v = round(v + 0.1, 1)
        out.append(max(v, 0.1))
    return tuple(out)


def _turn_rates(max_deg: float) -> tuple[float, ...]:
    out: list[float] = []
    for f in TURN_FRACTIONS:
        r = 5.0 * math.floor(f * max_deg / 5.0)
        if r >= 5.0 and r not in out:
            out.append(r)
    return tuple(out) or ((float(math.floor(max_deg)),) if max_deg >= 1.0 else ())


def plan_clip_set(character, *, gaits=None, speeds=None, turn_rates=None,
                  fps: float = 60.0) -> ClipSetPlan:
    """The clips of ``character``'s set (see the module's notes).

    Parameters
    ----------
    character : Character
    gaits : sequence of str, optional
        The gaits to make (default all the character's).
    speeds : dict of str to sequence of float, optional
        Loop speeds (m/s) per gait, replacing that gait's defaults; rounded to 0.1.
    turn_rates : sequence of float, optional
        Turn rates (deg/s) for every gait, replacing the defaults; a rate a gait
        cannot turn at is left out for that gait.
    fps : float

    Raises
    ------
    InputError
        An unknown gait, or a speed a gait is not held at.
    """
    from quadsim.locomotion.controller import ProceduralController
    from quadsim.locomotion.gaits import auto_gaits, gait_table, resolve_gait_name

    if not (isinstance(fps, (int, float)) and math.isfinite(fps) and fps > 0):
        raise InputError(f"`--fps` = {fps!r}: give a positive frame rate")
    table = gait_table(character)
    chosen = tuple(dict.fromkeys(resolve_gait_name(g, character)
                                 for g in (gaits or list(table))))
    asked = {resolve_gait_name(g, character): v for g, v in (speeds or {}).items()}
    left_out = [g for g in asked if g not in chosen]
    if left_out:
        raise InputError(f"`--speeds` names {', '.join(left_out)}, which `--gaits` leaves "
                         f"out; add it to `--gaits` ({','.join(chosen)}) or drop its speeds")
    ctl = ProceduralController(character)
    plan_speeds, plan_turns, left_out = {}, {}, []
    for g in chosen:
        cap = ctl.gait_speed_cap(g)
        vs = asked.get(g) or _default_speeds(table[g])
        vs = tuple(sorted({round(float(v), 1) for v in vs}))
        bad = [v for v in vs if not (0.1 <= v <= cap + 1e-9)]
        if bad:
            raise InputError(f"`--speeds` {g}={','.join(map(str, bad))}: {character.id}'s "
                             f"{g} is held at 0.1-{cap:.1f} m/s (its range "
                             f"{table[g].speed_range[0]:.1f}-{table[g].speed_range[1]:.1f})")
        plan_speeds[g] = vs
        top = math.degrees(ctl.max_turn_rate_at(vs[0]))
        if turn_rates is None:
            plan_turns[g] = _turn_rates(top)
        else:
            rates = [float(r) for r in dict.fromkeys(turn_rates)]
            plan_turns[g] = tuple(r for r in rates if 0 < r <= top + 1e-9)
            cannot = [f"{r:g}" for r in rates if r not in plan_turns[g]]
            if cannot:
                left_out.append(f"{g}: no turn loop at {', '.join(cannot)} deg/s (the {g} "
                                f"turns at up to {top:.0f} deg/s at {vs[0]:.1f} m/s)")
    starts = tuple(g for g in START_GAITS if g in chosen)
    auto = [g for g in auto_gaits(character) if g in chosen]
    if not starts and auto:
        starts = (auto[0],)
    pairs = []
    for a, b in zip(auto[:-1], auto[1:]):
        pairs += [(a, b), (b, a)]
    return ClipSetPlan(chosen, plan_speeds, plan_turns, starts, tuple(pairs), float(fps),
                       tuple(left_out))


def make_clip_set(character, plan: ClipSetPlan, *, progress=None) -> list[tuple[Clip, dict]]:
    """Make and measure every clip of ``plan``.

    Parameters
    ----------
    character : Character
    plan : ClipSetPlan
    progress : callable, optional
        Called with each clip's name as it is made.

    Returns
    -------
    list of (Clip, dict)
        Each clip and its measured figures (:func:`~quadsim.clipset.measure.clip_figures`),
        in :meth:`ClipSetPlan.names` order.
    """
    from quadsim.clipset.measure import clip_figures

    fps = plan.fps
    loops: dict = {}
    made: list[tuple[Clip, dict]] = []

    def add(clip, twin=None):
        if progress is not None:
            progress(clip.name)
        made.append((clip, clip_figures(clip, character, twin=twin)))

    for g in plan.gaits:
        for v in plan.speeds[g]:
            rm, ip, stepper = cycle_clips(character, g, v, fps)
            loops[g, v] = (rm, stepper, stepper.state_copy())
            add(rm)
            add(ip, twin=rm)
        for r in plan.turn_rates[g]:
            for sign in (1.0, -1.0):
                rm, ip, _ = cycle_clips(character, g, plan.speeds[g][0], fps,
                                        turn_deg_s=sign * r)
                add(rm)
                add(ip, twin=rm)

    def loop_at(g, v):
        rm, stepper, saved = loops[g, v]
        stepper.restore(saved)
        return rm, stepper

    for g in plan.starts:
        rm, stepper = loop_at(g, plan.speeds[g][0])
        add(start_clip(character, rm, fps))
        add(stop_clip(character, rm, stepper, fps))
    for a, b in plan.transitions:
        up = plan.speeds[a][0] <= plan.speeds[b][0]     # into the faster gait
        va = plan.speeds[a][-1] if up else plan.speeds[a][0]
        vb = plan.speeds[b][0] if up else plan.speeds[b][-1]
        src, stepper = loop_at(a, va)
        dst = loops[b, vb][0]
        add(transition_clip(character, src, stepper, dst, fps))
    return made
