"""Gait choice by speed with hysteresis, and smooth gait transitions.

A transition moves every gait parameter from its value when the transition
starts to the new gait's along the seed's duty-factor curve
``beta(t) = beta_1 + alpha t^2``, ``alpha = (beta_2 - beta_1) / T^2``
(Su and Lu, equations 1-2; after Chew et al.). The same progress
``(t / T)^2`` carries the phase offsets (each along the shorter way round
the circle), the stride law, the swing height and the spine mode, so the
CPG re-phases the legs smoothly; any two gaits can follow each other, at any
phase of the stride.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from quadsim.locomotion.gaits import Gait


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
        return cls(float(gait.duty(speed)), np.asarray(gait.phases, dtype=float),
                   gait.stride_coefficient, gait.speed_range[0], gait.swing_height,
                   gait.drop, 1.0 if gait.spine == "bound" else 0.0, gait.spine_amplitude)

    def blend(self, other: GaitParams, s: float) -> GaitParams:
        """``self`` moved a fraction ``s`` of the way to ``other``."""
        def lerp(a, b):
            return a + s * (b - a)

        dpsi = np.mod(other.phases - self.phases + 0.5, 1.0) - 0.5
        return GaitParams(
            lerp(self.duty, other.duty), np.mod(self.phases + s * dpsi, 1.0),
            lerp(self.stride_coefficient, other.stride_coefficient),
            lerp(self.min_speed, other.min_speed), lerp(self.swing_height, other.swing_height),
            lerp(self.drop, other.drop), lerp(self.bound, other.bound),
            lerp(self.spine_amplitude, other.spine_amplitude))

    def stride_length(self, speed: float, hip_height: float) -> float:
        """Natural stride length (m) at ``speed`` (Alexander's law, see gaits)."""
        vc = max(speed, self.min_speed, 1e-3)
        lam = hip_height * self.stride_coefficient * (vc * vc / (9.81 * hip_height)) ** 0.3
        return lam * speed / vc if speed < vc else lam


class GaitScheduler:
    """Chooses the gait and runs transitions.

    Parameters
    ----------
    gaits : dict of str to Gait
    auto : list of str
        Gaits chosen by speed, slowest first.
    hysteresis : float
        Relative half-width of the band around each speed boundary in which
        the current gait is kept (no flicker).
    initial : str
        Starting gait.
    """

    def __init__(self, gaits: dict[str, Gait], auto: list[str], initial: str,
                 speed: float = 0.0, hysteresis: float = 0.06):
        self.gaits = gaits
        self.auto = list(auto)
        self.hysteresis = hysteresis
        rng = [gaits[n].speed_range for n in self.auto]
        self.bounds = np.array([0.5 * (a[1] + b[0]) for a, b in zip(rng[:-1], rng[1:])])
        self.current = initial
        self.source: GaitParams | None = None
        self.source_name = initial
        self.elapsed = 0.0
        self.duration = 0.0
        self._last: tuple[str, float, GaitParams] | None = None

    @property
    def in_transition(self) -> bool:
        return self.source is not None

    @property
    def label(self) -> str:
        return f"{self.source_name}->{self.current}" if self.in_transition else self.current

    def auto_choice(self, speed: float) -> str:
        """The automatic gait for ``speed``, keeping the current one inside its band."""
        if self.current in self.auto:
            k = self.auto.index(self.current)
            lo = self.bounds[k - 1] * (1 - self.hysteresis) if k > 0 else -np.inf
            hi = self.bounds[k] * (1 + self.hysteresis) if k < len(self.bounds) else np.inf
            if lo <= speed <= hi:
                return self.current
        return self.auto[int(np.searchsorted(self.bounds, speed, side="right"))]

    def params(self, speed: float) -> GaitParams:
        """Blended parameters now, at ``speed``."""
        target = self.target(self.current, speed)
        if self.source is None:
            return target
        s = min(self.elapsed / self.duration, 1.0) ** 2
        return self.source.blend(target, s)

    def target(self, name: str, speed: float) -> GaitParams:
        """``GaitParams.of(gaits[name], speed)``, remembered for the last call."""
        last = self._last
        if last is not None and last[0] == name and last[1] == speed:
            return last[2]
        out = GaitParams.of(self.gaits[name], speed)
        self._last = (name, speed, out)
        return out

    def update(self, wanted: str, speed: float, dt: float, stride_period: float,
               duration: float | None = None) -> GaitParams:
        """Advance by ``dt``; start a transition when ``wanted`` differs.

        A transition lasts ``duration`` seconds if given, else 1.5 strides
        (between 0.5 and 2 s). Returns the parameters to use for this step.
        """
        if self.source is not None:
            self.elapsed += dt
            if self.elapsed >= self.duration:
                self.source = None
        if wanted != self.current:
            start = self.params(speed)
            self.source_name = self.current
            self.source = start
            self.current = wanted
            self.elapsed = 0.0
            self.duration = (float(duration) if duration is not None
                             else float(np.clip(1.5 * stride_period, 0.5, 2.0)))
        return self.params(speed)
