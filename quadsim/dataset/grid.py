"""A sweep's grid file: lists of parameters whose product is a dataset of clips.

A grid is a TOML file of top-level keys, each a value or a list of values::

    characters = ["leopard", "dog_cub"]      # identifiers or character files
    gaits = ["walk", "trot", "canter"]
    speeds = "preferred"                     # m/s, or each gait's preferred speed
    turn_rates_deg_s = [0, 20]
    seeds = [0, 1]
    seconds = 4
    fps = 60
    format = "npz"                           # or "bvh", "glb"

The sweep is the product of the lists (:meth:`Grid.clips`), in that order
(characters outermost, formats innermost). ``characters`` and ``gaits`` are
required; the others default to ``"preferred"``, ``[0]``, ``[0]``, 10 s,
60 fps and ``"npz"``. Character files are found relative to the grid file.

Each :class:`ClipSpec` has a stable identifier made from its parameters
alone (a hash of them, with the content of a character file rather than its
path), so the same clip gets the same name in every run, on every machine.
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

from quadsim.errors import InputError, read_toml

__all__ = ["DEFAULTS", "FORMATS", "KEYS", "ClipSpec", "Grid", "clamps", "load_grid", "parse_grid"]

#: The formats a sweep writes, each clip one file of that extension.
FORMATS = ("npz", "bvh", "glb")
#: Every key a grid file may hold, in the product's order.
KEYS = ("characters", "gaits", "speeds", "turn_rates_deg_s", "seeds", "seconds", "fps",
        "format")
#: The values of the keys a grid may leave out.
DEFAULTS = {"speeds": ("preferred",), "turn_rates_deg_s": (0.0,), "seeds": (0,),
            "seconds": (10.0,), "fps": (60.0,), "format": ("npz",)}
#: Fewest frames a clip may have (the measurements need three).
MIN_FRAMES = 3


@dataclass(frozen=True)
class ClipSpec:
    """One clip of a sweep: a character under one constant command.

    Attributes
    ----------
    character : str
        The character's identifier (``"leopard"``; from its file for a file).
    source : str
        What to load it from: the identifier of a shipped character, or the
        absolute path of a character file.
    digest : str
        SHA-256 of the character file's bytes (``""`` for a shipped character).
    gait : str
        Canonical gait name (``"transverse_gallop"`` for ``"gallop"``).
    speed : float
        Commanded forward speed (m/s).
    turn_rate_deg_s : float
        Commanded turn rate (deg/s, positive left).
    seed : int
        Seed of the oscillators' start offsets (the procedural controller's).
    seconds : float
        Length (s); the clip has ``round(seconds * fps)`` frames.
    fps : float
        Frames per second.
    format : {"npz", "bvh", "glb"}
    """

    character: str
    source: str
    digest: str
    gait: str
    speed: float
    turn_rate_deg_s: float
    seed: int
    seconds: float
    fps: float
    format: str

    @property
    def frames(self) -> int:
        """Number of frames, ``round(seconds * fps)``."""
        return round(self.seconds * self.fps)

    def parameters(self) -> dict:
        """The parameters as the manifest records them (plain JSON values)."""
        return {"character": self.character, "gait": self.gait, "speed": self.speed,
                "turn_rate_deg_s": self.turn_rate_deg_s, "seed": self.seed,
                "seconds": self.seconds, "fps": self.fps, "format": self.format}

    @cached_property
    def id(self) -> str:
        """Stable identifier: character, gait and 12 hex digits of a hash of every
        parameter (the character file by its content), e.g. ``leopard-trot-3f2a...``
        (found once a spec)."""
        key = dict(self.parameters(), character_file=self.digest)
        text = json.dumps(key, sort_keys=True, separators=(",", ":"))
        h = hashlib.sha256(text.encode("utf-8")).hexdigest()[:12]
        return f"{_slug(self.character)}-{_slug(self.gait)}-{h}"

    @cached_property
    def path(self) -> str:
        """The clip's file relative to the sweep's folder (``clips/<id>.<format>``)."""
        return f"clips/{self.id}.{self.format}"


def _slug(text: str) -> str:
    return "".join(c if c.isalnum() or c == "_" else "_" for c in text.lower())


@dataclass(frozen=True)
class Grid:
    """A parsed grid file: the lists whose product is the sweep.

    Attributes
    ----------
    source : str
        The grid file (for messages).
    characters : tuple of (str, str, str)
        Each character's identifier, source (identifier or absolute file path)
        and file digest (see :class:`ClipSpec`).
    gaits : tuple of str
        Canonical gait names.
    speeds : tuple of (float or "preferred")
        m/s; ``"preferred"`` is each gait's preferred speed, character by character.
    turn_rates_deg_s : tuple of float
    seeds : tuple of int
    seconds, fps : tuple of float
    formats : tuple of str
    """

    source: str
    characters: tuple
    gaits: tuple
    speeds: tuple
    turn_rates_deg_s: tuple
    seeds: tuple
    seconds: tuple
    fps: tuple
    formats: tuple

    def clips(self) -> list[ClipSpec]:
        """Every clip of the sweep, in the product's order, each once (a speed that
        appears both as a number and as ``"preferred"`` gives one clip)."""
        from quadsim.skeleton.character import load_character

        out: dict[str, ClipSpec] = {}
        for cid, src, digest in self.characters:
            table = _gait_table(load_character(src))
            for gait in self.gaits:
                for v in self.speeds:
                    speed = float(table[gait].preferred_speed) if v == "preferred" else v
                    for tr in self.turn_rates_deg_s:
                        for seed in self.seeds:
                            for s in self.seconds:
                                for fps in self.fps:
                                    for fmt in self.formats:
                                        c = ClipSpec(cid, src, digest, gait, speed, tr, seed,
                                                     s, fps, fmt)
                                        out.setdefault(c.id, c)
        return list(out.values())

    def __len__(self) -> int:
        return len(self.clips())


def clamps(clips) -> list[str]:
    """What the controller will clamp in these clips, once per distinct case.

    A speed above what a gait is held at (15 % above its range, at most the
    character's top speed), or a turn rate above the character's maximum at
    the speed it runs, is clamped by the controller (silently in a sweep: the
    measured speed in the manifest shows it). Returns one message each.
    """
    from quadsim.locomotion.controller import ProceduralController
    from quadsim.skeleton.character import load_character

    out: dict[str, None] = {}
    ctl: dict[str, ProceduralController] = {}
    for c in clips:
        k = ctl.get(c.source)
        if k is None:
            k = ctl[c.source] = ProceduralController(load_character(c.source))
        cap = k.gait_speed_cap(c.gait)
        if c.speed > cap:
            out[f"`speeds`: {c.speed:g} m/s is above what the {c.gait} of {c.character} "
                f"reaches; its clips run at {cap:.2f} m/s"] = None
        limit = math.degrees(k.max_turn_rate_at(min(c.speed, cap)))
        if abs(c.turn_rate_deg_s) > limit:
            out[f"`turn_rates_deg_s`: {c.turn_rate_deg_s:g} deg/s is beyond what "
                f"{c.character} turns at {min(c.speed, cap):.2f} m/s in the {c.gait} "
                f"({limit:.1f} deg/s); clamped"] = None
    return list(out)


def _gait_table(character):
    from quadsim.locomotion.gaits import gait_table

    return gait_table(character)


def load_grid(path) -> Grid:
    """Read and check a grid file.

    Parameters
    ----------
    path : str or path-like

    Returns
    -------
    Grid

    Raises
    ------
    InputError
        For a missing or malformed file, an unknown key, or a bad value; the
        message names the file and the key, and says what is allowed.
    """
    path = Path(path)
    return parse_grid(read_toml(path, "grid"), source=str(path), folder=path.parent)


def parse_grid(data: dict, *, source: str = "the grid", folder=".") -> Grid:
    """Check a grid's keys and values (see :func:`load_grid`); ``folder`` is where
    character files are looked for."""
    unknown = [k for k in data if k not in KEYS]
    if unknown:
        raise InputError(f"{source}: unknown key {unknown[0]!r}; allowed: {', '.join(KEYS)}")
    for key in ("characters", "gaits"):
        if key not in data:
            raise InputError(f"{source}: `{key}` is missing; give a list, e.g. "
                             + ('characters = ["leopard"]' if key == "characters"
                                else 'gaits = ["walk", "trot"]'))
    lists = {k: _as_list(data[k], k, source) if k in data else DEFAULTS[k] for k in KEYS}
    chars = tuple(_character(c, source, Path(folder)) for c in _strings(lists, "characters",
                                                                        source))
    _no_repeats([c[2] or c[1] for c in chars], "characters", source)
    loaded = [c[3] for c in chars]
    gaits = _gaits(_strings(lists, "gaits", source), loaded, source)
    fps = tuple(_positive(v, "fps", source) for v in lists["fps"])
    seconds = tuple(_positive(v, "seconds", source) for v in lists["seconds"])
    for s in seconds:
        for f in fps:
            if round(s * f) < MIN_FRAMES:
                raise InputError(f"{source}: `seconds` = {s:g} at `fps` = {f:g} gives "
                                 f"{round(s * f)} frames; a clip needs at least {MIN_FRAMES}")
    speeds = tuple(_speed(v, loaded, source) for v in lists["speeds"])
    turns = tuple(_turn(v, source) for v in lists["turn_rates_deg_s"])
    seeds = tuple(_seed(v, source) for v in lists["seeds"])
    formats = tuple(_format(v, source) for v in lists["format"])
    for key, values in (("gaits", gaits), ("speeds", speeds), ("turn_rates_deg_s", turns),
                        ("seeds", seeds), ("seconds", seconds), ("fps", fps),
                        ("format", formats)):
        _no_repeats(values, key, source)
    return Grid(source, tuple(c[:3] for c in chars), gaits, speeds, turns, seeds, seconds,
                fps, formats)


def _as_list(value, key: str, source: str) -> tuple:
    values = tuple(value) if isinstance(value, list) else (value,)
    if not values:
        raise InputError(f"{source}: `{key}` is an empty list; give at least one value")
    return values


def _strings(lists: dict, key: str, source: str) -> tuple:
    for v in lists[key]:
        if not isinstance(v, str) or not v.strip():
            raise InputError(f"{source}: `{key}` holds {v!r}; give names (strings)")
    return lists[key]


def _no_repeats(values, key: str, source: str) -> None:
    seen = set()
    for v in values:
        if v in seen:
            raise InputError(f"{source}: `{key}` lists {v!r} twice; give each value once")
        seen.add(v)


def _character(ref: str, source: str, folder: Path):
    """(identifier, source, digest, Character) of a grid entry."""
    from quadsim.skeleton.character import load_character

    is_file = ref.endswith(".toml") or "/" in ref or "\\" in ref
    if is_file:
        p = Path(ref) if Path(ref).is_absolute() else folder / ref
        if not p.is_file():
            raise InputError(f"{source}: `characters`: {ref!r}: no such character file "
                             f"(looked for {p}); give a shipped identifier "
                             "(`quadsim characters`) or a character file")
        try:
            ch = load_character(p)
        except InputError as e:
            raise InputError(f"{source}: `characters`: {e}") from None
        digest = hashlib.sha256(p.read_bytes()).hexdigest()
        return ch.id, str(p.resolve()), digest, ch
    try:
        ch = load_character(ref)
    except InputError as e:
        raise InputError(f"{source}: `characters`: {e}") from None
    return ch.id, ch.id, "", ch


def _gaits(names, characters, source: str) -> tuple:
    from quadsim.locomotion.gaits import resolve_gait_name

    out = []
    for name in names:
        canon = None
        for ch in characters:
            try:
                c = resolve_gait_name(name, ch)
            except InputError as e:
                raise InputError(f"{source}: `gaits`: {e}") from None
            canon = c if canon is None else canon
        out.append(canon)
    return tuple(out)


def _number(v, key: str, source: str) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise InputError(f"{source}: `{key}` holds {v!r}; give numbers")
    return float(v)


def _positive(v, key: str, source: str) -> float:
    x = _number(v, key, source)
    if x <= 0:
        raise InputError(f"{source}: `{key}` holds {v!r}; give numbers above 0")
    return x


def _speed(v, characters, source: str):
    if v == "preferred":
        return v
    if isinstance(v, str):
        raise InputError(f"{source}: `speeds` holds {v!r}; give speeds in m/s or "
                         "\"preferred\" (each gait's preferred speed)")
    x = _number(v, "speeds", source)
    from quadsim.config import SPEED_MARGIN

    for ch in characters:
        top = SPEED_MARGIN * max(g.speed_range[1] for g in _gait_table(ch).values())
        if not 0.0 <= x <= top:
            raise InputError(f"{source}: `speeds` holds {x:g} m/s, out of range for "
                             f"{ch.id}; allowed 0 to {top:.3g} m/s")
    return x


def _turn(v, source: str) -> float:
    from quadsim.config import MAX_TURN_RATE_DEG_S

    x = _number(v, "turn_rates_deg_s", source)
    if abs(x) > MAX_TURN_RATE_DEG_S:
        raise InputError(f"{source}: `turn_rates_deg_s` holds {x:g} deg/s; allowed "
                         f"-{MAX_TURN_RATE_DEG_S:g} to {MAX_TURN_RATE_DEG_S:g}")
    return x


def _seed(v, source: str) -> int:
    if isinstance(v, bool) or not isinstance(v, int) or v < 0:
        raise InputError(f"{source}: `seeds` holds {v!r}; give whole numbers >= 0")
    return int(v)


def _format(v, source: str) -> str:
    if not isinstance(v, str) or v.lower().lstrip(".") not in FORMATS:
        raise InputError(f"{source}: `format` = {v!r}; allowed: {', '.join(FORMATS)}")
    return v.lower().lstrip(".")
