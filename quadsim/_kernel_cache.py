"""One version key over all the compiled kernels' sources, for numba's cache.

numba keeps a cached kernel while the source file of the *top-level*
function is unchanged, but a kernel holds the machine code of every inner
kernel it calls, from other files: after editing an inner kernel's file
(``footpath.py``, ``ik.py``, ...) an editable install would keep running the
old code. :func:`install` (run by ``import quadsim``, before any kernel is
defined) makes every quadsim kernel's cache entry also depend on
:func:`sources_key`, a hash of every quadsim source file that defines
compiled code and of the quadsim modules those files import (whose
constants the kernels freeze): a change to any of them invalidates every
cached kernel, which numba then recompiles and overwrites once.

The cache is still where numba puts it (``__pycache__`` beside the sources,
numba's user cache, or ``NUMBA_CACHE_DIR``); ``NUMBA_CACHE_LOCATOR_CLASSES``
still replaces the locators, this key with them.
"""

from __future__ import annotations

import functools
import hashlib
import re
from pathlib import Path

PACKAGE = Path(__file__).resolve().parent

#: A source file defines compiled code if it decorates a function with
#: numba's ``njit`` or quadsim's ``inner`` / ``_inner`` decorators.
_KERNEL = re.compile(r"^\s*@(njit|inner|_inner)\b", re.MULTILINE)
_IMPORT = re.compile(r"^\s*(?:from|import)\s+(quadsim(?:\.\w+)*)", re.MULTILINE)


def _module_file(root: Path, module: str) -> Path | None:
    """The file of ``quadsim.x.y`` under ``root`` (the package folder), if any."""
    parts = module.split(".")[1:]
    for path in (root.joinpath(*parts).with_suffix(".py"), root.joinpath(*parts, "__init__.py")):
        if path.is_file():
            return path
    return None


def kernel_sources(root: Path = PACKAGE) -> list[Path]:
    """The source files :func:`sources_key` hashes: those under ``root`` (the
    package folder) that define compiled code, and the quadsim modules they
    import, sorted."""
    kernels = {p for p in root.rglob("*.py") if _KERNEL.search(p.read_text(encoding="utf-8"))}
    found = set(kernels)
    for p in kernels:
        for module in _IMPORT.findall(p.read_text(encoding="utf-8")):
            f = _module_file(root, module)
            if f is not None:
                found.add(f)
    return sorted(found)


@functools.lru_cache(maxsize=None)
def sources_key(root: Path = PACKAGE) -> str:
    """SHA-256 (hex) over the paths (relative to ``root``) and bytes of
    :func:`kernel_sources`; read once a process."""
    h = hashlib.sha256()
    for p in kernel_sources(root):
        h.update(p.relative_to(root).as_posix().encode())
        h.update(b"\0")
        h.update(p.read_bytes())
        h.update(b"\0")
    return h.hexdigest()


def _keyed_locator_class():
    from numba.core.caching import _CacheLocator

    class KernelSourcesLocator(_CacheLocator):
        """numba's own locator for a quadsim kernel, its stamp extended by
        :func:`sources_key`."""

        def __init__(self, base):
            self._base = base

        def __getattr__(self, name):  # what numba reads of its own locators (``_py_file``)
            return getattr(self.__dict__["_base"], name)

        def ensure_cache_path(self):
            self._base.ensure_cache_path()

        def get_cache_path(self):
            return self._base.get_cache_path()

        def get_source_stamp(self):
            return (self._base.get_source_stamp(), "quadsim-kernels", sources_key())

        def get_disambiguator(self):
            return self._base.get_disambiguator()

        @classmethod
        def from_function(cls, py_func, py_file):
            try:
                Path(py_file).resolve().relative_to(PACKAGE)
            except (ValueError, OSError):
                return None  # not quadsim's: numba's own locators as usual
            for other in _locator_list():
                if other is not cls:
                    base = other.from_function(py_func, py_file)
                    if base is not None:
                        return cls(base)
            return None

    return KernelSourcesLocator


def _locator_list() -> list:
    from numba.core import caching

    impl = getattr(caching, "CacheImpl", None) or caching._CacheImpl  # renamed in numba 0.61
    return impl._locator_classes


def install() -> bool:
    """Put the keyed locator first in numba's list (once); False if this numba
    has no such list (its caching then works as numba's own)."""
    try:
        classes = _locator_list()
    except (ImportError, AttributeError):
        return False
    if not any(getattr(c, "__name__", "") == "KernelSourcesLocator" for c in classes):
        classes.insert(0, _keyed_locator_class())
    return True
