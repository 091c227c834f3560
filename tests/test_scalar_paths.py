"""The compiled stage kernels the engine runs equal independent array forms.

The compiled one-point interpolation of the plan must agree with
``numpy.interp`` (inside, at knots and beyond the ends). The kernels shared
by the single and batched paths must agree with the pure-numpy oracles of
``tests/oracles.py``: the CPG step (also at zero amplitude), the feet stage
against the turning arc and the swing spline (a straight and a turning arc,
progress 0 to touchdown); and the posing
(:mod:`quadsim.locomotion.pose_kernel`) against the posing written with the
array IK and forward kinematics.
"""

import math

import numpy as np
import pytest
from numba import njit
from oracles import arc_advance, cpg_step, solve_leg, swing_position

from quadsim.kinematics.rotations import matrices_yaw_pitch
from quadsim.locomotion import bundles as B
from quadsim.locomotion.controller import ControllerSettings
from quadsim.locomotion.cpg import CPGParams, cpg_step_rows
from quadsim.locomotion.cpg import cpg_step as compiled_cpg_step
from quadsim.locomotion.feet import FOLD_SKEW, HIND_LEAD_CUT, feet_rows
from quadsim.locomotion.body import MAX_FOOTING
from quadsim.locomotion.footpath import swing_position as compiled_swing_position
from quadsim.locomotion.plan_kernels import step_constants
from quadsim.locomotion.pose_kernel import pack_plan
from quadsim.locomotion.posing import Poser
from quadsim.locomotion.rowmath import MIN_SWING, interp1
from quadsim.locomotion.turning import arc_advance as compiled_arc_advance
from quadsim.locomotion.turning import rotate_y
from quadsim.skeleton.character import load_character
from quadsim.skeleton.fk import forward_kinematics

TOL = 1e-12


@njit
def _feet_stage(state, scratch, reach, sc, out):
    """The feet stage called as the plan calls it (it has no Python entry)."""
    feet_rows(state, scratch, reach, sc, out)


def test_interp_equals_numpy_inside_at_knots_and_beyond_the_ends():
    xp = [0.0, 0.1, 0.1, 0.25, 0.4, 0.4, 0.7]  # non-decreasing, with flat steps
    fp = [0.0, 0.3, 0.35, 0.5, 0.9, 1.2, 1.3]
    xs = [-1.0, 0.0, 0.05, 0.1, 0.2, 0.25, 0.39, 0.4, 0.55, 0.7, 2.0]
    xs += list(np.random.default_rng(0).uniform(-0.1, 0.8, 50))
    xp, fp = np.array(xp), np.array(fp)
    for x in xs:
        assert interp1(x, xp, fp) == pytest.approx(float(np.interp(x, xp, fp)), abs=TOL), x


def test_compiled_cpg_step_equals_the_array_network():
    rng = np.random.default_rng(3)
    p = CPGParams()
    n = 20
    theta, r = rng.uniform(0, 30, (n, 4)), rng.uniform(0.0, 1.5, (n, 4))
    r[rng.uniform(size=n) < 0.3, rng.integers(0, 4)] = 0.0  # the fixed point
    ts, rs = rng.uniform(0, 30, n), rng.uniform(0.1, 1.5, n)
    rs[0] = 0.0
    omega, psi = rng.uniform(3, 20, n), rng.uniform(0, 1, (n, 4))
    a = cpg_step(theta, r, ts, rs, omega, psi, 1 / 60, p)
    for x, y in zip(a, compiled_cpg_step(theta, r, ts, rs, omega, psi, 1 / 60, p)):
        np.testing.assert_allclose(y, x, atol=TOL)
    b = cpg_step_rows(theta, r, ts, rs, omega, psi, 1 / 60, p.mu, p.gain, p.coupling,
                      p.spine_coupling, p.substeps)
    for x, y in zip(a, b):
        np.testing.assert_allclose(y, x, atol=TOL)
    # one row at a time (a lone controller's call) is the same as the batch
    for i in (0, 7):
        one = cpg_step_rows(theta[i:i + 1], r[i:i + 1], ts[i:i + 1], rs[i:i + 1],
                            omega[i:i + 1], psi[i:i + 1], 1 / 60, p.mu, p.gain, p.coupling,
                            p.spine_coupling, p.substeps)
        for x, y in zip(b, one):
            np.testing.assert_array_equal(y[0], x[i])


@pytest.mark.parametrize("yaw_rate", [0.0, 1e-9, 0.4, -1.3])
def test_compiled_feet_stage_follows_the_arc_and_the_swing_spline(yaw_rate):
    """feet.feet_rows against the oracles' arc and swing spline and rotate_y:
    swinging feet at progress from 0 to past 1
    (touchdown on the target), and a planted foot due to lift off."""
    rng = np.random.default_rng(5)
    n = 9
    theta = rng.uniform(20, 40, (n, 4))
    theta_lo = theta - rng.uniform(0.5, 3.0, (n, 4))
    theta_td = theta + np.linspace(-0.5, 3.0, n)[:, None] + rng.uniform(0, 0.2, (n, 4))
    theta_td = np.maximum(theta_td, theta_lo + 0.1)
    duty, final = rng.uniform(0.4, 0.7, n), rng.uniform(0.4, 0.7, n)
    duty[1] = 0.575  # between the slow path and the walk's
    freq, v = rng.uniform(1, 3, n), rng.uniform(0.5, 5, n)
    w = np.full(n, yaw_rate)
    keys = rng.normal(0, 1, (n, 2, 3))
    kh = rng.uniform(-3, 3, (n, 2))
    offset = rng.normal(0, 0.2, (n, 4, 3))
    swing_h, half = rng.uniform(0.05, 0.2, n), rng.uniform(0.1, 0.4, n)
    stance = np.zeros((n, 4), dtype=bool)
    stance[0, 0] = True  # planted, stride fraction past the duty factor: lifts off
    theta[0, 0] = 2 * np.pi * (5 + 0.5 * (duty[0] + 1 - MIN_SWING))
    theta_td[0, 0] = theta[0, 0] - 1.0
    planted = rng.normal(0, 1, (n, 4, 3))
    liftoff = rng.normal(0, 1, (n, 4, 3))
    swing_s = np.zeros((n, 4))
    feet_state = B.FeetState(*(x.copy() for x in (stance, swing_s, theta_lo, theta_td, planted,
                                                   liftoff)), np.zeros((n, 4)), np.zeros((n, 4)),
                            np.zeros((n, 4)), np.ones((n, 4)))
    z, z4 = np.zeros(n), np.zeros((n, 4))
    bound = np.where(np.arange(n) % 3 == 0, 0.0, rng.uniform(0, 1, n))  # some bounding
    params = B.GaitRows(duty.copy(), z4, z, z, swing_h.copy(), z, bound.copy(), z)
    state = B.PlanState(
        B.MotionState(v.copy(), w.copy(), z, np.zeros((n, 3)), z),
        B.CpgState(theta.copy(), z4, z, z, freq.copy()),
        B.ScheduleState(np.zeros(n, np.int64), np.zeros(n, np.int64), np.zeros(n, bool), z, z,
                        params, params),
        feet_state, B.BodyState(z, z, np.zeros((n, 2)), z, np.zeros((n, 0, 2)),
                                np.zeros((n, 2)), np.zeros((n, 2)), z.copy(), np.zeros((n, 2)),
                                np.full(n, MAX_FOOTING), np.full((n, 2), np.inf),
                                np.zeros((n, 2)), z.copy()))
    scratch = B.step_scratch(n)._replace(theta_prev=theta - 0.1, keys=keys, key_heading=kh,
                                         final_duty=final, trailing=np.zeros((n, 4), bool),
                                         half_min=half)
    reach = B.ReachTables(np.zeros(2), np.zeros((n, 2, 4)), np.zeros((n, 2)),
                          np.zeros((n, 4, 2)), offset, np.zeros((n, 4)), np.zeros((n, 4)),
                          np.full((n, 4), np.inf), np.zeros((n, 4)), np.zeros((n, 4, 2)),
                          np.zeros((n, 4)))  # no toe tips: the feet do not roll
    out = B.plan_outputs(n)
    _feet_stage(state, scratch, reach, step_constants(ControllerSettings(), 1 / 60), out)
    feet, fold = out.feet, out.fold
    st, ss, lo, td, pl, lf = feet_state[:6]
    assert not st[0, 0] and lo[0, 0] <= theta[0, 0] < td[0, 0]
    np.testing.assert_array_equal(lf[0, 0], planted[0, 0])
    # the expected targets and swing positions, from the array functions
    s = np.clip((theta - lo) / (td - lo), 0.0, 1.0)
    np.testing.assert_allclose(ss, s, atol=TOL)
    stance_time = np.maximum(duty, np.minimum(final, 1 - MIN_SWING)) / freq
    lead = np.minimum(0.5 * stance_time, 0.85 * half / np.maximum(v, 1e-6))
    # the time to touchdown at each leg's own phase rate this step (at least half the
    # clock's)
    rate = np.maximum((theta - (theta - 0.1)) * 60, 0.5 * 2 * np.pi * freq[:, None])
    # (in the bounding gaits a hind foot's touchdown point a little further back)
    girdle = np.array([1, 1, 0, 0])
    quick = np.clip((0.6 - duty) / 0.2, 0.0, 1.0)
    back = HIND_LEAD_CUT * (quick * bound * stance_time)[:, None] * (girdle == 0)
    assert (back > 0).any()
    tau = np.maximum((td - theta) / rate + lead[:, None] - back + 0.5 / 60, 0)
    kp, kh_new = arc_advance(keys[:, girdle], kh[:, girdle], v[:, None], w[:, None], tau)
    target = kp + rotate_y(offset, kh_new)
    target[..., 1] = 0.0
    step = np.linalg.norm(target - lf, axis=-1)
    # the clearance over the ground: a lift-off point's height (a rolled heel's) is not added
    height = np.maximum(np.minimum(swing_h[:, None], 0.35 * step + 0.3 * swing_h[:, None])
                        - 0.5 * lf[..., 1], 0.0)
    # the fast gaits' path from a duty factor of 0.6 down to 0.4, the walk's from
    # 0.55 up to 0.6 (the duties span both), the fast share split between the fast
    # and the bounding gaits' paths by the bound
    fast, bounding = (quick * (1 - bound))[:, None], (quick * bound)[:, None]
    walk = np.clip((duty - 0.55) / 0.05, 0.0, 1.0)[:, None]
    assert (fast == 0).any() and ((fast > 0) & (fast < 1)).any() and (bounding > 0).any()
    assert (walk == 0).any() and (walk == 1).any() and ((walk > 0) & (walk < 1)).any()
    want = swing_position(lf, target, height, s, fast, walk, bounding)
    np.testing.assert_allclose(compiled_swing_position(lf, target, height, s, fast, walk,
                                                       bounding), want, atol=TOL)
    kp2, kh2 = compiled_arc_advance(keys[:, girdle], kh[:, girdle], v[:, None], w[:, None], tau)
    np.testing.assert_allclose(kp2, kp, atol=1e-9)
    np.testing.assert_allclose(kh2, kh_new, atol=TOL)
    down = s >= 1 - 1e-12
    assert down.any() and (~down).any() and (s == 0).any()
    np.testing.assert_allclose(feet[~down], want[~down], atol=TOL)
    np.testing.assert_allclose(fold[~down], np.sin(np.pi * s[~down] ** FOLD_SKEW) ** 2, atol=TOL)
    np.testing.assert_allclose(feet[down], target[down], atol=TOL)
    np.testing.assert_allclose(pl[down], target[down], atol=TOL)
    assert st[down].all() and not st[~down].any() and (fold[down] == 0).all()
    # the spline's ends: the lift-off point, and the target
    np.testing.assert_allclose(swing_position(lf, target, height, 0.0), lf, atol=TOL)
    np.testing.assert_allclose(swing_position(lf, target, height, 1.0), target, atol=TOL)


def _random_plan(ch, rng, T):
    """T random plans near the rest pose: feet reachable and unreachable."""
    feet = ch.rest_foot_positions() + rng.normal(0, 0.3 * ch.hip_height, (T, 4, 3))
    return {"root": ch.skeleton.rest_positions[0] * rng.uniform(0.9, 1.0, (T, 1))
            + rng.normal(0, 0.05, (T, 3)),
            "heading": rng.uniform(-3, 3, T), "pitch": rng.normal(0, 0.05, T),
            "sway": rng.normal(0, 0.03, (T, 2)), "bend_yaw": rng.normal(0, 0.2, T),
            "bend_pitch": rng.normal(0, 0.1, T), "feet": feet, "fold": rng.uniform(0, 1, (T, 4)),
            "toe": rng.uniform(0, 0.3, (T, 4)), "load": rng.uniform(0, 2, (T, 4)),
            "tail": rng.normal(0, 0.1, (T, len(ch.tail), 2)),
            "look": rng.normal(0, 0.1, T)}


def _reference_pose(ch, poser, plan):
    """The posing written with the array functions: matrices_yaw_pitch,
    forward_kinematics and the oracle's solve_leg, leg by leg."""
    sk = ch.skeleton
    T, J = len(plan["root"]), sk.n_joints
    L = np.broadcast_to(np.eye(3), (T, J, 3, 3)).copy()
    flex, sway = plan["bend_pitch"], plan["sway"]
    L[:, 0] = matrices_yaw_pitch(plan["heading"] + sway[:, 0], plan["pitch"] - 0.5 * flex)
    spine = ch.spine[1:]
    K = len(spine)
    yaw = plan["bend_yaw"][:, None] / K * np.ones(K)
    yaw[:, 0] -= sway[:, 0]
    yaw[:, -1] += sway[:, 1]
    L[:, spine] = matrices_yaw_pitch(yaw, flex[:, None] / K * np.ones(K))
    L[:, ch.tail] = matrices_yaw_pitch(plan["tail"][..., 1], plan["tail"][..., 0])
    G, _ = forward_kinematics(sk, L, plan["root"])
    pitch = np.arcsin(np.clip(-G[:, ch.spine[-1], 1, 2], -1, 1))
    n = len(ch.neck)
    # the nod: half the fore legs' support (1 - fold) less the hind legs', scaled
    support = 1.0 - plan["fold"]
    nod = 0.5 * math.radians(ch.locomotion.get("head_nod_deg", 0.0)) * (
        support[:, :2].sum(axis=1) - support[:, 2:].sum(axis=1))
    L[:, ch.neck] = matrices_yaw_pitch(plan["look"][:, None] / n * np.ones(n),
                                       (nod - pitch)[:, None] / n * np.ones(n))
    G, P = forward_kinematics(sk, L, plan["root"])
    err = np.zeros((T, 4))
    for i, geom in enumerate(poser.legs):
        # the world yaw each foot keeps: its landing heading while planted
        yaw = plan["foot_yaw"][:, i] if "foot_yaw" in plan else \
            plan["heading"] + (plan["bend_yaw"] if i < 2 else 0.0)
        L[:, geom.chain], err[:, i] = solve_leg(geom, G[:, geom.parent], P[:, geom.parent],
                                                plan["feet"][:, i], plan["fold"][:, i],
                                                plan["toe"][:, i], foot_yaw=yaw,
                                                load=plan["load"][:, i])
    _, P = forward_kinematics(sk, L, plan["root"])
    return L, P, err


@pytest.mark.parametrize("name", ["leopard", "dog_cub", "horse"])
def test_compiled_posing_equals_the_array_functions(name):
    """The compiled kernel (Poser.pose, pose_packed) against the
    posing recomputed with solve_leg and forward_kinematics, which
    tests/test_ik.py and tests/test_fk.py check against known poses."""
    rng = np.random.default_rng(8)
    ch = load_character(name)
    poser = Poser.for_character(ch)
    plan = _random_plan(ch, rng, 40)
    L, P, err = _reference_pose(ch, poser, plan)
    assert np.any(err > 1e-3) and np.any(err == 0)  # unreachable and reachable targets
    local, root, err1 = poser.pose(plan)
    np.testing.assert_allclose(local, L, atol=TOL)
    np.testing.assert_allclose(root, plan["root"], atol=0)
    np.testing.assert_allclose(err1, err, atol=TOL)
    local2, P2, _ = poser.pose_packed(pack_plan(plan, len(ch.tail)))
    np.testing.assert_array_equal(local2, local)
    np.testing.assert_allclose(P2, P, atol=TOL)
    with pytest.raises(ValueError, match="rows"):  # too few columns for the tail
        poser.pose_packed(pack_plan(plan, len(ch.tail))[:, :-1])
    # the interactive step's one-frame way: the same pose, in arrays of its own
    packed = pack_plan(plan, len(ch.tail))
    for t in (0, 17, 39):
        local3, P3, err3 = poser.pose_row(np.ascontiguousarray(packed[t:t + 1]))
        np.testing.assert_array_equal(local3, local2[t])
        np.testing.assert_array_equal(P3, P2[t])
        np.testing.assert_allclose(err3, err[t], atol=TOL)
        assert local3.flags.owndata and P3.flags.owndata and err3.flags.owndata
