"""A character file as written: TOML read into frozen dataclasses, every key checked.

:func:`read_character_file` reads a character file (the format is in
:mod:`quadsim.skeleton.character`) into a :class:`CharacterFile`: its tables
become frozen dataclasses, numbers become floats, lists become tuples. It
checks what the file alone can say:

- every key at every level is known (a misspelt key is an error naming the
  file, the key, the allowed keys and the nearest one);
- every value has its type (offsets are three finite numbers, ``mass`` is a
  positive number, a leg's ``bend`` is ``"forward"`` or ``"back"``...);
- no bone has zero length: every joint but the root sits at least
  :data:`MIN_BONE` from its parent, and so does every ``end`` tip;
- each joint limit is ``[min_deg, max_deg]`` with
  ``-180 <= min_deg <= 0 <= max_deg <= 180`` and ``min_deg < max_deg`` (the
  rest pose, flexion 0, is allowed).

What needs the whole skeleton (a leg that cannot stand on the ground at its
rest height, a leg out of its plane, chains that are not chains) is checked
when the character is built from it
(:func:`quadsim.skeleton.character.build_character`). Every error is a
:class:`~quadsim.errors.InputError` whose message starts with the file and
names the field (``joints[3].offset``, ``legs.LH.ik``, ``limits.LF_elbow``).
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from pathlib import Path
from types import MappingProxyType

from quadsim.errors import InputError, read_toml

__all__ = [
    "GAIT_FIELDS",
    "MIN_BONE",
    "Chains",
    "CharacterFile",
    "CharacterMeta",
    "JointEntry",
    "LegEntry",
    "LocomotionTable",
    "character_file_from_dict",
    "locomotion_table",
    "read_character_file",
]

#: Shortest bone (m): a joint closer than this to its parent has no direction.
MIN_BONE = 1e-6
#: Legs a file may describe, in leg order; ``RF``/``RH`` may come by mirroring.
LEG_NAMES = ("LF", "RF", "LH", "RH")
#: Keys of a ``[gaits.<name>]`` override table (read by
#: :func:`quadsim.locomotion.gaits.gait_table`).
GAIT_FIELDS = ("duty", "phase", "froude", "speed", "stride", "swing_height", "spine",
               "spine_deg", "drop")

_TOP_KEYS = ("mirror_left_legs", "joints", "character", "chains", "legs", "limits",
             "locomotion", "gaits")
_JOINT_KEYS = ("name", "parent", "offset", "end")
_META_KEYS = ("id", "name", "species", "mass", "sources", "model", "clips")
_CHAIN_KEYS = ("spine", "neck", "head", "tail")
_LEG_KEYS = ("chain", "ik", "bend", "pre_gain", "post_gain")


# ------------------------------------------------------------ the tables
@dataclass(frozen=True)
class JointEntry:
    """One entry of ``joints``.

    Attributes
    ----------
    name, parent : str
        ``parent`` is ``""`` for the root (the first joint).
    offset : tuple of float, length 3
        Rest offset from the parent in world axes (m); the root's is its
        standing position.
    end : tuple of float, length 3, or None
        Bone tip of a leaf joint (m), relative to the joint.
    """

    name: str
    parent: str
    offset: tuple[float, float, float]
    end: tuple[float, float, float] | None = None


@dataclass(frozen=True)
class CharacterMeta:
    """The ``[character]`` table: ``id``, ``name``, ``species``, ``mass`` (kg), ``sources``,
    and ``model``: the user's own rig (glTF model or BVH) the character was adopted from,
    its path relative to the character file (an absolute :class:`~pathlib.Path` here),
    and ``clips``: the character's clip database for the data mode, a folder holding a
    ``manifest.toml`` (as ``quadsim clips-from`` writes), relative to the file likewise."""

    id: str
    name: str
    species: str
    mass: float
    sources: tuple[str, ...] = ()
    model: Path | None = None
    clips: Path | None = None


@dataclass(frozen=True)
class Chains:
    """The ``[chains]`` table: joint names; ``neck`` and ``tail`` may be empty."""

    spine: tuple[str, ...]
    head: str
    neck: tuple[str, ...] = ()
    tail: tuple[str, ...] = ()


@dataclass(frozen=True)
class LegEntry:
    """One ``[legs.<leg>]`` table.

    Attributes
    ----------
    chain : tuple of str
        From the top of the leg to the foot contact joint.
    ik : str
        First joint of the two-bone pair.
    bend : str
        ``"forward"`` (knee) or ``"back"`` (elbow).
    pre_gain, post_gain : float or None
        ``None`` when not given (the :class:`~quadsim.skeleton.character.LegSpec`
        default applies).
    """

    chain: tuple[str, ...]
    ik: str
    bend: str
    pre_gain: float | None = None
    post_gain: float | None = None


@dataclass(frozen=True)
class LocomotionTable(Mapping):
    """The ``[locomotion]`` table; a key left out is ``None`` here.

    It is also a read-only mapping of the keys the file gives, so
    ``character.locomotion.get("max_turn_rate_deg_s", 90.0)`` works as on
    the parsed TOML table.

    Attributes
    ----------
    gaits : tuple of str or None
        The character's gaits (default: every gait of the shared table).
    auto : tuple of str or None
        Gaits chosen by speed, a subset of ``gaits``.
    max_turn_rate_deg_s : float or None
        Largest turn rate (deg/s), positive.
    spine_flex_deg, spine_extend_deg : float or None
        Spine flexion targets of the bounding gaits (deg).
    spine_slow_scale : float or None
        Scale of the spine motion at slow speeds, at least 0.
    min_turn_radius_body_lengths : float or None
        Tightest turn radius in body lengths, positive.
    head_nod_deg : float or None
        How far the head and neck pitch down (deg) while the fore legs bear
        more of the weight than the hind ones (see
        :func:`~quadsim.locomotion.pose_kernel.nod_of`); 0 or absent keeps the
        head level in space, as cats and dogs hold it.
    toe_roll_deg : float or None
        How far each foot rolls over its toe tip by lift-off (deg): the heel
        rises through the last part of the stance, the toe tip planted
        (:mod:`quadsim.locomotion.feet`); 0 or absent keeps it flat.
    fetlock_sink_deg : float or None
        How far each leg's digit (the bones below the first one under its IK
        pair: a horse's pasterns) turns towards the ground under a load of the
        body's weight (deg), the fetlock sinking through the stance and
        recovering by lift-off (:func:`~quadsim.locomotion.feet.stance_load`);
        0 or absent keeps the digit at its rest angle to the leg.
    digit_flex_deg : float or None
        How far each fore leg's digit flexes back behind its cannon in mid-swing
        (deg), on top of the cannon's fold (a hoof tucks up behind the carpus);
        0 or absent folds it with its own joint only.
    """

    gaits: tuple[str, ...] | None = None
    auto: tuple[str, ...] | None = None
    max_turn_rate_deg_s: float | None = None
    spine_flex_deg: float | None = None
    spine_extend_deg: float | None = None
    spine_slow_scale: float | None = None
    min_turn_radius_body_lengths: float | None = None
    head_nod_deg: float | None = None
    toe_roll_deg: float | None = None
    fetlock_sink_deg: float | None = None
    digit_flex_deg: float | None = None

    def __getitem__(self, key: str):
        value = getattr(self, key, None) if key in _LOCOMOTION_KEYS else None
        if value is None:
            raise KeyError(key)
        return value

    def __iter__(self):
        return (k for k in _LOCOMOTION_KEYS if getattr(self, k) is not None)

    def __len__(self) -> int:
        return sum(1 for _ in self)


_LOCOMOTION_KEYS = tuple(f.name for f in fields(LocomotionTable))
#: name: (lowest, highest, lowest allowed itself); None for no bound.
_LOCOMOTION_RANGES = {
    "max_turn_rate_deg_s": (0.0, 3600.0, False),
    "spine_flex_deg": (-90.0, 90.0, True),
    "spine_extend_deg": (-90.0, 90.0, True),
    "spine_slow_scale": (0.0, 10.0, True),
    "min_turn_radius_body_lengths": (0.0, 100.0, False),
    "head_nod_deg": (0.0, 45.0, True),
    "toe_roll_deg": (0.0, 60.0, True),
    "fetlock_sink_deg": (0.0, 45.0, True),
    "digit_flex_deg": (0.0, 90.0, True),
}


@dataclass(frozen=True)
class CharacterFile:
    """A character file as written, checked key by key.

    Attributes
    ----------
    source : str
        The file (or ``"<character>"``), for messages.
    character : CharacterMeta
    joints : tuple of JointEntry
        As written, parents first; mirroring is not applied here.
    mirror_left_legs : bool
    chains : Chains
    legs : mapping of str to LegEntry
        By leg name, as written (``LF`` and ``LH`` only when mirrored).
    limits : mapping of str to (float, float)
        Joint name to ``(min_deg, max_deg)``, as written (degrees).
    locomotion : LocomotionTable
    gaits : mapping of str to mapping
        ``[gaits.<name>]`` overrides by gait; their values are checked by
        :func:`quadsim.locomotion.gaits.gait_table`.
    """

    source: str
    character: CharacterMeta
    joints: tuple[JointEntry, ...]
    mirror_left_legs: bool
    chains: Chains
    legs: Mapping[str, LegEntry]
    limits: Mapping[str, tuple[float, float]] = field(default_factory=dict)
    locomotion: LocomotionTable = field(default_factory=LocomotionTable)
    gaits: Mapping[str, Mapping] = field(default_factory=dict)


# --------------------------------------------------------------- reading
def read_character_file(path: str | Path,
                        gait_names: tuple[str, ...] | None = None) -> CharacterFile:
    """Read and check a character file.

    Parameters
    ----------
    path : str or Path
    gait_names : tuple of str, optional
        The gaits of the shared gait table; given, ``locomotion.gaits`` and
        ``locomotion.auto`` may name only these, and a ``[gaits.<name>]``
        table must name one of the character's gaits.

    Raises
    ------
    InputError
        When the file is missing, is not UTF-8 TOML, or breaks a rule of the
        format; the message names the file and the key.
    """
    path = Path(path)
    data = read_toml(path, "character")
    return character_file_from_dict(data, str(path), gait_names)


def character_file_from_dict(data: dict, src: str = "<character>",
                             gait_names: tuple[str, ...] | None = None) -> CharacterFile:
    """Check parsed TOML data (a dict) and build a :class:`CharacterFile`.

    ``src`` names the file in error messages; ``gait_names`` as in
    :func:`read_character_file`.
    """
    _check_keys(data, _TOP_KEYS, f"{src}: top level")
    mirror = data.get("mirror_left_legs", False)
    if not isinstance(mirror, bool):
        raise InputError(f"{src}: `mirror_left_legs` must be true or false, got {mirror!r}")
    joints = tuple(_joint(j, f"{src}: joints[{k}]", first=k == 0)
                   for k, j in enumerate(_need(data, "joints", src, list)))
    if not joints:
        raise InputError(f"{src}: `joints` is empty; the first joint is the root")
    legs_t = _need(data, "legs", src, dict)
    _check_keys(legs_t, LEG_NAMES, f"{src}: [legs]")
    legs = {}
    for name in LEG_NAMES:
        if name in legs_t:
            if not isinstance(legs_t[name], dict):
                raise InputError(f"{src}: legs.{name} must be a table, written [legs.{name}]")
            legs[name] = _leg(legs_t[name], f"{src}: legs.{name}")
    locomotion = locomotion_table(_table(data, "locomotion", src), src, gait_names)
    return CharacterFile(
        source=src,
        character=_meta(_need(data, "character", src, dict), f"{src}: [character]", src),
        joints=joints,
        mirror_left_legs=mirror,
        chains=_chains(_need(data, "chains", src, dict), src),
        legs=MappingProxyType(legs),
        limits=MappingProxyType(_limits(_table(data, "limits", src), src)),
        locomotion=locomotion,
        gaits=_gaits(_table(data, "gaits", src), locomotion.gaits or gait_names, src),
    )


# --------------------------------------------------------------- tables
def _joint(j, where: str, first: bool) -> JointEntry:
    if not isinstance(j, dict):
        raise InputError(f"{where} must be a table {{ name, parent, offset }}")
    _check_keys(j, _JOINT_KEYS, where)
    name = _need(j, "name", where, str)
    parent = _need(j, "parent", where, str)
    offset = _vec(_need(j, "offset", where), f"{where}.offset")
    end = _vec(j["end"], f"{where}.end") if "end" in j else None
    if not first and math.hypot(*offset) < MIN_BONE:
        raise InputError(f"{where}.offset = {list(offset)}: joint {name!r} sits on its parent "
                         f"{parent!r}, a bone of zero length; give it a length of at least "
                         f"{MIN_BONE:g} m")
    if end is not None and math.hypot(*end) < MIN_BONE:
        raise InputError(f"{where}.end = {list(end)}: the bone tip of {name!r} has zero "
                         f"length; leave `end` out or give it at least {MIN_BONE:g} m")
    return JointEntry(name, parent, offset, end)


def _meta(t: dict, where: str, src: str) -> CharacterMeta:
    _check_keys(t, _META_KEYS, where)
    ident = _need(t, "id", where, str)
    if not ident:
        raise InputError(f"{src}: character.id must not be empty")
    name = t.get("name", ident)
    species = t.get("species", "")
    for key, v in (("name", name), ("species", species)):
        if not isinstance(v, str):
            raise InputError(f"{src}: character.{key} must be a string, got {v!r}")
    mass = _need(t, "mass", where)
    if (isinstance(mass, bool) or not isinstance(mass, (int, float))
            or not math.isfinite(mass) or not mass > 0):
        raise InputError(f"{src}: character.mass must be a positive number (kg), got {mass!r}")
    sources = t.get("sources", [])
    if not isinstance(sources, list) or not all(isinstance(s, str) for s in sources):
        raise InputError(f"{src}: character.sources must be a list of strings")
    model = t.get("model")
    if model is not None:
        if not isinstance(model, str) or not model:
            raise InputError(f"{src}: character.model must be the path of a .gltf, .glb or "
                             f".bvh file, got {model!r}")
        base = Path(src).parent if not src.startswith("<") else Path(".")
        model = (base / model).resolve()
        if model.suffix.lower() not in (".gltf", ".glb", ".bvh") or not model.is_file():
            raise InputError(f"{src}: character.model: no .gltf, .glb or .bvh file at "
                             f"{model}; give the rigged model's path relative to the "
                             "character file")
    clips = t.get("clips")
    if clips is not None:
        if not isinstance(clips, str) or not clips:
            raise InputError(f"{src}: character.clips must be the path of a clip folder "
                             f"(relative to the character file), got {clips!r}")
        base = Path(src).parent if not src.startswith("<") else Path(".")
        clips = (base / clips).resolve()
        if not (clips / "manifest.toml").is_file():
            raise InputError(f"{src}: character.clips: no clip database at {clips} (no "
                             "manifest.toml there); cut one from your takes with `quadsim "
                             "clips-from TAKE.bvh --character THIS.toml --out DIR` and give "
                             "DIR relative to the character file, or remove the key")
    return CharacterMeta(ident, name, species, float(mass), tuple(sources), model, clips)


def _chains(t: dict, src: str) -> Chains:
    _check_keys(t, _CHAIN_KEYS, f"{src}: [chains]")
    return Chains(spine=_names(_need(t, "spine", src), f"{src}: chains.spine"),
                  head=_need(t, "head", f"{src}: [chains]", str),
                  neck=_names(t.get("neck", []), f"{src}: chains.neck"),
                  tail=_names(t.get("tail", []), f"{src}: chains.tail"))


def _leg(t: dict, where: str) -> LegEntry:
    _check_keys(t, _LEG_KEYS, where)
    chain = _names(_need(t, "chain", where, list), f"{where}.chain")
    bend = _need(t, "bend", where, str)
    if bend not in ("forward", "back"):
        raise InputError(f"{where}.bend must be \"forward\" or \"back\", got {bend!r}")
    gains = {}
    for key in ("pre_gain", "post_gain"):
        if key in t:
            g = t[key]
            if isinstance(g, bool) or not isinstance(g, (int, float)) or not 0.0 <= g <= 1.0:
                raise InputError(f"{where}.{key} must be a number from 0 to 1, got {g!r}")
            gains[key] = float(g)
    return LegEntry(chain, _need(t, "ik", where, str), bend, **gains)


def _limits(t: dict, src: str) -> dict[str, tuple[float, float]]:
    out = {}
    for name, lim in t.items():
        where = f"{src}: limits.{name}"
        if (not isinstance(lim, list) or len(lim) != 2
                or not all(_is_number(x) for x in lim) or not lim[0] < lim[1]):
            raise InputError(f"{where} must be [min_deg, max_deg] with min < max, "
                             f"got {lim!r}")
        lo, hi = lim
        if not -180.0 <= lo <= 0.0 <= hi <= 180.0:
            raise InputError(f"{where} = {lim!r}: the range must hold the rest pose (0 deg) "
                             "and lie within -180 to 180 deg: -180 <= min_deg <= 0 <= max_deg "
                             "<= 180")
        out[name] = (float(lo), float(hi))
    return out


def locomotion_table(t: dict, src: str,
                     gait_names: tuple[str, ...] | None = None) -> LocomotionTable:
    """Check a ``[locomotion]`` table (a dict) and build its :class:`LocomotionTable`.

    Raises
    ------
    InputError
        Naming ``src`` and the key, for an unknown key, a value of the wrong
        type or out of range, an ``auto`` gait not among ``gaits``, or (with
        ``gait_names``, the shared table's gaits) a gait the table lacks.
    """
    _check_keys(t, _LOCOMOTION_KEYS, f"{src}: [locomotion]")
    values: dict = {}
    for key in ("gaits", "auto"):
        if key in t:
            names = _names(t[key], f"{src}: locomotion.{key}", "gait names")
            if not names:
                raise InputError(f"{src}: locomotion.{key} must name at least one gait")
            if len(set(names)) != len(names):
                raise InputError(f"{src}: locomotion.{key} names a gait twice: {list(names)}")
            unknown = [g for g in names if gait_names is not None and g not in gait_names]
            if unknown:
                raise InputError(f"{src}: locomotion.{key} names {unknown[0]!r}, which is not a "
                                 f"gait of the shared gait table; known: {', '.join(gait_names)}"
                                 + _suggest(unknown[0], gait_names))
            values[key] = names
    if "gaits" in values and "auto" in values:
        extra = [g for g in values["auto"] if g not in values["gaits"]]
        if extra:
            raise InputError(f"{src}: locomotion.auto names {extra[0]!r}, which is not among "
                             f"locomotion.gaits; allowed: {', '.join(values['gaits'])}")
    for key, (lo, hi, closed) in _LOCOMOTION_RANGES.items():
        if key not in t:
            continue
        v = t[key]
        where = f"{src}: locomotion.{key}"
        if not _is_number(v):
            raise InputError(f"{where} must be a number, got {v!r}")
        if not ((lo <= v) if closed else (lo < v)) or not v <= hi:
            raise InputError(f"{where} = {v!r} is out of range; allowed "
                             f"{lo:g} {'<=' if closed else '<'} {key} <= {hi:g}")
        values[key] = float(v)
    return LocomotionTable(**values)


def _gaits(t: dict, have: tuple[str, ...] | None, src: str) -> Mapping[str, Mapping]:
    """The ``[gaits.*]`` tables; ``have``: the character's gaits, if known."""
    out = {}
    for name, over in t.items():
        where = f"{src}: gaits.{name}"
        if not isinstance(over, dict):
            raise InputError(f"{where} must be a table of gait fields, written [gaits.{name}]")
        if have is not None and name not in have:
            raise InputError(f"{src}: [gaits.{name}] overrides a gait that is not one of the "
                             f"character's gaits (locomotion.gaits, or the shared gait table); "
                             f"allowed: {', '.join(have)}" + _suggest(name, have))
        _check_keys(over, GAIT_FIELDS, where)
        out[name] = MappingProxyType(dict(over))
    return MappingProxyType(out)


# --------------------------------------------------------------- values
def _check_keys(table: dict, allowed: tuple[str, ...], where: str) -> None:
    unknown = [k for k in table if k not in allowed]
    if unknown:
        raise InputError(f"{where}: unknown key(s) {sorted(unknown)}; allowed: "
                         f"{', '.join(allowed)}" + _suggest(unknown[0], allowed))


def _suggest(key: str, allowed) -> str:
    near = difflib.get_close_matches(key, list(allowed), n=1)
    return f" (did you mean {near[0]!r}?)" if near else ""


def _need(d: dict, key: str, where: str, kind=None):
    if key not in d:
        raise InputError(f"{where}: missing key `{key}`")
    v = d[key]
    if kind is not None and not isinstance(v, kind):
        raise InputError(f"{where}: `{key}` must be {kind.__name__}, got {type(v).__name__}")
    return v


def _table(d: dict, key: str, where: str) -> dict:
    v = d.get(key, {})
    if not isinstance(v, dict):
        raise InputError(f"{where}: `{key}` must be a table, written [{key}]")
    return v


def _names(v, where: str, what: str = "joint names") -> tuple[str, ...]:
    if not isinstance(v, list) or not all(isinstance(n, str) for n in v):
        raise InputError(f"{where} must be a list of {what} (strings)")
    return tuple(v)


def _is_number(x) -> bool:
    return not isinstance(x, bool) and isinstance(x, (int, float)) and math.isfinite(x)


def _vec(v, where: str) -> tuple[float, float, float]:
    if not isinstance(v, list) or len(v) != 3 or not all(_is_number(x) for x in v):
        raise InputError(f"{where} must be a list of three numbers (metres)")
    return (float(v[0]), float(v[1]), float(v[2]))
