"""The spine state machine, gait choice and transitions, and key-point turning.

Specification (DESIGN.md):

* spine: the four contact combinations map to the four states of the table
  (double flight, front stance, double stance, back stance); the first two
  flex the back (theta_c), the others extend it (theta_v); the mid-spine moves
  towards its target at a bounded angular speed and holds it once reached;
* gait choice by speed has hysteresis: sweeping the speed slowly across a
  boundary switches once each way, up later than down;
* a transition moves the duty factor along ``beta(t) = beta_1 + alpha t^2``,
  ``alpha = (beta_2 - beta_1) / T^2``, and the phase offsets along the
  shorter way round the stride circle;
* turning: the body follows the exact arc of its speed and yaw rate (a
  circle closes, a quarter circle of radius ``R = v / w`` ends at ``(R, 0, R)``
  from heading 0 turning left), continuously into the straight line.
"""

from __future__ import annotations

import numpy as np
import pytest

from quadsim import list_characters, load_character
from quadsim.frames import FORWARD, Y, heading_vector
from quadsim.kinematics.rotations import matrices_about_axis
from quadsim.locomotion.gaits import auto_gaits, gait_table
from quadsim.locomotion.spine import (
    BACK_STANCE,
    DOUBLE_FLIGHT,
    DOUBLE_STANCE,
    FRONT_STANCE,
    rate_limited,
    spine_state,
    spine_target,
)
from quadsim.locomotion.transition import GaitParams, GaitScheduler
from quadsim.locomotion.turning import arc_advance, rotate_y, turn_rate_towards

DT = 1.0 / 60.0
HORSE = gait_table(load_character("horse"))


def circular(frac):
    return np.mod(np.asarray(frac) + 0.5, 1.0) - 0.5


# =================================================================== spine
def test_contact_combinations_map_to_the_four_states():
    fore = np.array([False, True, True, False])
    hind = np.array([False, False, True, True])
    expected = [DOUBLE_FLIGHT, FRONT_STANCE, DOUBLE_STANCE, BACK_STANCE]
    assert spine_state(fore, hind).tolist() == expected
    assert len(set(expected)) == 4
    for f, h, e in zip(fore, hind, expected):
        assert spine_state(bool(f), bool(h)) == e
    # any batch shape
    rng = np.random.default_rng(60)
    F, H = rng.integers(0, 2, (2, 7, 5)).astype(bool)
    got = spine_state(F, H)
    assert got.shape == (7, 5)
    assert np.array_equal(got == DOUBLE_STANCE, F & H)
    assert np.array_equal(got == DOUBLE_FLIGHT, ~F & ~H)
    assert np.array_equal(got == FRONT_STANCE, F & ~H)
    assert np.array_equal(got == BACK_STANCE, ~F & H)


def test_flight_and_front_stance_flex_the_back_the_others_extend_it():
    rng = np.random.default_rng(61)
    flexed, extended = rng.uniform(0.1, 0.5), -rng.uniform(0.1, 0.5)
    states = np.array([DOUBLE_FLIGHT, FRONT_STANCE, DOUBLE_STANCE, BACK_STANCE])
    np.testing.assert_array_equal(spine_target(states, flexed, extended),
                                  [flexed, flexed, extended, extended])
    # per-item targets broadcast with the state
    fl, ex = rng.uniform(0.1, 0.5, 4), -rng.uniform(0.1, 0.5, 4)
    np.testing.assert_array_equal(spine_target(states, fl, ex), [fl[0], fl[1], ex[2], ex[3]])


def test_rate_limited_moves_at_most_max_rate_dt_and_then_holds():
    rng = np.random.default_rng(62)
    n = 1000
    angle = rng.uniform(-1, 1, n)
    target = rng.uniform(-1, 1, n)
    rate = rng.uniform(0.5, 5.0, n)
    dt = rng.choice([1 / 30, 1 / 60, 1 / 240], n)
    steps_needed = np.ceil(np.abs(target - angle) / (rate * dt)).astype(int)
    a = angle.copy()
    for k in range(steps_needed.max() + 5):
        b = rate_limited(a, target, rate, dt)
        step = b - a
        assert np.all(np.abs(step) <= rate * dt * (1 + 1e-12))
        # always towards the target, never past it
        assert np.all(step * (target - a) >= 0)
        assert np.all(np.abs(target - b) <= np.abs(target - a))
        done = k + 1 >= steps_needed
        np.testing.assert_array_equal(b[done], target[done])
        a = b
    # far from the target it moves at full speed
    far = np.abs(target - angle) > 2 * rate * dt
    first = rate_limited(angle, target, rate, dt) - angle
    np.testing.assert_allclose(np.abs(first[far]), (rate * dt)[far], rtol=1e-12)


# ============================================================ gait choice
BOUNDARIES = []
for _name in list_characters():
    _ch = load_character(_name)
    _sched = GaitScheduler(gait_table(_ch), auto_gaits(_ch), auto_gaits(_ch)[0])
    BOUNDARIES += [(_name, k) for k in range(len(_sched.bounds))]


def scheduler(name, start):
    ch = load_character(name)
    return GaitScheduler(gait_table(ch), auto_gaits(ch), start)


def sweep_range(s, k):
    """Speeds around boundary ``k`` that reach no neighbouring boundary's band."""
    b, h = s.bounds[k], s.hysteresis
    lo, hi = b * (1 - 3 * h), b * (1 + 3 * h)
    if k > 0:
        lo = max(lo, 0.5 * (s.bounds[k - 1] * (1 + h) + b * (1 - h)))
    if k + 1 < len(s.bounds):
        hi = min(hi, 0.5 * (b * (1 + h) + s.bounds[k + 1] * (1 - h)))
    return lo, hi


@pytest.mark.parametrize("name, k", BOUNDARIES, ids=[f"{n}-{k}" for n, k in BOUNDARIES])
def test_speed_sweep_switches_once_each_way_with_hysteresis(name, k):
    s = scheduler(name, scheduler(name, "walk").auto[k])
    slow, fast = s.auto[k], s.auto[k + 1]
    lo, hi = sweep_range(s, k)
    assert lo < s.bounds[k] * (1 - s.hysteresis) and hi > s.bounds[k] * (1 + s.hysteresis)
    up = np.linspace(lo, hi, 3001)  # about 1e-4 of the speed per step
    speeds = np.concatenate([up, up[::-1]])
    gaits = []
    for v in speeds:
        s.update(s.auto_choice(v), v, DT, 0.5)
        gaits.append(s.current)
    gaits = np.array(gaits)
    switch = np.flatnonzero(gaits[1:] != gaits[:-1]) + 1
    assert len(switch) == 2, [(speeds[i], gaits[i]) for i in switch]
    i_up, i_down = switch
    assert i_up < len(up) <= i_down
    assert (gaits[i_up - 1], gaits[i_up]) == (slow, fast)
    assert (gaits[i_down - 1], gaits[i_down]) == (fast, slow)
    v_up, v_down = speeds[i_up], speeds[i_down]
    assert v_up > s.bounds[k] > v_down
    assert v_up - v_down > s.bounds[k] * s.hysteresis  # a real band, not a rounding


@pytest.mark.parametrize("name, k", BOUNDARIES, ids=[f"{n}-{k}" for n, k in BOUNDARIES])
def test_dithering_speed_inside_the_band_never_switches(name, k):
    rng = np.random.default_rng(70 + k)
    names = scheduler(name, "walk").auto
    for start in (names[k], names[k + 1]):
        s = scheduler(name, start)
        b, h = s.bounds[k], s.hysteresis
        for v in b * (1 + rng.uniform(-0.9 * h, 0.9 * h, 600)):
            s.update(s.auto_choice(v), v, DT, 0.5)
            assert s.current == start


# ============================================================ transitions
PAIRS = [("walk", "trot"), ("trot", "walk"), ("walk", "canter"), ("trot", "transverse_gallop"),
         ("amble", "rotary_gallop"), ("rotary_gallop", "pace"), ("rack", "walk")]


def run_transition(old, new, speed, period):
    """Steady in ``old``, then a transition to ``new`` at constant speed.

    Returns the scheduler and the (elapsed time, parameters) of every step
    of the transition.
    """
    s = GaitScheduler(HORSE, ["walk", "trot", "canter", "transverse_gallop"], old)
    s.update(old, speed, DT, period)
    samples = [(s.elapsed, s.update(new, speed, DT, period))]
    assert s.in_transition
    while True:
        p = s.update(new, speed, DT, period)
        if not s.in_transition:
            return s, samples, p
        samples.append((s.elapsed, p))


@pytest.mark.parametrize("period", [0.8, 0.2])
@pytest.mark.parametrize("old, new", PAIRS)
def test_duty_follows_the_quadratic_transition_curve(old, new, period):
    speed = HORSE[new].preferred_speed
    s, samples, after = run_transition(old, new, speed, period)
    T = s.duration
    assert T > 5 * DT
    beta1, beta2 = float(HORSE[old].duty(speed)), float(HORSE[new].duty(speed))
    assert abs(beta2 - beta1) > 0.05
    t = np.array([e for e, _ in samples])
    duty = np.array([p.duty for _, p in samples])
    assert t[0] == 0.0 and t[-1] > T - 2 * DT
    alpha = (beta2 - beta1) / T ** 2
    quad, lin, const = np.polyfit(t, duty, 2)
    np.testing.assert_allclose(quad, alpha, rtol=1e-9)
    assert abs(lin) < 1e-9 * abs(alpha)
    np.testing.assert_allclose(const, beta1, rtol=0, atol=1e-12)
    np.testing.assert_allclose(duty, beta1 + alpha * t ** 2, rtol=0, atol=1e-12)
    # the other parameters ride the same progress (t / T)^2
    u = (t / T) ** 2
    a, b = GaitParams.of(HORSE[old], speed), GaitParams.of(HORSE[new], speed)
    for field in ("swing_height", "drop", "bound", "spine_amplitude", "stride_coefficient"):
        got = np.array([getattr(p, field) for _, p in samples])
        want = getattr(a, field) + u * (getattr(b, field) - getattr(a, field))
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-12, err_msg=field)
    # and it ends exactly on the new gait
    assert after.duty == b.duty and np.array_equal(after.phases, b.phases)
    assert s.label == new


@pytest.mark.parametrize("old, new", PAIRS)
def test_phases_move_the_shorter_way_round(old, new):
    speed = HORSE[new].preferred_speed
    _, samples, after = run_transition(old, new, speed, 0.8)
    psi = np.array([p.phases for _, p in samples] + [after.phases])
    assert np.all((psi >= 0) & (psi < 1))
    steps = circular(np.diff(psi, axis=0))
    total = steps.sum(axis=0)
    short = circular(HORSE[new].phases - HORSE[old].phases)
    np.testing.assert_allclose(total, short, rtol=0, atol=1e-12)
    assert np.all(np.abs(total) <= 0.5)
    # each leg moves one way only
    assert np.all(steps * np.sign(short) >= -1e-15)


def test_walk_to_canter_right_fore_goes_forward_through_the_stride_end():
    """RF: 0.75 -> 0.0. The shorter way is +0.25 (through 1.0), not -0.75."""
    a = GaitParams.of(HORSE["walk"], 3.0)
    b = GaitParams.of(HORSE["canter"], 3.0)
    RF = 1
    assert (a.phases[RF], b.phases[RF]) == (0.75, 0.0)
    np.testing.assert_allclose(a.blend(b, 0.5).phases[RF], 0.875, atol=1e-15)
    np.testing.assert_allclose(a.blend(b, 0.96).phases[RF], 0.99, atol=1e-12)


def random_params(rng):
    return GaitParams(duty=rng.uniform(0.2, 0.8), phases=rng.uniform(0, 1, 4),
                      stride_coefficient=rng.uniform(1.5, 2.5), min_speed=rng.uniform(0, 5),
                      swing_height=rng.uniform(0.05, 0.3), drop=rng.uniform(0, 0.1),
                      bound=float(rng.integers(0, 2)), spine_amplitude=rng.uniform(0, 0.1))


FIELDS = ("duty", "stride_coefficient", "min_speed", "swing_height", "drop", "bound",
          "spine_amplitude")


def test_blend_ends_are_the_endpoints():
    rng = np.random.default_rng(80)
    for _ in range(200):
        a, b = random_params(rng), random_params(rng)
        at0, at1 = a.blend(b, 0.0), a.blend(b, 1.0)
        for f in FIELDS:
            assert getattr(at0, f) == getattr(a, f), f
            np.testing.assert_allclose(getattr(at1, f), getattr(b, f), rtol=1e-15, atol=1e-15)
        np.testing.assert_array_equal(at0.phases, a.phases)
        np.testing.assert_allclose(circular(at1.phases - b.phases), 0.0, atol=1e-15)
        assert np.all((at1.phases >= 0) & (at1.phases < 1))


def test_blend_is_proportional_along_the_shorter_arc():
    rng = np.random.default_rng(81)
    for _ in range(200):
        a, b = random_params(rng), random_params(rng)
        x = rng.uniform(0, 1)
        m = a.blend(b, x)
        short = circular(b.phases - a.phases)
        np.testing.assert_allclose(circular(m.phases - a.phases), x * short, atol=1e-12)
        np.testing.assert_allclose(m.duty, a.duty + x * (b.duty - a.duty), rtol=1e-14)


# ================================================================ turning
def exact_arc(p, h, v, w, tau):
    """Closed form with a stable sinc: chord ``2 R sin(dh/2)`` at ``h + dh/2``."""
    dh = w * tau
    chord = v * tau * np.sinc(dh / (2 * np.pi))  # np.sinc(x) = sin(pi x) / (pi x)
    return p + chord[..., None] * heading_vector(h + dh / 2), h + dh


def test_full_circle_returns_to_the_start():
    rng = np.random.default_rng(90)
    n = 200
    p = rng.uniform(-10, 10, (n, 3))
    h = rng.uniform(-np.pi, np.pi, n)
    v = rng.uniform(0.1, 15, n)
    w = rng.choice([-1, 1], n) * rng.uniform(0.05, 3, n)
    q, hq = arc_advance(p, h, v, w, 2 * np.pi / np.abs(w))
    np.testing.assert_allclose(q, p, rtol=0, atol=1e-9)
    np.testing.assert_allclose(hq, h + 2 * np.pi * np.sign(w), atol=1e-12)
    # halfway round it is a diameter away, to the left when turning left
    q, _ = arc_advance(p, h, v, w, np.pi / np.abs(w))
    left = heading_vector(h + np.pi / 2)
    np.testing.assert_allclose(q, p + 2 * (v / w)[:, None] * left, rtol=0, atol=1e-9)


def test_quarter_circle_left_from_heading_zero():
    rng = np.random.default_rng(91)
    v, w = rng.uniform(0.5, 10, 50), rng.uniform(0.1, 2.0, 50)
    R = v / w
    q, hq = arc_advance(np.zeros((50, 3)), np.zeros(50), v, w, (np.pi / 2) / w)
    np.testing.assert_allclose(q, np.stack([R, 0 * R, R], -1), rtol=0, atol=1e-12 * R.max())
    np.testing.assert_allclose(hq, np.pi / 2, atol=1e-15)
    # and to the right it mirrors in X
    q, hq = arc_advance(np.zeros((50, 3)), np.zeros(50), v, -w, (np.pi / 2) / w)
    np.testing.assert_allclose(q, np.stack([-R, 0 * R, R], -1), rtol=0, atol=1e-12 * R.max())


def test_straight_line_limit_is_continuous():
    """Yaw rates from large to zero, both sides of the solver's switch to the
    straight-line formula: the same closed form throughout."""
    rng = np.random.default_rng(92)
    w = np.concatenate([np.logspace(0, -14, 400), -np.logspace(0, -14, 400), [0.0]])
    n = len(w)
    p = rng.uniform(-5, 5, (n, 3))
    h = rng.uniform(-np.pi, np.pi, n)
    v = rng.uniform(0.5, 10, n)
    tau = rng.uniform(0.2, 2.0, n)
    q, hq = arc_advance(p, h, v, w, tau)
    qe, he = exact_arc(p, h, v, w, tau)
    # 1e-9 of the distance travelled: the arc formula loses digits to
    # cancellation (cos h - cos(h + dh)) just above the switch
    miss = np.linalg.norm(q - qe, axis=-1)
    assert np.all(miss <= 1e-9 * v * tau), (miss / (v * tau)).max()
    np.testing.assert_allclose(hq, he, rtol=0, atol=1e-15)
    # w = 0 is the straight line exactly
    np.testing.assert_allclose(q[-1], p[-1] + v[-1] * tau[-1] * heading_vector(h[-1]), atol=1e-12)
    # dense sweep through the switch: no jump between neighbouring yaw rates
    ws = np.concatenate([np.linspace(0.5e-6, 2e-6, 3001), -np.linspace(0.5e-6, 2e-6, 3001)])
    qs, _ = arc_advance(np.zeros(3), 0.3, 2.0, ws, 1.0)
    qe, _ = exact_arc(np.zeros(3), 0.3, 2.0, ws, 1.0)
    assert np.linalg.norm(qs - qe, axis=-1).max() <= 1e-9 * 2.0


def test_arc_moves_along_its_heading():
    """The velocity at the end of an arc (central differences in time) is
    ``v`` along the end heading."""
    rng = np.random.default_rng(93)
    n = 100
    p, h = rng.uniform(-5, 5, (n, 3)), rng.uniform(-np.pi, np.pi, n)
    v, w, tau = rng.uniform(0.5, 10, n), rng.uniform(-2, 2, n), rng.uniform(0.1, 3, n)
    e = 1e-6
    q1, _ = arc_advance(p, h, v, w, tau + e)
    q0, _ = arc_advance(p, h, v, w, tau - e)
    _, hq = arc_advance(p, h, v, w, tau)
    np.testing.assert_allclose((q1 - q0) / (2 * e), v[:, None] * heading_vector(hq),
                               rtol=0, atol=1e-6)
    assert np.all(q1[:, Y] == p[:, Y])


def test_rotate_y_matches_the_rotation_matrix():
    rng = np.random.default_rng(94)
    vec = rng.normal(size=(50, 7, 3))
    ang = rng.uniform(-10, 10, (50, 7))
    want = np.einsum("...ij,...j->...i", matrices_about_axis(Y, ang), vec)
    np.testing.assert_allclose(rotate_y(vec, ang), want, rtol=0, atol=1e-14)
    # one angle for many vectors
    np.testing.assert_allclose(rotate_y(vec, 0.7), vec @ matrices_about_axis(Y, 0.7).T,
                               rtol=0, atol=1e-14)
    # heading convention: forward turned by the heading is the heading vector, +X at 90 deg
    for a in ang.ravel()[:20]:
        np.testing.assert_allclose(rotate_y(FORWARD, a), heading_vector(a), atol=1e-15)
    np.testing.assert_allclose(rotate_y(FORWARD, np.pi / 2), [1.0, 0.0, 0.0], atol=1e-15)


def test_rotate_y_broadcasts_one_vector_over_many_angles():
    rng = np.random.default_rng(96)
    ang = rng.uniform(-10, 10, (50, 7))
    np.testing.assert_allclose(rotate_y(FORWARD, ang), heading_vector(ang), atol=1e-15)


def test_turn_rate_is_capped_and_turns_the_short_way():
    rng = np.random.default_rng(95)
    heading = rng.uniform(-20, 20, 2000)
    target = rng.uniform(-20, 20, 2000)
    cap = rng.uniform(0.1, 3.0, 2000)
    rate = turn_rate_towards(heading, target, cap, gain=2.0)
    err = np.mod(target - heading + np.pi, 2 * np.pi) - np.pi
    assert np.all(np.abs(rate) <= cap)
    assert np.all(np.sign(rate) == np.sign(err))
    small = 2.0 * np.abs(err) < cap
    np.testing.assert_allclose(rate[small], 2.0 * err[small], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(np.abs(rate[~small]), cap[~small], rtol=0)
    # across the +-pi seam: from 170 deg to -170 deg is 20 deg to the left
    r = turn_rate_towards(np.radians(170.0), np.radians(-170.0), 10.0, gain=1.0)
    np.testing.assert_allclose(r, np.radians(20.0), rtol=1e-12)
    assert turn_rate_towards(1.0, 1.0, 2.0) == 0.0
