"""`quadsim clips`: a clip set for game engines (see :mod:`quadsim.clipset`).

::

    quadsim clips CHARACTER|CONFIG|MODEL --out SET.glb|SET.fbx [--speeds GAIT=V[,V...] ...]
                  [--gaits G[,G...]] [--turn-rates DEG_S[,DEG_S...]] [--fps N]

One file of named animations -- every gait's loops with root motion and in
place, turn loops, starts, stops and transitions -- and the sidecar SET.json.
"""

from __future__ import annotations

import sys
from pathlib import Path

from quadsim.errors import InputError

__all__ = ["clips_command", "register"]


def _floats(text: str | None, flag: str) -> list[float] | None:
    if text is None:
        return None
    try:
        out = [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        out = []
    if not out:
        raise InputError(f"`{flag}` {text!r}: give numbers separated by commas, e.g. 20,45")
    return out


def _warn(message: str) -> None:
    print(f"quadsim: warning: {message}", file=sys.stderr)


def _source(source: str):
    """The character and the frame rate (a config's, else 60) of a CLI source."""
    from quadsim.api import DEFAULT_FPS, _is_config, resolve

    config = resolve(source)
    if config.mode != "procedural":
        _warn(f"{source}: a clip set is made by the procedural controller (its stride is "
              f"the CPG's); the config's mode {config.mode!r} does not apply")
    fps = config.fps if _is_config(source) else DEFAULT_FPS
    return config.load_character(), fps


def clips_command(args) -> int:
    """Plan, make, measure and write a clip set; print one line per kind of clip."""
    from quadsim.clipset import make_clip_set, parse_speeds, plan_clip_set, write_clip_set
    from quadsim.clipset.export import FORMATS, require_bpy
    from quadsim.io.atomic import output_path

    out = Path(args.out)
    if out.suffix.lower() not in FORMATS:
        raise InputError(f"`--out` {str(out)!r}: a clip set is written as "
                         f"{' or '.join(FORMATS)}")
    output_path(out)
    if out.suffix.lower() == ".fbx":
        require_bpy()       # before the work
    character, fps = _source(args.source)
    plan = plan_clip_set(character, gaits=args.gaits.split(",") if args.gaits else None,
                         speeds=parse_speeds(args.speeds),
                         turn_rates=_floats(args.turn_rates, "--turn-rates"),
                         fps=args.fps if args.fps is not None else fps)
    for message in plan.left_out:
        _warn(message)
    total = len(plan.names())
    done = [0]

    def progress(name):
        done[0] += 1
        if sys.stderr.isatty():
            print(f"\r{done[0]}/{total} {name:<40}", end="", file=sys.stderr, flush=True)

    made = make_clip_set(character, plan, progress=progress)
    if sys.stderr.isatty():
        print("\r" + " " * 50 + "\r", end="", file=sys.stderr)
    path, side = write_clip_set(character, plan, made, out)
    loops = [(c, f) for c, f in made if c.loop]
    seam = max((c.info["seam_m"] / f["max_step_m"] for c, f in loops if f["max_step_m"] > 0),
               default=0.0)
    wrap = max((f["wrap_step_m"] / f["max_step_m"] for _, f in loops if f["max_step_m"] > 0),
               default=0.0)
    drift = max((f["root_travel_m"] for c, f in loops if not c.root_motion), default=0.0)
    kinds = {}
    for c, _ in made:
        kinds[c.kind] = kinds.get(c.kind, 0) + 1
    print(f"wrote {path}: {len(made)} clips of {character.id} at {plan.fps:g} fps ("
          + ", ".join(f"{n} {k}" for k, n in kinds.items()) + f"); gaits: "
          f"{', '.join(plan.gaits)}")
    print(f"loops: seams at most {seam:.1e} of the loop's largest frame step (the wrap's "
          f"step at most {wrap:.2f} of it), in-place roots move {drift * 1000:.2f} mm at "
          f"most; sidecar {side}")
    return 0


def register(sub) -> None:
    """Add the ``clips`` sub-command to the ``quadsim`` parser's sub-parsers ``sub``."""
    c = sub.add_parser("clips", help="write a clip set for game engines (looped gaits with "
                       "root motion and in place, turns, starts, stops, transitions)",
                       description="One .glb (or .fbx, through Blender's bpy) of named "
                       "animations for every gait of a character -- <gait>_<speed>, "
                       "<gait>_<speed>_inplace, <gait>_turn_left_<deg_s>, start_<gait>, "
                       "stop_<gait>, <gait>_to_<gait> -- every loop whole strides cut at "
                       "the left hind touchdown, and a sidecar SET.json with each clip's "
                       "measured speed, stride, duty factors, phases and frames. A "
                       "character adopted with `quadsim rig` gets its own model back with "
                       "the clips added.")
    c.add_argument("source", metavar="CHARACTER|CONFIG|MODEL")
    c.add_argument("--out", required=True, metavar="SET.glb|SET.fbx")
    c.add_argument("--speeds", nargs="+", metavar="GAIT=V[,V...]",
                   help="loop speeds (m/s, one decimal) of some gaits, e.g. walk=0.6,1.0 "
                   "trot=2.0 (default: two per gait, a third and two thirds up its range)")
    c.add_argument("--gaits", metavar="G[,G...]", help="only these gaits (default all)")
    c.add_argument("--turn-rates", metavar="DEG_S[,DEG_S...]",
                   help="turn loop rates (deg/s) for every gait that turns that fast "
                   "(default 40 %% and 80 %% of each gait's largest)")
    c.add_argument("--fps", type=float, help="frame rate (default the config's, or 60)")
    c.set_defaults(func=clips_command)
