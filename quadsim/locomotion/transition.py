"""Gait choice by speed with hysteresis, and smooth gait transitions, compiled.

A transition moves every gait parameter from its value when the transition
starts to the new gait's along the seed's duty-factor curve
``beta(t) = beta_1 + alpha t^2``, ``alpha = (beta_2 - beta_1) / T^2``
(Su and Lu, equations 1-2; after Chew et al.). The same progress
``(t / T)^2`` carries the phase offsets (each along the shorter way round
the circle), the stride law, the swing height and the spine mode, so the
CPG re-phases the legs smoothly; any two gaits can follow each other, at any
phase of the stride.

The compiled functions here (:func:`target_into`, :func:`blend_into`,
:func:`auto_choice`, :func:`advance_schedule`) are the scheduler stage of the
plan (:func:`quadsim.locomotion.plan_kernels.plan_rows`). :class:`GaitParams`
and :class:`GaitScheduler` are their one-row Python faces: the tests drive
the scheduler through them, so what they specify is what runs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from itertools import pairwise

import numpy as np
from numba import njit

from quadsim.locomotion.bundles import GaitRows, GaitTables, ScheduleState, new_gait_rows
from quadsim.locomotion.gaits import STAND, Gait
from quadsim.locomotion.rowmath import plan_inner

#: Length of the transition out of standing (s): setting off is quicker
#: than a change between two gaits.
STAND_TRANSITION_TIME = 0.6
#: A transition between gaits lasts this many stride periods ...
TRANSITION_STRIDES = 1.5
#: ... but no less than this (s) ...
MIN_TRANSITION_TIME = 0.5
#: ... and no more than this (s).
MAX_TRANSITION_TIME = 2.0
#: Relative half-width of the band around each speed boundary in which the
#: current gait is kept (no flicker).
HYSTERESIS = 0.06


@plan_inner
def _frac(x):
    """``x % 1.0`` (Python's float modulo) as ``x - floor(x)``: the same value
    for every float, without the library ``fmod`` call."""
    return x - math.floor(x)


@plan_inner
def duty_at(lo, hi, d0, d1, speed):
    """The duty factor at ``speed`` (m/s) of a gait of speed range ``lo..hi``
    and duty factors ``d0..d1``: linear over the range, held outside it."""
    s = min(max((speed - lo) / (hi - lo), 0.0), 1.0)
    return d0 + s * (d1 - d0)


@njit(inline="always")  # a bundle passed per row costs more than the body
def target_into(tables, k, g, speed, out, m):
    """``GaitParams.of`` gait ``g`` of kind ``k`` at ``speed`` (m/s) into row
    ``m`` of ``out`` (:class:`~quadsim.locomotion.bundles.GaitRows`): the
    duty factor linear over the gait's speed range, the rest as tabled."""
    lo = tables.speed_lo[k, g]
    out.duty[m] = duty_at(tables.speed_lo[k, g], tables.speed_hi[k, g], tables.duty_lo[k, g],
                          tables.duty_hi[k, g], speed)
    for i in range(4):
        out.phases[m, i] = tables.phases[k, g, i]
    out.stride_coefficient[m] = tables.stride_coefficient[k, g]
    out.min_speed[m] = lo
    out.swing_height[m] = tables.swing_height[k, g]
    out.drop[m] = tables.drop[k, g]
    out.bound[m] = tables.bound[k, g]
    out.spine_amplitude[m] = tables.spine_amplitude[k, g]


@njit(inline="always")  # a bundle passed per row costs more than the body
def blend_into(src, n, out, m, s):
    """Row ``m`` of ``out`` moved a fraction ``s`` of the way from row ``n`` of
    ``src`` (in place): every parameter linearly, the phases along the
    shorter way round the stride circle."""
    out.duty[m] = src.duty[n] + s * (out.duty[m] - src.duty[n])
    for i in range(4):
        a = src.phases[n, i]
        dpsi = _frac(out.phases[m, i] - a + 0.5) - 0.5
        out.phases[m, i] = _frac(a + s * dpsi)
    out.stride_coefficient[m] = src.stride_coefficient[n] + s * (
        out.stride_coefficient[m] - src.stride_coefficient[n])
    out.min_speed[m] = src.min_speed[n] + s * (out.min_speed[m] - src.min_speed[n])
    out.swing_height[m] = src.swing_height[n] + s * (out.swing_height[m] - src.swing_height[n])
    out.drop[m] = src.drop[n] + s * (out.drop[m] - src.drop[n])
    out.bound[m] = src.bound[n] + s * (out.bound[m] - src.bound[n])
    out.spine_amplitude[m] = src.spine_amplitude[n] + s * (
        out.spine_amplitude[m] - src.spine_amplitude[n])


@njit(inline="always")  # a bundle passed per row costs more than the body
def scheduled_into(tables, k, g, in_tr, elapsed, duration, source, n, speed, out, m):
    """The blended parameters of gait ``g`` of kind ``k`` at ``speed`` into row
    ``m`` of ``out``: during a transition (``in_tr``) moved from row ``n`` of
    its start ``source`` by the progress ``(elapsed / duration)^2``."""
    target_into(tables, k, g, speed, out, m)
    if in_tr:
        s = min(elapsed / duration, 1.0) ** 2
        blend_into(source, n, out, m, s)


@plan_inner
def auto_choice(tables, k, current, speed, hysteresis):
    """The automatic gait id of kind ``k`` for ``speed`` (m/s), keeping
    ``current`` while the speed is inside its band widened by ``hysteresis``."""
    na = tables.n_auto[k]
    kpos = tables.auto_pos[k, current]
    if kpos >= 0:
        lo = tables.bounds[k, kpos - 1] * (1 - hysteresis) if kpos > 0 else -math.inf
        hi = tables.bounds[k, kpos] * (1 + hysteresis) if kpos < na - 1 else math.inf
        if lo <= speed <= hi:
            return current
    idx = 0
    for j in range(na - 1):
        if tables.bounds[k, j] <= speed:
            idx += 1
    return tables.auto[k, idx]


@plan_inner
def advance_schedule(tables, kinds, sched, wanted, speed, dt, period, stand):
    """One step of every row ``n`` of the scheduler ``sched``: the running
    transition advances by ``dt`` (s); if ``wanted[n]`` differs from the
    current gait a transition to it starts from the parameters now (lasting
    :data:`STAND_TRANSITION_TIME` out of the standing state ``stand``, else
    :data:`TRANSITION_STRIDES` stride periods ``period[n]`` s, within
    [:data:`MIN_TRANSITION_TIME`, :data:`MAX_TRANSITION_TIME`]); then the
    parameters at ``speed[n]`` (m/s) go into ``sched.params[n]``. ``kinds``
    (N,) index ``tables``.
    """
    current, source_name, in_transition = sched.current, sched.source_name, sched.in_transition
    elapsed, duration, source, params = sched.elapsed, sched.duration, sched.source, \
        sched.params
    for n in range(current.shape[0]):
        k = kinds[n]
        v = speed[n]
        if in_transition[n]:
            elapsed[n] += dt
            if elapsed[n] >= duration[n]:
                in_transition[n] = False
        starts = wanted[n] != current[n]
        # one call site of the inlined blend (each is typed and lowered again):
        # when a transition starts, the first pass finds the parameters now --
        # its start, copied to ``source`` -- the second those of this step
        for j in range(2 if starts else 1):
            scheduled_into(tables, k, current[n], in_transition[n], elapsed[n], duration[n],
                           source, n, v, params, n)
            if starts and j == 0:
                cur = current[n]
                _copy_row(params, n, source, n)
                source_name[n] = cur
                current[n] = wanted[n]
                in_transition[n] = True
                elapsed[n] = 0.0
                duration[n] = STAND_TRANSITION_TIME if cur == stand else min(
                    max(TRANSITION_STRIDES * period[n], MIN_TRANSITION_TIME),
                    MAX_TRANSITION_TIME)


@njit(inline="always")  # a bundle passed per row costs more than the body
def _copy_row(src, n, out, m):
    out.duty[m] = src.duty[n]
    for i in range(4):
        out.phases[m, i] = src.phases[n, i]
    out.stride_coefficient[m] = src.stride_coefficient[n]
    out.min_speed[m] = src.min_speed[n]
    out.swing_height[m] = src.swing_height[n]
    out.drop[m] = src.drop[n]
    out.bound[m] = src.bound[n]
    out.spine_amplitude[m] = src.spine_amplitude[n]


@njit(cache=True)
def _scheduler_step(tables, sched, wanted, speed, dt, period, stand):
    advance_schedule(tables, np.zeros(1, dtype=np.int64), sched, np.array([wanted]),
                     np.array([speed]), dt, np.array([period]), stand)


@njit(cache=True)
def _target(tables, g, speed, out):
    target_into(tables, 0, g, speed, out, 0)


@njit(cache=True)
def _blend(src, out, s):
    blend_into(src, 0, out, 0, s)


@njit(cache=True)
def _choice(tables, current, speed, hysteresis):
    return auto_choice(tables, 0, current, speed, hysteresis)


# ------------------------------------------------------------ the tables
def gait_tables(kinds, ids: tuple[str, ...]) -> GaitTables:
    """The compiled scheduler's tables for kinds of character.

    Parameters
    ----------
    kinds : sequence of (dict of str to Gait, list of str)
        Each kind's gaits by name (the standing state included, if any) and
        its automatic gaits, slowest first.
    ids : tuple of str
        The gait ids: the gait axis G of every table.
    """
    K, G = len(kinds), len(ids)
    A = max(len(auto) for _, auto in kinds)
    nan = np.full((K, G), np.nan)
    t = {f: nan.copy() for f in ("speed_lo", "speed_hi", "duty_lo", "duty_hi",
                                 "stride_coefficient", "swing_height", "drop", "bound",
                                 "spine_amplitude")}
    phases = np.full((K, G, 4), np.nan)
    auto_ids = np.full((K, A), -1, dtype=np.int64)
    bounds = np.full((K, A), np.inf)
    auto_pos = np.full((K, G), -1, dtype=np.int64)
    n_auto = np.zeros(K, dtype=np.int64)
    for k, (gaits, auto) in enumerate(kinds):
        for name, gait in gaits.items():
            g = ids.index(name)
            t["speed_lo"][k, g], t["speed_hi"][k, g] = gait.speed_range
            t["duty_lo"][k, g], t["duty_hi"][k, g] = gait.duty_range
            phases[k, g] = gait.phases
            t["stride_coefficient"][k, g] = gait.stride_coefficient
            t["swing_height"][k, g] = gait.swing_height
            t["drop"][k, g] = gait.drop
            t["bound"][k, g] = 1.0 if gait.spine == "bound" else 0.0
            t["spine_amplitude"][k, g] = gait.spine_amplitude
        ranges = [gaits[a].speed_range for a in auto]
        b = [0.5 * (x[1] + y[0]) for x, y in pairwise(ranges)]
        auto_ids[k, :len(auto)] = [ids.index(a) for a in auto]
        bounds[k, :len(b)] = b
        auto_pos[k, auto_ids[k, :len(auto)]] = np.arange(len(auto))
        n_auto[k] = len(auto)
    return GaitTables(phases=phases, auto=auto_ids, bounds=bounds, auto_pos=auto_pos,
                      n_auto=n_auto, **t)


# ------------------------------------------------------------ one-row faces
@dataclass(frozen=True)
class GaitParams:
    """The blendable parameters of a gait at one speed.

    Attributes
    ----------
    duty : float
    phases : ndarray, shape (4,)
    stride_coefficient : float
    min_speed : float
        Lowest speed of the gait's range (m/s); below it strides shorten.
    swing_height : float
        m.
    drop : float
        Fraction of hip height the body is lowered by.
    bound : float
        Weight of the bounding spine (0 for flex gaits, 1 for bound gaits).
    spine_amplitude : float
        rad.
    """

    duty: float
    phases: np.ndarray
    stride_coefficient: float
    min_speed: float
    swing_height: float
    drop: float
    bound: float
    spine_amplitude: float

    @classmethod
    def of(cls, gait: Gait, speed: float) -> GaitParams:
        """The parameters of ``gait`` at ``speed`` (m/s), by :func:`target_into`."""
        rows = new_gait_rows(1)
        _target(gait_tables([({gait.name: gait}, [gait.name])], (gait.name,)), 0, float(speed),
                rows)
        return cls.from_rows(rows, 0)

    @classmethod
    def from_rows(cls, rows: GaitRows, n: int) -> GaitParams:
        """Row ``n`` of a :class:`~quadsim.locomotion.bundles.GaitRows`."""
        return cls(float(rows.duty[n]), np.array(rows.phases[n]),
                   *(float(f[n]) for f in rows[2:]))

    def rows(self) -> GaitRows:
        """These parameters as a one-row :class:`~quadsim.locomotion.bundles.GaitRows`."""
        return GaitRows(np.array([self.duty], dtype=float),
                        np.array([self.phases], dtype=float),
                        *(np.array([getattr(self, f)], dtype=float)
                          for f in GaitRows._fields[2:]))

    def blend(self, other: GaitParams, s: float) -> GaitParams:
        """``self`` moved a fraction ``s`` of the way to ``other`` (:func:`blend_into`)."""
        out = other.rows()
        _blend(self.rows(), out, float(s))
        return GaitParams.from_rows(out, 0)


class GaitScheduler:
    """One row of the compiled scheduler (:func:`advance_schedule`), by name.

    Parameters
    ----------
    gaits : dict of str to Gait
    auto : list of str
        Gaits chosen by speed, slowest first.
    initial : str
        Starting gait.
    hysteresis : float
        Relative half-width of the band around each speed boundary in which
        the current gait is kept (no flicker).
    stand : str, optional
        The standing state, left by the quicker transition.
    """

    def __init__(self, gaits: dict[str, Gait], auto: list[str], initial: str,
                 hysteresis: float = HYSTERESIS, stand: str = STAND):
        self.names = tuple(gaits)
        self.auto = list(auto)
        self.hysteresis = float(hysteresis)
        self.tables = gait_tables([(gaits, self.auto)], self.names)
        self.bounds = self.tables.bounds[0, :len(self.auto) - 1].copy()
        self._stand = self.names.index(stand) if stand in self.names else -2
        g = self.names.index(initial)
        self.state = ScheduleState(np.array([g], dtype=np.int64), np.array([g], dtype=np.int64),
                                   np.zeros(1, dtype=bool), np.zeros(1), np.zeros(1),
                                   new_gait_rows(1), new_gait_rows(1))

    current = property(lambda self: self.names[self.state.current[0]],
                       doc="The gait run, or entered by the transition.")
    source_name = property(lambda self: self.names[self.state.source_name[0]])
    in_transition = property(lambda self: bool(self.state.in_transition[0]))
    elapsed = property(lambda self: float(self.state.elapsed[0]))
    duration = property(lambda self: float(self.state.duration[0]))

    @property
    def label(self) -> str:
        """``"old->new"`` during a transition, else the gait."""
        return f"{self.source_name}->{self.current}" if self.in_transition else self.current

    def auto_choice(self, speed: float) -> str:
        """The automatic gait for ``speed``, keeping the current one inside its band."""
        return self.names[_choice(self.tables, self.state.current[0], float(speed),
                                  self.hysteresis)]

    def update(self, wanted: str, speed: float, dt: float, stride_period: float) -> GaitParams:
        """Advance by ``dt``; start a transition when ``wanted`` differs.

        A transition lasts 1.5 strides (between 0.5 and 2 s), or 0.6 s out
        of standing. Returns the parameters to use for this step.
        """
        _scheduler_step(self.tables, self.state, self.names.index(wanted), float(speed),
                        float(dt), float(stride_period), self._stand)
        return GaitParams.from_rows(self.state.params, 0)
