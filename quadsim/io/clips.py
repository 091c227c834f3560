"""Clip folders: a character's looped gait clips, as BVH files plus a TOML manifest.

The manifest (``manifest.toml`` in the clip folder) has one table per clip::

    [clips.walk_1.4]
    file = "walk_1.4.bvh"          # BVH in the same folder, metres
    gait = "walk"                  # walk, amble, trot, rack, canter, gallop, leap
    speed = 1.4                    # forward speed of the clip (m/s)
    frames = 52                    # frames per cycle (the BVH holds at least this many)
    touchdown = { LF = 13, RF = 39, LH = 0, RH = 26 }   # frame of each foot's touchdown
    lead = "left"                  # canter, gallop and leap: the leading fore leg
    source = "how the clip was made"

A leap clip also gives ``start_gait`` (the gait it starts from) and
``height`` (the clearance of its feet at the top of the flight, m). Leap
clips are optional.

A gait's contact-time law (``Tc = a v^b``, Tc in s, v in m/s) may be given
in a top-level table; a gait without one uses the horse's Table 1
(:data:`quadsim.horse.speed.HOYT`) where it has a row, else an exponent of
its own clips (:func:`quadsim.horse.playback.gait_law`)::

    [laws.trot]
    a = 0.31                       # contact time (s) at 1 m/s
    b = -0.68
    anchor = "law"                 # or "clip": (v / v0)^b relative to the clip

Clips are read onto the character's skeleton by joint name: every joint of
the character's legs must be present in the BVH; other character joints the
file lacks stay at rest. :func:`load_database` reads any folder,
:func:`load_default_database` a character's shipped one
(:func:`clip_folder`: the folder the character file's ``character.clips``
names, else ``characters/<id>/clips``); the result is a
:class:`~quadsim.horse.database.ClipDatabase` for
:class:`~quadsim.horse.controller.HorseDataController`.
"""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np

from quadsim.errors import InputError
from quadsim.horse.database import (
    ASYMMETRIC,
    CLIP_GAITS,
    GAIT_ALIASES,
    LEGS,
    Clip,
    ClipDatabase,
    SpeedLaw,
)
from quadsim.io.bvh import read_bvh
from quadsim.skeleton.character import Character, characters_dir
from quadsim.skeleton.motion import Motion

__all__ = ["LAW_KEYS", "MANIFEST_KEYS", "clip_folder", "load_database",
           "load_default_database", "playable_gaits", "retarget_clip"]

#: The fields a manifest's clip table may have.
MANIFEST_KEYS = frozenset({"file", "gait", "speed", "frames", "touchdown", "lead", "source",
                           "start_gait", "height"})
#: The fields of a manifest's ``[laws.<gait>]`` table.
LAW_KEYS = frozenset({"a", "b", "anchor", "source"})


def load_database(folder, character: Character) -> ClipDatabase:
    """Read and validate a clip folder (``manifest.toml`` plus BVH files).

    Raises
    ------
    InputError
        Naming the manifest, the clip and the field at fault.
    """
    folder = Path(folder)
    man = folder / "manifest.toml"
    if not man.is_file():
        raise InputError(f"{folder}: no manifest.toml in the clip folder")
    try:
        data = tomllib.loads(man.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as e:
        raise InputError(f"{man}: not valid TOML: {e}") from None
    unknown = set(data) - {"clips", "description", "laws"}
    if unknown:
        raise InputError(f"{man}: unknown top-level key(s) {sorted(unknown)}; "
                         "allowed: clips, description, laws")
    table = data.get("clips")
    if not isinstance(table, dict) or not table:
        raise InputError(f"{man}: `clips` must be a table with at least one clip")
    clips = {}
    for name, entry in table.items():
        where = f"{man}: clip {name!r}"
        clips[name] = _load_clip(name, entry, where, folder, character)
    return ClipDatabase(character, clips, folder, _load_laws(data.get("laws", {}), man))


def _load_laws(table, man) -> dict:
    """The ``[laws.<gait>]`` tables as :class:`~quadsim.horse.database.SpeedLaw` by gait."""
    if not isinstance(table, dict):
        raise InputError(f"{man}: `laws` must be a table of [laws.<gait>] tables")
    out = {}
    for gait, t in table.items():
        where = f"{man}: laws.{gait}"
        g = GAIT_ALIASES.get(gait, gait)
        if g not in CLIP_GAITS[:-1]:
            raise InputError(f"{where}: {gait!r} is not a known gait; allowed: "
                             f"{', '.join(CLIP_GAITS[:-1])}")
        if not isinstance(t, dict):
            raise InputError(f"{where}: must be a table {{ a = .., b = .. }}")
        bad = set(t) - LAW_KEYS
        if bad:
            raise InputError(f"{where}: unknown field(s) {sorted(bad)}; "
                             f"allowed: {sorted(LAW_KEYS)}")
        a, b = t.get("a"), t.get("b")
        if isinstance(a, bool) or not isinstance(a, (int, float)) or not 0 < a < 1e3:
            raise InputError(f"{where}: `a` must be a positive number (s, the contact time "
                             f"at 1 m/s), got {a!r}")
        if isinstance(b, bool) or not isinstance(b, (int, float)) or not -3.0 <= b <= 0.5:
            raise InputError(f"{where}: `b` must be a number in [-3, 0.5] (the exponent), "
                             f"got {b!r}")
        anchor = t.get("anchor", "law")
        if anchor not in ("law", "clip"):
            raise InputError(f"{where}: `anchor` must be \"law\" or \"clip\", got {anchor!r}")
        out[g] = SpeedLaw(float(a), float(b), anchor)
    return out


def _load_clip(name, entry, where, folder, character) -> Clip:
    if not isinstance(entry, dict):
        raise InputError(f"{where}: must be a table")
    bad = set(entry) - MANIFEST_KEYS
    if bad:
        raise InputError(f"{where}: unknown field(s) {sorted(bad)}; "
                         f"allowed: {sorted(MANIFEST_KEYS)}")
    for key in ("file", "gait", "speed", "frames", "touchdown"):
        if key not in entry:
            raise InputError(f"{where}: missing field `{key}`")
    gait = GAIT_ALIASES.get(entry["gait"], entry["gait"])
    if gait not in CLIP_GAITS:
        raise InputError(f"{where}: `gait` = {entry['gait']!r} is not a known gait; "
                         f"allowed: {', '.join(CLIP_GAITS)}")
    speed = entry["speed"]
    if isinstance(speed, bool) or not isinstance(speed, (int, float)) or not speed > 0:
        raise InputError(f"{where}: `speed` must be a positive number (m/s), got {speed!r}")
    frames = entry["frames"]
    if isinstance(frames, bool) or not isinstance(frames, int) or frames < 4:
        raise InputError(f"{where}: `frames` must be an integer >= 4, got {frames!r}")
    td = entry["touchdown"]
    if not isinstance(td, dict):
        raise InputError(f"{where}: `touchdown` must be a table {{ LF = .., RF = .., LH = .., RH = .. }}")
    for leg in LEGS:
        if leg not in td:
            raise InputError(f"{where}: `touchdown` is missing foot {leg}")
    extra = set(td) - set(LEGS)
    if extra:
        raise InputError(f"{where}: `touchdown` has unknown foot/feet {sorted(extra)}; "
                         f"allowed: {', '.join(LEGS)}")
    tdf = []
    for leg in LEGS:
        v = td[leg]
        if isinstance(v, bool) or not isinstance(v, int) or not 0 <= v < frames:
            raise InputError(f"{where}: `touchdown.{leg}` = {v!r} is out of range; "
                             f"expected a frame in [0, {frames})")
        tdf.append(v)
    lead = entry.get("lead")
    if gait in ASYMMETRIC:
        if lead not in ("left", "right"):
            raise InputError(f"{where}: `lead` must be \"left\" or \"right\" for a {gait} clip, "
                             f"got {lead!r}")
    elif lead is not None:
        raise InputError(f"{where}: `lead` is only for {', '.join(ASYMMETRIC)} clips")
    start_gait = entry.get("start_gait")
    height = entry.get("height")
    if gait == "leap":
        if GAIT_ALIASES.get(start_gait, start_gait) not in CLIP_GAITS[:-1]:
            raise InputError(f"{where}: a leap clip needs `start_gait`, one of "
                             f"{', '.join(CLIP_GAITS[:-1])}; got {start_gait!r}")
        start_gait = GAIT_ALIASES.get(start_gait, start_gait)
        if isinstance(height, bool) or not isinstance(height, (int, float)) or not height > 0:
            raise InputError(f"{where}: a leap clip needs `height` > 0 (m), got {height!r}")
    path = folder / str(entry["file"])
    if not path.is_file():
        raise InputError(f"{where}: `file` {str(entry['file'])!r}: BVH file not found at {path}")
    try:
        raw = read_bvh(path)
    except (InputError, ValueError, OSError) as e:
        raise InputError(f"{where}: `file` {path.name!r} is not a usable BVH: {e}") from None
    motion = retarget_clip(raw, character, f"{where}: `file` {path.name!r}")
    if len(motion) < frames:
        raise InputError(f"{where}: `frames` = {frames} is out of range: "
                         f"the BVH holds only {len(motion)} frames")
    motion = motion[:frames]
    return Clip(name, gait, float(speed), frames, np.array(tdf), lead, motion,
                str(entry.get("source", "")), start_gait,
                None if height is None else float(height))


def retarget_clip(raw: Motion, character: Character, where: str) -> Motion:
    """Put a read motion (a clip's BVH) on the character's skeleton by joint name;
    ``where`` names the file in errors."""
    skel = character.skeleton
    names = set(raw.skeleton.names)
    leg_joints = [skel.names[j] for leg in character.legs for j in leg.chain]
    missing = [n for n in leg_joints if n not in names]
    if missing:
        raise InputError(f"{where}: joint names do not match the character's legs "
                         f"({character.id}); missing {', '.join(missing[:6])}"
                         f"{' ...' if len(missing) > 6 else ''}")
    if raw.skeleton.names[0] != skel.names[0]:
        raise InputError(f"{where}: the root joint is {raw.skeleton.names[0]!r}, "
                         f"expected {skel.names[0]!r}")
    T = len(raw)
    rot = np.zeros((T, skel.n_joints, 4))
    rot[..., 0] = 1.0
    for j, n in enumerate(skel.names):
        if n in names:
            rot[:, j] = raw.rotations[:, raw.skeleton.index(n)]
    return Motion(skel, raw.fps, raw.root_positions, rot, foot_joints=character.foot_joints)


def clip_folder(character: Character) -> Path | None:
    """The clip folder of a character: the one its file names (``character.clips``),
    else the shipped ``characters/<id>/clips``, if it exists."""
    named = None if character.file is None else character.file.character.clips
    if named is not None:
        return named if (named / "manifest.toml").is_file() else None
    d = characters_dir() / character.id / "clips"
    return d if (d / "manifest.toml").is_file() else None


def playable_gaits(character: Character) -> tuple[str, ...]:
    """The gaits the character's clips (:func:`clip_folder`) can be asked for (leap clips excepted),
    read from the manifest alone (no clip is loaded); empty without a clip folder."""
    d = clip_folder(character)
    if d is None:
        return ()
    try:
        table = tomllib.loads((d / "manifest.toml").read_text(encoding="utf-8")).get("clips")
    except tomllib.TOMLDecodeError:
        return ()                       # loading the database names the fault
    gaits = {GAIT_ALIASES.get(e.get("gait"), e.get("gait")) for e in (table or {}).values()
             if isinstance(e, dict)}
    return tuple(g for g in CLIP_GAITS if g in gaits and g != "leap")


def load_default_database(character: Character) -> ClipDatabase:
    """The character's clip database (:func:`clip_folder`: its file's
    ``character.clips``, else the shipped ``characters/<id>/clips``)."""
    d = clip_folder(character)
    if d is None:
        raise InputError(f"character {character.id!r} has no clip database "
                         f"(characters/{character.id}/clips/manifest.toml, or a "
                         "`clips = \"DIR\"` key in its file's [character] table: cut one "
                         "with `quadsim clips-from`)")
    return load_database(d, character)
