"""Long mocap-like takes built from quadsim's own procedural motion, for `quadsim clips-from`.

:func:`take` simulates a character through a plan of (gait, speed) segments
(gait changes between them) and returns the clean motion; :func:`noisy` adds
small per-frame joint-angle and root jitter; :func:`on_other_skeleton` puts
the motion on a bigger skeleton with extra (face, helper) joints, which a
take read onto the character by joint name must undo; :func:`write_take`
writes either as BVH.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from quadsim.commands import Command, Script
from quadsim.io.bvh import write_bvh
from quadsim.kinematics.rotations import quaternion_multiply
from quadsim.locomotion.offline import simulate
from quadsim.skeleton.motion import Motion
from quadsim.skeleton.skeleton import Skeleton

FPS = 60.0
#: Seconds each (gait, speed) segment of a take is held.
SEGMENT = 4.0


def take(character, plan, segment: float = SEGMENT, fps: float = FPS) -> Motion:
    """The procedural motion through ``plan`` [(gait, speed m/s), ...], ``segment`` s each,
    its feet kept flat through the stance (``[locomotion] toe_roll_deg`` off, as the horse's
    clips are baked): `clips-from` finds a take's contacts at the foot joints, which a paw
    rolling over its toes lifts through the last part of its stance (a walk was then not
    found)."""
    character = replace(character, locomotion=replace(character.locomotion, toe_roll_deg=None))
    script = Script(tuple(segment * i for i in range(len(plan))),
                    tuple(Command(speed=v, gait=g) for g, v in plan))
    return simulate(character, script, segment * len(plan), fps)


def noisy(motion: Motion, deg: float = 0.2, root: float = 0.001, seed: int = 0) -> Motion:
    """``motion`` with every joint turned by a random small rotation per frame (Gaussian,
    ``deg`` degrees rms about a random axis) and the root moved by ``root`` m rms."""
    rng = np.random.default_rng(seed)
    T, J = motion.rotations.shape[:2]
    axis = rng.normal(size=(T, J, 3))
    axis /= np.linalg.norm(axis, axis=-1, keepdims=True)
    ang = np.radians(deg) * rng.normal(size=(T, J, 1))
    dq = np.concatenate([np.cos(ang / 2), axis * np.sin(ang / 2)], axis=-1)
    rot = quaternion_multiply(motion.rotations, dq)
    pos = motion.root_positions + root * rng.normal(size=(T, 3))
    return Motion(motion.skeleton, motion.fps, pos, rot, foot_joints=motion.foot_joints)


def on_other_skeleton(motion: Motion, scale: float = 1.1) -> Motion:
    """The motion on a skeleton ``scale`` times bigger with extra joints (a jaw, two
    ears, a breast helper, a dew claw on each fore foot), the root's path scaled too."""
    sk = motion.skeleton
    names, parents = list(sk.names), list(sk.parents)
    offsets = [tuple(o * scale) for o in sk.offsets]
    head = next(n for n in names if "head" in n.lower())
    extra = [("jaw", head, (0.0, -0.02, 0.04)), ("ear_L", head, (0.02, 0.03, -0.01)),
             ("ear_R", head, (-0.02, 0.03, -0.01)), ("breast_helper", names[0], (0.0, -0.05, 0.1))]
    for leg, foot in zip(("LF", "RF"), motion.foot_joints[:2]):
        extra.append((f"{leg}_dewclaw", foot, (0.0, 0.01, -0.01)))
    for n, p, o in extra:
        names.append(n)
        parents.append(names.index(p))
        offsets.append(o)
    other = Skeleton(tuple(names), np.array(parents), np.array(offsets))
    T = len(motion)
    rot = np.zeros((T, len(names), 4))
    rot[..., 0] = 1.0
    rot[:, :sk.n_joints] = motion.rotations
    return Motion(other, motion.fps, motion.root_positions * scale, rot,
                  foot_joints=motion.foot_joints)


def write_take(motion: Motion, path, units: str = "m"):
    """Write a take as BVH (``units`` "m" or "cm")."""
    return write_bvh(motion, path, units=units, precision=6)
