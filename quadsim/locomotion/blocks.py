"""Calling the compiled kernels: rows in blocks on threads, fixed entry points.

:func:`run_blocks` runs rows in blocks on threads (the kernels release the GIL).

A step over many rows (characters or frames) is split into one block of
rows per thread, each block run by the same serial compiled kernel
(compiled with ``nogil=True``) on a thread of a shared pool. Rows are
independent, so the result is the one of a single call whatever the number
of threads; no threaded (``parallel=True``) variant of a kernel is compiled.
The number of threads is numba's (:func:`numba.get_num_threads`, set with
``NUMBA_NUM_THREADS`` or :func:`numba.set_num_threads`).

:class:`FixedEntry` calls a kernel's compiled entry point directly, for
arguments whose types never change: finding the types of a call of bundles
of some thirty arrays (numba's dispatch) costs more than a one-row step.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

from numba import get_num_threads

_POOL: ThreadPoolExecutor | None = None


def _pool() -> ThreadPoolExecutor:
    global _POOL
    if _POOL is None:
        _POOL = ThreadPoolExecutor(max_workers=max(get_num_threads(), 1),
                                   thread_name_prefix="quadsim-rows")
    return _POOL


def run_blocks(task, n: int) -> None:
    """``task(a, e)`` for blocks ``a:e`` covering rows ``0:n``, one a thread."""
    blocks = min(max(get_num_threads(), 1), max(n, 1))
    if blocks <= 1:
        task(0, n)
        return
    size = -(-n // blocks)
    futures = [_pool().submit(task, a, min(n, a + size)) for a in range(0, n, size)]
    for f in futures:
        f.result()


class FixedEntry:
    """``kernel(*args)`` for arguments of types that never change.

    The first call goes through numba's dispatcher (compiling or loading the
    kernel) and notes the argument types; later calls go straight to the
    compiled entry point. The caller's promise: the same types every call
    (same dtypes, dimensions, layouts, writeability and bundle classes).
    ``before_first``, if given, is called (without arguments) before the
    first call only.
    """

    def __init__(self, kernel, before_first=None):
        self.kernel = kernel
        self._entry = None
        self._before_first = before_first

    def __deepcopy__(self, memo):  # shareable: it holds no state of its caller
        return self

    def __call__(self, *args):
        entry = self._entry
        if entry is not None:
            return entry(*args)
        from numba import typeof

        if self._before_first is not None:
            self._before_first()
        out = self.kernel(*args)
        self._entry = self.kernel.overloads[tuple(typeof(a) for a in args)].entry_point
        return out
