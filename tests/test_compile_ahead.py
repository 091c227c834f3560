"""Compiling on an empty cache: the plan compiled in a second process, and
cached kernels keyed by every kernel source.

The second process (:mod:`quadsim.locomotion.precompile`) must never change
a run: it starts only when the plan is not cached, a failing or hanging one
neither fails nor hangs the run, it writes nothing, and it does not outlive
the run. The key (:mod:`quadsim._kernel_cache`) makes an edit of an inner
kernel's file invalidate the cached kernels that hold its code.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

from quadsim import _kernel_cache
from quadsim.locomotion import precompile
from quadsim.locomotion.plan_kernels import plan_rows

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture
def no_child(monkeypatch):
    """No second process before or after the test; the disable switch unset."""
    precompile.stop()
    monkeypatch.delenv(precompile.DISABLE_ENV, raising=False)
    yield
    precompile.stop()


class _Poser:
    """Counts the posings asked for while the plan compiles."""

    def __init__(self):
        self.posed = 0

    def pose_packed(self, rows):
        self.posed += 1


def test_no_second_process_when_the_plan_is_cached(no_child, monkeypatch):
    monkeypatch.setattr(precompile, "is_cached", lambda kernel: True)
    assert precompile.start() is False
    assert precompile._child is None
    precompile.while_plan_compiles(_Poser(), 10)  # returns at once


def test_no_second_process_when_disabled(no_child, monkeypatch):
    monkeypatch.setattr(precompile, "is_cached", lambda kernel: False)
    monkeypatch.setenv(precompile.DISABLE_ENV, "1")
    assert precompile.start() is False


def test_a_failing_second_process_neither_fails_nor_delays_the_run(no_child, monkeypatch,
                                                                    capfd):
    monkeypatch.setattr(precompile, "is_cached", lambda kernel: False)
    monkeypatch.setattr(precompile, "CHILD_ARGS",
                        ("-c", "import sys; print('noise'); sys.exit(3)"))
    assert precompile.start() is True
    child = precompile._child
    t0 = time.monotonic()
    precompile.while_plan_compiles(_Poser(), 10)
    precompile.wait()
    assert time.monotonic() - t0 < 10
    assert child.wait(timeout=10) == 3
    out, err = capfd.readouterr()
    assert "noise" not in out + err  # the second process writes nothing


def test_a_hanging_second_process_is_waited_for_at_most_the_limit_and_stopped(
        no_child, monkeypatch):
    monkeypatch.setattr(precompile, "is_cached", lambda kernel: False)
    monkeypatch.setattr(precompile, "CHILD_ARGS", ("-c", "import time; time.sleep(120)"))
    assert precompile.start() is True
    child = precompile._child
    assert precompile.compiling()
    t0 = time.monotonic()
    precompile.wait(limit=0.3)
    assert 0.25 < time.monotonic() - t0 < 5
    precompile.stop()  # what the run's exit does
    assert child.poll() is not None
    assert precompile._child is None


def test_the_cached_check_reads_numbas_index():
    # the kernel is (or is not) cached; either way the check answers without error
    assert precompile.is_cached(plan_rows) in (True, False)
    assert precompile.is_cached(object()) is True  # cannot tell: start nothing


@pytest.mark.slow
def test_the_second_process_caches_the_plan_a_run_then_loads(tmp_path):
    """The plan compiled by the second process has the very types of another
    character's controller: that process compiles no plan of its own."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"), PYTHONPATH=str(ROOT))
    env.pop(precompile.DISABLE_ENV, None)
    subprocess.run([sys.executable, *precompile.CHILD_ARGS], env=env, check=True,
                   cwd=tmp_path, timeout=600)
    probe = (
        "from numba.core import event\n"
        "names = []\n"
        "class L(event.Listener):\n"
        "    def on_start(self, e): names.append(e.data['dispatcher'].py_func.__name__)\n"
        "    def on_end(self, e): pass\n"
        "event.register('numba:compile', L())\n"
        "from quadsim.commands import Command\n"
        "from quadsim.locomotion.controller import ProceduralController\n"
        "from quadsim.skeleton import load_character\n"
        "ProceduralController(load_character('dog_cub'))._plan(Command(speed=2.0), None)\n"
        "print('plan_rows' in names)\n")
    out = subprocess.run([sys.executable, "-c", probe], env=env, check=True, cwd=tmp_path,
                         capture_output=True, text=True, timeout=600).stdout
    assert out.strip() == "False"


# ------------------------------------------------------------ the version key
def test_every_quadsim_kernel_is_keyed_by_all_kernel_sources():
    assert _kernel_cache.install() is True
    locator = plan_rows._cache._impl.locator
    assert type(locator).__name__ == "KernelSourcesLocator"
    assert locator.get_source_stamp()[-1] == _kernel_cache.sources_key()
    names = {p.relative_to(_kernel_cache.PACKAGE).as_posix()
             for p in _kernel_cache.kernel_sources()}
    # inner kernels' files, and the constants they freeze
    assert {"locomotion/footpath.py", "locomotion/body.py", "locomotion/feet.py",
            "kinematics/ik.py", "frames.py"} <= names
    assert "cli.py" not in names and "api.py" not in names


def test_the_key_changes_with_an_inner_kernel_file(tmp_path):
    pkg = tmp_path / "quadsim"
    shutil.copytree(_kernel_cache.PACKAGE, pkg, ignore=shutil.ignore_patterns("__pycache__"))
    before = _kernel_cache.sources_key(pkg)
    assert before == _kernel_cache.sources_key(_kernel_cache.PACKAGE)
    with open(pkg / "locomotion" / "footpath.py", "a", encoding="utf-8") as f:
        f.write("\n# edited\n")
    edited = _kernel_cache.sources_key.__wrapped__(pkg)
    assert edited != before
    (pkg / "cli.py").write_text("# not a kernel source\n", encoding="utf-8")
    assert _kernel_cache.sources_key.__wrapped__(pkg) == edited


def test_editing_another_kernel_file_recompiles_a_cached_kernel(tmp_path):
    """End to end, on a copy of the package: a cached kernel is loaded, and
    compiled again once a kernel file other than its own changes."""
    shutil.copytree(_kernel_cache.PACKAGE, tmp_path / "quadsim",
                    ignore=shutil.ignore_patterns("__pycache__"))
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"),
               PYTHONPATH=str(tmp_path))
    probe = (
        "import numpy as np\n"
        "from quadsim.kinematics.rotations import _quaternions_rows, quaternions_from_matrices\n"
        "quaternions_from_matrices(np.eye(3)[None])\n"
        "print(sum(_quaternions_rows._cache_misses.values()))\n")

    def misses():
        return subprocess.run([sys.executable, "-c", probe], env=env, check=True,
                              cwd=tmp_path, capture_output=True, text=True,
                              timeout=300).stdout.strip()

    assert misses() == "1"   # compiled
    assert misses() == "0"   # loaded
    with open(tmp_path / "quadsim" / "locomotion" / "footpath.py", "a",
              encoding="utf-8") as f:
        f.write("\n# edited\n")
    assert misses() == "1"   # compiled again
