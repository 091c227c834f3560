"""The compiled stride figures are those of plain NumPy, on synthetic contacts and series."""

from __future__ import annotations

import math

import numpy as np
import pytest

from quadsim.analysis.appearance_kernels import STRIDE_MEDIANS, stride_medians
from quadsim.analysis.strides import _phases, _table
from quadsim.frames import GRAVITY
from quadsim.skeleton.contacts import _events

FPS = 60.0


def _synthetic(seed: int, T: int = 240):
    """Contacts of four feet (some from frame 0, some to the end) and wandering feet."""
    rng = np.random.default_rng(seed)
    c = np.zeros((T, 4), dtype=bool)
    for i in range(4):
        t = int(rng.integers(0, 12))
        while t < T:
            n = int(rng.integers(6, 30))
            c[t:t + n, i] = True
            t += n + int(rng.integers(4, 20))
    feet = np.cumsum(rng.normal(0.0, 0.01, (T, 4, 3)), axis=0)
    feet[..., 1] = np.where(c, 0.0, 0.05)
    return c, feet


def _table_numpy(evs, f):
    """The stride table leg by leg with NumPy (the reference)."""
    rows = []
    for i, ev in enumerate(evs):
        on, off = ev["on"], ev["off"]
        k = np.flatnonzero(np.isfinite(on[:-1]))
        mid = (ev["s"] + ev["e"]) // 2
        p = f[mid, i][:, [0, 2]]
        rows.append((np.full(len(k), i), on[k], off[k], on[k + 1],
                     np.linalg.norm(p[k + 1] - p[k], axis=-1)))
    return [np.concatenate(col) for col in zip(*rows)]


def _phases_numpy(td):
    ref, out = td[2], np.full(4, np.nan)
    for i, t in enumerate(td):
        k = np.searchsorted(ref, t, side="right") - 1
        ok = (k >= 0) & (k < len(ref) - 1)
        if ok.any():
            ph = (t[ok] - ref[k[ok]]) / (ref[k[ok] + 1] - ref[k[ok]])
            out[i] = (np.angle(np.mean(np.exp(2j * np.pi * ph))) / (2 * np.pi)) % 1.0
    out[2] = 0.0
    return np.where(out > 1.0 - 1e-9, 0.0, out)


@pytest.mark.parametrize("seed", range(6))
def test_the_compiled_stride_table_is_numpys_to_the_last_bit(seed):
    c, feet = _synthetic(seed)
    evs = _events(c, FPS, feet)
    got = _table(evs, feet)
    leg, td, lo, nxt, length = _table_numpy(evs, feet)
    assert np.array_equal(got["leg"], leg) and got["leg"].dtype == np.int64
    for k, want in (("touchdown", td), ("liftoff", lo), ("next_touchdown", nxt),
                    ("length", length), ("stance", lo - td), ("period", nxt - td)):
        assert np.array_equal(got[k], want, equal_nan=True), k
    assert np.isnan(_table(evs, None)["length"]).all()


@pytest.mark.parametrize("seed", range(6))
def test_the_compiled_phases_are_numpys_to_rounding(seed):
    c, feet = _synthetic(seed)
    td = [ev["on"][np.isfinite(ev["on"])] for ev in _events(c, FPS, feet)]
    np.testing.assert_allclose(_phases(td), _phases_numpy(td), rtol=0, atol=1e-12)
    few = [t[:1] for t in td]  # no whole stride of the left hind: no phases
    assert np.isnan(_phases(few)).all()


def _medians_numpy(td, root, series, h):
    """The appearance's stride figures stride by stride with NumPy (the reference)."""
    rows = [[] for _ in STRIDE_MEDIANS]
    for s0, e in zip(td[:-1], td[1:]):
        dur = (e - s0) / FPS
        dist = float(np.linalg.norm(root[e, [0, 2]] - root[s0, [0, 2]]))
        fr = (dist / dur) ** 2 / (GRAVITY * h)
        rows[0].append(dist / h)
        rows[1].append(2.3 * fr ** 0.3 if fr > 0 else np.nan)
        rows[2].append(fr)
        rows[3].append(math.sqrt(h / GRAVITY) / dur)
        for k, (x, scale) in enumerate(series):
            seg = x[s0:e + 1]
            rows[4 + k].append(scale(seg.max() - seg.min()))
    out = []
    for r in rows:
        r = np.asarray(r, dtype=float)
        r = r[np.isfinite(r)]
        out.append(np.median(r) if r.size else np.nan)
    return np.array(out)


@pytest.mark.parametrize("strides", [0, 1, 2, 7])
def test_the_compiled_stride_medians_are_numpys(strides):
    rng = np.random.default_rng(strides)
    T, h = 240, 0.4
    root = np.cumsum(rng.normal(0.01, 0.005, (T, 3)), axis=0)
    root[100:, :] = root[100]  # standing still from frame 100: a stride of no speed
    series = [(rng.normal(size=T), np.degrees), (rng.normal(size=T), lambda x: x / h),
              (rng.normal(size=T), np.degrees), (rng.normal(size=T), np.degrees)]
    td = np.sort(rng.choice(np.arange(1, T), strides + 1, replace=False)).astype(np.int64)
    td = td[:strides + 1] if strides else td[:1]
    out = np.empty(8)
    stride_medians(td, root[:, 0], root[:, 2], *(x for x, _ in series), FPS, h, GRAVITY,
                   2.3, 0.3, out)
    want = _medians_numpy(td, root, series, h)
    np.testing.assert_allclose(out, want, rtol=1e-14, atol=0)
    assert np.array_equal(np.isnan(out), np.isnan(want))
    assert np.array_equal(out[4:], want[4:], equal_nan=True)  # ranges and medians: exact


def _series_numpy(P, Gf, Gh, ground, a, head_parent):
    """The appearance's per-frame arrays with NumPy over the batch (the reference)."""
    feet = P[..., list(a.feet), :].copy()
    feet[..., 1] -= ground
    toes = P[..., list(a.feet), :] + np.einsum("...lij,lj->...li", Gf, a.toe_offsets)
    toes[..., 1] -= ground
    vel = np.gradient(P[..., 0, :][..., [0, 2]], 1.0 / FPS, axis=-2)
    d = (P[..., a.head, :] - P[..., head_parent, :] if a.head_from_parent
         else np.einsum("...ij,j->...i", Gh, a.head_tip))
    pw = P[..., a.withers, :] - P[..., a.pelvis, :]
    ca = P[..., a.mid_spine, :] - P[..., a.pelvis, :]
    cb = P[..., a.withers, :] - P[..., a.mid_spine, :]
    cr = np.cross(ca, cb)
    left = np.stack([pw[..., 2], np.zeros(pw.shape[:-1]), -pw[..., 0]], axis=-1)
    flex = np.where((cr * left).sum(-1) > 0.0, 1.0, -1.0) * np.arctan2(
        np.linalg.norm(cr, axis=-1), (ca * cb).sum(-1))
    return {
        "toes": toes, "body_speed": np.linalg.norm(vel, axis=-1),
        "mid": 0.5 * (P[..., a.pelvis, :] + P[..., a.withers, :]),
        "girdles_y": P[..., [a.pelvis, a.withers], 1],
        "pitch": np.arctan2(pw[..., 1], np.hypot(pw[..., 0], pw[..., 2])),
        "flex": flex, "head": np.arctan2(d[..., 1], np.hypot(d[..., 0], d[..., 2])),
        "fvel": np.linalg.norm(np.diff(feet[..., [0, 2]], axis=-3), axis=-1) * FPS,
        "fdown": -np.diff(feet[..., 1], axis=-2) * FPS,
    }


@pytest.mark.parametrize("from_parent", [False, True])
def test_the_compiled_appearance_series_are_numpys(from_parent):
    from dataclasses import replace

    from quadsim.analysis.appearance import _series, spine_flexion, trunk_pitch
    from quadsim.kinematics.rotations import matrices_from_quaternions
    from quadsim.skeleton.anatomy import Anatomy

    rng = np.random.default_rng(7)
    N, T, J = 3, 50, 12
    P = rng.normal(size=(N, T, J, 3))
    Gf = matrices_from_quaternions(rng.normal(size=(N, T, 4, 4)))
    Gh = matrices_from_quaternions(rng.normal(size=(N, T, 4)))
    ground = rng.normal(0.0, 0.01, (N, T, 4))
    fields = {f: None for f in Anatomy.__dataclass_fields__}
    a = replace(Anatomy(**fields), feet=(3, 5, 8, 11), legs=((2, 3), (4, 5), (6, 8), (9, 11)),
                toe_offsets=rng.normal(size=(4, 3)),
                pelvis=1, mid_spine=2, withers=4, head=7, head_tip=rng.normal(size=3),
                head_from_parent=from_parent)
    got = _series(P, Gf, Gh, ground, a, 6, FPS)
    want = _series_numpy(P, Gf, Gh, ground, a, 6)
    for k, w in want.items():
        assert got[k].shape == w.shape, k
        np.testing.assert_allclose(got[k], w, rtol=1e-12, atol=1e-12, err_msg=k)
    assert np.array_equal(got["root"], P[:, :, 0])
    assert np.array_equal(np.sign(got["flex"]), np.sign(want["flex"]))
    assert np.array_equal(trunk_pitch(P, a), got["pitch"])  # the same code, alone
    assert np.array_equal(spine_flexion(P[1], a), got["flex"][1])


def test_a_batchs_positions_are_stacked_without_a_copy_and_others_copied():
    from quadsim.analysis.appearance import _stacked

    batch = np.arange(2 * 5 * 3 * 3, dtype=float).reshape(2, 5, 3, 3).copy()  # owns its data
    rows = [batch[0].view(), batch[1].view()]
    got = _stacked(rows)
    assert np.shares_memory(got, batch) and not got.flags.writeable
    assert np.array_equal(got, np.stack(rows))
    for others in ([batch[1], batch[0]], [batch[0]], [batch[0], batch[1].copy()],
                   [batch[0, :, :2], batch[1, :, :2]]):
        got = _stacked(others)
        assert not np.shares_memory(got, batch) and np.array_equal(got, np.stack(others))


def test_every_flight_phase_is_fitted_and_only_those():
    from quadsim.analysis.appearance_kernels import flight_accels

    T = 60
    flying = np.zeros(T, dtype=bool)
    flying[:8] = True  # from the first frame: not measured
    flying[10:13] = True  # three frames: too short
    flying[20:30] = True
    flying[40:46] = True
    flying[55:] = True  # to the last frame: not measured
    t = np.arange(T) / FPS
    y = 0.5 - 0.5 * GRAVITY * (t - 0.4) ** 2  # a ballistic fall throughout: -1 g
    out = np.empty(T)
    n = flight_accels(flying, y, FPS, 4, GRAVITY, out)
    np.testing.assert_allclose(out[:n], [-1.0, -1.0], rtol=1e-9)
