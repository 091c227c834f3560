"""quadsim as an installable package.

- The shipped characters, gait tables and clip database are package data,
  found through :mod:`importlib.resources`.
- The core (loading characters, both locomotion modes, writing BVH and GLB)
  runs with numpy, numba and pygltflib alone; the viz and test packages are extras, and
  a command that needs a missing extra says which one to install.
- A wheel built from the repository, installed into a fresh virtual
  environment and run from another folder, lists the four characters and
  writes motions; numba caches its compiled kernels beside the installed
  sources, so the second run compiles nothing.
"""

from __future__ import annotations

import importlib.util
import json
import os
import shutil
import subprocess
import sys
import sysconfig
import textwrap
from pathlib import Path

import pytest

from quadsim._optional import NEEDS, require, require_for
from quadsim.errors import InputError
from quadsim.skeleton.character import characters_dir

REPO = Path(__file__).resolve().parents[1]
FOUR = ("dog_cub", "horse", "leopard", "leopard_cub")
#: Packages the core must not need: the viz extra and the test-only ones.
NOT_CORE = ("pyvista", "vtk", "vtkmodules", "matplotlib", "imageio", "imageio_ffmpeg",
            "scipy", "transforms3d", "PIL", "skimage")


# ------------------------------------------------------------ package data
def test_shipped_data_lives_inside_the_package():
    import quadsim

    folder = characters_dir()
    assert folder.is_dir()
    assert folder.is_relative_to(Path(quadsim.__file__).parent)
    for name in FOUR:
        assert (folder / f"{name}.toml").is_file(), name
    assert (folder / "gaits.toml").is_file()
    assert (folder / "horse" / "clips" / "manifest.toml").is_file()


def test_every_data_file_is_declared_package_data():
    """Each file under quadsim/data matches a package-data pattern of pyproject.toml,
    so a wheel cannot silently drop one."""
    import tomllib

    cfg = tomllib.loads((REPO / "pyproject.toml").read_text(encoding="utf-8"))
    patterns = cfg["tool"]["setuptools"]["package-data"]["quadsim.data"]
    data = REPO / "quadsim" / "data"
    files = [p.relative_to(data) for p in data.rglob("*")
             if p.is_file() and "__pycache__" not in p.parts and p.name != "__init__.py"]
    assert len(files) >= 18  # 4 characters, gaits.toml, the horse manifest and 12 clips
    unmatched = [str(f) for f in files if not any(f.match(pat) for pat in patterns)]
    assert not unmatched, f"not package data in pyproject.toml: {unmatched}"


def test_core_dependencies_are_numpy_numba_and_pygltflib_only():
    import tomllib

    cfg = tomllib.loads((REPO / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    names = {d.split(">")[0].split("=")[0].split("[")[0].strip() for d in cfg["dependencies"]}
    assert names == {"numpy", "numba", "pygltflib"}  # pygltflib: a user's own glTF rig
    extras = cfg["optional-dependencies"]
    assert {"pyvista", "matplotlib", "imageio", "imageio-ffmpeg"} <= {
        d.split(">")[0].strip() for d in extras["viz"]}
    assert "quadsim[viz]" in extras["test"]


# ----------------------------------------------------------- optional parts
def test_require_returns_the_module():
    import json as json_module

    assert require("json", "`quadsim anything`") is json_module


@pytest.mark.parametrize("command", sorted(NEEDS))
def test_a_command_without_its_extra_names_the_extra(monkeypatch, command):
    missing = NEEDS[command][-1]
    monkeypatch.setitem(sys.modules, missing, None)  # makes `import missing` fail
    pip_name = missing.replace("_", "-")
    with pytest.raises(InputError, match=rf"`quadsim {command}` needs {pip_name}: "
                                         r"pip install 'quadsim\[viz\]'"):
        require_for(command)


def test_an_mp4_without_ffmpeg_names_imageio_ffmpeg(monkeypatch):
    monkeypatch.setitem(sys.modules, "imageio_ffmpeg", None)
    with pytest.raises(InputError, match=r"`quadsim render` to \.mp4 needs imageio-ffmpeg: "
                                         r"pip install 'quadsim\[viz\]'"):
        require("imageio_ffmpeg", "`quadsim render` to .mp4")


def test_a_missing_dotted_module_names_its_package(monkeypatch):
    monkeypatch.setitem(sys.modules, "matplotlib", None)
    monkeypatch.setitem(sys.modules, "matplotlib.figure", None)
    with pytest.raises(InputError, match=r"`quadsim diagram` needs matplotlib: "):
        require("matplotlib.figure", "`quadsim diagram`")


def test_an_installed_module_with_a_broken_dependency_keeps_its_own_error(tmp_path,
                                                                          monkeypatch):
    """Reinstalling the extra would not help, so the real error is not hidden."""
    (tmp_path / "needs_ghost.py").write_text("import quadsim_no_such_module_x\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    with pytest.raises(ModuleNotFoundError, match="quadsim_no_such_module_x"):
        require("needs_ghost", "`quadsim render`")


BLOCK = """\
import importlib.abc, sys
BLOCKED = {blocked!r}
class Block(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in BLOCKED:
            raise ModuleNotFoundError(f"No module named {{name!r}}", name=name)
        return None
sys.meta_path.insert(0, Block())
"""


def test_the_core_runs_without_the_viz_and_test_packages(tmp_path):
    """With pyvista, matplotlib, imageio, scipy and transforms3d unimportable, a
    procedural BVH run, a data-mode GLB run, `characters` and `validate` work."""
    script = BLOCK.format(blocked=NOT_CORE) + textwrap.dedent(f"""\
        from quadsim.cli import main
        from quadsim._optional import require_for
        from quadsim.errors import InputError
        cfg = {str(REPO / "configs" / "horse_data.toml")!r}
        assert main(["characters"]) == 0
        assert main(["validate", cfg]) == 0
        assert main(["run", {str(REPO / "configs" / "leopard.toml")!r}, "--seconds", "1",
                     "--out", "l.bvh"]) == 0
        assert main(["run", cfg, "--seconds", "1", "--out", "h.glb"]) == 0
        try:
            require_for("diagram")
        except InputError as e:
            print("MESSAGE", e)
        loaded = sorted(m for m in sys.modules if m.split(".")[0] in BLOCKED)
        print("LOADED", loaded)
        """)
    env = {k: v for k, v in os.environ.items() if k != "MPLBACKEND"}
    env["PYTHONPATH"] = str(REPO)
    out = subprocess.run([sys.executable, "-c", script], cwd=tmp_path, env=env,
                         capture_output=True, text=True, timeout=600, check=False)
    assert out.returncode == 0, out.stderr[-3000:]
    assert "LOADED []" in out.stdout
    assert "MESSAGE `quadsim diagram` needs matplotlib: pip install 'quadsim[viz]'" in out.stdout
    assert (tmp_path / "l.bvh").stat().st_size > 0
    assert (tmp_path / "h.glb").read_bytes()[:4] == b"glTF"


# -------------------------------------------------------------- the wheel
def _can_build_offline() -> bool:
    """setuptools >= 68 and wheel importable here: build without fetching them."""
    if importlib.util.find_spec("wheel") is None:
        return False
    try:
        import setuptools
    except ImportError:
        return False
    return int(setuptools.__version__.split(".")[0]) >= 68


def _run(cmd, cwd, env, timeout=300):
    out = subprocess.run([str(c) for c in cmd], cwd=cwd, env=env, capture_output=True,
                         text=True, timeout=timeout, check=False)
    assert out.returncode == 0, f"{cmd} failed:\n{out.stdout[-2000:]}\n{out.stderr[-3000:]}"
    return out


class Installed:
    """A wheel of this repository installed into a fresh virtual environment.

    quadsim comes only from the wheel; its dependencies (numpy, numba, ...)
    from this interpreter's site-packages, through a ``.pth`` file, so nothing
    is downloaded.
    """

    def __init__(self, root: Path):
        src, dist, self.venv, self.elsewhere = (root / n for n in
                                                ("src", "dist", "venv", "elsewhere"))
        keep = shutil.ignore_patterns("__pycache__", "*.pyc", "*.nbi", "*.nbc")
        shutil.copytree(REPO / "quadsim", src / "quadsim", ignore=keep)
        for name in ("pyproject.toml", "README.md"):
            shutil.copy(REPO / name, src / name)
        env = {k: v for k, v in os.environ.items()
               if k not in ("PYTHONPATH", "NUMBA_CACHE_DIR", "PIP_REQUIRE_VIRTUALENV")}
        pip = [sys.executable, "-m", "pip", "--disable-pip-version-check"]
        isolation = ["--no-build-isolation"] if _can_build_offline() else []
        _run(pip + ["wheel", "--no-deps", *isolation, "-w", dist, src], root, env)
        wheels = list(dist.glob("quadsim-*.whl"))
        assert len(wheels) == 1, wheels
        self.wheel = wheels[0]
        _run([sys.executable, "-m", "venv", "--without-pip", self.venv], root, env)
        self.python = self.venv / "bin" / "python"
        _run(pip + ["--python", self.python, "install", "--no-deps", "--no-index",
                    self.wheel], root, env)
        code = "import sysconfig; print(sysconfig.get_paths()['purelib'])"
        site = Path(_run([self.python, "-c", code], root, env).stdout.strip())
        parent = {sysconfig.get_paths()["purelib"], sysconfig.get_paths()["platlib"]}
        (site / "_quadsim_test_dependencies.pth").write_text("\n".join(sorted(parent)) + "\n")
        self.package = site / "quadsim"
        self.elsewhere.mkdir()
        self.env = env

    def run(self, *args, timeout=300, **extra_env):
        env = dict(self.env, **extra_env)
        return _run(list(args), self.elsewhere, env, timeout)

    def quadsim(self, *args, **kw):
        return self.run(self.venv / "bin" / "quadsim", *args, **kw)


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    return Installed(tmp_path_factory.mktemp("wheel"))


@pytest.mark.slow
def test_the_wheel_holds_the_data_and_quadsim_comes_from_it(installed):
    import zipfile

    names = zipfile.ZipFile(installed.wheel).namelist()
    for name in FOUR:
        assert f"quadsim/data/characters/{name}.toml" in names
    assert "quadsim/data/characters/gaits.toml" in names
    assert "quadsim/data/characters/horse/clips/manifest.toml" in names
    assert sum(n.startswith("quadsim/data/characters/horse/clips/") and n.endswith(".bvh")
               for n in names) == 12
    where = installed.run(installed.python, "-c", "import json, quadsim; from quadsim."
                          "skeleton.character import characters_dir; print(json.dumps("
                          "[quadsim.__file__, str(characters_dir())]))").stdout
    module, data = map(Path, json.loads(where))
    assert module.is_relative_to(installed.package)
    assert data == installed.package / "data" / "characters"


@pytest.mark.slow
def test_characters_from_another_folder_lists_the_four(installed):
    for out in (installed.run(installed.python, "-m", "quadsim", "characters"),
                installed.quadsim("characters")):
        ids = [line.split()[0] for line in out.stdout.splitlines()
               if line and not line.startswith(" ")][1:]
        assert ids == list(FOUR), out.stdout


@pytest.mark.slow
def test_a_run_from_the_wheel_compiles_once_into_site_packages(installed):
    """The first run saves numba's cache beside the installed sources; a second
    run loads it and compiles nothing."""
    cfg = installed.elsewhere / "trot.toml"
    cfg.write_text('character = "leopard"\nduration = 1.0\nfps = 30\n\n'
                   '[[command]]\nat = 0.0\ngait = "trot"\n', encoding="utf-8")
    first = installed.quadsim("run", cfg, "--out", "t.bvh", timeout=600, NUMBA_DEBUG_CACHE="1")
    assert f"data saved to '{installed.package}" in first.stdout + first.stderr
    cached = sorted(installed.package.rglob("__pycache__/*.nbi"))
    assert cached, "numba wrote no cache index beside the installed sources"
    second = installed.quadsim("run", cfg, "--out", "t.bvh", NUMBA_DEBUG_CACHE="1")
    log = second.stdout + second.stderr
    assert "data loaded from" in log
    assert "data saved to" not in log, "the second run compiled again"
    assert (installed.elsewhere / "t.bvh").read_text().startswith("HIERARCHY")


@pytest.mark.slow
def test_run_leopard_by_character_id_from_the_wheel(installed):
    installed.quadsim("run", "leopard", "--gait", "trot", "--seconds", "3", "--out", "l.bvh",
                      timeout=600)
    text = (installed.elsewhere / "l.bvh").read_text()
    assert text.startswith("HIERARCHY") and "MOTION" in text


@pytest.mark.slow
def test_run_horse_data_mode_by_character_id_from_the_wheel(installed):
    installed.quadsim("run", "horse", "--mode", "data", "--speed", "4", "--seconds", "3",
                      "--out", "h.glb", timeout=600)
    glb = (installed.elsewhere / "h.glb").read_bytes()
    assert glb[:4] == b"glTF" and len(glb) > 1000
