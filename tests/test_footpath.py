"""Swing-foot paths: the Catmull-Rom spline and the swing curve built on it.

Specification (STYLE.md, after scipy's spline tests): an analytic case (a
straight line is reproduced), invariants (the curve passes through its
interior knots, value and rate are continuous there, checked by central
differences), and one ``pytest.raises(ValueError, match=...)`` per bad
input. The swing path leaves the lift-off point and lands on the touchdown
point, clears the ground by about the requested height, never dips below
the ground on a level step, and never moves backwards.
"""

from __future__ import annotations

import numpy as np
import pytest

from quadsim.frames import UP
from quadsim.locomotion.footpath import catmull_rom, swing_position


def knots_of(K):
    """Curve parameters of the interior knots ``points[1] ... points[K-2]``."""
    return np.arange(K - 2) / (K - 3)


def along(points, s):
    """``catmull_rom`` with one control polygon and many parameters."""
    s = np.asarray(s, dtype=float)
    return catmull_rom(np.broadcast_to(points, s.shape + points.shape), s)


# ------------------------------------------------------------- Catmull-Rom
@pytest.mark.parametrize("K", [4, 5, 7, 10])
def test_passes_through_the_interior_knots(K):
    rng = np.random.default_rng(K)
    P = rng.normal(size=(20, K, 3))
    s = np.broadcast_to(knots_of(K), (20, K - 2))
    p = catmull_rom(P[:, None], s)
    np.testing.assert_allclose(p, P[:, 1:-1], rtol=0, atol=1e-12)


@pytest.mark.parametrize("K", [5, 7, 10])
def test_value_and_rate_are_continuous_at_the_knots(K):
    """Central differences just before and just after each interior knot agree
    with each other and with the Catmull-Rom tangent ``(P[j+1] - P[j-1]) / 2``
    per segment."""
    rng = np.random.default_rng(20 + K)
    P = rng.normal(size=(K, 3))
    nseg = K - 3
    h, gap = 1e-7, 1e-5
    for j, s in zip(range(2, K - 2), knots_of(K)[1:-1]):
        left = (along(P, s - gap + h) - along(P, s - gap - h)) / (2 * h)
        right = (along(P, s + gap + h) - along(P, s + gap - h)) / (2 * h)
        tangent = nseg * 0.5 * (P[j + 1] - P[j - 1])
        scale = np.abs(P).max() * nseg ** 2
        np.testing.assert_allclose(left, tangent, rtol=0, atol=1e-4 * scale)
        np.testing.assert_allclose(right, tangent, rtol=0, atol=1e-4 * scale)
        np.testing.assert_allclose(along(P, s + 1e-13), along(P, s - 1e-13), atol=1e-11)
        np.testing.assert_allclose(along(P, s), P[j], atol=1e-12)


def test_tangent_at_a_corner_is_the_centred_chord():
    """At a right-angle corner of the polygon the rate is ``(P[j+1] - P[j-1]) / 2``
    per segment, not either one-sided chord: the rate check above can tell them apart."""
    P = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0], [2, 1, 0], [2, 2, 0]], float)
    s, h = knots_of(5)[1], 1e-7
    central = (along(P, s + h) - along(P, s - h)) / (2 * h)
    np.testing.assert_allclose(central, 2 * 0.5 * (P[3] - P[1]), atol=1e-6)
    assert np.linalg.norm(central - 2 * (P[2] - P[1])) > 0.5


@pytest.mark.parametrize("K", [4, 6, 9])
def test_reproduces_a_straight_line(K):
    """Evenly spaced collinear points give the line itself, at uniform speed."""
    rng = np.random.default_rng(30 + K)
    a, d = rng.normal(size=3), rng.normal(size=3)
    P = a + np.arange(K)[:, None] * d
    s = np.linspace(0.0, 1.0, 101)
    expected = a + (1.0 + s * (K - 3))[:, None] * d
    np.testing.assert_allclose(along(P, s), expected, rtol=0, atol=1e-12)


def test_batched_curves_equal_single_ones():
    rng = np.random.default_rng(40)
    P = rng.normal(size=(6, 5, 7, 3))
    s = rng.uniform(0, 1, (6, 5))
    p = catmull_rom(P, s)
    assert p.shape == (6, 5, 3)
    for i in range(6):
        for k in range(5):
            np.testing.assert_allclose(catmull_rom(P[i, k], s[i, k]), p[i, k], rtol=0, atol=1e-15)


@pytest.mark.parametrize("K", [0, 1, 2, 3])
def test_too_few_control_points(K):
    with pytest.raises(ValueError, match=rf"at least 4 control points, got {K}"):
        catmull_rom(np.zeros((K, 3)), 0.5)


# ------------------------------------------------------------------ swing
def random_level_steps(rng, n):
    """Lift-off and touchdown on one level ground line, any direction and length."""
    a = rng.uniform(-5, 5, (n, 3))
    a[:, 1] = rng.uniform(-1, 1, n)
    length = rng.uniform(0.02, 3.0, n)
    heading = rng.uniform(-np.pi, np.pi, n)
    b = a + length[:, None] * np.stack([np.sin(heading), 0 * heading, np.cos(heading)], -1)
    return a, b, rng.uniform(0.01, 0.5, n)


def sampled(a, b, h, m=2001):
    """Swing positions, shape (n, m, 3), at ``m`` evenly spaced progress values."""
    s = np.broadcast_to(np.linspace(0.0, 1.0, m), (len(a), m))
    return swing_position(a[:, None], b[:, None], h[:, None], s)


def test_swing_starts_at_liftoff_and_ends_at_touchdown():
    rng = np.random.default_rng(50)
    a, b, h = random_level_steps(rng, 300)
    b[:150, 1] += rng.uniform(-0.3, 0.3, 150)  # some steps up or down
    np.testing.assert_array_equal(swing_position(a, b, h, np.zeros(300)), a)
    np.testing.assert_allclose(swing_position(a, b, h, np.ones(300)), b, rtol=0, atol=1e-13)


def test_swing_clears_the_ground_by_its_height_on_a_level_step():
    rng = np.random.default_rng(51)
    a, b, h = random_level_steps(rng, 300)
    rise = sampled(a, b, h)[..., 1] - a[:, None, 1]
    peak = rise.max(axis=1) / h
    assert np.all((peak >= 0.9) & (peak <= 1.2)), (peak.min(), peak.max())


def test_swing_never_goes_below_the_ground_on_a_level_step():
    rng = np.random.default_rng(52)
    a, b, h = random_level_steps(rng, 300)
    rise = sampled(a, b, h)[..., 1] - a[:, None, 1]
    assert rise.min() >= -1e-12
    # and it is off the ground everywhere in between
    assert rise[:, 1:-1].min() > 0


def test_swing_moves_forward_monotonically_in_its_plane():
    rng = np.random.default_rng(53)
    a, b, h = random_level_steps(rng, 300)
    p = sampled(a, b, h) - a[:, None]
    u = (b - a) / np.linalg.norm(b - a, axis=-1, keepdims=True)
    progress = np.einsum("nmi,ni->nm", p, u)
    assert np.all(np.diff(progress, axis=1) > 0)
    # no sideways wander: the path stays in the vertical plane of the step
    side = np.cross(u, UP)
    np.testing.assert_allclose(np.einsum("nmi,ni->nm", p, side), 0.0, atol=1e-12)


def test_scalar_progress_broadcasts_over_a_batch_of_steps():
    rng = np.random.default_rng(54)
    a, b, h = random_level_steps(rng, 5)
    p = swing_position(a, b, h, 0.5)
    np.testing.assert_allclose(p, swing_position(a, b, h, np.full(5, 0.5)), atol=1e-15)


@pytest.mark.parametrize("fast,bounding", [(0.5, 0.0), (1.0, 0.0), (0.0, 0.5), (0.0, 1.0),
                                           (0.4, 0.6)])
def test_the_fast_gaits_path_keeps_the_slow_paths_shape(fast, bounding):
    """Blended towards the fast or the bounding gaits' knots, a swing still runs from
    lift-off to touchdown, forwards all the way, clear of the ground by about its
    height."""
    rng = np.random.default_rng(55)
    a, b, h = random_level_steps(rng, 300)
    np.testing.assert_array_equal(swing_position(a, b, h, np.zeros(300), fast, 0.0, bounding),
                                  a)
    np.testing.assert_allclose(swing_position(a, b, h, np.ones(300), fast, 0.0, bounding), b,
                               rtol=0, atol=1e-13)
    s = np.broadcast_to(np.linspace(0.0, 1.0, 2001), (len(a), 2001))
    p = swing_position(a[:, None], b[:, None], h[:, None], s, fast, 0.0, bounding) \
        - a[:, None]
    u = (b - a) / np.linalg.norm(b - a, axis=-1, keepdims=True)
    assert np.all(np.diff(np.einsum("nmi,ni->nm", p, u), axis=1) > 0)
    peak = p[..., 1].max(axis=1) / h
    assert np.all((peak >= 0.9) & (peak <= 1.2)) and p[:, 1:-1, 1].min() > 0


@pytest.mark.parametrize("walk", [0.5, 1.0])
def test_the_walks_path_peels_the_foot_off_nearly_straight_up(walk):
    """Blended towards the walk's knots, a swing keeps the slow path's shape (lift-off
    to touchdown, forwards all the way, clear of the ground by about its height), but a
    sixteenth of the way into it the foot has covered under 0.4 of what the slow
    path's has, fully the walk's (its foot left at 0.7-0.9 of the body's speed)."""
    rng = np.random.default_rng(56)
    a, b, h = random_level_steps(rng, 300)
    np.testing.assert_array_equal(swing_position(a, b, h, np.zeros(300), 0.0, walk), a)
    np.testing.assert_allclose(swing_position(a, b, h, np.ones(300), 0.0, walk), b, rtol=0,
                               atol=1e-13)
    s = np.broadcast_to(np.linspace(0.0, 1.0, 2001), (len(a), 2001))
    p = swing_position(a[:, None], b[:, None], h[:, None], s, 0.0, walk) - a[:, None]
    u = (b - a) / np.linalg.norm(b - a, axis=-1, keepdims=True)
    assert np.all(np.diff(np.einsum("nmi,ni->nm", p, u), axis=1) > 0)
    peak = p[..., 1].max(axis=1) / h
    assert np.all((peak >= 0.9) & (peak <= 1.2)) and p[:, 1:-1, 1].min() > 0
    early = np.einsum("ni,ni->n", swing_position(a, b, h, 1 / 16, 0.0, walk) - a, u)
    slow = np.einsum("ni,ni->n", swing_position(a, b, h, 1 / 16) - a, u)
    assert np.all(early > 0)
    assert np.all(early < (1.0 - 0.6 * walk) * slow), (early / slow).max()


def test_the_fast_gaits_path_eases_out_over_the_last_quarter():
    """An eighth of the swing before touchdown the fast gaits' foot still moves
    forward at about half its mean speed (the slow gaits' at a fifth: it has
    braked harder), and both stop at touchdown."""
    a, b, h = np.zeros((1, 1, 3)), np.array([[[0.0, 0.0, 1.0]]]), np.array([[0.1]])
    s = np.array([0.875, 0.876, 0.999999, 1.0])[:, None]

    def speed(fast):  # per unit of progress: the mean is 1
        z = swing_position(a, b, h, s, fast)[:, 0, 2]
        return (z[1] - z[0]) / 0.001, (z[3] - z[2]) / 1e-6

    slow_mid, slow_end = speed(0.0)
    fast_mid, fast_end = speed(1.0)
    assert fast_mid > 0.4 and 0.1 < slow_mid < 0.3
    assert abs(fast_end) < 1e-3 and abs(slow_end) < 1e-3


@pytest.mark.parametrize("duty", [0.2, 0.25, 0.3])
def test_a_bounding_gaits_swing_comes_back_onto_its_touchdown_point_from_less_far(duty):
    """Seen from a body that covers ``1 - duty`` of the step while the foot swings (a
    steady gait), a galloping foot swings out past where it will land and comes back
    onto it, landing at rest on the ground: on the bounding gaits' path 0.08-0.10 of the
    step past it, a fifth less than on the slow path (0.11-0.13 of the step, the
    horse's fore hoof about 0.65 m: out of its leg's reach), and it starts no further
    back."""
    s = np.linspace(0.0, 1.0, 4001)
    a, b = np.zeros(3), np.array([0.0, 0.0, 1.0])
    ahead, back = {}, {}
    for name, share in (("slow", 0.0), ("bounding", 1.0)):
        z = swing_position(a, b, 0.1, s, bounding=share)[:, 2]
        body = z - (1.0 - duty) * s  # the foot from the body, in steps
        ahead[name], back[name] = body.max() - duty, -body.min()
        assert (z[-1] - z[-2]) / (s[1] - s[0]) < 0.01  # at rest along the ground
    assert ahead["bounding"] <= 0.8 * ahead["slow"] and ahead["bounding"] <= 0.101, ahead
    assert back["bounding"] <= back["slow"] + 1e-9, back
