"""Many characters stepped together equal each character stepped alone.

:class:`BatchController` runs N characters as one vectorised computation;
every row must follow exactly the path of a lone
:class:`ProceduralController` with the same seed, starting gait and
commands -- joint positions to 1e-9 m, identical contacts and gait labels --
through starts, gait changes (automatic and requested), turning by rate and
towards a heading, and stopping.
"""

import warnings

import numpy as np
import pytest

from quadsim.commands import Command, Script
from quadsim.errors import InputError
from quadsim.locomotion.batch import BatchController
from quadsim.locomotion.controller import ProceduralController
from quadsim.locomotion.gaits import gait_ids, max_speed
from quadsim.locomotion.posing import PLAN_FIELDS
from quadsim.skeleton.character import load_character

CHARACTERS = ("leopard", "leopard_cub", "dog_cub", "horse")
TOL = 1e-9


def _script(character, k: int) -> Script:
    """A varied 6-second run: start, speed up, turn, steer to a heading, a
    requested gait, stop, set off again; ``k`` varies speeds and gaits."""
    top = max_speed(character)
    cmds = (Command(speed=(0.15 + 0.1 * k) * top),
            Command(speed=(0.45 + 0.15 * k) * top, turn_rate=0.6 * (-1) ** k),
            Command(speed=0.85 * top, heading=-0.7 + 0.5 * k),
            Command(speed=0.3 * top, gait=("trot", "canter")[k]),
            Command(speed=0.2 * top, turn_rate=-0.4),
            Command(speed=0.0),
            Command(speed=0.4 * top, gait=(None, "walk")[k]))
    return Script((0.0, 0.8, 1.6, 2.4, 3.8, 4.6, 5.6), cmds)


def _row_of(batch: BatchController, j: int) -> tuple[int, int]:
    """Group index and position within the group of row ``j``."""
    for g, (_, rows) in enumerate(batch.groups):
        hit = np.flatnonzero(rows == j)
        if len(hit):
            return g, int(hit[0])
    raise AssertionError(f"row {j} in no group")


def test_mixed_batch_equals_each_character_alone():
    chars = {n: load_character(n) for n in CHARACTERS}
    # interleaved kinds, two rows each with different seeds, commands and starts
    rows = [(chars[CHARACTERS[i % 4]], i // 4, 7 * i + 1, ("walk", None)[i // 4])
            for i in range(8)]
    scripts = [_script(ch, k) for ch, k, _, _ in rows]
    dt, seconds = 1.0 / 60.0, 6.6
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        batch = BatchController([r[0] for r in rows], dt=dt, seeds=[r[2] for r in rows],
                                gaits=[r[3] for r in rows])
        alone = [ProceduralController(ch, dt=dt, seed=seed, gait=g) for ch, _, seed, g in rows]
        where = [_row_of(batch, j) for j in range(len(rows))]
        worst = 0.0
        labels = set()
        for k in range(int(seconds / dt)):
            cmds = [s.command_at(k * dt) for s in scripts]
            frame = batch.step_commands(cmds)
            for j, (ctl, cmd) in enumerate(zip(alone, cmds)):
                one = ctl.step(cmd)
                g, i = where[j]
                err = np.abs(frame["positions"][g][i] - one.positions).max()
                worst = max(worst, err)
                assert err <= TOL, (k, j, err)
                np.testing.assert_array_equal(frame["contacts"][j], one.contacts)
                assert batch.labels[j] == one.gait, (k, j)
                np.testing.assert_allclose(frame["root"][j], one.root, atol=TOL)
                np.testing.assert_allclose(frame["ik_error"][g][i], one.extras["ik_error"], atol=TOL)
                labels.add(one.gait)
    # the run really went through transitions, bounding gaits and standing
    assert any("->" in lb for lb in labels)
    assert any(lb.endswith("->stand") or lb == "stand" for lb in labels)
    assert "canter" in labels and "trot" in labels
    assert worst <= TOL


def test_one_row_batch_equals_the_controller_and_plan_only_matches_posed():
    ch = load_character("dog_cub")
    cmd = Command(speed=0.5 * max_speed(ch), turn_rate=0.3)
    batch = BatchController([ch], seeds=4)
    plan_only = BatchController([ch], seeds=4)
    ctl = ProceduralController(ch, seed=4)
    for _ in range(90):
        f = batch.step_commands([cmd])
        p = plan_only.step_commands([cmd], pose=False)
        one = ctl.step(cmd)
    np.testing.assert_allclose(f["positions"][0][0], one.positions, atol=TOL)
    np.testing.assert_allclose(f["local_rotations"][0][0], one.local_rotations, atol=TOL)
    np.testing.assert_allclose(p["feet"][0], one.extras["feet"], atol=TOL)
    np.testing.assert_allclose(p["phase"][0], one.extras["phase"], atol=TOL)
    assert "positions" not in p


def test_array_commands_equal_command_objects():
    ch = load_character("leopard")
    n = 5
    rng = np.random.default_rng(2)
    speed = rng.uniform(0.1, 0.7, n) * max_speed(ch)
    turn = rng.uniform(-0.5, 0.5, n)
    a = BatchController([ch] * n, seeds=range(n))
    b = BatchController([ch] * n, seeds=range(n))
    gait = a.gait_ids([None, "trot", None, "walk", None])
    assert list(gait) == [-1, gait_ids().index("trot"), -1, gait_ids().index("walk"), -1]
    cmds = [Command(speed=float(v), turn_rate=float(w), gait=g)
            for v, w, g in zip(speed, turn, [None, "trot", None, "walk", None])]
    for _ in range(40):
        fa = a.step(speed, turn, None, gait, pose=False)
        fb = b.step_commands(cmds, pose=False)
    np.testing.assert_array_equal(fa["feet"], fb["feet"])
    # different seeds give different rows
    assert np.abs(fa["phase"][0] - fa["phase"][1]).max() > 1e-3


def test_bad_batch_input_is_refused():
    ch = load_character("leopard")
    with pytest.raises(ValueError, match="empty"):
        BatchController([])
    with pytest.raises(ValueError, match="dt"):
        BatchController([ch], dt=0.0)
    with pytest.raises(ValueError, match="gaits"):
        BatchController([ch, ch], gaits=["walk"])
    b = BatchController([ch, ch])
    with pytest.raises(ValueError, match="speed"):
        b.step([1.0, -1.0])
    with pytest.raises(ValueError, match="turn_rate"):
        b.step([1.0, 1.0], [0.0, np.inf])
    with pytest.raises(InputError, match="unknown gait"):
        b.gait_ids(["amble", None])
    with pytest.raises(InputError, match="not among"):
        b.step([1.0, 1.0], gait=[gait_ids().index("amble"), -1])
    with pytest.raises(InputError, match="unknown gait"):
        b.step([1.0, 1.0], gait="amble")
    with pytest.raises(InputError, match="`gait` must be gait names"):
        b.step([1.0, 1.0], gait=[1.5j, 0])
    with pytest.raises(InputError, match="one or 2 of them"):
        b.step([1.0, 1.0], gait=["trot", "walk", "pace"])
    with pytest.raises(InputError, match="ids must lie in -1"):
        b.step([1.0, 1.0], gait=[-1, 99])
    with pytest.raises(ValueError, match="2 characters"):
        b.step_commands([Command(speed=1.0)])


def test_posing_a_mixed_herd_equals_posing_each_row_alone():
    chars = [load_character("leopard"), load_character("horse")]
    n = 11
    herd = BatchController([chars[i % 2] for i in range(n)], seeds=range(n))
    speed = np.linspace(0.5, 4.0, n)
    for _ in range(30):
        plan = herd.step(speed, 0.2, pose=False)
    whole = herd.pose(plan)
    assert [len(rows) for _, rows in herd.groups] == [6, 5]
    for g, (ch, rows) in enumerate(herd.groups):
        poser = herd.kinds[g].poser
        for i, row in enumerate(rows):
            one = {k: plan[k][row:row + 1] for k in PLAN_FIELDS}
            one["tail"] = one["tail"][:, :len(ch.tail)]
            local, _, err = poser.pose(one)
            np.testing.assert_array_equal(whole["local_rotations"][g][i], local[0])
            np.testing.assert_array_equal(whole["ik_error"][g][i], err[0])


def test_zero_first_step_starting_gaits_and_standing_still_match():
    """As simulate starts: a first step of dt = 0, then fixed steps; rows that
    start in a requested gait (the horse's amble) or stand still."""
    chars = [load_character(n) for n in ("leopard", "horse", "dog_cub")]
    starts = ["trot", "amble", None]
    cmds = [Command(speed=2.0), Command(speed=1.5, gait="amble", heading=1.0),
            Command(speed=0.0)]
    batch = BatchController(chars, seeds=[1, 2, 3], gaits=starts)
    alone = [ProceduralController(c, seed=k, gait=g) for c, k, g in zip(chars, [1, 2, 3], starts)]
    for k in range(120):
        dt = 0.0 if k == 0 else 1.0 / 60.0
        frame = batch.step_commands(cmds, dt)
        for j, ctl in enumerate(alone):
            one = ctl.step(cmds[j], dt)
            g, i = _row_of(batch, j)
            np.testing.assert_allclose(frame["positions"][g][i], one.positions, atol=TOL)
            assert batch.labels[j] == one.gait
    assert batch.labels == ["trot", "amble", "stand"]
    assert np.all(frame["contacts"][2])


def test_a_large_herd_is_posed_on_threads_exactly_as_row_by_row():
    from quadsim.locomotion import pose_kernel

    ch = load_character("leopard")
    n = pose_kernel.PARALLEL_ROWS + 37          # over the threshold, not a multiple of 2
    herd = BatchController([ch] * n, seeds=range(n))
    rng = np.random.default_rng(3)
    speed, turn = rng.uniform(0.5, 9.0, n), rng.uniform(-0.6, 0.6, n)
    for _ in range(150):
        plan = herd.step(speed, turn, pose=False)
    poser = herd.kinds[0].poser
    packed = pose_kernel.pack_plan(plan, len(ch.tail))
    threaded = poser.pose_packed(packed)               # blocks on threads
    J = ch.skeleton.n_joints
    serial = (np.empty((n, J, 3, 3)), np.empty((n, J, 3)), np.empty((n, 4)))
    pose_kernel.pose_rows(np.ascontiguousarray(packed), poser.rig, *serial,
                          pose_kernel.pose_scratch(poser.rig, n))
    for a, b in zip(threaded, serial):
        np.testing.assert_array_equal(a, b)
    assert np.ptp(np.linalg.norm(threaded[1][:, 0], axis=1)) > 1.0   # the herd spread out


def test_a_large_mixed_herd_plans_on_threads_exactly_as_on_one(monkeypatch):
    from quadsim.locomotion import batch as batch_mod

    names = ("leopard", "horse", "dog_cub")
    chars = [load_character(nm) for nm in names]
    n = batch_mod.PARALLEL_ROWS + 61                     # over the threshold, odd
    herd = [chars[i % 3] for i in range(n)]
    starts = [(None, "walk", "trot")[(i // 3) % 3] for i in range(n)]
    rng = np.random.default_rng(11)
    top = np.array([max_speed(ch) for ch in herd])
    frac = rng.uniform(0.0, 1.1, (4, n))                 # some above the top speed
    turn = rng.uniform(-1.5, 1.5, (4, n))
    heads = np.where(rng.random((4, n)) < 0.3, rng.uniform(-3.0, 3.0, (4, n)), np.nan)
    asks = [[(None, None, "walk", "trot")[(i + k) % 4] for i in range(n)] for k in range(4)]

    def run():
        b = BatchController(herd, seeds=range(n), gaits=starts)
        gaits = [b.gait_ids(a) for a in asks]
        out = []
        for f in range(200):
            k = f // 50
            fr = b.step(frac[k] * top, turn[k], heads[k], gaits[k], pose=False)
            out.append((fr["root"], fr["feet"], fr["contacts"], fr["tail"], b.labels))
        return out

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        threaded = run()                                  # blocks on threads
        monkeypatch.setattr(batch_mod, "PARALLEL_ROWS", 10 ** 9)
        serial = run()                                    # plan_rows
    for a, b in zip(threaded, serial):
        for x, y in zip(a[:4], b[:4]):
            np.testing.assert_array_equal(x, y)
        assert a[4] == b[4]
    labels = {lab for fr in threaded for lab in fr[4]}
    assert len(labels) > 3 and any("->" in lab for lab in labels)   # gaits changed
    assert np.ptp(np.linalg.norm(threaded[-1][0], axis=1)) > 1.0    # the herd spread out


def test_a_large_herd_posed_in_its_step_matches_posing_its_plans_afterwards():
    """One kind of character: each block of rows is posed right after its plan, on its
    thread; the poses are those of the plans posed row by row once the step is over."""
    from quadsim.locomotion import pose_kernel

    ch = load_character("dog_cub")
    n = pose_kernel.PARALLEL_ROWS + 37
    herd = BatchController([ch] * n, seeds=range(n))
    rng = np.random.default_rng(5)
    speed, turn = rng.uniform(0.3, 5.0, n), rng.uniform(-0.5, 0.5, n)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for _ in range(90):
            frame = herd.step(speed, turn, pose=True)
    J = ch.skeleton.n_joints
    serial = (np.empty((n, J, 3, 3)), np.empty((n, J, 3)), np.empty((n, 4)))
    packed = pose_kernel.pack_plan(frame, len(ch.tail))
    rig = herd.kinds[0].poser.rig
    pose_kernel.pose_rows(packed, rig, *serial, pose_kernel.pose_scratch(rig, n))
    for key, want in zip(("local_rotations", "positions", "ik_error"), serial):
        np.testing.assert_array_equal(frame[key][0], want)
    assert np.ptp(frame["positions"][0][:, 0, 2]) > 0.3             # the herd spread out


def test_an_error_in_one_block_of_rows_is_raised_after_every_block_ended():
    import threading
    import time

    from quadsim.locomotion import blocks

    ended = []

    def task(a, e):
        if a == 0:
            raise RuntimeError("block 0 failed")
        time.sleep(0.05)
        ended.append((a, threading.get_ident()))

    import numba

    if numba.config.NUMBA_NUM_THREADS < 2:
        pytest.skip("numba has one thread here")
    with pytest.raises(RuntimeError, match="block 0"), _threads(2):
        blocks.run_blocks(task, 10)
    assert [a for a, _ in ended] == [5]          # the other block ran to its end first


class _threads:
    """numba's thread count set for a ``with`` block."""

    def __init__(self, n):
        self.n = n

    def __enter__(self):
        import numba

        self.was = numba.get_num_threads()
        numba.set_num_threads(self.n)

    def __exit__(self, *exc):
        import numba

        numba.set_num_threads(self.was)


def test_gaits_are_asked_for_by_name_as_well_as_by_id():
    """``step(gait=...)`` takes names (one for every row, or one per row, ``None``
    choosing by speed) as :meth:`~BatchController.gait_ids` would turn them into ids:
    the same motion either way."""
    ch = load_character("leopard")
    by_name, by_id, one_name = (BatchController([ch, ch]) for _ in range(3))
    ids = by_id.gait_ids(["trot", None])
    for _ in range(30):
        a = by_name.step([2.0, 2.0], gait=["trot", None], pose=False)
        b = by_id.step([2.0, 2.0], gait=ids, pose=False)
        c = one_name.step([2.0, 2.0], gait="trot", pose=False)
    assert np.array_equal(a["gait"], b["gait"]) and np.array_equal(a["feet"], b["feet"])
    assert list(c["gait"]) == [gait_ids().index("trot")] * 2
