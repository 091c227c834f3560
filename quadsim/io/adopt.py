"""Adopting a user's rig: its locomotion structure, a match report, a character file.

:func:`adopt` reads a rig (:func:`~quadsim.io.rig.read_gltf_rig`), finds its
quadruped structure from the geometry (:func:`~quadsim.skeleton.anatomy.find_anatomy`)
and keeps the joints locomotion moves -- the spine from the pelvis to the
withers, neck and head, tail, the four legs -- rooted at the pelvis; every
other joint (root and helper joints above the pelvis, ears, jaw, eyes, twist
bones) is listed as ignored with the reason, and follows its nearest kept
ancestor when the motion is written into the model. :meth:`Adoption.report`
is the match report; :meth:`Adoption.character_toml` the character file the
user can read and edit.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from quadsim.frames import LEGS, Y
from quadsim.io.rig import Rig, read_gltf_rig
from quadsim.skeleton.anatomy import Anatomy, find_anatomy
from quadsim.skeleton.skeleton import Skeleton

__all__ = ["PLANE_TOLERANCE", "TOE_SUFFIX", "TOE_TOLERANCE", "Adoption", "adopt"]

#: A foot joint higher than this (fraction of the hip height) above the lowest
#: foot gets a toe joint of quadsim's own on the ground below it.
TOE_TOLERANCE = 0.05
#: Name suffix of those toe joints.
TOE_SUFFIX = "_toe"
#: How far (fraction of the leg's length) a rig's leg joints may stand off the
#: leg's sagittal plane; they are put in it.
PLANE_TOLERANCE = 0.05


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
    ignored: dict = field(default_factory=dict)
    ground: float = 0.0

    def write(self, motions, path, *, names=None):
        """Write ``motions`` of :attr:`skeleton` into the rig's own model
        (:func:`~quadsim.io.rig_export.write_into_model`)."""
        from quadsim.io.rig_export import write_into_model

        return write_into_model(self.rig, motions, path, names=names,
                                root_offset=np.array([0.0, self.ground, 0.0]))

    def _length(self, chain) -> float:
        P = self.skeleton.rest_positions
        idx = self.skeleton.indices(tuple(chain))
        return float(np.linalg.norm(np.diff(P[list(idx)], axis=0), axis=1).sum())

    def report(self) -> str:
        """The match report: every chain with its bones and lengths, what was ignored."""
        P = self.skeleton.rest_positions
        a = self.anatomy
        lines = [f"rig {self.rig.path.name}: {len(self.rig.names)} joints, unit "
                 f"{self.rig.unit} (x {self.rig.scale:g} to metres), "
                 f"{self.rig.vertex_count} skinned vertices",
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
            lines += [f"  {n}: {why}" for n, why in self.ignored.items()]
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
            ik = chain[1] if len(chain) >= 5 else chain[0]
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


_HELPER = re.compile(r"(twist|roll|helper|ik|pole|target|ctrl|control|end|nub)", re.I)
_FACE = re.compile(r"(ear|jaw|eye|lid|brow|lip|tongue|mouth|nose|mane|teeth|tooth|whisker)",
                   re.I)


def _why(name: str, above_pelvis: bool) -> str:
    if above_pelvis:
        return "root or helper joint above the pelvis (follows the pelvis)"
    if _FACE.search(name):
        return "face or head detail, not locomotion (follows the head)"
    if _HELPER.search(name):
        return "twist, helper or end bone (follows its parent)"
    return "not on a locomotion chain (follows its nearest kept parent)"


def adopt(path) -> Adoption:
    """Map the rig in ``path`` (``.gltf`` or ``.glb``) onto quadsim's structure.

    Raises
    ------
    InputError
        For a file that holds no rig.
    ValueError
        When the rig has no quadruped structure (the message says what was found).
    """
    rig = read_gltf_rig(Path(path))
    full = rig.skeleton()
    a = find_anatomy(full)
    P = full.rest_positions
    parents = full.parents
    kids: list[list[int]] = [[] for _ in full.names]
    for j in range(1, len(parents)):
        kids[parents[j]].append(j)

    def path_down(top, bottom):
        out = [bottom]
        while out[-1] != top:
            out.append(int(parents[out[-1]]))
        return out[::-1]

    head_path = path_down(a.withers, a.head)[1:]
    neck, head = head_path[:-1], head_path[-1]
    below_pelvis = []
    stack = [c for c in kids[a.pelvis]]
    used = set(a.spine) | set(head_path) | {j for leg in a.legs for j in leg}
    while stack:
        j = stack.pop()
        if j not in used:
            below_pelvis.append(j)
            stack += kids[j]
    leaves = [j for j in below_pelvis if not kids[j] and P[j, 2] < P[a.pelvis, 2]]
    tail = path_down(a.pelvis, min(leaves, key=lambda j: P[j, 2]))[1:] if leaves else []
    keep = sorted(set(a.spine) | set(head_path) | set(tail)
                  | {j for leg in a.legs for j in leg})
    # the legs swing in their sagittal planes: joints below a leg's top are put in
    # its plane (a rig's are off it by millimetres); farther off is no leg to adopt
    P = P.copy()
    for leg, chain in zip(LEGS, a.legs):
        top = chain[0]
        length = float(np.linalg.norm(P[chain[-1]] - P[top]))
        off = np.abs(P[list(chain[1:]), 0] - P[top, 0]).max()
        if off > PLANE_TOLERANCE * length:
            raise ValueError(f"leg {leg} ({full.names[top]} to {full.names[chain[-1]]}) bends "
                             f"{off:.3f} m out of its plane ({PLANE_TOLERANCE:.0%} of its "
                             "length at most): quadsim's legs swing in their sagittal plane")
        P[list(chain[1:]), 0] = P[top, 0]
    index = {j: k for k, j in enumerate(keep)}
    names = list(full.names[j] for j in keep)
    new_parents = [-1] + [index[int(parents[j])] for j in keep[1:]]
    floor = float(min(P[f, Y] for f in a.feet))
    at = [P[j] - np.array([0.0, floor, 0.0]) for j in keep]          # the ground at y = 0
    legs = [[full.names[j] for j in chain] for chain in a.legs]
    for leg, foot in zip(legs, a.feet):
        if P[foot, Y] - floor <= TOE_TOLERANCE * a.hip_height:
            at[index[foot]][Y] = 0.0            # on the ground (a rig's feet differ by a hair)
        else:  # a foot joint above the ground (a wrist): a toe joint of quadsim's own below it
            names.append(f"{full.names[foot]}{TOE_SUFFIX}")
            new_parents.append(index[foot])
            at.append(np.array([P[foot, 0], 0.0, P[foot, 2]]))
            leg.append(names[-1])
    at = np.array(at)
    offsets = np.array([at[0]] + [at[k] - at[new_parents[k]] for k in range(1, len(at))])
    ends = {}
    for j in keep:
        if not any(c in index for c in kids[j]) and kids[j]:
            far = max((c for c in kids[j]), key=lambda c: np.linalg.norm(P[c] - P[j]))
            ends[full.names[j]] = P[far] - P[j]
    sk = Skeleton(tuple(names), new_parents, offsets, ends)
    above = set(range(len(full.names))) - set(keep)
    top_chain = set(path_down(0, a.pelvis)) - {a.pelvis}
    ignored = {full.names[j]: _why(full.names[j], j in top_chain) for j in sorted(above)}
    nm = full.names
    return Adoption(
        rig=rig, skeleton=sk, rig_index=np.array(keep, dtype=np.int64),
        anatomy=find_anatomy(sk), spine=tuple(nm[j] for j in a.spine),
        neck=tuple(nm[j] for j in neck), head=nm[head], tail=tuple(nm[j] for j in tail),
        legs={leg: tuple(chain) for leg, chain in zip(LEGS, legs)},
        ignored=ignored, ground=floor)
