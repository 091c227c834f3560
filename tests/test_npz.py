"""NPZ and CSV export: write, load back with plain numpy, compare with the motion."""

import csv
from pathlib import Path

import numpy as np
import pytest

from quadsim.analysis.metrics import foot_contacts
from quadsim.cli import main
from quadsim.errors import InputError
from quadsim.frames import LEGS
from quadsim.io.npz import FORMAT_VERSION, csv_header, write_csv, write_npz
from quadsim.locomotion import Command, simulate
from quadsim.skeleton.character import load_character
from quadsim.skeleton.motion import Motion
from quadsim.skeleton.skeleton import Skeleton

REPO = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def motion():
    return simulate(load_character("leopard"), Command(speed=1.5), 3.0, 30)


@pytest.fixture
def bare():
    """A two-joint motion with no feet, contacts or gait labels."""
    skel = Skeleton(("root", "tip"), np.array([-1, 0]), np.array([[0, 1, 0], [0, 0, 0.5]]))
    rng = np.random.default_rng(0)
    q = rng.normal(size=(7, 2, 4))
    return Motion(skel, 24, rng.normal(size=(7, 3)), q / np.linalg.norm(q, axis=-1)[..., None])


# --------------------------------------------------------------------- NPZ
def test_npz_round_trip(motion, tmp_path):
    path = write_npz(motion, tmp_path / "clip.npz")
    with np.load(path, allow_pickle=False) as f:
        d = {k: f[k] for k in f.files}
    assert str(d["format"]) == "quadsim-npz"
    assert int(d["format_version"]) == FORMAT_VERSION
    assert str(d["units"]) == "m"
    assert float(d["fps"]) == motion.fps
    assert str(d["quaternion_order"]) == "wxyz"
    assert list(d["joint_names"]) == list(motion.skeleton.names)
    assert list(d["legs"]) == list(LEGS)
    assert list(d["foot_joints"]) == list(motion.foot_joints)
    np.testing.assert_array_equal(d["parents"], motion.skeleton.parents)
    np.testing.assert_allclose(d["offsets"], motion.skeleton.offsets, atol=1e-12)
    T, J = len(motion), motion.skeleton.n_joints
    assert d["positions"].shape == (T, J, 3)
    np.testing.assert_allclose(d["positions"], motion.world_positions(), rtol=0, atol=1e-9)
    np.testing.assert_allclose(d["root_positions"], motion.root_positions, rtol=0, atol=1e-9)
    np.testing.assert_allclose(d["rotations"], motion.rotations, rtol=0, atol=1e-12)
    np.testing.assert_allclose(d["times"], motion.times, rtol=0, atol=1e-12)
    assert d["contacts"].dtype == bool and d["contacts"].shape == (T, 4)
    np.testing.assert_array_equal(d["contacts"],
                                  foot_contacts(motion.contact_points(), motion.fps))
    assert d["contacts"].any(axis=0).all()   # every foot touches down in 3 s of walking
    np.testing.assert_array_equal(d["planned_contacts"], motion.contacts)
    assert list(d["gaits"]) == [str(g) for g in motion.gaits]


def test_npz_without_feet_and_labels(bare, tmp_path):
    path = write_npz(bare, tmp_path / "bare.npz")
    with np.load(path, allow_pickle=False) as f:
        assert not {"contacts", "planned_contacts", "gaits", "foot_joints"} & set(f.files)
        np.testing.assert_allclose(f["positions"], bare.world_positions(), atol=1e-12)


def test_npz_keeps_the_path_as_given(bare, tmp_path):
    path = write_npz(bare, tmp_path / "clip.data")
    assert path == tmp_path / "clip.data"
    assert [p.name for p in tmp_path.iterdir()] == ["clip.data"]
    with np.load(path) as f:
        assert "positions" in f.files


# --------------------------------------------------------------------- CSV
def test_csv_round_trip(motion, tmp_path):
    path = write_csv(motion, tmp_path / "clip.csv")
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    header, body = rows[0], rows[1:]
    names = motion.skeleton.names
    assert header[0] == "time"
    assert header[1:4] == [f"{names[0]}_x", f"{names[0]}_y", f"{names[0]}_z"]
    assert header[-4:] == ["contact_LF", "contact_RF", "contact_LH", "contact_RH"]
    assert header == csv_header(motion)
    assert len(header) == 1 + 3 * len(names) + 4
    assert len(body) == len(motion)
    table = np.array(body, dtype=float)
    np.testing.assert_allclose(table[:, 0], motion.times, rtol=0, atol=1e-9)
    pos = table[:, 1:1 + 3 * len(names)].reshape(len(motion), len(names), 3)
    np.testing.assert_allclose(pos, motion.world_positions(), rtol=0, atol=1e-9)
    np.testing.assert_array_equal(table[:, -4:].astype(bool),
                                  foot_contacts(motion.contact_points(), motion.fps))


def test_csv_without_feet(bare, tmp_path):
    path = write_csv(bare, tmp_path / "bare.csv")
    lines = path.read_text().splitlines()
    assert lines[0] == "time,root_x,root_y,root_z,tip_x,tip_y,tip_z"
    assert len(lines) == 1 + len(bare)


def test_csv_rejects_joint_names_it_cannot_hold(tmp_path):
    skel = Skeleton(("root", "a,b"), np.array([-1, 0]), np.zeros((2, 3)))
    m = Motion(skel, 30, np.zeros((2, 3)), np.tile([1.0, 0, 0, 0], (2, 2, 1)))
    with pytest.raises(InputError, match="commas"):
        write_csv(m, tmp_path / "x.csv")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("writer", [write_npz, write_csv])
def test_unwritable_destination(writer, bare, tmp_path):
    with pytest.raises(InputError, match="cannot write"):
        writer(bare, tmp_path / "missing" / "x.out")
    assert list(tmp_path.iterdir()) == []


# --------------------------------------------------------------------- CLI
@pytest.mark.parametrize("ext", [".npz", ".csv"])
def test_cli_run_writes_arrays(ext, tmp_path, capsys):
    out = tmp_path / f"x{ext}"
    code = main(["run", str(REPO / "configs" / "leopard.toml"), "--seconds", "1",
                 "--fps", "30", "--out", str(out)])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    assert captured.err == ""
    if ext == ".npz":
        with np.load(out, allow_pickle=False) as f:
            assert f["positions"].shape[0] == 30
            assert float(f["fps"]) == 30.0
    else:
        assert len(out.read_text().splitlines()) == 1 + 30


def test_cli_warns_that_arrays_are_in_metres(tmp_path, capsys):
    out = tmp_path / "x.npz"
    code = main(["run", str(REPO / "configs" / "leopard.toml"), "--seconds", "0.5",
                 "--units", "cm", "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 0
    assert "quadsim: warning: .npz files are always in metres" in err
    with np.load(out) as f:
        assert str(f["units"]) == "m"
