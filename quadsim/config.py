"""Run configurations: TOML files parsed once into frozen dataclasses.

A run configuration says which character to animate, for how long, at what
frame rate, and what it is asked to do over time. Example::

    description = "Leopard tour: walk, trot, gallop, turn, slow down"  # optional
    character = "leopard"      # an identifier, or a path to a character file
    duration = 20.0            # s, 0 < duration <= 3600
    fps = 60                   # frames per second, 1 <= fps <= 1000
    seed = 0                   # optional, default 0
    mode = "procedural"        # optional: "procedural", or "data" (a character with
                               # a clip database, i.e. the horse)
    units = "m"                # optional, length unit of the output file: "m" or "cm"

    [[command]]
    at = 0.0                   # s, when this command starts; the first is at 0
    speed = 1.0                # m/s (or speed_kmh, or speed_mph; at most one)
    gait = "walk"              # optional; omitted = chosen by speed
    turn_rate_deg_s = 0.0      # optional, positive turns left; or heading_deg
    leap = false               # optional
    slope_deg = 0.0            # optional, data mode: ground slope ahead, climbing positive

    [[command]]
    at = 6.0
    speed_kmh = 9.0

Each ``[[command]]`` holds until the next one starts. Rules:

- ``duration`` and ``fps`` give at least one frame: ``duration * fps >= 1``.
- ``at`` starts at 0 and increases, and every ``at`` is before ``duration``.
- Speed: exactly one of ``speed`` (m/s), ``speed_kmh``, ``speed_mph``, from 0
  to 1.5 times the top speed of the character's fastest gait. When ``gait``
  is given the speed may be left out: the gait's preferred speed is used.
- ``gait``: one of the character's gaits (``quadsim characters`` lists them);
  ``"gallop"`` means ``"transverse_gallop"``.
- ``turn_rate_deg_s`` (deg/s, magnitude at most 720) or ``heading_deg``
  (deg about +Y, 0 faces +Z, positive left, magnitude at most 360), not both.
- ``slope_deg`` (deg, magnitude at most 20; data mode): the ground ahead
  rises (positive) or falls along the heading from this command on.
- A relative character path is taken from the config file's folder.

Unknown keys are errors. Every error is a :class:`quadsim.errors.InputError`
whose message names the file, the key (``command[2].speed``; commands are
counted from 0) and what is allowed. Degrees, km/h and mph are converted to SI
(radians, m/s) here; everything past this module is SI.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path

from quadsim.commands import Command, Script
from quadsim.errors import InputError, read_toml
from quadsim.frames import KMH, MPH

__all__ = [
    "FPS_RANGE", "MAX_DURATION", "MAX_TURN_RATE_DEG_S", "MODES", "UNITS",
    "RunConfig", "constant_command", "load_config", "parse_config", "speed_limit",
    "with_overrides",
]

#: Allowed frame rates (frames per second), inclusive.
FPS_RANGE = (1.0, 1000.0)
#: Longest run (s).
MAX_DURATION = 3600.0
#: Largest turn rate magnitude (deg/s).
MAX_TURN_RATE_DEG_S = 720.0
#: Largest ground slope magnitude (deg), data mode.
MAX_SLOPE_DEG = 20.0
#: Largest heading magnitude (deg).
MAX_HEADING_DEG = 360.0
#: Top speed allowed, as a multiple of the fastest gait's top speed.
SPEED_MARGIN = 1.5
#: Generation modes: ``"data"`` plays a clip database (characters/<id>/clips).
MODES = ("procedural", "data")
#: Length units of output files.
UNITS = ("m", "cm")

_TOP_KEYS = ("description", "character", "duration", "fps", "seed", "mode", "units", "command")
_COMMAND_KEYS = ("at", "speed", "speed_kmh", "speed_mph", "gait", "turn_rate_deg_s",
                 "heading_deg", "leap", "slope_deg")
_SPEED_KEYS = {"speed": 1.0, "speed_kmh": KMH, "speed_mph": MPH}


@dataclass(frozen=True)
class RunConfig:
    """A validated run configuration, in SI units.

    Attributes
    ----------
    character : str
        A character identifier (``"leopard"``) or an absolute path to a
        character file; pass it to :func:`quadsim.load_character`.
    duration : float
        Length of the run (s).
    fps : float
        Frames per second.
    seed : int
        Random seed (the same config and seed give the same motion).
    mode : str
        ``"procedural"``.
    units : str
        Length unit of the output file, ``"m"`` or ``"cm"``.
    commands : Script
        What the character is asked to do over time (SI units).
    source : Path or None
        The file this configuration was read from.
    description : str
        Free text from the file (may be empty).
    """

    character: str
    duration: float
    fps: float
    seed: int
    mode: str
    units: str
    commands: Script
    source: Path | None = None
    description: str = ""

    def __post_init__(self) -> None:
        _check_frames(self.duration, self.fps, "`duration`", "`fps`",
                      str(self.source) if self.source is not None else "<config>")

    @property
    def n_frames(self) -> int:
        """Frames a run produces: ``round(duration * fps)``."""
        return round(self.duration * self.fps)

    def load_character(self):
        """The :class:`~quadsim.skeleton.character.Character` this config animates."""
        from quadsim.skeleton.character import load_character

        return load_character(self.character)


# ------------------------------------------------------------------ loading
def load_config(path: str | Path) -> RunConfig:
    """Read and validate a run configuration file.

    Raises
    ------
    InputError
        When the file is missing, is not valid TOML (the message gives the
        line), or breaks a rule of the format (the message names the key).
    """
    path = Path(path)
    data = read_toml(path, "config")
    return parse_config(data, source=path)


def parse_config(data: dict, source: str | Path | None = None) -> RunConfig:
    """Validate parsed TOML data (a dict) and build a :class:`RunConfig`.

    ``source`` names the file in error messages and anchors relative
    character paths; without it they are taken from the current folder.
    """
    src = str(source) if source is not None else "<config>"
    base = Path(source).parent if source is not None else Path(".")
    _check_keys(data, _TOP_KEYS, src, "")

    description = data.get("description", "")
    if not isinstance(description, str):
        raise InputError(f"{src}: `description` must be a string")

    name = _need(data, "character", src)
    if not isinstance(name, str) or not name:
        raise InputError(f"{src}: `character` must be a character identifier or a path "
                         f"to a character file, got {name!r}")
    character_ref = name
    if name.endswith(".toml"):
        p = Path(name)
        character_ref = str((p if p.is_absolute() else base / p).resolve())
        if not Path(character_ref).is_file():
            raise InputError(f"{src}: `character`: no such character file {name!r} "
                             f"(looked for {character_ref})")
    try:
        from quadsim.skeleton.character import load_character

        character = load_character(character_ref)
    except InputError as e:
        raise InputError(f"{src}: `character`: {e}") from None

    duration = _number(_need(data, "duration", src), f"{src}: `duration`")
    if not 0.0 < duration <= MAX_DURATION:
        raise InputError(f"{src}: `duration` = {duration:g} s is out of range; "
                         f"allowed 0 < duration <= {MAX_DURATION:g} s")
    fps = _check_fps(_need(data, "fps", src), f"{src}: `fps`")
    _check_frames(duration, fps, "`duration`", "`fps`", src)

    seed = data.get("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed < 2**32:
        raise InputError(f"{src}: `seed` = {seed!r} must be an integer from 0 to 2**32 - 1")
    mode = data.get("mode", MODES[0])
    if mode not in MODES:
        raise InputError(f"{src}: `mode` = {mode!r} is not a known mode; "
                         f"allowed: {', '.join(map(repr, MODES))}")
    clip_gaits = ()
    if mode == "data":
        from quadsim.io.clips import clip_folder, playable_gaits

        if clip_folder(character) is None:
            raise InputError(f"{src}: `mode` = 'data' needs a character with a clip "
                             f"database (characters/<id>/clips/manifest.toml, or the folder "
                             f"its file's [character] `clips` names: `quadsim clips-from` "
                             f"cuts one from your takes); {character.id!r} has none; allowed "
                             f"for it: 'procedural'")
        clip_gaits = playable_gaits(character)
    units = data.get("units", "m")
    if units not in UNITS:
        raise InputError(f"{src}: `units` = {units!r}; allowed: {', '.join(map(repr, UNITS))}")

    raw = data.get("command")
    if raw is None:
        raise InputError(f"{src}: no commands; add at least one [[command]] table "
                         "with `at = 0.0` and a speed or gait")
    if not isinstance(raw, list) or not all(isinstance(c, dict) for c in raw) or not raw:
        raise InputError(f"{src}: `command` must be an array of tables, written [[command]]")

    times: list[float] = []
    commands: list[Command] = []
    for k, table in enumerate(raw):
        key = f"command[{k}]"
        _check_keys(table, _COMMAND_KEYS, src, key + ".")
        at = _number(_need(table, "at", f"{src}: {key}"), f"{src}: `{key}.at`")
        if k == 0 and at != 0.0:
            raise InputError(f"{src}: `{key}.at` = {at:g} s; the first command must start "
                             "at 0")
        if k > 0 and not at > times[-1]:
            raise InputError(f"{src}: `{key}.at` = {at:g} s; start times must increase "
                             f"(the previous command starts at {times[-1]:g} s)")
        if at >= duration:
            raise InputError(f"{src}: `{key}.at` = {at:g} s is not before the end of the "
                             f"run; allowed 0 <= at < duration = {duration:g} s")
        speed = None
        given = [s for s in _SPEED_KEYS if s in table]
        if len(given) > 1:
            raise InputError(f"{src}: {key} gives {' and '.join(given)}; give one speed "
                             "(speed in m/s, speed_kmh or speed_mph)")
        if not given and "gait" not in table:
            raise InputError(f"{src}: {key} needs a speed (speed in m/s, speed_kmh or "
                             "speed_mph) or a gait (which then runs at its preferred speed)")
        if given:
            s = given[0]
            speed = _number(table[s], f"{src}: `{key}.{s}`") * _SPEED_KEYS[s]
        turn = table.get("turn_rate_deg_s")
        heading = table.get("heading_deg")
        if turn is not None and heading is not None:
            raise InputError(f"{src}: {key} gives turn_rate_deg_s and heading_deg; "
                             "give one of them")
        leap = table.get("leap", False)
        if not isinstance(leap, bool):
            raise InputError(f"{src}: `{key}.leap` = {leap!r}; allowed: true or false")
        cmd = constant_command(
            character, speed=speed, gait=table.get("gait"),
            turn_rate_deg_s=turn, heading_deg=heading, leap=leap,
            label=lambda name, key=key: f"{src}: `{key}.{name}`",
            speed_key=given[0] if given else "speed")
        _check_clip_gait(cmd, clip_gaits, character, table.get("gait"),
                         f"{src}: `{key}.gait`")
        if "slope_deg" in table:
            sl = _number(table["slope_deg"], f"{src}: `{key}.slope_deg`")
            if abs(sl) > MAX_SLOPE_DEG:
                raise InputError(f"{src}: `{key}.slope_deg` = {sl:g} deg is out of range; "
                                 f"allowed -{MAX_SLOPE_DEG:g} to {MAX_SLOPE_DEG:g} deg")
            if sl != 0.0 and mode != "data":
                raise InputError(f"{src}: `{key}.slope_deg` = {sl:g} deg needs `mode` = "
                                 "'data' (the procedural mode walks on flat ground); "
                                 "remove it or set mode = \"data\"")
            cmd = replace(cmd, slope=math.radians(sl))
        commands.append(cmd)
        times.append(at)

    return RunConfig(character=character_ref, duration=duration, fps=fps, seed=seed,
                     mode=mode, units=units,
                     commands=Script(tuple(times), tuple(commands)),
                     source=Path(source) if source is not None else None,
                     description=description)


# ----------------------------------------------------------------- commands
def speed_limit(character) -> float:
    """Top speed a command may ask of ``character`` (m/s).

    1.5 times the top of the speed range of the character's fastest gait.
    """
    table = _gait_table(character)
    return SPEED_MARGIN * max(g.speed_range[1] for g in table.values())


def constant_command(character, *, speed: float | None = None, gait: str | None = None,
                     turn_rate_deg_s: float | None = None, heading_deg: float | None = None,
                     leap: bool = False, label=None, speed_key: str = "speed") -> Command:
    """Validate one command's values and build a :class:`Command` in SI units.

    Parameters
    ----------
    character : Character
    speed : float or None
        Forward speed (m/s). ``None`` uses the preferred speed of ``gait``
        or, without a gait, of the character's slowest automatic gait.
    gait : str or None
        Gait name (aliases accepted); ``None`` lets the speed choose.
    turn_rate_deg_s, heading_deg : float or None
        Turn rate (deg/s) or heading (deg); at most one.
    leap : bool
    label : callable, optional
        ``label(key)`` names a field in error messages (default: the key in
        backquotes); ``key`` is ``speed_key``, ``"gait"``,
        ``"turn_rate_deg_s"`` or ``"heading_deg"``.
    speed_key : str
        The key that gave the speed (``"speed_kmh"``, ...).

    Raises
    ------
    InputError
        When a value is out of range or the gait unknown; the message names
        the field and what is allowed.
    """
    if label is None:
        label = "`{}`".format
    table = _gait_table(character)
    if gait is not None:
        if not isinstance(gait, str):
            raise InputError(f"{label('gait')} must be a gait name, got {gait!r}; "
                             f"allowed: {', '.join(table)}")
        gait = _resolve_gait(gait, character, table, label("gait"))
    if speed is None:
        g = table[gait] if gait is not None else table[_slowest_gait(character, table)]
        speed = float(g.preferred_speed)
    else:
        name = label(speed_key)
        speed = _number(speed, name)
        top = SPEED_MARGIN * max(g.speed_range[1] for g in table.values())
        if not 0.0 <= speed <= top:
            raise InputError(f"{name} gives {speed:.3g} m/s, out of range for "
                             f"{character.id}; allowed 0 to {top:.3g} m/s "
                             f"({SPEED_MARGIN:g} x the top speed of its fastest gait)")
    if turn_rate_deg_s is not None and heading_deg is not None:
        raise InputError(f"{label('turn_rate_deg_s')} and {label('heading_deg')} are both "
                         "given; give one of them")
    turn_rate = heading = None
    if turn_rate_deg_s is not None:
        name = label("turn_rate_deg_s")
        r = _number(turn_rate_deg_s, name)
        if abs(r) > MAX_TURN_RATE_DEG_S:
            raise InputError(f"{name} = {r:g} deg/s is out of range; allowed "
                             f"-{MAX_TURN_RATE_DEG_S:g} to {MAX_TURN_RATE_DEG_S:g} deg/s")
        turn_rate = math.radians(r)
    if heading_deg is not None:
        name = label("heading_deg")
        h = _number(heading_deg, name)
        if abs(h) > MAX_HEADING_DEG:
            raise InputError(f"{name} = {h:g} deg is out of range; allowed "
                             f"-{MAX_HEADING_DEG:g} to {MAX_HEADING_DEG:g} deg")
        heading = math.radians(h)
    return Command(speed=speed, turn_rate=turn_rate, heading=heading, gait=gait,
                   leap=bool(leap))


def with_overrides(config: RunConfig, *, duration: float | None = None,
                   fps: float | None = None, units: str | None = None,
                   speed: float | None = None, gait: str | None = None,
                   turn_rate_deg_s: float | None = None) -> RunConfig:
    """A copy of ``config`` with command-line overrides applied.

    ``duration``, ``fps`` and ``units`` replace the config's values. Any of
    ``speed`` (m/s), ``gait`` and ``turn_rate_deg_s`` replaces the scripted
    commands with one constant command: ``gait`` alone runs that gait at its
    preferred speed; ``turn_rate_deg_s`` alone walks at the preferred speed
    of the character's slowest automatic gait while turning.

    Raises
    ------
    InputError
        Naming the flag (``--speed``, ...) and the allowed values.
    """
    changes: dict = {}
    if duration is not None:
        d = _number(duration, "`--seconds`")
        if not 0.0 < d <= MAX_DURATION:
            raise InputError(f"`--seconds` = {d:g} is out of range; allowed 0 < seconds "
                             f"<= {MAX_DURATION:g}")
        changes["duration"] = d
    if fps is not None:
        changes["fps"] = _check_fps(fps, "`--fps`")
    if "duration" in changes or "fps" in changes:
        _check_frames(changes.get("duration", config.duration), changes.get("fps", config.fps),
                      "`--seconds`" if "duration" in changes else "the config's `duration`",
                      "`--fps`" if "fps" in changes else "the config's `fps`",
                      str(config.source) if config.source is not None else "<config>")
    if units is not None:
        if units not in UNITS:
            raise InputError(f"`--units` = {units!r}; allowed: {', '.join(UNITS)}")
        changes["units"] = units
    if speed is not None or gait is not None or turn_rate_deg_s is not None:
        flags = {"speed": "--speed", "gait": "--gait", "turn_rate_deg_s": "--turn-rate"}
        character = config.load_character()
        command = constant_command(character, speed=speed, gait=gait,
                                   turn_rate_deg_s=turn_rate_deg_s,
                                   label=lambda key: f"`{flags[key]}`")
        if config.mode == "data":
            from quadsim.io.clips import playable_gaits

            _check_clip_gait(command, playable_gaits(character), character, gait, "`--gait`")
        changes["commands"] = Script.constant(command)
    return replace(config, **changes) if changes else config


# ------------------------------------------------------------------ helpers
def _check_clip_gait(command: Command, clip_gaits: tuple[str, ...], character, given,
                     label: str) -> None:
    """In data mode, a command's gait must be one the character's clips play."""
    g = command.gait
    if not clip_gaits or g is None:
        return
    if (g if g != "transverse_gallop" else "gallop") not in clip_gaits:
        raise InputError(f"{label} = {given!r} has no clips in {character.id}'s database "
                         f"(data mode); allowed: {', '.join(clip_gaits)}")


def _check_keys(table: dict, allowed: tuple[str, ...], src: str, prefix: str) -> None:
    unknown = [k for k in table if k not in allowed]
    if unknown:
        raise InputError(f"{src}: unknown key `{prefix}{unknown[0]}`; allowed keys"
                         f"{' in a [[command]]' if prefix else ''}: {', '.join(allowed)}")


def _need(table: dict, key: str, where: str):
    if key not in table:
        raise InputError(f"{where}: missing key `{key}`")
    return table[key]


def _number(v, label: str) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise InputError(f"{label} must be a number, got {v!r}")
    v = float(v)
    if not math.isfinite(v):
        raise InputError(f"{label} must be a finite number, got {v}")
    return v


def _check_frames(duration: float, fps: float, duration_label: str, fps_label: str,
                  src: str) -> None:
    """A run must hold at least one frame: ``duration * fps >= 1``.

    Parameters
    ----------
    duration : float
        Run length (s).
    fps : float
        Frames per second.
    duration_label, fps_label : str
        How the message names the two values (a key or a flag).
    src : str
        The config file, for the message.

    Raises
    ------
    InputError
        Naming both values and the shortest duration at this frame rate.
    """
    if duration * fps < 1.0:
        raise InputError(f"{src}: {duration_label} = {duration:g} s at {fps_label} = {fps:g} "
                         f"gives less than one frame ({duration * fps:.3g}); a run needs "
                         f"duration * fps >= 1, here a duration of at least {1.0 / fps:.4g} s "
                         "or a higher fps")


def _check_fps(v, label: str) -> float:
    fps = _number(v, label)
    lo, hi = FPS_RANGE
    if not lo <= fps <= hi:
        raise InputError(f"{label} = {fps:g} is out of range; allowed {lo:g} to {hi:g} "
                         "frames per second")
    return fps


def _gait_table(character) -> dict:
    """The character's gaits by name (only those it has)."""
    from quadsim.locomotion.gaits import gait_table

    table = gait_table(character)
    have = character.locomotion.get("gaits")
    if have:
        table = {k: v for k, v in table.items() if k in have}
    return table


def _resolve_gait(name: str, character, table: dict, label: str) -> str:
    from quadsim.locomotion.gaits import resolve_gait_name

    allowed = ", ".join(table)
    if "transverse_gallop" in table:
        allowed += " (or gallop, meaning transverse_gallop)"
    try:
        resolved = resolve_gait_name(name, character)
    except InputError:
        resolved = None
    if resolved not in table:
        raise InputError(f"{label} = {name!r} is not a gait of {character.id}; "
                         f"allowed: {allowed}")
    return resolved


def _slowest_gait(character, table: dict) -> str:
    from quadsim.locomotion.gaits import auto_gaits

    auto = [g for g in auto_gaits(character) if g in table]
    return auto[0] if auto else min(table, key=lambda g: table[g].speed_range[0])
