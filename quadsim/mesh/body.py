"""One skinned body mesh for any quadruped skeleton: a smooth skin around the bones.

:func:`skinned_body` builds it in the skeleton's rest (bind) pose:

1. **Primitives.** The :class:`~quadsim.mesh.profiles.Profile`'s parts are laid
   along the skeleton's chains as short tapered segments with elliptic or
   boxy sections (:func:`quadsim.mesh.parts.primitives`).
2. **Implicit surface.** Each segment has an approximate signed distance
   (negative inside); a tube (a part along one chain, or a blob) is the plain
   union of its segments, ``d_i`` the least of their distances; the body is
   the zero set of the tubes' smooth union ``f = -k log(sum_i exp(-d_i / k))``
   with the profile's blend radius ``k``, so parts melt into each other over
   about ``k``. ``f`` is sampled on a grid of the profile's voxel size, each
   segment only over its own box.
3. **Surface.** scikit-image's ``marching_cubes`` meshes ``f = 0``; a few
   Taubin smoothing passes (which keep the volume) remove the grid's steps,
   and normals come from the smoothed faces.
4. **Skin.** Every vertex takes the joint weights of the segments near it,
   each segment's weights blended along it (:mod:`quadsim.mesh.parts`), the
   segments weighted by ``exp(-(d_i - min d) / k)``; the four largest
   weights are kept and normalised (:func:`quadsim.mesh.skinning.top_weights`).
   Colours are blended the same way with a sharper falloff.

Results are cached per skeleton (by its names, tree and rest offsets) and
profile. The profile of a shipped character is found by matching the
skeleton against the shipped characters' (:func:`profile_for`).

The shipped characters' bodies are also stored built, as package data
(``quadsim/data/bodies``, written by ``tools/build_body_meshes.py`` and checked
against a fresh build by the tests), so writing a shipped character's GLB
needs neither scikit-image nor the build time; any other skeleton's body is
built, which needs scikit-image (the ``viz`` extra).
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, fields

import numpy as np

from quadsim.mesh.parts import Primitives, bone_primitives, primitives
from quadsim.mesh.profiles import Profile, profile_for_id
from quadsim.mesh.skinning import top_weights
from quadsim.skeleton.anatomy import find_anatomy
from quadsim.skeleton.skeleton import Skeleton

__all__ = ["SkinnedBody", "body_key", "build_body", "field_distances", "profile_for",
           "save_body", "shipped_path", "skinned_body"]

#: Taubin smoothing passes and their two factors.
SMOOTH_PASSES = 4
SMOOTH_LAMBDA, SMOOTH_MU = 0.55, -0.58
#: Radius of the tubes around the bones of a skeleton that is not a quadruped's,
#: as a fraction of its scale (0.75 of its largest extent at rest).
TUBE = 0.06
#: Falloff of a segment's share of a vertex's weights, as a fraction of the blend radius.
WEIGHT_SHARPNESS = 0.6
#: Colour falloff as a fraction of the blend radius.
COLOR_SHARPNESS = 0.35


@dataclass(frozen=True, eq=False)
class SkinnedBody:
    """A closed triangle mesh at rest, skinned to the skeleton's joints.

    Attributes
    ----------
    positions : ndarray, shape (V, 3)
        Vertex positions in the world at rest (m).
    normals : ndarray, shape (V, 3)
        Unit outward normals.
    triangles : ndarray of int, shape (F, 3)
        Counter-clockwise seen from outside.
    joints : ndarray of int, shape (V, 4)
        Up to four influences per vertex, by decreasing weight; unused slots
        hold joint 0.
    weights : ndarray, shape (V, 4)
        Influence weights, each row summing to 1; unused slots 0.
    colors : ndarray, shape (V, 3)
        RGB in [0, 1].
    part : ndarray of int, shape (V,)
        Index into :data:`~quadsim.mesh.profiles.PARTS` of the part nearest
        each vertex.
    profile : str
        Name of the profile it was built from.
    """

    positions: np.ndarray
    normals: np.ndarray
    triangles: np.ndarray
    joints: np.ndarray
    weights: np.ndarray
    colors: np.ndarray
    part: np.ndarray
    profile: str

    @property
    def n_vertices(self) -> int:
        return len(self.positions)


# ------------------------------------------------------------------ distances
def field_distances(pr: Primitives, p: int, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Approximate signed distances of points to one segment, and their place along it.

    Parameters
    ----------
    pr : Primitives
    p : int
        The segment.
    X : ndarray, shape (n, 3)
        Points (m).

    Returns
    -------
    d : ndarray, shape (n,)
        Negative inside the segment (m): the section-normalised radius minus
        one, times the smaller half-size.
    t : ndarray, shape (n,)
        Fraction along the segment of each point's projection, in [0, 1].
    """
    L = max(pr.length[p], 1e-9)
    rel = X - pr.a[p]
    along = rel @ pr.axis[p]
    t = np.clip(along / L, 0.0, 1.0)
    e = along - t * L
    du = rel @ pr.across[p]
    dv = rel @ pr.up[p]
    (w0, w1), (d0, d1) = pr.width[p], pr.depth[p]
    w = w0 + (w1 - w0) * t
    dd = d0 + (d1 - d0) * t
    r = np.minimum(w, dd)
    power = pr.power[p]
    if power == 2.0:
        q = np.sqrt((du / w) ** 2 + (dv / dd) ** 2 + (e / r) ** 2)
    else:
        q = (np.abs(du / w) ** power + np.abs(dv / dd) ** power
             + np.abs(e / r) ** power) ** (1.0 / power)
    return (q - 1.0) * r, t


def _boxes(pr: Primitives, k: float) -> tuple[np.ndarray, np.ndarray]:
    """Bounds (P, 3) of each segment's reach: beyond them it adds nothing to the union."""
    reach = np.maximum(pr.width.max(axis=1), pr.depth.max(axis=1)) + 4.0 * k
    return (np.minimum(pr.a, pr.b) - reach[:, None], np.maximum(pr.a, pr.b) + reach[:, None])


def _grid_field(pr: Primitives, k: float, voxel: float):
    """``f`` on a grid padded around every segment: (values, origin).

    Within a tube (a :attr:`Primitives.group`) the distance is the least of its
    segments'; the tubes are then melted together.
    """
    lo_p, hi_p = _boxes(pr, k)
    origin = lo_p.min(axis=0) - 2 * voxel
    shape = np.ceil((hi_p.max(axis=0) + 2 * voxel - origin) / voxel).astype(int) + 1
    S = np.zeros(tuple(shape))
    i0 = np.clip(np.floor((lo_p - origin) / voxel).astype(int), 0, shape - 1)
    i1 = np.clip(np.ceil((hi_p - origin) / voxel).astype(int) + 1, 0, shape)
    for g in np.unique(pr.group):
        members = np.nonzero(pr.group == g)[0]
        g0, g1 = i0[members].min(axis=0), i1[members].max(axis=0)
        D = np.full(tuple(g1 - g0), np.inf)
        for p in members:
            ax = [origin[c] + voxel * np.arange(i0[p, c], i1[p, c]) for c in range(3)]
            pts = np.stack(np.meshgrid(*ax, indexing="ij"), axis=-1)
            d, _ = field_distances(pr, p, pts.reshape(-1, 3))
            sl = tuple(slice(i0[p, c] - g0[c], i1[p, c] - g0[c]) for c in range(3))
            np.minimum(D[sl], d.reshape(pts.shape[:3]), out=D[sl])
        sl = tuple(slice(g0[c], g1[c]) for c in range(3))
        S[sl] += np.exp(-np.minimum(D, 40.0 * k) / k)
    f = -k * np.log(np.maximum(S, 1e-30))
    return np.minimum(f, 10.0 * k), origin


# -------------------------------------------------------------------- surface
def _edges(tri: np.ndarray) -> np.ndarray:
    e = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    lo, hi = e.min(axis=1), e.max(axis=1)
    key = np.unique(lo * (int(tri.max()) + 1) + hi)
    return np.stack([key // (int(tri.max()) + 1), key % (int(tri.max()) + 1)], axis=1)


def _smooth(v: np.ndarray, tri: np.ndarray, passes: int) -> np.ndarray:
    """Taubin smoothing (a shrinking and an inflating Laplacian step per pass)."""
    e = _edges(tri)
    i = np.concatenate([e[:, 0], e[:, 1]])
    j = np.concatenate([e[:, 1], e[:, 0]])
    deg = np.maximum(np.bincount(i, minlength=len(v)), 1)[:, None]
    for _ in range(passes):
        for f in (SMOOTH_LAMBDA, SMOOTH_MU):
            mean = np.stack([np.bincount(i, weights=v[j, c], minlength=len(v))
                             for c in range(3)], axis=1) / deg
            v = v + f * (mean - v)
    return v


def vertex_normals(v: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """Area-weighted unit vertex normals (V, 3) of a triangle mesh."""
    p = v[tri]
    fn = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    n = np.zeros_like(v)
    for c in range(3):
        np.add.at(n, tri[:, c], fn)
    return n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-20)


def _surface(pr: Primitives, k: float, voxel: float) -> tuple[np.ndarray, np.ndarray]:
    from skimage.measure import marching_cubes

    f, origin = _grid_field(pr, k, voxel)
    verts, tri, _, _ = marching_cubes(f, level=0.0, spacing=(voxel,) * 3,
                                      allow_degenerate=False)
    verts = verts + origin
    tri = tri.astype(np.int64)
    # outward: the enclosed volume is positive with counter-clockwise faces
    p = verts[tri]
    if np.einsum("ij,ij->i", p[:, 0], np.cross(p[:, 1], p[:, 2])).sum() < 0:
        tri = tri[:, ::-1].copy()
    return _smooth(verts, tri, SMOOTH_PASSES), tri


# ----------------------------------------------------------------------- skin
def _skin(pr: Primitives, v: np.ndarray, k: float):
    """Joints, weights, colours and part of every vertex from the segments near it."""
    V, P = len(v), len(pr.a)
    d = np.full((V, P), np.inf)
    t = np.zeros((V, P))
    lo, hi = _boxes(pr, k)
    for p in range(P):
        near = np.nonzero(np.all((v >= lo[p]) & (v <= hi[p]), axis=1))[0]
        if len(near):
            d[near, p], t[near, p] = field_distances(pr, p, v[near])
    gap = d - d.min(axis=1, keepdims=True)
    kw = WEIGHT_SHARPNESS * k
    soft = np.where(gap < 12.0 * kw, np.exp(-np.minimum(gap, 12.0 * kw) / kw), 0.0)
    soft /= soft.sum(axis=1, keepdims=True)
    W = (soft * (1.0 - t)) @ pr.weights[:, 0] + (soft * t) @ pr.weights[:, 1]
    joints, weights = top_weights(W, 4)
    kc = COLOR_SHARPNESS * k
    sharp = np.where(gap < 12.0 * kc, np.exp(-np.minimum(gap, 12.0 * kc) / kc), 0.0)
    rgb = sharp @ pr.rgb / sharp.sum(axis=1, keepdims=True)
    part = pr.part[np.argmin(d, axis=1)]
    return joints, weights, np.clip(rgb, 0.0, 1.0), part


def _coat(profile: Profile, v, n, tri, part, rgb, h: float) -> np.ndarray:
    """A lighter underside and dark spots, as the profile asks (colours (V, 3))."""
    from quadsim.frames import Y
    from quadsim.mesh.profiles import PARTS

    rgb = np.array(rgb)
    body = np.isin(part, [PARTS.index(c) for c in ("trunk", "neck", "head")])
    if profile.belly > 0:
        under = np.clip(-n[:, Y], 0.0, 1.0) * body * profile.belly
        rgb += under[:, None] * (np.asarray(profile.belly_rgb) - rgb)
    sp = profile.spots
    if sp is not None:
        on = np.isin(part, [PARTS.index(c) for c in
                            ("trunk", "neck", "fore_leg", "hind_leg", "tail")])
        coat = np.nonzero(on)[0]
        p = v[tri[on[tri].all(axis=1)]]
        area = 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1).sum()
        rng = np.random.default_rng(sp.seed)
        count = max(1, round(float(sp.density * area) / h ** 2))
        centres = v[rng.choice(coat, size=min(count, len(coat)), replace=False)]
        r = sp.radius * h
        near = np.full(len(v), np.inf)
        for c in np.array_split(centres, max(1, len(centres) // 64)):
            d = np.linalg.norm(v[coat, None, :] - c[None], axis=-1).min(axis=1)
            near[coat] = np.minimum(near[coat], d)
        x = np.clip(1.0 - near / r, 0.0, 1.0)
        dark = sp.darkness * np.minimum(1.0, 2.5 * x)
        rgb *= (1.0 - dark)[:, None]
    return np.clip(rgb, 0.0, 1.0)


_CACHE: dict = {}


def _fingerprint(skel: Skeleton) -> tuple:
    ends = tuple(sorted((k, tuple(np.round(v, 6))) for k, v in skel.end_sites.items()))
    return (skel.names, skel.parents.tobytes(), np.round(skel.offsets, 6).tobytes(), ends)


def skinned_body(skeleton: Skeleton, profile: Profile | None = None) -> SkinnedBody:
    """The skinned body of a quadruped skeleton (cached per skeleton and profile).

    Parameters
    ----------
    skeleton : Skeleton
    profile : Profile, optional
        By default the shipped character's whose skeleton this is
        (:func:`profile_for`), else :data:`~quadsim.mesh.profiles.DEFAULT_PROFILE`.

    A skeleton that is not a quadruped's (see
    :func:`quadsim.skeleton.anatomy.find_anatomy`) gets a round tube around
    every bone, each moved rigidly by its parent joint.
    """
    if profile is None:
        profile = profile_for(skeleton)
    key = (_fingerprint(skeleton), profile)
    hit = _CACHE.get(key) or _load_shipped(skeleton, profile)
    if hit is not None:
        _CACHE[key] = hit
        return hit
    body = build_body(skeleton, profile)
    if len(_CACHE) > 32:
        _CACHE.clear()
    _CACHE[key] = body
    return body


def build_body(skeleton: Skeleton, profile: Profile) -> SkinnedBody:
    """Build the skinned body (no cache; needs scikit-image).

    Raises
    ------
    InputError
        When scikit-image is not installed (the message names the extra).
    """
    from quadsim._optional import require

    require("skimage", "a body mesh for this skeleton")
    try:
        h = find_anatomy(skeleton).hip_height
        pr = primitives(skeleton, profile, h)
    except ValueError:                            # not a quadruped: a tube around each bone
        P = skeleton.rest_positions
        h = max(0.75 * float(np.ptp(P, axis=0).max()), 1e-3)
        pr = bone_primitives(skeleton, TUBE * h, profile.color)
    k = profile.blend * h
    v, tri = _surface(pr, k, profile.voxel * h)
    n = vertex_normals(v, tri)
    joints, weights, rgb, part = _skin(pr, v, k)
    rgb = _coat(profile, v, n, tri, part, rgb, h)
    arrays = (v, n, tri, joints, weights, rgb, part)
    for a in arrays:
        a.setflags(write=False)
    return SkinnedBody(*arrays, profile=profile.name)


def body_key(skeleton: Skeleton, profile: Profile) -> str:
    """A name for the body of ``skeleton`` in ``profile``: it changes when either does."""
    text = repr((_fingerprint(skeleton), repr(profile)))
    return f"{profile.name}-{hashlib.sha1(text.encode()).hexdigest()[:16]}"


def shipped_path(skeleton: Skeleton, profile: Profile):
    """Where a built body of ``skeleton`` in ``profile`` is shipped (it may not be)."""
    from importlib.resources import files

    return files("quadsim.data") / "bodies" / f"{body_key(skeleton, profile)}.npz"


def save_body(body: SkinnedBody, path) -> None:
    """Write ``body`` as an ``.npz`` (what :func:`skinned_body` loads for shipped skeletons):
    floats as float32 (what a GLB stores), indices in the narrowest unsigned type."""
    out = {}
    for f in fields(body):
        a = getattr(body, f.name)
        if isinstance(a, np.ndarray):
            if a.dtype.kind == "f":
                a = a.astype(np.float32)
            elif a.dtype.kind in "iu":
                a = a.astype(np.uint16 if a.max(initial=0) < 2**16 else np.uint32)
        out[f.name] = a
    np.savez_compressed(path, **out)


def _load_shipped(skeleton: Skeleton, profile: Profile) -> SkinnedBody | None:
    path = shipped_path(skeleton, profile)
    if not path.is_file():
        return None
    with np.load(path) as data:
        arrays = {f.name: data[f.name] for f in fields(SkinnedBody)}
    arrays["profile"] = str(arrays["profile"])
    for k, a in arrays.items():
        if isinstance(a, np.ndarray):
            arrays[k] = a.astype(np.float64 if a.dtype.kind == "f" else np.int64)
    for k, a in arrays.items():
        if isinstance(a, np.ndarray):
            a.setflags(write=False)
    return SkinnedBody(**arrays)


def profile_for(skeleton: Skeleton) -> Profile:
    """The profile of the shipped character with this skeleton (up to scale), else the default."""
    return profile_for_id(_character_id(skeleton))


_IDS: dict = {}


def _character_id(skeleton: Skeleton) -> str | None:
    key = _fingerprint(skeleton)
    if key in _IDS:
        return _IDS[key]
    from quadsim.skeleton.character import list_characters, load_character

    found = None
    mine = _shape(skeleton)
    for cid in list_characters():
        other = _shape(load_character(cid).skeleton)
        if other.keys() == mine.keys() and all(
                np.allclose(mine[n], other[n], atol=1e-4) for n in mine):
            found = cid
            break
    _IDS[key] = found
    return found


def _shape(skel: Skeleton) -> dict:
    """Rest offsets by joint name, scaled to a unit total bone length."""
    off = {n: skel.offsets[j] for j, n in enumerate(skel.names) if j > 0}
    scale = max(sum(np.linalg.norm(v) for v in off.values()), 1e-9)
    out = {n: v / scale for n, v in off.items()}
    out[""] = np.array([len(skel.names), 0.0, 0.0])
    return out
