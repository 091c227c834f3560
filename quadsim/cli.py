"""The ``quadsim`` command.

::

    quadsim run CONFIG|CHARACTER|MODEL [--out FILE.bvh|.glb|.npz|.csv] [--mode procedural|data]
                       [--seconds S] [--fps N] [--speed M_PER_S] [--gait NAME]
                       [--turn-rate DEG_PER_S] [--units m|cm]
    quadsim --version
    quadsim characters
    quadsim validate CONFIG|CHARACTER
    quadsim metrics FILE.bvh [--json] [--start S] [--units m|cm]
    quadsim diagram CONFIG|FILE.bvh [--out FILE.png|.svg|.pdf] [--seconds S]
    quadsim preview CONFIG|CHARACTER [--mode procedural|data] [--size WxH]
                    [--camera follow|side|top]
    quadsim render CONFIG|FILE.bvh [--out FILE.mp4|.gif] [--seconds S] [--size WxH]
                   [--camera follow|side|top] [--fps N]
    quadsim rig MODEL.glb|.gltf|.bvh [--out CHARACTER.toml] [--id ID]
    quadsim clips CHARACTER|CONFIG|MODEL --out SET.glb|SET.fbx [--speeds GAIT=V[,V...] ...]
                  [--gaits G[,G...]] [--turn-rates DEG_S[,DEG_S...]] [--fps N]
    quadsim retarget CHARACTER|CONFIG --robot URDF [--gait G] [--speed V] [--seconds S]
                     [--fps N] --out REF.json|REF.npz
    quadsim clips-from TAKE.bvh [TAKE.bvh ...] --character CHARACTER.toml|ID --out DIR
    quadsim sweep GRID.toml [--out DIR] [--workers N] [--scheduler ADDRESS] [--limit K]
    quadsim bench [--quick] [--max-n N] [--characters A,B] [--out FILE.json]

Exit status 0 on success and 2 on bad input (a bad config, flag or file),
with a one-paragraph message on stderr that starts with ``quadsim: error:``.
Output files are written atomically, and only after the motion has been
generated, so a failed run never leaves a partial file or clobbers an old one.
Heavy modules are imported inside the command that needs them.
"""

from __future__ import annotations

import argparse
import importlib
import json
import math
import os
import sys
import warnings
from pathlib import Path

from quadsim import __version__
from quadsim.api import DEFAULT_SECONDS
from quadsim.errors import InputError

PROG = "quadsim"
#: modules that each register a sub-command with ``register(subparsers)``; they import
#: their heavy parts inside the command, so listing them costs nothing at start-up
COMMAND_MODULES = ("quadsim.cli_rig", "quadsim.cli_clips", "quadsim.cli_retarget",
                   "quadsim.cli_sweep", "quadsim.cli_clips_from")


class _UsageError(Exception):
    """A command-line syntax error found by argparse."""


class _Parser(argparse.ArgumentParser):
    """An argument parser that reports errors to ``main`` instead of exiting."""

    def error(self, message: str):
        raise _UsageError(f"{message} (see `{self.prog} --help`)")


# ------------------------------------------------------------------ commands
def _report_warning(message: str) -> None:
    print(f"{PROG}: warning: {message}", file=sys.stderr)


def _resolve(args, source: str, **overrides):
    """The run a CONFIG|CHARACTER argument and its flags describe (one front door)."""
    from quadsim.api import resolve

    return resolve(source, **overrides)


def cmd_run(args) -> int:
    from quadsim.api import run_reporting, save
    from quadsim.locomotion.precompile import start_for

    config = _resolve(args, args.source, mode=args.mode, seconds=args.seconds, fps=args.fps,
                      units=args.units, speed=args.speed, gait=args.gait,
                      turn_rate_deg_s=args.turn_rate)
    out = Path(args.out) if args.out is not None else Path("out") / f"{Path(args.source).stem}.bvh"
    _check_out(out)
    start_for(config.mode)  # an empty cache: the plan compiles in a second process meanwhile
    character = config.load_character()
    motion = run_reporting(config, _report_warning)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        save(motion, out, units=config.units, character=character)
    for w in caught:
        _report_warning(str(w.message))
    gaits = _gaits_used(motion)
    print(f"wrote {out}: {motion.n_frames} frames, {config.duration:g} s at "
          f"{config.fps:g} fps, {character.id} ({config.mode} mode), "
          f"gaits: {', '.join(gaits) or 'none'}")
    return 0


def _check_out(out: Path) -> None:
    """Refuse an output name quadsim cannot write before any work is done."""
    from quadsim.api import FORMATS

    ext = out.suffix.lower()
    if ext not in FORMATS:
        kind = f"{ext} files" if ext else "files without an extension"
        raise InputError(f"`--out` {str(out)!r}: cannot write {kind}; "
                         f"supported: {', '.join(FORMATS)}")
    from quadsim.io.atomic import output_path

    output_path(out)  # a folder or a read-only file is refused before the work


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
    config = _resolve(args, args.config)
    character = config.load_character()
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
    print(f"  character {character.id}; {config.duration:g} s at {config.fps:g} fps "
          f"({config.n_frames} frames); seed {config.seed}; mode {config.mode}; "
          f"units {config.units}")
    print(f"  {len(commands)} command(s); speeds {min(speeds):.2f} to {max(speeds):.2f} m/s; "
          f"gaits: {gaits}")
    return 0


def cmd_metrics(args) -> int:
    from quadsim.analysis.metrics import format_report, motion_report
    from quadsim.frames import LEGS
    from quadsim.io.bvh import read_bvh

    path = Path(args.file)
    if not path.is_file():
        raise InputError(f"{path}: no such file")
    if not (math.isfinite(args.start) and args.start >= 0):
        raise InputError(f"`--start` = {args.start}: must be a time >= 0 s")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        motion = read_bvh(path, units=args.units)
    for w in caught:
        print(f"{PROG}: warning: {w.message}", file=sys.stderr)
    from quadsim.io.guess import with_feet

    motion, by_shape = with_feet(motion, path)
    if by_shape:
        print(f"{PROG}: warning: {path}: feet taken from the skeleton's shape: "
              + ", ".join(f"{leg} {name}" for leg, name in zip(LEGS, motion.foot_joints)),
              file=sys.stderr)
    n, fps = len(motion), motion.fps
    if n < 3:
        raise InputError(f"{path}: the file has {n} frame{'' if n == 1 else 's'}; "
                         "measuring a motion needs at least 3")
    if math.ceil(args.start * fps - 1e-9) > n - 3:
        raise InputError(f"{path}: `--start` = {args.start:g} s leaves fewer than 3 frames to "
                         f"measure: the motion lasts {(n - 1) / fps:.3f} s ({n} frames at "
                         f"{fps:g} fps); give a smaller --start")
    try:
        report = motion_report(motion, start=args.start)
    except ValueError as e:
        raise InputError(f"{path}: {e}") from None
    from quadsim.analysis.appearance import appearance_report, format_appearance

    try:
        report["appearance"] = appearance_report(motion, start=args.start)
    except ValueError as e:  # no quadruped structure to measure the trunk and head on
        report["appearance"] = None
        print(f"{PROG}: warning: {path}: trunk, head and toe measures left out: {e}",
              file=sys.stderr)
    if args.json:
        print(json.dumps(report, indent=2, default=_json_default))
    else:
        print(format_report(report))
        if report["appearance"] is not None:
            print("\nwhat a viewer sees (joint world positions):")
            print(format_appearance(report["appearance"]))
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


# ------------------------------------------------------- seeing motion (viz)
def _motion_source(source: str, seconds: float | None, units: str | None = None,
                   mode: str | None = None):
    """A motion from a BVH file (cut to ``seconds``; its unit detected unless ``units``
    says), or the run of a config or character (the front door)."""
    path = Path(source)
    if path.suffix.lower() == ".bvh":
        from quadsim.io.bvh import BvhUnitsWarning, read_bvh

        if not path.is_file():
            raise InputError(f"{path}: no such file")
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", BvhUnitsWarning)
            motion = read_bvh(path, units=units)
        for w in caught:
            if issubclass(w.category, BvhUnitsWarning):
                _report_warning(str(w.message))
            else:
                warnings.showwarning(w.message, w.category, w.filename, w.lineno)
        if seconds is not None:
            if not (math.isfinite(seconds) and seconds > 0):
                raise InputError(f"`--seconds` = {seconds}: must be a positive duration")
            motion = motion.time_slice(0.0, seconds + 0.5 / motion.fps)
        return motion
    from quadsim.api import run_reporting

    config = _resolve(None, source, seconds=seconds, mode=mode)
    return run_reporting(config, _report_warning)


def cmd_diagram(args) -> int:
    from quadsim._optional import require_for

    require_for("diagram")
    from quadsim.viz.diagram import FORMATS, gait_diagram

    out = Path(args.out) if args.out else Path("out") / f"{Path(args.source).stem}-diagram.png"
    if out.suffix.lower() not in FORMATS:
        raise InputError(f"`--out` {str(out)!r}: a diagram is written as "
                         f"{', '.join(FORMATS)}")
    motion = _motion_source(args.source, args.seconds, args.units)
    try:
        data_path = gait_diagram(motion, out, title=f"{Path(args.source).name}: footfalls "
                                 "measured from the foot positions")
    except ValueError as e:
        raise InputError(str(e)) from None
    print(f"wrote {data_path}: {motion.n_frames} frames, {motion.duration:.2f} s")
    return 0


def cmd_preview(args) -> int:
    from quadsim._optional import require_for

    require_for("preview")
    from quadsim.viz.scene import parse_size

    try:
        size = parse_size(args.size)
    except ValueError as e:
        raise InputError(f"`--size`: {e}") from None
    source = args.source
    if not source.endswith(".toml"):
        from quadsim.skeleton.character import load_character

        source = load_character(source)  # an identifier; InputError lists the known ones
    elif not Path(source).is_file():
        raise InputError(f"{source}: no such config file")
    if args.mode is not None:
        from quadsim.api import check_mode
        from quadsim.viz.preview import resolve_source

        check_mode(resolve_source(source)[0], args.mode, "`--mode`")
    if args.screenshot is None:
        from quadsim.viz.preview import display_available

        if not display_available():
            raise InputError("no display to open the preview window on (DISPLAY and "
                             "WAYLAND_DISPLAY are unset); run it on a desktop, render a "
                             "video off screen with `quadsim render`, or take a picture "
                             "with `--screenshot FILE.png`")
    from quadsim.viz.preview import Preview

    off = args.screenshot is not None
    pv = Preview(source, mode=args.mode, size=size, off_screen=off, camera=args.camera,
                 record_dir=args.record_dir)
    if not off:
        print(f"{PROG}: preview of {pv.character.name} ({pv.mode} mode): H for help, "
              "Q to quit", file=sys.stderr)
        pv.run()
        if pv.last_recording is not None:
            print(f"last recording: {pv.last_recording}")
        return 0
    seconds = 3.0 if args.seconds is None else args.seconds
    if not (math.isfinite(seconds) and 0 <= seconds <= 600):
        raise InputError(f"`--seconds` = {seconds}: must be from 0 to 600 s")
    for _ in range(round(seconds / pv.dt)):
        pv.update(pv.dt)
    shot = Path(args.screenshot)
    shot.parent.mkdir(parents=True, exist_ok=True)
    pv.screenshot(shot)
    pv.close()
    print(f"wrote {shot}: {pv.character.id} ({pv.mode} mode) after {seconds:g} s, "
          f"gait {pv.gait}, {pv.speed:.2f} m/s")
    return 0


def cmd_render(args) -> int:
    from quadsim.viz.render import FORMATS, render_video
    from quadsim.viz.scene import parse_size

    out = Path(args.out) if args.out else Path("out") / f"{Path(args.source).stem}.mp4"
    if out.suffix.lower() not in FORMATS:
        raise InputError(f"`--out` {str(out)!r}: a video is written as {', '.join(FORMATS)}")
    try:
        size = parse_size(args.size)
    except ValueError as e:
        raise InputError(f"`--size`: {e}") from None
    if out.suffix.lower() == ".mp4" and (size[0] % 2 or size[1] % 2):
        raise InputError(f"`--size` {size[0]}x{size[1]}: an .mp4 needs an even width and "
                         "height")
    if args.fps is not None and not (math.isfinite(args.fps) and 0 < args.fps <= 240):
        raise InputError(f"`--fps` = {args.fps}: must be from 0 to 240 frames per second")
    from quadsim._optional import require, require_for
    from quadsim.io.atomic import output_path

    require_for("render")
    if out.suffix.lower() == ".mp4":
        require("imageio_ffmpeg", "`quadsim render` to .mp4")
    output_path(out)  # a folder or a read-only file is refused before the work
    motion = _motion_source(args.source, args.seconds, args.units)
    if args.fps is None and Path(args.source).suffix.lower() != ".bvh":
        from quadsim.viz.render import DEFAULT_FPS

        fps = DEFAULT_FPS[out.suffix.lower()]
    else:
        fps = args.fps
    if fps is not None and abs(fps - motion.fps) > 1e-9:
        motion = motion.resample(fps)
    try:
        path = render_video(motion, out, size=size, camera=args.camera,
                            progress=not args.quiet)
    except ValueError as e:
        raise InputError(str(e)) from None
    print(f"wrote {path}: {len(motion)} frames at {motion.fps:g} fps, {size[0]}x{size[1]}, "
          f"camera {args.camera}")
    return 0


def cmd_bench(args) -> int:
    # the suite lives in the source checkout's benchmarks/, beside the package
    try:
        from benchmarks.command import run_from_args
    except ImportError:
        root = Path(__file__).resolve().parents[1]
        if not (root / "benchmarks" / "suite.py").is_file():
            raise InputError("the benchmark suite is not installed: run `quadsim bench` "
                             "from a source checkout of quadsim") from None
        sys.path.insert(0, str(root))
        from benchmarks.command import run_from_args
    if args.max_n < 1:
        raise InputError(f"`--max-n` = {args.max_n}: give at least 1 character")
    return run_from_args(args)


# ------------------------------------------------------------------- parser
def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog=PROG, description="Kinematic quadruped locomotion: generate, check and "
                "measure gaits.")
    p.add_argument("--version", action="version", version=f"{PROG} {__version__}")
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND",
                           parser_class=_Parser)

    r = sub.add_parser("run", help="generate a motion from a config or a character and write "
                       "it to a file",
                       description="Generate a motion from a config file, or from a character "
                       "(an identifier such as `leopard`, a character file, or your rigged model "
                       "itself, .gltf/.glb/.bvh, adopted as `quadsim rig` would) under a constant "
                       "command, and write it. --speed/--gait/--turn-rate replace the config's "
                       "commands with one constant command; --gait alone uses that gait's "
                       f"preferred speed. A character alone walks for {DEFAULT_SECONDS:g} s.")
    r.add_argument("source", metavar="CONFIG|CHARACTER|MODEL",
                   help="run configuration (TOML), character identifier, character file, or a "
                   "rigged model (.gltf, .glb, .bvh)")
    r.add_argument("--mode", choices=("procedural", "data"),
                   help="controller: procedural, or data (a character with a clip database: "
                   "the horse); default the config's mode, else procedural")
    r.add_argument("--out", metavar="FILE",
                   help="output file, by extension: .bvh, .glb, .npz or .csv "
                   "(default out/<config or character name>.bvh)")
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
    v.add_argument("config", metavar="CONFIG|CHARACTER",
                   help="run configuration (TOML), character identifier or character file")
    v.set_defaults(func=cmd_validate)

    m = sub.add_parser("metrics", help="measure a motion file: footfalls, slide, "
                       "penetration, speed")
    m.add_argument("file", metavar="FILE.bvh")
    m.add_argument("--json", action="store_true", help="print the report as JSON")
    m.add_argument("--start", type=float, default=0.0, metavar="S",
                   help="ignore the first S seconds (default 0)")
    m.add_argument("--units", choices=("m", "cm"),
                   help="length unit of the file (default: detected from the skeleton's size, "
                   "centimetres when it stands over 3 units tall at the hips)")
    m.set_defaults(func=cmd_metrics)

    d = sub.add_parser("diagram", help="draw the gait diagram of a config or a BVH file",
                       description="Footfall diagram measured from the foot positions, with "
                       "gait names, stride duty factors and phases, a Hildebrand plot, and "
                       "the CPG phases and spine angle (configs). A config is simulated first.")
    d.add_argument("source", metavar="CONFIG|FILE.bvh")
    d.add_argument("--out", metavar="FILE", help="image file: .png, .svg or .pdf "
                   "(default out/<name>-diagram.png)")
    d.add_argument("--seconds", type=float, metavar="S",
                   help="duration: replaces a config's, cuts a BVH file")
    d.add_argument("--units", choices=("m", "cm"),
                   help="length unit of a BVH file (default m)")
    d.set_defaults(func=cmd_diagram)

    pr = sub.add_parser("preview", help="steer a character live in a window",
                        description="Open an interactive pyvista window: Up/Down speed, "
                        "Left/Right turn, 1-9 gait (0 automatic), Space leap (data mode), "
                        "P pause, R record to BVH, H help, Q quit. A config's commands play "
                        "until the first steering key. A config's `mode` picks the "
                        "controller; --mode overrides it.")
    pr.add_argument("source", metavar="CONFIG|CHARACTER",
                    help="a run configuration (TOML) or a character identifier")
    pr.add_argument("--mode", choices=("procedural", "data"),
                    help="controller: procedural, or data (the clip database of a character "
                    "that has one: the horse); default the config's mode, else procedural")
    pr.add_argument("--size", default="960x640", metavar="WxH", help="window size (960x640)")
    pr.add_argument("--camera", choices=("follow", "side", "top"), default="follow")
    pr.add_argument("--record-dir", default="out", metavar="DIR",
                    help="folder for recordings (default out)")
    pr.add_argument("--screenshot", metavar="FILE.png",
                    help="no window: run off screen for --seconds and save the last frame")
    pr.add_argument("--seconds", type=float, metavar="S",
                    help="with --screenshot: seconds to run first (default 3)")
    pr.set_defaults(func=cmd_preview)

    rd = sub.add_parser("render", help="render a video of a config or a BVH file off screen",
                        description="Render the motion off screen to an .mp4 (H.264) or a "
                        ".gif, with a progress bar on stderr. A config is simulated first "
                        "and shown at 30 fps (.mp4) or 25 fps (.gif).")
    rd.add_argument("source", metavar="CONFIG|FILE.bvh")
    rd.add_argument("--out", metavar="FILE", help="video file: .mp4 or .gif "
                    "(default out/<name>.mp4)")
    rd.add_argument("--seconds", type=float, metavar="S",
                    help="duration: replaces a config's, cuts a BVH file")
    rd.add_argument("--size", default="640x480", metavar="WxH", help="frame size (640x480)")
    rd.add_argument("--camera", choices=("follow", "side", "top"), default="follow",
                    help="follow (behind-left, turning with it), side or top")
    rd.add_argument("--fps", type=float, metavar="N", help="video frame rate")
    rd.add_argument("--units", choices=("m", "cm"),
                    help="length unit of a BVH file (default: detected from the skeleton's "
                    "size)")
    rd.add_argument("--quiet", action="store_true", help="no progress bar")
    rd.set_defaults(func=cmd_render)

    for name in COMMAND_MODULES:  # each adds its own sub-command (`register(sub)`)
        importlib.import_module(name).register(sub)

    b = sub.add_parser("bench", help="measure step rate, offline generation, many "
                       "characters and export on this machine",
                       description="Run the benchmark suite (the same as `python -m "
                       "benchmarks`): print medians over repeats and the machine's details, "
                       "and write benchmarks/results/<machine>.json (a --quick run writes "
                       "out/bench-quick.json instead, unless --out names the file).")
    b.add_argument("--quick", action="store_true", help="a short, rough smoke run, written "
                   "to out/bench-quick.json unless --out says otherwise")
    b.add_argument("--max-n", type=int, default=1000, metavar="N",
                   help="largest number of characters stepped together (1000)")
    b.add_argument("--characters", metavar="A,B",
                   help="characters to measure, comma-separated (default all four)")
    b.add_argument("--out", metavar="FILE.json", help="result file (default "
                   "benchmarks/results/<machine>.json, or out/bench-quick.json with --quick)")
    b.set_defaults(func=cmd_bench)
    return p


_ANNOUNCING = False


def _announce_compiling() -> None:
    """Say once, on stderr, when the numba kernels are being compiled.

    numba compiles a kernel on its first use and caches the machine code
    (``__pycache__``), so this shows only on the first run after installing
    or updating -- on every kind of output (a terminal, a pipe, a log), so a
    wait of several seconds is never unexplained. The line starts with
    ``quadsim: note:``.
    """
    global _ANNOUNCING
    if _ANNOUNCING:
        return
    _ANNOUNCING = True
    from numba.core import event

    class _Note(event.Listener):
        said = False

        def on_start(self, ev) -> None:
            if not self.said:
                self.said = True
                print(f"{PROG}: note: compiling the numeric kernels (once after installing "
                      "or updating; cached afterwards) ...", file=sys.stderr, flush=True)

        def on_end(self, ev) -> None:
            pass

    event.register("numba:compile", _Note())


def main(argv: list[str] | None = None) -> int:
    """Run the ``quadsim`` command; returns the exit status."""
    # threads that wait passively give their core back at once: on a machine shared
    # with other busy jobs the threaded batch then keeps its pace (README, Performance)
    os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
    _announce_compiling()
    from quadsim.io.atomic import SignalExit, cleanup_on_signals

    parser = build_parser()
    try:
        # SIGTERM/SIGINT remove unfinished output files before the command stops
        with cleanup_on_signals():
            args = parser.parse_args(argv)
            return int(args.func(args) or 0)
    except SignalExit as e:
        print(f"{PROG}: stopped by signal {e.signum}; unfinished files removed",
              file=sys.stderr)
        return e.code
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
        print(f"{PROG}: interrupted; unfinished files removed", file=sys.stderr)
        return 130


def _fail(message: str) -> int:
    print(f"{PROG}: error: {' '.join(message.split())}", file=sys.stderr)
    return 2
