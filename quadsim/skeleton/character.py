"""Characters as data: a skeleton plus the named chains locomotion needs.

A character file (TOML; the shipped ones are in the package data,
:func:`characters_dir`) holds:

``[character]``
    ``id``, ``name``, ``species``, ``mass`` (kg), ``sources`` (list of str);
    optional ``model`` (the user's rig it was adopted from) and ``clips`` (its
    clip database for the data mode, a folder with a ``manifest.toml``), both
    paths relative to the file.
``joints``
    An array of inline tables ``{ name, parent, offset = [x, y, z], end = [x, y, z] }``
    in topological order (parents first). Offsets are metres in world axes at
    rest (+Y up, +Z forward, +X the character's left); the root's offset is its
    standing position. ``end`` is the optional bone tip of a leaf joint.
    With ``mirror_left_legs = true`` (top level), every joint named ``LF_*`` or
    ``LH_*`` is copied to ``RF_*`` / ``RH_*`` with X negated.
``[chains]``
    ``spine`` (root pelvis first, front-girdle joint last), ``neck``, ``head``,
    ``tail`` (may be short or empty).
``[legs.LF]``, ``[legs.LH]`` (and ``RF``/``RH`` unless mirrored)
    ``chain``: joint names from the top of the leg (scapula or hip) to the foot
    contact joint; ``ik``: the first joint of the two-bone pair the IK solves
    (the pair is that joint and the next two in the chain); ``bend``: which way
    the middle joint of the pair points, ``"forward"`` (a knee or stifle) or
    ``"back"`` (an elbow).
    ``pre_gain``, ``post_gain`` (optional, 0 to 1): see :class:`LegSpec`.
``[limits]``
    Optional ``joint = [min_deg, max_deg]``: allowed flexion about the joint's
    lateral (+X) axis relative to rest, used to keep legs from bending the
    wrong way; ``-180 <= min_deg <= 0 <= max_deg <= 180``.
``[locomotion]``
    Optional: ``gaits`` and ``auto`` (gait names; ``auto``, chosen by speed,
    is a subset of ``gaits``), ``max_turn_rate_deg_s``, ``spine_flex_deg``,
    ``spine_extend_deg``, ``spine_slow_scale``, ``min_turn_radius_body_lengths``,
    ``head_nod_deg`` (:class:`~quadsim.skeleton.character_file.LocomotionTable`).
``[gaits.<name>]``
    Per-character overrides of the shared gait table, read by
    :mod:`quadsim.locomotion.gaits` (keys:
    :data:`~quadsim.skeleton.character_file.GAIT_FIELDS`).

Loading reads the file into frozen dataclasses
(:mod:`quadsim.skeleton.character_file`: every key at every level checked,
no zero-length bone, limit ranges holding the rest pose) and then builds the
:class:`Character`, checking what needs the whole skeleton: chains that are
chains, legs in their planes, each foot on the ground at rest (a leg neither
over-long nor too short for its rest height), each IK pair bent the way its
``bend`` says, the fore legs ahead of the hind legs. Any failure is an
:class:`~quadsim.errors.InputError` naming the file and the field.
"""

from __future__ import annotations

import itertools
import math
import os
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from functools import cached_property, lru_cache
from importlib import resources
from pathlib import Path
from types import MappingProxyType

import numpy as np

from quadsim.errors import InputError
from quadsim.frames import LEGS, Y
from quadsim.skeleton.character_file import (
    CharacterFile,
    LegEntry,
    LocomotionTable,
    character_file_from_dict,
    locomotion_table,
    read_character_file,
)
from quadsim.skeleton.skeleton import Skeleton

_MIRROR = {"LF_": "RF_", "LH_": "RH_"}


def characters_dir() -> Path:
    """The folder of shipped character files, gait tables and clip databases.

    ``$QUADSIM_CHARACTERS`` overrides it; otherwise the ``characters/`` folder
    of the package data (``quadsim/data/characters``), found through
    :mod:`importlib.resources` so that it works from a source checkout, an
    editable install and an installed wheel alike.

    Returns
    -------
    Path
        The folder; it holds ``<id>.toml`` per character, ``gaits.toml`` and
        ``<id>/clips/`` per clip database.
    """
    env = os.environ.get("QUADSIM_CHARACTERS")
    if env:
        return Path(env)
    return _packaged_characters_dir()


@lru_cache(maxsize=1)
def _packaged_characters_dir() -> Path:
    """The package data's ``characters/`` folder, looked up once (a gait name is
    resolved against its gait table many times a batch)."""
    folder = resources.files("quadsim.data") / "characters"
    if not isinstance(folder, os.PathLike):
        raise InputError("quadsim's data folder is not on the file system (a zipped "
                         "install?); install quadsim as a plain wheel or folder")
    return Path(folder)


@dataclass(frozen=True)
class LegSpec:
    """One leg's joints.

    Attributes
    ----------
    name : str
        ``"LF"``, ``"RF"``, ``"LH"`` or ``"RH"``.
    chain : ndarray of int, shape (n,)
        Joint indices from the top of the leg to the foot contact joint.
    ik_start : int
        Position in ``chain`` of the first joint of the two-bone pair.
    bend : float
        +1 when the pair's middle joint points forward (knee), -1 when back (elbow).
    pre_gain, post_gain : float
        Fraction of the leg's swing angle taken by the bones above and below
        the two-bone pair (see :mod:`quadsim.kinematics.ik`).
    """

    name: str
    chain: np.ndarray
    ik_start: int
    bend: float
    pre_gain: float = 0.6
    post_gain: float = 0.5

    @property
    def top(self) -> int:
        return int(self.chain[0])

    @property
    def foot(self) -> int:
        return int(self.chain[-1])


@dataclass(frozen=True, eq=False)
class Character:
    """An immutable character description.

    Attributes
    ----------
    id, name, species : str
    mass : float
        Body mass (kg).
    skeleton : Skeleton
    legs : tuple of LegSpec
        In leg order LF, RF, LH, RH.
    spine, neck, tail : ndarray of int
        Joint indices; ``spine[0]`` is the root (pelvis) and ``spine[-1]`` the
        joint the fore legs hang from.
    head : int
    limits : dict of int to (float, float)
        Flexion limits (radians) about the joint's lateral axis, by joint index.
    locomotion : LocomotionTable
        The ``[locomotion]`` table: typed attributes, and a read-only mapping
        of the keys the file gives (``locomotion.get("auto")``).
    gait_overrides : mapping of str to mapping
        The ``[gaits.*]`` tables (read-only), by gait name.
    sources : tuple of str
    path : Path or None
        The character file, when read from one.
    file : CharacterFile or None
        The file as written (before mirroring), when read from one.
    """

    id: str
    name: str
    species: str
    mass: float
    skeleton: Skeleton
    legs: tuple[LegSpec, ...]
    spine: np.ndarray
    neck: np.ndarray
    head: int
    tail: np.ndarray
    limits: dict = field(default_factory=dict)
    locomotion: LocomotionTable = field(default_factory=LocomotionTable)
    gait_overrides: Mapping = field(default_factory=dict)
    sources: tuple[str, ...] = ()
    path: Path | None = None
    file: CharacterFile | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.locomotion, LocomotionTable):  # a plain dict
            object.__setattr__(self, "locomotion",
                               locomotion_table(dict(self.locomotion), f"<{self.id}>"))
        over = self.gait_overrides
        if not isinstance(over, MappingProxyType):
            object.__setattr__(self, "gait_overrides", MappingProxyType(
                {k: MappingProxyType(dict(v)) for k, v in over.items()}))

    # -------------------------------------------------------- derived sizes
    @cached_property
    def foot_joints(self) -> tuple[str, ...]:
        """Names of the four foot contact joints, leg order."""
        return tuple(self.skeleton.names[leg.foot] for leg in self.legs)

    @cached_property
    def hip_height(self) -> float:
        """Mean rest height of the hip joints above the feet (m)."""
        P = self.skeleton.rest_positions
        return float(np.mean([P[leg.top, Y] - P[leg.foot, Y] for leg in self.legs[2:]]))

    @cached_property
    def shoulder_height(self) -> float:
        """Withers height at rest: the highest point of the front girdle (m).

        The larger of the fore legs' top joints and the spine joint they hang from.
        """
        P = self.skeleton.rest_positions
        tops = [P[leg.top, Y] for leg in self.legs[:2]] + [P[self.spine[-1], Y]]
        return float(max(tops) - np.mean([P[leg.foot, Y] for leg in self.legs[:2]]))

    @cached_property
    def leg_lengths(self) -> np.ndarray:
        """Summed bone lengths of each leg from its IK pair to the foot, shape (4,) (m)."""
        off = self.skeleton.offsets
        return np.array([np.linalg.norm(off[leg.chain[leg.ik_start + 1:]], axis=-1).sum()
                         for leg in self.legs])

    @cached_property
    def body_length(self) -> float:
        """Rest distance between the hip and shoulder IK joints along +Z (m)."""
        P = self.skeleton.rest_positions
        fore = np.mean([P[leg.chain[leg.ik_start], 2] for leg in self.legs[:2]])
        hind = np.mean([P[leg.chain[leg.ik_start], 2] for leg in self.legs[2:]])
        return float(fore - hind)

    def rest_foot_positions(self) -> np.ndarray:
        """Feet at rest, shape (4, 3) (m)."""
        return self.skeleton.rest_positions[[leg.foot for leg in self.legs]]


# ---------------------------------------------------------------- loading
def list_characters() -> list[str]:
    """Identifiers of the shipped characters (the ``*.toml`` files in :func:`characters_dir`).

    Other data files in that folder are skipped: ``gaits.toml`` (the shared
    gait tables) and any valid TOML file without a ``[character]`` table. A
    file that is not valid TOML is listed, so that loading it reports the error.
    """
    d = characters_dir()
    out = []
    for p in d.glob("*.toml"):
        if p.name == "gaits.toml":
            continue
        try:
            data = tomllib.loads(p.read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError):
            out.append(p.stem)
            continue
        if isinstance(data.get("character"), dict):
            out.append(p.stem)
    return sorted(out)


def load_character(name_or_path: str | os.PathLike) -> Character:
    """Load a character by identifier (``"leopard"``) or by file path.

    Raises
    ------
    InputError
        When the character is unknown or its file is malformed; the message
        names the file and the key.
    """
    p = Path(name_or_path)
    if p.suffix != ".toml":
        cand = characters_dir() / f"{name_or_path}.toml"
        if not cand.exists():
            known = ", ".join(list_characters()) or "(none found)"
            raise InputError(f"unknown character {str(name_or_path)!r}; known: {known}")
        p = cand
    return _cached_load(str(p.resolve()))


_CACHE: dict[str, Character] = {}


def _cached_load(path: str) -> Character:
    try:
        key = (path, os.stat(path).st_mtime_ns)
    except FileNotFoundError:
        raise InputError(f"{path}: no such character file") from None
    hit = _CACHE.get(path)
    if hit is not None and getattr(hit, "_key", None) == key:
        return hit
    ch = parse_character_file(Path(path))
    object.__setattr__(ch, "_key", key)
    _CACHE[path] = ch
    return ch


def parse_character_file(path: Path) -> Character:
    """Read, check and build a character file (see the module docstring).

    Raises
    ------
    InputError
        Naming the file and the field (:func:`read_character_file`,
        :func:`build_character`).
    """
    return build_character(read_character_file(path, _shared_gait_names()))


def character_from_dict(data: dict, src: str = "<character>") -> Character:
    """Build a :class:`Character` from parsed TOML data; ``src`` names it in messages."""
    return build_character(character_file_from_dict(data, src, _shared_gait_names()))


def _shared_gait_names() -> tuple[str, ...] | None:
    """The gaits of the shared table ``gaits.toml``, or None when it cannot be read
    (:mod:`quadsim.locomotion.gaits` reports that when it loads the table)."""
    path = characters_dir() / "gaits.toml"
    try:
        return _gait_names_of(str(path), path.stat().st_mtime_ns)
    except OSError:
        return None


@lru_cache(maxsize=8)
def _gait_names_of(path: str, mtime_ns: int) -> tuple[str, ...] | None:
    try:
        data = tomllib.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError):
        return None
    return tuple(k for k, v in data.items() if isinstance(v, dict))


def build_character(cf: CharacterFile) -> Character:
    """Build a :class:`Character` from a checked :class:`CharacterFile`.

    Applies ``mirror_left_legs``, resolves joint names to indices and checks
    what needs the whole skeleton: the chains are chains, every leg lies in
    its plane, stands with its foot on the ground (y = 0) at rest, bends its
    IK pair the way ``bend`` says, and the fore legs are ahead of the hind
    legs (see :func:`_check_stance`).

    Raises
    ------
    InputError
        Naming ``cf.source`` and the field.
    """
    src = cf.source
    names, parents, offsets, ends = _joint_tables(cf)
    try:
        skel = Skeleton(tuple(names), np.array(parents), np.array(offsets), ends)
    except ValueError as e:
        raise InputError(f"{src}: {e}") from None
    joints = _Joints(names, parents)

    c = cf.chains
    spine = [joints.index(n, f"{src}: chains.spine") for n in c.spine]
    if len(spine) < 3:
        raise InputError(f"{src}: chains.spine needs the pelvis and at least two more joints")
    if spine[0] != 0:
        raise InputError(f"{src}: chains.spine must start at the root joint {names[0]!r}")
    limits = {joints.index(n, f"{src}: limits"): (np.radians(lo), np.radians(hi))
              for n, (lo, hi) in cf.limits.items()}
    meta = cf.character
    ch = Character(
        id=meta.id, name=meta.name, species=meta.species, mass=meta.mass, skeleton=skel,
        legs=tuple(_leg_spec(cf, leg, joints) for leg in LEGS),
        spine=joints.chain(c.spine, f"{src}: chains.spine"),
        neck=joints.chain(c.neck, f"{src}: chains.neck"),
        head=joints.index(c.head, f"{src}: chains.head"),
        tail=joints.chain(c.tail, f"{src}: chains.tail"),
        limits=limits, locomotion=cf.locomotion, gait_overrides=cf.gaits,
        sources=meta.sources, path=Path(src) if not src.startswith("<") else None, file=cf)
    _check_stance(ch, src)
    return ch


class _Joints:
    """Joint names to indices, for building a character (messages name the field)."""

    def __init__(self, names: list[str], parents: list[int]):
        self.names, self.parents = names, parents
        self._index = {n: k for k, n in enumerate(names)}

    def index(self, name: str, where: str) -> int:
        if name not in self._index:
            raise InputError(f"{where}: no joint named {name!r}")
        return self._index[name]

    def chain(self, joint_names, where: str) -> np.ndarray:
        """Indices of a chain, each joint the child of the one before, shape (n,)."""
        ch = np.array([self.index(n, where) for n in joint_names], dtype=int)
        for a, b in itertools.pairwise(ch):
            if self.parents[b] != a:
                raise InputError(f"{where}: {self.names[b]!r} is not a child of "
                                 f"{self.names[a]!r}")
        return ch


def _leg_spec(cf: CharacterFile, leg: str, joints: _Joints) -> LegSpec:
    t = _leg_entry(cf, leg)
    where = f"{cf.source}: legs.{leg}"
    chain = joints.chain(t.chain, f"{where}.chain")
    if t.ik not in t.chain:
        raise InputError(f"{where}.ik: {t.ik!r} is not in the leg's chain")
    k = t.chain.index(t.ik)
    if k + 2 >= len(t.chain):
        raise InputError(f"{where}.ik: the two-bone pair starting at {t.ik!r} "
                         "needs two more joints below it in the chain")
    gains = {g: getattr(t, g) for g in ("pre_gain", "post_gain") if getattr(t, g) is not None}
    return LegSpec(leg, chain, k, 1.0 if t.bend == "forward" else -1.0, **gains)


def _joint_tables(cf: CharacterFile):
    """Names, parent indices, offsets (J, 3) and end sites, mirrored legs added."""
    src = cf.source
    names: list[str] = []
    parents: list[int] = []
    offsets: list[tuple[float, float, float]] = []
    ends: dict[str, tuple[float, float, float]] = {}
    index: dict[str, int] = {}

    def add(name, parent, offset, end):
        if name in index:
            raise InputError(f"{src}: joint {name!r} defined twice")
        if parent == "":
            if names:
                raise InputError(f"{src}: only the first joint may have no parent ({name!r})")
            pi = -1
        elif parent not in index:
            raise InputError(f"{src}: joint {name!r} names parent {parent!r}, "
                             "which is not defined before it")
        else:
            pi = index[parent]
        index[name] = len(names)
        names.append(name)
        parents.append(pi)
        offsets.append(offset)
        if end is not None:
            ends[name] = end

    for j in cf.joints:
        add(j.name, j.parent, j.offset, j.end)
    if not cf.mirror_left_legs:
        return names, parents, offsets, ends
    for j in cf.joints:
        pre = j.name[:3]
        if pre in _MIRROR:
            mpar = _MIRROR[j.parent[:3]] + j.parent[3:] if j.parent[:3] in _MIRROR else j.parent
            o, e = j.offset, j.end
            add(_MIRROR[pre] + j.name[3:], mpar, (-o[0], o[1], o[2]),
                None if e is None else (-e[0], e[1], e[2]))
    return names, parents, offsets, ends


def _leg_entry(cf: CharacterFile, leg: str) -> LegEntry:
    """The leg's table, or the mirror of its left twin's (``mirror_left_legs``)."""
    if leg in cf.legs:
        return cf.legs[leg]
    twin = {"RF": "LF", "RH": "LH"}.get(leg)
    if twin is None or not cf.mirror_left_legs or twin not in cf.legs:
        raise InputError(f"{cf.source}: missing table [legs.{leg}]")
    t = cf.legs[twin]
    prefix = twin + "_"
    return replace(t, chain=tuple(leg + "_" + n[3:] if n[:3] == prefix else n for n in t.chain),
                   ik=leg + "_" + t.ik[3:])


#: How far (m) a foot may rest off the ground (y = 0).
GROUND_TOLERANCE = 1e-6
#: Smallest bend of a leg's IK pair at rest, as a fraction of the pair's length:
#: a straighter pair leaves the IK no room to shorten the leg or no fold direction.
MIN_PAIR_BEND = 0.01
#: The least distance (m) a foot's toe tip lies ahead of its joint for the foot to
#: roll over it (:func:`_check_stance`).
MIN_TOE_TIP = 1e-3


def _check_stance(ch: Character, src: str) -> None:
    """The geometry the engines rely on, checked on the built character.

    - Below its top joint a leg lies in its plane (zero X offsets).
    - Each foot contact joint rests on the ground, ``|y| <= GROUND_TOLERANCE``:
      a leg longer than its top's height (foot below ground) or shorter (foot
      in the air) cannot stand at the rest height, and the stance measurement
      finds no reach at all (the division by zero this replaces).
    - The IK pair's top is above the ground, and its middle joint bends the
      way ``bend`` says by at least ``MIN_PAIR_BEND`` of the pair's length.
    - The fore legs' IK joints are ahead (+Z) of the hind legs' (a positive
      body length, which the turning divides by).
    - A character whose paws roll over their toes (``locomotion.toe_roll_deg``
      above 0) gives each foot a toe tip (its end site) ahead of its joint, at
      least ``MIN_TOE_TIP`` m: the roll pivots on it.
    - A character whose digits sink under load or flex in swing
      (``locomotion.fetlock_sink_deg``, ``digit_flex_deg`` above 0) has at least two
      bones below every leg's IK pair (the first, a cannon, and the digit below it).
    """
    sk = ch.skeleton
    P = sk.rest_positions
    names = sk.names
    for leg in ch.legs:
        where = f"{src}: legs.{leg.name}"
        off = sk.offsets[leg.chain[1:]]
        side = [names[j] for j, o in zip(leg.chain[1:], off) if abs(o[0]) > 1e-9]
        if side:
            raise InputError(f"{where}.chain: joints below the top of a leg lie in the leg's "
                             f"plane (offset x = 0); not so for {', '.join(side)}")
        foot = leg.foot
        y = float(P[foot, Y])
        if abs(y) > GROUND_TOLERANCE:
            top = leg.chain[0]
            kind, fix = (("over-long leg", "shorten the leg or raise the root") if y < 0
                         else ("leg too short", "lengthen the leg or lower the root"))
            raise InputError(
                f"{where}: {kind}: at rest its foot {names[foot]!r} is {abs(y):.4g} m "
                f"{'below' if y < 0 else 'above'} the ground (y = {y:.4g} m, from "
                f"{names[top]!r} at y = {P[top, Y]:.4g} m); a foot stands on the ground "
                f"(y = 0) at rest: {fix} by {abs(y):.4g} m")
        a, b, d = leg.chain[leg.ik_start:leg.ik_start + 3]
        if not P[a, Y] > GROUND_TOLERANCE:
            raise InputError(f"{where}.ik: the pair's top {names[a]!r} is at y = "
                             f"{P[a, Y]:.4g} m, not above the ground")
        u, w = P[d] - P[a], P[b] - P[a]
        length = float(np.linalg.norm(P[b] - P[a]) + np.linalg.norm(P[d] - P[b]))
        # how far b lies forward (+Z) of the line a -> d, in the (Z, Y) plane
        fwd = float((u[2] * w[1] - u[1] * w[2]) / max(math.hypot(u[2], u[1]), 1e-12))
        if leg.bend * fwd < MIN_PAIR_BEND * length:
            want = "forward" if leg.bend > 0 else "back"
            raise InputError(
                f"{where}.bend = \"{want}\": at rest {names[b]!r} lies {abs(fwd):.4g} m "
                f"{'forward of' if fwd > 0 else 'behind'} the line {names[a]!r} -> "
                f"{names[d]!r}; it must lie {want} of it by at least {MIN_PAIR_BEND:g} of "
                f"the pair's length ({MIN_PAIR_BEND * length:.3g} m)")
    if not ch.body_length > 0.0:
        raise InputError(f"{src}: legs: the fore legs' IK joints must lie ahead (+Z) of the "
                         f"hind legs' at rest; body length {ch.body_length:.4g} m")
    for key, does in (("fetlock_sink_deg", "sinks under load"),
                      ("digit_flex_deg", "flexes in swing")):
        value = float(ch.locomotion.get(key, 0.0))
        short = [leg.name for leg in ch.legs if len(leg.chain) - 1 < leg.ik_start + 4]
        if value > 0.0 and short:
            raise InputError(
                f"{src}: locomotion.{key} = {value:g}: a leg's digit (the bones below the "
                f"first one under its IK pair) {does}, so every leg needs at least two bones "
                f"below its pair; legs {', '.join(short)} have fewer: give them a digit "
                f"(fetlock -> pastern -> hoof) or set {key} = 0")
    roll = float(ch.locomotion.get("toe_roll_deg", 0.0))
    if roll > 0.0:
        short = [leg.name for leg in ch.legs
                 if not float(sk.end_sites.get(names[leg.foot], np.zeros(3))[2]) >= MIN_TOE_TIP]
        if short:
            raise InputError(
                f"{src}: locomotion.toe_roll_deg = {roll:g}: a foot rolls over its toe tip, "
                f"the end site of its foot joint, which must lie at least {MIN_TOE_TIP:g} m "
                f"ahead (+Z) of it; not so for legs {', '.join(short)}: give each foot joint "
                "an `end` ahead of it, or set toe_roll_deg = 0")
