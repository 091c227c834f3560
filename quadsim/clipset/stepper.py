"""Stepping the procedural controller for clips: any step, recorded, cut at a touchdown.

A clip set's loops must close without a seam and line up in phase. The
procedural controller's stride is set by its CPG: in a steady gait every leg's
oscillator turns at the stride frequency ``f`` (``ProceduralController.freq``),
locked to the gait's phase offsets, so the motion repeats every ``1 / f``
seconds. :class:`Stepper` steps one controller with steps of any length and
records the packed plan of each step (the posing kernel's input); the
functions below drive it:

- :func:`loop_step`: the step ``dt`` that makes ``n`` strides an exact number
  of frames ``N`` (``N dt = n / f``), the frames then labelled at the clip's
  frame rate -- a time scale of at most ``1 / (2 N)``, recorded.
- :meth:`Stepper.to_touchdown`: steps of ``dt`` up to the left hind foot's
  next touchdown (its oscillator's phase a whole number of turns) and one
  shorter step onto it, so every clip starts or ends at the same phase.
- :func:`steady_cycle`: warm up at a command, cut at a touchdown, and record
  whole loops until one closes on its start.

Legs are LF, RF, LH, RH (the left hind foot is leg 2); units SI.
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from quadsim.clipset.rows import closure
from quadsim.commands import Command
from quadsim.locomotion.controller import ProceduralController
from quadsim.locomotion.cpg import TWO_PI

__all__ = ["LEFT_HIND", "Recording", "Stepper", "loop_step", "steady_cycle"]

#: The leg whose touchdown starts every loop (LF, RF, LH, RH).
LEFT_HIND = 2
#: Longest loop tried for a frame count close to a whole number: this many strides,
#: and no more than :data:`MAX_LOOP_SECONDS` (one stride at least).
MAX_STRIDES = 6
MAX_LOOP_SECONDS = 3.0
#: A loop's time scale (frames at the clip rate against strides simulated) good
#: enough to stop trying more strides.
GOOD_SCALE = 0.005


class Recording:
    """What a :class:`Stepper` recorded: one entry per frame, frame 0 the state
    at the start.

    Attributes
    ----------
    rows : ndarray, shape (T, F)
        Packed plans (:mod:`quadsim.locomotion.pose_kernel`).
    contacts : ndarray of bool, shape (T, 4)
        Planned stance.
    theta : ndarray, shape (T, 4)
        Unwrapped oscillator phases (rad).
    gaits : ndarray of str, shape (T,)
    speed, duty, freq : ndarray, shape (T,)
        Forward speed (m/s), duty factor and stride frequency (Hz).
    dt : float
        The step between frames (s) as simulated.
    """

    def __init__(self, frames: list[tuple], dt: float):
        self.rows = np.array([f[0] for f in frames])
        self.contacts = np.array([f[1] for f in frames], dtype=bool)
        self.theta = np.array([f[2] for f in frames])
        self.gaits = np.array([f[3] for f in frames], dtype=object)
        self.speed = np.array([f[4] for f in frames])
        self.duty = np.array([f[5] for f in frames])
        self.freq = np.array([f[6] for f in frames])
        self.dt = float(dt)

    def __len__(self) -> int:
        return len(self.rows)


class Stepper:
    """One :class:`~quadsim.locomotion.controller.ProceduralController` stepped with
    steps of any length, its plans recorded on demand.

    Parameters
    ----------
    character : Character
    gait : str, optional
        Starting gait (default standing).
    seed : int
        The oscillators' seed.
    """

    def __init__(self, character, gait: str | None = None, seed: int = 0):
        self.character = character
        self.ctl = ProceduralController(character, dt=1.0 / 60.0, seed=seed, gait=gait)
        self._last = None
        self._frames: list[tuple] | None = None
        self.step(Command(speed=0.0, gait=gait), 0.0)  # the start's own plan

    def step(self, command: Command, dt: float) -> None:
        """Advance ``dt`` seconds under ``command``; record the new state if recording."""
        with warnings.catch_warnings():
            if self._frames is None:  # clamps while warming up (speeding up) are expected
                warnings.simplefilter("ignore")
            out = self.ctl._plan(command, dt, True)
        self._last = out.packed[0].copy()
        if self._frames is not None:
            self._frames.append(self._snapshot())

    def _snapshot(self) -> tuple:
        st = self.ctl.state
        return (self._last, st.feet.stance[0].copy(), st.cpg.theta[0].copy(), self.ctl.gait,
                float(st.motion.speed[0]), float(st.schedule.params.duty[0]),
                float(st.cpg.freq[0]))

    def record(self) -> None:
        """Start recording, the present state as frame 0."""
        self._frames = [self._snapshot()]

    def take(self, dt: float) -> Recording:
        """Stop recording; the frames recorded since :meth:`record`."""
        frames, self._frames = self._frames, None
        if frames is None:
            raise RuntimeError("take() without record()")
        return Recording(frames, dt)

    def run(self, command: Command, seconds: float, dt: float) -> None:
        """Steps of ``dt`` for ``seconds`` (rounded to whole steps)."""
        for _ in range(max(int(round(seconds / dt)), 0)):
            self.step(command, dt)

    @property
    def last_row(self) -> np.ndarray:
        """The packed plan of the present state, shape (F,)."""
        return self._last

    @property
    def lh_phase(self) -> float:
        """The left hind oscillator's unwrapped phase (rad)."""
        return float(self.ctl.state.cpg.theta[0, LEFT_HIND])

    def to_touchdown(self, command: Command, dt: float, target: float | None = None
                     ) -> tuple[float, float]:
        """Steps of ``dt``, then one of at most ``dt``, ending on the left hind foot's
        touchdown: its phase at ``target`` (rad, a whole number of turns; default the next
        one), at the present stride frequency. Returns the last step's length (s, 0 when
        already there) and the target."""
        if target is None:
            target = math.ceil(self.lh_phase / TWO_PI + 1e-9) * TWO_PI
        for _ in range(100_000):
            rate = TWO_PI * self.ctl.freq
            if self.lh_phase + rate * dt >= target - 1e-12:
                break
            self.step(command, dt)
        rest = (target - self.lh_phase) / (TWO_PI * self.ctl.freq)
        if rest > 1e-12:
            self.step(command, rest)
        return max(rest, 0.0), target

    def state_copy(self):
        """A copy of the controller's whole state (restore with :meth:`restore`)."""
        return (_copy(self.ctl.state), self.ctl.time, self._last.copy())

    def restore(self, saved) -> None:
        """Put back a state from :meth:`state_copy`."""
        state, t, last = saved
        _copy_into(state, self.ctl.state)
        self.ctl.time = t
        self._last = last.copy()
        self.ctl._label = self.ctl._current_label()


def _copy(bundle):
    if isinstance(bundle, np.ndarray):
        return bundle.copy()
    return type(bundle)(*(_copy(x) for x in bundle))


def _copy_into(src, dst) -> None:
    if isinstance(dst, np.ndarray):
        dst[...] = src
        return
    for a, b in zip(src, dst):
        _copy_into(a, b)


def loop_step(freq: float, fps: float) -> tuple[int, int, float]:
    """The strides ``n``, frames ``N`` and step ``dt`` (s) of a loop at stride frequency
    ``freq`` (Hz) for a clip at ``fps``: ``N dt = n / freq`` exactly, with ``N`` the whole
    number of frames nearest to ``n fps / freq``; the fewest strides (at most
    :data:`MAX_STRIDES`, and :data:`MAX_LOOP_SECONDS`) whose time scale
    ``|N / (n fps / freq) - 1|`` is under :data:`GOOD_SCALE`, else the strides with the
    least."""
    best = None
    most = max(1, min(MAX_STRIDES, int(MAX_LOOP_SECONDS * freq)))
    for n in range(1, most + 1):
        exact = n * fps / freq
        N = max(int(round(exact)), 2)
        scale = abs(N / exact - 1.0)
        if best is None or scale < best[0] - 1e-12:
            best = (scale, n, N)
        if scale <= GOOD_SCALE:
            break
    _, n, N = best
    return n, N, n / freq / N


def steady_cycle(stepper: Stepper, command: Command, fps: float, *, warm: float,
                 tol: float = 1e-5, max_loops: int = 8) -> tuple[Recording, int, float]:
    """A steady loop of ``command``, cut at the left hind foot's touchdown.

    Warms up for ``warm`` seconds at ``1 / fps`` (straight first, then with the
    command's turn), sets the step so that whole strides are a whole number of
    frames (:func:`loop_step`), settles two more seconds, steps onto a touchdown
    and records loops until one closes on its own start within ``tol`` (the
    largest change of any packed plan value after taking out the travel, m or
    rad) or ``max_loops`` are done.

    Returns
    -------
    recording : Recording
        ``N + 1`` frames: the loop's start and its ``N`` steps, the last at the
        touchdown ``n`` strides on (the stepper is left there).
    strides : int
    closure : float
        The last loop's closure (see ``tol``).
    """
    dt0 = 1.0 / fps
    straight = Command(speed=command.speed, gait=command.gait)
    stepper.run(straight, warm, dt0)
    if command.turn_rate:
        stepper.run(command, 2.0, dt0)
    n, N, dt = loop_step(stepper.ctl.freq, fps)
    stepper.run(command, 2.0, dt)
    stepper.to_touchdown(command, dt)
    for _ in range(max_loops):
        stepper.record()
        for _ in range(N):
            stepper.step(command, dt)
        rec = stepper.take(dt)
        gap = closure(rec.rows)
        if gap <= tol:
            break
    return rec, n, gap
