"""`quadsim clips-from`: cut a clip database for the data mode out of long mocap takes.

``quadsim clips-from TAKE.bvh [TAKE.bvh ...] --character CHARACTER.toml --out DIR``
reads each take onto the character's skeleton by joint name, finds the steady
runs of each gait from the measured footfalls, cuts a looped cycle out of
each, fits each gait's contact-time law ``Tc = a v^b`` to the steady strides
and writes the clips and their ``manifest.toml`` into ``DIR``
(:mod:`quadsim.io.takes`). Naming ``DIR`` in the character file's
``[character]`` table (``clips = "DIR"``, relative to the file) makes
``quadsim run CHARACTER.toml --mode data`` play it.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

from quadsim.errors import InputError

__all__ = ["clips_from_command", "register"]


def _report(cut, out: Path) -> list[str]:
    lines = [f"{len(cut.strides)} strides measured; {len(cut.clips)} clip(s):"]
    for c in cut.clips:
        td = " ".join(f"{leg}={int(x)}" for leg, x in zip(("LF", "RF", "LH", "RH"), c.touchdown))
        lead = f", {c.lead} lead" if c.lead else ""
        lines.append(f"  {c.name}: {c.gait}{lead}, {c.speed:.3f} m/s, {c.frames} frames "
                     f"({c.frames / c.motion.fps:.3f} s), touchdowns {td}, loop error "
                     f"{c.loop_error_deg:.1f} deg, from {Path(c.take).name} at "
                     f"{c.start_time:.2f} s ({c.strides} steady strides)")
    lines.append("contact-time laws Tc = a v^b (s, m/s):")
    for g, law in cut.laws.items():
        n, lo, hi, rms = cut.fits[g]
        lines.append(f"  {g}: a = {law.a:.4g}, b = {law.b:.4g} (fitted to {n} strides at "
                     f"{lo:.3g}-{hi:.3g} m/s, rms {rms:.3f} in log Tc)")
    lines += [f"  note: {n}" for n in cut.notes]
    return lines


def clips_from_command(args) -> int:
    """Read the takes, cut the database, write it, print what was found."""
    from quadsim.io.takes import cut_database, read_take, smooth_take, write_database
    from quadsim.skeleton.character import characters_dir, load_character

    if not 0.0 <= args.smooth <= 10.0:
        raise InputError(f"`--smooth` {args.smooth!r}: give a Gaussian width in frames, "
                         "0 (none) to 10")
    character = load_character(args.character)
    roll = float(character.locomotion.get("toe_roll_deg", 0.0))
    if roll > 0.0:
        print(f"quadsim: warning: {args.character}: its paws roll over their toe tips at "
              f"push-off (toe_roll_deg = {roll:g}), and clips-from finds a take's contacts at "
              "its foot joints, which rise through the last 60 % of such a stance: stances "
              "read short and a walk may not be found (cut takes of flat-footed motion, or "
              "a character whose toe_roll_deg is 0)", file=sys.stderr)
    takes = []
    for t in args.takes:
        p = Path(t)
        if p.suffix.lower() != ".bvh":
            raise InputError(f"{p}: `quadsim clips-from` reads BVH takes (.bvh)")
        if not p.is_file():
            raise InputError(f"{p}: no such take")
        takes.append((str(p), smooth_take(read_take(p, character), args.smooth)))
    cut = cut_database(takes, character)
    out = write_database(cut, Path(args.out), [str(Path(t).resolve()) for t in args.takes])
    print("\n".join(_report(cut, out)))
    path = None if character.path is None else Path(character.path).resolve()
    if path is not None and path.parent != characters_dir().resolve():
        ref = os.path.relpath(out.resolve(), path.parent)
        print(f"wrote {out}; to play it, add `clips = \"{ref}\"` to the [character] table of "
              f"{character.path} and run `quadsim run {character.path} --mode data --speed V`")
    else:
        print(f"wrote {out}; to play it, copy the character file {path or character.id} "
              "beside it under a name and `id` of your own, add `clips = \"<this folder, "
              "relative to the copy>\"` to its [character] table and run `quadsim run "
              "COPY.toml --mode data --speed V`")
    return 0


def register(sub) -> None:
    """Add the ``clips-from`` sub-command to the ``quadsim`` parser's sub-parsers ``sub``."""
    cf = sub.add_parser("clips-from", help="cut a clip database for the data mode out of your "
                        "own long mocap takes (BVH)",
                        description="Read long takes onto a character by joint name, cut "
                        "steady looped cycles out of them, label their gaits and touchdowns "
                        "from the measured footfalls, fit each gait's contact-time law and "
                        "write a clip database (BVH clips and manifest.toml) for "
                        "`--mode data`.")
    cf.add_argument("takes", nargs="+", metavar="TAKE.bvh")
    cf.add_argument("--character", required=True, metavar="CHARACTER.toml|ID",
                    help="the character the takes are read onto (a character file or a "
                    "built-in character's identifier)")
    cf.add_argument("--out", required=True, metavar="DIR",
                    help="folder to write the clip database into (replaced when it holds one)")
    cf.add_argument("--smooth", type=float, default=0.0, metavar="FRAMES",
                    help="low-pass the takes with a Gaussian of this many frames first "
                    "(noisy capture; default 0: as recorded)")
    cf.set_defaults(func=clips_from_command)
