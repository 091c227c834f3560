"""An animal's motion carried onto a legged robot: scaled, footed, solved within limits.

Dynamic similarity sets the scale: with ``s = h_robot / h_animal`` (hip heights),
lengths are multiplied by ``s`` and times by ``sqrt(s)``, so the Froude number
``v^2 / (g h)`` is kept and ``v_robot = v_animal * sqrt(s)`` -- the caller runs
the animal at ``fps * sqrt(s)`` frames per second to get frames ``1 / fps`` apart
in robot time (:func:`froude_scale`). The robot's hip height is
``height_ratio`` times its leg's length (hip to knee to foot).

* **Trunk.** The robot's hip midpoint follows the animal's trunk midpoint (pelvis
  and front girdle), its path scaled by ``s * k`` and its height by the robot's
  stance height over the animal's; heading, pitch and roll are the animal's
  trunk's, less their rest values.
* **Feet.** Each foot follows the animal's foot about the robot's own nominal
  stance point (under its hip, at the foot's lateral offset at zero angles), its
  excursions scaled by ``s * k``, its swing height by ``s``; the foot point rests
  one foot radius above the ground while the animal's foot is planted, and is
  pinned there for the whole stance.
* **Legs.** Damped least-squares IK per leg, all frames at once, from a seed
  with the knee behind the hip-foot line that the limits allow; no joint leaves
  its limits. When a foot cannot be reached the stride factor ``k`` is lowered
  (the speed with it) until it can; what still cannot is reported.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from quadsim.errors import InputError
from quadsim.kinematics.rotations import quaternions_from_matrices
from quadsim.robots.legs import RobotLegs

__all__ = ["Nominal", "Retargeted", "froude_scale", "nominal_stance", "retarget"]

#: Largest distance (m) between a foot and its target that counts as reached.
REACH_TOLERANCE = 1e-3
#: Room (m) kept between two legs' lower segments (their centre lines) beyond two foot
#: radii, for the links' thickness.
CLEARANCE = 0.02


def _urdf(v: np.ndarray) -> np.ndarray:
    """quadsim's frame (+Y up, +Z forward, +X left) to the URDF's (+Z up, +X forward, +Y left)."""
    return np.asarray(v)[..., [2, 0, 1]]


@dataclass(frozen=True, eq=False)
class Nominal:
    """A robot's stance: where its feet stand, how high its hips are.

    Attributes
    ----------
    hip_height : float
        Hip joints above the foot points (m).
    leg_length : float
        Mean hip-to-foot length along the leg's segments (m).
    mid : ndarray, shape (3,)
        Mean of the hips, body frame (m).
    feet : ndarray, shape (4, 3)
        Nominal foot points, body frame (m).
    seeds : tuple of ndarray
        Per leg, the joint angles that reach its nominal foot point.
    """

    hip_height: float
    leg_length: float
    mid: np.ndarray
    feet: np.ndarray
    seeds: tuple


def _leg_length(leg) -> float:
    T, foot = leg.frames(np.zeros((1, leg.n)))
    pts = [T[0, i, :3, 3] for i in range(max(leg.n - 2, 0), leg.n)] + [foot[0]]
    return float(sum(np.linalg.norm(b - a) for a, b in zip(pts, pts[1:])))


def _seed(leg, target_b: np.ndarray, body: np.ndarray) -> np.ndarray | None:
    """Joint angles reaching ``target_b`` (base frame), knee behind when it can be."""
    grid = np.array(np.meshgrid(*[np.linspace(-1.5, 1.5, 5)] * leg.n)).reshape(leg.n, -1).T
    lo = np.where(np.isfinite(leg.lower), leg.lower, -np.pi)
    hi = np.where(np.isfinite(leg.upper), leg.upper, np.pi)
    grid = np.concatenate([grid, ((lo + hi) / 2)[None]])
    q, res = leg.solve(np.broadcast_to(target_b, (len(grid), 3)), grid, iterations=80)
    ok = res < 1e-5
    if not ok.any():
        return None
    T, foot = leg.frames(q)
    knee = T[:, leg.n - 1, :3, 3] @ body
    hip = T[:, max(leg.n - 2, 0), :3, 3] @ body
    behind = knee[:, 0] < (hip[:, 0] + (foot @ body)[:, 0]) / 2 - 1e-4
    pick = ok & behind if (ok & behind).any() else ok
    cost = np.where(pick, np.sum(q ** 2, axis=1), np.inf)
    return q[int(np.argmin(cost))]


def nominal_stance(robot: RobotLegs, height_ratio: float = 0.75) -> Nominal:
    """The robot's standing pose: hips ``height_ratio`` of a leg's length above the feet.

    A lower stance is taken (down to half a leg) when a leg cannot reach that one.
    """
    B = robot.body
    hips = robot.hips() @ B
    zero_feet = np.array([leg.frames(np.zeros((1, leg.n)))[1][0] for leg in robot.legs]) @ B
    length = float(np.mean([_leg_length(leg) for leg in robot.legs]))
    mid = hips.mean(axis=0)
    for ratio in np.arange(height_ratio, 0.45, -0.05):
        h = ratio * length
        feet = np.column_stack([hips[:, 0], zero_feet[:, 1], np.full(4, mid[2] - h)])
        seeds = [_seed(leg, B @ f, B) for leg, f in zip(robot.legs, feet)]
        if all(s is not None for s in seeds):
            return Nominal(float(h), length, mid, feet, tuple(seeds))
    raise InputError(f"{robot.urdf.label}: no leg reaches a standing "
                     "pose below its hip within the joint limits; check the limits")


def froude_scale(character, nominal: Nominal) -> float:
    """``s = h_robot / h_animal``, the length scale of the robot to the animal."""
    return nominal.hip_height / float(character.hip_height)


@dataclass(frozen=True, eq=False)
class Retargeted:
    """A robot's reference motion in the URDF's world frame (+Z up).

    Attributes
    ----------
    fps : float
    joint_names : tuple of str
    base_position : ndarray, shape (T, 3)
        The base link's origin (m).
    base_quaternion : ndarray, shape (T, 4)
        Its orientation, ``(x, y, z, w)``.
    joint_angles : ndarray, shape (T, J)
        In ``joint_names`` order (rad, m).
    foot_links : tuple of str
        The four foot links, leg order LF, RF, LH, RH.
    foot_positions, foot_velocities : ndarray, shape (T, 4, 3)
        Foot points (m, m/s), leg order.
    foot_radius : ndarray, shape (4,)
    contacts : ndarray of bool, shape (T, 4)
    gaits : ndarray of str, shape (T,)
    info : dict
        Scale, stride factor, speeds, reach residual, joint-limit margin, leg clearance.
    """

    fps: float
    joint_names: tuple[str, ...]
    base_position: np.ndarray
    base_quaternion: np.ndarray
    joint_angles: np.ndarray
    foot_links: tuple[str, ...]
    foot_positions: np.ndarray
    foot_velocities: np.ndarray
    foot_radius: np.ndarray
    contacts: np.ndarray
    gaits: np.ndarray
    info: dict = field(default_factory=dict)

    @property
    def n_frames(self) -> int:
        return len(self.joint_angles)


def _rot_z(a):
    c, s = np.cos(a), np.sin(a)
    R = np.zeros(np.shape(a) + (3, 3))
    R[..., 0, 0], R[..., 0, 1], R[..., 1, 0], R[..., 1, 1], R[..., 2, 2] = c, -s, s, c, 1
    return R


def _rot_y(a):
    c, s = np.cos(a), np.sin(a)
    R = np.zeros(np.shape(a) + (3, 3))
    R[..., 0, 0], R[..., 0, 2], R[..., 2, 0], R[..., 2, 2], R[..., 1, 1] = c, s, -s, c, 1
    return R


def _rot_x(a):
    c, s = np.cos(a), np.sin(a)
    R = np.zeros(np.shape(a) + (3, 3))
    R[..., 1, 1], R[..., 1, 2], R[..., 2, 1], R[..., 2, 2], R[..., 0, 0] = c, -s, s, c, 1
    return R


@dataclass(frozen=True, eq=False)
class _Trunk:
    """The animal's trunk in URDF axes: midpoint (T, 3), heading, pitch, roll (T,)."""

    mid: np.ndarray
    yaw: np.ndarray
    pitch: np.ndarray
    roll: np.ndarray
    rest_mid: np.ndarray


def _trunk(motion, character) -> _Trunk:
    P = _urdf(motion.world_positions())
    R = _urdf(character.skeleton.rest_positions)
    a, b = character.spine[0], character.spine[-1]
    lt, rt = character.legs[2].top, character.legs[3].top

    def angles(Pa, Pb, Pl, Pr):
        d = Pb - Pa
        yaw = np.arctan2(d[..., 1], d[..., 0])
        pitch = np.arctan2(d[..., 2], np.hypot(d[..., 0], d[..., 1]))
        w = Pl - Pr
        lat = -np.sin(yaw) * w[..., 0] + np.cos(yaw) * w[..., 1]
        return yaw, pitch, np.arctan2(w[..., 2], lat)

    yaw, pitch, roll = angles(P[:, a], P[:, b], P[:, lt], P[:, rt])
    _, p0, r0 = angles(R[a], R[b], R[lt], R[rt])
    return _Trunk((P[:, a] + P[:, b]) / 2, np.unwrap(yaw), pitch - p0, roll - r0,
                  (R[a] + R[b]) / 2)


def _pin(raw: np.ndarray, contact: np.ndarray) -> np.ndarray:
    """``raw`` (T, 2) with each stance held at its middle and swings bent to meet them."""
    T = len(raw)
    c = np.asarray(contact, dtype=bool)
    edges = np.flatnonzero(np.diff(np.r_[0, c.astype(int), 0]))
    runs = list(zip(edges[::2], edges[1::2]))
    if not runs:
        return raw.copy()
    corr = np.full((T, 2), np.nan)
    for s0, s1 in runs:
        corr[s0:s1] = raw[(s0 + s1 - 1) // 2] - raw[s0:s1]
    known = np.flatnonzero(~np.isnan(corr[:, 0]))
    t = np.arange(T)
    for k in range(2):
        corr[:, k] = np.interp(t, known, corr[known, k])
    return raw + corr


@dataclass(frozen=True, eq=False)
class _Plan:
    base: np.ndarray        # (T, 3) base origin, world
    R_wb: np.ndarray        # (T, 3, 3) base orientation
    feet: np.ndarray        # (T, 4, 3) foot targets, world


def _plan(motion, character, robot: RobotLegs, nom: Nominal, s: float, k: float) -> _Plan:
    tr = _trunk(motion, character)
    sh = s * k
    radius = np.array([leg.foot_radius for leg in robot.legs])
    height = radius.mean() + nom.hip_height * tr.mid[:, 2] / tr.rest_mid[2]
    mid_w = np.column_stack([sh * tr.mid[:, 0], sh * tr.mid[:, 1], height])
    R_wc = _rot_z(tr.yaw) @ _rot_y(-tr.pitch) @ _rot_x(tr.roll)
    R_wb = R_wc @ robot.body.T
    mid_w[:, :2] -= mid_w[0, :2]  # the hips start above the origin
    base = mid_w - R_wc @ nom.mid
    F = _urdf(motion.foot_positions())
    rest = _urdf(character.rest_foot_positions())
    off = (nom.feet[:, :2] - nom.mid[:2]) - sh * (rest[:, :2] - tr.rest_mid[:2])  # (4, 2)
    Rz = _rot_z(tr.yaw)[:, :2, :2]
    contacts = motion.contacts if motion.contacts is not None else \
        np.zeros((len(F), 4), dtype=bool)
    feet = np.empty_like(F)
    start = sh * tr.mid[0, :2]
    for i in range(4):
        raw = sh * F[:, i, :2] - start + Rz @ off[i]
        feet[:, i, :2] = _pin(raw, contacts[:, i])
        lift = np.maximum(F[:, i, 2] - rest[i, 2], 0.0) * s
        feet[:, i, 2] = radius[i] + np.where(contacts[:, i], 0.0, lift)
    return _Plan(base, R_wb, feet)


def _solve(robot: RobotLegs, nom: Nominal, plan: _Plan):
    local = np.einsum("tba,tlb->tla", plan.R_wb, plan.feet - plan.base[:, None])
    T = len(local)
    angles = np.broadcast_to(robot.rest_angles(), (T, len(robot.joint_names))).copy()
    residual = np.empty((T, 4))
    for i, leg in enumerate(robot.legs):
        q, res = leg.solve(local[:, i], nom.seeds[i])
        angles[:, leg.columns] = q
        residual[:, i] = res
    return angles, residual


def _segment_distance(p0, p1, q0, q1):
    """Closest distance between segments p0-p1 and q0-q1, batched over leading axes."""
    u, v, w = p1 - p0, q1 - q0, p0 - q0
    a, b, c = (u * u).sum(-1), (u * v).sum(-1), (v * v).sum(-1)
    d, e = (u * w).sum(-1), (v * w).sum(-1)
    den = np.maximum(a * c - b * b, 1e-12)
    sN = np.clip((b * e - c * d) / den, 0, 1)
    tN = np.clip((b * sN + e) / np.maximum(c, 1e-12), 0, 1)
    sN = np.clip((b * tN - d) / np.maximum(a, 1e-12), 0, 1)
    return np.linalg.norm(w + sN[..., None] * u - tN[..., None] * v, axis=-1)


def leg_clearance(robot: RobotLegs, angles: np.ndarray) -> float:
    """Smallest distance (m) between the lower segments (hip-knee-foot) of two legs."""
    segs = []
    for leg in robot.legs:
        T, foot = leg.frames(angles[:, leg.columns])
        pts = [T[:, i, :3, 3] for i in range(max(leg.n - 2, 0), leg.n)] + [foot]
        segs.append(list(zip(pts, pts[1:])))
    best = np.inf
    for i in range(4):
        for j in range(i + 1, 4):
            for a in segs[i]:
                for b in segs[j]:
                    best = min(best, float(_segment_distance(*a, *b).min()))
    return best


def retarget(motion, character, robot: RobotLegs, nominal: Nominal, *, scale: float,
             min_stride: float = 0.4, warn=None) -> Retargeted:
    """Carry ``motion`` of ``character`` onto ``robot``.

    Parameters
    ----------
    motion : Motion
        The animal's motion, run at ``fps * sqrt(scale)`` (see the module notes);
        its frames become the robot's frames ``1 / fps`` apart.
    character : Character
    robot : RobotLegs
    nominal : Nominal
        From :func:`nominal_stance`.
    scale : float
        ``s`` of :func:`froude_scale`.
    min_stride : float
        Smallest stride factor ``k`` tried before giving up reaching every target.
    warn : callable, optional
        ``warn(message)`` for each compromise (shortened stride, target missed).

    Returns
    -------
    Retargeted
    """
    warn = warn or (lambda m: None)
    need = 2.0 * max(leg.foot_radius for leg in robot.legs) + CLEARANCE
    best = None
    for k in np.r_[1.0, 0.95 ** np.arange(1, 40)]:
        if k < min_stride - 1e-9:
            break
        plan = _plan(motion, character, robot, nominal, scale, float(k))
        angles, res = _solve(robot, nominal, plan)
        gap = leg_clearance(robot, angles)
        bad = (max(res.max() - REACH_TOLERANCE, 0.0), max(need - gap, 0.0))
        if best is None or bad < best[4]:
            best = (float(k), plan, angles, res, bad, gap)
        if bad == (0.0, 0.0):
            break
    k, plan, angles, res, bad, gap = best
    if k < 1.0:
        warn(f"{robot.urdf.label}: the stride was shortened to {k:.0%} of the scaled "
             "animal's (the speed with it) to keep every foot within reach and the joint "
             f"limits, and the legs {need * 100:.0f} cm apart")
    if res.max() > REACH_TOLERANCE:
        leg = robot.legs[int(np.argmax(res.max(axis=0)))].name
        warn(f"{robot.urdf.label}: the joint limits were clamped: the {leg} foot misses its "
             f"target by up to {res.max() * 100:.1f} cm")
    if gap < need:
        warn(f"{robot.urdf.label}: two legs come within {gap * 100:.1f} cm of each other "
             f"(less than the {need * 100:.0f} cm kept elsewhere) even at the shortest stride")
    fps = motion.fps / np.sqrt(scale)
    local = robot.feet(angles)
    feet = plan.base[:, None] + np.einsum("tab,tlb->tla", plan.R_wb, local)
    q = quaternions_from_matrices(plan.R_wb)
    flip = np.r_[1.0, np.sign(np.sum(q[1:] * q[:-1], axis=1))]
    q = q * np.cumprod(flip)[:, None]
    lo = np.where(np.isfinite(robot.lower), angles - robot.lower, np.inf).min()
    hi = np.where(np.isfinite(robot.upper), robot.upper - angles, np.inf).min()
    dist = float(np.linalg.norm(plan.base[-1, :2] - plan.base[0, :2]))
    info = {"scale": float(scale), "stride_factor": k, "fps": float(fps),
            "robot_hip_height": nominal.hip_height, "robot_leg_length": nominal.leg_length,
            "animal_hip_height": float(character.hip_height),
            "robot_speed": dist / max(motion.duration * np.sqrt(scale), 1e-9),
            "animal_speed": float(np.linalg.norm(np.diff(motion.root_positions[[0, -1]][:, [0, 2]],
                                                         axis=0))) / max(motion.duration, 1e-9),
            "reach_residual_max": float(res.max()),
            "limit_margin_min": float(min(lo, hi)),
            "leg_clearance_min": gap}
    contacts = motion.contacts if motion.contacts is not None else \
        np.zeros((len(angles), 4), dtype=bool)
    gaits = motion.gaits if motion.gaits is not None else np.full(len(angles), "", dtype=object)
    return Retargeted(float(fps), robot.joint_names, plan.base, q[:, [1, 2, 3, 0]], angles,
                      tuple(leg.foot_link for leg in robot.legs), feet,
                      np.gradient(feet, 1.0 / fps, axis=0) if len(feet) > 1
                      else np.zeros_like(feet),
                      np.array([leg.foot_radius for leg in robot.legs]),
                      np.array(contacts, dtype=bool), np.array(gaits, dtype=str), info)
