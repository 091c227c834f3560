"""A user's rig read from its shape: its axes, feet, legs, girdles and what is no locomotion.

Real rigs come in every convention: +Y or +Z up, facing any horizontal axis,
in metres or centimetres, named ``thigh.L`` or ``b_LeftLeg01_015`` or
``bone.023``, with 20 to 200 bones of which most are no leg (face, ears, jaw,
eyes, mane, twist and helper bones). This module finds the structure
adoption needs without trusting the names, except to set aside bones that
say what they are:

- **Named away** (:func:`named_away`): a joint whose name has a face word
  (``ear``, ``jaw``, ``eye``, ``lid``, ``tongue``, ``mane``...) or a helper word
  (``twist``, ``helper``, ``ik``, ``pole``, ``ctrl``, ``mch``...) *and* whose
  whole subtree is named so, is no locomotion (a twist bone between the
  thigh and the shin keeps its place: its children are the leg).
- **Feet** (:func:`find_feet`): the end joints within
  :data:`~quadsim.skeleton.anatomy.FOOT_BAND` of the rig's height above the
  lowest one; end joints whose common ancestor is itself that low and that
  near them are toes of one foot (the longest toe is the foot).
- **Legs** (:func:`leg_groups`): each foot climbs to the first joint another
  foot also hangs from: its girdle. A quadruped has two girdles of two feet.
- **Up** (:func:`detect_frame`): of the six signed axes, the one along which
  the rig stands on two girdles of two feet with the longest legs. **Forward**:
  from the hind girdle (the one nearer the root of the tree) to the fore
  girdle, snapped to an axis; **left** is up x forward, so the result is
  quadsim's frame (+Y up, +Z forward, +X left) by a rotation.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from quadsim.skeleton.anatomy import FOOT_BAND

__all__ = ["FACE_WORDS", "HEAD_WORDS", "HELPER_WORDS", "STRAIGHT_DEG", "Frame", "RigMatchError",
           "Structure", "detect_frame", "find_feet", "find_structure", "leg_groups",
           "name_kind", "name_words", "named_away", "straight_joints"]

#: Toe ends of one foot this close in height (a fraction of the feet's band) count as
#: level: the longest of them is the foot.
TOE_TIE = 1e-6

#: Words of bone names that are face or head detail.
FACE_WORDS = frozenset(
    "ear ears jaw eye eyes eyeball eyelid lid lids brow brows lip lips tongue mouth nose "
    "nostril mane teeth tooth whisker whiskers cheek chin forehead temple muzzle snout "
    "horn antler breast belly udder".split())
#: Words of bone names that are twist, helper, control or mechanism bones.
HELPER_WORDS = frozenset(
    "twist roll helper helpers ik pole target ctrl control mch org wgt corrective fix "
    "jiggle dyn physics sim prop weapon".split())
_SPLIT = re.compile(r"[A-Z]+(?![a-z])|[A-Z]?[a-z]+|\d+")


class RigMatchError(ValueError):
    """The rig has no structure quadsim can map by itself.

    Attributes
    ----------
    found : str
        What was found (for the message).
    keys : tuple of str
        Keys of the character file to set by hand (``legs.RH.chain``...);
        empty when no key would help (the rig is refused).
    partial : dict of str to tuple of str
        Leg chains that were found, by leg name, for a draft file.
    """

    def __init__(self, found: str, keys=(), partial=None):
        super().__init__(found)
        self.found = found
        self.keys = tuple(keys)
        self.partial = dict(partial or {})


def name_words(name: str) -> tuple[str, ...]:
    """The lower-case words of a bone name: ``"b_LeftEar_03"`` -> ``("b", "left", "ear", "03")``."""
    return tuple(w.lower() for w in _SPLIT.findall(name))


def name_kind(name: str) -> str | None:
    """``"face"``, ``"helper"`` or None, from the words of ``name``."""
    words = set(name_words(name))
    if words & FACE_WORDS:
        return "face"
    if words & HELPER_WORDS:
        return "helper"
    return None


def children(parents) -> list[list[int]]:
    """Children of each joint (parents before children)."""
    kids: list[list[int]] = [[] for _ in range(len(parents))]
    for j in range(1, len(parents)):
        kids[int(parents[j])].append(j)
    return kids


def path_up(parents, j: int) -> list[int]:
    """``j`` and its ancestors up to the root."""
    out = [int(j)]
    while parents[out[-1]] >= 0:
        out.append(int(parents[out[-1]]))
    return out


def named_away(names, parents) -> dict[int, str]:
    """Joints set aside by their names: each with ``"face"`` or ``"helper"``.

    A joint is set aside when its name and the names of all its descendants
    are face or helper names.
    """
    kids = children(parents)
    kind = [name_kind(n) for n in names]
    away: dict[int, str] = {}
    for j in range(len(names) - 1, -1, -1):         # children before parents
        if kind[j] is not None and all(c in away for c in kids[j]):
            away[j] = kind[j]
    return away


def find_feet(P: np.ndarray, parents, away, up: np.ndarray) -> tuple[list[int], dict[int, int]]:
    """The foot joints along ``up`` and the extra toes of each.

    Parameters
    ----------
    P : ndarray, shape (J, 3)
        Rest positions (any unit).
    parents : array-like of int, shape (J,)
    away : collection of int
        Joints not to consider.
    up : ndarray, shape (3,)

    Returns
    -------
    feet : list of int
        One joint per foot, lowest first.
    toes : dict of int to int
        Other end joints of a foot (toes), each with its foot.
    """
    kids = children(parents)
    usable = [j for j in range(len(P)) if j not in away]
    live = [[c for c in kids[j] if c not in away] for j in range(len(P))]
    leaves = [j for j in usable if not live[j]]
    h = P @ up
    floor = min(h[j] for j in leaves)
    band = FOOT_BAND * (max(h[j] for j in usable) - floor)
    near = sorted((j for j in leaves if h[j] - floor <= band), key=lambda j: (h[j], j))
    anc = {j: path_up(parents, j) for j in near}
    clusters: list[list[int]] = []
    for j in near:
        for c in clusters:
            common = next(a for a in anc[j] if a in anc[c[0]])
            near_both = max(np.linalg.norm(P[common] - P[j]),
                            np.linalg.norm(P[common] - P[c[0]])) <= band
            if h[common] - floor <= band and near_both:     # a toe of the same foot
                c.append(j)
                break
        else:
            clusters.append([j])
    feet, toes = [], {}
    for c in clusters:
        top = next(a for a in anc[c[0]] if all(a in anc[m] for m in c))
        # the longest toe: the deepest chain, then the lowest end (heights within
        # TOE_TIE of the band alike: rounding in a file's units must not decide),
        # then the furthest from the joint the toes share
        low = min(h[m] for m in c) + TOE_TIE * band
        foot = max(c, key=lambda m: (anc[m].index(top), bool(h[m] <= low),
                                     float(np.linalg.norm(P[m] - P[top])), -m))
        feet.append(foot)
        toes.update({m: foot for m in c if m != foot})
    return feet, toes


def leg_groups(parents, feet) -> dict[int, list[tuple[int, int]]]:
    """Each foot's girdle: the first joint above it another foot hangs from.

    Returns
    -------
    dict of int to list of (int, int)
        Girdle joint -> its ``(foot, leg top)`` pairs, the leg top being the
        girdle's child on the way to the foot.
    """
    anc = {f: path_up(parents, f) for f in feet}
    groups: dict[int, list[tuple[int, int]]] = {}
    for f in feet:
        others = [g for g in feet if g != f]
        chain = anc[f]
        for k in range(1, len(chain)):
            if any(chain[k] in anc[g] for g in others):
                groups.setdefault(chain[k], []).append((f, chain[k - 1]))
                break
    return groups


@dataclass(frozen=True)
class Frame:
    """How a rig stands.

    Attributes
    ----------
    axes : ndarray, shape (3, 3)
        Rotation from the rig's world to quadsim's (rows: the rig's left, up
        and forward directions), a proper rotation.
    up, forward : str
        The rig's up and forward axes, e.g. ``"+Z"``, ``"-Y"``.
    height : float
        Standing height: the extent of the rig along its up axis (file units).
    found : bool
        False when no axis shows two girdles of two feet: then up is the axis
        along which the legs found hang longest (+Y when none), forward +Z
        (-Y for +Z up, Blender's convention).
    """

    axes: np.ndarray
    up: str
    forward: str
    height: float
    found: bool


_AXIS_NAMES = ("X", "Y", "Z")


def _axis_name(v: np.ndarray) -> str:
    k = int(np.argmax(np.abs(v)))
    return ("+" if v[k] > 0 else "-") + _AXIS_NAMES[k]


def _score(P, parents, away, up, feet=None, strict=True):
    """(score, groups) of standing along ``up``; score None when it shows no quadruped
    (``strict``: two girdles of two feet; else four feet or more on any girdles)."""
    if feet is None:
        feet, _ = find_feet(P, parents, away, up)
    if len(feet) < 4 or (strict and len(feet) != 4):
        return None, None
    groups = leg_groups(parents, feet)
    if strict and (len(groups) != 2 or any(len(g) != 2 for g in groups.values())):
        return None, None
    if not groups:
        return None, None
    h = P @ up
    usable = [j for j in range(len(P)) if j not in away]
    H = float(np.ptp(h[usable])) or 1.0
    drops = [h[g] - h[f] for g, legs in groups.items() for f, _ in legs]
    if min(drops) < 0.2 * H:
        return None, None
    spread = float(np.ptp(h[list(feet)]))
    return float(np.mean(drops) - spread) / H, groups


def hind_girdle(parents, groups, P, up) -> int:
    """The hind girdle of two: an ancestor of the other, else the nearer to the root,
    else the one whose other branches hang lower (a tail below a head)."""
    a, b = groups
    if a in path_up(parents, b):
        return a
    if b in path_up(parents, a):
        return b
    da, db = len(path_up(parents, a)), len(path_up(parents, b))
    if da != db:
        return a if da < db else b
    return a if P[a] @ up <= P[b] @ up else b


def detect_frame(P: np.ndarray, names, parents, feet=None) -> Frame:
    """How the rig with rest positions ``P`` (file units, its own axes) stands.

    Parameters
    ----------
    P : ndarray, shape (J, 3)
    names : sequence of str
    parents : array-like of int
    feet : sequence of int, optional
        The four foot joints when known (given by hand).

    Returns
    -------
    Frame
    """
    away = named_away(names, parents)
    usable = [j for j in range(len(P)) if j not in away]
    for strict in (True, False):
        best = (None, None, None)
        for k in range(3):
            for s in (1.0, -1.0):
                up = np.zeros(3)
                up[k] = s
                score, groups = _score(P, parents, away, up, feet, strict)
                if score is not None and (best[0] is None or score > best[0]):
                    best = (score, groups, up)
        if best[0] is not None:
            break
    score, groups, up = best
    if score is None or not strict:    # no quadruped: the up axis of the longest legs
        up = np.array([0.0, 1.0, 0.0]) if score is None else up
        fwd = np.array([0.0, -1.0, 0.0]) if up[2] else np.array([0.0, 0.0, 1.0])
        axes = np.stack([np.cross(up, fwd), up, fwd])
        return Frame(axes, _axis_name(up), _axis_name(fwd), float(np.ptp(P[usable] @ up)),
                     False)
    hind = hind_girdle(parents, groups, P, up)
    fore = next(g for g in groups if g != hind)
    d = np.mean([P[f] for f, _ in groups[fore]], axis=0) - \
        np.mean([P[f] for f, _ in groups[hind]], axis=0)
    d = d - (d @ up) * up
    k = int(np.argmax(np.abs(d)))
    fwd = np.zeros(3)
    fwd[k] = np.sign(d[k]) or 1.0
    left = np.cross(up, fwd)
    return Frame(np.stack([left, up, fwd]), _axis_name(up), _axis_name(fwd),
                 float(np.ptp(P[usable] @ up)), True)


#: A leg joint whose bones in and out turn by less than this (degrees) at rest is an
#: inline segment (a twist bone, ``thigh.001``): it follows its parent.
STRAIGHT_DEG = 3.0
#: Name words of the head joint, when a joint on the way to the head says so.
HEAD_WORDS = frozenset({"head", "skull", "cranium"})


@dataclass(frozen=True)
class Structure:
    """A rig's locomotion chains, as joint indices of the rig (quadsim's frame).

    Attributes
    ----------
    feet : tuple of int
        LF, RF, LH, RH.
    legs : tuple of tuple of int
        Each leg from its top joint (below the girdle) to its foot.
    pelvis, withers, head : int
    spine, neck, tail : tuple of int
        The spine from the pelvis to the withers; the neck between the withers
        and the head; the tail from below the pelvis to its tip.
    toes : dict of int to int
        Extra toes set aside, with their foot.
    away : dict of int to str
        Joints set aside by their names (``"face"`` or ``"helper"``).
    """

    feet: tuple
    legs: tuple
    pelvis: int
    withers: int
    head: int
    spine: tuple
    neck: tuple
    tail: tuple
    toes: dict
    away: dict


def _fail(found, keys, names, legs=None):
    partial = {}
    if legs is not None:
        partial = {leg: tuple(names[j] for j in chain) for leg, chain in legs.items()}
    raise RigMatchError(found, keys, partial)


def find_structure(P: np.ndarray, names, parents, feet=None) -> Structure:
    """The locomotion chains of a rig standing in quadsim's frame.

    Parameters
    ----------
    P : ndarray, shape (J, 3)
        Rest positions, +Y up, +Z forward, +X left (any unit).
    names : sequence of str
    parents : array-like of int
    feet : sequence of int, length 4, optional
        The feet given by hand (any order; sorted into LF, RF, LH, RH here).

    Raises
    ------
    RigMatchError
        When the rig does not show one quadruped: the message says what was
        found, :attr:`RigMatchError.keys` which character-file keys to set.
    """
    up = np.array([0.0, 1.0, 0.0])
    away = named_away(names, parents)
    toes: dict[int, int] = {}
    if feet is None:
        feet, toes = find_feet(P, parents, away, up)
    feet = list(feet)
    every = ("legs.LF.chain", "legs.RF.chain", "legs.LH.chain", "legs.RH.chain")
    listed = ", ".join(names[f] for f in feet)
    if len(feet) < 4:
        _fail(f"found {len(feet)} leg(s) ending in a foot near the ground at rest "
              f"({listed or 'none'}); a quadruped has four", every, names)
    groups = leg_groups(parents, feet)
    if len(feet) > 4 or len(groups) != 2 or any(len(g) != 2 for g in groups.values()):
        where = "; ".join(f"{names[g]}: {', '.join(names[f] for f, _ in legs)}"
                          for g, legs in groups.items())
        _fail(f"found {len(feet)} feet hanging from {len(groups)} girdle(s) ({where}); a "
              "quadruped has two girdles of two legs (a second spine or skeleton?)",
              every, names)
    hind = hind_girdle(parents, groups, P, up)
    fore = next(g for g in groups if g != hind)
    order = []
    for g in (fore, hind):
        order += sorted(groups[g], key=lambda ft: -P[ft[0], 0])   # left (+X) first
    chains = {}
    for leg, (f, top) in zip(("LF", "RF", "LH", "RH"), order):
        up_f = path_up(parents, f)
        chains[leg] = tuple(reversed(up_f[:up_f.index(top) + 1]))
    up_fore = path_up(parents, fore)
    if hind not in up_fore:
        _fail(f"the fore legs' girdle {names[fore]!r} does not hang from the hind legs' "
              f"{names[hind]!r} (the tree's root lies between them); quadsim roots the "
              "character at the pelvis", (), names, legs=chains)
    spine = tuple(reversed(up_fore[:up_fore.index(hind) + 1]))
    if len(spine) < 3:
        _fail(f"the spine from {names[hind]!r} to {names[fore]!r} has {len(spine)} joints; "
              "quadsim bends a spine of at least three", (), names, legs=chains)
    kids = children(parents)
    used = set(spine) | {j for c in chains.values() for j in c}
    ahead = [j for j in range(len(names)) if not [c for c in kids[j] if c not in away]
             and j not in away and j not in used and j not in toes
             and fore in path_up(parents, j)]
    if not ahead:
        _fail(f"no head: no end joint hangs ahead of the withers {names[fore]!r}",
              (), names, legs=chains)
    tip = max(ahead, key=lambda j: (P[j, 2], -j))
    way = list(reversed(path_up(parents, tip)[:path_up(parents, tip).index(fore)]))
    named = [j for j in way if set(name_words(names[j])) & HEAD_WORDS]
    head = named[0] if named else tip
    neck = tuple(way[:way.index(head)])
    behind = []
    stack = [c for c in kids[hind] if c not in used and c not in away]
    while stack:
        j = stack.pop()
        live = [c for c in kids[j] if c not in away and c not in toes]
        if not live and P[j, 2] < P[hind, 2]:
            behind.append(j)
        stack += live
    tail = ()
    if behind:
        end = min(behind, key=lambda j: (P[j, 2], j))
        up_t = path_up(parents, end)
        tail = tuple(reversed(up_t[:up_t.index(hind)]))
    return Structure(feet=tuple(f for f, _ in order), legs=tuple(chains.values()),
                     pelvis=hind, withers=fore, head=head, spine=spine, neck=neck,
                     tail=tail, toes=toes, away=away)


def straight_joints(P: np.ndarray, chain) -> list[int]:
    """Inner joints of a leg chain that are inline segments at rest (twist bones).

    A joint whose bone in and bone out turn by less than :data:`STRAIGHT_DEG`,
    or that stands where its parent does, is one; the inner joint bending
    most is kept whatever its angle, so a leg keeps at least three joints.
    """
    chain = list(chain)
    turn = {}
    for k in range(1, len(chain) - 1):
        a = P[chain[k]] - P[chain[k - 1]]
        b = P[chain[k + 1]] - P[chain[k]]
        na, nb = np.linalg.norm(a), np.linalg.norm(b)
        if na < 1e-9 * (1 + nb) or nb < 1e-12:
            turn[chain[k]] = -1.0
            continue
        turn[chain[k]] = float(np.degrees(np.arccos(np.clip(a @ b / (na * nb), -1, 1))))
    ranked = sorted(turn, key=lambda j: -turn[j])
    keep = set(ranked[:1])
    return [j for j in chain[1:-1] if j not in keep and turn[j] < STRAIGHT_DEG]
