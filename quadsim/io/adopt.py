"""Adopting a user's rig: its locomotion structure, a match report, a character file.

:func:`adopt` reads a rig (:func:`read_rig`: glTF or BVH, in
its own axes and unit), finds its quadruped structure from the geometry
(:func:`~quadsim.io.rig_structure.find_structure`) and keeps the joints
locomotion moves -- the spine from the pelvis to the withers, neck and head,
tail, the four legs -- rooted at the pelvis, in quadsim's frame and metres;
every other joint (root and helper joints above the pelvis, ears, jaw, eyes,
extra toes, twist bones, inline leg segments straight at rest) is listed as
ignored with the reason, and follows its nearest kept ancestor when the motion
is written into the model. :meth:`Adoption.report` is the match report;
:meth:`Adoption.character_toml` the character file the user can read and
edit; :func:`write_for_character` writes a run of such a character into the
user's own kind of file (``.glb`` model, ``.bvh`` hierarchy).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from quadsim.errors import InputError
from quadsim.frames import LEGS, Y
from quadsim.io.bvh_rig import read_bvh_rig
from quadsim.io.rig import Rig, foot_indices, read_gltf_rig
from quadsim.io.rig_structure import (
    RigMatchError,
    find_structure,
    name_kind,
    path_up,
    straight_joints,
)
from quadsim.skeleton.anatomy import Anatomy, find_anatomy
from quadsim.skeleton.skeleton import Skeleton

__all__ = ["IK_BEND", "PLANE_TOLERANCE", "TOE_SUFFIX", "TOE_TOLERANCE", "Adoption", "adopt",
           "read_rig", "rig_foot", "write_for_character", "write_rig_motion"]

#: A foot joint higher than this (fraction of the hip height) above the lowest
#: foot gets a toe joint of quadsim's own on the ground below it.
TOE_TOLERANCE = 0.05
#: Name suffix of those toe joints.
TOE_SUFFIX = "_toe"
#: How far (fraction of the leg's length) a rig's leg joints may stand off the
#: leg's sagittal plane; they are put in it.
PLANE_TOLERANCE = 0.05
#: The IK pair's middle joint bends its leg's way by at least this fraction of the
#: pair's length at rest (the character file asks for 0.01).
IK_BEND = 0.02


@dataclass(frozen=True, eq=False)
class Adoption:
    """A rig mapped onto quadsim's locomotion structure.

    Attributes
    ----------
    rig : Rig
    skeleton : Skeleton
        The kept joints, rooted at the pelvis, in metres, identity rest rotations.
    rig_index : ndarray of int, shape (K,)
        The rig joint of each of the first K joints of :attr:`skeleton`; the
        joints after them are quadsim's own toe joints (named ``<foot>_toe``)
        below rig feet that stand above the ground (a wrist as the last joint).
    anatomy : Anatomy
        Of :attr:`skeleton`.
    spine, neck, tail : tuple of str
        Chains (the spine from the pelvis to the withers).
    head : str
    legs : dict of str to tuple of str
        Each leg's chain, LF, RF, LH, RH, from its top joint to its foot.
    ik : dict of str to str
        Each leg's IK pair top: the first joint whose next one bends the leg's
        way at rest (an elbow back, a knee forward).
    ignored : dict of str to str
        Rig joints not kept, with the reason.
    ground : float
        Height of the rig's ground (its lowest foot) in the rig's world (m):
        :attr:`skeleton` stands with it at y = 0.
    """

    rig: Rig
    skeleton: Skeleton
    rig_index: np.ndarray
    anatomy: Anatomy
    spine: tuple[str, ...]
    neck: tuple[str, ...]
    head: str
    tail: tuple[str, ...]
    legs: dict = field(default_factory=dict)
    ik: dict = field(default_factory=dict)
    ignored: dict = field(default_factory=dict)
    ground: float = 0.0

    def write(self, motions, path, *, names=None):
        """Write ``motions`` of :attr:`skeleton` into the rig's own kind of file
        (:func:`write_rig_motion`: a ``.glb`` of a glTF model, a ``.bvh``)."""
        return write_rig_motion(self.rig, motions, path, names=names,
                                root_offset=np.array([0.0, self.ground, 0.0]))

    def _length(self, chain) -> float:
        P = self.skeleton.rest_positions
        idx = self.skeleton.indices(tuple(chain))
        return float(np.linalg.norm(np.diff(P[list(idx)], axis=0), axis=1).sum())

    def report(self) -> str:
        """The match report: every chain with its bones and lengths, what was ignored."""
        P = self.skeleton.rest_positions
        a = self.anatomy
        r = self.rig
        axes = (f"{r.up} up, {r.forward} forward" if r.frame_found else
                "+Y up, +Z forward (assumed: not found from the shape)")
        lines = [f"rig {r.path.name}: {len(r.names)} joints, unit {r.unit} "
                 f"(x {r.scale:g} to metres), {axes}, {r.vertex_count} skinned vertices",
                 f"standing: hip {a.hip_height:.3f} m, withers "
                 f"{P[a.withers, Y] - P[a.feet[0], Y]:.3f} m",
                 f"spine ({self._length(self.spine):.3f} m): {' > '.join(self.spine)}",
                 f"neck and head: {' > '.join((*self.neck, self.head))}",
                 f"tail: {' > '.join(self.tail) if self.tail else '(none)'}"]
        for leg in LEGS:
            chain = self.legs[leg]
            lines.append(f"leg {leg} ({len(chain) - 1} bones, {self._length(chain):.3f} m): "
                         f"{' > '.join(chain)}")
        if self.ignored:
            lines.append(f"ignored ({len(self.ignored)}):")
            by_reason: dict[str, list[str]] = {}
            for n, why in self.ignored.items():
                by_reason.setdefault(why, []).append(n)
            lines += [f"  {', '.join(ns)}: {why}" for why, ns in by_reason.items()]
        return "\n".join(lines)

    def character_toml(self, character_id: str, *, name: str | None = None,
                       mass: float | None = None, model: str | None = None) -> str:
        """A character file for the adopted rig (TOML text); ``model`` is the rig's path
        as the file should refer to it (relative to the file's folder)."""
        sk = self.skeleton
        h = self.anatomy.hip_height
        mass = mass if mass is not None else round(float(55.0 * (h / 0.57) ** 3), 2)

        def vec(v):
            return "[" + ", ".join(f"{x:.6g}" for x in v) + "]"

        def names(seq):
            return "[" + ", ".join(f'"{n}"' for n in seq) + "]"

        out = [f"# Adopted from {self.rig.path.name} by `quadsim rig`; edit freely.",
               "# Units: metres; +Y up, +Z forward, +X the animal's left.",
               "", "joints = ["]
        for j, n in enumerate(sk.names):
            par = sk.names[sk.parents[j]] if sk.parents[j] >= 0 else ""
            end = sk.end_sites.get(n)
            tail = f", end = {vec(end)}" if end is not None else ""
            out.append(f'  {{ name = "{n}", parent = "{par}", offset = {vec(sk.offsets[j])}'
                       f"{tail} }},")
        out += ["]", "", "[character]", f'id = "{character_id}"',
                f'name = "{name or character_id}"', f"mass = {mass:g}",
                f'sources = ["Rig: {self.rig.path.name} ({self.rig.unit})"]',
                *([f"model = {_toml_string(model)}"] if model else []), "",
                "[chains]", f"spine = {names(self.spine)}", f"neck = {names(self.neck)}",
                f'head = "{self.head}"', f"tail = {names(self.tail)}", ""]
        for leg in LEGS:
            chain = self.legs[leg]
            ik = self.ik[leg]
            bend = "back" if leg[1] == "F" else "forward"
            out += [f"[legs.{leg}]", f"chain = {names(chain)}", f'ik = "{ik}"',
                    f'bend = "{bend}"', ""]
        out += ["[locomotion]",
                'gaits = ["walk", "trot", "pace", "canter", "transverse_gallop", '
                '"rotary_gallop"]',
                'auto = ["walk", "trot", "canter", "rotary_gallop"]',
                f"max_turn_rate_deg_s = {120.0 * (0.57 / h) ** 0.5:.0f}",
                "spine_flex_deg = 20.0", "spine_extend_deg = -12.0", ""]
        return "\n".join(out)


def _toml_string(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def read_rig(path, feet=None) -> Rig:
    """The rig in ``path``: a ``.gltf``/``.glb`` model's first skin or a ``.bvh`` hierarchy.

    ``feet`` (four joint names, optional) are the feet when given by hand;
    they decide the up and forward axes. Raises :class:`InputError` for
    another kind of file.
    """
    path = Path(path)
    ext = path.suffix.lower()
    if ext == ".bvh":
        return read_bvh_rig(path, feet=feet)
    if ext in (".gltf", ".glb"):
        return read_gltf_rig(path, feet=feet)
    raise InputError(f"{path}: a rig is read from .gltf, .glb or .bvh files")


def _ik_joint(P: np.ndarray, chain, fore: bool) -> int:
    """Position in ``chain`` of the IK pair's top: the first joint whose next joint bends
    the leg's way (an elbow back, a knee forward) by :data:`IK_BEND` of the pair's length,
    else the one bending most that way."""
    sign = -1.0 if fore else 1.0
    best, best_k = -np.inf, 0
    for k in range(len(chain) - 2):
        a, b, d = (P[chain[k + i]] for i in range(3))
        u, w = d - a, b - a
        length = np.linalg.norm(b - a) + np.linalg.norm(d - b)
        fwd = (u[2] * w[1] - u[1] * w[2]) / max(np.hypot(u[2], u[1]), 1e-12)
        if sign * fwd >= IK_BEND * length:
            return k
        if sign * fwd / length > best:
            best, best_k = sign * fwd / length, k
    return best_k


def _reasons(full: Skeleton, s, keep: set, inline: dict) -> dict[str, str]:
    """Why each rig joint not kept is left out."""
    parents = full.parents
    above = set(path_up(parents, s.pelvis)[1:])
    under_head = set()
    for j in range(full.n_joints):
        if s.head in path_up(parents, j)[1:]:
            under_head.add(j)
    out = {}
    for j, name in enumerate(full.names):
        if j in keep:
            continue
        if j in above:
            why = "root or helper joint above the pelvis (moves with the pelvis)"
        elif j in s.toes:
            why = f"another toe of the foot {full.names[s.toes[j]]} (follows its parent)"
        elif j in inline:
            why = f"inline segment of leg {inline[j]}, straight at rest (follows its parent)"
        elif s.away.get(j) == "face" or name_kind(name) == "face":
            why = "face, head or body detail, by its name (follows the joint it hangs from)"
        elif j in under_head:
            why = "head detail beyond the head (follows the head)"
        elif s.away.get(j) == "helper" or name_kind(name) == "helper":
            why = "twist, helper or control bone, by its name (follows its parent)"
        elif s.pelvis not in path_up(parents, j):
            why = "not below the pelvis (moves with it, keeps its rest rotation)"
        else:
            why = "not on a locomotion chain (follows the joint it hangs from)"
        out[name] = why
    return out


def adopt(path, feet=None) -> Adoption:
    """Map the rig in ``path`` (``.gltf``, ``.glb`` or ``.bvh``) onto quadsim's structure.

    Parameters
    ----------
    path : str or path-like
    feet : sequence of str, length 4, optional
        The foot joints, when given by hand (any order).

    Raises
    ------
    InputError
        For a file that holds no rig.
    RigMatchError
        When the rig has no quadruped structure quadsim can find (a
        ``ValueError``; the message says what was found, ``keys`` which keys
        of the character file to set by hand).
    """
    rig = read_rig(Path(path), feet=feet)
    full = rig.skeleton()
    P = full.rest_positions.copy()
    s = find_structure(P, full.names, full.parents, foot_indices(full.names, feet, path))
    inline = {}
    legs_idx = []
    for leg, chain in zip(LEGS, s.legs):
        drop = straight_joints(P, chain)
        inline.update({j: leg for j in drop})
        legs_idx.append([j for j in chain if j not in drop])
    keep = sorted(set(s.spine) | set(s.neck) | {s.head} | set(s.tail)
                  | {j for chain in legs_idx for j in chain})
    # the legs swing in their sagittal planes: the joints below a leg's top are put
    # in their common plane (a rig's are off it by millimetres; farther off is no leg
    # to adopt), and the top joint (a scapula's head often lies nearer the spine)
    # moves sideways into it, so that the rig's own leg below it is quadsim's
    for leg, chain in zip(LEGS, legs_idx):
        top, below = chain[0], list(chain[1:])
        length = float(np.linalg.norm(P[chain[-1]] - P[top]))
        plane = float(np.mean(P[below, 0]))
        off = np.abs(P[below, 0] - plane).max()
        if off > PLANE_TOLERANCE * length:
            raise RigMatchError(
                f"leg {leg} ({full.names[top]} to {full.names[chain[-1]]}) bends {off:.3f} m "
                f"out of its plane ({PLANE_TOLERANCE:.0%} of its length at most): quadsim's "
                "legs swing in their sagittal plane", ())
        P[chain, 0] = plane
    index = {j: k for k, j in enumerate(keep)}
    names = [full.names[j] for j in keep]

    def kept_parent(j):
        p = int(full.parents[j])
        while p not in index:
            p = int(full.parents[p])
        return index[p]

    new_parents = [-1] + [kept_parent(j) for j in keep[1:]]
    floor = float(min(P[f, Y] for f in s.feet))
    at = [P[j] - np.array([0.0, floor, 0.0]) for j in keep]          # the ground at y = 0
    legs = [[full.names[j] for j in chain] for chain in legs_idx]
    hip = float(np.mean([P[c[0], Y] - P[c[-1], Y] for c in legs_idx[2:]]))
    for leg, foot in zip(legs, s.feet):
        if P[foot, Y] - floor <= TOE_TOLERANCE * hip:
            at[index[foot]][Y] = 0.0            # on the ground (a rig's feet differ by a hair)
        else:  # a foot joint above the ground (a wrist): a toe joint of quadsim's own below it
            names.append(f"{full.names[foot]}{TOE_SUFFIX}")
            new_parents.append(index[foot])
            at.append(np.array([P[foot, 0], 0.0, P[foot, 2]]))
            leg.append(names[-1])
    at = np.array(at)
    offsets = np.array([at[0]] + [at[k] - at[new_parents[k]] for k in range(1, len(at))])
    kids = full.children
    ends = {}
    for j in keep:
        if any(c in index for c in kids[j]):
            continue
        if full.names[j] in rig.end_sites:
            e = rig.axes @ rig.end_sites[full.names[j]] * rig.scale
            if np.linalg.norm(e) > 1e-6:
                ends[full.names[j]] = e
        elif kids[j]:
            far = max(kids[j], key=lambda c: np.linalg.norm(P[c] - P[j]))
            if np.linalg.norm(P[far] - P[j]) > 1e-6:
                ends[full.names[j]] = P[far] - P[j]
    sk = Skeleton(tuple(names), new_parents, offsets, ends)
    Q = sk.rest_positions
    ik = {}
    for leg, chain in zip(LEGS, legs):
        idx = list(sk.indices(tuple(chain)))
        ik[leg] = chain[_ik_joint(Q, idx, leg[1] == "F")]
    nm = full.names
    return Adoption(
        rig=rig, skeleton=sk, rig_index=np.array(keep, dtype=np.int64),
        anatomy=find_anatomy(sk, [c[-1] for c in legs]),
        spine=tuple(nm[j] for j in s.spine), neck=tuple(nm[j] for j in s.neck),
        head=nm[s.head], tail=tuple(nm[j] for j in s.tail),
        legs={leg: tuple(chain) for leg, chain in zip(LEGS, legs)}, ik=ik,
        ignored=_reasons(full, s, set(keep), inline), ground=floor)


def rig_foot(chain) -> str:
    """The rig's foot joint of a leg chain (names): its last joint, or the joint above
    when that is a toe of quadsim's own (``<foot>_toe``)."""
    last = chain[-1]
    if last.endswith(TOE_SUFFIX) and len(chain) > 1 and chain[-2] == last[:-len(TOE_SUFFIX)]:
        return chain[-2]
    return last


def write_rig_motion(rig: Rig, motions, path, *, names=None, root_offset=(0.0, 0.0, 0.0)):
    """Write motions of an adopted skeleton into the rig's own kind of file: a ``.glb``
    of the user's glTF model with the motions added
    (:func:`~quadsim.io.rig_export.write_into_model`), or a ``.bvh`` of the rig's own
    hierarchy (:func:`~quadsim.io.bvh_rig.write_rig_bvh`, the first motion)."""
    from quadsim.skeleton.motion import Motion

    ext = Path(path).suffix.lower()
    if ext == ".bvh":
        from quadsim.io.bvh_rig import write_rig_bvh

        motion = motions if isinstance(motions, Motion) else list(motions)[0]
        return write_rig_bvh(rig, motion, path, root_offset=root_offset)
    if ext == ".glb" and not rig.is_bvh:
        from quadsim.io.rig_export import write_into_model

        return write_into_model(rig, motions, path, names=names, root_offset=root_offset)
    raise InputError(f"{path}: a motion is written into {rig.path.name}'s own kind of file "
                     f"as {'.bvh' if rig.is_bvh else '.glb or .bvh'}")


def write_for_character(character, motion, path, *, names=None) -> Path:
    """Write ``motion`` of a character adopted from the user's model (its file's
    ``character.model``) into that model's kind of file (:func:`write_rig_motion`)."""
    sk = character.skeleton
    model = character.file.character.model
    feet = [rig_foot([sk.names[j] for j in leg.chain]) for leg in character.legs]
    rig = read_rig(model, feet=feet)
    root = sk.names[0]
    if root not in rig.names:
        raise InputError(f"{character.file.character.id}: the root joint {root!r} is not a "
                         f"joint of {model.name}")
    offset = rig.rest_positions[rig.names.index(root)] - sk.rest_positions[0]
    return write_rig_motion(rig, motion, path, names=names, root_offset=offset)
