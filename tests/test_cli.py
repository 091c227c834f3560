"""The ``quadsim`` command, called as ``main([...])`` in a temporary folder."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from quadsim.cli import main
from quadsim.errors import InputError

REPO = Path(__file__).resolve().parents[1]

WALK = """\
character = "leopard"
duration = 10.0
fps = 60

[[command]]
at = 0.0
speed = 1.0

[[command]]
at = 1.0
speed = 2.5
turn_rate_deg_s = 20.0
"""


@pytest.fixture
def here(tmp_path, monkeypatch):
    """A temporary working folder holding a small leopard config, ``walk.toml``."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "walk.toml").write_text(WALK, encoding="utf-8")
    return tmp_path


def files_in(folder):
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


def _without_notes(err: str) -> str:
    """stderr without the one-time ``quadsim: note:`` line of a kernel compile."""
    return "".join(line for line in err.splitlines(keepends=True)
                   if not line.startswith("quadsim: note:"))


def assert_input_error(code, capsys, *patterns):
    """Exit status 2, one ``quadsim: error:`` paragraph on stderr, no traceback."""
    err = _without_notes(capsys.readouterr().err)
    assert code == 2
    assert err.startswith("quadsim: error: ")
    assert err.count("\n") == 1
    assert "Traceback" not in err
    for p in patterns:
        assert p in err
    return err


def collect_strings(obj):
    """Every key and string value in a JSON document."""
    if isinstance(obj, dict):
        return set(obj) | set().union(*(collect_strings(v) for v in obj.values()))
    if isinstance(obj, list):
        return set().union(*(collect_strings(v) for v in obj)) if obj else set()
    return {obj} if isinstance(obj, str) else set()


# --------------------------------------------------------------- characters
def test_characters_lists_the_four_characters(here, capsys):
    assert main(["characters"]) == 0
    out = capsys.readouterr().out
    ids = [line.split()[0] for line in out.splitlines()[1:] if line and not line[0].isspace()]
    assert sorted(ids) == ["dog_cub", "horse", "leopard", "leopard_cub"]
    assert "walk" in out and "m/s" in out


# ----------------------------------------------------------------- validate
def test_validate_ok(here, capsys):
    assert main(["validate", "walk.toml"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("ok: walk.toml")
    assert "leopard" in out and "600 frames" in out and "2 command(s)" in out


def test_validate_shipped_config(here, capsys):
    assert main(["validate", str(REPO / "configs" / "leopard.toml")]) == 0
    assert capsys.readouterr().out.startswith("ok: ")


def test_validate_bad_config(here, capsys):
    (here / "bad.toml").write_text(WALK.replace("speed = 2.5", "speed = -2.5"))
    code = main(["validate", "bad.toml"])
    assert_input_error(code, capsys, "bad.toml", "command[1].speed")


def test_validate_toml_syntax_error(here, capsys):
    (here / "bad.toml").write_text(WALK.replace("fps = 60", "fps = "))
    assert_input_error(main(["validate", "bad.toml"]), capsys, "bad.toml", "line 3")


def test_validate_missing_file(here, capsys):
    assert_input_error(main(["validate", "nothere.toml"]), capsys, "nothere.toml")


def test_usage_errors_exit_2(here, capsys):
    assert_input_error(main([]), capsys)
    assert_input_error(main(["fly"]), capsys, "fly")
    assert_input_error(main(["run"]), capsys, "CONFIG")


def test_help_exits_0(here, capsys):
    assert main(["--help"]) == 0
    assert "run" in capsys.readouterr().out


def test_python_dash_m(here):
    (here / "bad.toml").write_text("duration = 1\n")
    r = subprocess.run([sys.executable, "-m", "quadsim", "validate", "bad.toml"],
                       capture_output=True, text=True, cwd=here, check=False)
    assert r.returncode == 2
    assert r.stderr.startswith("quadsim: error: bad.toml: missing key `character`")


# ---------------------------------------------------------------------- run
def test_run_writes_a_bvh_with_seconds_times_fps_frames(here, capsys):
    from quadsim.io.bvh import read_bvh

    assert main(["run", "walk.toml", "--seconds", "2", "--out", "clips/walk.bvh"]) == 0
    out = capsys.readouterr().out
    path = here / "clips" / "walk.bvh"
    assert path.stat().st_size > 0
    assert "120 frames" in out and str(Path("clips/walk.bvh")) in out
    motion = read_bvh(path)
    assert len(motion) == 120
    assert motion.fps == pytest.approx(60.0)


def test_run_default_output_and_fps(here, capsys):
    from quadsim.io.bvh import read_bvh

    assert main(["run", "walk.toml", "--seconds", "2", "--fps", "30"]) == 0
    path = here / "out" / "walk.bvh"
    assert len(read_bvh(path)) == 60
    assert "60 frames" in capsys.readouterr().out


def test_run_constant_gait_override(here, capsys):
    assert main(["run", "walk.toml", "--seconds", "2", "--gait", "trot",
                 "--out", "trot.bvh"]) == 0
    assert "trot" in capsys.readouterr().out


def test_run_is_deterministic(here):
    for name in ("a.bvh", "b.bvh"):
        assert main(["run", "walk.toml", "--seconds", "2", "--out", name]) == 0
    assert (here / "a.bvh").read_bytes() == (here / "b.bvh").read_bytes()


def test_run_units_cm(here):
    from quadsim.io.bvh import read_bvh

    assert main(["run", "walk.toml", "--seconds", "1", "--out", "m.bvh"]) == 0
    assert main(["run", "walk.toml", "--seconds", "1", "--out", "cm.bvh", "--units", "cm"]) == 0
    m, cm = read_bvh(here / "m.bvh"), read_bvh(here / "cm.bvh", units="cm")
    np.testing.assert_allclose(cm.root_positions, m.root_positions, atol=1e-4)


BAD_RUNS = {
    "negative speed": (["--speed", "-1"], "--speed"),
    "speed not a number": (["--speed", "fast"], "--speed"),
    "unknown gait": (["--gait", "flying"], "flying"),
    "turn rate": (["--turn-rate", "5000"], "--turn-rate"),
    "seconds": (["--seconds", "0"], "--seconds"),
    "fps": (["--fps", "0"], "--fps"),
    "units": (["--units", "ft"], "--units"),
    "output format": (["--out", "x.xyz"], ".xyz"),
    "output without extension": (["--out", "clip"], "extension"),
    "unknown flag": (["--colour", "red"], "--colour"),
}


@pytest.mark.parametrize("flags, named", BAD_RUNS.values(), ids=BAD_RUNS.keys())
def test_run_bad_flag_exits_2_and_writes_nothing(here, capsys, flags, named):
    code = main(["run", "walk.toml", "--seconds", "2", *flags])
    assert_input_error(code, capsys, named)
    assert files_in(here) == ["walk.toml"]


def test_run_bad_config_writes_nothing(here, capsys):
    (here / "bad.toml").write_text(WALK.replace('"leopard"', '"unicorn"'))
    assert_input_error(main(["run", "bad.toml"]), capsys, "unicorn")
    assert not (here / "out").exists()


def test_run_missing_config(here, capsys):
    assert_input_error(main(["run", "nothere.toml"]), capsys, "nothere.toml")
    assert files_in(here) == ["walk.toml"]


def test_failed_run_keeps_an_existing_output(here, capsys):
    old = here / "keep.bvh"
    old.write_text("old contents")
    code = main(["run", "walk.toml", "--gait", "flying", "--out", "keep.bvh"])
    assert_input_error(code, capsys, "flying")
    assert old.read_text() == "old contents"


def test_failed_simulation_writes_nothing(here, capsys, monkeypatch):
    import quadsim.api

    def broken(*args, **kw):
        raise InputError("the engine refused")

    monkeypatch.setattr(quadsim.api, "simulate", broken)
    (here / "keep.bvh").write_text("old contents")
    code = main(["run", "walk.toml", "--out", "keep.bvh"])
    assert_input_error(code, capsys, "the engine refused")
    assert (here / "keep.bvh").read_text() == "old contents"
    code = main(["run", "walk.toml", "--out", "new/clip.bvh"])
    assert_input_error(code, capsys, "the engine refused")
    assert files_in(here) == ["keep.bvh", "walk.toml"]


def test_run_prints_each_distinct_warning_once_as_one_line(here, capsys, monkeypatch):
    import warnings

    import quadsim.api

    real = quadsim.api.simulate

    def warns(*args, **kw):
        for _ in range(3):
            warnings.warn("turn rate clamped", UserWarning, stacklevel=2)
        warnings.warn("speed clamped", UserWarning, stacklevel=2)
        return real(*args, **kw)

    monkeypatch.setattr(quadsim.api, "simulate", warns)
    assert main(["run", "walk.toml", "--seconds", "1", "--out", "w.bvh"]) == 0
    err = _without_notes(capsys.readouterr().err)
    assert err == "quadsim: warning: turn rate clamped\nquadsim: warning: speed clamped\n"


# ------------------------------------------------------------------ metrics
@pytest.fixture
def clip(here):
    assert main(["run", "walk.toml", "--seconds", "2", "--out", "clip.bvh"]) == 0
    return here / "clip.bvh"


def test_metrics_prints_a_table(clip, capsys):
    capsys.readouterr()
    assert main(["metrics", str(clip)]) == 0
    out = capsys.readouterr().out
    assert len(out.strip().splitlines()) >= 2


def test_metrics_json_has_the_four_feet(clip, capsys):
    capsys.readouterr()
    assert main(["metrics", str(clip), "--json", "--start", "0.5"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert {"LF", "RF", "LH", "RH"} <= collect_strings(report)


def test_metrics_missing_file(here, capsys):
    assert_input_error(main(["metrics", "nothere.bvh"]), capsys, "nothere.bvh")


def test_metrics_bad_start(clip, capsys):
    capsys.readouterr()
    assert_input_error(main(["metrics", str(clip), "--start", "-1"]), capsys, "--start")
