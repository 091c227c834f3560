"""`quadsim retarget`: an animal's gait as a reference motion for a legged robot's URDF.

::

    quadsim retarget CHARACTER|CONFIG --robot URDF [--gait G] [--speed V] [--seconds S]
                     [--fps N] --out REF.json|REF.npz

The animal runs at the same Froude number as the robot (``v_robot = v_animal *
sqrt(h_robot / h_animal)``, hip heights), its stride scaled by the same length
ratio; ``--speed`` and ``--seconds`` are the robot's. A character without
``--gait`` or ``--speed`` trots; a config keeps its own commands (its times in
the animal's time). See :mod:`quadsim.robots.retarget`.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

from quadsim.errors import InputError

__all__ = ["register", "retarget_command"]


def _warn(message: str) -> None:
    print(f"quadsim: warning: {message}", file=sys.stderr)


def _check_out(out: Path) -> None:
    from quadsim.io.atomic import output_path
    from quadsim.robots.reference import FORMATS

    if out.suffix.lower() not in FORMATS:
        kind = f"{out.suffix} files" if out.suffix else "files without an extension"
        raise InputError(f"`--out` {str(out)!r}: cannot write {kind}; a reference is "
                         f"written as {' or '.join(FORMATS)} (REF.json or REF.npz)")
    output_path(out)


def _positive(value, flag: str) -> None:
    if value is not None and not (math.isfinite(value) and value > 0):
        raise InputError(f"`{flag}` {value!r}: give a positive number")


def retarget_command(args) -> int:
    """Resolve the animal's run at the robot's Froude number, retarget it, write it."""
    from quadsim.api import resolve, run_reporting
    from quadsim.robots.legs import find_legs
    from quadsim.robots.reference import write_reference
    from quadsim.robots.retarget import froude_scale, nominal_stance, retarget
    from quadsim.robots.urdf import read_urdf

    out = Path(args.out)
    _check_out(out)
    for flag, v in (("--speed", args.speed), ("--seconds", args.seconds), ("--fps", args.fps)):
        _positive(v, flag)
    robot = find_legs(read_urdf(args.robot))
    nominal = nominal_stance(robot)
    base = resolve(args.source, gait=args.gait)  # the character, and --gait checked
    character = base.load_character()
    s = froude_scale(character, nominal)
    root = math.sqrt(s)
    gait = args.gait
    if gait is None and args.speed is None and base.source is None:
        gait = "trot"
    seconds = args.seconds if args.seconds is not None else base.duration
    fps = args.fps if args.fps is not None else base.fps
    config = resolve(args.source, seconds=seconds / root, fps=fps * root, gait=gait,
                     speed=None if args.speed is None else args.speed / root)
    motion = run_reporting(config, _warn)
    ref = retarget(motion, character, robot, nominal, scale=s, warn=_warn)
    ref.info.update(character=character.id, robot=robot.urdf.label)
    write_reference(ref, out)
    i = ref.info
    gaits = ", ".join(dict.fromkeys(str(g) for g in ref.gaits if "->" not in str(g))) or "none"
    print(f"wrote {out}: {ref.n_frames} frames at {ref.fps:g} fps, {character.id} on "
          f"{robot.urdf.label} (hips {i['robot_hip_height']:.3f} m, scale {s:.3f}, stride "
          f"{i['stride_factor']:.0%}), {i['robot_speed']:.2f} m/s on average (with the start "
          f"from standing), gaits: {gaits}; "
          f"{len(ref.joint_names)} joints: {', '.join(ref.joint_names)}")
    return 0


def register(sub) -> None:
    """Add the ``retarget`` sub-command to the ``quadsim`` parser's sub-parsers ``sub``."""
    p = sub.add_parser("retarget", help="a gait as a reference motion for a robot's URDF",
                       description="Scale a character's gait to a legged robot by leg length "
                       "and Froude number, place the feet with the robot's own legs read "
                       "from its URDF (IK within the joint limits), and write a reference "
                       "motion in the URDF's frame (Z up): the motion-imitation JSON layout "
                       "or an NPZ with foot positions, velocities, contacts and gaits.")
    p.add_argument("source", metavar="CHARACTER|CONFIG")
    p.add_argument("--robot", required=True, metavar="URDF", help="the robot's .urdf file")
    p.add_argument("--gait", help="gait name (default: trot for a character, the config's "
                   "commands for a config)")
    p.add_argument("--speed", type=float, metavar="M_PER_S",
                   help="the robot's speed (m/s; the animal runs at the same Froude number)")
    p.add_argument("--seconds", type=float, metavar="S",
                   help="length of the reference (s; default the config's, else 10)")
    p.add_argument("--fps", type=float, metavar="N", help="frames per second (default 60)")
    p.add_argument("--out", required=True, metavar="REF.json|REF.npz")
    p.set_defaults(func=retarget_command)
