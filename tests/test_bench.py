"""The benchmark suite runs and writes its result (``quadsim bench``)."""

import json

from quadsim.cli import main


def test_bench_quick_writes_json(tmp_path, capsys):
    out = tmp_path / "bench.json"
    assert main(["bench", "--quick", "--max-n", "1", "--characters", "leopard",
                 "--out", str(out)]) == 0
    r = json.loads(out.read_text())
    assert r["machine"]["cores"] >= 1 and r["machine"]["numpy"]
    assert r["step"]["leopard"]["pose"]["steps_per_s"] > 0
    assert r["step"]["leopard"]["plan_only"]["steps_per_s"] > 0
    assert r["simulate"]["leopard"]["seconds"] > 0
    assert set(r["many"]["by_n"]) == {"1"} and r["many"]["method"]
    assert r["export"]["bvh"]["bytes"] > 0 and r["export"]["glb"]["bytes"] > 0
    assert r["warm_up"]["compile_s"] > 0 and r["warm_up"]["cached_s"] > 0
    assert "frames per second" in capsys.readouterr().out


def test_bench_rejects_a_bad_size(capsys):
    assert main(["bench", "--max-n", "0"]) == 2
    assert "--max-n" in capsys.readouterr().err


def test_preview_frame_benchmark_times_both_modes_and_a_gait_change():
    """``python -m benchmarks.preview_frame`` drives a real off-screen preview."""
    import math
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the checkout's benchmarks/
    from benchmarks.preview_frame import measure

    for character, mode in (("leopard", None), ("horse", "data")):
        r = measure(character, size="320x240", frames=4, repeats=1, mode=mode)
        for key in ("frame_ms", "p95_ms", "update_ms", "render_ms", "gait_change_max_ms"):
            assert math.isfinite(r[key]) and r[key] > 0, (mode, key, r[key])
        assert r["update_ms"] + r["render_ms"] <= r["frame_ms"] * 1.5 + 1.0


def test_compare_refuses_a_revision_that_names_no_commit(capsys):
    from benchmarks.compare import main

    assert main(["no-such-revision-here", "--rounds", "1"]) == 2
    err = capsys.readouterr().err
    assert "'no-such-revision-here' is not a commit" in err and "Traceback" not in err


def test_compare_stopped_by_sigterm_removes_its_temporary_worktree(tmp_path):
    """`kill` during a side-by-side run leaves no temporary folder and no git worktree."""
    import os
    import signal
    import subprocess
    import sys
    import time
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    env = dict(os.environ, TMPDIR=str(tmp_path), PYTHONPATH=str(root))
    proc = subprocess.Popen([sys.executable, "-m", "benchmarks.compare", "HEAD", "--rounds", "1"],
                            cwd=root, env=env, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60
    while not list(tmp_path.glob("quadsim-compare-*/tree/quadsim")):
        assert proc.poll() is None and time.monotonic() < deadline, proc.stderr.read()
        time.sleep(0.1)
    proc.send_signal(signal.SIGTERM)
    assert proc.wait(timeout=60) == 130
    assert not list(tmp_path.glob("quadsim-compare-*"))
    trees = subprocess.run(["git", "-C", str(root), "worktree", "list"], capture_output=True,
                           text=True, check=True).stdout
    assert str(tmp_path) not in trees
