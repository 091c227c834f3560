"""Every figure of a motion at once: the footfall report and the appearance, measured once.

``quadsim metrics --json`` and a sweep's manifest report the same figures of
a motion: :func:`~quadsim.analysis.report.motion_report` and, under
``appearance``, :func:`~quadsim.analysis.appearance.appearance_report`.
Measured one after the other, both find the joints' world positions, the
feet's contacts and the joints' angular velocities. :func:`measure_motion`
computes each of these once and gives it to both figures (and the contacts
back to the caller, for a ``.npz`` file's ``contacts``): the figures are
exactly those of the separate calls.

:func:`measure_motions` measures a batch of motions of one skeleton, frame
rate and length (a sweep's): their contacts, touchdowns, slides and the
appearance's per-frame arrays are found for the whole batch at once
(:mod:`quadsim.skeleton.contacts_many`,
:func:`~quadsim.analysis.appearance.appearance_many`), the angular
velocities compiled (:mod:`quadsim.analysis.angular`), and each motion's
figures are read from its own arrays by the code above: every result is
:func:`measure_motion`'s, to the last bit.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from quadsim.analysis.angular import angular_figures
from quadsim.analysis.appearance import (appearance_from_arrays, appearance_many, ground_points,
                                         toe_positions)
from quadsim.analysis.report import feet_over_ground, report_from_arrays
from quadsim.skeleton.anatomy import Anatomy, find_anatomy
from quadsim.skeleton import contacts_many
from quadsim.skeleton.contacts import default_contact_thresholds, foot_contacts

__all__ = ["Measured", "measure_motion", "measure_motions"]


@dataclass(frozen=True)
class Measured:
    """The figures of a motion and the contacts they were measured with.

    Attributes
    ----------
    report : dict
        :func:`~quadsim.analysis.report.motion_report` of the motion, with
        ``appearance``: its :func:`~quadsim.analysis.appearance.appearance_report`,
        or None when the skeleton has no quadruped structure to measure.
    contacts : ndarray of bool, shape (T, 4)
        :func:`~quadsim.skeleton.contacts.foot_contacts` of the motion's foot
        joint world positions as they are (default thresholds): what
        :func:`quadsim.io.npz.npz_arrays` stores as ``contacts``.
    """

    report: dict
    contacts: np.ndarray


def measure_motion(motion, *, anatomy: Anatomy | None = None,
                   appearance: bool = True) -> Measured:
    """The report of ``quadsim metrics --json`` of a whole motion, measured once.

    Parameters
    ----------
    motion : Motion
        Must name its four foot joints (``foot_joints``).
    anatomy : Anatomy, optional
        The skeleton's anatomy (default: found from it); ignored without
        ``appearance``.
    appearance : bool
        Measure the appearance too (``report["appearance"]``; None when the
        skeleton has no quadruped structure, or when False).

    Returns
    -------
    Measured
        ``report`` equal to ``motion_report(motion)`` plus ``appearance``
        (``appearance_report(motion, anatomy=anatomy)``), and the contacts of
        the feet as they are.

    Raises
    ------
    ValueError
        When the motion does not name its foot joints, or is too short.
    """
    if getattr(motion, "foot_joints", None) is None:
        raise ValueError("measure_motion needs the motion's foot joints: build the Motion "
                         "with foot_joints=(LF, RF, LH, RH joint names)")
    fps = float(motion.fps)
    if len(motion) < 3:
        raise ValueError(f"need at least 3 frames; the motion has {len(motion)} frames "
                         f"at {fps:g} fps")
    feet = feet_over_ground(motion)
    height, speed = default_contact_thresholds(feet)
    contacts = foot_contacts(feet, fps, height=height, speed=speed)
    omega, joint_speed, joint_accel = angular_figures(motion.rotations, fps)
    report = report_from_arrays(feet, motion.root_positions, fps, contacts, omega,
                                joint_names=motion.skeleton.names, height=height,
                                speed=speed, joint_speed=joint_speed, joint_accel=joint_accel)
    report["appearance"] = None
    if appearance:
        try:  # as appearance_report, the contacts of the anatomy's feet
            a = anatomy or find_anatomy(motion.skeleton, motion.foot_joints)
            if tuple(a.feet) == tuple(motion.skeleton.indices(motion.foot_joints)):
                mine = contacts
            else:
                mine = foot_contacts(ground_points(motion, a), fps)
            report["appearance"] = appearance_from_arrays(motion, a, 0, mine, joint_speed)
        except ValueError:  # no quadruped structure to measure the trunk and head on
            report["appearance"] = None
    ground = (getattr(motion, "extras", None) or {}).get("ground")
    if ground is not None:
        contacts = foot_contacts(motion.contact_points(), fps)
    return Measured(report, contacts)


def _alike(motions) -> bool:
    """Whether the motions share skeleton, feet, frame rate and length, on flat ground."""
    m0 = motions[0]
    return m0.foot_joints is not None and len(m0) >= 3 and all(
        m.skeleton is m0.skeleton and m.foot_joints == m0.foot_joints
        and float(m.fps) == float(m0.fps) and len(m) == len(m0)
        and (getattr(m, "extras", None) or {}).get("ground") is None for m in motions)


def measure_motions(motions, *, anatomy: Anatomy | None = None,
                    appearance: bool = True) -> list[Measured]:
    """:func:`measure_motion` of each motion, the contacts of all found together.

    Motions of one skeleton, foot joints, frame rate and length on flat
    ground (a sweep's batch) have their foot contacts and touchdowns found
    in one pass (:mod:`quadsim.skeleton.contacts_many`); any others are
    measured one by one. Either way each result is :func:`measure_motion`'s
    to the last bit (tests hold it).

    Parameters
    ----------
    motions : sequence of Motion
    anatomy : Anatomy, optional
        Their skeleton's anatomy (default: found from it).
    appearance : bool
        As :func:`measure_motion`.

    Returns
    -------
    list of Measured
        One per motion, in order.
    """
    motions = list(motions)
    if not motions:
        return []
    if not _alike(motions):
        return [measure_motion(m, anatomy=anatomy, appearance=appearance) for m in motions]
    m0 = motions[0]
    fps = float(m0.fps)
    each = [m.contact_points() for m in motions]  # as measure_motion has them
    feet = np.stack(each)  # (N, T, 4, 3)
    heights, speeds = contacts_many.default_thresholds(feet)
    together = contacts_many.foot_contacts(feet, fps, heights, speeds)
    evs = contacts_many.events(together, fps, feet, heights)
    found = contacts_many.runs(together)
    slid = contacts_many.per_foot(contacts_many.slides(feet, together, found), found[3],
                                  len(motions))
    # and laid out as measure_motion has them (a .npz stores the layout)
    contacts = [contacts_many.laid_out_as(c, f) for c, f in zip(together, each)]
    a = None
    if appearance:
        try:
            a = anatomy or find_anatomy(m0.skeleton, m0.foot_joints)
        except ValueError:  # no quadruped structure to measure the trunk and head on
            a = None
    same_feet = a is not None and tuple(a.feet) == tuple(m0.skeleton.indices(m0.foot_joints))
    reports, speeds_of = [], []
    for i, m in enumerate(motions):
        omega, joint_speed, joint_accel = angular_figures(m.rotations, fps)
        reports.append(report_from_arrays(
            each[i], m.root_positions, fps, contacts[i], omega, joint_names=m.skeleton.names,
            height=float(heights[i]), speed=float(speeds[i]), joint_speed=joint_speed,
            joint_accel=joint_accel, events=evs[i], slides=slid[i]))
        reports[-1]["appearance"] = None
        speeds_of.append(joint_speed)
    if a is not None:
        try:
            mine = contacts if same_feet else [
                foot_contacts(toe_positions(m, a), fps) for m in motions]
            found = appearance_many(motions, a, mine, speeds_of)
        except ValueError:  # some cannot be measured: each as measure_motion would
            found = [measure_motion(m, anatomy=a).report["appearance"] for m in motions]
        for r, f in zip(reports, found):
            r["appearance"] = f
    return [Measured(r, c) for r, c in zip(reports, contacts)]
