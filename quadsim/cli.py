"""The ``quadsim`` command.

::

    quadsim run CONFIG [--out FILE.bvh] [--seconds S] [--fps N] [--speed M_PER_S]
                       [--gait NAME] [--turn-rate DEG_PER_S] [--units m|cm]
    quadsim characters
    quadsim validate CONFIG
    quadsim metrics FILE.bvh [--json] [--start S] [--units m|cm]

Exit status 0 on success and 2 on bad input (a bad config, flag or file),
with a one-paragraph message on stderr that starts with ``quadsim: error:``.
Output files are written atomically, and only after the motion has been
generated, so a failed run never leaves a partial file or clobbers an old one.
Heavy modules are imported inside the command that needs them.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import warnings
from pathlib import Path

from quadsim.errors import InputError

PROG = "quadsim"


class _UsageError(Exception):
    """A command-line syntax error found by argparse."""


class _Parser(argparse.ArgumentParser):
    """An argument parser that reports errors to ``main`` instead of exiting."""

    def error(self, message: str):
        raise _UsageError(f"{message} (see `{self.prog} --help`)")


# ------------------------------------------------------------------ writers
def _write_bvh(motion, path: Path, units: str) -> None:
    from quadsim.io.bvh import write_bvh

    write_bvh(motion, path, units=units)


#: Output writers by file extension: ``writer(motion, path, units)``.
WRITERS = {".bvh": _write_bvh}


def _writer_for(path: Path):
    ext = path.suffix.lower()
    if ext not in WRITERS:
        kind = f"{ext} files" if ext else "files without an extension"
        raise InputError(f"`--out` {str(path)!r}: cannot write {kind}; "
                         f"supported: {', '.join(sorted(WRITERS))}")
    return WRITERS[ext]


# ------------------------------------------------------------------ commands
def cmd_run(args) -> int:
    from quadsim.config import load_config, with_overrides

    config = load_config(args.config)
    config = with_overrides(config, duration=args.seconds, fps=args.fps, units=args.units,
                            speed=args.speed, gait=args.gait,
                            turn_rate_deg_s=args.turn_rate)
    out = Path(args.out) if args.out is not None else Path("out") / f"{Path(args.config).stem}.bvh"
    write = _writer_for(out)
    if out.is_dir():
        raise InputError(f"`--out` {str(out)!r} is a folder; give a file name")
    character = config.load_character()

    from quadsim.locomotion import simulate

    # Warnings (a command clamped to what the character can do) as one line each.
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        motion = simulate(character, config.commands, config.duration, config.fps,
                          seed=config.seed)
    for w in caught:
        print(f"{PROG}: warning: {w.message}", file=sys.stderr)
    out.parent.mkdir(parents=True, exist_ok=True)
    write(motion, out, config.units)
    gaits = _gaits_used(motion)
    print(f"wrote {out}: {motion.n_frames} frames, {config.duration:g} s at "
          f"{config.fps:g} fps, {character.id}, gaits: {', '.join(gaits) or 'none'}")
    return 0


def cmd_characters(args) -> int:
    from quadsim.locomotion.gaits import gait_table
    from quadsim.skeleton.character import list_characters, load_character

    rows, gait_lines = [], []
    for cid in list_characters():
        c = load_character(cid)
        rows.append((c.id, c.name, f"{c.shoulder_height:.2f}", f"{c.hip_height:.2f}",
                     f"{c.mass:g}", str(c.skeleton.n_joints)))
        gait_lines.append(", ".join(f"{g.name} {g.speed_range[0]:.1f}-{g.speed_range[1]:.1f}"
                                    for g in gait_table(c).values()))
    head = ("id", "name", "shoulder (m)", "hip (m)", "mass (kg)", "joints")
    widths = [max(len(r[i]) for r in [head, *rows]) for i in range(len(head))]

    def line(r):
        return "  ".join(s.ljust(w) if i < 2 else s.rjust(w)
                         for i, (s, w) in enumerate(zip(r, widths))).rstrip()

    print(line(head))
    for r, gaits in zip(rows, gait_lines):
        print(line(r))
        print(" " * (widths[0] + 2) + f"gaits (m/s): {gaits}")
    return 0


def cmd_validate(args) -> int:
    from quadsim.config import load_config

    config = load_config(args.config)
    commands = config.commands.commands
    speeds = [c.speed for c in commands]
    named = sorted({c.gait for c in commands if c.gait})
    if not named:
        gaits = "chosen by speed"
    elif all(c.gait for c in commands):
        gaits = ", ".join(named)
    else:
        gaits = ", ".join(named) + ", others chosen by speed"
    print(f"ok: {args.config}")
    print(f"  character {config.character}; {config.duration:g} s at {config.fps:g} fps "
          f"({config.n_frames} frames); seed {config.seed}; mode {config.mode}; "
          f"units {config.units}")
    print(f"  {len(commands)} command(s); speeds {min(speeds):.2f} to {max(speeds):.2f} m/s; "
          f"gaits: {gaits}")
    return 0


def cmd_metrics(args) -> int:
    from quadsim.analysis.metrics import format_report, motion_report
    from quadsim.io.bvh import read_bvh

    path = Path(args.file)
    if not path.is_file():
        raise InputError(f"{path}: no such file")
    if not (math.isfinite(args.start) and args.start >= 0):
        raise InputError(f"`--start` = {args.start}: must be a time >= 0 s")
    motion = read_bvh(path, units=args.units)
    report = motion_report(motion, start=args.start)
    if args.json:
        print(json.dumps(report, indent=2, default=_json_default))
    else:
        print(format_report(report))
    return 0


def _json_default(o):
    """Numpy scalars and arrays as plain JSON values."""
    if hasattr(o, "tolist"):
        return o.tolist()
    raise TypeError(f"{type(o).__name__} is not JSON serialisable")


def _gaits_used(motion) -> list[str]:
    """Steady gaits in the order they first appear (transition labels skipped)."""
    if motion.gaits is None:
        return []
    seen: list[str] = []
    for g in motion.gaits:
        g = str(g)
        if g and "->" not in g and g not in seen:
            seen.append(g)
    return seen


# ------------------------------------------------------------------- parser
def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog=PROG, description="Kinematic quadruped locomotion: generate, check and "
                "measure gaits.")
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND",
                           parser_class=_Parser)

    r = sub.add_parser("run", help="generate a motion from a config and write it to a file",
                       description="Generate a motion from a config file and write it. "
                       "--speed/--gait/--turn-rate replace the config's commands with one "
                       "constant command; --gait alone uses that gait's preferred speed.")
    r.add_argument("config", metavar="CONFIG", help="run configuration (TOML)")
    r.add_argument("--out", metavar="FILE",
                   help="output file, by extension: .bvh (default out/<config name>.bvh)")
    r.add_argument("--seconds", type=float, metavar="S", help="duration (s), replaces the config's")
    r.add_argument("--fps", type=float, metavar="N", help="frames per second")
    r.add_argument("--speed", type=float, metavar="M_PER_S", help="constant speed (m/s)")
    r.add_argument("--gait", metavar="NAME", help="constant gait (walk, trot, gallop, ...)")
    r.add_argument("--turn-rate", type=float, metavar="DEG_PER_S",
                   help="constant turn rate (deg/s, positive turns left)")
    r.add_argument("--units", choices=("m", "cm"), help="length unit of the output file")
    r.set_defaults(func=cmd_run)

    c = sub.add_parser("characters", help="list the shipped characters and their gaits")
    c.set_defaults(func=cmd_characters)

    v = sub.add_parser("validate", help="check a config file without running it")
    v.add_argument("config", metavar="CONFIG")
    v.set_defaults(func=cmd_validate)

    m = sub.add_parser("metrics", help="measure a motion file: footfalls, slide, "
                       "penetration, speed")
    m.add_argument("file", metavar="FILE.bvh")
    m.add_argument("--json", action="store_true", help="print the report as JSON")
    m.add_argument("--start", type=float, default=0.0, metavar="S",
                   help="ignore the first S seconds (default 0)")
    m.add_argument("--units", choices=("m", "cm"), default="m",
                   help="length unit of the file (default m)")
    m.set_defaults(func=cmd_metrics)
    return p


def main(argv: list[str] | None = None) -> int:
    """Run the ``quadsim`` command; returns the exit status."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
        return int(args.func(args) or 0)
    except SystemExit as e:  # --help
        return e.code if isinstance(e.code, int) else 0
    except (_UsageError, InputError) as e:
        return _fail(str(e))
    except BrokenPipeError:  # e.g. `quadsim characters | head`: stop quietly
        try:
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, sys.stdout.fileno())
        except (OSError, ValueError):
            pass
        return 1
    except FileNotFoundError as e:
        return _fail(f"{e.filename or ''}: no such file or folder".lstrip(": "))
    except OSError as e:
        return _fail(f"{e.filename + ': ' if e.filename else ''}{e.strerror or e}")
    except KeyboardInterrupt:
        print(f"{PROG}: interrupted", file=sys.stderr)
        return 130


def _fail(message: str) -> int:
    print(f"{PROG}: error: {' '.join(message.split())}", file=sys.stderr)
    return 2
