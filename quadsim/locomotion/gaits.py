"""Gaits as data: footfall tables, duty factors and stride laws per character.

The shared table ``characters/gaits.toml`` states each gait in dimensionless
form (Froude numbers, stride length relative to hip height). A character's
file may override any field under ``[gaits.<name>]``, e.g. real speed ranges
in m/s. Dynamic similarity (Alexander and Jayes 1983) turns the table into
speeds and strides for a character of hip height ``h``:

``v = sqrt(Fr g h)``, ``lambda = h * stride * Fr^0.3``.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np

from quadsim.errors import InputError
from quadsim.frames import GRAVITY
from quadsim.skeleton.character import Character, characters_dir

#: The standing state: every foot planted (duty factor 1), entered when the
#: commanded speed is zero and left when it is not. Its id follows the gaits'.
STAND = "stand"
#: Other names a user may give a gait by.
ALIASES = {"gallop": "transverse_gallop"}
#: Default foot clearance at mid-swing (fraction of the hip height) and
#: stride coefficient, for a gait whose table gives none.
DEFAULT_SWING_HEIGHT = 0.12
DEFAULT_STRIDE = 2.3
#: Default body drop (fraction of the hip height) of a gait whose table
#: gives none.
DEFAULT_DROP = 0.03
_FIELDS = {"duty", "phase", "froude", "speed", "stride", "swing_height", "spine",
           "spine_deg", "drop"}


@dataclass(frozen=True, eq=False)
class Gait:
    """One gait of one character.

    Attributes
    ----------
    name : str
    duty_range : (float, float)
        Duty factor at the slow and the fast end of ``speed_range``.
    phases : ndarray, shape (4,)
        Touchdown phase of LF, RF, LH, RH after LH's, fractions of a stride.
    speed_range : (float, float)
        Speeds the gait is used at (m/s).
    stride_coefficient : float
        ``lambda / h = stride_coefficient * Fr^0.3``.
    swing_height : float
        Foot clearance at mid-swing (m).
    spine : str
        ``"flex"`` or ``"bound"``.
    spine_amplitude : float
        Amplitude of the spine's compress/stretch motion (rad), flex gaits.
    drop : float
        Fraction of the hip height the body is lowered by in this gait.
    hip_height : float
        The character's hip height (m), for the Froude laws.
    """

    name: str
    duty_range: tuple[float, float]
    phases: np.ndarray
    speed_range: tuple[float, float]
    stride_coefficient: float
    swing_height: float
    spine: str
    spine_amplitude: float
    drop: float
    hip_height: float

    @property
    def preferred_speed(self) -> float:
        """Middle of the speed range (m/s)."""
        return 0.5 * (self.speed_range[0] + self.speed_range[1])

    def _s(self, v):
        lo, hi = self.speed_range
        return np.clip((np.asarray(v, dtype=float) - lo) / (hi - lo), 0.0, 1.0)

    def duty(self, v):
        """Duty factor at speed ``v`` (m/s), linear over the speed range."""
        s = self._s(v)
        return self.duty_range[0] + s * (self.duty_range[1] - self.duty_range[0])

    def stride_length(self, v):
        """Natural stride length at speed ``v`` (m), Alexander's law.

        Below the gait's lowest speed the stride frequency is held, so the
        stride shortens in proportion to the speed.
        """
        v = np.asarray(v, dtype=float)
        vc = np.maximum(v, self.speed_range[0])
        fr = vc * vc / (GRAVITY * self.hip_height)
        lam = self.hip_height * self.stride_coefficient * fr ** 0.3
        return np.where(v < vc, lam * v / vc, lam)

    def froude(self, v):
        v = np.asarray(v, dtype=float)
        return v * v / (GRAVITY * self.hip_height)


def _check_pair(v, where, lo=None, hi=None):
    if (not isinstance(v, list) or len(v) != 2
            or not all(isinstance(x, (int, float)) and math.isfinite(x) for x in v)):
        raise InputError(f"{where} must be a list of two numbers")
    if lo is not None and not all(lo <= x <= hi for x in v):
        raise InputError(f"{where} values must lie in [{lo}, {hi}], got {v}")
    return float(v[0]), float(v[1])


@lru_cache(maxsize=8)
def _shared_table(path: str) -> dict:
    try:
        return tomllib.loads(Path(path).read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise InputError(f"{path}: gait table not found") from None
    except tomllib.TOMLDecodeError as e:
        raise InputError(f"{path}: not valid TOML ({e})") from None


def _table_path() -> str:
    return str(characters_dir() / "gaits.toml")


def gait_names() -> tuple[str, ...]:
    """Every gait of the shared gait table (``gaits.toml``), in its order."""
    return tuple(k for k, v in _shared_table(_table_path()).items() if isinstance(v, dict))


def gait_ids() -> tuple[str, ...]:
    """The gait ids of the compiled plan: the gait table's gaits in its
    order, then :data:`STAND` (a gait's id is its index here)."""
    return gait_names() + (STAND,)


def resolve_gait_name(name: str, character: Character | None = None) -> str:
    """Canonical gait identifier; ``InputError`` if unknown (to the character)."""
    key = ALIASES.get(str(name).strip().lower(), str(name).strip().lower())
    known = gait_names()
    allowed = list(character.locomotion.get("gaits", known)) if character else list(known)
    if key not in known or key not in allowed:
        who = f" for {character.id}" if character else ""
        raise InputError(f"unknown gait {name!r}{who}; choose one of: {', '.join(allowed)}"
                         + (" (or 'gallop' for transverse_gallop)"
                            if "transverse_gallop" in allowed else ""))
    return key


def gait_table(character: Character) -> dict[str, Gait]:
    """Every gait the character has, with its own speeds and strides."""
    return _gait_table(character)


_TABLES: dict[int, dict[str, Gait]] = {}


def _gait_table(character: Character) -> dict[str, Gait]:
    hit = _TABLES.get(id(character))
    if hit is not None and hit.get("__owner__") is character:
        return {k: v for k, v in hit.items() if k != "__owner__"}
    src = _table_path()
    shared = _shared_table(src)
    known = gait_names()
    where_c = str(character.path or character.id)
    names = character.locomotion.get("gaits", list(known))
    h = character.hip_height
    out: dict[str, Gait] = {}
    for n in names:
        if n not in known:
            raise InputError(f"{where_c}: locomotion.gaits names unknown gait {n!r}; "
                             f"known: {', '.join(known)}")
        if n not in shared:
            raise InputError(f"{src}: no table for gait {n!r}")
        d = dict(shared[n])
        over = character.gait_overrides.get(n, {})
        bad = set(over) - _FIELDS
        if bad:
            raise InputError(f"{where_c}: gaits.{n}: unknown key(s) {sorted(bad)}; "
                             f"allowed: {', '.join(sorted(_FIELDS))}")
        d.update(over)
        w = f"{where_c}: gaits.{n}" if over else f"{src}: {n}"
        duty = _check_pair(d.get("duty"), f"{w}.duty", 0.05, 1.0)
        ph = d.get("phase")
        if (not isinstance(ph, list) or len(ph) != 4
                or not all(isinstance(x, (int, float)) for x in ph)):
            raise InputError(f"{w}.phase must be four numbers (LF, RF, LH, RH)")
        if "speed" in over or ("speed" in d and "froude" not in over):
            if "speed" in d:
                sp = _check_pair(d["speed"], f"{w}.speed", 0.0, 40.0)
            else:
                fr = _check_pair(d.get("froude"), f"{w}.froude", 0.0, 100.0)
                sp = tuple(math.sqrt(f * GRAVITY * h) for f in fr)
        else:
            fr = _check_pair(d.get("froude"), f"{w}.froude", 0.0, 100.0)
            sp = tuple(math.sqrt(f * GRAVITY * h) for f in fr)
        if not sp[0] < sp[1]:
            raise InputError(f"{w}: speed range must increase, got {sp}")
        spine = d.get("spine", "flex")
        if spine not in ("flex", "bound"):
            raise InputError(f"{w}.spine must be 'flex' or 'bound', got {spine!r}")
        ph_arr = np.mod(np.asarray(ph, dtype=float), 1.0)
        ph_arr.setflags(write=False)
        out[n] = Gait(
            name=n, duty_range=duty, phases=ph_arr, speed_range=(float(sp[0]), float(sp[1])),
            stride_coefficient=float(d.get("stride", DEFAULT_STRIDE)),
            swing_height=float(d.get("swing_height", DEFAULT_SWING_HEIGHT)) * h,
            spine=spine, spine_amplitude=math.radians(float(d.get("spine_deg", 3.0))),
            drop=float(d.get("drop", _DEFAULT_DROP.get(n, DEFAULT_DROP))),
            hip_height=h,
        )
    _TABLES[id(character)] = dict(out, __owner__=character)
    return out


#: Body drops of the shipped gaits whose table gives none (a gait's own
#: ``drop`` in the table wins).
_DEFAULT_DROP = {"walk": 0.01, "amble": 0.03, "rack": 0.04, "trot": 0.04, "pace": 0.04,
                 "canter": 0.06, "transverse_gallop": 0.08, "rotary_gallop": 0.08}


def auto_gaits(character: Character) -> list[str]:
    """Gaits chosen automatically by speed, slowest first."""
    table = gait_table(character)
    auto = character.locomotion.get("auto", list(table))
    for n in auto:
        if n not in table:
            raise InputError(f"{character.path or character.id}: locomotion.auto names "
                             f"{n!r}, which is not among its gaits")
    return sorted(auto, key=lambda n: table[n].speed_range[0])


def max_speed(character: Character) -> float:
    """The top of the fastest gait's speed range (m/s)."""
    return max(g.speed_range[1] for g in gait_table(character).values())
