"""Characters as data: a skeleton plus the named chains locomotion needs.

A character file (TOML; the shipped ones are in the package data,
:func:`characters_dir`) holds:

``[character]``
    ``id``, ``name``, ``species``, ``mass`` (kg), ``sources`` (list of str).
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
``[limits]``
    Optional ``joint = [min_deg, max_deg]``: allowed flexion about the joint's
    lateral (+X) axis relative to rest, used to keep legs from bending the
    wrong way.
``[locomotion]`` and ``[gaits.<name>]``
    Gait selection and per-character gait overrides, read by
    :mod:`quadsim.locomotion.gaits`.
"""

from __future__ import annotations

import os
import tomllib
from importlib import resources
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import numpy as np

from quadsim.errors import InputError
from quadsim.frames import LEGS, Y
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
    locomotion : dict
        The raw ``[locomotion]`` table.
    gait_overrides : dict
        The raw ``[gaits.*]`` tables.
    sources : tuple of str
    path : Path or None
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
    locomotion: dict = field(default_factory=dict)
    gait_overrides: dict = field(default_factory=dict)
    sources: tuple[str, ...] = ()
    path: Path | None = None

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
    """Parse and validate a character file (see the module docstring)."""
    try:
        data = tomllib.loads(Path(path).read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise InputError(f"{path}: no such character file") from None
    except tomllib.TOMLDecodeError as e:
        raise InputError(f"{path}: not valid TOML ({e})") from None
    return character_from_dict(data, str(path))


def _need(d: dict, key: str, where: str, kind=None):
    if key not in d:
        raise InputError(f"{where}: missing key `{key}`")
    v = d[key]
    if kind is not None and not isinstance(v, kind):
        raise InputError(f"{where}: `{key}` must be {kind.__name__}, got {type(v).__name__}")
    return v


def character_from_dict(data: dict, src: str = "<character>") -> Character:
    """Build a :class:`Character` from parsed TOML data."""
    meta = _need(data, "character", src, dict)
    joints = _need(data, "joints", src, list)
    names: list[str] = []
    parents: list[int] = []
    offsets: list[list[float]] = []
    ends: dict[str, list[float]] = {}
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

    def vec(v, where):
        if (not isinstance(v, list) or len(v) != 3
                or not all(isinstance(x, (int, float)) for x in v)):
            raise InputError(f"{where} must be a list of three numbers (metres)")
        return [float(x) for x in v]

    for k, j in enumerate(joints):
        where = f"{src}: joints[{k}]"
        if not isinstance(j, dict):
            raise InputError(f"{where} must be a table {{ name, parent, offset }}")
        unknown = set(j) - {"name", "parent", "offset", "end"}
        if unknown:
            raise InputError(f"{where}: unknown key(s) {sorted(unknown)}; "
                             "allowed: name, parent, offset, end")
        name = _need(j, "name", where, str)
        parent = _need(j, "parent", where, str)
        off = vec(_need(j, "offset", where), f"{where}.offset")
        end = vec(j["end"], f"{where}.end") if "end" in j else None
        add(name, parent, off, end)

    if data.get("mirror_left_legs", False):
        for name in names:
            pre = name[:3]
            if pre in _MIRROR:
                j = index[name]
                par = names[parents[j]] if parents[j] >= 0 else ""
                mpar = _MIRROR[par[:3]] + par[3:] if par[:3] in _MIRROR else par
                o = offsets[j]
                e = ends.get(name)
                add(_MIRROR[pre] + name[3:], mpar, [-o[0], o[1], o[2]],
                    None if e is None else [-e[0], e[1], e[2]])

    try:
        skel = Skeleton(tuple(names), np.array(parents), np.array(offsets), ends)
    except ValueError as e:
        raise InputError(f"{src}: {e}") from None

    def idx(name, where):
        if name not in index:
            raise InputError(f"{where}: no joint named {name!r}")
        return index[name]

    chains = _need(data, "chains", src, dict)
    spine = np.array([idx(n, f"{src}: chains.spine") for n in _need(chains, "spine", src, list)])
    if len(spine) < 5:
        raise InputError(f"{src}: chains.spine needs the pelvis and at least four more joints")
    if spine[0] != 0:
        raise InputError(f"{src}: chains.spine must start at the root joint {names[0]!r}")
    neck = np.array([idx(n, f"{src}: chains.neck") for n in chains.get("neck", [])], dtype=int)
    head = idx(_need(chains, "head", src, str), f"{src}: chains.head")
    tail = np.array([idx(n, f"{src}: chains.tail") for n in chains.get("tail", [])], dtype=int)
    for nm, ch in (("spine", spine), ("neck", neck), ("tail", tail)):
        for a, b in zip(ch[:-1], ch[1:]):
            if parents[b] != a:
                raise InputError(f"{src}: chains.{nm}: {names[b]!r} is not a child of {names[a]!r}")

    legs_t = _need(data, "legs", src, dict)
    legs = []
    for leg in LEGS:
        if leg not in legs_t:
            mirror_of = {"RF": "LF", "RH": "LH"}.get(leg)
            if mirror_of and data.get("mirror_left_legs", False) and mirror_of in legs_t:
                t = dict(legs_t[mirror_of])
                t["chain"] = [leg + "_" + n[3:] if n[:3] == mirror_of + "_" else n
                              for n in t["chain"]]
                t["ik"] = leg + "_" + t["ik"][3:]
            else:
                raise InputError(f"{src}: missing table [legs.{leg}]")
        else:
            t = legs_t[leg]
        where = f"{src}: legs.{leg}"
        chain_names = _need(t, "chain", where, list)
        chain = np.array([idx(n, f"{where}.chain") for n in chain_names])
        for a, b in zip(chain[:-1], chain[1:]):
            if parents[b] != a:
                raise InputError(f"{where}.chain: {names[b]!r} is not a child of {names[a]!r}")
        ik = _need(t, "ik", where, str)
        if ik not in chain_names:
            raise InputError(f"{where}.ik: {ik!r} is not in the leg's chain")
        k = chain_names.index(ik)
        if k + 2 >= len(chain_names):
            raise InputError(f"{where}.ik: the two-bone pair starting at {ik!r} "
                             "needs two more joints below it in the chain")
        bend = _need(t, "bend", where, str)
        if bend not in ("forward", "back"):
            raise InputError(f"{where}.bend must be \"forward\" or \"back\", got {bend!r}")
        gains = {}
        for key in ("pre_gain", "post_gain"):
            if key in t:
                g = t[key]
                if not isinstance(g, (int, float)) or not 0.0 <= g <= 1.0:
                    raise InputError(f"{where}.{key} must be a number from 0 to 1, got {g!r}")
                gains[key] = float(g)
        unknown = set(t) - {"chain", "ik", "bend", "pre_gain", "post_gain"}
        if unknown:
            raise InputError(f"{where}: unknown key(s) {sorted(unknown)}; allowed: chain, ik, "
                             "bend, pre_gain, post_gain")
        legs.append(LegSpec(leg, chain, k, 1.0 if bend == "forward" else -1.0, **gains))

    limits = {}
    for n, lim in data.get("limits", {}).items():
        j = idx(n, f"{src}: limits")
        if (not isinstance(lim, list) or len(lim) != 2
                or not all(isinstance(x, (int, float)) for x in lim) or not lim[0] < lim[1]):
            raise InputError(f"{src}: limits.{n} must be [min_deg, max_deg] with min < max")
        limits[j] = (np.radians(lim[0]), np.radians(lim[1]))
    mass = _need(meta, "mass", f"{src}: [character]")
    if not isinstance(mass, (int, float)) or not mass > 0:
        raise InputError(f"{src}: character.mass must be a positive number (kg), got {mass!r}")
    return Character(
        id=str(_need(meta, "id", f"{src}: [character]", str)),
        name=str(meta.get("name", meta["id"])),
        species=str(meta.get("species", "")),
        mass=float(mass),
        skeleton=skel,
        legs=tuple(legs),
        spine=spine,
        neck=neck,
        head=head,
        tail=tail,
        limits=limits,
        locomotion=dict(data.get("locomotion", {})),
        gait_overrides=dict(data.get("gaits", {})),
        sources=tuple(meta.get("sources", ())),
        path=Path(src) if not src.startswith("<") else None,
    )
