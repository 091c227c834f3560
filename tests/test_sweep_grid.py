"""`quadsim sweep`'s grid files: the product of their lists, stable clip ids, and errors
that name the key -- from the library (InputError) and from the command (exit 2)."""

import shutil
import textwrap
from pathlib import Path

import numpy as np
import pytest

import quadsim
from quadsim.cli import main
from quadsim.dataset import generate, load_grid, npz_bytes, parse_grid
from quadsim.dataset.clips import ZIP_DATE
from quadsim.errors import InputError
from quadsim.skeleton.character import characters_dir

DONE_WHEN = {"characters": ["leopard", "dog_cub"], "gaits": ["walk", "trot", "canter"],
             "turn_rates_deg_s": [0, 20], "seeds": [0, 1], "seconds": 4}


def write(tmp_path: Path, text: str, name: str = "grid.toml") -> Path:
    p = tmp_path / name
    p.write_text(textwrap.dedent(text), encoding="utf-8")
    return p


def test_the_sweep_is_the_product_of_the_lists_in_order():
    clips = parse_grid(DONE_WHEN).clips()
    assert len(clips) == 2 * 3 * 2 * 2
    assert [(c.character, c.gait, c.turn_rate_deg_s, c.seed) for c in clips[:5]] == [
        ("leopard", "walk", 0.0, 0), ("leopard", "walk", 0.0, 1), ("leopard", "walk", 20.0, 0),
        ("leopard", "walk", 20.0, 1), ("leopard", "trot", 0.0, 0)]
    assert {c.frames for c in clips} == {240} and {c.format for c in clips} == {"npz"}


def test_preferred_speed_is_each_gaits_own_per_character():
    clips = parse_grid(dict(DONE_WHEN, speeds="preferred")).clips()
    for c in clips:
        g = quadsim.load_character(c.character)
        ctl = quadsim.make_controller(g)
        assert c.speed == ctl.preferred_speed(c.gait)
    assert len({c.speed for c in clips}) == 6


def test_clip_ids_are_stable_unique_and_made_of_the_parameters():
    a, b = parse_grid(DONE_WHEN).clips(), parse_grid(dict(DONE_WHEN)).clips()
    assert [c.id for c in a] == [c.id for c in b]
    assert len({c.id for c in a}) == len(a)
    assert a[0].id.startswith("leopard-walk-") and a[0].path == f"clips/{a[0].id}.npz"
    other = parse_grid(dict(DONE_WHEN, seeds=[5])).clips()
    assert not {c.id for c in other} & {c.id for c in a}


def test_a_character_file_is_found_beside_the_grid_and_named_by_its_content(tmp_path):
    shutil.copy(characters_dir() / "dog_cub.toml", tmp_path / "pup.toml")
    grid = write(tmp_path, """\
        characters = ["pup.toml"]
        gaits = ["trot"]
        seconds = 1
    """)
    (c,) = load_grid(grid).clips()
    moved = tmp_path / "elsewhere"
    moved.mkdir()
    shutil.copy(tmp_path / "pup.toml", moved / "pup.toml")
    shutil.copy(grid, moved / "grid.toml")
    assert load_grid(moved / "grid.toml").clips()[0].id == c.id  # the path does not count
    with open(moved / "pup.toml", "a") as f:
        f.write("\n# an edit\n")
    assert load_grid(moved / "grid.toml").clips()[0].id != c.id  # the content does


@pytest.mark.parametrize("text, key", [
    ("characters = ['leopard']\ngaits = ['trot']\ncolour = 'red'\n", "colour"),
    ("characters = ['leopard']\ngaits = ['trot']\nspeeds = ['fast']\n", "speeds"),
    ("characters = ['leopard']\ngaits = ['trot']\nspeeds = [99.0]\n", "speeds"),
    ("characters = ['leopard']\ngaits = ['trot']\nseeds = [-1]\n", "seeds"),
    ("characters = ['leopard']\ngaits = ['trot']\nseeds = [true]\n", "seeds"),
    ("characters = ['leopard']\ngaits = ['trot']\nseeds = [1.5]\n", "seeds"),
    ("characters = ['leopard']\ngaits = ['trot']\nformat = 'fbx'\n", "format"),
    ("characters = ['leopard']\ngaits = ['trot']\nfps = 0\n", "fps"),
    ("characters = ['leopard']\ngaits = ['trot']\nseconds = 0.01\n", "seconds"),
    ("characters = ['leopard']\ngaits = ['trot']\nturn_rates_deg_s = [1000]\n",
     "turn_rates_deg_s"),
    ("characters = ['leopard']\ngaits = ['trot']\nseeds = [0, 0]\n", "seeds"),
    ("characters = ['leopard']\ngaits = []\n", "gaits"),
    ("characters = ['leopard']\ngaits = ['moonwalk']\n", "gaits"),
    ("characters = ['leopard', 'dog_cub']\ngaits = ['amble']\n", "gaits"),
    ("characters = ['unicorn']\ngaits = ['trot']\n", "characters"),
    ("characters = ['missing.toml']\ngaits = ['trot']\n", "characters"),
    ("gaits = ['trot']\n", "characters"),
])
def test_a_bad_grid_is_an_input_error_naming_the_key(tmp_path, text, key):
    with pytest.raises(InputError, match=key):
        load_grid(write(tmp_path, text))


def test_an_unknown_character_lists_the_known_ones(tmp_path):
    with pytest.raises(InputError, match="unicorn.*known: .*leopard"):
        load_grid(write(tmp_path, "characters = ['unicorn']\ngaits = ['trot']\n"))


@pytest.mark.parametrize("text, flags, words", [
    ("characters = ['leopard']\ngaits = ['trot']\nsped = 2\n", [], "sped"),
    ("characters = ['leopard']\ngaits = ['trot']\nfps = 'sixty'\n", [], "fps"),
    ("characters = ['unicorn']\ngaits = ['trot']\n", [], "unicorn"),
    ("characters = ['leopard']\ngaits = ['trot']\n", ["--workers", "0"], "--workers"),
    ("characters = ['leopard']\ngaits = ['trot']\n", ["--workers", "-3"], "--workers"),
    ("characters = ['leopard']\ngaits = ['trot']\n", ["--workers", "two"], "--workers"),
    ("characters = ['leopard']\ngaits = ['trot']\n", ["--limit", "0"], "--limit"),
    ("characters = ['leopard']\ngaits = ['trot']\n",
     ["--workers", "2", "--scheduler", "tcp://127.0.0.1:1"], "--scheduler"),
    ("characters = ['leopard']\ngaits = ['trot']\n", ["--scheduler", "localhost"],
     "--scheduler"),
])
def test_the_command_exits_2_with_one_message_naming_the_key(tmp_path, capsys, text, flags,
                                                             words):
    grid = write(tmp_path, text)
    assert main(["sweep", str(grid), "--out", str(tmp_path / "out"), *flags]) == 2
    err = capsys.readouterr().err
    assert err.startswith("quadsim: error:") and words in err and "Traceback" not in err
    assert not (tmp_path / "out").exists()


def test_a_batched_clip_is_the_lone_simulation_bit_for_bit():
    """Clips stepped together by the BatchController are what quadsim.simulate makes of
    each alone, and a clip's bytes do not depend on the clips sharing its batch."""
    clips = [c for c in parse_grid(DONE_WHEN).clips() if c.character == "dog_cub"]
    together = generate(clips)
    for c, m in zip(clips[::5], together[::5]):
        alone = quadsim.simulate(c.character, quadsim.Command(
            speed=c.speed, gait=c.gait, turn_rate=np.radians(c.turn_rate_deg_s)),
            seconds=c.seconds, fps=c.fps, seed=c.seed)
        assert np.array_equal(alone.rotations, m.rotations)
        assert np.array_equal(alone.root_positions, m.root_positions)
        assert np.array_equal(alone.contacts, m.contacts)
        assert list(alone.gaits) == list(m.gaits)
        assert npz_bytes(alone) == npz_bytes(m)
    fewer = generate(clips[4:10])    # another batch
    few = generate(clips[3:5])       # too few to batch: simulated one by one
    assert [npz_bytes(m) for m in fewer] == [npz_bytes(m) for m in together[4:10]]
    assert [npz_bytes(m) for m in few] == [npz_bytes(m) for m in together[3:5]]


def test_the_npz_is_a_plain_npz_with_fixed_dates(tmp_path):
    import zipfile

    from quadsim.io.npz import npz_arrays

    (c,) = parse_grid({"characters": "leopard", "gaits": "trot", "seconds": 0.5}).clips()
    (m,) = generate([c])
    p = tmp_path / "clip.npz"
    p.write_bytes(npz_bytes(m))
    with zipfile.ZipFile(p) as z:
        assert {i.date_time for i in z.infolist()} == {ZIP_DATE}
    with np.load(p, allow_pickle=False) as f:
        want = npz_arrays(m)
        assert sorted(f.files) == sorted(want)
        for k, v in want.items():
            assert np.array_equal(f[k], v)


def test_what_the_controller_will_clamp_is_said_once_per_case():
    from quadsim.dataset.grid import clamps

    clips = parse_grid({"characters": "horse", "gaits": ["walk", "trot"], "speeds": [1.5, 3.0],
                        "turn_rates_deg_s": [0, 200], "seeds": [0, 1], "seconds": 1}).clips()
    said = clamps(clips)
    assert len(said) == len(set(said))
    assert any("`speeds`: 3 m/s" in m and "walk of horse" in m for m in said)
    assert any("`turn_rates_deg_s`: 200 deg/s" in m for m in said)
    assert not any("trot of horse" in m and "`speeds`" in m for m in said)
    assert clamps(parse_grid(DONE_WHEN).clips()) == []


def test_the_progress_bar_shows_clips_rate_and_time_left():
    import io

    from quadsim.cli_sweep import ProgressBar
    from quadsim.dataset import Progress

    line = ProgressBar.line(Progress(6, 24, 2.0), width=8)
    assert line == "[##------] 6/24 clips  3.0 clips/s  ETA 00:06"
    assert ProgressBar.line(Progress(0, 24, 0.5)).endswith("ETA --:--")
    pipe = io.StringIO()
    bar = ProgressBar(pipe)  # not a terminal: nothing drawn
    bar(Progress(1, 2, 1.0))
    bar.close()
    assert pipe.getvalue() == ""


def test_the_measured_figures_are_those_of_quadsim_metrics():
    from quadsim.analysis.appearance import appearance_report
    from quadsim.analysis.metrics import motion_report
    from quadsim.dataset import measure

    (c,) = parse_grid({"characters": "leopard", "gaits": "trot", "seconds": 2}).clips()
    (m,) = generate([c])
    want = dict(motion_report(m), appearance=appearance_report(m))
    assert measure(m) == want and measure(m) == want  # the anatomy found once is the same


def test_an_out_that_is_a_file_is_refused(tmp_path, capsys):
    grid = write(tmp_path, "characters = ['leopard']\ngaits = ['trot']\nseconds = 1\n")
    (tmp_path / "taken").write_text("mine\n")
    assert main(["sweep", str(grid), "--out", str(tmp_path / "taken")]) == 2
    assert "--out" in capsys.readouterr().err
    assert (tmp_path / "taken").read_text() == "mine\n"


def test_on_a_terminal_the_bar_is_redrawn_in_place_and_ended():
    import io

    from quadsim.cli_sweep import ProgressBar
    from quadsim.dataset import Progress

    class Tty(io.StringIO):
        def isatty(self):
            return True

    tty = Tty()
    bar = ProgressBar(tty, width=4)
    bar(Progress(0, 10, 0.0))
    bar(Progress(10, 10, 2.0))
    bar.close()
    first, second = tty.getvalue().split("\r")[1:]
    assert first.startswith("[----] 0/10") and second.startswith("[####] 10/10 clips  5.0")
    assert second.endswith("\n") and len(second) >= len(first)
