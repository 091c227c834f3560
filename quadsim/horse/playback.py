"""Playing a clip database: gait bands, expanded clips by speed, poses at a generic time.

:class:`ClipPlayer` is what :class:`~quadsim.horse.controller.HorseDataController`
asks of its clips:

* **Gait by speed.** The automatic gaits (:func:`auto_gaits`: the character's
  ``locomotion.auto`` gaits that have clips, else :data:`AUTO_GAITS`; the
  horse's amble and rack only on request) are chosen by speed bands whose boundaries
  are the geometric means of neighbouring gaits' clip speeds, with a
  hysteresis of :data:`HYSTERESIS` either side so a speed near a boundary
  does not flicker (:meth:`ClipPlayer.gait_for`).
* **Speed.** A gait's nearest clip is expanded to the asked speed
  (:func:`quadsim.horse.speed.expand` with the gait's law, :func:`gait_law`;
  speeds quantised to :data:`SPEED_STEP`
  relative steps and the expansions cached), between :data:`SPEED_REACH`
  times the gait's slowest and fastest clip (:meth:`ClipPlayer.expanded`,
  :meth:`ClipPlayer.speed_range`).
* **Poses.** A looped clip's local root and rotations at a generic time and
  the feet it holds still there (:meth:`ClipPlayer.local`,
  :meth:`ClipPlayer.stance`), and a motion's pose at a fractional frame
  (:meth:`ClipPlayer.sample`), by the compiled samplers of
  :mod:`quadsim.horse.place_kernel`.
* **Transitions.** :func:`start_transition` computes the asynchronous time
  warp between two clips once, as a :class:`Transition` to play through.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..kinematics.compiled import FixedEntry
from ..skeleton.character import Character
from ..skeleton.contacts import foot_contacts
from ..skeleton.motion import Motion
from .database import GAIT_ALIASES, Clip, ClipDatabase, SpeedLaw
from .place_kernel import pack_contacts, sample_row, stance_row
from .root import FLIGHT, clip_stance_cycles
from .speed import DEFAULT_EXPONENT, expand, hoyt_law
from .timewarp import leg_times, transition_motion
from .turning import GROUND_BAND

#: Gaits chosen by speed, slowest first, for a character whose ``locomotion.auto``
#: names none with clips (amble, rack and pace only on request).
AUTO_GAITS = ("walk", "trot", "canter", "gallop", "rotary_gallop")
#: Relative hysteresis about each gait boundary.
HYSTERESIS = 0.06
#: Relative speed quantum of the expansion cache.
SPEED_STEP = 0.02
#: Gaits expanded relative to their clip when they use Table 1's law (the horse's
#: absolute law is out of the leg's reach).
CLIP_ANCHORED = ("amble", "gallop")
#: Lowest and highest speed played, as multiples of the gait's slowest / fastest clip.
SPEED_REACH = (0.6, 1.4)
#: A foot lifted for at most this long (s) between two contacts in a transition stays planted.
MIN_AIR = 0.05
#: Shortest mean contact time (cycles) a clip is taken to have (a guard for the turn limit).
MIN_CONTACT_CYCLES = 1e-3


def fill_gaps(stance: np.ndarray, n: int) -> np.ndarray:
    """``stance`` (T, 4) bool with each foot's gaps of at most ``n`` frames between contacts
    closed (a transition's per-leg switch of clips can lift a foot for a frame or two)."""
    out = np.array(stance, dtype=bool)
    for j in range(out.shape[1]):
        d = np.diff(np.concatenate([[1], out[:, j].astype(np.int8), [1]]))
        starts, ends = np.nonzero(d == -1)[0], np.nonzero(d == 1)[0]
        for a, b in zip(starts, ends):
            if 0 < a and b < len(out) and b - a <= n:
                out[a:b, j] = True
    return out


def auto_gaits(character: Character, database: ClipDatabase) -> list[str]:
    """The gaits chosen by speed, slowest first: the character's ``locomotion.auto``
    gaits that have clips (names as the clips give them), else those of
    :data:`AUTO_GAITS`, else every clip gait but the leap by its clips' mean speed."""
    have = [g for g in database.gaits if g != "leap"]
    auto = []
    for g in character.locomotion.get("auto", ()) or ():
        g = GAIT_ALIASES.get(g, g)
        if g in have and g not in auto:
            auto.append(g)
    if not auto:
        auto = [g for g in AUTO_GAITS if g in have]
    if not auto:
        auto = have
    return sorted(auto, key=lambda g: float(np.mean([np.log(c.speed)
                                                     for c in database.by_gait(g)])))


def gait_law(database: ClipDatabase, gait: str) -> SpeedLaw:
    """The contact-time law a gait's clips are expanded by: the database's own
    (``[laws.<gait>]``), else Table 1's row (relative to the clip for
    :data:`CLIP_ANCHORED` gaits), else :data:`DEFAULT_EXPONENT` relative to the clip."""
    law = database.laws.get(gait)
    if law is not None:
        return law
    law = hoyt_law(gait, "clip" if gait in CLIP_ANCHORED else "law")
    return law if law is not None else SpeedLaw(float("nan"), DEFAULT_EXPONENT, "clip")


class _Packed:
    """A clip's arrays for the compiled sampling: one cycle closed by its first frame
    (the root's travel added), and its contacts (:func:`~.place_kernel.stance_row`)."""

    def __init__(self, clip: Clip):
        m = clip.motion
        self.root = np.ascontiguousarray(np.concatenate(
            [m.root_positions, m.root_positions[:1] + [0.0, 0.0, clip.speed * clip.period]]),
            dtype=float)
        self.rot = np.ascontiguousarray(np.concatenate([m.rotations, m.rotations[:1]]),
                                        dtype=float)
        self.on_off, self.count = pack_contacts(clip_stance_cycles(clip))


class ClipPlayer:
    """A character's clip database, played by gait, speed and generic time.

    Parameters
    ----------
    character : Character
    database : ClipDatabase

    Attributes
    ----------
    db : ClipDatabase
    auto : list of str
        The automatic gaits that have clips, slowest first.
    bounds : list of float
        Speeds (m/s) between neighbouring automatic gaits.
    leap_clip : Clip or None
    leap_contacts : ndarray of bool, shape (T, 4) or None
        The leap clip's measured contacts per frame.
    """

    def __init__(self, character: Character, database: ClipDatabase):
        self.character = character
        self.db = database
        self.auto = auto_gaits(character, database)
        if not self.auto:
            where = "" if database.folder is None else f" {database.folder}"
            raise InputError(f"the clip database{where} has no gait clip (only leaps); cut "
                             "some with `quadsim clips-from`")
        mean = [float(np.exp(np.mean([np.log(c.speed) for c in database.by_gait(g)])))
                for g in self.auto]
        self.bounds = [math.sqrt(a * b) for a, b in zip(mean[:-1], mean[1:])]
        leaps = database.by_gait("leap")
        self.leap_clip = leaps[0] if leaps else None
        self.leap_contacts = None
        if self.leap_clip is not None:
            lm = self.leap_clip.motion
            self.leap_contacts = np.ascontiguousarray(
                foot_contacts(lm.foot_positions(), lm.fps), dtype=bool)
        self._clips = {g: database.by_gait(g) for g in database.gaits}
        self._ranges = {g: (c[0].speed * SPEED_REACH[0], c[-1].speed * SPEED_REACH[1])
                        for g, c in self._clips.items()}
        self._cache: dict = {}
        self._last_expanded = (None, None, None)   # (gait, speed, clip) of the last ask
        self._stance: dict = {}
        self._packed: dict = {}
        self._n_joints = character.skeleton.n_joints
        # the looped clips' samplers take arrays of one set of types (see _Packed)
        self._sample_row = FixedEntry(sample_row)
        self._stance_row = FixedEntry(stance_row)

    # ------------------------------------------------------------ gaits and speeds
    def gaits(self) -> list[str]:
        """The gaits a command may ask for (every clip gait but the leap)."""
        return [g for g in self.db.gaits if g != "leap"]

    def check_gait(self, gait: str) -> str:
        """The clip gait a command's ``gait`` names (aliases resolved).

        Raises
        ------
        InputError
            When the database has no clips of it.
        """
        g = GAIT_ALIASES.get(gait, gait)
        if not self.db.by_gait(g) or g == "leap":
            raise InputError(f"gait {gait!r} has no clips in the database; "
                             f"allowed: {', '.join(self.gaits())}")
        return g

    def gait_for(self, speed: float, current: str | None) -> str:
        """The automatic gait for ``speed`` (m/s), keeping ``current`` within its hysteresis."""
        b = self.bounds
        if current in self.auto:
            cur = self.auto.index(current)
            lo = b[cur - 1] * (1 - HYSTERESIS) if cur > 0 else -math.inf
            hi = b[cur] * (1 + HYSTERESIS) if cur < len(b) else math.inf
            if lo <= speed <= hi:
                return current
        return self.auto[bisect.bisect_left(b, speed)]

    def preferred_speed(self, gait: str) -> float:
        """Geometric mean of the gait's clip speeds (m/s)."""
        clips = self.db.by_gait(gait)
        return float(math.exp(np.mean([math.log(c.speed) for c in clips])))

    def speed_range(self, gait: str) -> tuple[float, float]:
        """Slowest and fastest speed (m/s) the gait's clips are played at."""
        r = self._ranges.get(gait)
        if r is None:
            r = self._ranges.get(GAIT_ALIASES.get(gait, gait))
            if r is None:
                raise InputError(f"the clip database has no {gait!r} clip; "
                                 f"it has: {', '.join(self.db.gaits)}")
        return r

    def expanded(self, gait: str, speed: float) -> Clip:
        """The gait's nearest clip expanded to ``speed`` (clamped to :meth:`speed_range`,
        quantised to :data:`SPEED_STEP`, cached)."""
        last = self._last_expanded            # asked again and again for the same
        if last[0] == gait and last[1] == speed:
            return last[2]
        lo, hi = self.speed_range(gait)
        speed_asked = speed
        speed = min(max(float(speed), lo), hi)
        q = round(math.log(speed) / math.log1p(SPEED_STEP))
        key = (gait, q)
        if key not in self._cache:
            v = math.exp(q * math.log1p(SPEED_STEP))
            base = self.db.nearest(gait, v)
            law = gait_law(self.db, gait)
            self._cache[key] = expand(base, self.character, v, anchor=law.anchor, law=law)
        clip = self._cache[key]
        self._last_expanded = (gait, speed_asked, clip)
        return clip

    def stance_time(self, clip: Clip) -> float:
        """Mean contact time of a clip's feet (s)."""
        tc = self._stance.get(clip)
        if tc is None:
            d = np.concatenate([(s[:, 1] - s[:, 0]) % 1.0 for s in clip_stance_cycles(clip)])
            tc = self._stance[clip] = float(max(d.mean(), MIN_CONTACT_CYCLES) * clip.period)
        return tc

    # ------------------------------------------------------------ poses
    def _pack(self, clip: Clip) -> _Packed:
        pk = self._packed.get(clip)
        if pk is None:
            pk = self._packed[clip] = _Packed(clip)
        return pk

    def local(self, clip: Clip, phase: float) -> tuple[np.ndarray, np.ndarray]:
        """Local root (3,) (m, travel unwrapped) and rotations (J, 4) at ``phase`` (cycles)."""
        pk = self._pack(clip)
        f = (phase % 1.0) * clip.frames
        fl = math.floor(f)
        i = int(fl) % clip.frames
        root = np.empty(3)
        q = np.empty((self._n_joints, 4))
        self._sample_row(pk.root, pk.rot, i, i + 1, float(f - fl), root, q)
        root[2] += math.floor(phase) * clip.speed * clip.period
        return root, q

    def stance(self, clip: Clip, phase: float) -> np.ndarray:
        """The feet (4,) bool the clip holds still at ``phase``.

        A contact's measured ends fall between frames, but the pose between
        two frames is interpolated: a foot there is still only when it is on
        the ground on both frames. Played between the frames at either end of
        a contact, the foot is already lifting (or still landing) and is left
        to the clip -- held on its plant there, it would be pulled back up to
        a fifth of a metre for a frame and the leg would snap.
        """
        pk = self._pack(clip)
        st = np.empty(4, dtype=bool)
        self._stance_row(pk.on_off, pk.count, int(clip.frames), float(phase), st)
        return st

    def sample(self, motion: Motion, f: float) -> tuple[np.ndarray, np.ndarray]:
        """Root (3,) and rotations (J, 4) of ``motion`` at fractional frame ``f`` (clipped)."""
        f = min(max(f, 0.0), len(motion) - 1.0)
        i0 = int(math.floor(f))
        root = np.empty(3)
        q = np.empty((self._n_joints, 4))
        sample_row(motion.root_positions, motion.rotations, i0, min(i0 + 1, len(motion) - 1),
                   f - i0, root, q)
        return root, q


@dataclass(frozen=True, eq=False)
class Transition:
    """A gait transition computed once and played through.

    Attributes
    ----------
    motion : Motion
        One cycle of the old clip, the time-warped blend, then one cycle of the new
        (:func:`~quadsim.horse.timewarp.transition_motion`, feet held).
    f0, f_end : int
        The frame it starts playing from and its last frame.
    end : float
        The new clip's generic time (cycles) at ``f_end``.
    clip2 : Clip
        The new gait's clip.
    gait : str
        The new gait.
    stance : ndarray of bool, shape (T, 4)
        The feet held per frame.
    label : str
        ``"old->new"``.
    """

    motion: Motion
    f0: int
    f_end: int
    end: float
    clip2: Clip
    gait: str
    stance: np.ndarray
    label: str

    @property
    def fps(self) -> float:
        return self.motion.fps

    def progress(self, tau: float) -> float:
        """Fraction (0..1, unclipped) of the blend played after ``tau`` s."""
        return tau * self.fps / max(self.f_end - self.f0, 1e-9)


def start_transition(character: Character, clip1: Clip, clip2: Clip, phase: float,
                     old_gait: str, gait: str, planted=None) -> Transition:
    """The transition from ``clip1`` at generic time ``phase`` (cycles) into ``clip2``.

    ``planted`` (4,) bool, optional: the feet down on the frame played before (the
    steady clip, sampled between its frames, may put a foot down a frame before the
    transition's whole-frame copy of it does); such a foot stays down into the
    transition's first contact when that begins within the short-lift gap
    (:data:`MIN_AIR`), instead of lifting for a frame and striking again.
    """
    ph = phase % 1.0
    # one cycle of M1 before, so the transition starts one frame after frame f0
    m = transition_motion(character, clip1, clip2, t_start=ph, before=1.0, after=1.0)
    n0 = round((1.0 + ph) * clip1.frames)
    f0 = n0 - 1
    lt = leg_times(clip1, clip2, (n0 - 1) / clip1.frames)
    # on the ground: the foot phase, or the transition's foot at the ground; a lift of a
    # frame or two between two contacts (a leg switching clips) is no step
    held = m.foot_positions()[..., 1] <= GROUND_BAND
    on = (m.extras["foot_phase"] != FLIGHT) | held
    if planted is not None:
        on[f0] |= np.asarray(planted, dtype=bool)   # the frame before the first played one
    stance = np.ascontiguousarray(fill_gaps(on, max(1, round(MIN_AIR * m.fps))))
    # played through one cycle of M2 after the blend (root and feet settle)
    return Transition(m, f0, len(m) - 1, lt["end"] + (len(m) - 1 - f0 - lt["B"]) / clip2.frames,
                      clip2, gait, stance, f"{old_gait}->{gait}")


__all__ = ["AUTO_GAITS", "CLIP_ANCHORED", "HYSTERESIS", "MIN_AIR", "SPEED_REACH", "SPEED_STEP",
           "ClipPlayer", "Transition", "auto_gaits", "fill_gaps", "gait_law", "start_transition"]
