"""The procedural body mesh (quadsim.mesh): closed, skinned, around the bones, per character."""

from __future__ import annotations

import numpy as np
import pytest

from quadsim.frames import X, Y, Z
from quadsim.mesh import DEFAULT_PROFILE, PROFILES, profile_for, skinned_body
from quadsim.mesh.profiles import PARTS
from quadsim.skeleton.anatomy import find_anatomy
from quadsim.skeleton.character import list_characters, load_character
from quadsim.skeleton.skeleton import Skeleton

CHARACTERS = list_characters()


@pytest.fixture(scope="module")
def bodies():
    return {c: skinned_body(load_character(c).skeleton) for c in CHARACTERS}


def closed_and_oriented(tri: np.ndarray) -> bool:
    """Every edge is shared by exactly two triangles, once in each direction."""
    directed = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    fwd = {tuple(e) for e in directed}
    return len(fwd) == len(directed) and all((b, a) in fwd for a, b in fwd)


def volume(v: np.ndarray, tri: np.ndarray) -> float:
    p = v[tri]
    return float(np.einsum("ij,ij->i", p[:, 0], np.cross(p[:, 1], p[:, 2])).sum() / 6.0)


def winding(v: np.ndarray, tri: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Generalised winding number of a closed mesh at points q (n, 3): 1 inside, 0 outside."""
    out = np.empty(len(q))
    for i, x in enumerate(q):
        a, b, c = (v[tri[:, k]] - x for k in range(3))
        la, lb, lc = (np.linalg.norm(u, axis=1) for u in (a, b, c))
        num = np.einsum("ij,ij->i", a, np.cross(b, c))
        den = (la * lb * lc + np.einsum("ij,ij->i", a, b) * lc
               + np.einsum("ij,ij->i", b, c) * la + np.einsum("ij,ij->i", c, a) * lb)
        out[i] = np.sum(2.0 * np.arctan2(num, den)) / (4.0 * np.pi)
    return out


# ------------------------------------------------------------------ surface
@pytest.mark.parametrize("cid", CHARACTERS)
def test_each_body_is_a_closed_outward_surface_of_a_glb_sized_mesh(bodies, cid):
    b = bodies[cid]
    assert b.profile == cid                       # its own profile, found from the skeleton
    assert 5_000 <= len(b.triangles) <= 20_000
    assert closed_and_oriented(b.triangles)
    assert volume(b.positions, b.triangles) > 0   # counter-clockwise seen from outside
    p = b.positions[b.triangles]
    face = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    agree = np.sum(face * b.normals[b.triangles].mean(axis=1), axis=1) > 0
    assert agree.mean() > 0.999
    np.testing.assert_allclose(np.linalg.norm(b.normals, axis=1), 1.0, atol=1e-9)


@pytest.mark.parametrize("cid", CHARACTERS)
def test_skin_weights_are_valid_for_gltf(bodies, cid):
    b = bodies[cid]
    J = load_character(cid).skeleton.n_joints
    assert b.joints.shape == b.weights.shape == (b.n_vertices, 4)
    assert b.joints.min() >= 0 and b.joints.max() < J
    assert np.all(b.weights >= 0)
    np.testing.assert_allclose(b.weights.sum(axis=1), 1.0, atol=1e-12)
    assert np.all(np.diff(b.weights, axis=1) <= 1e-15)          # by decreasing weight
    assert np.all(b.joints[b.weights == 0] == 0)                 # unused slots: joint 0
    used = b.weights > 0
    for row_j, row_u in zip(b.joints[:500], used[:500]):
        assert len(set(row_j[row_u])) == row_u.sum()             # no joint twice
    # smooth: many vertices blend two or more joints
    assert 0.3 < np.mean(used.sum(axis=1) >= 2) < 1.0


@pytest.mark.parametrize("cid", CHARACTERS)
def test_the_skin_encloses_the_bones(bodies, cid):
    """Every joint is inside the skin or within 4 % of the hip height of it."""
    b = bodies[cid]
    skel = load_character(cid).skeleton
    h = find_anatomy(skel).hip_height
    P = skel.rest_positions
    inside = winding(b.positions, b.triangles, P) > 0.5
    gap = np.array([np.linalg.norm(b.positions - p, axis=1).min() for p in P])
    ok = inside | (gap < 0.04 * h)
    assert ok.all(), [skel.names[j] for j in np.nonzero(~ok)[0]]
    assert inside.mean() > 0.85


# ------------------------------------------------------------- per character
def head_over_trunk(b) -> float:
    """Bounding-box volume of the head's vertices over the trunk's."""
    def box(part):
        v = b.positions[b.part == PARTS.index(part)]
        return float(np.prod(np.ptp(v, axis=0)))
    return box("head") / box("trunk")


def test_cubs_have_larger_heads_for_their_bodies_than_adults(bodies):
    adult = head_over_trunk(bodies["leopard"])
    assert head_over_trunk(bodies["leopard_cub"]) > 1.5 * adult
    assert head_over_trunk(bodies["dog_cub"]) > 1.3 * adult
    assert head_over_trunk(bodies["horse"]) < head_over_trunk(bodies["dog_cub"])


def neck_section(b, skel) -> tuple[float, float]:
    """Width (across) and depth (in the body's plane, across the neck) at mid-neck (m)."""
    a = find_anatomy(skel)
    P = skel.rest_positions
    base, top = P[a.withers], P[a.head]
    axis = (top - base) / np.linalg.norm(top - base)
    v = b.positions[b.part == PARTS.index("neck")]
    s = (v - base) @ axis / np.linalg.norm(top - base)
    mid = v[(s > 0.35) & (s < 0.65)]
    across = np.zeros(3)
    across[X] = 1.0
    depth_axis = np.cross(axis, across)
    return float(np.ptp(mid @ across)), float(np.ptp(mid @ depth_axis))


def test_the_horse_neck_is_deep_and_flat_sided_the_cats_round(bodies):
    w, d = neck_section(bodies["horse"], load_character("horse").skeleton)
    assert d > 1.8 * w
    wl, dl = neck_section(bodies["leopard"], load_character("leopard").skeleton)
    assert dl < 1.4 * wl


def trunk_depth(b, skel, f: float) -> float:
    """Depth (m) of the trunk in its mid-plane at fraction f from the pelvis to the withers."""
    a = find_anatomy(skel)
    P = skel.rest_positions
    z0, z1 = P[a.pelvis, Z], P[a.withers, Z]
    v = b.positions[b.part == PARTS.index("trunk")]
    band = (np.abs(v[:, X]) < 0.04 * a.hip_height) & (
        np.abs(v[:, Z] - (z0 + f * (z1 - z0))) < 0.04 * abs(z1 - z0))
    return float(np.ptp(v[band, Y]))


def test_the_chest_is_deeper_than_the_waist(bodies):
    for cid in ("horse", "leopard", "leopard_cub", "dog_cub"):
        skel = load_character(cid).skeleton
        assert trunk_depth(bodies[cid], skel, 0.7) > 1.12 * trunk_depth(bodies[cid], skel, 0.3)


def test_a_leopard_has_spots_and_a_thick_tail_the_horse_dark_hooves(bodies):
    leo = bodies["leopard"]
    coat = leo.colors[leo.part == PARTS.index("trunk")].sum(axis=1)
    assert np.mean(coat < 0.6 * np.median(coat)) > 0.05              # dark spots
    horse = bodies["horse"]
    hoof = horse.colors[horse.part == PARTS.index("fore_foot")].mean(axis=0)
    body = horse.colors[horse.part == PARTS.index("trunk")].mean(axis=0)
    assert hoof.sum() < 0.7 * body.sum()

    def tail_radius(cid):
        b = bodies[cid]
        v = b.positions[b.part == PARTS.index("tail")]
        return np.mean(np.abs(v[:, X])) / find_anatomy(load_character(cid).skeleton).hip_height
    assert tail_radius("leopard") > 1.2 * tail_radius("dog_cub")


# ------------------------------------------------------------- any skeleton
def test_a_users_rig_gets_the_default_profile_and_a_closed_skin():
    skel = load_character("leopard").skeleton
    renamed = Skeleton(tuple(f"bone{j}" for j in range(skel.n_joints)), skel.parents,
                       skel.offsets * 1.7,
                       {f"bone{skel.index(n)}": o * 1.7 for n, o in skel.end_sites.items()})
    assert profile_for(renamed) is DEFAULT_PROFILE
    b = skinned_body(renamed)
    assert b.profile == "default" and closed_and_oriented(b.triangles)
    np.testing.assert_allclose(b.weights.sum(axis=1), 1.0, atol=1e-12)
    # a shipped character's skeleton scaled is still that character
    assert profile_for(skel.scaled(0.5)) is PROFILES["leopard"]


def test_a_skeleton_that_is_no_quadruped_gets_a_tube_around_each_bone():
    skel = Skeleton(("root", "a", "b"), [-1, 0, 1], [[0, 1, 0], [0, 0, 0.5], [0, -0.5, 0]],
                    {"b": [0, 0, 0.3]})
    b = skinned_body(skel)
    assert closed_and_oriented(b.triangles) and volume(b.positions, b.triangles) > 0
    assert b.profile == "default"
    assert set(np.unique(b.joints[:, 0])) == {0, 1, 2}        # each bone moves its tube
    np.testing.assert_allclose(b.weights.sum(axis=1), 1.0, atol=1e-12)


def test_bodies_are_built_once_per_skeleton(bodies):
    skel = load_character("horse").skeleton
    assert skinned_body(skel) is bodies["horse"]
    assert not bodies["horse"].positions.flags.writeable


@pytest.mark.parametrize("cid", ["leopard", "leopard_cub", "dog_cub", "horse"])
def test_the_shipped_body_is_the_one_the_builder_makes(cid):
    """quadsim/data/bodies holds each shipped character's body built; a change of profile
    or builder without `python tools/build_body_meshes.py` fails here."""
    pytest.importorskip("skimage")
    from quadsim.mesh.body import _load_shipped, build_body, profile_for, shipped_path

    sk = load_character(cid).skeleton
    profile = profile_for(sk)
    assert shipped_path(sk, profile).is_file(), "run python tools/build_body_meshes.py"
    shipped, fresh = _load_shipped(sk, profile), build_body(sk, profile)
    np.testing.assert_array_equal(shipped.triangles, fresh.triangles)
    np.testing.assert_array_equal(shipped.joints, fresh.joints)
    for name in ("positions", "normals", "weights", "colors"):
        np.testing.assert_allclose(getattr(shipped, name), getattr(fresh, name), atol=1e-6,
                                   err_msg=name)
