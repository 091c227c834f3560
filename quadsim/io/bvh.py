"""BVH (Biovision hierarchy) motion files.

Conventions of the files this module writes, and how it reads others:

- **Axes**: none changed. BVH's usual frame is quadsim's (+Y up, +Z forward,
  +X the character's left), so positions and rotations pass through as they are.
- **Units**: lengths in the file are metres (``units="m"``) or centimetres
  (``units="cm"``); angles are degrees. Inside quadsim everything is SI.
  Reading without a unit detects it from the skeleton's size
  (:func:`quadsim.io.guess.guess_units`: a rest pose standing more than 3
  file units tall at the hips is in centimetres) and says so with a
  :class:`BvhUnitsWarning` when it picks centimetres.
- **Rotations**: each joint's ``CHANNELS`` list its rotation channels in the
  order they are applied, intrinsically: ``Zrotation Xrotation Yrotation``
  means ``R = Rz(z) @ Rx(x) @ Ry(y)`` (the usual BVH reading; Blender's too).
  The reader takes any order, per joint, and any subset of the three axes.
- **Root position**: the root's position channels hold its absolute world
  position; a position channel *replaces* that coordinate of the OFFSET (the
  reading of Blender's importer). The writer puts ``OFFSET 0 0 0`` on the
  root, so readers that instead *add* the channels to the OFFSET agree too.
  The skeleton's rest root position is therefore not stored: a skeleton read
  back has the root OFFSET of the file (zero for files written here) as its
  root offset, while every frame's joint world positions round-trip exactly.
- **Position channels on other joints** are accepted when they are constant
  over the file (they then replace the joint's OFFSET, as for the root);
  animated translations of non-root joints raise :class:`InputError`, since a
  :class:`~quadsim.skeleton.skeleton.Skeleton` has fixed bone offsets.
- **End Sites** become ``Skeleton.end_sites``. A leaf joint without an end
  site is written with a zero-length ``End Site`` (many tools expect one on
  every leaf) and zero-length End Sites are dropped on reading, so a round
  trip keeps the end sites exactly.
- **Joint order**: a BVH file lists joints depth first. A skeleton whose
  joints are in another topological order comes back in the file's order;
  compare joints by name (``skeleton.indices(names)``).
- **Not stored**: contacts, gait labels and extras of a
  :class:`~quadsim.skeleton.motion.Motion`. ``foot_joints`` is recovered from
  the joint names by :func:`guess_foot_joints`.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass, field
from decimal import Decimal, InvalidOperation
from pathlib import Path

import numpy as np

from quadsim.errors import InputError, read_text_lines
from quadsim.io.atomic import atomic_write
from quadsim.io.guess import guess_foot_joints, guess_units, rest_hip_height
from quadsim.kinematics.rotations import (
    euler_from_matrices,
    matrices_about_axis,
    matrices_from_euler,
    quaternions_from_matrices,
)
from quadsim.skeleton.motion import Motion
from quadsim.skeleton.skeleton import Skeleton

__all__ = ["BvhUnitsWarning", "guess_foot_joints", "read_bvh", "write_bvh"]

#: File units and how many of them make a metre.
UNITS = {"m": 1.0, "cm": 100.0}

_AXES = "XYZ"
#: Canonical channel names by their lower-case spelling -> (kind, axis index).
_CHANNELS = {f"{a}{kind}".lower(): (kind, i)
             for kind in ("position", "rotation") for i, a in enumerate(_AXES)}
_CANONICAL = {f"{a}{kind}".lower(): f"{a}{kind}"
              for kind in ("position", "rotation") for a in _AXES}


class BvhUnitsWarning(UserWarning):
    """A BVH file was read in a unit detected from its skeleton's size, not given."""


#: A non-root position channel counts as constant when it varies less than this (m).
_CONSTANT_TOL = 1e-9
_NAME_OK = re.compile(r"^[^\s{}]+$")


# ===================================================================== writing
def write_bvh(motion: Motion, path: str | os.PathLike, *, units: str = "m",
              rotation_order: str = "ZXY", precision: int = 9) -> Path:
    """Write a motion as a BVH file, atomically.

    Parameters
    ----------
    motion : Motion
        Joint names must contain no whitespace or braces.
    path : str or path-like
        Destination; an existing file is replaced only once the new one is
        complete (written to a temporary file in the same folder, then
        ``os.replace``), so a failure never leaves a half-written file.
    units : {"m", "cm"}
        Length unit of the file's OFFSETs and positions.
    rotation_order : str
        Three distinct letters from ``XYZ``: the order of every joint's
        rotation channels (intrinsic, see the module notes). ``"ZXY"`` is the
        most common in the wild.
    precision : int
        Decimal places of every number (angles in degrees, lengths in the
        file's unit), 0 to 15. The default 9 keeps a write-read round trip
        within 1e-8 m of the joint world positions for characters of a few
        metres at any angles; 6 (what many exporters write) can drift by
        about 1e-6 m in metres.

    Returns
    -------
    Path
        The path written.

    Raises
    ------
    InputError
        Bad ``units``, ``rotation_order`` or ``precision``, an unwritable
        joint name, or a destination that cannot be written.
    """
    scale = _unit_scale(units)
    order = _check_order(rotation_order)
    if isinstance(precision, bool) or not isinstance(precision, (int, np.integer)) \
            or not 0 <= precision <= 15:
        raise InputError(f"`precision` must be an integer from 0 to 15, got {precision!r}")
    p = int(precision)
    skel = motion.skeleton
    bad = [n for n in skel.names if not _NAME_OK.match(n)]
    if bad:
        raise InputError("BVH joint names may not be empty or contain whitespace or "
                         f"braces; rename: {', '.join(repr(n) for n in bad)}")
    dfs = _depth_first(skel)
    header = _hierarchy_text(skel, dfs, order, scale, p)
    header += f"MOTION\nFrames: {len(motion)}\nFrame Time: {1.0 / motion.fps!r}\n"

    T = len(motion)
    angles = np.degrees(euler_from_matrices(motion.local_matrices[:, dfs], order))
    values = np.concatenate([motion.root_positions * scale,
                             angles.reshape(T, 3 * skel.n_joints)], axis=1)
    path = Path(path)
    _atomic_write(path, header, values, p)
    return path


def _depth_first(skel: Skeleton) -> list[int]:
    """Joint indices in depth-first pre-order (children in index order)."""
    out, stack = [], [0]
    children = skel.children
    while stack:
        j = stack.pop()
        out.append(j)
        stack.extend(reversed(children[j]))
    return out


def _numbers(v, p: int) -> str:
    v = np.round(np.asarray(v, dtype=float), p) + 0.0  # no "-0.000"
    return " ".join(f"{x:.{p}f}" for x in v)


def _hierarchy_text(skel: Skeleton, dfs: list[int], order: str, scale: float, p: int) -> str:
    depth = np.zeros(skel.n_joints, dtype=int)
    for j in dfs[1:]:
        depth[j] = depth[skel.parents[j]] + 1
    rot = " ".join(f"{a}rotation" for a in order)
    lines = ["HIERARCHY"]
    stack: list[tuple[int, bool]] = [(0, False)]
    while stack:
        j, closing = stack.pop()
        ind = "\t" * int(depth[j])
        name = skel.names[j]
        if closing:
            leaf = not skel.children[j]
            if name in skel.end_sites or leaf:
                tip = skel.end_sites.get(name, np.zeros(3)) * scale
                lines += [f"{ind}\tEnd Site", f"{ind}\t{{",
                          f"{ind}\t\tOFFSET {_numbers(tip, p)}", f"{ind}\t}}"]
            lines.append(f"{ind}}}")
            continue
        if j == 0:
            lines += ["ROOT " + name, "{", f"\tOFFSET {_numbers(np.zeros(3), p)}",
                      f"\tCHANNELS 6 Xposition Yposition Zposition {rot}"]
        else:
            lines += [f"{ind}JOINT {name}", f"{ind}{{",
                      f"{ind}\tOFFSET {_numbers(skel.offsets[j] * scale, p)}",
                      f"{ind}\tCHANNELS 3 {rot}"]
        stack.append((j, True))
        stack.extend((c, False) for c in reversed(skel.children[j]))
    return "\n".join(lines) + "\n"


def _write_frames(f, values: np.ndarray, p: int) -> None:
    """Write the frame lines (one row of ``values`` per line)."""
    if values.shape[0]:
        np.savetxt(f, np.round(values, p) + 0.0, fmt=f"%.{p}f", delimiter=" ")


def _atomic_write(path: Path, header: str, values: np.ndarray, p: int) -> None:
    def write(f):
        f.write(header)
        _write_frames(f, values, p)

    atomic_write(path, write)


# ===================================================================== reading
@dataclass
class _Joint:
    name: str
    parent: int
    line: int
    offset: np.ndarray | None = None
    channels: list[str] = field(default_factory=list)
    channels_line: int = 0
    end_site: np.ndarray | None = None


class _Tokens:
    """Tokens of a list of lines, one line at a time, with 1-based line numbers."""

    _SPLIT = re.compile(r"[{}]|[^\s{}]+")

    def __init__(self, lines: list[str], src: str):
        self.lines = lines
        self.src = src
        self.i = 0          # index of the next line to tokenise
        self.line = 0       # line number of the tokens in ``buf``
        self.buf: list[str] = []
        #: number of the last non-blank line (where an early end of file is reported)
        self.last = next((k + 1 for k in range(len(lines) - 1, -1, -1) if lines[k].strip()), 1)

    def error(self, line: int, msg: str) -> InputError:
        return InputError(f"{self.src}:{line}: {msg}")

    def next(self, expected: str) -> tuple[int, str]:
        """The next token; at the end of the file, an error saying what was expected."""
        while not self.buf:
            if self.i >= len(self.lines):
                raise self.error(self.last, f"unexpected end of file, expected {expected}")
            self.buf = self._SPLIT.findall(self.lines[self.i])
            self.i += 1
            self.line = self.i
        return self.line, self.buf.pop(0)

    def rest(self) -> list[str]:
        """The remaining tokens of the current line up to (not including) a brace."""
        k = next((k for k, t in enumerate(self.buf) if t in "{}"), len(self.buf))
        out, self.buf = self.buf[:k], self.buf[k:]
        return out


def read_bvh(path: str | os.PathLike, *, units: str | None = None,
             fps: float | None = None) -> Motion:
    """Read a BVH file into a :class:`~quadsim.skeleton.motion.Motion`.

    Parameters
    ----------
    path : str or path-like
    units : {"m", "cm"}, optional
        Length unit the file's OFFSETs and positions are in. None (the
        default) detects it from the rest pose's hip height: above
        :data:`~quadsim.io.guess.CM_ABOVE` file units (a quadruped's hip
        height in metres is 0.1 to 3) the file is read as centimetres, with
        a :class:`BvhUnitsWarning` naming the file and the height.
    fps : float, optional
        Frame rate; by default ``1 / Frame Time``, snapped to a whole number of
        frames per second when the Frame Time, as written, is that rate's frame
        time rounded to the digits given (``0.0333333`` reads as 30 fps).

    Returns
    -------
    Motion
        Joints in the file's (depth-first) order; rotations from any channel
        order per joint; ``foot_joints`` from :func:`guess_foot_joints`.

    Raises
    ------
    InputError
        A missing or malformed file; the message names the file, the line and
        what was expected there.
    """
    if units is not None:
        _unit_scale(units)
    if fps is not None:
        try:
            fps = float(fps)
        except (TypeError, ValueError):
            fps = float("nan")
        if not np.isfinite(fps) or fps <= 0:
            raise InputError(f"`fps` must be a positive number, got {fps!r}")
    src = str(path)
    lines = read_text_lines(path, "BVH")
    tok = _Tokens(lines, src)
    if not any(s.strip() for s in lines):
        raise tok.error(1, "empty file, expected HIERARCHY")

    joints = _parse_hierarchy(tok)
    if units is None:
        units = _detect_units(src, joints)
    scale = _unit_scale(units)
    n_frames, frame_time, frames_line, start = _parse_motion_header(tok, lines)
    n_channels = sum(len(j.channels) for j in joints)
    data = _parse_frames(tok, lines, start, n_frames, n_channels, frames_line)

    if fps is None:
        fps = _fps_from_frame_time(frame_time)
    return _build_motion(tok, joints, data, scale, fps)


def _parse_hierarchy(tok: _Tokens) -> list[_Joint]:
    ln, t = tok.next("HIERARCHY")
    if t.upper() != "HIERARCHY":
        raise tok.error(ln, f"expected HIERARCHY, got {t!r}")
    ln, t = tok.next("ROOT")
    if t.upper() != "ROOT":
        raise tok.error(ln, f"expected ROOT, got {t!r}")
    joints: list[_Joint] = []
    stack: list[int] = []

    def open_joint(kw_line: int, parent: int) -> None:
        name = " ".join(tok.rest())
        if not name:
            raise tok.error(kw_line, "expected a joint name after ROOT/JOINT")
        ln, t = tok.next("'{'")
        if t != "{":
            raise tok.error(ln, f"expected '{{' to open joint {name!r}, got {t!r}")
        joints.append(_Joint(name, parent, kw_line))
        stack.append(len(joints) - 1)

    def offset(ln: int, what: str) -> np.ndarray:
        vals = tok.rest()
        if len(vals) != 3:
            raise tok.error(ln, f"OFFSET of {what} needs three numbers, got {len(vals)}")
        return np.array([_number(tok, ln, v) for v in vals])

    open_joint(ln, -1)
    while stack:
        cur = joints[stack[-1]]
        ln, t = tok.next(f"'}}' to close joint {cur.name!r} opened at line {cur.line} "
                         "(unbalanced braces)")
        T = t.upper()
        if t == "}":
            if cur.offset is None:
                raise tok.error(ln, f"joint {cur.name!r} (line {cur.line}) has no OFFSET")
            stack.pop()
        elif T == "OFFSET":
            if cur.offset is not None:
                raise tok.error(ln, f"second OFFSET in joint {cur.name!r}")
            cur.offset = offset(ln, f"joint {cur.name!r}")
        elif T == "CHANNELS":
            if cur.channels_line:
                raise tok.error(ln, f"second CHANNELS in joint {cur.name!r}")
            cur.channels = _channels(tok, ln, tok.rest(), cur.name)
            cur.channels_line = ln
        elif T == "JOINT":
            open_joint(ln, stack[-1])
        elif T == "END":
            ln2, t2 = tok.next("Site")
            if t2.upper() != "SITE":
                raise tok.error(ln2, f"expected 'Site' after 'End', got {t2!r}")
            if cur.end_site is not None:
                raise tok.error(ln, f"second End Site in joint {cur.name!r}")
            ln2, t2 = tok.next("'{'")
            if t2 != "{":
                raise tok.error(ln2, f"expected '{{' to open the End Site, got {t2!r}")
            ln2, t2 = tok.next("OFFSET")
            if t2.upper() != "OFFSET":
                raise tok.error(ln2, f"expected OFFSET in the End Site, got {t2!r}")
            cur.end_site = offset(ln2, f"the End Site of {cur.name!r}")
            ln2, t2 = tok.next("'}' to close the End Site (unbalanced braces)")
            if t2 != "}":
                raise tok.error(ln2, f"expected '}}' to close the End Site, got {t2!r}")
        elif T == "ROOT":
            raise tok.error(ln, "ROOT inside a joint; expected JOINT")
        elif T == "MOTION":
            raise tok.error(ln, f"MOTION before joint {cur.name!r} (opened at line {cur.line}) "
                                "was closed: unbalanced braces, expected '}'")
        else:
            raise tok.error(ln, f"expected OFFSET, CHANNELS, JOINT, End Site or '}}' "
                                f"in joint {cur.name!r}, got {t!r}")
    if tok.buf:
        raise tok.error(tok.line, f"unexpected {tok.buf[0]!r} after the hierarchy "
                                  "(unbalanced braces?)")
    return joints


def _channels(tok: _Tokens, ln: int, items: list[str], name: str) -> list[str]:
    if not items:
        raise tok.error(ln, "CHANNELS needs a count")
    try:
        n = int(items[0])
    except ValueError:
        raise tok.error(ln, f"CHANNELS count must be a whole number, got {items[0]!r}") from None
    names = items[1:]
    if n < 0 or n != len(names):
        raise tok.error(ln, f"bad channel count: CHANNELS {items[0]} in joint {name!r} "
                            f"lists {len(names)} channel name(s)")
    out = []
    for c in names:
        key = c.lower()
        if key not in _CHANNELS:
            raise tok.error(ln, f"unknown channel name {c!r} in joint {name!r}; expected "
                                "Xposition, Yposition, Zposition, Xrotation, Yrotation "
                                "or Zrotation")
        if _CANONICAL[key] in out:
            raise tok.error(ln, f"channel {c!r} repeated in joint {name!r}")
        out.append(_CANONICAL[key])
    return out


def _number(tok: _Tokens, ln: int, s: str) -> float:
    try:
        v = float(s)
    except ValueError:
        raise tok.error(ln, f"expected a number, got {s!r}") from None
    if not np.isfinite(v):
        raise tok.error(ln, f"expected a finite number, got {s!r}")
    return v


_FRAMES = re.compile(r"^\s*frames\s*:\s*(\S*)\s*$", re.IGNORECASE)
_FRAME_TIME = re.compile(r"^\s*frame\s+time\s*:\s*(\S*)\s*$", re.IGNORECASE)


def _next_line(lines: list[str], i: int) -> int:
    """Index of the first non-blank line at or after ``i`` (``len(lines)`` if none)."""
    while i < len(lines) and not lines[i].strip():
        i += 1
    return i


def _parse_motion_header(tok: _Tokens, lines: list[str]):
    """(frames, Frame Time as written, Frames line number, index of the first data line)."""
    i = _next_line(lines, tok.i)
    if i >= len(lines):
        raise tok.error(tok.last, "missing MOTION section after the hierarchy")
    words = lines[i].split()
    if words[0].upper() != "MOTION" or len(words) > 1:
        what = ("only one ROOT is supported" if words[0].upper() == "ROOT"
                else f"got {lines[i].strip()!r}")
        raise tok.error(i + 1, f"expected MOTION after the hierarchy; {what}")
    i = _next_line(lines, i + 1)
    m = _FRAMES.match(lines[i]) if i < len(lines) else None
    if m is None:
        raise tok.error(min(i + 1, tok.last), "expected 'Frames: <count>'")
    try:
        n_frames = int(m.group(1))
    except ValueError:
        n_frames = -1
    if n_frames < 0:
        raise tok.error(i + 1, f"Frames must be a whole number >= 0, got {m.group(1)!r}")
    frames_line = i + 1
    i = _next_line(lines, i + 1)
    m = _FRAME_TIME.match(lines[i]) if i < len(lines) else None
    if m is None:
        raise tok.error(min(i + 1, tok.last), "expected 'Frame Time: <seconds>'")
    ft = m.group(1)
    if _number(tok, i + 1, ft) <= 0:
        raise tok.error(i + 1, f"Frame Time must be positive (seconds), got {ft!r}")
    return n_frames, ft, frames_line, i + 1


def _fps_from_frame_time(ft: str) -> float:
    """``1 / Frame Time``, snapped to a whole rate the written digits stand for."""
    fps = 1.0 / float(ft)
    n = round(fps)
    if n >= 1:
        try:
            d = Decimal(ft)
            exact = (Decimal(1) / Decimal(n)).quantize(Decimal(1).scaleb(d.as_tuple().exponent))
        except (InvalidOperation, ValueError):
            return fps
        if exact == d or float(ft) == 1.0 / n:
            return float(n)
    return fps


def _parse_frames(tok: _Tokens, lines: list[str], start: int, n_frames: int,
                  n_channels: int, frames_line: int) -> np.ndarray:
    rows = [(k + 1, s) for k in range(start, len(lines)) if (s := lines[k].split())]
    counts = np.fromiter((len(s) for _, s in rows), dtype=np.int64, count=len(rows))
    bad = np.flatnonzero(counts != n_channels)
    if bad.size:
        ln, s = rows[bad[0]]
        raise tok.error(ln, f"frame line has {len(s)} values, expected {n_channels} "
                            "(the sum of the CHANNELS counts)")
    if len(rows) != n_frames:
        if len(rows) > n_frames:
            raise tok.error(rows[n_frames][0], f"more frame lines than 'Frames: {n_frames}' "
                                               f"(found {len(rows)})")
        raise tok.error(rows[-1][0] if rows else frames_line,
                        f"'Frames: {n_frames}' but the file has only {len(rows)} frame lines")
    flat = [t for _, s in rows for t in s]
    try:
        data = np.array(flat, dtype=float).reshape(n_frames, n_channels)
    except ValueError:
        for ln, s in rows:
            for t in s:
                _number(tok, ln, t)
        raise  # pragma: no cover - _number raised above
    finite = np.isfinite(data).all(axis=1)
    if not finite.all():
        k = int(np.flatnonzero(~finite)[0])
        raise tok.error(rows[k][0], "expected finite numbers in the frame line "
                                    "(found nan or inf)")
    return data


def _build_motion(tok: _Tokens, joints: list[_Joint], data: np.ndarray, scale: float,
                  fps: float) -> Motion:
    """Skeleton and motion from parsed joints and frame values (file units, degrees)."""
    T = data.shape[0]
    J = len(joints)
    offsets = np.array([j.offset for j in joints]) / scale
    root = np.broadcast_to(offsets[0], (T, 3)).copy()
    groups: dict[str, tuple[list[int], list[list[int]]]] = {}
    col = 0
    for k, jt in enumerate(joints):
        order, rcols = "", []
        for ch in jt.channels:
            kind, axis = _CHANNELS[ch.lower()]
            if kind == "rotation":
                order += _AXES[axis]
                rcols.append(col)
            elif k == 0:
                root[:, axis] = data[:, col] / scale
            else:
                v = data[:, col] / scale
                if T and np.ptp(v) > _CONSTANT_TOL:
                    raise tok.error(jt.channels_line,
                                    f"joint {jt.name!r} has animated position channels; "
                                    "only the root may translate (constant ones are allowed)")
                if T:
                    offsets[k, axis] = v[0]
            col += 1
        if order:
            idx, cols = groups.setdefault(order, ([], []))
            idx.append(k)
            cols.append(rcols)
    R = np.broadcast_to(np.eye(3), (T, J, 3, 3)).copy()
    for order, (idx, cols) in groups.items():
        ang = np.radians(data[:, np.array(cols)])  # (T, n, k)
        if len(order) == 3:
            Rg = matrices_from_euler(ang, order)
        else:
            Rg = matrices_about_axis(_AXES.index(order[0]), ang[..., 0])
            for m in range(1, len(order)):
                Rg = Rg @ matrices_about_axis(_AXES.index(order[m]), ang[..., m])
        R[:, idx] = Rg
    ends = {j.name: j.end_site / scale for j in joints
            if j.end_site is not None and np.any(j.end_site != 0)}
    names = tuple(j.name for j in joints)
    try:
        skel = Skeleton(names, np.array([j.parent for j in joints]), offsets, ends)
    except ValueError as e:
        raise InputError(f"{tok.src}: {e}") from None
    return Motion(skel, fps, root, quaternions_from_matrices(R),
                  foot_joints=guess_foot_joints(skel))


# ===================================================================== helpers
def _detect_units(src: str, joints: list[_Joint]) -> str:
    """The unit of a file from its rest pose's size, with a warning when it is not metres."""
    import warnings

    index = {id(j): k for k, j in enumerate(joints)}
    ends = [(index[id(j)], j.end_site) for j in joints if j.end_site is not None]
    h = rest_hip_height(np.array([j.offset for j in joints]), [j.parent for j in joints], ends)
    units = guess_units(h)
    if units != "m":
        warnings.warn(BvhUnitsWarning(
            f"{src}: read as centimetres: its skeleton stands {h:.4g} units tall at the hips "
            f"({h / 100:.3g} m in centimetres, {h:.4g} m in metres, more than a quadruped); "
            "give the unit to read it otherwise (units='m', on the command line --units m)"),
            stacklevel=3)
    return units


def _unit_scale(units: str) -> float:
    if units not in UNITS:
        raise InputError(f"`units` must be one of {', '.join(map(repr, UNITS))}, got {units!r}")
    return UNITS[units]


def _check_order(order: str) -> str:
    o = str(order).upper()
    if len(o) != 3 or set(o) != set(_AXES):
        raise InputError(f"`rotation_order` must be three distinct letters from XYZ "
                         f"(e.g. 'ZXY'), got {order!r}")
    return o
