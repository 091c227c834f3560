"""The fast paths compute what the straightforward ones do.

Interactive stepping (one frame posed at a time, ``step(pose=True)``) and
offline :func:`simulate` (plans first, all frames posed at once) must give
the same motion; the IK of stacked legs must equal each leg solved alone;
the CPG on a batch must equal each oscillator network alone.
"""

import warnings

import numpy as np
import pytest
from oracles import solve_leg as oracle_solve_leg

from quadsim.commands import Command, Script
from quadsim.kinematics.ik import leg_geometry, solve_leg
from quadsim.kinematics.rotations import quaternions_from_matrices
from quadsim.locomotion.controller import ProceduralController
from quadsim.locomotion.cpg import cpg_step
from quadsim.locomotion.gaits import max_speed
from quadsim.locomotion.offline import simulate
from quadsim.skeleton.character import load_character

CHARACTERS = ("leopard", "leopard_cub", "dog_cub", "horse")
TOL = 1e-9


def _tour(character) -> Script:
    """Start, walk, run, turn both ways, a requested gait, stop."""
    top = max_speed(character)
    return Script((0.0, 1.0, 2.0, 3.0, 4.0, 5.0),
                  (Command(speed=0.15 * top), Command(speed=0.5 * top, turn_rate=0.5),
                   Command(speed=0.8 * top, heading=-0.6), Command(speed=0.3 * top, gait="trot"),
                   Command(speed=0.2 * top, turn_rate=-0.4), Command(speed=0.0)))


@pytest.mark.parametrize("name", CHARACTERS)
def test_step_by_step_equals_simulate(name):
    ch = load_character(name)
    script, fps, seconds = _tour(ch), 60.0, 6.0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        motion = simulate(ch, script, seconds, fps, seed=3)
        dt = 1.0 / fps
        ctl = ProceduralController(ch, dt=dt, seed=3, gait=script.commands[0].gait)
        frames = [ctl.step(script.commands[0], 0.0)]
        frames += [ctl.step(script.command_at((k - 1) * dt), dt)
                   for k in range(1, motion.n_frames)]
    local = np.stack([f.local_rotations for f in frames])
    np.testing.assert_allclose(quaternions_from_matrices(local), motion.rotations, atol=TOL)
    np.testing.assert_allclose(np.stack([f.root for f in frames]), motion.root_positions,
                               atol=TOL)
    np.testing.assert_allclose(np.stack([f.positions for f in frames]),
                               motion.world_positions(), atol=1e-8)
    np.testing.assert_array_equal(np.stack([f.contacts for f in frames]), motion.contacts)
    for key in ("phase", "ik_error", "spine", "duty", "speed", "heading", "cpg_amplitude"):
        np.testing.assert_allclose(np.stack([f.extras[key] for f in frames]), motion.extras[key],
                                   atol=TOL, err_msg=key)
    assert [f.gait for f in frames] == list(motion.gaits)
    np.testing.assert_allclose([f.time for f in frames], np.arange(motion.n_frames) / fps,
                               atol=1e-9)


@pytest.mark.parametrize("name", CHARACTERS)
def test_compiled_leg_ik_equals_the_array_oracle(name):
    """solve_leg (the posing's compiled leg IK) against the array IK of
    tests/oracles.py: tilted parents, reachable and unreachable targets,
    swing fold and toe pitch, every leg."""
    rng = np.random.default_rng(11)
    ch = load_character(name)
    rest = ch.skeleton.rest_positions
    T = 60
    for leg in ch.legs:
        geom = leg_geometry(ch, leg)
        R = np.stack([_rot(a) for a in rng.normal(0.0, 0.2, (T, 3))])
        parent = rest[geom.parent] + rng.normal(0.0, 0.02, (T, 3))
        targets = rest[leg.foot] + rng.normal(0.0, 0.3 * ch.hip_height, (T, 3))
        fold, toe = rng.uniform(0, 1, T), rng.normal(0, 0.2, T)
        local, reached = solve_leg(geom, R, parent, targets, fold, toe)
        want_local, want_reached = oracle_solve_leg(geom, R, parent, targets, fold, toe)
        assert np.any(want_reached > 1e-3) and np.any(want_reached == 0)
        np.testing.assert_allclose(local, want_local, atol=1e-12)
        np.testing.assert_allclose(reached, want_reached, atol=1e-12)
        # one target alone is the same as in the batch
        one, r1 = solve_leg(geom, R[5], parent[5], targets[5], fold[5], toe[5])
        np.testing.assert_array_equal(one, local[5])
        assert r1 == reached[5]


def _rot(a):
    cx, sx = np.cos(a[0]), np.sin(a[0])
    cy, sy = np.cos(a[1]), np.sin(a[1])
    Rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    Ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    return Ry @ Rx


def test_cpg_batch_equals_each_network_alone():
    rng = np.random.default_rng(5)
    N = 6
    theta = rng.uniform(0, 20, (N, 4))
    r = rng.uniform(0.2, 1.5, (N, 4))
    theta_s, r_s = rng.uniform(0, 20, N), rng.uniform(0.2, 1.5, N)
    omega, psi = rng.uniform(3, 20, N), rng.uniform(0, 1, (N, 4))
    out = cpg_step(theta, r, theta_s, r_s, omega, psi, 1 / 60)
    for n in range(N):
        one = cpg_step(theta[n], r[n], theta_s[n], r_s[n], omega[n], psi[n], 1 / 60)
        for a, b in zip(out, one):
            np.testing.assert_allclose(a[n], b, atol=1e-12)
