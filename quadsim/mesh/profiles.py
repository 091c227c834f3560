"""Body profiles: the shape of each part of a quadruped, as data.

A :class:`Profile` describes a body by its parts, each laid along a chain of
the skeleton found by :func:`quadsim.skeleton.anatomy.find_anatomy`:

========== =================================== ===============================
part       t = 0                               t = 1
========== =================================== ===============================
trunk      pelvis                              withers (beyond: level, forward)
neck       withers                             head joint
head       head joint                          the head's end site (muzzle)
fore_leg   top joint of each fore leg          fore foot joint
hind_leg   top joint of each hind leg          hind foot joint
fore_foot  fore foot joint                     its toe tip (end site)
hind_foot  hind foot joint                     its toe tip
tail       first tail joint                    tail tip (beyond: along its end)
========== =================================== ===============================

``t`` runs by arc length along the chain and may leave [0, 1]: the chain is
then extended straight (the trunk level and forward or back, the others along
their end bones). Along a part, cross-sections (:class:`Section`) give the
half-width (across the body, +X), the half-depth (in the plane of the body,
perpendicular to the chain: up for the trunk, neck and head, fore-aft for the
legs) and a *lift* of the section's centre off the chain along that second
axis. All lengths are fractions of the hip height, so one profile fits an
animal of any size. :class:`Blob` adds small pieces (ears, a nose) fixed to a
part. Parts and blobs carry a tone (a multiple of the body colour) or their
own colour, and a cross-section exponent (2: ellipses; higher: boxier, as for
hooves).

:data:`PROFILES` holds the shipped characters' profiles by character id;
:data:`DEFAULT_PROFILE` is a generic medium quadruped that fits any skeleton.
"""

from __future__ import annotations

from dataclasses import dataclass, field

__all__ = ["BODY_COLORS", "DEFAULT_COLOR", "DEFAULT_PROFILE", "PARTS", "PROFILES", "Blob",
           "Part", "Profile", "Section", "Spots", "profile_for_id"]

#: Names of the chains a part can follow.
PARTS = ("trunk", "neck", "head", "fore_leg", "hind_leg", "fore_foot", "hind_foot", "tail")

#: Body colour (RGB in [0, 1]) by character id.
BODY_COLORS = {
    "leopard": (0.86, 0.64, 0.30),
    "leopard_cub": (0.90, 0.74, 0.45),
    "dog_cub": (0.62, 0.44, 0.28),
    "horse": (0.50, 0.30, 0.18),
}
DEFAULT_COLOR = (0.70, 0.66, 0.60)


@dataclass(frozen=True)
class Section:
    """One cross-section of a part (lengths in hip heights).

    Attributes
    ----------
    t : float
        Position along the part's chain (0 at its start, 1 at its end).
    width, depth : float
        Half-width across the body and half-depth in the body's plane.
    lift : float
        Offset of the section's centre from the chain along the depth axis
        (up for trunk, neck and head; forward for legs and feet).
    """

    t: float
    width: float
    depth: float
    lift: float = 0.0


@dataclass(frozen=True)
class Part:
    """A smooth tube along one chain: its sections, tone and section exponent.

    Attributes
    ----------
    chain : str
        One of :data:`PARTS`.
    sections : tuple of Section
        In increasing ``t``; radii are interpolated linearly between them.
    tone : float
        Multiplies the body colour.
    rgb : tuple of float, optional
        A colour of its own instead (hooves, a mane).
    power : float
        Cross-section exponent: 2 for ellipses, 3-4 for rounded boxes.
    grow : float
        Added to every half-width and half-depth (hip heights).
    """

    chain: str
    sections: tuple[Section, ...]
    tone: float = 1.0
    rgb: tuple[float, float, float] | None = None
    power: float = 2.0
    grow: float = 0.0


@dataclass(frozen=True)
class Blob:
    """A short tapered piece fixed to a part at ``t``, e.g. an ear.

    Its ends are offsets ``(across, depth axis, along the chain)`` in hip
    heights in the part's frame at ``t``; ``mirror`` adds the copy on the
    other side (``across`` negated).
    """

    chain: str
    t: float
    start: tuple[float, float, float]
    end: tuple[float, float, float]
    radius_start: tuple[float, float]
    radius_end: tuple[float, float]
    mirror: bool = True
    tone: float = 1.0
    rgb: tuple[float, float, float] | None = None


@dataclass(frozen=True)
class Spots:
    """Dark spots on the coat (a leopard's).

    Attributes
    ----------
    density : float
        Spots per square hip height of the coat (trunk, neck, legs and tail).
    radius : float
        Spot radius (hip heights).
    darkness : float
        Fraction of the colour removed at a spot's centre.
    seed : int
        Places the spots (the same seed, the same coat).
    """

    density: float
    radius: float
    darkness: float = 0.7
    seed: int = 7


@dataclass(frozen=True)
class Profile:
    """A whole body: parts, blobs, colour, the blend radius and the grid step.

    Attributes
    ----------
    parts : tuple of Part
    blobs : tuple of Blob
    color : tuple of float
        Body colour, RGB in [0, 1].
    blend : float
        Radius over which parts melt into each other (hip heights).
    voxel : float
        Grid step of the surface (hip heights): sets the triangle count.
    name : str
    belly : float
        How far the underside (downward normals of trunk, neck and head)
        turns to ``belly_rgb``, 0 to 1.
    belly_rgb : tuple of float
    spots : Spots, optional
        Dark spots on the coat.
    """

    parts: tuple[Part, ...]
    blobs: tuple[Blob, ...] = ()
    color: tuple[float, float, float] = DEFAULT_COLOR
    blend: float = 0.035
    voxel: float = 0.036
    name: str = field(default="default")
    belly: float = 0.0
    belly_rgb: tuple[float, float, float] = (0.93, 0.88, 0.78)
    spots: Spots | None = None


def _s(*rows) -> tuple[Section, ...]:
    return tuple(Section(*r) for r in rows)


HOOF_RGB = (0.24, 0.22, 0.20)
NOSE_RGB = (0.12, 0.10, 0.10)
POINTS_RGB = (0.13, 0.09, 0.07)

# -------------------------------------------------------------------- horse
# a hoof: a flat sole on the ground, the wall lower at the heel and sloping to the toe
_HOOF = _s((-0.9, 0.036, 0.026, 0.028), (-0.3, 0.046, 0.038, 0.04), (0.4, 0.046, 0.04, 0.04),
           (1.0, 0.036, 0.02, 0.022))

_HORSE = Profile(
    name="horse",
    color=BODY_COLORS["horse"],
    blend=0.03,
    voxel=0.031,
    parts=(
        # barrel: deep through the girth, a tucked flank, a high croup and a breast
        Part("trunk", _s((-0.55, 0.13, 0.17, -0.20), (-0.35, 0.18, 0.23, -0.20),
                         (-0.1, 0.20, 0.25, -0.21), (0.25, 0.20, 0.20, -0.19),
                         (0.6, 0.22, 0.25, -0.23), (0.9, 0.19, 0.27, -0.26),
                         (1.15, 0.15, 0.22, -0.30), (1.35, 0.11, 0.14, -0.34)), grow=0.02),
        # a deep, flat-sided neck, deepest at its base, the crest above the vertebrae
        Part("neck", _s((0.0, 0.09, 0.20, -0.17), (0.3, 0.085, 0.16, -0.04),
                        (0.65, 0.07, 0.125, -0.04), (0.9, 0.06, 0.09, -0.06),
                        (1.0, 0.055, 0.075, -0.07))),
        Part("neck", _s((0.05, 0.025, 0.04, 0.06), (0.3, 0.025, 0.045, 0.14),
                        (0.65, 0.024, 0.04, 0.1), (1.0, 0.022, 0.03, 0.02)),
             rgb=POINTS_RGB),
        # a long wedge: wide jowls behind, a narrow face, a muzzle
        Part("head", _s((0.0, 0.07, 0.10, -0.06), (0.2, 0.09, 0.14, -0.10),
                        (0.5, 0.068, 0.10, -0.055), (0.8, 0.055, 0.078, -0.04),
                        (1.0, 0.055, 0.07, -0.045))),
        # slim legs, black below the knees and hocks (a bay's points)
        Part("fore_leg", _s((0.0, 0.09, 0.12), (0.26, 0.06, 0.085), (0.45, 0.04, 0.05),
                            (0.55, 0.035, 0.04)), grow=0.008),
        Part("fore_leg", _s((0.55, 0.035, 0.04), (0.59, 0.034, 0.038), (0.7, 0.022, 0.03),
                            (0.83, 0.03, 0.036), (0.91, 0.022, 0.027), (1.0, 0.03, 0.032)),
             rgb=POINTS_RGB, grow=0.008),
        Part("hind_leg", _s((0.0, 0.15, 0.19, -0.05), (0.27, 0.09, 0.14, -0.03),
                            (0.42, 0.045, 0.075, -0.03), (0.55, 0.03, 0.055, -0.02)), grow=0.01),
        Part("hind_leg", _s((0.55, 0.03, 0.055, -0.02), (0.6, 0.028, 0.05, -0.015),
                            (0.7, 0.022, 0.032), (0.84, 0.03, 0.036), (0.92, 0.022, 0.027),
                            (1.0, 0.03, 0.032)), rgb=POINTS_RGB, grow=0.01),
        # hooves: rounded boxes standing on the ground, wider at the sole
        Part("fore_foot", _HOOF, rgb=HOOF_RGB, power=4.0),
        Part("hind_foot", _HOOF, rgb=HOOF_RGB, power=4.0),
        # the dock, then the hair hanging to the hocks
        Part("tail", _s((0.0, 0.05, 0.055), (1.0, 0.045, 0.05), (1.8, 0.05, 0.06),
                        (3.2, 0.03, 0.035)), rgb=POINTS_RGB, grow=0.01),
    ),
    blobs=(
        Blob("head", 0.03, (0.05, 0.03, -0.01), (0.08, 0.14, -0.12), (0.034, 0.04),
             (0.022, 0.026)),
    ),
)

# ------------------------------------------------------------------ leopard
_CAT_TRUNK = _s((-0.15, 0.11, 0.13, -0.10), (0.0, 0.14, 0.16, -0.13), (0.3, 0.12, 0.15, -0.13),
                (0.6, 0.15, 0.21, -0.19), (0.85, 0.16, 0.24, -0.22), (1.02, 0.15, 0.22, -0.21),
                (1.15, 0.10, 0.15, -0.19))

_LEOPARD = Profile(
    name="leopard",
    color=BODY_COLORS["leopard"],
    belly=0.6,
    spots=Spots(density=45.0, radius=0.045),
    blend=0.035,
    voxel=0.038,
    parts=(
        Part("trunk", _CAT_TRUNK, grow=0.05),
        Part("neck", _s((0.0, 0.13, 0.19, -0.10), (0.5, 0.12, 0.14, -0.05),
                        (1.0, 0.11, 0.12, -0.03)), grow=0.045),
        # a round skull, a short broad muzzle
        # a round skull and a short face: the muzzle stops short of the head's tip
        Part("head", _s((-0.2, 0.13, 0.13, 0.03), (0.2, 0.155, 0.14, 0.02),
                        (0.5, 0.11, 0.09, -0.02), (0.72, 0.085, 0.07, -0.04),
                        (0.88, 0.07, 0.055, -0.05)), grow=0.02),
        Part("fore_leg", _s((0.0, 0.06, 0.08), (0.24, 0.085, 0.12), (0.5, 0.07, 0.085),
                            (0.72, 0.055, 0.06), (0.88, 0.042, 0.047), (1.0, 0.045, 0.045)), grow=0.025),
        Part("hind_leg", _s((0.0, 0.12, 0.16, -0.02), (0.33, 0.08, 0.11), (0.5, 0.06, 0.075),
                            (0.75, 0.036, 0.048), (1.0, 0.04, 0.042)), grow=0.03),
        Part("fore_foot", _s((-0.3, 0.056, 0.043, 0.043), (0.45, 0.075, 0.05, 0.05),
                             (1.1, 0.06, 0.035, 0.035)), grow=0.01),
        Part("hind_foot", _s((-0.3, 0.049, 0.038, 0.038), (0.45, 0.065, 0.045, 0.045),
                             (1.1, 0.052, 0.032, 0.032)), grow=0.01),
        # long and thick to the tip
        Part("tail", _s((-0.3, 0.07, 0.07), (0.0, 0.065, 0.065), (0.3, 0.05, 0.05),
                        (1.0, 0.04, 0.04)), grow=0.02),
    ),
    blobs=(
        Blob("head", 0.1, (0.09, 0.1, -0.02), (0.11, 0.23, -0.05), (0.06, 0.035),
             (0.04, 0.022)),
        Blob("head", 0.88, (0.0, 0.0, -0.01), (0.0, 0.0, 0.01), (0.025, 0.02),
             (0.02, 0.015), mirror=False, rgb=NOSE_RGB),
    ),
)

# --------------------------------------------------------------- leopard cub
_LEOPARD_CUB = Profile(
    name="leopard_cub",
    color=BODY_COLORS["leopard_cub"],
    belly=0.6,
    spots=Spots(density=35.0, radius=0.06, darkness=0.55),
    blend=0.05,
    voxel=0.043,
    parts=(
        # a round belly, less waist than the adult
        Part("trunk", _s((-0.15, 0.12, 0.13, -0.09), (0.0, 0.15, 0.17, -0.13),
                         (0.4, 0.16, 0.20, -0.16), (0.75, 0.17, 0.23, -0.19),
                         (1.02, 0.15, 0.21, -0.19), (1.15, 0.11, 0.15, -0.17)), grow=0.055),
        Part("neck", _s((0.0, 0.14, 0.19, -0.08), (0.5, 0.13, 0.15, -0.04),
                        (1.0, 0.13, 0.14, -0.02)), grow=0.05),
        # a big round head, a short muzzle
        Part("head", _s((-0.3, 0.17, 0.17, 0.05), (0.2, 0.22, 0.21, 0.05),
                        (0.65, 0.15, 0.12, -0.02), (1.0, 0.09, 0.08, -0.04)), grow=0.03),
        Part("fore_leg", _s((0.0, 0.07, 0.09), (0.24, 0.09, 0.12), (0.5, 0.075, 0.09),
                            (0.72, 0.062, 0.066), (0.88, 0.055, 0.058), (1.0, 0.06, 0.06)), grow=0.035),
        Part("hind_leg", _s((0.0, 0.13, 0.16), (0.33, 0.09, 0.11), (0.5, 0.07, 0.08),
                            (0.75, 0.05, 0.055), (1.0, 0.055, 0.055)), grow=0.045),
        # big paws
        Part("fore_foot", _s((-0.3, 0.075, 0.06, 0.06), (0.45, 0.1, 0.07, 0.07),
                             (1.1, 0.08, 0.049, 0.049)), grow=0.025),
        Part("hind_foot", _s((-0.3, 0.068, 0.055, 0.055), (0.45, 0.09, 0.065, 0.065),
                             (1.1, 0.072, 0.045, 0.045)), grow=0.025),
        Part("tail", _s((-0.3, 0.065, 0.065), (0.0, 0.06, 0.06), (1.0, 0.04, 0.04)), grow=0.005),
    ),
    blobs=(
        Blob("head", 0.05, (0.12, 0.13, -0.02), (0.14, 0.28, -0.06), (0.065, 0.035),
             (0.045, 0.02)),
        Blob("head", 1.0, (0.0, 0.0, -0.01), (0.0, 0.0, 0.01), (0.035, 0.028),
             (0.03, 0.022), mirror=False, rgb=NOSE_RGB),
    ),
)

# ------------------------------------------------------------------ dog cub
_DOG_CUB = Profile(
    name="dog_cub",
    color=BODY_COLORS["dog_cub"],
    belly=0.35,
    blend=0.05,
    voxel=0.043,
    parts=(
        Part("trunk", _s((-0.15, 0.13, 0.14, -0.10), (0.0, 0.16, 0.18, -0.14),
                         (0.35, 0.15, 0.19, -0.16), (0.7, 0.17, 0.24, -0.21),
                         (1.0, 0.16, 0.23, -0.21), (1.2, 0.11, 0.15, -0.18)), grow=0.055),
        Part("neck", _s((0.0, 0.13, 0.19, -0.08), (0.5, 0.12, 0.14, -0.04),
                        (1.0, 0.12, 0.13, -0.02)), grow=0.05),
        # a round skull with a stop, then a box-like muzzle
        Part("head", _s((-0.25, 0.17, 0.17, 0.05), (0.25, 0.19, 0.19, 0.05),
                        (0.5, 0.11, 0.10, -0.03), (0.75, 0.09, 0.08, -0.05),
                        (1.0, 0.08, 0.07, -0.06)), grow=0.03),
        Part("fore_leg", _s((0.0, 0.07, 0.09), (0.24, 0.09, 0.12), (0.5, 0.07, 0.08),
                            (0.75, 0.055, 0.06), (0.9, 0.05, 0.055), (1.0, 0.055, 0.055)), grow=0.035),
        Part("hind_leg", _s((0.0, 0.13, 0.17), (0.33, 0.09, 0.11), (0.5, 0.065, 0.08),
                            (0.75, 0.045, 0.055), (1.0, 0.05, 0.05)), grow=0.045),
        Part("fore_foot", _s((-0.3, 0.064, 0.051, 0.051), (0.45, 0.085, 0.06, 0.06),
                             (1.1, 0.068, 0.042, 0.042)), grow=0.025),
        Part("hind_foot", _s((-0.3, 0.06, 0.047, 0.047), (0.45, 0.08, 0.055, 0.055),
                             (1.1, 0.064, 0.038, 0.038)), grow=0.025),
        Part("tail", _s((-0.2, 0.06, 0.06), (0.0, 0.055, 0.055), (1.0, 0.028, 0.028))),
    ),
    blobs=(
        # floppy ears hanging at the sides of the skull
        Blob("head", 0.1, (0.19, 0.17, -0.03), (0.26, -0.1, 0.0), (0.035, 0.08),
             (0.03, 0.07), tone=0.6),
        Blob("head", 1.0, (0.0, 0.0, -0.01), (0.0, 0.0, 0.02), (0.04, 0.035),
             (0.035, 0.03), mirror=False, rgb=NOSE_RGB),
    ),
)

# ------------------------------------------------------------------ default
DEFAULT_PROFILE = Profile(
    name="default",
    parts=(
        Part("trunk", _s((-0.15, 0.12, 0.13, -0.10), (0.0, 0.15, 0.17, -0.13),
                         (0.35, 0.14, 0.17, -0.15), (0.7, 0.16, 0.22, -0.19),
                         (1.0, 0.15, 0.21, -0.19), (1.15, 0.10, 0.14, -0.17)), grow=0.035),
        Part("neck", _s((0.0, 0.12, 0.17, -0.08), (0.5, 0.11, 0.13, -0.04),
                        (1.0, 0.10, 0.11, -0.02)), grow=0.03),
        Part("head", _s((-0.1, 0.11, 0.11, 0.02), (0.3, 0.12, 0.11, 0.02),
                        (0.7, 0.08, 0.07, -0.02), (1.0, 0.06, 0.055, -0.03)), grow=0.02),
        Part("fore_leg", _s((0.0, 0.06, 0.08), (0.25, 0.08, 0.11), (0.5, 0.06, 0.075),
                            (0.8, 0.045, 0.05), (1.0, 0.045, 0.045)), grow=0.015),
        Part("hind_leg", _s((0.0, 0.11, 0.15), (0.33, 0.075, 0.10), (0.5, 0.055, 0.07),
                            (0.8, 0.04, 0.045), (1.0, 0.042, 0.042)), grow=0.02),
        Part("fore_foot", _s((-0.3, 0.049, 0.038, 0.038), (0.45, 0.065, 0.045, 0.045),
                             (1.1, 0.052, 0.032, 0.032)), grow=0.01),
        Part("hind_foot", _s((-0.3, 0.045, 0.038, 0.038), (0.45, 0.06, 0.045, 0.045),
                             (1.1, 0.048, 0.032, 0.032)), grow=0.01),
        Part("tail", _s((-0.2, 0.05, 0.05), (0.0, 0.045, 0.045), (1.0, 0.03, 0.03)), grow=0.01),
    ),
    blobs=(
        Blob("head", 0.15, (0.07, 0.07, -0.01), (0.08, 0.14, -0.03), (0.035, 0.025),
             (0.015, 0.01)),
    ),
)

#: Profiles of the shipped characters by character id.
PROFILES = {p.name: p for p in (_HORSE, _LEOPARD, _LEOPARD_CUB, _DOG_CUB)}


def profile_for_id(character_id: str | None) -> Profile:
    """The profile of a character id, :data:`DEFAULT_PROFILE` for any other."""
    return PROFILES.get(character_id or "", DEFAULT_PROFILE)
