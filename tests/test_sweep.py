"""`quadsim sweep` end to end: the issue's grid of 24 clips on two workers, measured
manifest lines, resuming after SIGTERM with the same bytes and no leftovers, one worker
and a Dask cluster on loopback giving the same bytes again."""

import filecmp
import json
import os
import signal
import socket
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

from quadsim.dataset import MANIFEST, load_grid, run_sweep
from quadsim.dataset.manifest import Manifest
from quadsim.errors import InputError

REPO = Path(__file__).resolve().parents[1]
GRID = """\
    characters = ["leopard", "dog_cub"]
    gaits = ["walk", "trot", "canter"]
    turn_rates_deg_s = [0, 20]
    seeds = [0, 1]
    seconds = 4
"""
PARAMETERS = ("character", "gait", "speed", "turn_rate_deg_s", "seed", "seconds", "fps")


def env() -> dict:
    e = dict(os.environ)
    e["PYTHONPATH"] = os.pathsep.join([str(REPO), e.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    return e


def sweep(*args, **kw) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "quadsim", "sweep", *map(str, args)],
                            env=env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, **kw)


def finish(p: subprocess.Popen, timeout: float = 300) -> tuple[int, str, str]:
    out, err = p.communicate(timeout=timeout)
    return p.returncode, out, err


def lines(folder: Path) -> list[dict]:
    text = (folder / MANIFEST).read_text(encoding="utf-8")
    return [json.loads(x) for x in text.splitlines()]


def hidden(folder: Path) -> list[str]:
    """Temporary (dot) files anywhere under the folder."""
    return sorted(str(p.relative_to(folder)) for p in folder.rglob(".*"))


def same_tree(a: Path, b: Path) -> bool:
    names = sorted(p.name for p in (a / "clips").iterdir())
    if names != sorted(p.name for p in (b / "clips").iterdir()):
        return False
    _, mismatch, errors = filecmp.cmpfiles(a / "clips", b / "clips", names, shallow=False)
    return not mismatch and not errors and \
        (a / MANIFEST).read_bytes() == (b / MANIFEST).read_bytes()


@pytest.fixture(scope="module")
def grid(tmp_path_factory) -> Path:
    p = tmp_path_factory.mktemp("grid") / "grid.toml"
    p.write_text(textwrap.dedent(GRID), encoding="utf-8")
    return p


@pytest.fixture(scope="module")
def reference(grid, tmp_path_factory) -> Path:
    """The done-when run: `quadsim sweep grid.toml --out DIR --workers 2`."""
    out = tmp_path_factory.mktemp("ref") / "data"
    code, stdout, err = finish(sweep(grid, "--out", out, "--workers", 2))
    assert code == 0, err
    assert "24 clips made" in stdout and "2 local processes" in stdout
    return out


def test_two_workers_make_24_clips_and_24_measured_manifest_lines(reference):
    clips = sorted(p.name for p in (reference / "clips").iterdir())
    assert len(clips) == 24 and all(c.endswith(".npz") for c in clips)
    entries = lines(reference)
    assert len(entries) == 24 and len({e["id"] for e in entries}) == 24
    for e in entries:
        assert all(k in e for k in PARAMETERS)
        assert e["path"] == f"clips/{e['id']}.npz" and (reference / e["path"]).is_file()
        assert e["frames"] == 240 and e["bytes"] == (reference / e["path"]).stat().st_size
        m = e["metrics"]
        for leg in ("LF", "RF", "LH", "RH"):
            assert 0.2 < m["legs"][leg]["duty_factor"] < 0.9
            assert 0.0 <= m["legs"][leg]["phase"] < 1.0
            assert m["legs"][leg]["max_slide_mm"] is not None
        assert m["stride_length"] > 0 and m["stride_frequency"] > 0
        assert abs(m["mean_speed"] - e["speed"]) < 0.35 * e["speed"]
        assert m["max_penetration_mm"] < 5.0
        assert m["appearance"]["stride_over_h"] > 0
    with np.load(reference / entries[0]["path"], allow_pickle=False) as f:
        assert f["positions"].shape[0] == 240
    assert hidden(reference) == []


def test_the_manifest_follows_the_grid_and_its_figures_are_the_clips(reference, grid):
    ids = [c.id for c in load_grid(grid).clips()]
    assert [e["id"] for e in lines(reference)] == ids
    walk = next(e for e in lines(reference) if e["gait"] == "walk")
    trot = next(e for e in lines(reference) if e["gait"] == "trot")
    assert walk["metrics"]["legs"]["LF"]["duty_factor"] > \
        trot["metrics"]["legs"]["LF"]["duty_factor"]


def test_one_worker_in_process_gives_the_same_bytes(reference, grid, tmp_path):
    s = run_sweep(load_grid(grid), tmp_path / "one", workers=1)
    assert (s.made, s.skipped, s.remaining, s.frames) == (24, 0, 0, 24 * 240)
    assert same_tree(reference, tmp_path / "one")


def test_a_second_run_makes_nothing_and_changes_nothing(reference, grid, tmp_path):
    import shutil

    copy = tmp_path / "copy"
    shutil.copytree(reference, copy)
    before = {p.name: p.stat().st_mtime_ns for p in (copy / "clips").iterdir()}
    s = run_sweep(load_grid(grid), copy, workers=2)
    assert (s.made, s.skipped) == (0, 24)
    assert before == {p.name: p.stat().st_mtime_ns for p in (copy / "clips").iterdir()}
    assert same_tree(reference, copy)


def test_sigterm_part_way_then_again_gives_the_same_24_files(reference, grid, tmp_path):
    out = tmp_path / "killed"
    p = sweep(grid, "--out", out, "--workers", 2)
    manifest = out / MANIFEST
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and p.poll() is None:
        if manifest.is_file() and manifest.read_bytes().count(b"\n") >= 1:
            break
        time.sleep(0.002)
    p.send_signal(signal.SIGTERM)
    code, _, err = finish(p)
    n = len(lines(out))
    assert code == 128 + signal.SIGTERM and "stopped by signal" in err, err
    assert 0 < n < 24
    # the files written are exactly the manifest's, nothing unfinished
    assert sorted(p.name for p in (out / "clips").iterdir()) == \
        sorted(Path(e["path"]).name for e in lines(out))
    assert hidden(out) == []
    code, stdout, err = finish(sweep(grid, "--out", out, "--workers", 2))
    assert code == 0, err
    assert f"{24 - n} clips made, {n} already there" in stdout
    assert same_tree(reference, out) and hidden(out) == []


def _children(pid: int) -> list[int]:
    """The worker processes of ``pid`` (its children, multiprocessing's helpers left out)."""
    out = []
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                fields = (d / "stat").read_text().rsplit(")", 1)[1].split()
                command = (d / "cmdline").read_bytes()
            except OSError:
                continue
            if int(fields[1]) == pid and b"resource_tracker" not in command \
                    and b"forkserver" not in command:
                out.append(int(d.name))
    return out


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs Linux's /proc")
def test_a_worker_killed_outright_is_one_message_and_a_rerun_finishes(reference, grid,
                                                                      tmp_path):
    out = tmp_path / "worker-killed"
    p = sweep(grid, "--out", out, "--workers", 2)
    deadline = time.monotonic() + 120
    kids: list[int] = []
    while time.monotonic() < deadline and p.poll() is None and not kids:
        kids = _children(p.pid)
        time.sleep(0.005)
    assert kids, "no worker process seen"
    os.kill(kids[0], signal.SIGKILL)
    code, _, err = finish(p)
    assert code == 2 and "worker process stopped unexpectedly" in err, err
    assert "Traceback" not in err
    code, _, err = finish(sweep(grid, "--out", out, "--workers", 2))
    assert code == 0, err
    assert same_tree(reference, out) and hidden(out) == []


def test_limit_then_the_rest_and_a_torn_line_and_a_leftover(reference, grid, tmp_path):
    out = tmp_path / "limited"
    g = load_grid(grid)
    s = run_sweep(g, out, workers=1, limit=5)
    assert (s.made, s.remaining) == (5, 19) and len(lines(out)) == 5
    with open(out / MANIFEST, "ab") as f:   # a stop in the middle of a line
        f.write(b'{"id": "leopard-trot-')
    (out / "clips" / ".x.npz.123.abcd.tmp").write_bytes(b"half a clip")
    s = run_sweep(g, out, workers=2)
    assert (s.made, s.skipped, s.remaining) == (19, 5, 0)
    assert same_tree(reference, out) and hidden(out) == []


def test_a_clip_whose_file_is_gone_is_made_again(reference, grid, tmp_path):
    import shutil

    copy = tmp_path / "gone"
    shutil.copytree(reference, copy)
    victim = lines(copy)[7]["path"]
    (copy / victim).unlink()
    s = run_sweep(load_grid(grid), copy, workers=1)
    assert (s.made, s.skipped) == (1, 23)
    assert same_tree(reference, copy)


def test_two_sweeps_cannot_write_one_folder_at_once(tmp_path):
    with Manifest(tmp_path / "busy"), pytest.raises(InputError, match="another sweep"):
        Manifest(tmp_path / "busy")
    Manifest(tmp_path / "busy").close()  # free again


def test_the_progress_reaches_the_total(grid, tmp_path):
    seen = []
    run_sweep(load_grid(grid), tmp_path / "p", workers=1, limit=3, progress=seen.append)
    assert seen[0].done == 0 and seen[-1].done == seen[-1].total == 3
    assert seen[-1].eta == 0.0 and seen[-1].rate > 0


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _stop(proc: subprocess.Popen) -> None:
    if proc.poll() is None:
        proc.send_signal(signal.SIGTERM)
        try:
            proc.wait(20)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


@pytest.mark.slow
def test_a_dask_scheduler_and_worker_on_loopback_give_the_same_bytes(reference, grid,
                                                                    tmp_path):
    pytest.importorskip("distributed", reason="Dask is the optional extra quadsim[dask]")
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    logs = tmp_path / "logs"
    logs.mkdir()
    procs = []
    with open(logs / "scheduler.log", "w") as slog, open(logs / "worker.log", "w") as wlog:
        try:
            procs.append(subprocess.Popen(
                [sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1",
                 "--port", str(port), "--no-dashboard"], env=env(), cwd=tmp_path,
                stdout=slog, stderr=subprocess.STDOUT))
            procs.append(subprocess.Popen(
                [sys.executable, "-m", "distributed.cli.dask_worker", address, "--nthreads",
                 "1", "--nworkers", "2", "--no-dashboard", "--local-directory",
                 str(tmp_path / "w")], env=env(), cwd=tmp_path, stdout=wlog,
                stderr=subprocess.STDOUT))
            from distributed import Client

            with Client(address, timeout="60s") as c:
                c.wait_for_workers(2, timeout=120)
            code, stdout, err = finish(sweep(grid, "--out", tmp_path / "dask", "--scheduler",
                                             address))
            assert code == 0, err
            assert "24 clips made" in stdout and "Dask" in stdout
            assert same_tree(reference, tmp_path / "dask")
            assert hidden(tmp_path / "dask") == []
        finally:
            for p in reversed(procs):
                _stop(p)


def test_an_unreachable_scheduler_is_an_input_error(grid, tmp_path, monkeypatch):
    pytest.importorskip("distributed", reason="Dask is the optional extra quadsim[dask]")
    from quadsim.dataset import sweep as module

    monkeypatch.setattr(module, "CONNECT_TIMEOUT", 1.0)
    with pytest.raises(InputError, match="--scheduler"):
        run_sweep(load_grid(grid), tmp_path / "x", scheduler=f"tcp://127.0.0.1:{_free_port()}",
                  limit=1)
    assert not (tmp_path / "x").exists()


def test_without_dask_the_scheduler_flag_says_how_to_install_it(grid, tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "distributed", None)
    with pytest.raises(InputError, match=r"--scheduler.*needs distributed: "
                                         r"pip install 'quadsim\[dask\]'"):
        run_sweep(load_grid(grid), tmp_path / "x", scheduler="tcp://127.0.0.1:1", limit=1)
    assert not (tmp_path / "x").exists()
