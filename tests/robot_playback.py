"""Play a robot reference kinematically in PyBullet and measure it (a test helper).

Each frame sets the base pose (``resetBasePositionAndOrientation``) and every
joint (``resetJointState``), then reads the toes (``getLinkState``), their
distance to the ground plane (``getClosestPoints``: negative is sinking) and the
distances between the robot's own links (``getClosestPoints`` of the body with
itself), leaving out adjacent links (parent and child) and pairs that already
touch at zero joint angles (overlaps built into the model).
"""

from __future__ import annotations

import numpy as np


def _links(p, robot):
    names, parents = {}, {}
    for i in range(p.getNumJoints(robot)):
        info = p.getJointInfo(robot, i)
        names[info[12].decode()] = i
        parents[i] = info[16]
    names[p.getBodyInfo(robot)[0].decode()] = -1
    return names, parents


def _pairs(p, robot, parents):
    """Pairs to check: not parent and child, nor a link and its grandparent through a hip
    motor (the thigh and the trunk), nor touching at zero joint angles."""
    n = p.getNumJoints(robot)
    out = []
    for a in range(-1, n):
        for b in range(a + 1, n):
            if parents.get(b) == a or parents.get(a) == b:
                continue
            if parents.get(parents.get(b, -2), -2) == a:
                continue
            out.append((a, b))
    touching = {pair for pair in out
                if p.getClosestPoints(robot, robot, 0.0, linkIndexA=pair[0],
                                      linkIndexB=pair[1])}
    return [pair for pair in out if pair not in touching], sorted(touching)


def _set(p, robot, ref, t, index):
    # PyBullet places a body by its base's inertial frame; the reference gives the link frame
    local_pos, local_orn = p.getDynamicsInfo(robot, -1)[3:5]
    pos, orn = p.multiplyTransforms(ref["base_position"][t].tolist(),
                                    ref["base_quaternion"][t].tolist(), local_pos, local_orn)
    p.resetBasePositionAndOrientation(robot, pos, orn)
    for name, q in zip(ref["joint_names"], ref["joint_angles"][t]):
        p.resetJointState(robot, index[name], float(q))


def play(urdf: str, ref: dict, *, collision_every: int = 3) -> dict:
    """Figures of ``ref`` (a dict of the NPZ's arrays) played on ``urdf`` in PyBullet.

    Returns
    -------
    dict
        ``toes`` (T, 4, 3) toe link positions; ``ground`` (T, 4) toe distance to the
        plane (m, negative: sinking); ``self_contacts`` list of (frame, link a, link
        b, distance); ``limits`` (J, 2) PyBullet's own joint limits; ``excluded``
        link pairs touching at zero angles.
    """
    import pybullet as p
    import pybullet_data

    cid = p.connect(p.DIRECT)
    try:
        p.setAdditionalSearchPath(pybullet_data.getDataPath(), physicsClientId=cid)
        plane = p.loadURDF("plane.urdf", physicsClientId=cid)
        robot = p.loadURDF(urdf, [0, 0, 2], useFixedBase=False, physicsClientId=cid)
        links, parents = _links(p, robot)
        index = {p.getJointInfo(robot, i)[1].decode(): i for i in range(p.getNumJoints(robot))}
        limits = np.array([p.getJointInfo(robot, index[n])[8:10] for n in ref["joint_names"]])
        pairs, excluded = _pairs(p, robot, parents)
        toes = [links[str(n)] for n in ref["foot_links"]]
        T = len(ref["joint_angles"])
        pos = np.empty((T, 4, 3))
        ground = np.empty((T, 4))
        contacts = []
        for t in range(T):
            _set(p, robot, ref, t, index)
            for k, link in enumerate(toes):
                pos[t, k] = p.getLinkState(robot, link, computeForwardKinematics=True)[4]
                near = p.getClosestPoints(robot, plane, 0.5, linkIndexA=link)
                ground[t, k] = min(c[8] for c in near) if near else np.inf
            if t % collision_every == 0:
                for a, b in pairs:
                    for c in p.getClosestPoints(robot, robot, 0.0, linkIndexA=a, linkIndexB=b):
                        contacts.append((t, a, b, c[8]))
        return {"toes": pos, "ground": ground, "self_contacts": contacts, "limits": limits,
                "excluded": excluded}
    finally:
        p.disconnect(cid)


def figures(ref: dict, played: dict) -> dict:
    """The done-when figures of a played reference (lengths in m)."""
    toes, ground, c = played["toes"], played["ground"], np.asarray(ref["contacts"], bool)
    slides = []
    for k in range(4):
        edges = np.flatnonzero(np.diff(np.r_[0, c[:, k].astype(int), 0]))
        for s0, s1 in zip(edges[::2], edges[1::2]):
            d = np.linalg.norm(toes[s0:s1, k, :2] - toes[s0, k, :2], axis=1)
            slides.append(d.max())
    q, lim = ref["joint_angles"], played["limits"]
    bounded = lim[:, 0] < lim[:, 1]
    margin = np.minimum(q - lim[:, 0], lim[:, 1] - q)[:, bounded]
    planted = ground[c] if c.any() else np.array([np.nan])
    measured = ground < 0.005
    return {"lowest_toe_max": float(ground.min(axis=1).max()),
            "lowest_toe_min": float(ground.min(axis=1).min()),
            "sink_max": float(max(0.0, -ground.min())),
            "planted_gap_max": float(np.abs(planted).max()),
            "slide_p90": float(np.percentile(slides, 90)) if slides else 0.0,
            "slide_max": float(max(slides)) if slides else 0.0,
            "diagonal_agreement": float(min(np.mean(measured[:, 0] == measured[:, 3]),
                                            np.mean(measured[:, 1] == measured[:, 2]))),
            "limit_margin_min": float(margin.min()) if margin.size else float("inf"),
            "self_collisions": len(played["self_contacts"]),
            "forward_travel": float(ref["base_position"][-1, 0] - ref["base_position"][0, 0]),
            "lateral_drift": float(abs(ref["base_position"][-1, 1] - ref["base_position"][0, 1]))}
